"""The Traverse task with its defaults, on stretches of the Urban-Tra-Standard track.

The full track is 1,200 m (``citygen bench --task traverse --policy ai``, minutes); these
tests run short routes cut from it, through the terrain and the agents that stopped the
defaults before (the stairs up from the even units, a crest between two slopes, the
dynamic uneven unit), so that CI sees the same class of failure in under a minute.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import citygen
from citygen.runner.bench import run_episode
from citygen.runner.make import make_env
from citygen.runner.metrics import TraverseEpisode, traverse_metrics
from citygen.runner.policies import make_policy
from citygen.spec.blocks import Pose2


@pytest.fixture(scope="module")
def track():
    return citygen.generate("urban-tra-standard", index=0)


def _stretch(scene, start: tuple[float, float], route: list[tuple[float, float]], time_limit: float):
    """The track with its traverse task cut to ``route`` from ``start`` (facing the route)."""
    yaw = math.atan2(route[0][1] - start[1], route[0][0] - start[0])
    task = scene.task.model_copy(
        update={"start": Pose2(position=start, yaw=yaw), "route": tuple(route), "time_limit": time_limit}
    )
    return scene.model_copy(update={"task": task})


def test_default_robot_is_the_tracks_quadruped(track):
    env = make_env("traverse", track)
    assert env.robot.name == track.task.robot == "quadruped"


@pytest.mark.slow
def test_the_planner_climbs_the_stairs_and_crosses_the_uneven_units(track):
    # Up the 17 cm stairs at the start of unit 4 (x = 60 m), over rough tiles, up the second
    # flight and down the slopes beyond: the quadruped's ideal locomotion stalled at the first
    # riser and the wheeled robot cannot climb it. (The planner: the ai mode's learned
    # navigator and its recovery take their time, see the full track in docs/training.md.)
    scene = _stretch(track, (56.0, 2.5), [(66.0, 2.5), (76.0, 2.5), (86.0, 2.5)], time_limit=60.0)
    env = make_env("traverse", scene)
    heights = []

    def base_height(e, t):
        heights.append(e.unwrapped.handle.pose(e.unwrapped.data)[2])

    result = run_episode(env, make_policy("planner"), seed=0, on_step=base_height)
    assert result["success_rate"] == 100.0, result
    assert result["route_completion"] == 100.0
    assert result["attempts"] == 0.0
    assert max(heights) - min(heights) > 0.9  # it climbed the two flights (1.03 m)
    assert env.progress["done"] == 1.0 and env.progress["waypoints"] == 3


@pytest.mark.slow
def test_the_planner_passes_a_crest_between_two_slopes(track):
    # The waypoint (94.5, 7.5) of the fourth lap's way back lies on a ridge where two slopes
    # meet; the feet used to drag on it and the robot stood still until reset, forever.
    scene = _stretch(track, (99.0, 7.5), [(94.5, 7.5), (91.0, 7.5)], time_limit=30.0)
    result = run_episode(make_env("traverse", scene), make_policy("planner"), seed=0)
    assert result["success_rate"] == 100.0, result
    assert result["attempts"] == 0.0


def test_a_reset_on_the_crest_stands_the_robot_on_the_ground_and_it_walks_on(track):
    # A failed attempt puts the robot back at its last waypoint. On the crest at (94.5, 7.5)
    # it used to be set at the ground under its base: its hind feet sank 2.5 cm into the
    # higher slope behind, and the learned AI's planner fallback stood there for 125 attempts.
    from citygen.runner.envs import STUCK_SECONDS

    scene = _stretch(track, (99.0, 7.5), [(94.5, 7.5), (91.0, 7.5), (71.5, 7.5)], time_limit=60.0)
    env = make_env("traverse", scene)
    env.reset(seed=0)
    u = env.unwrapped
    u.waypoint, u._anchor, u._best = 1, ((94.5, 7.5), math.pi), 0.0  # no progress for too long:
    u._since_progress = STUCK_SECONDS + 1.0  # the next step fails the attempt
    forward = np.array([1.0, 0.0], dtype=np.float32)
    info = env.step(forward)[-1]
    assert info["attempts"] == 1
    x0 = u.handle.pose(u.data)[0]
    assert x0 == pytest.approx(94.5, abs=0.05)
    n = u.data.ncon
    g1, g2, dist = u.data.contact.geom1[:n], u.data.contact.geom2[:n], u.data.contact.dist[:n]
    robot, ground = u._robot_geoms, u.prepared.ground_geoms
    inside = ((robot[g1] & ground[g2]) | (robot[g2] & ground[g1])) & (dist < -1e-3)
    assert not inside.any(), dist[inside]
    for _ in range(30):
        info = env.step(forward)[-1]
    assert info["attempts"] == 1
    assert x0 - u.handle.pose(u.data)[0] > 0.5  # it walked on towards the next waypoint


@pytest.mark.slow
def test_human_oracle_needs_no_more_attempts_than_ai(track):
    # The dynamic uneven unit: people, cyclists and scooters on slopes, stairs and rough tiles.
    scene = _stretch(track, (99.0, 2.5), [(108.0, 2.5), (117.5, 2.5), (117.5, 7.5)], time_limit=120.0)
    rows = {}
    for mode in ("ai", "human"):
        rows[mode] = run_episode(make_env("traverse", scene), make_policy(mode), seed=0)
        assert rows[mode]["success_rate"] == 100.0, (mode, rows[mode])
    assert rows["human"]["attempts"] <= rows["ai"]["attempts"]
    assert rows["human"]["labor_cost"] == pytest.approx(rows["human"]["time"], rel=1e-6)
    assert rows["ai"]["labor_cost"] == 0.0


def test_traverse_metrics_time_is_the_runs_duration():
    ep = TraverseEpisode(start_xy=(0.0, 0.0), dt=0.1, mass=10.0)
    for k in range(7):
        ep.record_step((0.1 * k, 0.0), torques=[1.0], joint_velocities=[1.0], body_speed=1.0)
    ep.finish()
    assert traverse_metrics(ep)["time"] == pytest.approx(0.7)
    assert np.isfinite(traverse_metrics(ep)["speed"])


def test_the_ai_sub_goal_runs_ahead_along_the_route_up_to_the_next_waypoint():
    from citygen.runner.policies import carrot

    route = [(0.0, 0.0), (10.0, 0.0), (10.0, 10.0)]
    assert np.allclose(carrot(route, 1, (2.0, 0.5), 6.0), (8.0, 0.0))  # on the first leg
    # near the corner: the waypoint itself (it counts only within its tolerance), not past it
    assert np.allclose(carrot(route, 1, (8.0, -0.3), 6.0), (10.0, 0.0))
    assert np.allclose(carrot(route, 2, (10.0, 1.0), 6.0), (10.0, 7.0))  # the next leg
    assert np.allclose(carrot(route, 2, (10.0, 8.0), 6.0), (10.0, 10.0))  # the route's end
    assert np.allclose(carrot(route, 0, (-3.0, 0.0), 6.0), (0.0, 0.0))  # the first waypoint


def test_the_ai_drives_the_robots_shipped_learned_navigator_else_the_planner(monkeypatch, tmp_path):
    from citygen.runner import policies
    from citygen.runner.learn import policy as learned

    assert isinstance(policies.traverse_ai("no-such-robot"), policies.PlannerPolicy)
    # the quadruped's track is driven by its shipped NavStatic baseline
    ai = policies.traverse_ai("quadruped")
    assert isinstance(ai, policies.LearnedNavigator)
    assert ai.path == str(learned.shipped()[("nav-static", "quadruped")])
    some = next(iter(learned.shipped().values()))
    monkeypatch.setattr(
        learned, "shipped", lambda locomotion="servo": {("nav-static", "wheeled_legged"): some}
    )
    # a shipped baseline drives the traverse only once it is named for the robot's track
    assert isinstance(policies.traverse_ai("wheeled_legged"), policies.PlannerPolicy)
    monkeypatch.setitem(policies.TRAVERSE_AI, "wheeled_legged", "nav-static")
    ai = policies.traverse_ai("wheeled_legged")
    assert isinstance(ai, policies.LearnedNavigator) and ai.path == str(some)


def test_a_learned_model_given_on_a_traverse_drives_its_ai_mode(track):
    """``--policy FILE.npz`` on a traverse: the ai mode with that model as its navigator,
    which steers the quadruped along the track towards its next waypoint."""
    from citygen.runner import policies
    from citygen.runner.learn.policy import shipped

    model = str(shipped()[("nav-clear", "quadruped")])
    policy = make_policy(model, task="traverse")
    assert isinstance(policy, policies.ControlMode) and isinstance(policy.ai, policies.LearnedNavigator)
    assert policy.ai.path == model and policy.threshold == policies.MODES["ai"]
    assert not isinstance(make_policy(model, task="nav-static"), policies.ControlMode)
    scene = _stretch(track, (2.5, 2.5), [(12.5, 2.5), (22.5, 2.5)], time_limit=6.0)
    env = make_env("traverse", scene)
    xs = []

    def x(e, t):
        xs.append(e.unwrapped.handle.pose(e.unwrapped.data)[0])

    result = run_episode(env, policy, seed=0, on_step=x)
    assert policy.ai.env is env.unwrapped and not policy.human  # the learned navigator drove
    assert result["labor_cost"] == 0.0 and result["steps"] == 60
    assert xs[-1] - 2.5 > 3.0  # it went along the route, forwards (6 s at up to 1 m/s)


def test_the_ai_sub_goal_follows_a_path_around_what_blocks_the_straight_leg(monkeypatch):
    """With the map guide the learned navigator steers round a wall across the leg to the
    next waypoint; the route guide points it into the wall."""
    from types import SimpleNamespace

    from citygen.exporters.occupancy import CLASSES, OccupancyMap
    from citygen.geometry.raster import Grid
    from citygen.runner import policies
    from citygen.runner.control.pursuit import point_ahead
    from citygen.runner.learn import policy as learned

    grid = Grid.covering((0.0, 0.0, 20.0, 10.0), 0.05)
    labels = np.full(grid.shape, CLASSES.index("sidewalk"), dtype=np.uint8)
    xs, ys = grid.xs(), grid.ys()
    wall = np.ix_(ys <= 7.0, (xs >= 9.0) & (xs <= 10.0))  # a wall with a gap at the top
    labels[wall] = CLASSES.index("building")
    occ = OccupancyMap(labels, np.zeros(grid.shape, np.float32), np.zeros(grid.shape, np.uint8), grid)
    route = [(2.0, 3.0), (17.0, 3.0)]
    env = SimpleNamespace(
        prepared=SimpleNamespace(occupancy=occ, free=None),
        robot=SimpleNamespace(radius=0.3, max_speed=1.0, max_yaw_rate=1.5),
        route=route,
        waypoint=1,
        _goal=lambda: route[1],
        dt=0.1,
        np_random=np.random.default_rng(0),
    )
    env.prepared.free = ~occ.inflated(0.3)
    some = str(next(iter(learned.shipped().values())))
    nav = policies.LearnedNavigator(some)
    nav.reset(env)
    x, y = 4.0, 3.0
    gx, gy = nav.subgoal(x, y)
    assert gy > 3.5 and gx < 9.0  # up towards the gap, not at the wall
    assert math.dist((x, y), (gx, gy)) == pytest.approx(policies.CARROT, abs=0.05)
    # through the gap: still on the path, now heading down to the waypoint
    gx, gy = nav.subgoal(9.5, 7.6)
    assert gx > 10.0
    # off the path by more than the planner's replan distance: planned again from there
    before = nav.planner.path
    nav.subgoal(4.0, 1.0)
    assert nav.planner.path is not before and math.dist(nav.planner.path[0], (4.0, 1.0)) < 0.1
    route_nav = policies.LearnedNavigator(some, guide="route")
    route_nav.reset(env)
    assert np.allclose(route_nav.subgoal(x, y), (10.0, 3.0))  # straight into the wall
    assert np.allclose(point_ahead(np.array([[0.0, 0.0], [1.0, 0.0]]), (0.2, 0.3), 5.0), (1.0, 0.0))
    with pytest.raises(ValueError, match="guide"):
        policies.LearnedNavigator(some, guide="gps")
    # wedged: under 0.15 m in 2 s is stuck; walking on at 0.5 m/s is not; a reset starts over
    steps = round(policies.STUCK[0] / env.dt)
    assert not any(nav.stuck(4.0 + 0.05 * k, 3.0) for k in range(3 * steps))
    assert [nav.stuck(9.0 + 0.001 * k, 3.0) for k in range(steps + 1)][-1]
    assert not nav.stuck(2.0, 3.0)  # put back at the last waypoint
    # after HANDOVER failed attempts at one stretch the planner drives it
    monkeypatch.setattr(policies, "HANDOVER", 1)
    env.handle = SimpleNamespace(pose=lambda data: (4.0, 3.0, 0.0, 0.0))
    env.data, env.scene, env.steps = None, None, 0
    env.others = lambda: (np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0))
    env.attempts = 0
    nav.reset(env)
    env.attempts = 1
    planner = policies.PlannerPolicy()
    planner.reset(env)
    np.testing.assert_allclose(nav.act({}), planner.act({}))
    # wedged: it backs up, then samples from its Gaussian (the mean would wedge the same way
    # again) until it reaches the next waypoint
    monkeypatch.setattr(policies, "HANDOVER", 2)
    sampled = []
    nav.reset(env)

    def predict(obs, rng):
        sampled.append(rng is not None)
        return np.ones(2), None

    nav.policy = SimpleNamespace(predict=predict)
    for _ in range(steps + 1):  # standing still at (4, 3) for STUCK[0] s
        nav.act({})
    assert sampled == [False] * steps  # the mean, until it is found stuck
    back = round(policies.BACK_UP[0] / env.dt)
    backing = [nav.act({}) for _ in range(back - 1)]
    assert all(a[0] < 0 for a in backing) and sampled == [False] * steps
    nav.act({})
    assert sampled[-1] is True
    env.waypoint = 2  # reached the next waypoint: the mean again
    nav.act({})
    assert sampled[-1] is False


def test_the_learned_ai_waits_for_walk_as_the_planner_does(track, monkeypatch):
    """In a city the learned navigator stops at a crosswalk that does not show walk (it
    crossed on red within 20 s before): its forward command is held at 0 while
    :func:`wait_for_walk` says wait, and passes when it does not."""
    from citygen.runner import policies
    from citygen.runner.learn.policy import shipped

    scene = _stretch(track, (2.5, 2.5), [(12.5, 2.5), (22.5, 2.5)], time_limit=6.0)
    env = make_env("traverse", scene)
    obs, _ = env.reset(seed=0)
    nav = policies.LearnedNavigator(str(shipped()[("nav-static", "quadruped")]))
    nav.reset(env.unwrapped)
    assert nav.act(obs)[0] > 0  # the way ahead is clear: it drives on
    monkeypatch.setattr(policies, "wait_for_walk", lambda env, x, y, yaw: True)
    assert nav.act(obs)[0] == 0.0
