"""The runner's robots: built in code, composed into generated scenes, driven on flat ground.

Every built-in robot compiles alone and inside a generated Urban-Nav scene at its task
start; sizes and masses are those documented; the quadruped stands (PD hold and the stand
controller) and trots forward; ``drive`` tracks forward speed and yaw rate on every robot;
a user's MJCF and URDF robots load through an adapter and drive; bad adapters give one line.
"""

from __future__ import annotations

import math
import pickle

import mujoco
import numpy as np
import pytest

import citygen
from citygen.errors import CitygenError, SpecError
from citygen.exporters import mjcf
from citygen.geometry.terrain import height_at
from citygen.runner import robots
from citygen.runner.control import gaits
from citygen.runner.robots import BUILTIN, RobotHandle, compose, flat_ground, load_robot
from citygen.spec.task import ROBOT_RADIUS

CONTROL = 10  # physics steps per control step (50 Hz at the 0.002 s timestep)


def on_flat(name_or_robot):
    robot = load_robot(name_or_robot) if isinstance(name_or_robot, str) else name_or_robot
    model = compose(flat_ground(), robot, (0.0, 0.0, 0.0, 0.0))
    data = mujoco.MjData(model)
    handle = RobotHandle(model, robot)
    handle.reset(data, (0.0, 0.0, 0.0, 0.0))
    return model, data, handle


def extent(model, data, geoms):
    """Axis-aligned bounds (m) of geoms' oriented bounding boxes: (lo xyz, hi xyz)."""
    lo, hi = np.full(3, np.inf), np.full(3, -np.inf)
    for g in geoms:
        R = data.geom_xmat[g].reshape(3, 3)
        centre = data.geom_xpos[g] + R @ model.geom_aabb[g][:3]
        half = np.abs(R) @ model.geom_aabb[g][3:]
        lo, hi = np.minimum(lo, centre - half), np.maximum(hi, centre + half)
    return lo, hi


@pytest.mark.parametrize("name", BUILTIN)
def test_builtin_compiles_alone_and_in_a_generated_scene(name):
    robot = load_robot(name)
    alone = mujoco.MjModel.from_xml_string(robot.xml)
    assert alone.nbody >= 2 and alone.jnt_type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert robot.radius == ROBOT_RADIUS[name]
    assert pickle.loads(pickle.dumps(robot)) == robot
    scene = citygen.generate("urban-nav-2-test", index=0)
    (x, y), yaw = scene.task.start.position, scene.task.start.yaw
    z = float(height_at(scene, x, y))
    model = compose(mjcf.to_mjcf(scene), robot, (x, y, z, yaw))
    data = mujoco.MjData(model)
    handle = RobotHandle(model, robot)
    handle.reset(data, (x, y, z, yaw))
    px, py, pz, pyaw = handle.pose(data)
    assert (px, py) == pytest.approx((x, y)) and pz == pytest.approx(z + robot.stand_height)
    assert math.cos(pyaw - yaw) == pytest.approx(1.0)
    # robot geoms touch the static world and agents, never each other
    assert set(model.geom_contype[handle.geom_ids]) <= {0, 2}
    assert set(model.geom_conaffinity[handle.geom_ids]) <= {0, 5}
    assert model.opt.timestep == robot.timestep  # each robot its own (5 ms built in)
    assert model.opt.cone == getattr(mujoco.mjtCone, f"mjCONE_{robot.cone.upper()}")
    for _ in range(100):
        handle.drive(data, 0.0, 0.0)
        mujoco.mj_step(model, data)
    assert np.all(np.isfinite(data.qpos))
    assert abs(handle.pose(data)[2] - (z + robot.stand_height)) < 0.05  # still standing where put


