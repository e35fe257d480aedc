"""Every navigation task is solvable by the robot it names: the runner's own map of the ground
that robot can cross (the occupancy map, its step edges and the tiles it cannot climb, shrunk
by its radius) connects the start to the goal region. Computed from the exported map, not
from the generator's polygons, so the two must agree."""

from __future__ import annotations

import math

import pytest
from shapely.geometry import LineString, box

from citygen.exporters.occupancy import occupancy
from citygen.generate.pipeline import generate
from citygen.generate.splits import generate_scene, resolve
from citygen.generate.terrain import build_terrain
from citygen.geometry.traversable import blocked_tiles, tile_crossable
from citygen.runner.control.regions import region_distance
from citygen.runner.robots import load_robot
from citygen.runner.scenes import free_cells, map_resolution
from citygen.seeding import stage_rng
from citygen.spec.config import TerrainConfig
from citygen.spec.scene import Bounds
from citygen.spec.task import ROBOTS
from citygen.spec.terrain import RoughTile, SlopeTile, StairTile

# Scenes whose terrain cut the wheeled robot's start from its goal before the task stage
# checked (a stair terrace across the scene, or rough ground too bumpy): 0.1.0's numbering.
WERE_CUT = {"urban-nav-1-test": (11, 20, 85), "urban-nav-2-test": (4, 7, 34), "urban-nav-3-test": (5, 6, 9)}


def _reachable(scene, robot_name: str) -> bool:
    robot = load_robot(robot_name)
    occ = occupancy(scene, map_resolution(scene))
    free = free_cells(occ, robot, scene.terrain)
    try:
        field = region_distance(free, occ.grid, scene.task.goal, scene.task.goal_tolerance)
    except ValueError:
        return False
    return math.isfinite(field[occ.grid.cell(*scene.task.start.position)])


@pytest.mark.slow
@pytest.mark.parametrize("split", sorted(WERE_CUT))
def test_urban_nav_tasks_are_solvable_by_their_robot(split):
    part = resolve(split)[0]
    config = part.config
    for index in (*WERE_CUT[split], *range(0, 256, 64)):
        scene = generate_scene(part, index)
        assert scene.task.robot == config.task.robot == "wheeled"
        assert _reachable(scene, "wheeled"), (split, index)


@pytest.mark.slow
@pytest.mark.parametrize("robot", ["wheelchair", "quadruped"])
def test_tasks_are_solvable_for_other_robots(robot):
    part = resolve("urban-nav-2-test")[0]
    task = part.config.task.model_copy(update={"robot": robot})
    config = part.config.model_copy(update={"task": task})
    for seed in range(6):
        scene = generate(config, seed)
        assert scene.task.robot == robot
        assert _reachable(scene, robot), (robot, seed)


def test_tile_crossable_by_capability():
    wheeled, quad = ROBOTS["wheeled"], ROBOTS["quadruped"]
    low = StairTile(kind="stair", step_height=0.05, step_count=3)
    high = StairTile(kind="stair", step_height=0.22, step_count=2)
    assert not tile_crossable(low, 2.5, wheeled)  # wheels take no stairs, however low
    assert tile_crossable(low, 2.5, quad) and not tile_crossable(high, 2.5, quad)  # risers > 0.18 m
    steep = SlopeTile(kind="slope", angle=0.5)
    assert tile_crossable(steep, 2.5, quad) and not tile_crossable(steep, 2.5, wheeled)
    gentle = RoughTile(kind="rough", amplitude=0.02, scale=1.0, seed=1)
    bumpy = RoughTile(kind="rough", amplitude=0.1, scale=0.2, seed=1)
    assert tile_crossable(gentle, 2.5, wheeled) and not tile_crossable(bumpy, 2.5, wheeled)


def test_rough_tiles_settled_by_their_slope_bound_answer_as_rough_step_does():
    """tile_crossable skips sampling a rough tile when rough_slope_bound already allows the
    step: the bound must hold on every tile (any scale, size, amplitude), and the answer must
    be rough_step's for every robot and for steps right around the tile's own rise."""
    import numpy as np

    from citygen.geometry.terrain import rough_slope_bound
    from citygen.geometry.traversable import _ALLOWANCE, rough_step
    from citygen.spec.task import STEP_RUN, Mobility

    rng = np.random.default_rng(5)
    settled = 0
    for k in range(150):
        size = float(rng.choice([2.0, 2.5, 5.0]))
        tile = RoughTile(
            kind="rough", amplitude=float(rng.uniform(0.0, 0.2)), scale=float(rng.uniform(0.1, 3.0)), seed=k
        )
        step = rough_step(tile, size)
        bound = rough_slope_bound(tile, size) * STEP_RUN
        assert step <= bound, (tile, size)
        steps = {m.max_step for m in ROBOTS.values()} | {step * _ALLOWANCE, step * _ALLOWANCE * (1 + 1e-12)}
        for max_step in steps:
            mobility = Mobility(radius=0.3, max_step=max_step, max_slope=1.0, stairs=True)
            assert tile_crossable(tile, size, mobility) == (step * _ALLOWANCE <= max_step), (tile, max_step)
            settled += bound * 1.2 <= max_step
    assert settled > 50  # the shortcut is taken, not only the sampled path


def test_terrain_corridor_holds_only_tiles_the_robot_crosses():
    """A corridor across a grid where stair-only terraces are likely: every tile it reaches
    is one the wheeled robot crosses, whatever WFC draws elsewhere."""
    bounds = Bounds(min=(0.0, 0.0), max=(15.0, 15.0))
    cfg = TerrainConfig(slope_angle=(0.5, 0.6))  # slopes too steep for wheels: stairs or nothing
    corridor = LineString([(1.0, 1.0), (14.0, 14.0)]).buffer(0.45)
    stairs = 0
    for seed in range(8):
        free = build_terrain(bounds, (), cfg, stage_rng(seed, "terrain"))
        stairs += sum(isinstance(t, StairTile) for t in free.tiles)
        t = build_terrain(
            bounds, (), cfg, stage_rng(seed, "terrain"), corridor=corridor, mobility=ROBOTS["wheeled"]
        )
        blocked = blocked_tiles(t, ROBOTS["wheeled"])
        for r in range(t.rows):
            for c in range(t.cols):
                s = t.tile_size
                square = box(c * s, r * s, (c + 1) * s, (r + 1) * s)
                if corridor.intersects(square) and not corridor.touches(square):
                    tile = t.tiles[r * t.cols + c]
                    assert not blocked[r, c] and not isinstance(tile, RoughTile), (seed, r, c, tile)
    assert stairs > 0  # the unconstrained terrain has stairs: the corridor is what kept them off
