"""The navigation baseline's planner: A*, geodesic fields, shortcuts, pure pursuit, avoidance."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

import citygen
from citygen.exporters.occupancy import CLASSES, OccupancyMap, occupancy
from citygen.geometry.raster import Grid
from citygen.runner.control.fields import DistanceField, geodesic_distance
from citygen.runner.control.grid import astar, line_of_sight, path_length, path_to_world, shortcut, snap_free
from citygen.runner.control.planner import Planner
from citygen.runner.control.pursuit import avoid, pure_pursuit
from citygen.spec.task import ROBOT_RADIUS

SQ2 = math.sqrt(2.0)


def _grid(text: str) -> np.ndarray:
    """A free mask from rows of '.' (free) and '#' (blocked), first row = row 0."""
    return np.array([[ch == "." for ch in line] for line in text.split()], dtype=bool)


def _assert_valid(free: np.ndarray, path: list[tuple[int, int]]) -> None:
    for (r0, c0), (r1, c1) in itertools.pairwise(path):
        assert max(abs(r1 - r0), abs(c1 - c0)) == 1
        assert free[r1, c1]
        if r1 != r0 and c1 != c0:  # no corner cutting
            assert free[r0, c1] and free[r1, c0]


def test_astar_hand_made_grids():
    open5 = np.ones((5, 5), dtype=bool)
    assert astar(open5, (0, 0), (4, 4)) == [(i, i) for i in range(5)]
    assert astar(open5, (2, 2), (2, 2)) == [(2, 2)]
    # A wall with a gap at the far end: the path goes round it through the gap.
    wall = _grid(
        """
        .....
        ####.
        .....
        """
    )
    path = astar(wall, (0, 0), (2, 0))
    _assert_valid(wall, path)
    assert path[0] == (0, 0) and path[-1] == (2, 0) and (1, 4) in path


def test_astar_is_optimal_against_the_geodesic_field():
    rng = np.random.default_rng(7)
    checked = 0
    for trial in range(12):
        free = rng.random((30, 40)) > 0.3
        cells = np.argwhere(free)
        for k in range(4):
            start = tuple(int(v) for v in cells[rng.integers(len(cells))])
            goal = tuple(int(v) for v in cells[rng.integers(len(cells))])
            field = geodesic_distance(free, goal, 1.0)
            path = astar(free, start, goal)
            if path is None:
                assert math.isinf(field[start]), (trial, k)
            else:
                _assert_valid(free, path)
                assert path[0] == start and path[-1] == goal
                assert path_length(path) == pytest.approx(field[start], abs=1e-9)
                checked += 1
    assert checked > 20  # most pairs are connected at 30 % blocked


def test_astar_wall_detour_length_by_hand():
    wall = _grid(
        """
        .....
        ####.
        .....
        """
    )
    # The diagonals (0,3)->(1,4) and (1,4)->(2,3) would cut the wall cell (1,3)'s corner, so
    # 4 right, 2 down, 4 left: 10 cells.
    assert path_length(astar(wall, (0, 0), (2, 0))) == pytest.approx(10.0)
    assert geodesic_distance(wall, (2, 0), 0.5)[0, 0] == pytest.approx(5.0)  # metres at 0.5 m


def test_astar_none_when_unreachable_or_blocked():
    split = _grid(
        """
        ..#..
        ..#..
        ..#..
        """
    )
    assert astar(split, (0, 0), (0, 4)) is None
    assert astar(split, (0, 2), (0, 4)) is None  # start blocked
    assert math.isinf(geodesic_distance(split, (0, 4), 1.0)[0, 0])
    # Two free cells touching only at a corner are not connected.
    corner = _grid(
        """
        .#
        #.
        """
    )
    assert astar(corner, (0, 0), (1, 1)) is None
    assert math.isinf(geodesic_distance(corner, (1, 1), 1.0)[0, 0])


def test_bad_arguments_are_clear_errors():
    with pytest.raises(ValueError, match="2-D bool"):
        astar(np.ones((3, 3), dtype=int), (0, 0), (1, 1))
    with pytest.raises(ValueError, match="outside the grid"):
        astar(np.ones((3, 3), dtype=bool), (0, 0), (3, 1))
    with pytest.raises(ValueError, match="connectivity"):
        geodesic_distance(np.ones((3, 3), dtype=bool), (0, 0), 1.0, connectivity=4)
    with pytest.raises(ValueError, match="resolution"):
        geodesic_distance(np.ones((3, 3), dtype=bool), (0, 0), 0.0)


def test_geodesic_sixteen_connected_is_closer_to_the_straight_line():
    free = np.ones((41, 41), dtype=bool)
    f8 = geodesic_distance(free, (0, 0), 1.0)
    f16 = geodesic_distance(free, (0, 0), 1.0, connectivity=16)
    assert f16[1, 2] == pytest.approx(math.sqrt(5.0))
    assert f8[1, 2] == pytest.approx(1.0 + SQ2)
    rows, cols = np.indices(free.shape)
    straight = np.hypot(rows, cols)
    assert (f16 <= f8 + 1e-9).all() and (f16 >= straight - 1e-9).all()
    assert (f8 / np.maximum(straight, 1))[1:, 1:].max() > 1.07  # 8-connected: up to 8.2 % long
    assert (f16 / np.maximum(straight, 1))[1:, 1:].max() < 1.03
    # Knight's moves do not pass a blocked cell they cross.
    free[0, 1] = free[1, 1] = False
    assert geodesic_distance(free, (0, 0), 1.0, connectivity=16)[1, 2] > math.sqrt(5.0) + 0.1


def test_snap_free_and_distance_field():
    free = _grid(
        """
        ######
        #....#
        ######
        """
    )
    assert snap_free(free, (1, 2)) == (1, 2)
    assert snap_free(free, (0, 1)) == (1, 1)
    assert snap_free(free, (2, 4)) == (1, 4)
    within = np.zeros_like(free)
    within[1, 3] = True
    assert snap_free(free, (1, 1), within=within) == (1, 3)
    assert snap_free(np.zeros((2, 2), dtype=bool), (0, 0)) is None
    m = occupancy("examples/nav_static_10m.json", resolution=0.1)
    free = ~m.inflated(ROBOT_RADIUS["wheeled"])
    cells = np.argwhere(free)
    goal_cell = tuple(int(v) for v in cells[len(cells) // 2])
    gx, gy = m.grid.centre(goal_cell)
    field = DistanceField.build(free, m.grid, (gx, gy))
    assert field.at(gx, gy) == pytest.approx(0.0)
    far = tuple(int(v) for v in cells[0])
    assert field.at(*m.grid.centre(far)) >= math.dist(m.grid.centre(far), (gx, gy)) - 1e-9
    # A point in the inflated band: the nearest reachable cell's distance plus the straight line.
    band = tuple(int(v) for v in np.argwhere(~free & m.walkable_mask())[0])
    near = snap_free(np.isfinite(field.distance), band)
    bx, by = m.grid.centre(band)
    expected = field.distance[near] + math.dist((bx, by), m.grid.centre(near))
    assert field.at(bx, by) == pytest.approx(expected)


def test_line_of_sight_and_shortcut():
    free = np.ones((3, 3), dtype=bool)
    free[0, 1] = False
    # The diagonal (0,0)->(2,2) passes exactly through the corner of the blocked cell (0,1).
    assert not line_of_sight(free, (0, 0), (2, 2))
    # (2,0)->(0,2) passes through the corner shared by (0,1), (0,2), (1,1) and (1,2).
    assert line_of_sight(free, (2, 0), (0, 2)) is False
    assert line_of_sight(free, (1, 0), (1, 2))
    assert line_of_sight(free, (2, 0), (2, 2))
    # An L-shaped corridor keeps its corner; an open grid collapses to the two ends.
    corridor = _grid(
        """
        .....
        ####.
        ####.
        """
    )
    path = astar(corridor, (0, 0), (2, 4))
    cut = shortcut(corridor, path)
    assert cut == [(0, 0), (0, 4), (2, 4)]
    assert cut[0] == (0, 0) and cut[-1] == (2, 4) and len(cut) < len(path)
    assert all(line_of_sight(corridor, a, b) for a, b in itertools.pairwise(cut))
    assert shortcut(np.ones((9, 9), dtype=bool), astar(np.ones((9, 9), dtype=bool), (0, 0), (3, 8))) == [
        (0, 0),
        (3, 8),
    ]


def test_path_to_world_gives_cell_centres():
    m = occupancy("examples/nav_static_10m.json", resolution=0.25)
    xy = path_to_world([(0, 0), (2, 3)], m)
    x0, y0 = m.origin
    assert xy.tolist() == [[x0 + 0.125, y0 + 0.125], [x0 + 0.875, y0 + 0.625]]


def test_pure_pursuit():
    path = np.array([[0.0, 0.0], [10.0, 0.0]])
    v, w = pure_pursuit((0.0, 0.0, 0.0), path, 0.5, 1.0, 1.5)
    assert v == pytest.approx(1.0) and w == pytest.approx(0.0, abs=1e-12)
    # Left of the path heading along it: steer right (negative yaw rate), slower.
    v, w = pure_pursuit((2.0, 0.2, 0.0), path, 0.5, 1.0, 1.5)
    assert w < 0 and 0 < v < 1.0
    # Target behind: turn on the spot towards it.
    v, w = pure_pursuit((2.0, 0.0, math.pi), path, 0.5, 1.0, 1.5)
    assert v == 0.0 and abs(w) == 1.5
    # Near the end: slow down linearly within slow_radius (1 m), and stop at it.
    v, _ = pure_pursuit((9.5, 0.0, 0.0), path, 0.5, 1.0, 1.5)
    assert v == pytest.approx(0.5)
    assert pure_pursuit((10.0, 0.0, 0.0), path, 0.5, 1.0, 1.5) == (0.0, 0.0)
    # A sharp corner ahead within the look-ahead: aim at the corner, not past it.
    corner = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 5.0]])
    _, w = pure_pursuit((0.8, 0.0, 0.0), corner, 1.0, 1.0, 10.0, corner_radius=0.1)
    assert w == pytest.approx(0.0, abs=1e-9)
    with pytest.raises(ValueError, match="lookahead"):
        pure_pursuit((0.0, 0.0, 0.0), path, 0.0, 1.0, 1.5)


def test_avoid_steers_around_a_disc_coming_head_on():
    pose = np.array([0.0, 0.0, 0.0])
    other, other_vel, dt = np.array([4.0, 0.0]), np.array([-0.8, 0.0]), 0.1
    # Nothing in the way: the desired command comes back unchanged.
    assert avoid(pose, 1.0, 0.2, np.array([[0.0, 8.0]]), np.zeros((1, 2)), 0.3, 0.35, 2.0) == (1.0, 0.2)
    first = avoid(pose, 1.0, 0.0, other[None], other_vel[None], 0.3, 0.35, 2.0, max_speed=1.0)
    assert first != (1.0, 0.0)
    closest = math.inf
    for _ in range(60):
        goal_heading = math.atan2(-pose[1], 6.0 - pose[0])  # keep heading back to the x axis
        w_des = float(
            np.clip(2.0 * ((goal_heading - pose[2] + math.pi) % (2 * math.pi) - math.pi), -1.5, 1.5)
        )
        v, w = avoid(pose, 1.0, w_des, other[None], other_vel[None], 0.3, 0.35, 2.0, max_speed=1.0)
        pose += (v * math.cos(pose[2]) * dt, v * math.sin(pose[2]) * dt, w * dt)
        other = other + other_vel * dt
        closest = min(closest, math.dist(pose[:2], other))
    assert closest > 0.3 + 0.35
    assert pose[0] > other[0] + 1.0  # it got past the agent


def _unicycle_run(planner: Planner, start, yaw, goal, tolerance):
    pose = np.array([start[0], start[1], yaw])
    dt, entered = 0.05, 0
    for _ in range(3000):
        v, w = planner.command(pose)
        pose += (v * math.cos(pose[2]) * dt, v * math.sin(pose[2]) * dt, w * dt)
        entered += not bool(planner.free_at(pose[0], pose[1]))
        if math.dist(pose[:2], goal) < tolerance / 4 and v == 0.0:
            break
    return pose, entered


@pytest.mark.parametrize("index", range(5))
def test_planner_on_urban_nav_test_scenes(index):
    scene = citygen.generate("urban-nav-2-test", index=index)
    task = scene.task
    m = occupancy(scene, 0.05)
    radius = ROBOT_RADIUS["wheeled"]
    free = ~m.inflated(radius)
    start, goal = task.start.position, task.goal
    cells = astar(free, snap_free(free, m.cell(*start)), snap_free(free, m.cell(*goal)))
    assert cells is not None
    assert all(free[c] for c in cells)
    planner = Planner(m, radius)
    assert (planner.free == free).all()
    xy = planner.plan(start, goal)
    assert xy is not None
    # The smoothed path stays on free cells (sampled every 1 cm) and is no longer than A*'s.
    for a, b in itertools.pairwise(xy):
        t = np.linspace(0.0, 1.0, max(2, int(math.dist(a, b) / 0.01)))[:, None]
        pts = a + t * (b - a)
        assert planner.free_at(pts[:, 0], pts[:, 1]).all()
    assert path_length(xy) <= path_length(cells) * m.resolution * 1.05
    pose, entered = _unicycle_run(planner, start, task.start.yaw, goal, task.goal_tolerance)
    assert math.dist(pose[:2], goal) < task.goal_tolerance
    assert entered == 0


def test_planner_replans_when_off_the_path():
    scene = citygen.generate("urban-nav-2-test", index=0)
    m = occupancy(scene, 0.05)
    planner = Planner(m, ROBOT_RADIUS["wheeled"])
    with pytest.raises(ValueError, match="plan"):
        planner.command((0.0, 0.0, 0.0))
    task = scene.task
    planner.plan(task.start.position, task.goal)
    # Teleported to another free cell far from the path: the next command plans again.
    path = planner.path.copy()
    cells = np.argwhere(planner.free)
    xy = np.array([m.grid.centre(tuple(int(v) for v in c)) for c in cells[:: max(1, len(cells) // 500)]])
    d = np.min(np.hypot(xy[:, None, 0] - path[None, :, 0], xy[:, None, 1] - path[None, :, 1]), axis=1)
    away = xy[int(np.argmax(d))]
    planner.command((away[0], away[1], 0.0))
    assert planner.replans == 1
    assert math.dist(planner.path[0], away) < 0.1


def _plaza(
    width: float, height: float, walls: tuple[tuple[float, float, float, float], ...] = ()
) -> OccupancyMap:
    """A sidewalk rectangle of ``width`` x ``height`` m at 0.05 m, with building boxes
    ``(x0, y0, x1, y1)``."""
    grid = Grid.covering((0.0, 0.0, width, height), 0.05)
    labels = np.full(grid.shape, CLASSES.index("sidewalk"), dtype=np.uint8)
    xs, ys = grid.xs(), grid.ys()
    for x0, y0, x1, y1 in walls:
        labels[np.ix_((ys >= y0) & (ys <= y1), (xs >= x0) & (xs <= x1))] = CLASSES.index("building")
    return OccupancyMap(labels, np.zeros(grid.shape, np.float32), np.zeros(grid.shape, np.uint8), grid)


def _drive(planner: Planner, pose, goal, agent, steps=1500):
    pose, dt, closest = np.array(pose, dtype=np.float64), 0.05, math.inf
    for _ in range(steps):
        v, w = planner.command(pose, np.array([agent]), np.zeros((1, 2)), 0.3)
        pose += (v * math.cos(pose[2]) * dt, v * math.sin(pose[2]) * dt, w * dt)
        closest = min(closest, math.dist(pose[:2], agent))
        assert planner.free_at(pose[0], pose[1])
        if math.dist(pose[:2], goal) < 0.05 and v == 0.0:
            break
    return pose, closest


def test_planner_goes_around_a_standing_agent():
    planner = Planner(_plaza(8.0, 4.0), ROBOT_RADIUS["wheeled"])
    planner.plan((1.0, 2.0), (7.0, 2.0))
    assert len(planner.path) == 2  # straight through where the agent will stand
    pose, closest = _drive(planner, (1.0, 2.0, 0.0), (7.0, 2.0), (4.0, 2.0))
    assert math.dist(pose[:2], (7.0, 2.0)) < 0.05
    assert closest > 0.3 + ROBOT_RADIUS["wheeled"]
    assert planner.replans >= 1 and len(planner.path) > 2


def test_planner_waits_when_an_agent_closes_the_only_way():
    # A 1 m gap in a wall across the plaza, with an agent standing in it.
    walls = ((3.5, 0.0, 4.5, 1.5), (3.5, 2.5, 4.5, 4.0))
    planner = Planner(_plaza(8.0, 4.0, walls), ROBOT_RADIUS["wheeled"])
    assert planner.plan((1.0, 2.0), (7.0, 2.0)) is not None
    pose, closest = _drive(planner, (1.0, 2.0, 0.0), (7.0, 2.0), (4.0, 2.0), steps=400)
    assert pose[0] < 3.5 and closest > 0.3 + ROBOT_RADIUS["wheeled"]
    assert math.dist(planner.path[-1], (7.0, 2.0)) < 1e-9  # still heading for the goal


def test_farthest_visible_is_the_last_segment_visible_tests_one_at_a_time():
    """The batched line-of-sight test of the taut path (SPL's shortest path) finds the same
    farthest point in sight as testing each segment with ``_visible``, on random obstacles,
    with points inside and outside the grid and batches of more than one pass."""
    from citygen.runner.control.regions import _SIGHT_BATCH, _farthest_visible, _visible

    rng = np.random.default_rng(7)
    grid = Grid(-1.0, 2.0, 0.05, 80, 120)
    agreed = found = 0
    for trial in range(60):
        free = rng.random((grid.rows, grid.cols)) > (0.002 if trial % 2 else 0.0005)
        pts = rng.uniform((-1.5, 1.5), (5.5, 6.5), size=(2 * _SIGHT_BATCH + 5, 2))
        a = pts[0]
        first = int(rng.integers(1, 6))
        naive = next((j for j in range(len(pts) - 1, first - 1, -1) if _visible(free, grid, a, pts[j])), None)
        assert _farthest_visible(free, grid, a, pts, first) == naive
        agreed += 1
        found += naive is not None
    assert agreed == 60 and 0 < found < 60  # both outcomes met


def test_components_are_the_graph_searchs_regions_without_corner_cutting():
    """``components`` labels as a graph search over the free cells' 8-neighbour steps with no
    corner cutting labels (the same numbers, row-major by first cell), on random masks and
    on a diagonal pair that must stay apart."""
    import scipy.sparse.csgraph

    from citygen.geometry.raster import _graph, components

    rng = np.random.default_rng(3)
    for _ in range(200):
        free = rng.random((int(rng.integers(1, 40)), int(rng.integers(1, 40)))) < rng.uniform(0.3, 0.8)
        want = np.zeros(free.shape, dtype=np.int32)
        count = 0
        if free.any():
            count, parts = scipy.sparse.csgraph.connected_components(_graph(free)[0], directed=False)
            want[free] = parts + 1
        labels, n = components(free)
        assert n == count and labels.dtype == np.int32 and np.array_equal(labels, want)
    labels, n = components(_grid(".# #."))
    assert n == 2 and labels[0, 0] != labels[1, 1]
