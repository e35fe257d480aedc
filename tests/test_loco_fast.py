"""The locomotion environment's fast step against the per-step computation it replaced: the same
observations, rewards, ends and metrics to the bit over a few hundred steps of random actions
(falls and resets included); and the compiled height map against its plain-numpy reference
(the 5 cm ground raster interpolated by ``Prepared.ground``)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from citygen.geometry.raster import Grid
from citygen.geometry.terrain import height_at
from citygen.geometry.tiles import KIND_CODES, build_table
from citygen.runner import metrics as M
from citygen.runner.envs.height_kernel import flat_tiles_around, ground_around
from citygen.runner.envs.loco import FALL_FORCE
from citygen.runner.envs.sensors import HEIGHT_MAP
from citygen.runner.make import make_env
from citygen.spec.terrain import FlatTile, StairTile, Terrain

# --- the per-step computation before the fast path (kept here as the reference) -------------


def _reference_ground_force(env) -> float:
    g1, g2 = env._contacts()
    if g1.size == 0:
        return 0.0
    body, ground = env._fall_geoms, env.prepared.ground_geoms
    hits = np.flatnonzero((body[g1] & ground[g2]) | (body[g2] & ground[g1]))
    force = np.zeros(6)
    worst = 0.0
    for i in hits:
        mujoco.mj_contactForce(env.model, env.data, int(i), force)
        worst = max(worst, abs(force[0]))
    return worst


def _reference_heights(env, x: float, y: float, yaw: float) -> np.ndarray:
    u, v, _ = env._hm_local
    cs, sn = math.cos(yaw), math.sin(yaw)
    xs, ys = np.empty(u.size + 1), np.empty(u.size + 1)
    xs[:-1], ys[:-1] = x + cs * u - sn * v, y + sn * u + cs * v
    xs[-1], ys[-1] = x, y
    return env.prepared.ground(xs, ys)


def _reference_observation(env) -> dict[str, np.ndarray]:
    h, d = env.handle, env.data
    x, y, z, yaw = h.pose(d)
    vel = h.velocity(d)
    z = _reference_heights(env, x, y, yaw)
    obs = {
        "base_lin_vel": np.asarray(vel[:3], dtype=np.float32),
        "base_ang_vel": np.asarray(d.qvel[h.dadr + 3 : h.dadr + 6], dtype=np.float32),
        "projected_gravity": -np.asarray(d.xmat[h.base_id][6:9], dtype=np.float32),
        "command": env.command.astype(np.float32),
        "joint_pos": np.asarray(h.joint_positions(d) - h.default, dtype=np.float32),
        "joint_vel": np.concatenate([h.joint_velocities(d), h.wheel_velocities(d)]).astype(np.float32),
        "last_action": env.last_action.astype(np.float32),
        "height_map": (z[:-1] - float(z[-1])).reshape(env._hm_local[2]).astype(np.float32),
    }
    return {k: obs[k] for k in env.observation_space.spaces}


def _reference_step(env, action):
    a = np.clip(np.asarray(action, dtype=np.float64).reshape(env.n_actions), -1.0, 1.0)
    env.handle.joint_action(env.data, a)
    env._physics(None)
    env.steps += 1
    x, y, _, _ = env.handle.pose(env.data)
    vel = env.handle.velocity(env.data)
    fallen = _reference_ground_force(env) > FALL_FORCE or env._out_of_bounds(x, y)
    dv = (vel[0] - env.command[0]) ** 2 + (vel[1] - env.command[1]) ** 2
    dz = (vel[3] - env.command[2]) ** 2
    reward = math.exp(-dv / 0.25**2) + 0.5 * math.exp(-dz / 0.25**2)
    reward += 2.0 * -(vel[2] ** 2)
    reward += 0.01 * -float(np.sum((a - env.last_action) ** 2))
    if fallen:
        reward -= 100.0
    env.last_action = a
    env.recorder.record_step((x, y), np.array(env.data.actuator_force), fallen=fallen)
    truncated = not fallen and env.steps >= env.horizon
    info = {"scene": env.source.name, "index": env._index, "fallen": fallen}
    if fallen or truncated:
        env.recorder.finish()
        info["metrics"] = M.loco_metrics(env.recorder)
        info["is_success"] = not fallen
    return _reference_observation(env), float(reward), bool(fallen), bool(truncated), info


def _same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
        assert a[k].tobytes() == b[k].tobytes(), k


@pytest.mark.parametrize(
    ("robot", "split"),
    # the training grid's coarse map (its flat tiles' heights) and the test split's 5 cm raster
    [("quadruped", "urban-loc-1-train"), ("wheeled_legged", "urban-loc-1-test")],
)
def test_fast_step_is_the_reference_step_to_the_bit(robot, split):
    # Random actions topple the robot every hundred steps or so: falls, ends and resets.
    fast = make_env("loco-flat", split=split, robot=robot, max_steps=150).unwrapped
    ref = make_env("loco-flat", split=split, robot=robot, max_steps=150).unwrapped
    obs, _ = fast.reset(seed=3)
    ref.reset(seed=3)
    _same(obs, _reference_observation(ref))
    rng = np.random.default_rng(0)
    ends = 0
    for action in rng.uniform(-1.3, 1.3, (300, fast.n_actions)).astype(np.float32):
        got, want = fast.step(action), _reference_step(ref, action)
        _same(got[0], want[0])
        assert got[1:] == want[1:]  # reward, terminated, truncated, info (metrics included)
        if got[2] or got[3]:
            ends += 1
            obs, _ = fast.reset()
            ref.reset()
            _same(obs, _reference_observation(ref))
    assert ends >= 3


def _poses(rng, lo: float, hi: float, n: int = 60):
    xs, ys, yaws = rng.uniform(lo, hi, n), rng.uniform(lo, hi, n), rng.uniform(-4, 4, n)
    return zip(xs.tolist(), ys.tolist(), yaws.tolist(), strict=True)


def _map_points(x: float, y: float, yaw: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The height map's grid ``(u, v)`` and its points around ``(x, y, yaw)`` as the numpy
    reference lays them out (the base's point last)."""
    hx, hy, step = HEIGHT_MAP
    nx, ny = round(hx / step) + 1, round(hy / step) + 1
    u, v = np.meshgrid(np.linspace(-hx / 2, hx / 2, nx), np.linspace(-hy / 2, hy / 2, ny), indexing="ij")
    u, v = u.ravel(), v.ravel()
    cs, sn = math.cos(yaw), math.sin(yaw)
    xs, ys = np.empty(u.size + 1), np.empty(u.size + 1)
    xs[:-1], ys[:-1] = x + cs * u - sn * v, y + sn * u + cs * v
    xs[-1], ys[-1] = x, y
    return u, v, xs, ys


