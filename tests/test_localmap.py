"""The navigation observation's ego-centric local map: orientation, objects, agents, walkability,
and the ``info["is_success"]`` of the last step."""

from __future__ import annotations

import math

import numpy as np
import pytest

import citygen
from citygen.runner import localmap
from citygen.runner.localmap import AGENT_HEIGHT, LocalMap, StaticLayers, with_margin
from citygen.runner.make import make_env

pytestmark = pytest.mark.filterwarnings("ignore::citygen.exporters.ExportWarning")


def _layers():
    """20 m x 20 m at 0.1 m, all walkable, with a 0.8 m box at x in [3, 4], y in [-0.5, 0.5]
    (the world's origin at the grid's centre)."""
    elev = np.zeros((200, 200), dtype=np.float32)
    walk = np.ones((200, 200), dtype=bool)
    xs = -10 + (np.arange(200) + 0.5) * 0.1
    box = (xs[None, :] >= 3) & (xs[None, :] <= 4) & (np.abs(xs[:, None]) <= 0.5)
    elev[box] = 0.8
    walk[box] = False
    return with_margin(StaticLayers(elev, walk, -10.0, -10.0, 0.1))


def _cells(m: LocalMap, grid: np.ndarray) -> set[tuple[float, float]]:
    """Centres ``(u, v)`` of the cells where ``grid`` is true."""
    return {(round(u, 2), round(v, 2)) for u, v in zip(m.u.reshape(m.shape)[grid], m.v.reshape(m.shape)[grid],
                                                       strict=True)}  # fmt: skip


def test_an_object_ahead_shows_ahead_whichever_way_the_robot_faces():
    m = LocalMap()
    layers = _layers()
    facing = m(layers, (0.0, 0.0, 0.0), 0.0)
    assert facing.shape == (2, 32, 32) and facing.dtype == np.float32
    high = _cells(m, facing[0] > 0.5)
    assert high and all(3.0 <= u <= 4.0 and abs(v) <= 0.6 for u, v in high)
    assert _cells(m, facing[1] == 0) == high  # not walkable exactly where the box stands
    # Standing at (3.5, -3.5) facing +y (yaw 90 degrees), the box is 3.5 m ahead.
    turned = m(layers, (3.5, -3.5, math.pi / 2), 0.0)
    high = _cells(m, turned[0] > 0.5)
    assert high and all(2.9 <= u <= 4.1 and abs(v) <= 0.6 for u, v in high)
    # Elevations are relative to the ground under the robot.
    assert m(layers, (0.0, 0.0, 0.0), 0.3)[0].min() == pytest.approx(-0.3)


def test_moving_agents_are_discs_and_outside_the_scene_is_not_walkable():
    m = LocalMap()
    layers = _layers()
    grid = m(layers, (-8.0, 0.0, 0.0), 0.0, agents=(np.array([[-7.0, 1.0]]), np.array([0.3])))
    person = _cells(m, grid[0] >= AGENT_HEIGHT - 1e-6)
    assert person and all(math.hypot(u - 1.0, v - 1.0) <= 0.3 + 0.15 for u, v in person)
    # The scene ends 2 m behind the robot: no walkable cell there.
    behind = m.u.reshape(m.shape) < -2.05
    assert not grid[1][behind].any()
    assert grid[1][~behind].mean() > 0.9


def test_the_inside_layer_ends_where_the_scene_does_whichever_way_the_robot_faces():
    """``local_map_inside``: 1 on the cells whose centre lies in the scene's bounds, 0 beyond
    them, in the map's own frame (rows forward, columns leftward)."""
    m = LocalMap()
    bounds = ((0.0, 0.0), (15.0, 15.0))
    u, v = m.u.reshape(m.shape), m.v.reshape(m.shape)
    # 1 m from the left edge (x = 0) facing +x: the scene ends 1 m behind
    (grid,) = m.inside(bounds, (1.0, 7.0, 0.0))
    assert grid.dtype == np.float32 and np.array_equal(grid == 1, u >= -1.0)
    # facing +y (yaw 90 degrees) the same edge is 1 m to the left (v = 1)
    (grid,) = m.inside(bounds, (1.0, 7.0, math.pi / 2))
    assert np.array_equal(grid == 1, v <= 1.0)
    # in a corner facing it diagonally: the cells whose world centre is inside, one by one
    x, y, yaw = 14.0, 14.5, math.pi / 4
    wx = x + u * math.cos(yaw) - v * math.sin(yaw)
    wy = y + u * math.sin(yaw) + v * math.cos(yaw)
    (grid,) = m.inside(bounds, (x, y, yaw))
    assert np.array_equal(grid == 1, (wx <= 15.0) & (wy <= 15.0)) and 0 < grid.mean() < 1
    # far from every edge: all inside
    assert m.inside(bounds, (7.5, 7.5, 1.0)).min() == 1.0