def test_lowest_point_of_a_spinning_ellipsoid_tyre_is_its_lowest_surface_point():
    """The wheeled robot's tyres are ellipsoids: their lowest point wherever the wheel has
    turned to (a bounding box's corner would be up to 41 % of the radius too low)."""
    model = mujoco.MjModel.from_xml_string(load_robot("wheeled").xml)
    data = mujoco.MjData(model)
    tyre = model.geom("left_wheel").id
    assert model.geom_type[tyre] == mujoco.mjtGeom.mjGEOM_ELLIPSOID
    a, b = np.meshgrid(np.linspace(0, np.pi, 181), np.linspace(0, 2 * np.pi, 361))
    unit = np.stack([np.sin(a) * np.cos(b), np.sin(a) * np.sin(b), np.cos(a)], -1).reshape(-1, 3)
    for turn in (0.0, 0.4, math.pi / 4, 2.0):
        data.qpos[model.jnt_qposadr[model.joint("left_wheel").id]] = turn
        data.qpos[3:7] = (math.cos(0.1), math.sin(0.1), 0.0, 0.0)  # the base rolled a little
        mujoco.mj_kinematics(model, data)
        surface = data.geom_xpos[tyre] + (unit * model.geom_size[tyre]) @ data.geom_xmat[tyre].reshape(3, 3).T
        assert robots.lowest_point(model, data, tyre) == pytest.approx(surface[:, 2].min(), abs=2e-4)


SIZES = {  # name: (length range, width range, mass range) in m, m, kg
    "wheeled": ((0.65, 0.75), (0.5, 0.6), (40.0, 50.0)),
    "quadruped": ((0.5, 0.75), (0.25, 0.4), (13.0, 17.0)),
    "wheeled_legged": ((0.9, 1.3), (0.45, 0.9), (60.0, 80.0)),
    "wheelchair": ((1.0, 1.2), (0.6, 0.7), (100.0, 120.0)),
    "humanoid": ((0.22, 0.35), (0.4, 0.55), (32.0, 38.0)),
    "scooter": ((1.15, 1.35), (0.55, 0.7), (130.0, 150.0)),
}


@pytest.mark.parametrize("name", BUILTIN)
def test_sizes_and_masses_are_the_documented_ones(name):
    model, data, handle = on_flat(name)
    (length, width, mass) = SIZES[name]
    lo, hi = extent(model, data, handle.geom_ids)
    assert length[0] <= hi[0] - lo[0] <= length[1]
    assert width[0] <= hi[1] - lo[1] <= width[1]
    assert mass[0] <= handle.mass <= mass[1]
    assert handle.robot.mass == pytest.approx(handle.mass, abs=1e-3)
    feet = [robots.lowest_point(model, data, g) for g in handle.foot_geom_ids]
    assert min(feet) == pytest.approx(0.0, abs=1e-6)  # standing on the ground, not in it
    others = np.setdiff1d(handle.geom_ids, handle.foot_geom_ids)
    assert min(robots.lowest_point(model, data, g) for g in others) > 0.01  # only feet reach down


def test_quadruped_is_go2_like_with_12_actuated_hinges():
    robot = load_robot("quadruped")
    model, _, handle = on_flat(robot)
    trunk = model.geom("robot:trunk")
    assert 2 * trunk.size == pytest.approx((0.38, 0.093, 0.114), abs=0.01)
    hinges = [j for j in handle.joint_ids if model.jnt_type[j] == mujoco.mjtJoint.mjJNT_HINGE]
    actuated = {int(model.actuator_trnid[a, 0]) for a in range(model.nu)}
    assert len(hinges) == 12 and set(hinges) == actuated
    assert model.nu == 12 and handle.n_joints == 12
    assert 0.27 <= robot.stand_height <= 0.33
    # position servos: force = kp * (ctrl - q) - kd * qdot
    assert np.all(model.actuator_biasprm[:, 1] == -model.actuator_gainprm[:, 0])
    assert np.all(model.actuator_biasprm[:, 2] < 0)


def test_wheeled_legged_has_12_leg_joints_and_4_driven_wheels():
    model, _, handle = on_flat("wheeled_legged")
    assert handle.n_joints == 12 and len(handle.wheel_act) == 4 and model.nu == 16
    # velocity servos: force = kv * (ctrl - joint speed)
    assert np.all(model.actuator_gainprm[handle.wheel_act, 0] > 0)
    assert np.all(model.actuator_biasprm[handle.wheel_act, 2] == -model.actuator_gainprm[handle.wheel_act, 0])
    assert np.all(model.actuator_biasprm[handle.wheel_act, 1] == 0)


