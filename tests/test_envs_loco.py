"""Locomotion episodes as the paper's test: a seed draws the region of the Urban-Loc grid,
the start pose in it and the command; the robot starts standing on the ground under every
part of it (rough bumps, stair edges), and only its body touching down is a fall."""

from __future__ import annotations

import numpy as np
import pytest

from citygen.geometry.terrain import height_at
from citygen.runner.bench import run_episode
from citygen.runner.make import make_env
from citygen.runner.policies import make_policy
from citygen.runner.robots import PREFIX, lowest_point
from citygen.runner.tasks import robots_for


def _grid(task: str, n: int):
    """An n x n Urban-Loc grid of the task's test ranges (row n - 1 the hardest)."""
    from citygen.generate import generate
    from citygen.generate.splits import resolve
    from citygen.runner.envs import DEFAULT_SPLIT

    cfg = resolve(DEFAULT_SPLIT[task])[0].config
    terrain = cfg.terrain.model_copy(update={"grid": (n, n)})
    return generate(cfg.model_copy(update={"size": (8.0 * n, 8.0 * n), "terrain": terrain}), seed=1)


@pytest.fixture(scope="module")
def rough():
    env = make_env("loco-rough", robot="quadruped")
    yield env
    env.close()


def test_seeds_draw_region_start_and_command(rough):
    starts = []
    for seed in range(6):
        _, info = rough.reset(seed=seed)
        x, y, _, yaw = rough.handle.pose(rough.data)
        starts.append((info["region"], round(x, 3), round(y, 3), round(yaw, 3), info["command"]))
        speed = np.hypot(*rough.scene.task.command[:2])
        assert np.hypot(*info["command"][:2]) == pytest.approx(speed)  # fixed magnitude
        assert info["command"][2] == rough.scene.task.command[2]
    assert len({s[0] for s in starts}) > 1, starts  # regions
    assert len({s[1:4] for s in starts}) == len(starts), starts  # poses
    # the command keeps the scene's, ahead of the robot: its world direction is the heading drawn
    assert {s[4] for s in starts} == {tuple(rough.scene.task.command)}, starts
    _, again = rough.reset(seed=3)
    assert (again["region"], again["command"]) == (starts[3][0], starts[3][4])


