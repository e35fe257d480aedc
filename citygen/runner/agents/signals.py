"""Signals in time, and people who wait for *walk*.

:class:`SignalPlan` turns a scene's :class:`~citygen.spec.signals.Signal` plans into the
state of each approach lane (``green``, ``amber``, ``red``) and crosswalk (*walk* or not) at a
time ``t`` (s) since the simulation started. :class:`Crossings` says what ground a point is on
(a crosswalk, the roadway). :class:`SignalCrowd` wraps a :class:`~citygen.runner.agents.crowd.Crowd`
(its public API only): a person about to step onto a signalised crosswalk that does not show
*walk* stands still at its edge; people already on it when the signal changes walk on.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.spec.scene import Scene


class SignalPlan:
    """The states of a scene's signals in time.

    >>> from citygen.spec.signals import Signal
    >>> plan = SignalPlan([Signal(id="s", junction="b0", cycle=40, offset=5, phases=[
    ...     {"id": "a", "lanes": ["in:0"], "crosswalks": ["c1"], "green": 15},
    ...     {"id": "b", "lanes": ["left:0"], "crosswalks": ["c2"], "green": 15}])])
    >>> [plan.lane("b0", "in:0", t) for t in (0.0, 5.0, 19.0, 21.0, 25.0)]
    ['red', 'green', 'green', 'amber', 'red']
    >>> plan.walk("c1", 10.0), plan.walk("c2", 10.0), plan.walk("nowhere", 10.0)
    (True, False, None)
    """

    def __init__(self, signals) -> None:
        self.signals = list(signals or ())
        self._lanes: dict[tuple[str, str], list[tuple[int, int]]] = {}
        self._walks: dict[str, list[tuple[int, int]]] = {}
        self.junctions = {s.junction for s in self.signals}
        for i, s in enumerate(self.signals):
            for k, phase in enumerate(s.phases):
                for lane in phase.lanes:
                    self._lanes.setdefault((s.junction, lane), []).append((i, k))
                for c in phase.crosswalks:
                    self._walks.setdefault(c, []).append((i, k))

    def phase(self, i: int, t: float) -> tuple[int, str]:
        """The phase of signal ``i`` in force at ``t`` (s) and its state."""
        s = self.signals[i]
        u = (t - s.offset) % s.cycle
        for k, p in enumerate(s.phases):
            if u < p.green:
                return k, "green"
            if u < p.green + p.amber:
                return k, "amber"
            if u < p.green + p.amber + p.red:
                return k, "red"
            u -= p.green + p.amber + p.red
        return len(s.phases) - 1, "red"

    def lane(self, junction: str, lane: str, t: float) -> str | None:
        """``green``, ``amber`` or ``red`` for an approach lane ``"<socket>:<k>"`` of a
        junction at ``t``; None where the junction has no signal."""
        if junction not in self.junctions:
            return None
        for i, k in self._lanes.get((junction, lane), ()):
            now, state = self.phase(i, t)
            if now == k and state != "red":
                return state
        return "red"

    def walk(self, crosswalk: str, t: float) -> bool | None:
        """Whether a crosswalk zone shows *walk* at ``t``; None where no signal serves it."""
        served = self._walks.get(crosswalk)
        if not served:
            return None
        return any(self.phase(i, t) == (k, "green") for i, k in served)


@dataclass
class Crossings:
    """The scene's crosswalk and roadway zones, to ask what ground a point is on."""

    scene: Scene
    walk_ids: list[str] = field(init=False)
    drives: list | None = None
    """The vehicles' drive paths (:func:`citygen.runner.agents.lanes.drive_path`), once built."""

    def __post_init__(self) -> None:
        self.plan = SignalPlan(self.scene.signals)
        walks = [z for z in self.scene.zones if z.kind == "crosswalk"]
        self.walk_ids = [z.id for z in walks]
        self._walks = shapely.STRtree([Polygon(z.polygon, z.holes) for z in walks])
        roads = [Polygon(z.polygon, z.holes) for z in self.scene.zones if z.kind == "roadway"]
        self._roads = shapely.STRtree(roads)
        self._signalled = np.array([self.plan.walk(c, 0.0) is not None for c in self.walk_ids], dtype=bool)

    def crosswalk_at(self, xy: np.ndarray) -> np.ndarray:
        """Index (into :attr:`walk_ids`) of the crosswalk under each point ``(N, 2)``, -1 off them."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        out = np.full(len(xy), -1, dtype=np.int64)
        if len(xy) and len(self.walk_ids):
            pts, hits = self._walks.query(shapely.points(xy), predicate="within")
            out[pts] = hits
        return out

    def on_roadway(self, xy: np.ndarray) -> np.ndarray:
        """Whether each point ``(N, 2)`` is on a roadway zone (not a crosswalk)."""
        xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        out = np.zeros(len(xy), dtype=bool)
        if len(xy):
            pts, _ = self._roads.query(shapely.points(xy), predicate="within")
            out[pts] = True
        return out

    def no_walk(self, xy: np.ndarray, t: float) -> np.ndarray:
        """Whether each point is on a signalised crosswalk that does not show *walk* at ``t``."""
        k = self.crosswalk_at(xy)
        out = np.zeros(len(k), dtype=bool)
        for i in np.flatnonzero(k >= 0).tolist():
            out[i] = self._signalled[k[i]] and not self.plan.walk(self.walk_ids[k[i]], t)
        return out


def crossings_of(prepared, scene: Scene) -> Crossings:
    """The :class:`Crossings` of ``scene``, built once and kept on the env's cached scene data."""
    have = getattr(prepared, "_crossings", None)
    if have is None or have.scene is not scene:
        have = Crossings(scene)
        prepared._crossings = have
    return have


# --- people ---------------------------------------------------------------------------------


class SignalCrowd:
    """A :class:`~citygen.runner.agents.crowd.Crowd` whose people wait at crosswalks for *walk*.

    Everything but :meth:`step` is the crowd's own (``pos``, ``vel``, ``radius``, ``ids`` ...).
    ``t`` (s) is the signals' clock, advanced by ``dt`` each step.
    """

    def __init__(self, crowd, crossings: Crossings) -> None:
        self._crowd = crowd
        self.crossings = crossings
        self.t = 0.0
        self.held = 0
        """People kept off a crosswalk in the last step."""

    def __getattr__(self, name: str):
        return getattr(self._crowd, name)

    def step(self, robot_xy, robot_vel, robot_radius: float, vehicles=None, active=None) -> None:
        """The crowd's step (``active``: who moves, :meth:`Crowd.step`), people held at the
        edge of a crosswalk that does not show *walk*."""
        c = self._crowd
        old = c.pos.copy()
        was = self.crossings.crosswalk_at(old)
        rows = np.arange(len(old)) if active is None else np.flatnonzero(active)
        ahead = old.copy()  # where each is heading within a second (the standing: where they stand)
        ahead[rows] += c.preferred_velocities(rows) * 1.0
        red = self.crossings.no_walk(ahead, self.t) & (was < 0)
        speed = c.speed.copy()
        c.speed[red] = 0.0  # stand at the edge
        try:
            c.step(robot_xy, robot_vel, robot_radius, vehicles, active)
        finally:
            c.speed[:] = speed
        now = self.crossings.crosswalk_at(c.pos)
        stepped_on = (now >= 0) & (now != was) & self.crossings.no_walk(c.pos, self.t)
        stepped_on &= was < 0
        if stepped_on.any():
            c.pos[stepped_on] = old[stepped_on]
            c.vel[stepped_on] = 0.0
        self.held = int(red.sum() + stepped_on.sum())
        self.t += c.dt