@pytest.mark.parametrize("name", ["quadruped", "wheeled_legged"])
def test_leg_inverse_kinematics_matches_mujoco(name):
    model, data, handle = on_flat(name)
    rng = np.random.default_rng(3)
    for i, leg in enumerate(handle.robot.legs):
        q = handle.default[3 * i : 3 * i + 3] + rng.uniform(-0.3, 0.3, 3)
        data.qpos[handle.leg_qadr[3 * i : 3 * i + 3]] = q
        mujoco.mj_kinematics(model, data)
        calf = model.body(f"robot:{leg.name}_calf").id
        foot = data.xpos[calf] + data.xmat[calf].reshape(3, 3) @ (0.0, 0.0, -leg.calf)
        hip = data.xpos[handle.base_id] + (leg.hip_x, leg.hip_y, 0.0)
        assert foot - hip == pytest.approx(leg.fk(q), abs=1e-9)
        assert leg.ik(leg.fk(q)) == pytest.approx(q, abs=1e-6)


def test_quadruped_stands_2s_on_its_pd():
    model, data, handle = on_flat("quadruped")
    for _ in range(int(2.0 / model.opt.timestep)):
        mujoco.mj_step(model, data)
        assert handle.body_contacts(data).size == 0  # only the feet touch the ground
    z = handle.pose(data)[2]
    assert abs(z - handle.robot.stand_height) < 0.03
    assert data.xmat[handle.base_id][8] > 0.99  # upright


def test_stand_controller_holds_the_quadruped_10s():
    model, data, handle = on_flat("quadruped")
    ctrl = gaits.StandController()
    heights = []
    for k in range(int(10.0 / (CONTROL * model.opt.timestep))):
        handle.joint_action(data, ctrl.act(handle, data, data.time))
        for _ in range(CONTROL):
            mujoco.mj_step(model, data)
        assert handle.body_contacts(data).size == 0
        if k * CONTROL * model.opt.timestep > 5.0:
            heights.append(handle.pose(data)[2])
    assert np.mean(heights) == pytest.approx(handle.robot.stand_height, abs=0.01)  # sag corrected
    x, y, _, yaw = handle.pose(data)
    assert math.hypot(x, y) < 0.1 and abs(yaw) < 0.05
    assert data.xmat[handle.base_id][8] > 0.99


def test_trot_moves_the_quadruped_forward():
    model, data, handle = on_flat("quadruped")
    ctrl = gaits.TrotController(command=(0.5, 0.0, 0.0))
    lowest = np.inf
    for _ in range(int(10.0 / (CONTROL * model.opt.timestep))):
        action = ctrl.act(handle, data, data.time)
        assert action.shape == (12,) and np.all(np.abs(action) <= 1.0)
        handle.joint_action(data, action)
        for _ in range(CONTROL):
            mujoco.mj_step(model, data)
        lowest = min(lowest, handle.pose(data)[2])
        assert data.xmat[handle.base_id][8] > 0.8  # never tips over
    x, y, _, _ = handle.pose(data)
    assert x >= 1.0 and abs(y) < 0.5 * x
    assert lowest > 0.2  # never sat down or fell
    assert handle.body_contacts(data).size == 0


def measure(model, data, handle, v, w, seconds=3.0):
    """Mean base velocity [vx, vy, vz, wz] over the last second of driving (v, w)."""
    steps = int(seconds / model.opt.timestep)
    tail = []
    for k in range(steps):
        handle.drive(data, v, w)
        mujoco.mj_step(model, data)
        if k >= steps - int(1.0 / model.opt.timestep):
            tail.append(handle.velocity(data))
    return np.mean(tail, axis=0)


