"""The URBAN-BENCH metrics against small episodes computed by hand."""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest

from citygen.runner.metrics import (
    G,
    LocoEpisode,
    NavEpisode,
    TraverseEpisode,
    format_table,
    loco_metrics,
    nav_metrics,
    summarise,
    traverse_metrics,
)


def _nav(start, best, steps, *, success, left, route=None):
    ep = NavEpisode(start_xy=start, best_length=best, route_length=route)
    for xy, walkable, collision in steps:
        ep.record_step(xy, walkable=walkable, collision=collision)
    ep.finish(success=success, distance_left=left)
    return ep


# Success, 4 steps of 1 m each (driven 4 m), shortest path 3 m.
NAV_A = _nav(
    (0.0, 0.0),
    3.0,
    [
        ((1.0, 0.0), True, False),
        ((2.0, 0.0), True, True),
        ((2.0, 1.0), False, False),
        ((3.0, 1.0), True, False),
    ],
    success=True,
    left=0.3,
)
# Failure after 3 steps with 2 m of a 5 m route left.
NAV_B = _nav(
    (0.0, 0.0),
    4.0,
    [((0.5, 0.0), True, True), ((1.0, 0.0), True, True), ((1.0, 0.0), True, False)],
    success=False,
    left=2.0,
    route=5.0,
)


def test_nav_metrics_success_episode():
    m = nav_metrics(NAV_A)
    assert m["success_rate"] == 100.0
    assert m["route_completion"] == 100.0  # success: the goal counts as reached
    assert m["spl"] == pytest.approx(3.0 / 4.0)  # s * L_best / max(l_moving, L_best)
    assert m["on_walkable"] == pytest.approx(75.0)  # 3 of 4 steps
    assert m["collision"] == pytest.approx(0.25)  # 1 of 4 steps


def test_nav_metrics_failed_episode():
    m = nav_metrics(NAV_B)
    assert m["success_rate"] == 0.0
    assert m["route_completion"] == pytest.approx(60.0)  # (5 - 2) / 5
    assert m["spl"] == 0.0
    assert m["on_walkable"] == pytest.approx(100.0)
    assert m["collision"] == pytest.approx(2.0 / 3.0)


def test_route_completion_is_clipped_and_spl_at_most_one():
    # Ended farther from the goal than it started: no progress, not a negative one.
    lost = _nav((0.0, 0.0), 5.0, [((-1.0, 0.0), True, False)], success=False, left=7.0)
    assert nav_metrics(lost)["route_completion"] == 0.0
    # Drove a shorter line than the shortest walkable path (across a lawn): SPL caps at 1.
    short = _nav(
        (0.0, 0.0), 5.0, [((2.0, 0.0), False, False), ((4.0, 0.0), False, False)], success=True, left=0.4
    )
    assert nav_metrics(short)["spl"] == 1.0
    # The route length defaults to the shortest path's.
    half = _nav((0.0, 0.0), 4.0, [((1.0, 0.0), True, False)], success=False, left=1.0)
    assert nav_metrics(half)["route_completion"] == pytest.approx(75.0)


def test_loco_metrics_fallen_episode():
    ep = LocoEpisode(start_xy=(0.0, 0.0), target_heading=0.0, dt=0.5, t_start=1.0)
    ep.record_step((0.5, 0.1), [0.0, 0.0])
    ep.record_step((1.0, 0.2), [3.0, 4.0])
    ep.record_step((1.5, 0.2), [3.0, 4.0], fallen=True)
    ep.record_step((2.0, 0.4), [0.0, 0.0])  # after the fall: ignored
    ep.finish()
    m = loco_metrics(ep)
    assert m["balance"] == 0.0
    assert m["x_displacement"] == pytest.approx(1.5)  # fall position . (cos 0, sin 0)
    assert m["ttf"] == pytest.approx(1.5)  # fell at 1.0 + 3 * 0.5 s
    assert m["smoothness"] == pytest.approx((5.0 + 0.0) / 3)  # ||(3, 4) - (0, 0)|| + 0, over 3 steps
    assert ep.fall_xy == (1.5, 0.2)


