"""The humanoid (G1-like joints, feet and IK; stands a LocoFlat horizon, walks 5 m) and the
mobility scooter (Ackermann steering, K-turns, 15 km/h); every built-in robot is offered by
``citygen bench --robot`` and named by the spec."""

from __future__ import annotations

import math
from typing import get_args

import mujoco
import numpy as np
import pytest

from citygen.runner.bench import run_episode
from citygen.runner.control import gaits_biped
from citygen.runner.make import make_env
from citygen.runner.policies import make_policy
from citygen.runner.robots import BUILTIN, PREFIX, RobotHandle, compose, flat_ground, load_robot
from citygen.spec.task import Robot


def on_flat(name):
    robot = load_robot(name)
    model = compose(flat_ground(), robot, (0.0, 0.0, 0.0, 0.0))
    data = mujoco.MjData(model)
    handle = RobotHandle(model, robot)
    handle.reset(data, (0.0, 0.0, 0.0, 0.0))
    return model, data, handle


def test_humanoid_is_g1_like_with_21_position_servo_joints_and_box_feet():
    model, data, handle = on_flat("humanoid")
    robot = handle.robot
    hinges = [j for j in handle.joint_ids if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    actuated = {int(model.actuator_trnid[a, 0]) for a in range(model.nu)}
    assert len(hinges) == 21 and set(hinges) == actuated and handle.n_joints == 21
    assert np.all(model.actuator_biasprm[:, 1] == -model.actuator_gainprm[:, 0])  # position servos
    for side in ("left", "right"):
        for joint in ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll"):
            assert f"{side}_{joint}" in robot.leg_joints
        foot = model.geom(f"{PREFIX}{side}_foot")
        assert foot.type == mujoco.mjtGeom.mjGEOM_BOX and 0.18 < 2 * foot.size[0] < 0.26
    knee = model.actuator(f"{PREFIX}left_knee")
    assert knee.forcerange[1] == pytest.approx(139.0)  # G1's knee torque
    assert model.jnt_range[model.joint(f"{PREFIX}left_ankle_roll").id] == pytest.approx((-0.26, 0.26))
    top = max(data.geom_xpos[g][2] + model.geom_rbound[g] for g in handle.geom_ids)
    assert 1.25 < top < 1.4 and 0.6 < robot.stand_height < 0.75
    assert robot.nav_mode == "base" and robot.radius == 0.3 and len(robot.legs) == 2


def test_biped_leg_ik_matches_mujoco_with_the_foot_flat():
    model, data, handle = on_flat("humanoid")
    rng = np.random.default_rng(5)
    for i, (side, leg) in enumerate(zip(("left", "right"), handle.robot.legs, strict=True)):
        for _ in range(5):
            target = np.array([0.0, 0.0, -0.54]) + rng.uniform((-0.1, -0.1, -0.06), (0.1, 0.1, 0.06))
            q = gaits_biped.leg_ik(target, leg.thigh, leg.calf)
            data.qpos[handle.leg_qadr[6 * i : 6 * i + 6]] = q
            mujoco.mj_kinematics(model, data)
            ankle = model.body(f"{PREFIX}{side}_ankle").id
            hip = data.xpos[handle.base_id] + (leg.hip_x, leg.hip_y, 0.0)
            assert data.xpos[ankle] - hip == pytest.approx(target, abs=1e-9)
            foot = model.body(f"{PREFIX}{side}_foot").id
            assert data.xmat[foot] == pytest.approx(np.eye(3).ravel(), abs=1e-9)  # sole parallel


@pytest.fixture(scope="module")
def loco_flat():
    return make_env("loco-flat", split="urban-loc-1-test", robot="humanoid")


@pytest.mark.slow
def test_humanoid_stands_a_whole_loco_flat_horizon(loco_flat):
    result = run_episode(loco_flat, make_policy("stand"), seed=0, index=0)
    assert result["steps"] == 1000 and result["balance"] == 100.0
    assert abs(result["x_displacement"]) < 0.1


@pytest.mark.slow
def test_humanoid_walks_5m_on_loco_flat(loco_flat):
    result = run_episode(loco_flat, make_policy("trot"), seed=0, index=0)  # a biped's trot is its walk
    assert result["balance"] == 100.0 and result["x_displacement"] >= 5.0


def test_scooter_steers_ackermann_and_turns_by_k_turns():
    model, data, handle = on_flat("scooter")
    robot = handle.robot
    assert robot.nav_mode == "ackermann" and robot.max_speed == pytest.approx(15 / 3.6)
    left, right = (model.actuator(f"{PREFIX}{n}").id for n in robot.steer_actuators)
    for _ in range(int(3.0 / model.opt.timestep)):
        handle.drive(data, 1.5, 0.8)
        mujoco.mj_step(model, data)
    inner, outer = data.ctrl[left], data.ctrl[right]
    assert inner > outer > 0  # turning left: the inner (left) wheel steers more
    # both front wheels turn about one point on the rear axle's line (Ackermann geometry)
    centre_outer = robot.wheelbase / math.tan(outer) - robot.track_width / 2
    assert robot.wheelbase / math.tan(inner) + robot.track_width / 2 == pytest.approx(centre_outer, rel=1e-6)
    # asked to turn on the spot, it K-turns: the yaw keeps growing while it stays near its start
    handle.reset(data, (0.0, 0.0, 0.0, 0.0))
    yaw, turned, far = 0.0, 0.0, 0.0
    for _ in range(int(8.0 / model.opt.timestep)):
        handle.drive(data, 0.0, 1.0)
        mujoco.mj_step(model, data)
        x, y, _, new = handle.pose(data)
        turned += (new - yaw + math.pi) % (2 * math.pi) - math.pi
        yaw, far = new, max(far, math.hypot(x, y))
    assert turned > 2.0 and far < 1.5
    assert handle.body_contacts(data).size == 0


def test_scooter_tops_out_at_15_km_h():
    model, data, handle = on_flat("scooter")
    for _ in range(int(6.0 / model.opt.timestep)):
        handle.drive(data, 10.0, 0.0)
        mujoco.mj_step(model, data)
    assert handle.velocity(data)[0] == pytest.approx(15 / 3.6, rel=0.05)


def test_every_builtin_robot_is_a_spec_robot_and_in_bench_help(cli):
    assert set(get_args(Robot)) == set(BUILTIN)
    result = cli("bench", "--help")
    text = " ".join(result.out.split())
    assert result.code == 0
    for name in BUILTIN:
        assert name in text


def test_locomotion_robots_are_those_with_leg_joints():
    legged = {name for name in BUILTIN if load_robot(name).leg_joints}
    assert legged == {"quadruped", "wheeled_legged", "humanoid"}