@pytest.mark.parametrize("name", BUILTIN)
def test_drive_tracks_speed_and_yaw_rate(name):
    model, data, handle = on_flat(name)
    vel = measure(model, data, handle, 1.0, 0.0)
    assert vel[0] == pytest.approx(1.0, rel=0.15) and abs(vel[3]) < 0.05
    handle.reset(data, (0.0, 0.0, 0.0, 0.0))
    v = 1.5 if handle.robot.nav_mode == "ackermann" else 0.0  # no turning on the spot
    vel = measure(model, data, handle, v, 1.0)
    assert vel[3] == pytest.approx(1.0, rel=0.2)
    assert handle.body_contacts(data).size == 0  # drove on its feet or wheels only


def test_wheeled_legged_drives_level_at_full_speed_on_its_drive_pose():
    """From rest to 2 m/s at the drive's acceleration limit, then its fastest turn at 1 m/s:
    the base stays within 10 degrees of level, on all four wheels. On its walking stance (a
    0.46 m wheelbase under a 0.58 m base) the same start rode a wheelie: pitched 40 degrees
    at 1.5 m/s, the front wheels in the air, and tipped over at 2 m/s."""
    model, data, handle = on_flat("wheeled_legged")
    robot = handle.robot
    assert not np.allclose(handle.drive_pose, handle.default)
    handle.reset(data, (0.0, 0.0, 0.0, 0.0), drive=True)
    assert np.array_equal(data.qpos[handle.leg_qadr], handle.drive_pose)
    n, b = handle.drive_substeps, handle.base_id
    periods = round(1.0 / (n * model.opt.timestep))
    tilt = 0.0
    for v, w in ((robot.max_speed, 0.0), (robot.max_speed, 0.0), (1.0, robot.max_yaw_rate)):
        for _ in range(periods):
            handle.control(data, v, w, n)
            tilt = max(tilt, math.degrees(math.acos(min(1.0, data.xmat[b][8]))))
    assert tilt < 10.0
    assert handle.velocity(data)[3] > 0.8 * robot.max_yaw_rate
    assert handle.body_contacts(data).size == 0


@pytest.mark.parametrize("name", [n for n in BUILTIN if load_robot(n).nav_mode == "base"])
def test_ideal_locomotion_turns_with_its_nose_on_a_wall(name):
    """A legged robot pushing into a wall at full speed still turns when asked (its yaw torque
    is of the order of its push at the feet's lever, Robot.servo_yaw_gain): with the servo's
    old yaw gain of 10/s the contact's friction held it within 2 degrees for the 3 s, pinned,
    as learned policies were on benches in NavDynamic; the humanoid at the quadruped's 50/s
    turned 32 degrees (pinned on bins in NavDynamic), at its own 100/s about 150."""
    robot = load_robot(name)
    ground = flat_ground()
    wall = (
        f'<body name="object:wall"><geom name="object:wall:0" type="box" size="0.2 3 0.6" '
        f'pos="{robot.radius + 0.45} 0 0.6" contype="1" conaffinity="0" '
        'friction="0.75 0.005 0.0001"/></body>\n'
    )
    scene = mjcf.MJCF(ground.xml.replace("  </worldbody>", wall + "  </worldbody>"), ground.assets)
    model = compose(scene, robot, (0.0, 0.0, 0.0, 0.0))
    data = mujoco.MjData(model)
    handle = RobotHandle(model, robot)
    handle.reset(data, (0.0, 0.0, 0.0, 0.0))
    n = round(0.1 / model.opt.timestep)
    touched = False
    for _ in range(30):
        handle.control(data, robot.max_speed, robot.max_yaw_rate, n)
        touched |= handle.body_contacts(data).size > 0
    yaw = handle.pose(data)[3]
    assert touched  # it did reach the wall
    assert abs(math.degrees(yaw)) > 90.0