def test_loco_metrics_balanced_episode():
    ep = LocoEpisode(start_xy=(1.0, 1.0), target_heading=math.pi / 4, dt=0.02)
    for xy, tau in (((1.5, 1.5), [1.0, -2.0]), ((2.0, 2.0), [1.0, 0.0])):
        ep.record_step(xy, tau)
    ep.finish()
    m = loco_metrics(ep)
    assert m["balance"] == 100.0
    assert m["x_displacement"] == pytest.approx(math.sqrt(2.0))  # (1, 1) along 45 degrees
    assert m["ttf"] == pytest.approx(0.04)  # to the episode's end
    assert m["smoothness"] == pytest.approx(2.0 / 2)
    # Sideways to the command: no displacement along it.
    side = LocoEpisode(start_xy=(0.0, 0.0), target_heading=math.pi / 2, dt=0.1)
    side.record_step((3.0, 0.0), [0.0])
    side.finish()
    assert loco_metrics(side)["x_displacement"] == pytest.approx(0.0, abs=1e-12)


def _traverse():
    ep = TraverseEpisode(start_xy=(0.0, 0.0), dt=0.1, mass=10.0)
    ep.record_step(
        (1.0, 0.0), torques=[2.0, -1.0], joint_velocities=[1.0, 1.0], body_speed=1.0, intervene=True
    )
    ep.record_step(
        (2.0, 0.0), torques=[1.0, 1.0], joint_velocities=[3.0, -1.0], body_speed=2.0, collision=True
    )
    ep.record_step(
        (0.0, 0.0), torques=[5.0, 5.0], joint_velocities=[5.0, 5.0], body_speed=0.05,
        intervene=True, reset=True, collision=True,
    )  # fmt: skip
    ep.record_step(
        (0.5, 0.0), torques=[0.0, 4.0], joint_velocities=[0.0, 0.5], body_speed=0.5, intervene=True
    )
    ep.finish()
    return ep


def test_traverse_metrics():
    m = traverse_metrics(_traverse())
    assert m["attempts"] == 1.0
    assert m["labor_cost"] == pytest.approx(0.3)  # 3 steps of 0.1 s
    assert m["interventions"] == 2.0  # takeovers at steps 1 and 3
    assert m["collision_times"] == 2.0
    # 1 + 1 + (reset: 0) + 0.5 m over 4 steps of 0.1 s.
    assert m["speed"] == pytest.approx(2.5 / 0.4)
    # Positive power / (m g v) at the steps moving at >= 0.1 m/s: 2/(98.1*1), 3/(98.1*2), 2/(98.1*0.5).
    assert m["mcot"] == pytest.approx((2.0 / 1.0 + 3.0 / 2.0 + 2.0 / 0.5) / (10.0 * G) / 3)


def test_mcot_is_nan_standing_still_and_summarise_leaves_it_out():
    ep = TraverseEpisode(start_xy=(0.0, 0.0), dt=0.1, mass=5.0)
    ep.record_step((0.0, 0.0), torques=[1.0], joint_velocities=[1.0], body_speed=0.0)
    ep.finish()
    still = traverse_metrics(ep)
    assert math.isnan(still["mcot"]) and still["speed"] == 0.0
    summary = summarise([still, traverse_metrics(_traverse())])
    assert summary["mcot"]["n"] == 1 and summary["mcot"]["sem"] == 0.0
    assert summary["speed"]["n"] == 2


def test_summarise_mean_and_standard_error():
    summary = summarise([nav_metrics(NAV_A), nav_metrics(NAV_B)])
    assert list(summary) == ["success_rate", "route_completion", "spl", "on_walkable", "collision"]
    # [100, 0]: mean 50, sample sd 70.71, sem 70.71 / sqrt(2) = 50.
    assert summary["success_rate"] == {"mean": 50.0, "sem": pytest.approx(50.0), "n": 2}
    # [100, 60]: mean 80, sample sd 28.28, sem 20.
    assert summary["route_completion"]["mean"] == pytest.approx(80.0)
    assert summary["route_completion"]["sem"] == pytest.approx(20.0)
    # [1/4, 2/3]: sem = |a - b| / 2.
    assert summary["collision"]["sem"] == pytest.approx((2 / 3 - 1 / 4) / 2)
    one = summarise([{"spl": 0.4}])
    assert one["spl"] == {"mean": 0.4, "sem": 0.0, "n": 1}
    assert summarise([]) == {}


