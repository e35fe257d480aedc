"""The URBAN-BENCH metrics against small episodes computed by hand."""

from __future__ import annotations

import math

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
