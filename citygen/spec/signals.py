"""Signalised junctions: which approach lanes and crosswalks each phase of a traffic light serves.

A :class:`Signal` belongs to one junction block (``junction``, a block id), or to the
``straight`` block a signalised mid-block crossing crosses (its approach lanes ``in:<k>`` and,
both ways, ``out:<k>``; a real place's), or to the crosswalk zone of a pedestrian signal on
no street (a real place's footway crossing tram tracks, which no scene draws: ``junction``
names that zone, served by a phase, and no phase names a lane). Its phases run in
order, each for ``green``, then ``amber``, then ``red`` seconds (the all-red clearance before
the next phase); ``cycle`` is their sum and ``offset`` shifts the whole plan in time (phase 0
turns green at ``t = offset`` and every ``cycle`` seconds after). A lane not served by the
phase in force faces red; a crosswalk shows *walk* only during the green of a phase serving it.

An approach lane is named ``"<socket>:<k>"``: the junction block's socket the road comes in
by and the lane, ``0`` the rightmost of those driving into the junction. Crosswalks are named
by the ids of their ``crosswalk`` zones (a crosswalk cut into several zones is named by all).
``heads`` are where the lights stand (one per approach), for exporters and for the
``traffic_light`` placements that stand there; traffic stops before the crosswalks of its
approach and not past the light facing it, whichever is further out (a real place's light
stands where its map puts the signal).

>>> s = Signal(id="signal-b0", junction="b0", phases=[
...     {"id": "ew", "lanes": ["in:0", "out:0"], "crosswalks": ["zone-7"], "green": 20},
...     {"id": "ns", "lanes": ["left:0", "right:0"], "green": 15}], cycle=45)
>>> s.phases[0].amber, s.phases[0].red, sum(p.green + p.amber + p.red for p in s.phases)
(3.0, 2.0, 45.0)
"""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, Strict

from citygen.spec.base import Identifier, SpecModel, Vec2, Yaw, bounded_float

MAX_PHASES = 8
MAX_REFS = 64

LaneRef = Annotated[
    str,
    Strict(),
    Field(
        max_length=64,
        pattern=r"^[A-Za-z0-9_][A-Za-z0-9_.-]*:[0-9]$",
        description="An approach lane '<socket>:<k>': the junction's socket and the lane (0 rightmost).",
    ),
]
Seconds = bounded_float(0.0, 600.0)


class Phase(SpecModel):
    """One phase of a signal plan: who may go, and for how long."""

    id: Identifier
    lanes: tuple[LaneRef, ...] = Field(default=(), max_length=MAX_REFS)
    """Approach lanes that get green (``"<socket>:<k>"``)."""
    crosswalks: tuple[Identifier, ...] = Field(default=(), max_length=MAX_REFS)
    """Ids of the crosswalk zones that show *walk* during the green."""
    green: bounded_float(1.0, 600.0)
    """Green time, in seconds."""
    amber: Seconds = 3.0
    """Amber time after the green, in seconds."""
    red: Seconds = 2.0
    """All-red clearance after the amber, in seconds."""


class Head(SpecModel):
    """Where one traffic light stands."""

    position: Vec2
    """``[x, y]`` of the pole's foot, in metres."""
    yaw: Yaw = 0.0
    """Heading the light faces (towards the traffic it signals), in radians."""


class Signal(SpecModel):
    """The traffic lights of one junction and their plan."""

    id: Identifier
    junction: Identifier
    """The junction's block id (a straight's, for a mid-block crossing; a crosswalk zone's,
    for a pedestrian signal on no street)."""
    phases: tuple[Phase, ...] = Field(min_length=1, max_length=MAX_PHASES)
    cycle: bounded_float(1.0, 3600.0)
    """Length of the plan, in seconds: the sum of the phases' green, amber and red."""
    offset: Seconds = 0.0
    """When phase 0 turns green, in seconds from the start of the simulation."""
    heads: tuple[Head, ...] = Field(default=(), max_length=MAX_REFS)
    """Where the lights stand."""