def test_options_pick_region_and_command(rough):
    obs, info = rough.reset(seed=0, options={"region": (15, 2), "command": (0.5, 0.0, 0.2)})
    assert info["region"] == (15, 2)
    np.testing.assert_allclose(obs["command"], (0.5, 0.0, 0.2))
    x, y, _, _ = rough.handle.pose(rough.data)
    assert (int(y // 8), int(x // 8)) == (15, 2)


def test_the_start_leaves_room_for_the_whole_walk_inside_the_grid(rough):
    """Walking off the grid ends an episode as a fall; a drawn start leaves room for the
    command's walk over the horizon, in every row (42 of a shipped policy's 48 test "falls"
    on LocoFlat were the grid's edge), and a region given by the curriculum keeps its tile."""
    (x0, y0), (x1, y1) = rough.scene.bounds.min, rough.scene.bounds.max
    reach = np.hypot(*rough.scene.task.command[:2]) * rough.horizon * rough.dt
    rows = set()
    for seed in range(48):
        _, info = rough.reset(seed=seed, options={"region": (0, 0)} if seed % 4 == 0 else None)
        x, y, _, yaw = rough.handle.pose(rough.data)
        ex, ey = x + reach * np.cos(yaw), y + reach * np.sin(yaw)
        assert x0 < min(x, ex) and max(x, ex) < x1 and y0 < min(y, ey) and max(y, ey) < y1, (seed, x, y, yaw)
        rows.add(info["region"][0])
        if seed % 4 == 0:
            assert info["region"] == (0, 0)
    assert {0, rough.scene.terrain.rows - 1} <= rows or len(rows) > 8, rows


def test_without_randomize_the_scene_start_and_command_hold():
    env = make_env("loco-flat", robot="quadruped", randomize=False)
    try:
        for seed in (0, 1):
            obs, _ = env.reset(seed=seed)
            np.testing.assert_allclose(obs["command"], env.scene.task.command)
            np.testing.assert_allclose(env.handle.pose(env.data)[:2], env.scene.task.start.position)
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.parametrize("task", ["loco-rough", "loco-stair"])
@pytest.mark.parametrize("robot", robots_for("loco-rough"))
def test_spawn_puts_the_robot_down_on_the_ground_and_it_stands(task, robot):
    """The LocoRough regression (a fall on step 1 of every episode): on any row, the hardest
    too, the robot starts with no part inside the ground and nothing of its body touching
    it; on the easier half of the grid the stand controller keeps it up."""
    env = make_env(task, _grid(task, 4), robot=robot, max_steps=50)
    try:
        for seed in range(4):
            for row in (3, seed):  # the hardest row, then each
                env.reset(seed=seed, options={"region": (row, seed)})
                m, d = env.model, env.data
                feet = env.handle.foot_geom_ids  # on (not in) the ground under them
                low = np.array([lowest_point(m, d, int(g)) for g in feet])
                ground = height_at(env.scene, d.geom_xpos[feet, 0], d.geom_xpos[feet, 1])
                assert np.all(low >= ground - 0.01), (seed, row, low - ground)
                if task == "loco-rough":  # not dropped from high (a stair pit may not fit a big robot)
                    assert np.min(low - ground) <= 0.1, (seed, row, low - ground)
                n = d.ncon
                assert not np.any(env._fall_geoms[d.contact.geom1[:n]] | env._fall_geoms[d.contact.geom2[:n]])
                assert np.all(d.contact.dist[:n] >= -1e-3), (seed, row, d.contact.dist[:n])
            if seed > 1:  # the easier half of the grid
                continue
            if (task, robot) == ("loco-rough", "humanoid"):
                # Its scripted stand does not hold on rough ground, whatever the contacts: it fell
                # at 1.02-1.62 s on MuJoCo's default and at 1.00-1.56 s on the stiffer rough
                # heightfields (the issue asks for standing on flat, slope and stair tiles).
                continue
            result = run_episode(env, make_policy("stand"), seed=seed, options={"region": (seed, seed)})
            assert result["balance"] == 100.0, (task, robot, seed, result)
    finally:
        env.close()


def test_a_fall_is_the_body_not_the_legs(rough):
    rough.reset(seed=0)
    names = {rough.model.geom(int(g)).name.removeprefix(PREFIX) for g in np.flatnonzero(rough._fall_geoms)}
    assert {"trunk", "head"} <= names
    assert not any(n.startswith(("FR_", "FL_", "RR_", "RL_")) for n in names), names


@pytest.mark.parametrize("task", ["loco-slope", "loco-rough"])
def test_a_walking_foot_does_not_stick_in_slope_or_rough_tiles(task):
    """The shipped LocoFlat walker on the flat floor of LocoSlope's easiest pit, or on
    LocoRough's mildest row, walks as it does on flat ground: slope tiles are prisms under
    feet and rough tiles stiffer heightfields (``terrain="hybrid"``). On MuJoCo's plain
    heightfields its feet sank, the contacts turned sideways and held them: 0.17 m (slope)
    and 0.13 m (rough) in 3 s, where it walks 2.7 and 2.3 m. The physics, not the protocol:
    the command stays fixed (heading control's turning slows this flat walker to 1.7 m in
    3 s on rough ground)."""
    from citygen.runner.learn.policy import load_policy
    from citygen.runner.learn.shipped_models import baseline

    policy = load_policy(baseline("loco-flat", "quadruped"))
    env = make_env(task, robot="quadruped", max_steps=150, heading_control=False)  # 3 s
    try:
        region = (0, 1 if task == "loco-slope" else 5)
        result = run_episode(env, policy, seed=0, options={"region": region})
        assert env.terrain == "hybrid" and (env.model.nhfield == 0) == (task == "loco-slope")
        assert result["balance"] == 100.0 and result["x_displacement"] > 2.0, result
    finally:
        env.close()


def test_a_straight_command_holds_the_heading_and_a_yaw_rate_command_stays(rough):
    """Heading control (Isaac Lab's ``heading_command``): a straight command's yaw rate turns
    the robot back to its start heading (0.5 times the error); a command with a yaw rate of
    its own, or ``heading_control=False``, stays as drawn. With it the shipped LocoFlat
    walker, turned 0.4 rad off, comes back within 3 s; without, it walks on askew."""
    import mujoco

    from citygen.runner.learn.policy import load_policy
    from citygen.runner.learn.shipped_models import baseline

    def turned(env, options=None, hold=True):
        env.heading_control = hold
        obs, _ = env.reset(seed=0, options={"region": (0, 0), **(options or {})})
        h = env.handle
        yaw0 = h.pose(env.data)[3]
        q = np.array(env.data.qpos[h.qadr + 3 : h.qadr + 7])
        mujoco.mju_mulQuat(
            env.data.qpos[h.qadr + 3 : h.qadr + 7], np.array([np.cos(0.2), 0, 0, np.sin(0.2)]), q
        )
        mujoco.mj_forward(env.model, env.data)
        return obs, yaw0

    def error(env, yaw0):
        return abs(np.remainder(env.handle.pose(env.data)[3] - yaw0 + np.pi, 2 * np.pi) - np.pi)

    turned(rough)
    obs, *_ = rough.step(np.zeros(rough.n_actions))
    assert obs["command"][2] == pytest.approx(-0.2, abs=0.02)  # 0.5 x (0 - 0.4 rad)
    turned(rough, {"command": (0.5, 0.0, 0.2)})
    assert rough.step(np.zeros(rough.n_actions))[0]["command"][2] == 0.2
    turned(rough, hold=False)
    assert rough.step(np.zeros(rough.n_actions))[0]["command"][2] == 0.0
    rough.heading_control = True

    policy = load_policy(baseline("loco-flat", "quadruped"))
    env = make_env("loco-flat", robot="quadruped")
    try:
        errors = []
        for hold in (True, False):
            obs, yaw0 = turned(env, hold=hold)
            policy.reset(env)
            for _ in range(150):
                obs, _, fallen, _, _ = env.step(policy.act(obs))
                assert not fallen
            errors.append(error(env, yaw0))
        assert errors[0] < 0.12 < 0.25 < errors[1], errors
    finally:
        env.close()