@pytest.mark.parametrize("name", [n for n in BUILTIN if load_robot(n).nav_mode in ("wheels", "ackermann")])
def test_drive_tracks_at_the_environments_drive_rate(name):
    """The environments call a wheel drive once per DRIVE_DT and hold its targets between."""
    model, data, handle = on_flat(name)
    k = handle.drive_substeps
    # 1 at 10 ms physics steps (a user's robot)
    assert k * model.opt.timestep == pytest.approx(robots.DRIVE_DT) and k >= 1
    for v, w in ((1.0, 0.0), (0.0, 1.0)):
        if handle.robot.nav_mode == "ackermann" and v == 0.0:
            v = 1.5  # no turning on the spot: an arc of 1.5 m radius
        handle.reset(data, (0.0, 0.0, 0.0, 0.0))
        tail = []
        steps = int(3.0 / model.opt.timestep)
        for i in range(0, steps, k):
            handle.drive(data, v, w, k * model.opt.timestep)
            mujoco.mj_step(model, data, nstep=k)
            if i >= steps - int(1.0 / model.opt.timestep):
                tail.append(handle.velocity(data))
        vel = np.mean(tail, axis=0)
        assert vel[0] == pytest.approx(v, rel=0.15, abs=0.05)
        assert vel[3] == pytest.approx(w, rel=0.2, abs=0.05)
        assert handle.body_contacts(data).size == 0


@pytest.mark.parametrize("name", [n for n in BUILTIN if load_robot(n).nav_mode == "base"])
def test_ideal_locomotion_servo_held_at_the_drive_rate_stays_level_and_leaves_locomotion_undamped(name):
    """The servo's forces are held for DRIVE_DT (its velocity feedback is the free joint's
    damping, which MuJoCo applies implicitly every physics step): at full speed and turn
    rate the trunk stays level at the hover height and tracks; a locomotion step after it
    gives the free joint back its own damping."""
    from citygen.runner.robots.handle import HOVER_CLEARANCE

    model, data, handle = on_flat(name)
    own = model.dof_damping[handle.dadr : handle.dadr + 6].copy()
    assert handle.drive_substeps * model.opt.timestep == pytest.approx(robots.DRIVE_DT)
    r = handle.robot
    n = round(0.1 / model.opt.timestep)
    ups, heights, vels = [], [], []
    for i in range(40):  # 4 s: accelerate, then hold full speed while turning
        handle.control(data, r.max_speed, r.max_yaw_rate * 0.5, n)
        ups.append(data.xmat[handle.base_id][8])
        heights.append(data.qpos[handle.qadr + 2])
        if i >= 20:
            vels.append(handle.velocity(data))
    assert np.all(np.isfinite(data.qpos)) and min(ups) > 0.995
    assert np.mean(heights[20:]) == pytest.approx(r.stand_height + HOVER_CLEARANCE, abs=0.02)
    vel = np.mean(vels, axis=0)
    assert vel[0] == pytest.approx(r.max_speed, rel=0.1)
    assert vel[3] == pytest.approx(r.max_yaw_rate * 0.5, rel=0.15)
    assert np.all(model.dof_damping[handle.dadr : handle.dadr + 6] > 0)
    handle.joint_action(data, np.zeros(handle.n_joints))
    assert np.array_equal(model.dof_damping[handle.dadr : handle.dadr + 6], own)


MJCF_ROBOT = """<mujoco model="cart">
  <worldbody>
    <body name="chassis" pos="0 0 0.2">
      <geom name="box" type="box" size="0.25 0.18 0.06" mass="12"/>
      <geom name="caster" type="sphere" size="0.05" pos="0.18 0 -0.07" mass="0.2"/>
      <body name="left" pos="-0.08 0.21 -0.04">
        <joint name="left_axle" axis="0 1 0"/>
        <geom name="left_tyre" type="cylinder" size="0.08 0.02" zaxis="0 1 0" mass="0.5"/>
      </body>
      <body name="right" pos="-0.08 -0.21 -0.04">
        <joint name="right_axle" axis="0 1 0"/>
        <geom name="right_tyre" type="cylinder" size="0.08 0.02" zaxis="0 1 0" mass="0.5"/>
      </body>
    </body>
  </worldbody>
</mujoco>
"""