def test_format_table_prints_the_papers_units():
    text = format_table(summarise([nav_metrics(NAV_A), nav_metrics(NAV_B)]), "NavStatic wheeled planner")
    lines = text.splitlines()
    assert lines[0] == "NavStatic wheeled planner"
    body = {line.split("  ")[0].strip(): line for line in lines[3:]}
    assert set(body) == {
        "Success Rate (%)", "Route Completion (%)", "SPL", "On Walkable Region (%)", "Collision",
    }  # fmt: skip
    assert "50.00 ± 50.00" in body["Success Rate (%)"]
    assert "80.00 ± 20.00" in body["Route Completion (%)"]
    assert body["SPL"].split()[1:3] == ["0.38", "±"]  # mean of [0.75, 0]
    assert body["SPL"].endswith("  2")


def test_bad_episodes_are_clear_errors():
    with pytest.raises(ValueError, match="best_length"):
        NavEpisode(start_xy=(0.0, 0.0), best_length=0.0)
    with pytest.raises(ValueError, match="start_xy"):
        NavEpisode(start_xy=(math.nan, 0.0), best_length=1.0)
    unfinished = NavEpisode(start_xy=(0.0, 0.0), best_length=1.0)
    unfinished.record_step((1.0, 0.0), walkable=True, collision=False)
    with pytest.raises(ValueError, match="not finished"):
        nav_metrics(unfinished)
    empty = NavEpisode(start_xy=(0.0, 0.0), best_length=1.0)
    empty.finish(success=False, distance_left=1.0)
    with pytest.raises(ValueError, match="no steps"):
        nav_metrics(empty)
    with pytest.raises(ValueError, match="distance_left"):
        empty.finish(success=False, distance_left=-1.0)
    with pytest.raises(ValueError, match="dt"):
        LocoEpisode(start_xy=(0.0, 0.0), target_heading=0.0, dt=0.0)
    loco = LocoEpisode(start_xy=(0.0, 0.0), target_heading=0.0, dt=0.1)
    loco.record_step((0.0, 0.0), [1.0, 2.0])
    with pytest.raises(ValueError, match="expected 2 torques"):
        loco.record_step((0.0, 0.0), [1.0])
    tra = TraverseEpisode(start_xy=(0.0, 0.0), dt=0.1, mass=1.0)
    with pytest.raises(ValueError, match="joint velocities"):
        tra.record_step((0.0, 0.0), torques=[1.0, 2.0], joint_velocities=[1.0], body_speed=0.0)
    with pytest.raises(ValueError, match="mass"):
        TraverseEpisode(start_xy=(0.0, 0.0), dt=0.1, mass=-1.0)


# --- SPL's shortest path on a hand-made map ---------------------------------------------------

RES = 0.05


def _wall_map():
    """10 m x 10 m at 5 cm, a wall from x = 0 to 7 m between y = 4.9 and 5.1 m (on cell
    edges), the goal region a 0.5 m disc around (1, 8): the way from (1, 2) goes round the
    wall's free end, so the exact Euclidean geodesic is start -> (7, 4.9) -> (7, 5.1) -> the
    disc."""
    from citygen.geometry.raster import Grid

    grid = Grid(0.0, 0.0, RES, 200, 200)
    free = np.ones(grid.shape, dtype=bool)
    free[98:102, :140] = False
    return grid, free


def _polyline(points, step=RES):
    """Points every ``step`` metres along straight legs through ``points`` (first excluded)."""
    out = []
    for a, b in itertools.pairwise(points):
        n = max(1, math.ceil(math.dist(a, b) / step))
        out += [(a[0] + (b[0] - a[0]) * k / n, a[1] + (b[1] - a[1]) * k / n) for k in range(1, n + 1)]
    return out


