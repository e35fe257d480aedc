"""A locomotion policy riding on the quadruped's trot (citygen.runner.learn.residual,
``gait = "trot"``): the trot's swing clears a riser it steps onto, a zero residual at the
trot's own swing height is the scripted trot to the bit, and a tiny LocoStair run with the
trot exports a policy that ``citygen bench`` runs, numpy only, with the actions of its SB3
model."""

from __future__ import annotations

import json
import math
import pickle
from types import SimpleNamespace

import numpy as np
import pytest

from citygen.runner.bench import run_episode
from citygen.runner.control.gaits import TrotController
from citygen.runner.learn.residual import HEIGHT, PHASE_KEY, GaitResidual
from citygen.runner.make import make_env
from tests.conftest import TINY_LOCO, loco_grid, scripted_and_zero_residual, tiny_loco_run

RISER = 0.15  # m: a riser of the test grid's middle rows (0.10-0.30 m)
TINY = TINY_LOCO + 'gait = "trot"\n'


@pytest.fixture(scope="module")
def grids(tmp_path_factory):
    folder = tmp_path_factory.mktemp("grids")
    paths = {}
    for kind in ("flat", "stair"):
        paths[kind] = folder / f"{kind}.toml"
        paths[kind].write_text(loco_grid(kind, "quadruped"))
    return paths


def test_the_trots_swing_clears_a_riser_it_steps_onto(grids):
    """The trot's feet driven kinematically (the body carried forward at 0.5 m/s, the feet's
    targets recorded) over a 15 cm step 0.25 m ahead of the body's centre: every swing foot
    is above the step's top wherever it passes over the riser's edge (the foot's bottom, 2 cm
    ahead of its centre included), and the front feet come to stand on the step. Before the
    swing looked ahead, a swing foot was ``step_height`` (6.4 cm) over the ground under it
    and hit the riser."""
    env = make_env("loco-flat", robot="quadruped", split=str(grids["flat"]))
    try:
        env.reset(seed=0)
        handle, data = env.handle, env.data
        x0, y0, _, yaw = handle.pose(data)
        c, s = math.cos(yaw), math.sin(yaw)
        edge = 0.25  # m ahead of the start

        def ahead_of_start(x: float, y: float) -> float:
            return (x - x0) * c + (y - y0) * s

        step = SimpleNamespace(ground_at=lambda x, y: RISER if ahead_of_start(x, y) >= edge else 0.0)
        handle.terrain = step
        trot = TrotController(command=(0.5, 0.0, 0.0), ramp=0.0)
        seen = []
        trot._action = lambda handle, data, feet, ground, stance, dt: (
            seen.append((feet.copy(), ground.copy(), stance.copy())) or np.zeros(12)
        )
        radius = handle.robot.legs[0].foot_radius
        crossings, on_step = 0, set()
        speed, dt = 0.5, env.dt
        for k in range(60):  # 1.2 s: 3.4 trot cycles, 0.6 m
            data.qpos[handle.qadr] = x0 + speed * k * dt * c
            data.qpos[handle.qadr + 1] = y0 + speed * k * dt * s
            data.qvel[handle.dadr : handle.dadr + 2] = (speed * c, speed * s)
            trot.act(handle, data, k * dt)
            feet, ground, stance = seen[-1]
            world = trot._world_xy(data, handle, feet)
            for i in range(4):
                front = ahead_of_start(*world[i])
                bottom = ground[i] + feet[i, 2]  # the foot's lowest point's target height
                if stance[i]:
                    if ground[i] == RISER:
                        on_step.add(i)
                    continue
                if edge - radius - 0.01 <= front <= edge:  # over the riser's edge, or about to be
                    crossings += 1
                    assert bottom >= RISER + 0.005, (k, i, front, bottom)
        assert crossings >= 2 and {0, 1} <= on_step, (crossings, on_step)
    finally:
        env.close()


