"""Stage 6: the robot's task (start pose, goal, route), solvable by construction.

The stage runs in two steps around the others, drawing only from its own generator:

1. :func:`choose_endpoints`, right after the ground: the start and the goal (or the
   traverse route) on walkable ground wide enough for the robot, in one connected
   piece of it, at least ``min_distance`` apart in a straight line, so at least as far
   along any walkable path. The terrain stage then keeps their tiles flat, and the
   placement stage keeps the robot's discs there clear and never cuts the walkable
   connection between them.
2. :func:`make_task`, at the end: the spec's task model from those endpoints.

Locomotion tasks start at the centre of a tile of the terrain grid, facing along +x
or across, and carry no goal.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from citygen.errors import GenerationError
from citygen.generate.space import (
    Sampler,
    cell_groups,
    far_pair,
    free_space,
    pieces,
    straighten,
    walkable_ground,
    zone_polygon,
)
from citygen.geometry import raster
from citygen.spec.blocks import Pose2
from citygen.spec.config import TaskConfig
from citygen.spec.scene import Bounds
from citygen.spec.task import ROBOT_RADIUS, LocoTask, NavTask, Task, TraverseTask
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

MARGIN = 0.1
"""Extra clearance (m) beyond the robot's radius kept at the start, the goal and on the route."""
LEG = 25.0
"""Longest straight leg (m) between two traverse waypoints."""


@dataclass(frozen=True)
class Endpoints:
    """Where the task starts and ends, chosen before the terrain and the objects."""

    start: tuple[float, float]
    yaw: float
    goal: tuple[float, float] | None = None
    route: tuple[tuple[float, float], ...] = ()
    radius: float = 0.0
    """Clearance (m) kept around ``start``, ``goal`` and the route: robot radius + margin."""

    @property
    def points(self) -> list[tuple[float, float]]:
        """Start, goal and route points: where the terrain must be flat."""
        return [self.start, *([self.goal] if self.goal is not None else []), *self.route]

    @property
    def needs_path(self) -> bool:
        """Whether later stages must keep a walkable path from start to goal."""
        return self.goal is not None


def robot_clearance(cfg: TaskConfig) -> float:
    return ROBOT_RADIUS[cfg.robot] + MARGIN


def choose_endpoints(
    bounds: Bounds,
    zones: Sequence[Zone],
    cfg: TaskConfig,
    rng: np.random.Generator,
    *,
    seed: int,
    walkable: BaseGeometry | None = None,
) -> Endpoints | None:
    """The start and goal (nav), the route (traverse); None for locomotion tasks, whose
    start is chosen on the terrain grid by :func:`make_task`. ``walkable`` is the walkable
    ground when the caller has it (:func:`~citygen.generate.space.walkable_ground`)."""
    if cfg.kind.startswith("loco-"):
        return None
    radius = robot_clearance(cfg)
    if walkable is None:
        walkable = walkable_ground(zones, (*bounds.min, *bounds.max))
    free = free_space(walkable, (), radius)
    candidates = pieces(free)
    if not candidates:
        raise GenerationError(
            "task",
            seed,
            f"no walkable ground wide enough for the {cfg.robot} robot ({2 * radius:g} m across)",
        )
    need = cfg.min_distance
    # Pieces that could hold two points ``need`` apart, largest first.
    able = [p for p in candidates if math.dist(p.bounds[:2], p.bounds[2:]) >= need][:8]
    for piece in able:
        if cfg.kind == "traverse":
            found = _traverse(piece, need, rng)
            if found is None:
                continue
            start, route = found
            # Face the first leg: a traverse starts on its route.
            yaw = round(math.atan2(route[0][1] - start[1], route[0][0] - start[0]), 6)
            return Endpoints(start, yaw, None, tuple(route), radius=radius)
        pair = far_pair(piece, Sampler(piece), rng, need)
        if pair is not None:
            yaw = round(float(rng.uniform(-math.pi, math.pi)), 6)
            return Endpoints(pair[0], yaw, pair[1], radius=radius)
    raise GenerationError(
        "task",
        seed,
        f"no two points of connected walkable ground at least {need:g} m apart for the {cfg.robot} robot "
        f"(radius {ROBOT_RADIUS[cfg.robot]:g} m); lower task.min_distance or widen the walkable zones",
    )


def street_route(
    bounds: Bounds, zones: Sequence[Zone], cfg: TaskConfig, rng: np.random.Generator, *, seed: int
) -> Endpoints:
    """A city's traverse: a route along the sidewalks and crosswalks only (the ground people
    walk along streets on, through the junctions), ending at least ``min_distance`` metres
    from its start in a straight line, so the route is at least that long. The cells are
    finer (0.5 m) than :func:`choose_endpoints`' so that a narrow sidewalk stays connected."""
    radius = robot_clearance(cfg)
    walks = [zone_polygon(z) for z in zones if z.kind in ("sidewalk", "crosswalk")]
    free = free_space(shapely.union_all(walks, grid_size=1e-3), (), radius)
    for piece in pieces(free)[:4]:
        found = _traverse(piece, cfg.min_distance, rng, res=STREET_CELL)
        if found is not None:
            start, route = found
            yaw = round(math.atan2(route[0][1] - start[1], route[0][0] - start[0]), 6)
            return Endpoints(start, yaw, None, tuple(route), radius=radius)
    raise GenerationError(
        "task",
        seed,
        f"no two points of connected sidewalk {cfg.min_distance:g} m apart for the {cfg.robot} robot; "
        "lower task.min_distance",
    )


