"""The locomotion environment's fast step (and the training wrapper's gait shaping) against the
per-step computation they replaced: the same observations, rewards, ends and metrics to the bit
over a few hundred steps of random actions (falls and resets included); and the compiled height
maps against their plain-numpy references (the 5 cm ground raster interpolated by
``Grid.bilinear``; a coarse map's flat tiles by ``height_at``)."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from citygen.geometry.raster import Grid
from citygen.geometry.terrain import height_at
from citygen.geometry.tiles import KIND_CODES, build_table
from citygen.runner import metrics as M
from citygen.runner.envs.height_kernel import ground_around, tiles_around
from citygen.runner.envs.loco import FALL_FORCE, HEADING_STIFFNESS
from citygen.runner.envs.sensors import HEIGHT_MAP
from citygen.runner.learn.loco import AIR_TIME, WEIGHTS, LocoTraining
from citygen.runner.make import make_env
from citygen.spec.terrain import FlatTile, RoughTile, SlopeTile, StairTile, Terrain

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
    if not env.prepared.fine_ground:  # a training grid's coarse map: the terrain's own heights
        z = height_at(env.scene, xs, ys)  # around the 5 cm raster's ground under the base
        z[-1] = env.prepared.fine_tiles.ground_at(x, y)
        return z
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
    fallen = _reference_ground_force(env) > FALL_FORCE
    outside = env._out_of_bounds(x, y)
    dv = (vel[0] - env.command[0]) ** 2 + (vel[1] - env.command[1]) ** 2
    dz = (vel[3] - env.command[2]) ** 2
    reward = math.exp(-dv / 0.25**2) + 0.5 * math.exp(-dz / 0.25**2)
    reward += 2.0 * -(vel[2] ** 2)
    reward += 0.01 * -float(np.sum((a - env.last_action) ** 2))
    if fallen:
        reward -= 100.0
    env.last_action = a
    env.recorder.record_step((x, y), np.array(env.data.actuator_force), fallen=fallen)
    if env.held_heading is not None:  # heading control: the next step's yaw rate
        yaw = env.handle.pose(env.data)[3]
        env.command[2] = float(
            np.clip(HEADING_STIFFNESS * math.remainder(env.held_heading - yaw, 2 * math.pi), -1.0, 1.0)
        )
    truncated = not fallen and (outside or env.steps >= env.horizon)
    info = {"scene": env.source.name, "index": env._index, "fallen": fallen, "out_of_bounds": outside}
    if fallen or truncated:
        env.recorder.finish()
        info["metrics"] = M.loco_metrics(env.recorder)
        info["is_success"] = not fallen
    return _reference_observation(env), float(reward), bool(fallen), bool(truncated), info


class _ReferenceTraining(LocoTraining):
    """LocoTraining over the reference step, with the gait shaping as it was computed."""

    def step(self, action):
        obs, reward, terminated, truncated, info = _reference_step(self.env.unwrapped, action)
        if self.shaping:
            reward += self.shaping * self._shaping()
        if (terminated or truncated) and self.curriculum and self.level is not None:
            self._move_level(bool(terminated))
            info = {**info, "terrain_level": self.level}
        return obs, reward, terminated, truncated, info

    def _shaping(self) -> float:
        u = self.env.unwrapped
        d, h, c = u.data, u.handle, u.command
        vx, vy, _, wz = h.velocity(d)
        w = d.qvel[h.dadr + 3 : h.dadr + 5]
        g = d.xmat[h.base_id][6:8]
        tau = d.actuator_force[h.leg_act]
        qvel = d.qvel[h.leg_dadr]
        r = WEIGHTS["track_lin"] * math.exp(-((vx - c[0]) ** 2 + (vy - c[1]) ** 2) / 0.25)
        r += WEIGHTS["track_ang"] * math.exp(-((wz - c[2]) ** 2) / 0.25)
        asked = c[0] * c[0] + c[1] * c[1]
        if asked > 0.01:
            r += WEIGHTS["progress"] * min(max((vx * c[0] + vy * c[1]) / asked, -1.0), 1.0)
        r += WEIGHTS["ang_vel_xy"] * float(w @ w)
        r += WEIGHTS["tilt"] * float(g @ g)
        r += WEIGHTS["torque"] * float(tau @ tau)
        if self._last_qvel is not None:
            acc = (qvel - self._last_qvel) / u.dt
            r += WEIGHTS["joint_acc"] * float(acc @ acc)
        self._last_qvel = qvel
        touching = self._feet_touching()
        landed = touching & (self._air > 0)
        self._air += u.dt
        if self._stepping and (math.hypot(c[0], c[1]) > 0.1 or abs(c[2]) > 0.1):
            r += WEIGHTS["air_time"] * float(np.sum((self._air - AIR_TIME) * landed))
        self._air[touching] = 0.0
        return r


def _same(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].dtype == b[k].dtype and a[k].shape == b[k].shape, k
        assert a[k].tobytes() == b[k].tobytes(), k


@pytest.mark.parametrize(
    ("robot", "split"),
    # the training grids' coarse maps (their tiles' heights: flat; stairs) and the test
    # split's 5 cm raster
    [
        ("quadruped", "urban-loc-1-train"),
        ("quadruped", "urban-loc-3-train"),
        ("wheeled_legged", "urban-loc-1-test"),
    ],
)
def test_fast_step_is_the_reference_step_to_the_bit(robot, split):
    # Through the training wrapper (gait shaping, commands, curriculum) as `citygen train` runs
    # it; random actions topple the robot every hundred steps or so: falls, ends and resets.
    def wrapped(cls):
        env = make_env("loco-flat", split=split, robot=robot, max_steps=150)
        return cls(env, seed=0, rank=1, shaping=1.0, command_mix=0.5)

    fast, ref = wrapped(LocoTraining), wrapped(_ReferenceTraining)
    obs, _ = fast.reset(seed=3)
    ref.reset(seed=3)
    _same(obs, _reference_observation(ref.unwrapped))
    rng = np.random.default_rng(0)
    ends = 0
    for action in rng.uniform(-1.3, 1.3, (300, fast.unwrapped.n_actions)).astype(np.float32):
        got, want = fast.step(action), ref.step(action)
        _same(got[0], want[0])
        assert got[1:] == want[1:]  # reward, terminated, truncated, info (metrics included)
        if got[2] or got[3]:
            ends += 1
            obs, _ = fast.reset()
            ref.reset()
            _same(obs, _reference_observation(ref.unwrapped))
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


def test_tiles_kernel_is_height_at_to_the_bit():
    # Every tile kind (flat; slope and stair flights along each axis, pyramids and pits; rough
    # tiles of several scales, amplitudes and seeds), points inside and outside the grid.
    rng = np.random.default_rng(2)
    shapes = [{"ascent": a} for a in ("+x", "-x", "+y", "-y")] + [{"shape": "pyramid"}, {"shape": "pit"}]

    def tile(k: int, h: float):
        shape = shapes[k % len(shapes)]
        if k % 4 == 1:
            return SlopeTile(kind="slope", height=h, angle=float(rng.uniform(0.05, 0.6)), **shape)
        if k % 4 == 2:
            rise, n = float(rng.uniform(0.05, 0.3)), int(rng.integers(1, 9))
            return StairTile(kind="stair", height=h, step_height=rise, step_count=n, **shape)
        if k % 4 == 3:
            amp, scale = float(rng.uniform(0.02, 0.2)), float(rng.uniform(0.3, 3.0))
            seed = int(rng.integers(1 << 32))
            return RoughTile(kind="rough", height=h, amplitude=amp, scale=scale, seed=seed)
        return FlatTile(kind="flat", height=h)

    tiles = [tile(k, float(h)) for k, h in enumerate(rng.uniform(-0.5, 0.5, 48))]
    terrain = Terrain(origin=(0.5, -1.0), tile_size=2.0, rows=6, cols=8, tiles=tuple(tiles))
    tab = build_table(terrain.tiles, terrain.tile_size)
    codes = np.array([KIND_CODES[k] for k in (FlatTile, SlopeTile, StairTile, RoughTile)])
    unknown = codes.copy()
    unknown[3] = -1  # a kind the kernel would not know: left to height_at
    left = 0
    for x, y, yaw in _poses(rng, -1.5, 17.5, 400):
        u, v, xs, ys = _map_points(x, y, yaw)
        args = (tab.kind, tab.h, tab.a, tab.n, tab.asc, tab.sign, tab.scale, tab.key)
        grid = (2.0, 0.5, -1.0, 6, 8, u, v, x, y, math.cos(yaw), math.sin(yaw))
        got, ok = tiles_around(*args, codes, *grid)
        assert ok and got.tobytes() == height_at(terrain, xs, ys).tobytes()
        left += not tiles_around(*args, unknown, *grid)[1]
    assert left > 50
