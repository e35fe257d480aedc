"""People moved only near the robot (issue 45, a city's 200 people): ``Crowd.step(active=...)``
and ``NavEnv.agents_near``. With everyone active the crowd moves as it did, to the bit; the
people left standing do not move and are never walked into; in an environment the people
beyond ``agents_near`` of the robot stand, and move again once the robot comes near."""

from __future__ import annotations

import math

import numpy as np
import pytest

import citygen
from citygen.exporters.occupancy import occupancy
from citygen.runner.agents.crowd import Crowd
from citygen.runner.bench import run_episode
from citygen.runner.envs import nav
from citygen.runner.make import make_env
from citygen.runner.policies import make_policy
from tests.test_crowd import DT, ROBOT_R, Checker


@pytest.fixture(scope="module")
def square():
    scene = citygen.generate("urban-nav-3-test", index=2)
    return scene, occupancy(scene)


def _shuttle(scene, t: int) -> tuple[np.ndarray, np.ndarray]:
    """A robot disc going from the task's start towards its goal at 0.6 m/s."""
    a, b = np.array(scene.task.start.position), np.array(scene.task.goal)
    d = (b - a) / np.linalg.norm(b - a)
    return a + d * min(0.6 * DT * t, np.linalg.norm(b - a)), 0.6 * d


def test_with_everyone_active_the_crowd_moves_as_before(square):
    scene, occ = square
    crowds = [Crowd(scene, occ, rng=np.random.default_rng(3), dt=DT) for _ in range(2)]
    every = np.ones(len(crowds[0].ids), dtype=bool)
    for t in range(80):
        xy, vel = _shuttle(scene, t)
        crowds[0].step(xy, vel, ROBOT_R)
        crowds[1].step(xy, vel, ROBOT_R, active=every)
        assert crowds[0].pos.tobytes() == crowds[1].pos.tobytes()
    assert np.abs(crowds[0].pos - crowds[0].start).max() > 1.0  # they walked


def test_standing_people_stay_put_and_the_others_keep_clear_of_them(square):
    scene, occ = square
    crowd = Crowd(scene, occ, rng=np.random.default_rng(3), dt=DT)
    n = len(crowd.ids)
    assert n >= 4
    active = np.arange(n) % 2 == 0
    check = Checker(crowd, occ)  # no overlaps, on walkable ground, out of the robot's disc
    for t in range(150):
        xy, vel = _shuttle(scene, t)
        crowd.step(xy, vel, ROBOT_R, active=active)
        check(xy, ROBOT_R)
        assert np.array_equal(crowd.pos[~active], crowd.start[~active])
        assert not crowd.vel[~active].any() and not crowd.arrivals[~active].any()
    assert np.abs(crowd.pos[active] - crowd.start[active]).max() > 1.0
    crowd.step(xy, vel, ROBOT_R, active=np.zeros(n, dtype=bool))  # no one moves
    assert not crowd.vel.any()


def test_far_people_stand_until_the_robot_comes_near():
    env = make_env("nav-dynamic", split="urban-nav-3-test", robot="wheeled")
    u = env.unwrapped
    u.agents_near = 2.5
    env.reset(seed=0, options={"index": 2})
    crowd = u.crowd
    assert u._people_near == 2.5
    x, y = u.handle.pose(u.data)[:2]
    far = np.hypot(crowd.pos[:, 0] - x, crowd.pos[:, 1] - y) > 6.0
    assert far.any()
    start = crowd.pos.copy()
    for _ in range(10):  # the robot standing: the far people stand too
        env.step(np.zeros(2, dtype=np.float32))
    assert np.array_equal(crowd.pos[far], start[far])
    i = int(np.flatnonzero(far)[0])
    mocap = u.prepared.agent_bodies[crowd.ids[i]]
    np.testing.assert_allclose(u.data.mocap_pos[mocap, :2], start[i])
    # The robot put beside person i (1.5 m off, on its side away from the person's goal)
    px, py = crowd.pos[i]
    gx, gy = crowd.targets()[i]
    away = math.atan2(py - gy, px - gx)
    u._spawn(px + 1.5 * math.cos(away), py + 1.5 * math.sin(away), away)
    for _ in range(10):
        env.step(np.zeros(2, dtype=np.float32))
    assert np.hypot(*(crowd.pos[i] - start[i])) > 0.3  # walking again
    np.testing.assert_allclose(u.data.mocap_pos[mocap, :2], crowd.pos[i])


def test_a_large_radius_changes_no_episode():
    """Everyone within agents_near: the masked step is the full one, metrics to the bit."""
    runs = []
    for near in (None, 1e6):
        env = make_env("nav-dynamic", split="urban-nav-3-test", robot="wheeled")
        env.unwrapped.agents_near = near
        runs.append(run_episode(env, make_policy("planner", task="nav-dynamic"), seed=0, index=3))
        assert env.unwrapped._people_near == near
    assert runs[0] == runs[1]


def test_a_city_sized_crowd_moves_only_near_the_robot(monkeypatch):
    env = make_env("nav-dynamic", split="urban-nav-3-test", robot="wheeled")
    env.reset(seed=0, options={"index": 2})
    assert env.unwrapped._people_near is None  # a square's few people all move
    monkeypatch.setattr(nav, "NEAR_FROM_AGENTS", 0)  # as if it were a city
    env.reset(seed=0, options={"index": 2})
    assert env.unwrapped._people_near == nav.PEOPLE_NEAR
