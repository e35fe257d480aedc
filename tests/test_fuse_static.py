"""A town's or a city's model (more than ``FUSE_FROM_GEOMS`` geoms) has its static bodies
fused into the world (citygen.runner.robots.handle.compose): the same geoms by name, where
they were, with their contact parameters; the moving agents keep their mocap bodies; a
fraction of the bodies; the robot moves as it did (the same physics, its contacts listed in
another order). Smaller scenes (the Urban-Nav squares) are compiled as they were."""

from __future__ import annotations

import functools

import mujoco
import numpy as np
import pytest

from citygen.geometry.terrain import height_at
from citygen.runner import scenes
from citygen.runner.robots import handle as H
from citygen.runner.robots.registry import load_robot
from citygen.runner.scenes import SceneSource


@functools.cache
def _composed(name: str):
    scene = SceneSource(split="urban-nav-2-test").scene(5)
    robot = load_robot(name)
    mjcf = scenes._scene_mjcf(scene)
    x, y = scene.task.start.position
    pose = (x, y, float(height_at(scene, x, y)), scene.task.start.yaw)
    assert mjcf.xml.count("<geom ") <= H.FUSE_FROM_GEOMS  # an Urban-Nav square: left as it was
    plain = H.compose(mjcf, robot, pose)
    was = H.FUSE_FROM_GEOMS
    H.FUSE_FROM_GEOMS = 0  # as if it were a town
    try:
        fused = H.compose(mjcf, robot, pose)
    finally:
        H.FUSE_FROM_GEOMS = was
    return scene, robot, plain, fused


@pytest.fixture
def composed():
    return _composed("quadruped")


def _named(model) -> dict[str, int]:
    return {model.geom(i).name: i for i in range(model.ngeom)}


def test_the_fused_model_has_the_same_geoms_where_they_were_and_fewer_bodies(composed):
    scene, _, plain, fused = composed
    assert plain.ngeom + 1 == fused.ngeom and fused.nbody < plain.nbody  # + the still body's
    static = plain.body_weldid[1:] == 0
    moving = (plain.body_mocapid[1:] >= 0) | ~static
    assert int(np.sum(static & (plain.body_mocapid[1:] < 0))) > 10  # objects' bodies, fused
    # the world, the robot's and the agents' bodies, and the still body (_still_world)
    assert fused.nbody == 1 + int(moving.sum()) + 1
    for a in scene.agents:
        assert fused.body_mocapid[fused.body(f"agent:{a.id}").id] >= 0
    dp, df = mujoco.MjData(plain), mujoco.MjData(fused)
    mujoco.mj_kinematics(plain, dp)
    mujoco.mj_kinematics(fused, df)
    a, b = _named(plain), _named(fused)
    assert b.pop(H.STILL_BODY) == fused.ngeom - 1
    assert a.keys() == b.keys() and "" not in a
    i, j = np.array(list(a.values())), np.array([b[n] for n in a])
    np.testing.assert_allclose(df.geom_xpos[j], dp.geom_xpos[i], atol=1e-9)
    np.testing.assert_allclose(df.geom_xmat[j], dp.geom_xmat[i], atol=1e-9)
    fields = ("geom_type", "geom_contype", "geom_conaffinity", "geom_friction", "geom_size", "geom_group")
    for field in fields:
        assert np.array_equal(getattr(fused, field)[j], getattr(plain, field)[i]), field


def test_the_robot_moves_in_the_fused_model_as_in_the_plain_one():
    _, robot, plain, fused = _composed("wheeled")  # on its wheels: in contact all along
    traces = []
    for model in (plain, fused):
        data = mujoco.MjData(model)
        handle = H.RobotHandle(model, robot)
        handle.reset(data, (*handle_start(model, data, handle), 0.0))
        mujoco.mj_forward(model, data)
        trace = []
        for _ in range(20):  # 2 s of the drive ahead and turning
            handle.control(data, 0.8 * robot.max_speed, 0.3 * robot.max_yaw_rate, 20)
            trace.append(np.array(data.qpos[handle.qadr : handle.qadr + 7]))
        traces.append(np.array(trace))
        assert data.ncon > 0
    np.testing.assert_allclose(traces[1], traces[0], atol=1e-6)


def handle_start(model, data, handle) -> tuple[float, float, float]:
    """Where the composed robot stands: its base's compiled place, the ground under it."""
    mujoco.mj_kinematics(model, data)
    x, y, z = data.xpos[handle.base_id]
    return float(x), float(y), float(z) - handle.robot.stand_height


def test_the_static_world_is_placed_once_and_the_robot_never_sleeps(composed):
    """_still_world: with sleeping on and the still body asleep, MuJoCo places the static
    world's geoms when the data is made and not at each step; the robot, standing still for
    3 s, stays awake and then drives off."""
    _, robot, plain, fused = composed
    assert not plain.opt.enableflags & mujoco.mjtEnableBit.mjENBL_SLEEP  # an Urban-Nav square's
    model = fused
    data = mujoco.MjData(model)
    handle = H.RobotHandle(model, robot)
    handle.reset(data, (*handle_start(model, data, handle), 0.0))
    world = np.flatnonzero(model.geom_bodyid == 0)
    placed = np.array(data.geom_xpos[world])
    assert np.abs(placed).sum() > 0  # placed by mj_resetData
    data.geom_xpos[world[0]] += 7.0  # a step that placed the world's geoms would undo this
    for _ in range(30):  # 3 s standing
        handle.control(data, 0.0, 0.0, 20)
    still = model.body_treeid[model.body(H.STILL_BODY).id]
    awake = np.flatnonzero(data.tree_awake)
    assert still not in awake and data.nbody_awake < model.nbody  # the filter is on
    assert model.body_treeid[handle.base_id] in awake  # the robot is not asleep
    np.testing.assert_array_equal(data.geom_xpos[world[0]], placed[0] + 7.0)
    np.testing.assert_array_equal(data.geom_xpos[world[1:]], placed[1:])
    x0 = data.xpos[handle.base_id, 0]
    for _ in range(10):
        handle.control(data, 0.8 * robot.max_speed, 0.0, 20)
    assert abs(data.xpos[handle.base_id, 0] - x0) > 0.3


def test_the_reach_leaves_a_fused_model_whole(composed, monkeypatch):
    """citygen.runner.envs.reach: a model whose static geoms are all the world's (fused) is
    stepped whole; the same scene compiled plain, its objects in bodies, gets a reach."""
    from citygen.runner.envs import reach as R

    _, robot, plain, fused = composed
    monkeypatch.setattr(R, "FROM_GEOMS", 1)  # as if the square were a city
    for model, want in ((plain, True), (fused, False)):
        handle = H.RobotHandle(model, robot)
        got = R.reach_of(model, mujoco.MjData(model), handle.geom_ids, handle.base_id)
        assert (got is not None) is want
