"""Dynamic agents (stage 5): who moves through the scene, from where to where.

Only intentions are stored (start, goal, size, preferred speed); the motion itself
is simulated by the runner (ORCA for people, IDM for vehicles).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from citygen.spec import limits
from citygen.spec.base import Identifier, SpecModel, Vec2, bounded_float


class _Agent(SpecModel):
    id: Identifier
    start: Vec2
    """``[x, y]`` where the agent appears, in metres."""
    goal: Vec2
    """``[x, y]`` the agent heads for, in metres."""


class Person(_Agent):
    """A pedestrian, cyclist or scooter rider, moving on walkable ground."""

    kind: Literal["pedestrian", "cyclist", "scooter"]
    radius: bounded_float(0.1, 1.5) = 0.3
    """Radius of the disc the agent occupies, in metres."""
    speed: bounded_float(0.0, 15.0) = 1.3
    """Preferred speed in metres per second."""


class Vehicle(_Agent):
    """A car, van or bus following lanes on the roadway."""

    kind: Literal["vehicle"]
    length: bounded_float(1.5, 25.0) = 4.5
    """Length in metres."""
    width: bounded_float(0.8, 3.5) = 1.8
    """Width in metres."""
    speed: bounded_float(0.0, 40.0) = 8.0
    """Desired speed (IDM's v0) in metres per second."""
    route: tuple[Identifier, ...] = Field(default=(), max_length=limits.MAX_ROUTE_POINTS)
    """Ids of the blocks the vehicle drives through, in order (empty: follow the lane)."""


Agent = Annotated[Person | Vehicle, Field(discriminator="kind")]
AGENT_TYPES = (Person, Vehicle)