def test_nav_observation_has_the_inside_layer():
    env = make_env("nav-clear", robot="wheeled")
    obs, _ = env.reset(seed=0, options={"index": 0})
    assert env.observation_space.contains(obs)
    x, y, _, yaw = env.unwrapped.handle.pose(env.unwrapped.data)
    b = env.unwrapped.scene.bounds
    expected = LocalMap().inside(((b.min[0], b.min[1]), (b.max[0], b.max[1])), (x, y, yaw))
    assert np.array_equal(obs["local_map_inside"], expected)
    env.close()


def test_the_crossable_layer_is_walkability_less_the_ground_the_robot_cannot_cross():
    """``LocalMap.crossable``: walkable cells (objects and moving agents excluded, as in the
    map) that the layers' ``crossable`` mask allows, turned with the robot like the map."""
    base = _layers()
    xs = -10 + (np.arange(200) + 0.5) * 0.1
    cross = np.ones((200, 200), dtype=bool)
    cross[:, (xs >= -2.0) & (xs <= -1.0)] = False  # a strip 1-2 m behind a robot at the origin facing +x
    elev, walk = base.elevation[50:-50, 50:-50], base.walkable[50:-50, 50:-50]  # the margin off again
    layers = with_margin(StaticLayers(elev, walk, -10.0, -10.0, 0.1, cross))
    m = LocalMap()
    u, v = m.u.reshape(m.shape), m.v.reshape(m.shape)
    person = (np.array([[0.0, 2.0]]), np.array([0.3]))
    grid = m(layers, (0.0, 0.0, 0.0), 0.0, agents=person)
    (cr,) = m.crossable(layers, (0.0, 0.0, 0.0), agents=person)
    strip = (u >= -1.95) & (u <= -1.05)
    assert cr.dtype == np.float32 and not cr[strip].any() and grid[1][strip].all()
    assert np.array_equal(cr[~strip] == 1, grid[1][~strip] == 1)  # the box and the person as walkability
    assert not cr[(u >= 3.05) & (u <= 3.95) & (np.abs(v) <= 0.45)].any()
    # Facing +y the strip lies to the right (v from 1 to 2), asked without a map made first.
    (turned,) = LocalMap().crossable(layers, (0.0, 0.0, math.pi / 2))
    assert not turned[(v >= 1.05) & (v <= 1.95)].any() and turned[(v <= 0.95) & (v >= -2.5)].all()
    # Without a crossable mask it is walkability.
    (plain,) = m.crossable(base, (0.0, 0.0, 0.0))
    assert np.array_equal(plain, m(base, (0.0, 0.0, 0.0), 0.0)[1])


@pytest.mark.parametrize("robot", ["wheeled", "quadruped"])
def test_nav_observation_crossable_layer_follows_the_robots_mobility(robot):
    """On a test scene where the robot starts on a slope the wheels cannot climb: the wheeled
    robot's crossable layer drops part of the walkable ground, the quadruped's keeps it all,
    and every dropped cell covers ground the scene's crossable mask excludes."""
    env = make_env("nav-clear", robot=robot)
    obs, _ = env.reset(seed=25, options={"index": 25})
    assert env.observation_space.contains(obs)
    (cross,), walk = obs["local_map_crossable"], obs["local_map"][1]
    assert np.all(cross <= walk)
    dropped = (walk == 1) & (cross == 0)
    if robot == "quadruped":
        assert not dropped.any()
        return
    assert dropped.mean() > 0.1
    u = env.unwrapped
    x, y, _, yaw = u.handle.pose(u.data)
    m = LocalMap()
    cu, cv = m.u.reshape(m.shape)[dropped], m.v.reshape(m.shape)[dropped]
    wx = x + cu * math.cos(yaw) - cv * math.sin(yaw)
    wy = y + cu * math.sin(yaw) + cv * math.cos(yaw)
    occ, crossable = u.prepared.occupancy, u.prepared.crossable
    for px, py in zip(wx, wy, strict=True):
        near = [crossable[occ.cell(px + dx, py + dy)] for dx in (-0.1, 0.0, 0.1) for dy in (-0.1, 0.0, 0.1)]
        assert not all(near), (px, py)
    env.close()


