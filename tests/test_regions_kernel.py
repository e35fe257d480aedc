"""The compiled taut path (citygen.runner.control.regions_kernel) against its plain-numpy
reference (``region_path_length(..., reference=True)``): the same length, to 1e-9 m, from
every start tried, on a test scene's free cells and on random maps of boxes."""

from __future__ import annotations

import math

import numpy as np
import pytest

from citygen.geometry.raster import Grid
from citygen.runner.control.regions import region_distance, region_path_length


def _agree(free, grid, goal, tol, starts):
    field = region_distance(free, grid, goal, tol)
    checked = 0
    for xy in starts:
        ref = region_path_length(free, grid, field, xy, goal, tol, reference=True)
        fast = region_path_length(free, grid, field, xy, goal, tol)
        if math.isinf(ref):
            assert math.isinf(fast)
            continue
        assert fast == pytest.approx(ref, abs=1e-9), xy
        checked += 1
    return checked


@pytest.mark.parametrize("seed", range(4))
def test_kernel_agrees_with_the_reference_on_random_maps_of_boxes(seed):
    rng = np.random.default_rng(seed)
    grid = Grid(-3.0, 2.0, 0.1, 90, 120)
    free = np.ones(grid.shape, dtype=bool)
    for _ in range(14):  # boxes, some touching, so paths bend round corners and through gaps
        r, c = rng.integers(0, 80), rng.integers(0, 110)
        free[r : r + rng.integers(2, 20), c : c + rng.integers(2, 20)] = False
    goal = (grid.x0 + 1.0, grid.y0 + 1.0)
    free[:20, :20] = True
    starts = rng.uniform((grid.x0, grid.y0), (grid.x0 + 12.0, grid.y0 + 9.0), (60, 2))
    assert _agree(free, grid, goal, 0.5, [tuple(s) for s in starts]) > 30


def test_kernel_agrees_with_the_reference_on_a_test_scenes_free_cells():
    from citygen.runner.make import make_env

    env = make_env("nav-static", split="urban-nav-2-test", robot="wheeled")
    env.reset(seed=0, options={"index": 3})
    u = env.unwrapped
    free, grid = u.prepared.free, u.prepared.occupancy.grid
    rows, cols = np.nonzero(free)
    rng = np.random.default_rng(0)
    pick = rng.choice(len(rows), 40, replace=False)
    starts = [grid.centre((int(rows[k]), int(cols[k]))) for k in pick]
    starts += [(x + 0.013, y - 0.021) for x, y in starts[:10]]  # off the centres
    assert _agree(free, grid, tuple(u.goal[:2]), u.tolerance, starts) > 30
    env.close()
