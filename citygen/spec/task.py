"""The benchmark task of a scene (stage 6): where the robot starts and what it must do."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from types import MappingProxyType
from typing import Annotated, Literal

from pydantic import Field

from citygen.spec import limits
from citygen.spec.base import SpecModel, Vec2, Vec3, bounded_float
from citygen.spec.blocks import Pose2

STEP_RUN = 0.05
"""Run (m) over which a rise of the ground counts as one step (the runner's map cell)."""


@dataclass(frozen=True)
class Mobility:
    """What ground an embodiment can cross: the capabilities the task stage keeps a scene's
    start and goal connected by, and the runner's planner and metrics plan with
    (:func:`citygen.geometry.traversable.tile_crossable` says which terrain tiles they allow)."""

    radius: float
    """Radius (m) of the disc the robot occupies on the ground: what the task stage keeps clear
    at the start and goal and along a path between them, and what the planner inflates the
    occupancy map by."""
    max_step: float
    """Highest edge (m) the robot drives or walks over: a stair riser, a curb, a bump of rough
    ground (a rise over :data:`STEP_RUN`); the runner keeps its centre a radius away from higher
    edges."""
    max_slope: float
    """Steepest slope (rad) the robot climbs and descends."""
    stairs: bool
    """Whether it climbs stairs (those whose risers are at most :attr:`max_step`); wheels do not."""


#: The embodiments of the runner and what ground each crosses: a wheeled delivery robot, a
#: Go2-like quadruped, a B2-W-like wheeled-legged robot, a G1-like humanoid, an electric
#: wheelchair, a mobility scooter. A new embodiment is one entry here (and its model in the runner,
#: which takes its radius and highest step from here).
ROBOTS: Mapping[str, Mobility] = MappingProxyType(
    {
        "wheeled": Mobility(radius=0.35, max_step=0.05, max_slope=0.25, stairs=False),
        "quadruped": Mobility(radius=0.4, max_step=0.18, max_slope=0.6, stairs=True),
        "wheeled_legged": Mobility(radius=0.5, max_step=0.08, max_slope=0.5, stairs=True),
        "humanoid": Mobility(radius=0.3, max_step=0.2, max_slope=0.4, stairs=True),
        "wheelchair": Mobility(radius=0.45, max_step=0.05, max_slope=0.2, stairs=False),
        "scooter": Mobility(radius=0.55, max_step=0.05, max_slope=0.2, stairs=False),
    }
)

Robot = Literal[tuple(ROBOTS)]  # type: ignore[valid-type]
"""The name of an embodiment: a key of :data:`ROBOTS`."""

#: Radius (m) of each embodiment (:attr:`Mobility.radius`).
ROBOT_RADIUS: Mapping[str, float] = MappingProxyType({name: m.radius for name, m in ROBOTS.items()})


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