def test_nav_static_observation_sees_the_scenes_objects():
    scene = citygen.generate("urban-nav-2-test", index=0)
    env = make_env("nav-static", scene, max_steps=3)
    obs, _ = env.reset(seed=0)
    assert env.observation_space["local_map"].contains(obs["local_map"])
    assert obs["height_map"].shape == (17, 11)  # the paper's height map is kept
    layers = localmap.static_layers(scene, env.prepared.occupancy)
    occ = env.prepared.occupancy
    # Every object's base is elevated in the static layer (relative to its ground).
    obstacle = occ.obstacle_mask()
    assert obstacle.any()
    rows, cols = np.nonzero(obstacle)
    x = occ.grid.x0 + (cols + 0.5) * occ.resolution
    y = occ.grid.y0 + (rows + 0.5) * occ.resolution
    r = ((y - layers.y0) / layers.cell).astype(int)
    c = ((x - layers.x0) / layers.cell).astype(int)
    assert np.all(layers.elevation[r, c] - occ.heights[rows, cols] > 0.05)
    assert not layers.walkable[r, c].any()
    # Step to the end: the last step says whether the goal was reached.
    for _ in range(3):
        obs, _, term, trunc, info = env.step(np.zeros(2, dtype=np.float32))
        assert obs["local_map"].shape == (2, 32, 32)
        if term or trunc:
            break
    assert info["is_success"] is False


def test_nav_dynamic_local_map_marks_the_people():
    env = make_env("nav-dynamic", split="urban-nav-3-test")
    env.reset(seed=0, options={"index": 0})
    xy, _, radius = env.others()
    assert len(xy)
    # Put the robot next to the first person: their disc appears in the map.
    grid = localmap.observe(env, float(xy[0, 0]) - 1.0, float(xy[0, 1]), 0.0, 0.0)
    m = localmap.LocalMap()
    near = np.hypot(m.u - 1.0, m.v).reshape(m.shape) <= radius[0]
    assert np.all(grid[0][near] >= AGENT_HEIGHT - 1e-6) and not grid[1][near].any()


def test_the_motion_layer_gives_each_agents_velocity_in_the_robots_frame_on_its_disc():
    """``local_map_motion``: a person walking +x at 1.2 m/s and a car driving -y at 8 m/s;
    facing +x the person moves forward (u), facing +y it moves to the right (-v)."""
    m = LocalMap()
    layers = _layers()
    xy, vel = np.array([[-6.0, 1.0], [-6.0, -2.0]]), np.array([[1.2, 0.0], [0.0, -8.0]])
    agents = (xy, np.array([0.3, 0.9]), vel)
    grid = m(layers, (-8.0, 0.0, 0.0), 0.0, agents=agents, crossable=True, motion=True)
    assert grid.shape == (5, 32, 32)
    person = grid[0] >= AGENT_HEIGHT - 1e-6
    plain = m(layers, (-8.0, 0.0, 0.0), 0.0, agents=agents[:2], crossable=True)
    np.testing.assert_array_equal(grid[:3], plain)  # the other layers are unchanged
    moving = (grid[3] != 0) | (grid[4] != 0)
    np.testing.assert_array_equal(moving, person)  # velocity exactly on the discs
    near_person = np.hypot(m.u - 2.0, m.v - 1.0).reshape(m.shape) <= 0.3
    near_car = np.hypot(m.u - 2.0, m.v + 2.0).reshape(m.shape) <= 0.9
    np.testing.assert_allclose(grid[3][near_person], 1.2)
    np.testing.assert_allclose(grid[4][near_person], 0.0, atol=1e-6)
    np.testing.assert_allclose(grid[4][near_car], -8.0)
    # Facing +y (yaw 90 degrees) from (-6, -1): the person, 2 m ahead, crosses to the right.
    turned = m(layers, (-6.0, -1.0, math.pi / 2), 0.0, agents=agents, motion=True)
    assert turned.shape == (4, 32, 32)
    ahead = np.hypot(m.u - 2.0, m.v).reshape(m.shape) <= 0.3
    np.testing.assert_allclose(turned[2][ahead], 0.0, atol=1e-6)
    np.testing.assert_allclose(turned[3][ahead], -1.2, atol=1e-6)
    # No agents: zeros.
    assert not m(layers, (0.0, 0.0, 0.0), 0.0, motion=True)[2:].any()