URDF_ROBOT = """<robot name="diffbot">
  <link name="base_link">
    <inertial><mass value="10"/>{inertia}</inertial>
    <collision name="chassis"><origin xyz="0 0 0.06"/>
      <geometry><box size="0.4 0.3 0.1"/></geometry></collision>
  </link>
  <link name="caster_link">
    <inertial><mass value="0.2"/>{inertia}</inertial>
    <collision name="caster"><geometry><sphere radius="0.04"/></geometry></collision>
  </link>
  <joint name="caster_joint" type="fixed">
    <parent link="base_link"/><child link="caster_link"/><origin xyz="0.15 0 -0.02"/>
  </joint>
  {wheels}
</robot>
"""
URDF_WHEEL = """
  <link name="{side}_link">
    <inertial><mass value="0.5"/>{inertia}</inertial>
    <collision name="{side}_tyre"><origin rpy="1.5707963 0 0"/>
      <geometry><cylinder radius="0.06" length="0.03"/></geometry></collision>
  </link>
  <joint name="{side}_wheel" type="continuous">
    <parent link="base_link"/><child link="{side}_link"/><origin xyz="-0.05 {y} 0"/><axis xyz="0 1 0"/>
  </joint>"""
INERTIA = '<inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/>'


def test_custom_mjcf_robot_loads_through_an_adapter_and_drives(tmp_path):
    path = tmp_path / "cart.xml"
    path.write_text(MJCF_ROBOT)
    adapter = tmp_path / "cart.toml"
    adapter.write_text(
        'radius = 0.35\nmax_speed = 1.2\nmax_yaw_rate = 1.5\ncasters = ["caster"]\n'
        '[nav]\nmode = "wheels"\nleft = ["left_axle"]\nright = ["right_axle"]\n'
        "wheel_radius = 0.08\ntrack_width = 0.42\n"
    )
    robot = load_robot(path, adapter)
    assert robot.base_body == "chassis" and robot.mass == pytest.approx(13.2)
    assert robot.stand_height == pytest.approx(0.12)  # tyres 0.08 below the axles, 0.04 below the base
    assert set(robot.foot_geoms) == {"caster", "left_tyre", "right_tyre"}
    model, data, handle = on_flat(robot)
    assert measure(model, data, handle, 1.0, 0.0)[0] == pytest.approx(1.0, rel=0.15)
    handle.reset(data, (0.0, 0.0, 0.0, 0.0))
    assert measure(model, data, handle, 0.0, 1.0)[3] == pytest.approx(1.0, rel=0.2)


def test_custom_urdf_robot_loads_through_an_adapter_and_drives(tmp_path):
    wheels = "".join(
        URDF_WHEEL.format(side=s, y=y, inertia=INERTIA) for s, y in (("left", 0.17), ("right", -0.17))
    )
    path = tmp_path / "diffbot.urdf"
    path.write_text(URDF_ROBOT.format(wheels=wheels, inertia=INERTIA))
    adapter = {
        "radius": 0.3, "max_speed": 1.0, "max_yaw_rate": 1.5, "casters": ["caster"],
        "nav": {"mode": "wheels", "left": ["left_wheel"], "right": ["right_wheel"], "wheel_radius": 0.06,
                "track_width": 0.34},
    }  # fmt: skip
    robot = load_robot(path, adapter)
    assert robot.base_body == "base_link" and robot.mass == pytest.approx(11.2)
    assert robot.stand_height == pytest.approx(0.06)
    model, data, handle = on_flat(robot)
    assert measure(model, data, handle, 0.8, 0.0)[0] == pytest.approx(0.8, rel=0.15)
    handle.reset(data, (0.0, 0.0, 0.0, 0.0))
    assert measure(model, data, handle, 0.0, 1.0)[3] == pytest.approx(1.0, rel=0.2)


def test_custom_robot_with_ideal_base_servo_drives(tmp_path):
    path = tmp_path / "puck.xml"
    path.write_text(
        '<mujoco><worldbody><body name="puck"><geom name="disc" type="cylinder" size="0.25 0.1" '
        'mass="20"/></body></worldbody></mujoco>'
    )
    robot = load_robot(path, {"radius": 0.25, "max_speed": 1.0, "max_yaw_rate": 1.0, "nav": {"mode": "base"}})
    model, data, handle = on_flat(robot)
    assert measure(model, data, handle, 1.0, 0.0)[0] == pytest.approx(1.0, rel=0.15)


