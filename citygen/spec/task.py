"""The benchmark task of a scene (stage 6): where the robot starts and what it must do."""

from __future__ import annotations

from types import MappingProxyType
from typing import Annotated, Literal

from pydantic import Field

from citygen.spec import limits
from citygen.spec.base import SpecModel, Vec2, Vec3, bounded_float
from citygen.spec.blocks import Pose2

Robot = Literal["wheeled", "quadruped", "wheeled_legged", "humanoid", "wheelchair", "scooter"]
"""The embodiments of the runner: a wheeled delivery robot, a Go2-like quadruped, a
B2-W-like wheeled-legged robot, a G1-like humanoid, an electric wheelchair, a mobility scooter."""

#: Radius (m) of the disc each embodiment occupies on the ground: what the task stage
#: keeps clear at the start and goal and along a walkable path between them, and what
#: the runner's planner inflates the occupancy map by.
ROBOT_RADIUS = MappingProxyType(
    {
        "wheeled": 0.35,
        "quadruped": 0.4,
        "wheeled_legged": 0.5,
        "humanoid": 0.3,
        "wheelchair": 0.45,
        "scooter": 0.55,
    }
)


class _Task(SpecModel):
    robot: Robot = "wheeled"
    """The embodiment the task is set for."""
    start: Pose2
    """Where the robot starts and which way it faces."""
    time_limit: bounded_float(0.1, 86_400.0)
    """Seconds before the episode ends unsuccessfully."""


class NavTask(_Task):
    """Point-goal navigation (NavClear, NavStatic, NavDynamic): reach ``goal``."""

    kind: Literal["nav-clear", "nav-static", "nav-dynamic"]
    goal: Vec2
    """``[x, y]`` to reach, in metres."""
    goal_tolerance: bounded_float(0.01, 10.0) = 0.5
    """Distance from the goal, in metres, that counts as reached."""


class LocoTask(_Task):
    """Locomotion (LocoFlat, LocoSlope, LocoStair, LocoRough): track a velocity command."""

    kind: Literal["loco-flat", "loco-slope", "loco-stair", "loco-rough"]
    command: Vec3 = (1.0, 0.0, 0.0)
    """Commanded ``[vx, vy, yaw_rate]`` in the robot frame, in m/s and rad/s."""


class TraverseTask(_Task):
    """Kilometre-scale traverse: follow ``route`` to its last point."""

    kind: Literal["traverse"]
    route: tuple[Vec2, ...] = Field(min_length=1, max_length=limits.MAX_ROUTE_POINTS)
    """Waypoints ``[[x, y], ...]`` in metres; the last one is the goal."""
    goal_tolerance: bounded_float(0.01, 10.0) = 1.0
    """Distance from a waypoint, in metres, that counts as reached."""


Task = Annotated[NavTask | LocoTask | TraverseTask, Field(discriminator="kind")]
TASK_KINDS: tuple[str, ...] = (
    "nav-clear",
    "nav-static",
    "nav-dynamic",
    "loco-flat",
    "loco-slope",
    "loco-stair",
    "loco-rough",
    "traverse",
)