def test_nav_dynamic_observation_carries_the_people_s_motion():
    env = make_env("nav-dynamic", split="urban-nav-3-test")
    obs, _ = env.reset(seed=0, options={"index": 0})
    assert env.observation_space["local_map_motion"].contains(obs["local_map_motion"])
    for _ in range(5):
        obs, *_ = env.step(np.zeros(2, dtype=np.float32))
    xy, vel, _ = env.others()
    x, y, _, yaw = env.handle.pose(env.data)
    grid = localmap.observe(env, x, y, yaw, 0.0, crossable=True, motion=True)
    np.testing.assert_array_equal(obs["local_map_motion"], grid[3:])
    # Beside a walking person, the layer holds their velocity turned into the robot's frame.
    k = int(np.argmax(np.hypot(vel[:, 0], vel[:, 1])))
    assert np.hypot(*vel[k]) > 0.1
    grid = localmap.observe(env, float(xy[k, 0]) - 1.0, float(xy[k, 1]), 0.0, 0.0, motion=True)
    m = localmap.LocalMap()
    centre = int(np.argmin(np.hypot(m.u - 1.0, m.v)))
    np.testing.assert_allclose(grid[2:].reshape(2, -1)[:, centre], vel[k], atol=1e-5)
    static = make_env("nav-static", split="urban-nav-2-test")
    obs, _ = static.reset(seed=0, options={"index": 0})
    assert not obs["local_map_motion"].any()


def _reference_local_map(layers: StaticLayers, pose, ground, window=localmap.LOCAL_MAP):
    """The local map by its definition, one output cell at a time: the highest elevation and
    "all walkable" of the layers' cells under 2 x 2 sub-samples a quarter cell from the
    cell's centre, turned with the robot's yaw."""
    hx, hy, step = window
    x, y, yaw = pose
    c, s = math.cos(yaw), math.sin(yaw)
    nu, nv = round(hx / step), round(hy / step)
    out = np.zeros((2, nu, nv), dtype=np.float32)
    q = step / 4
    for i in range(nu):
        for j in range(nv):
            u, v = -hx / 2 + (i + 0.5) * step, -hy / 2 + (j + 0.5) * step
            elev, walk = -np.inf, True
            for du, dv in ((-q, -q), (-q, q), (q, -q), (q, q)):
                px = x + c * (u + du) - s * (v + dv)
                py = y + s * (u + du) + c * (v + dv)
                col = int((px - layers.x0) / layers.cell)
                row = int((py - layers.y0) / layers.cell)
                elev = max(elev, float(layers.elevation[row, col]))
                walk = walk and bool(layers.walkable[row, col])
            out[0, i, j] = np.clip(np.float32(elev) - np.float32(ground), -localmap.MAX_ELEVATION,
                                   localmap.MAX_ELEVATION)  # fmt: skip
            out[1, i, j] = walk
    return out


def test_the_vectorised_local_map_is_its_definition_cell_by_cell():
    rng = np.random.default_rng(3)
    elev = rng.uniform(-1.0, 3.0, (120, 120)).astype(np.float32)
    walk = rng.uniform(size=(120, 120)) < 0.85
    layers = with_margin(StaticLayers(elev, walk, 0.0, 0.0, 0.1))
    m = LocalMap()
    for _ in range(6):
        pose = (*rng.uniform(1.0, 11.0, 2), rng.uniform(-math.pi, math.pi))
        ground = float(rng.uniform(-0.3, 0.3))
        got, want = m(layers, pose, ground), _reference_local_map(layers, pose, ground)
        # Sub-samples on a cell's edge may round either way: allow a handful of cells.
        assert np.count_nonzero(got != want) <= 4, pose


