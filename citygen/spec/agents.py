"""Dynamic agents (stage 5): who moves through the scene, from where to where.

Only intentions are stored (start, goal, size, preferred speed); the motion itself
is simulated by the runner (ORCA for people, IDM for vehicles).
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field

from citygen.spec import limits
from citygen.spec.base import Float, Identifier, SpecModel, Vec2


class _Agent(SpecModel):
    id: Identifier
    start: Vec2
    """``[x, y]`` where the agent appears, in metres."""
    goal: Vec2
    """``[x, y]`` the agent heads for, in metres."""


class Person(_Agent):
    """A pedestrian, cyclist or scooter rider, moving on walkable ground."""

    kind: Literal["pedestrian", "cyclist", "scooter"]
    radius: Float = Field(default=0.3, ge=0.1, le=1.5)
    """Radius of the disc the agent occupies, in metres."""
    speed: Float = Field(default=1.3, ge=0.0, le=15.0)
    """Preferred speed in metres per second."""


class Vehicle(_Agent):
    """A car, van or bus following lanes on the roadway."""

    kind: Literal["vehicle"]
    length: Float = Field(default=4.5, ge=1.5, le=25.0)
    """Length in metres."""
    width: Float = Field(default=1.8, ge=0.8, le=3.5)
    """Width in metres."""
    speed: Float = Field(default=8.0, ge=0.0, le=40.0)
    """Desired speed (IDM's v0) in metres per second."""
    route: tuple[Identifier, ...] = Field(default=(), max_length=limits.MAX_ROUTE_POINTS)
    """Ids of the blocks the vehicle drives through, in order (empty: follow the lane)."""


Agent = Annotated[Person | Vehicle, Field(discriminator="kind")]
AGENT_TYPES = (Person, Vehicle)