def test_a_zero_residual_at_the_trots_height_is_the_scripted_trot(grids):
    env = make_env("loco-flat", robot="quadruped", split=str(grids["flat"]))
    try:
        runs, gait = scripted_and_zero_residual(env, "trot")
        # the phase: the trot's cycle (2.8 Hz for the quadruped) and its ramp
        phase = gait.phase(env)
        assert phase.shape == (3,) and phase[2] == 1.0
        assert math.atan2(phase[0], phase[1]) == pytest.approx(
            math.remainder(2 * math.pi * 100 * env.dt * 2.8, 2 * math.pi), abs=1e-4
        )
        assert runs[0].tobytes() == runs[1].tobytes()
        assert np.hypot(*(runs[0][-1, :2] - runs[0][0, :2])) > 0.3  # it walked
        # the height action sets the swing height, within its bounds
        gait = GaitResidual("trot", 0.2)
        env.reset(seed=0)
        gait.reset(env)
        reach = env.robot.legs[0].thigh + env.robot.legs[0].calf
        assert gait.height == pytest.approx(HEIGHT * reach)
        for _ in range(50):
            gait.action(env, np.r_[np.zeros(env.n_actions), 5.0])
        assert gait.walk.step_height == pytest.approx(0.25 * reach, rel=1e-3)
    finally:
        env.close()


def test_a_tiny_trot_run_on_stairs_exports_a_policy_that_rides_on_the_trot(tmp_path, grids):
    from stable_baselines3 import PPO

    from citygen.runner.learn.export import read_policy, write_policy
    from citygen.runner.learn.policy import load_policy
    from citygen.runner.learn.residual import ResidualPolicy, ResidualTraining

    out, printed = tiny_loco_run(tmp_path, "loco-stair", "quadruped", grids["stair"], TINY)
    meta = json.loads((out / "policy.json").read_text())
    assert meta["gait"] == {"name": "trot", "scale": 0.2, "max_speed": 1.0} and PHASE_KEY in meta["keys"]
    assert meta["action_shape"] == [13] and "Balance" in printed
    # the exported network gives the SB3 model's actions on the residual's observations
    model = PPO.load(out / "model.zip", device="cpu")
    with open(out / "vecnormalize.pkl", "rb") as f:
        stats = pickle.load(f)
    exported = read_policy(out / "policy.npz")
    env = ResidualTraining(
        make_env("loco-stair", robot="quadruped", split=str(grids["stair"])), gait="trot", scale=0.2
    )
    try:
        obs, _ = env.reset(seed=2)
        batch = []
        for k in range(12):
            batch.append({key: obs[key] for key in exported.keys})
            obs, *_ = env.step(0.3 * np.sin(np.arange(13) + k))
        stacked = {key: np.stack([o[key] for o in batch]) for key in exported.keys}
        torch_actions, _ = model.predict(stats.normalize_obs(stacked), deterministic=True)
        np.testing.assert_allclose(exported.predict(stacked), torch_actions, atol=1e-5)
    finally:
        env.close()
    # its network silenced (a zero mean), the policy is the scripted trot: it walks flat ground
    arrays = {f"w{i}": w for i, w in enumerate(exported.weights)} | {
        f"b{i}": b for i, b in enumerate(exported.biases)
    }
    last = len(exported.weights) - 1
    for key in (f"w{last}", f"b{last}"):
        arrays[key] = np.zeros_like(arrays[key])
    policy = load_policy(write_policy(tmp_path / "silent.npz", exported.meta, arrays))
    assert isinstance(policy, ResidualPolicy) and PHASE_KEY not in policy.shapes
    env = make_env("loco-flat", robot="quadruped", split=str(grids["flat"]), max_steps=250)
    try:
        result = run_episode(env, policy, seed=1)
    finally:
        env.close()
    assert result["balance"] == 100.0 and result["x_displacement"] > 1.0, result