@pytest.mark.parametrize(
    ("text", "key"),
    [
        ('radius = 0.3\nmax_sped = 1.0\nmax_yaw_rate = 1.0\n[nav]\nmode = "base"\n', "$.max_sped"),
        ('radius = 0.3\nmax_speed = 1.0\nmax_yaw_rate = 1.0\n[nav]\nmode = "legs"\n', "$.nav.mode"),
        ('radius = -1\nmax_speed = 1.0\nmax_yaw_rate = 1.0\n[nav]\nmode = "base"\n', "$.radius"),
        ('radius = 0.3\nmax_speed = 1.0\nmax_yaw_rate = 1.0\n[nav]\nmode = "wheels"\nleft = ["nope"]\n'
         'right = ["right_axle"]\nwheel_radius = 0.08\ntrack_width = 0.4\n', "$.nav.left[0]"),
    ],
)  # fmt: skip
def test_bad_adapter_gives_one_line_naming_file_and_key(tmp_path, text, key):
    path = tmp_path / "cart.xml"
    path.write_text(MJCF_ROBOT)
    adapter = tmp_path / "bad.toml"
    adapter.write_text(text)
    with pytest.raises(SpecError) as err:
        load_robot(path, adapter)
    message = str(err.value)
    assert "\n" not in message
    assert message.startswith(f"{adapter}: {key}: expected")


def test_unknown_robot_is_a_clear_error_naming_the_builtin_ones():
    with pytest.raises(CitygenError, match="unknown robot 'rover'") as err:
        load_robot("rover")
    assert all(name in str(err.value) for name in BUILTIN)


def test_scene_rays_pass_through_the_robot_and_renderings_show_it():
    """The composed robot's geoms sit in their own group: the servo's ground probe (a ray of
    the scene's groups) under a foot finds the ground, not the leg above it, and a rendering
    with the environments' option shows the robot that the default option hides."""
    from citygen.runner.robots.handle import ROBOT_GROUP, render_option

    model, data, handle = on_flat("quadruped")
    assert set(model.geom_group[handle.geom_ids]) == {ROBOT_GROUP}
    foot = data.geom_xpos[handle.foot_geom_ids[0]]
    top = float(data.xpos[handle.base_id][2])
    assert handle._ground_at(data, float(foot[0]), float(foot[1]), top) == pytest.approx(0.0, abs=1e-9)
    with mujoco.Renderer(model, 64, 64) as renderer:
        cam = mujoco.MjvCamera()
        cam.lookat[:], cam.distance, cam.elevation = (0.0, 0.0, 0.3), 1.5, -20.0
        renderer.update_scene(data, camera=cam, scene_option=render_option())
        shown = renderer.render().copy()
        renderer.update_scene(data, camera=cam)
        hidden = renderer.render().copy()
    assert np.abs(shown.astype(int) - hidden.astype(int)).sum() > 0


@pytest.mark.parametrize("name", ["wheeled", "quadruped", "scooter"])
def test_control_step_equals_drive_before_each_period(name):
    """``control`` (the environments' one call per control step) moves the robot exactly as
    calling ``drive`` before every ``drive_substeps`` physics steps does."""
    model, data, handle = on_flat(name)
    other, other_handle = mujoco.MjData(model), RobotHandle(model, handle.robot)
    other_handle.reset(other, (0.0, 0.0, 0.0, 0.0))
    k, h, n = handle.drive_substeps, model.opt.timestep, 21
    for v, w in [(0.8, 0.3), (1.0, -1.0), (1.5, 0.0)]:
        handle.control(data, v, w, n)
        done = 0
        while done < n:
            m = min(k, n - done)
            other_handle.drive(other, v, w, m * h)
            mujoco.mj_step(model, other, nstep=m)
            done += m
    assert np.array_equal(data.qpos, other.qpos) and np.array_equal(data.qvel, other.qvel)
    assert math.hypot(*data.qpos[handle.qadr : handle.qadr + 2]) > 0.002  # it moved