def test_the_distance_left_from_a_cell_touching_the_goal_region_is_the_way_onto_the_disc():
    """A robot stopped just outside the tolerance, in a cell the region's field already
    counts as 0, has the metres onto the disc left (was an IndexError ending a bench run)."""
    from citygen.runner.control.regions import region_distance, region_path_length

    grid, free = _wall_map()
    goal, tol = (1.0, 8.0), 0.5
    field = region_distance(free, grid, goal, tol)
    starts = []
    for r, c in zip(*np.nonzero(field == 0.0), strict=True):
        cx, cy = grid.centre((int(r), int(c)))
        for dx in (-0.49, 0.49):
            for dy in (-0.49, 0.49):
                xy = (cx + dx * RES, cy + dy * RES)
                if math.dist(xy, goal) > tol + 1e-3 and grid.cell(*xy) == (r, c):
                    starts.append(xy)
    assert starts, "no point outside the disc in a cell the field counts as inside"
    for start in starts[:8]:
        left = region_path_length(free, grid, field, start, goal, tol)
        assert left == pytest.approx(math.dist(start, goal) - tol, abs=1e-9)


def test_spl_shortest_path_is_the_any_angle_geodesic_to_the_goal_region():
    from citygen.runner.control.fields import DistanceField
    from citygen.runner.control.regions import region_distance

    grid, free = _wall_map()
    goal, tol = (1.0, 8.0), 0.5
    start = grid.centre(grid.cell(1.0, 2.0))
    a, b = (7.0, 4.9), (7.0, 5.1)
    exact = math.dist(start, a) + 0.2 + math.dist(b, goal) - tol
    field = region_distance(free, grid, goal, tol)
    assert field[grid.cell(*goal)] == 0.0 and math.isinf(field[99, 10])  # inside the wall
    assert field[grid.cell(*start)] == pytest.approx(exact, rel=0.01)  # fast marching: a little over
    best = DistanceField.build(free, grid, goal, tolerance=tol).route(*start)
    assert best == pytest.approx(exact, abs=RES / 4)
    # The 8-connected grid path to the goal's centre, the old L*_best: much longer.
    assert DistanceField.build(free, grid, goal, connectivity=8).at(*start) > exact + tol + 0.3

    # An agent driving the geodesic (into the disc, where success fires) scores SPL ~1 ...
    f = 1 - tol / math.dist(b, goal)
    entry = (b[0] + (goal[0] - b[0]) * f, b[1] + (goal[1] - b[1]) * f)
    ep = NavEpisode(start_xy=start, best_length=best)
    for xy in _polyline([start, a, b, entry]):
        ep.record_step(xy, walkable=True, collision=False)
    ep.finish(success=True, distance_left=0.0)
    assert nav_metrics(ep)["spl"] == pytest.approx(1.0, abs=0.01)
    # ... and a detour along the map's edge less, by the ratio of the lengths.
    detour = NavEpisode(start_xy=start, best_length=best)
    legs = [start, (9.5, 2.0), (9.5, 8.0), (goal[0] + tol, goal[1])]
    for xy in _polyline(legs):
        detour.record_step(xy, walkable=True, collision=False)
    detour.finish(success=True, distance_left=0.0)
    driven = sum(math.dist(p, q) for p, q in itertools.pairwise(legs))
    assert nav_metrics(detour)["spl"] == pytest.approx(best / driven, rel=1e-6)
    assert nav_metrics(detour)["spl"] < 0.8


def test_spl_geodesic_around_an_l_shaped_corridor():
    """An L-shaped corridor 1 m wide: the geodesic hugs the inner corner (2, 2)."""
    from citygen.geometry.raster import Grid
    from citygen.runner.control.fields import DistanceField

    grid = Grid(0.0, 0.0, RES, 100, 100)  # 5 m x 5 m
    free = np.zeros(grid.shape, dtype=bool)
    free[20:40, :] = True  # y in [1, 2]: the horizontal arm
    free[:, 20:40] = True  # x in [1, 2]: the vertical arm
    free[20:40, :20] = False  # the arms meet at x, y in [1, 2]: an L
    free[:20, 20:40] = False
    start = grid.centre(grid.cell(4.5, 1.5))
    goal, tol = (1.5, 4.5), 0.3
    corner = (2.0, 2.0)
    exact = math.dist(start, corner) + math.dist(corner, goal) - tol
    field = DistanceField.build(free, grid, goal, tolerance=tol)
    assert field.route(*start) == pytest.approx(exact, abs=RES / 4)
    assert field.at(*start) == pytest.approx(exact, rel=0.01)
    assert math.isinf(field.distance[grid.cell(4.5, 4.5)])  # not free
