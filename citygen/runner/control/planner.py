"""The navigation baseline (:class:`Planner`): A* on the occupancy grid inflated by the
robot's radius (:mod:`~citygen.runner.control.grid`), line-of-sight shortcuts, pure pursuit
and reactive avoidance of moving agents (:mod:`~citygen.runner.control.pursuit`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from citygen.exporters.occupancy import OccupancyMap
from citygen.geometry.raster import components, erode
from citygen.runner.control.grid import (
    Cell,
    _free_array,
    astar,
    path_length,
    path_to_world,
    shortcut,
    snap_free,
)
from citygen.runner.control.pursuit import _closest_on_path, _point_at, avoid, pure_pursuit

_AGENT_BERTH = 0.2
"""Extra clearance (m) around an agent's disc when the planner replans around agents: more
than :func:`avoid`'s default margin, so the new path is one avoidance lets the robot follow."""


class Planner:
    """A* on the occupancy grid inflated by the robot's radius, line-of-sight shortcuts,
    pure pursuit and reactive avoidance of agents: the navigation baseline.

    Paths are planned on the grid inflated by ``robot_radius + margin`` when that connects
    start and goal by a path at most ``detour`` (a fraction) longer than the one on the grid
    inflated by ``robot_radius`` alone (the extra ``margin`` metres leave room for pure
    pursuit's arcs), else on the latter. :meth:`command` replans from the robot's
    position when it is more than ``replan_distance`` metres off the path, and around the
    agents (as discs) after ``patience`` calls in a row in which avoidance held it still.
    """

    def __init__(
        self,
        occupancy: OccupancyMap,
        robot_radius: float,
        *,
        margin: float = 0.1,
        lookahead: float = 0.5,
        max_speed: float = 1.0,
        max_yaw_rate: float = 1.5,
        horizon: float = 1.5,
        replan_distance: float = 0.5,
        patience: int = 10,
        detour: float = 0.05,
        free: np.ndarray | None = None,
    ) -> None:
        if not (max_speed > 0 and max_yaw_rate > 0 and lookahead > 0 and margin >= 0):
            raise ValueError(
                "Planner: max_speed (m/s), max_yaw_rate (rad/s) and lookahead (m) must be positive and "
                f"margin (m) >= 0, got {max_speed!r}, {max_yaw_rate!r}, {lookahead!r}, {margin!r}"
            )
        self.occupancy = occupancy
        self.grid = occupancy.grid
        self.robot_radius = float(robot_radius)
        self.free = ~occupancy.inflated(robot_radius) if free is None else _free_array(free)
        """Cells a robot of this radius may have its centre on (``free`` when given: the
        same mask computed once by the caller)."""
        if self.free.shape != occupancy.shape:
            raise ValueError(f"Planner: free has shape {self.free.shape}, the map {occupancy.shape}")
        self.margin, self.detour = float(margin), float(detour)
        # The free cells at least `margin` further from anything blocked (including whatever
        # a caller's `free` leaves out beyond the map's own obstacles).
        self.roomy = self.free & ~occupancy.inflated(robot_radius + margin) if margin > 0 else self.free
        if margin > 0 and free is not None:
            self.roomy &= erode(self.free, margin / self.grid.resolution)
        self.lookahead, self.max_speed, self.max_yaw_rate = lookahead, max_speed, max_yaw_rate
        self.horizon, self.replan_distance, self.patience = horizon, replan_distance, patience
        self.path: np.ndarray | None = None
        """The current path ``(K, 2)`` (m), None before :meth:`plan` or when none exists."""
        self.goal: np.ndarray | None = None
        self.replans = 0
        """How many times :meth:`command` planned again."""
        self._held = 0
        self._progress = 0
        self._components: dict[str, np.ndarray] = {}

    def free_at(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Whether points (m, broadcastable arrays) lie on free cells (False off the grid)."""
        g = self.grid
        col = np.floor((np.asarray(xs) - g.x0) / g.resolution)
        row = np.floor((np.asarray(ys) - g.y0) / g.resolution)
        inside = (col >= 0) & (col < g.cols) & (row >= 0) & (row < g.rows)
        out = np.zeros(np.broadcast(col, row).shape, dtype=bool)
        out[inside] = self.free[row[inside].astype(np.int64), col[inside].astype(np.int64)]
        return out

    def _ends(
        self, free: np.ndarray, start_xy: np.ndarray, goal_xy: np.ndarray, cache: str | None = None
    ) -> tuple[Cell, Cell] | None:
        """The free cells nearest start and goal, the goal's among those connected to the
        start's (the connected regions of the planner's own masks are computed once)."""
        start = snap_free(free, self.grid.cell(*start_xy))
        if start is None:
            return None
        if cache is None:
            labels, _ = components(free)
        else:
            if cache not in self._components:
                self._components[cache] = components(free)[0]
            labels = self._components[cache]
        goal = snap_free(free, self.grid.cell(*goal_xy), within=labels == labels[start])
        return None if goal is None else (start, goal)

    def plan(
        self, start_xy: Sequence[float], goal_xy: Sequence[float], *, blocked: np.ndarray | None = None
    ) -> np.ndarray | None:
        """Plan from ``start_xy`` to ``goal_xy`` (m); start and goal snap to the nearest free
        cells (the goal to the nearest one connected to the start). ``blocked`` marks extra
        cells to avoid (bool, the grid's shape). The path ``(K, 2)`` (m) runs from the
        robot's position (its snapped cell's centre when that is not free) through the
        corners to the goal (the goal itself when it is on a free cell); None when no cell
        near the start is free."""
        start, goal = np.asarray(start_xy, dtype=np.float64)[:2], np.asarray(goal_xy, dtype=np.float64)[:2]
        self.goal = goal
        extra = np.zeros(self.free.shape, dtype=bool) if blocked is None else np.asarray(blocked, dtype=bool)
        cache = ("free", "roomy") if blocked is None else (None, None)
        ends = self._ends(self.free & ~extra, start, goal, cache[0])
        if ends is None:
            self.path = None
            return None
        # The roomy grid's path when its ends are those of the tight grid (give or take the
        # margin) and it is at most `detour` longer.
        slack = (self.margin / self.grid.resolution + 1.5) ** 2
        roomy = self._ends(self.roomy & ~extra, start, goal, cache[1])
        tight = self.free & ~extra
        cells = astar(tight, *ends)
        if cells is None:  # not reached: the goal was snapped within the start's component
            self.path = None
            return None
        path = shortcut(tight, cells)
        if roomy is not None and all(
            (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 <= slack for a, b in zip(roomy, ends, strict=True)
        ):
            wide = astar(self.roomy & ~extra, *roomy)
            if wide is not None:  # joined to the tight grid's ends
                wide = shortcut(self.roomy & ~extra, wide)
                head, tail = astar(tight, ends[0], wide[0]), astar(tight, wide[-1], ends[1])
                wide = shortcut(tight, head or [ends[0]])[:-1] + wide + shortcut(tight, tail or [ends[1]])[1:]
                if path_length(wide) <= (1.0 + self.detour) * path_length(path) + 2 * slack**0.5:
                    path = wide
        xy = path_to_world(path, self.grid)
        if self.grid.cell(*goal) == ends[1]:
            xy[-1] = goal
        if self.grid.cell(*start) == ends[0]:
            xy[0] = start
        self.path, self._progress, self._held = xy, 0, 0
        return xy

    def off_path(self, xy: Sequence[float]) -> bool:
        """Whether ``xy`` lies more than ``replan_distance`` m from the planned path (or there
        is none)."""
        if self.path is None:
            return True
        s, cum = _closest_on_path(self.path, np.asarray(xy, dtype=np.float64)[:2])
        return math.hypot(*(_point_at(self.path, cum, s) - np.asarray(xy[:2]))) > self.replan_distance

    def _others_blocked(self, xy: np.ndarray, radius: np.ndarray) -> np.ndarray:
        g = self.grid
        xs, ys = g.xs(), g.ys()
        out = np.zeros(self.free.shape, dtype=bool)
        for (ox, oy), r in zip(xy, radius, strict=True):
            reach = r + self.robot_radius + _AGENT_BERTH
            rows, cols = g.window((ox - reach, oy - reach, ox + reach, oy + reach))
            out[rows, cols] |= np.hypot(xs[cols][None, :] - ox, ys[rows][:, None] - oy) <= reach
        return out

    def command(
        self,
        pose: Sequence[float],
        others_xy: np.ndarray | None = None,
        others_vel: np.ndarray | None = None,
        others_radius: np.ndarray | float = 0.3,
        *,
        max_speed: float | None = None,
        max_yaw_rate: float | None = None,
        horizon: float | None = None,
    ) -> tuple[float, float]:
        """``(v, w)`` (m/s, rad/s) for a unicycle at ``pose = (x, y, yaw)`` (m, m, rad),
        avoiding the agents at ``others_xy`` (``(N, 2)``, m) of ``others_radius`` (m) moving at
        ``others_vel`` (m/s). ``max_speed``, ``max_yaw_rate`` and ``horizon`` override the
        planner's settings for this call. ``(0, 0)`` without a path. Call :meth:`plan` first."""
        vmax = self.max_speed if max_speed is None else max_speed
        wmax = self.max_yaw_rate if max_yaw_rate is None else max_yaw_rate
        horizon = self.horizon if horizon is None else horizon
        if self.goal is None:
            raise ValueError("Planner.command: call plan(start_xy, goal_xy) first")
        xy = np.asarray(pose[:2], dtype=np.float64)
        if self.path is None:
            return 0.0, 0.0
        rest = self.path[self._progress :]
        if len(rest) > 1:
            s, cum = _closest_on_path(rest, xy)
            k = int(np.searchsorted(cum, s, side="right") - 1)
            self._progress += max(0, min(k, len(rest) - 2))
            foot = _point_at(rest, cum, s)
            if math.hypot(*(foot - xy)) > self.replan_distance:
                self.replans += 1
                if self.plan(xy, self.goal) is None:
                    return 0.0, 0.0
        v, w = pure_pursuit(
            pose, self.path[self._progress :], self.lookahead, self.max_speed, self.max_yaw_rate
        )
        if others_xy is None or len(others_xy) == 0:
            return v, w
        others = np.asarray(others_xy, dtype=np.float64).reshape(-1, 2)
        vel = np.zeros_like(others) if others_vel is None else np.asarray(others_vel, dtype=np.float64)
        radius = np.broadcast_to(np.asarray(others_radius, dtype=np.float64), (len(others),))
        v2, w2 = avoid(
            pose, v, w, others, vel, radius, self.robot_radius, horizon,
            max_speed=vmax, max_yaw_rate=wmax, free_at=self.free_at,
        )  # fmt: skip
        self._held = self._held + 1 if v > 0.05 and v2 < 0.05 else 0
        if self._held >= self.patience:  # around the agents, unless they close the way: then wait
            self.replans += 1
            kept = (self.path, self._progress)
            around = self.plan(xy, self.goal, blocked=self._others_blocked(others, radius))
            if around is None or math.hypot(*(around[-1] - kept[0][-1])) > self.grid.resolution * 1.5:
                self.path, self._progress = kept
            self._held = 0
        return v2, w2