def test_the_compiled_gather_is_the_numpy_reference_to_the_bit():
    """localmap_kernel.gather against LocalMap(...)(..., reference=True): random poses over a
    test scene's pooled layers (objects, kerbs, a crossable mask) and people about, every
    channel."""
    env = make_env("nav-static", split="urban-nav-2-test", robot="wheeled")
    env.reset(seed=0, options={"index": 5})
    layers = localmap._layers_of(env.unwrapped)
    assert layers.crossable is not None and not layers.walkable.all() and np.ptp(layers.elevation) > 0.3
    env.close()
    m, rng = LocalMap(), np.random.default_rng(0)
    rows, cols = layers.elevation.shape
    x0, y0 = layers.x0 + 5, layers.y0 + 5  # inside the 5 m margin
    x1, y1 = layers.x0 + layers.cell * cols - 5, layers.y0 + layers.cell * rows - 5
    for k in range(200):
        pose = (rng.uniform(x0, x1), rng.uniform(y0, y1), rng.uniform(-2 * math.pi, 2 * math.pi))
        agents = (rng.uniform((x0, y0), (x1, y1), (6, 2)), rng.uniform(0.2, 0.5, 6), rng.normal(size=(6, 2)))
        agents[0][:2] = np.array(pose[:2]) + rng.uniform(-2, 2, (2, 2))  # two in the window
        kw = {"agents": agents if k % 2 else None, "crossable": k % 3 != 0, "motion": k % 2 == 1}
        ground = float(rng.uniform(-0.2, 0.4))
        fast = m(layers, pose, ground, **kw)
        ref = m(layers, pose, ground, reference=True, **kw)
        assert fast.dtype == ref.dtype and np.array_equal(fast, ref), (k, pose)


def test_pooled_layers_keep_the_highest_elevation_and_all_of_each_block():
    elev = np.arange(15, dtype=np.float32).reshape(3, 5)
    walk = np.ones((3, 5), dtype=bool)
    walk[0, 1] = False
    cross = walk.copy()
    cross[2, 4] = False
    p = localmap.pooled(StaticLayers(elev, walk, 1.0, 2.0, 0.1, cross), 2)
    assert p.elevation.shape == p.walkable.shape == p.crossable.shape == (2, 3)
    assert (p.x0, p.y0, p.cell) == (1.0, 2.0, 0.2)
    np.testing.assert_array_equal(p.elevation, [[6, 8, 9], [11, 13, 14]])
    # Past the uneven end nothing is walkable: the last row and column's blocks are not all walkable.
    np.testing.assert_array_equal(p.walkable, [[False, True, False], [False, False, False]])
    np.testing.assert_array_equal(p.crossable, p.walkable)


def test_the_wide_map_is_given_on_request_and_sees_past_the_local_maps_edge():
    """``local_map_wide`` is not among a navigation env's default keys; asked for, it is
    crossable ground over 12.8 m, the robot at its centre: where the two maps overlap it agrees
    with the local map's crossable layer, and past the local map's edge it shows ground and
    where the ground ends, each crossable cell on ground the scene lets the robot cross."""
    env = make_env("nav-clear", robot="wheeled")
    assert "local_map_wide" not in env.observation_space.spaces
    env.close()
    keys = ["goal", "local_map", "local_map_crossable", "local_map_wide"]
    env = make_env("nav-clear", robot="wheeled", observations=keys)
    obs, _ = env.reset(seed=25, options={"index": 25})
    assert env.observation_space.contains(obs) and obs["local_map_wide"].shape == (1, 32, 32)
    (wide,), (near,) = obs["local_map_wide"], obs["local_map_crossable"]
    m = LocalMap(localmap.WIDE_MAP)
    u, v = m.u.reshape(m.shape), m.v.reshape(m.shape)
    beyond = np.maximum(np.abs(u), np.abs(v)) > 3.2
    assert 0 < wide[beyond].mean() < 1
    # The local map's 0.2 m cells, 2 x 2 to a wide cell, over the middle 16 x 16 of the wide map.
    fine = near.reshape(16, 2, 16, 2).all(axis=(1, 3))
    assert np.count_nonzero(fine != (wide[8:24, 8:24] == 1)) <= 12
    e = env.unwrapped
    x, y, _, yaw = e.handle.pose(e.data)
    wx, wy = x + u * math.cos(yaw) - v * math.sin(yaw), y + u * math.sin(yaw) + v * math.cos(yaw)
    occ, crossable = e.prepared.occupancy, e.prepared.crossable
    for px, py in zip(wx[wide == 1], wy[wide == 1], strict=True):
        assert crossable[occ.cell(px, py)], (px, py)
    env.close()