def test_raster_kernel_is_the_bilinear_interpolation_to_the_bit():
    rng = np.random.default_rng(1)
    grid = Grid(-1.3, 0.7, 0.05, 90, 130)
    heights = rng.normal(0.0, 0.2, grid.shape)
    flat = heights.reshape(-1)
    for x, y, yaw in _poses(rng, -2.0, 8.0):
        u, v, xs, ys = _map_points(x, y, yaw)
        want = grid.bilinear(heights, xs, ys)
        got = ground_around(
            flat, grid.rows, grid.cols, grid.x0, grid.y0, 1.0 / grid.resolution, u, v, x, y,
            math.cos(yaw), math.sin(yaw),
        )  # fmt: skip
        assert got.tobytes() == want.tobytes()


def test_flat_tiles_kernel_is_height_at_to_the_bit_and_leaves_other_tiles_to_it():
    rng = np.random.default_rng(2)
    tiles = [
        FlatTile(kind="flat", height=float(h))
        if k % 4
        else StairTile(kind="stair", step_height=0.1, step_count=3)
        for k, h in enumerate(rng.uniform(-0.5, 0.5, 12))
    ]
    terrain = Terrain(origin=(0.5, -1.0), tile_size=2.0, rows=3, cols=4, tiles=tuple(tiles))
    tab = build_table(terrain.tiles, terrain.tile_size)
    answered = left = 0
    for x, y, yaw in _poses(rng, -1.5, 9.5, 200):
        u, v, xs, ys = _map_points(x, y, yaw)
        got, ok = flat_tiles_around(
            tab.kind,
            tab.h,
            KIND_CODES[FlatTile],
            2.0,
            0.5,
            -1.0,
            3,
            4,
            u,
            v,
            x,
            y,
            math.cos(yaw),
            math.sin(yaw),
        )
        want = height_at(terrain, xs, ys)
        if ok:
            assert got.tobytes() == want.tobytes()
            answered += 1
        else:
            left += 1
    assert answered > 20 and left > 20  # both ways taken