#: Side (m) of the cells a city's street route is found on, and of the squares they are
#: found in (a point-in-polygon test against a square's part of the sidewalks is far quicker
#: than against a whole city's).
STREET_CELL, SQUARE = 0.5, 100.0


def _tiled_cell_groups(piece: shapely.Polygon, res: float) -> tuple[raster.Grid, np.ndarray]:
    """:func:`~citygen.generate.space.cell_groups`, painted square by square."""
    x0, y0, x1, y1 = piece.bounds
    grid = raster.Grid.covering((x0 - res, y0 - res, x1 + res, y1 + res), res)
    inner = piece.buffer(-0.75 * res, quad_segs=4)
    inside = np.zeros(grid.shape, dtype=bool)
    for x in np.arange(x0 - res, x1 + res, SQUARE):
        for y in np.arange(y0 - res, y1 + res, SQUARE):
            part = shapely.clip_by_rect(inner, x, y, x + SQUARE, y + SQUARE)
            raster.paint(grid, inside, part, True)
    labels, _ = raster.components(inside)
    return grid, labels


def _traverse(
    piece: shapely.Polygon, need: float, rng: np.random.Generator, tries: int = 256, res: float | None = None
) -> tuple[tuple[float, float], list[tuple[float, float]]] | None:
    """A start and a route of waypoints inside ``piece`` ending at least ``need`` metres from
    the start, or None.

    The piece is rasterised into cells whose centres keep half a diagonal inside it (so a
    straight step between neighbouring centres never leaves it); start and goal are cells of
    the largest 8-connected group, so the shortest path between them exists on the grid. The
    path is straightened (legs kept inside the piece) and cut so no leg exceeds :data:`LEG`.
    """
    x0, y0, x1, y1 = piece.bounds
    if res is None:
        res = min(1.0, max(0.1, math.sqrt((x1 - x0) * (y1 - y0) / 2e6)))
        grid, labels = cell_groups(piece, res)
    else:
        grid, labels = _tiled_cell_groups(piece, res)
    if not labels.any():
        return None
    sizes = np.bincount(labels.ravel())
    sizes[0] = 0
    largest = int(np.argmax(sizes))
    cells = np.argwhere(labels == largest)
    for _ in range(tries):
        a, b = (tuple(int(v) for v in cells[int(rng.integers(len(cells)))]) for _ in range(2))
        if math.dist(grid.centre(a), grid.centre(b)) >= need + res:
            break
    else:
        return None
    path = raster.shortest_path(labels == largest, a, b)
    if path is None:  # cannot happen: a and b are in one 8-connected group
        return None
    points = straighten([grid.centre(c) for c in path], piece)
    legs = []
    for p, q in itertools.pairwise(points):
        n = max(1, math.ceil(math.dist(p, q) / LEG))
        legs += [(p[0] + (q[0] - p[0]) * k / n, p[1] + (q[1] - p[1]) * k / n) for k in range(1, n + 1)]
    start = (round(points[0][0], 3) + 0.0, round(points[0][1], 3) + 0.0)
    return start, [(round(x, 3) + 0.0, round(y, 3) + 0.0) for x, y in legs]


def make_task(
    cfg: TaskConfig, ends: Endpoints | None, terrain: Terrain | None, rng: np.random.Generator
) -> Task:
    """The task model: a nav task from ``ends``, a traverse along its route, or a locomotion
    task starting at the centre of a random tile of ``terrain``."""
    common = {"robot": cfg.robot, "time_limit": cfg.time_limit}
    if ends is None:
        if terrain is None:
            raise ValueError("a locomotion task needs a terrain grid")
        r, c = int(rng.integers(terrain.rows)), int(rng.integers(terrain.cols))
        s = terrain.tile_size
        x, y = terrain.origin[0] + (c + 0.5) * s, terrain.origin[1] + (r + 0.5) * s
        yaw = float(rng.integers(4)) * math.pi / 2 - math.pi
        return LocoTask(kind=cfg.kind, start=Pose2(position=(x, y), yaw=round(yaw, 6)), **common)
    start = Pose2(position=ends.start, yaw=ends.yaw)
    if cfg.kind == "traverse":
        return TraverseTask(
            kind="traverse", start=start, route=ends.route, goal_tolerance=cfg.goal_tolerance, **common
        )
    return NavTask(kind=cfg.kind, start=start, goal=ends.goal, goal_tolerance=cfg.goal_tolerance, **common)
