"""A robot inside a scene: :func:`compose` puts it in a compiled model, :class:`RobotHandle`
resets, reads and drives it there (the wheel drive, the ideal-locomotion servo, joint targets)."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from citygen.errors import CitygenError, ExportError
from citygen.exporters.mjcf.contract import MJCF, ROBOT_BIT, ROBOT_CONAFFINITY, MJCFTree, import_mujoco
from citygen.exporters.mjcf.parse import compile_spec, elements, scene_spec
from citygen.runner.robots.base import _GRAVITY, HOVER_CLEARANCE, IMPRATIO, PREFIX, Robot, _v


def flat_ground(size: float = 40.0, friction: float = 0.75) -> MJCF:
    """A scene of flat ground only: a static box ``size`` metres square, top at z = 0, with
    the scene exporter's contact bits and the given sliding friction (concrete's by default)."""
    xml = (
        '<mujoco model="flat">\n  <compiler angle="radian" autolimits="true"/>\n  <worldbody>\n'
        f'    <geom name="zone:none:ground:0" type="box" size="{_v(size / 2, size / 2, 0.5)}" pos="0 0 -0.5" '
        f'contype="1" conaffinity="0" priority="1" friction="{_v(friction, 0.005, 0.0001)}" '
        'rgba="0.8 0.8 0.78 1"/>\n'
        '    <light name="sun" directional="true" dir="0.3 0.4 -1" pos="0 0 10"/>\n'
        "  </worldbody>\n</mujoco>\n"
    )
    return MJCF(xml, {})


#: Geoms of a scene (its MJCF's) above which :func:`compose` fuses the static bodies into the
#: world (MuJoCo's ``fusestatic``) and gives MuJoCo an arena for its broadphase: a town or a
#: city, never an Urban-Nav square or a locomotion grid, whose models stay as they were.
FUSE_FROM_GEOMS = 2000


def compose(
    scene_mjcf: MJCF | MJCFTree,
    robot: Robot,
    pose: tuple[float, float, float, float],
    big: bool | None = None,
) -> Any:
    """The scene with the robot in it, compiled: a ``mujoco.MjModel``.

    ``pose = (x, y, ground_z, yaw)`` in m and rad: the robot stands there (its base
    origin ``robot.stand_height`` above ``ground_z``; :meth:`RobotHandle.reset` puts it
    anywhere later). The robot's names get the prefix :data:`PREFIX`; the physics step
    is ``robot.timestep`` with the implicit-fast integrator. A scene of more than
    :data:`FUSE_FROM_GEOMS` geoms has its bodies without a joint (but mocap bodies: the moving
    agents) fused into their parents: the same geoms by name, a fraction of the bodies;
    ``big`` says whether to treat the scene so whatever its count (a window of a locomotion
    grid is compiled as its whole grid was: :mod:`citygen.runner.envs.window`).
    """
    mujoco = import_mujoco()
    x, y, z, yaw = (float(v) for v in pose)
    # A city holds ~10^5 static geoms: MuJoCo's default arena is too small for its broadphase.
    # Counted in the text or tree: MjSpec.geoms wraps every element in Python (minutes for a city).
    n = elements(scene_mjcf, "geom")
    big = n > FUSE_FROM_GEOMS if big is None else big
    try:
        # A city's in chunks (MuJoCo's parser is quadratic); a town's or a city's static
        # bodies read as frames, what fusing them would make of them, at none of its cost
        scene = scene_spec(scene_mjcf, frames=big)
        child = mujoco.MjSpec.from_string(robot.xml, assets=dict(robot.assets))
    except ValueError as exc:
        raise ExportError(f"compose: MuJoCo rejected the {robot.name!r} robot or the scene: {exc}") from None
    base = child.body(robot.base_body)
    base.pos, base.quat = [0.0, 0.0, robot.stand_height], [1.0, 0.0, 0.0, 0.0]
    for geom in child.geoms:
        if geom.contype or geom.conaffinity:
            geom.contype, geom.conaffinity = ROBOT_BIT, ROBOT_CONAFFINITY
        # The robot's own geom groups (ROBOT_GROUP, its hidden ones ROBOT_HIDDEN_GROUP): a
        # ray of the scene's groups (SCENE_GROUPS) passes through the robot in one C call.
        geom.group = ROBOT_GROUP if geom.group < ROBOT_GROUP else ROBOT_HIDDEN_GROUP
    for spec in (scene, child):  # equal options, so attaching has nothing to reconcile
        spec.option.timestep = robot.timestep
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.cone = getattr(mujoco.mjtCone, f"mjCONE_{robot.cone.upper()}")
        spec.option.impratio = IMPRATIO
    if big:
        scene.memory = max(scene.memory, n * 16 * 1024)
        # The static objects' bodies (7,900 on a city) fused into the world: MuJoCo's passes
        # over bodies run at every physics step whatever the body, so a static body costs as
        # a moving one; its steps' physics went 44 -> 29 ms. Their geoms keep their names,
        # places and contact parameters. scene_spec has already read them as frames of the
        # world (MuJoCo's fusing took 17 s of CPU of a city's compile); fusestatic is kept for
        # what is left, the robot's static bodies, so that the model is the same to the byte.
        scene.compiler.fusestatic = True
    frame = scene.worldbody.add_frame(pos=[x, y, z], quat=[math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    scene.attach(child, prefix=PREFIX, frame=frame)
    if big:
        _still_world(scene, mujoco)
    try:
        model = compile_spec(scene)
    except ValueError as exc:
        raise ExportError(
            f"compose: MuJoCo rejected the scene with the {robot.name!r} robot: {exc}"
        ) from None
    if big:  # the robot's tree (any but the still body's) never sleeps
        still = model.body_treeid[model.body(STILL_BODY).id]
        keep = np.arange(model.ntree) != still
        model.tree_sleep_policy[keep] = mujoco.mjtSleepPolicy.mjSLEEP_NEVER
    return model


#: Name of the body :func:`_still_world` adds to a town's or a city's model.
STILL_BODY = "citygen:still"


def _still_world(spec: Any, mujoco: Any) -> None:
    """Keep MuJoCo from recomputing the static world's geoms at every physics step.

    MuJoCo's kinematics places every geom of every body at every step (on a city 118,000 geoms,
    20 times a control step: most of its physics) unless sleeping is enabled and some tree is
    asleep: then bodies welded to the world (``mjS_STATIC``, the world body and its fused
    geoms) are placed once, by ``mj_resetData`` (every new MjData), and skipped after. The
    robot's tree is set never to sleep (by :func:`compose`, once compiled), the agents' mocap
    bodies are always awake, and one tree that is asleep from the start and touches nothing
    (:data:`STILL_BODY`: a slider far below the scene, collision bits 0, in the robot's hidden
    geom group) turns the filter on. The robot's physics is the same to the bit: its dofs are
    stepped in the same order, its contacts found against the same geom places
    (``tests/test_fuse_static.py``)."""
    spec.option.enableflags |= mujoco.mjtEnableBit.mjENBL_SLEEP
    still = spec.worldbody.add_body(name=STILL_BODY, pos=[0.0, 0.0, -1000.0])
    still.sleep = mujoco.mjtSleepPolicy.mjSLEEP_INIT
    still.add_joint(name=STILL_BODY, type=mujoco.mjtJoint.mjJNT_SLIDE, axis=[0.0, 0.0, 1.0])
    still.add_geom(
        name=STILL_BODY, type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[0.01, 0.0, 0.0], mass=0.001,
        contype=0, conaffinity=0, group=ROBOT_HIDDEN_GROUP,
    )  # fmt: skip


#: Geom group of a composed robot's geoms (the scene's are 0 ground, 1 objects, 2 agents) and
#: of those its own file hid (groups 3-5 there); renderings of the environments show
#: :data:`ROBOT_GROUP` (:func:`render_option`).
ROBOT_GROUP, ROBOT_HIDDEN_GROUP = 3, 5
#: ``mj_ray``'s geom group filter of the scene alone: ground, objects and agents.
SCENE_GROUPS = np.array([1, 1, 1, 0, 0, 0], dtype=np.uint8)


def render_option() -> Any:
    """A ``mujoco.MjvOption`` that shows the scene's groups and the robot's (:data:`ROBOT_GROUP`)."""
    mujoco = import_mujoco()
    opt = mujoco.MjvOption()
    opt.geomgroup[ROBOT_GROUP] = 1
    return opt


# --- driving a robot in a compiled model ------------------------------------------------------

#: Period (s) of the wheel drive's feedback loop as the environments run it: they call
#: :meth:`RobotHandle.drive` of a wheeled robot once per period and hold its wheel speed
#: targets for the physics steps in between (100 Hz: every 2 physics steps of the built-in
#: robots' 5 ms, every 5 of the default 2 ms (:attr:`Robot.timestep`); real wheel
#: controllers run at 100-1000 Hz). The wheels' velocity actuators and the legs' PD act at
#: every physics step inside MuJoCo. The ideal-locomotion servo (``nav_mode == "base"``)
#: stands in for a locomotion policy with stiff force feedback and runs at the same rate:
#: its velocity feedback is damping of the base's free joint, which MuJoCo applies
#: implicitly at every physics step (held as explicit forces for 10 ms, its attitude loop
#: diverged), and its springs and push are held; its gain's composite inertia, which
#: changes with the legs' pose alone, and its footprint's ground are recomputed every
#: :data:`SERVO_REFRESH_DT`.
DRIVE_DT = 0.01
#: Period (s) at which the ideal-locomotion servo recomputes its composite inertia and the
#: ground under and ahead of its feet (:data:`SERVO_LOOKAHEAD`): 50 Hz, 2 cm of travel at
#: 1 m/s against a look-ahead of 25 cm (quadruped planner success on Urban-Nav-2 is the same
#: as at 100 Hz, for half the probes).
SERVO_REFRESH_DT = 0.02

# Drive feedback: wheel speeds get the command plus these gains (1) times the error of the
# measured forward speed and yaw rate, and these gains (1/s) times its integral.
_WHEEL_P, _WHEEL_I = 0.5, 3.0
# Ideal-locomotion servo: planar velocity (1/s), height (1/s^2, 1/s), attitude (1/s^2, 1/s);
# its yaw gain is the robot's (Robot.servo_yaw_gain: a torque of the order of its push at the
# feet's lever, so that a robot with its nose on a bench still turns while it pushes).
_SERVO_V, _SERVO_KP, _SERVO_KD = 10.0, 400.0, 40.0
#: Ackermann steering's K-turn (see :meth:`RobotHandle.drive`): top speed (m/s) and the
#: time (s) of each forward or backward leg.
KTURN_SPEED, KTURN_PERIOD = 0.6, 1.5
#: Ideal locomotion stands on the highest ground under its feet and this far (m) ahead of its
#: front feet and behind its rear feet: the hover height rises before a foot meets a stair
#: riser (the height loop needs ~0.2 s, 0.2 m at full speed) and falls once the last foot is
#: past an edge, and no foot drags on a crest, a slope or a bump.
SERVO_LOOKAHEAD = 0.25


def yaw_of(quat: Any) -> float:
    """Yaw (rad) of a unit quaternion ``(w, x, y, z)`` (any sequence of 4 numbers)."""
    w, x, y, z = (float(v) for v in quat)
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def _clamp(x: float, limit: float) -> float:
    return -limit if x < -limit else limit if x > limit else x


class RobotHandle:
    """A robot inside a compiled model (from :func:`compose`): ids, reset, state, drive.

    ``geom_ids``, ``body_ids``: all of the robot's; ``foot_geom_ids``: those allowed to
    touch the ground. Arrays are of MuJoCo ids in ``model``. ``drive_substeps``: physics
    steps per call of :meth:`drive` in the environments (a :data:`DRIVE_DT` period).
    """

    def __init__(self, model: Any, robot: Robot, prefix: str = PREFIX) -> None:
        mujoco = import_mujoco()
        self.model, self.robot, self._mj = model, robot, mujoco
        try:
            self.base_id = model.body(prefix + robot.base_body).id
            self.foot_geom_ids = np.array([model.geom(prefix + n).id for n in robot.foot_geoms], dtype=int)
            self.leg_act = np.array([model.actuator(prefix + n).id for n in robot.leg_actuators], dtype=int)
            joints = [model.joint(prefix + n).id for n in robot.leg_joints]
            self.left = np.array([model.actuator(prefix + n).id for n in robot.left_wheels], dtype=int)
            self.right = np.array([model.actuator(prefix + n).id for n in robot.right_wheels], dtype=int)
            self._steer_ids = [model.actuator(prefix + n).id for n in robot.steer_actuators]
        except KeyError as exc:
            raise CitygenError(
                f"the model holds no robot {robot.name!r} under the prefix {prefix!r}: {exc}"
            ) from None
        root = self.base_id
        jnt = model.body_jntadr[root]
        if jnt < 0 or model.jnt_type[jnt] != mujoco.mjtJoint.mjJNT_FREE:
            raise CitygenError(f"the robot {robot.name!r}'s base has no free joint")
        self.qadr, self.dadr = int(model.jnt_qposadr[jnt]), int(model.jnt_dofadr[jnt])
        self.body_ids = np.flatnonzero(model.body_rootid == root)
        self.geom_ids = np.flatnonzero(np.isin(model.geom_bodyid, self.body_ids))
        self.joint_ids = np.flatnonzero(np.isin(model.jnt_bodyid, self.body_ids))
        self.dof_ids = np.flatnonzero(np.isin(model.dof_bodyid, self.body_ids))
        self.leg_qadr = model.jnt_qposadr[joints].astype(int)
        self.leg_dadr = model.jnt_dofadr[joints].astype(int)
        self.wheel_act = np.concatenate([self.left, self.right])
        # Wheels a locomotion action drives (Robot.loco_wheels) and the dofs of their joints.
        self.loco_wheels = np.array([model.actuator(prefix + n).id for n in robot.loco_wheels], dtype=int)
        self.loco_wheel_dadr = model.jnt_dofadr[model.actuator_trnid[self.loco_wheels, 0]].astype(int)
        self.wheel_speed = robot.max_speed / robot.wheel_radius if self.loco_wheels.size else 0.0
        self.mass = float(model.body_subtreemass[root])
        self.default = np.array(robot.default_pose, dtype=float)
        self.drive_pose = np.array(robot.drive_pose or robot.default_pose, dtype=float)
        self.scale = np.array(robot.action_scale, dtype=float)
        self._is_robot_geom = np.zeros(model.ngeom, dtype=bool)
        self._is_robot_geom[self.geom_ids] = True
        self._not_foot = self._is_robot_geom.copy()
        self._not_foot[self.foot_geom_ids] = False
        self.drive_substeps = max(1, round(DRIVE_DT / model.opt.timestep))
        # Drive state: the integral of the speed and yaw-rate errors, the ramped reference.
        self._integral = (0.0, 0.0)
        self._ref = (0.0, 0.0)
        self._ground: float | None = None
        self._kturn_time = 0.0  # s of the current K-turn (Ackermann steering)
        self._servo_age = math.inf  # s since the servo's inertia was computed
        self._servo_inertia = 0.0  # kg m^2
        # The servo's damping of the base's free joint (_damp) and the model's own.
        self._free_damping = model.dof_damping[self.dadr : self.dadr + 6].copy()
        self._damped = False
        # Constants of the drive, read once: plain floats and ids (the drive runs often).
        self._timestep = float(model.opt.timestep)
        self._left_ids = [int(a) for a in self.left]
        self._right_ids = [int(a) for a in self.right]
        self._mass_list = model.body_mass[self.body_ids].tolist()
        self._half_inertia = float(model.body_inertia[self.body_ids].sum() / 2)
        self._ray_point = np.zeros(3)
        self._ray_down = np.array([0.0, 0.0, -1.0])
        self._ray_geom = np.zeros(1, dtype=np.int32)
        self._footprint_ground = -math.inf  # m: highest ground at the footprint's probes
        self.terrain: Any = None
        """Where the ground is, if known without casting rays: an object whose
        ``ground_at(x, y)`` gives the ground's height (m) at a point (such as
        :class:`~citygen.runner.scenes.Prepared`'s raster of the scene's terrain, a few
        microseconds where a ray through the scene costs ~10). The servo then stands on the
        terrain alone: objects and people under it are obstacles, not ground."""

    @property
    def n_joints(self) -> int:
        return self.robot.n_joints

    def reset(self, data: Any, pose: tuple[float, float, float, float], drive: bool = False) -> None:
        """Put the robot standing at ``pose = (x, y, ground_z, yaw)`` (m, rad), legs in the
        default pose (``drive``: in the wheel drive's, :attr:`Robot.drive_pose`), every robot
        velocity, applied force and drive integral zero; runs ``mj_forward``."""
        m = self.model
        x, y, z, yaw = (float(v) for v in pose)
        for j in self.joint_ids:
            a, n = m.jnt_qposadr[j], (7 if m.jnt_type[j] == 0 else 4 if m.jnt_type[j] == 1 else 1)
            data.qpos[a : a + n] = m.qpos0[a : a + n]
        q = self.qadr
        data.qpos[q : q + 7] = (x, y, z + self.robot.stand_height, math.cos(yaw / 2), 0, 0, math.sin(yaw / 2))
        legs = self.drive_pose if drive else self.default
        data.qpos[self.leg_qadr] = legs
        data.qvel[self.dof_ids] = 0.0
        data.qacc_warmstart[self.dof_ids] = 0.0
        data.ctrl[self.leg_act] = legs
        data.ctrl[self.wheel_act] = 0.0
        data.ctrl[self._steer_ids] = 0.0
        data.xfrc_applied[self.body_ids] = 0.0
        self._integral = (0.0, 0.0)
        self._ref = (0.0, 0.0)
        self._ground = z
        self._kturn_time = 0.0
        self._footprint_ground = -math.inf
        self._servo_age = math.inf
        self._undamp()
        self._mj.mj_forward(m, data)

    def pose(self, data: Any) -> tuple[float, float, float, float]:
        """``(x, y, z, yaw)`` of the base origin, in m and rad (z is the base's height)."""
        x, y, z, qw, qx, qy, qz = data.qpos[self.qadr : self.qadr + 7].tolist()
        return x, y, z, math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))

    def velocity(self, data: Any) -> np.ndarray:
        """``[vx, vy, vz, wz]`` of the base (m/s, rad/s) in its yaw frame (x forward, z up)."""
        return np.array(self._velocity(data))

    def _velocity(self, data: Any) -> tuple[float, float, float, float]:
        """:meth:`velocity` as plain floats."""
        qw, qx, qy, qz = data.qpos[self.qadr + 3 : self.qadr + 7].tolist()
        lx, ly, lz, ax, ay, az = data.qvel[self.dadr : self.dadr + 6].tolist()
        r = data.xmat[self.base_id].tolist()  # row-major 3x3; the free joint's spin is local
        yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
        c, s = math.cos(yaw), math.sin(yaw)
        return c * lx + s * ly, -s * lx + c * ly, lz, r[6] * ax + r[7] * ay + r[8] * az

    def drive(self, data: Any, v: float, w: float, dt: float | None = None) -> None:
        """Track forward speed ``v`` (m/s) and yaw rate ``w`` (rad/s), clipped to the
        robot's limits and approached at its acceleration limits. Call it once per feedback
        period ``dt`` (s; default one physics step): it feeds back the base's measured
        motion (wheel robots: a PI correction of the wheel speeds, and the front wheels'
        Ackermann angles with ``nav_mode == "ackermann"``, which turns on the spot by
        K-turns; ideal locomotion: the base servo's forces in ``data.xfrc_applied`` and its
        damping of the free joint) and its outputs hold until the next call. The
        environments call it every :data:`DRIVE_DT`."""
        r = self.robot
        dt = self._timestep if dt is None else float(dt)
        if r.nav_mode == "base":
            self._servo(data, v, w, (1,), dt, step=False)
            return
        self._wheels(data, v, w, (1,), dt, step=False)

    def control(self, data: Any, v: float, w: float, nstep: int) -> None:
        """One control step of ``nstep`` physics steps holding the command ``(v, w)``: the
        same as calling :meth:`drive` (its ``dt`` the time until the next call) before every
        :attr:`drive_substeps` of them, in one Python call whose loop reads MuJoCo's arrays
        through views bound once (the environments' hot loop)."""
        k = self.drive_substeps
        periods = (k,) * (nstep // k) + ((nstep % k,) if nstep % k else ())
        if self.robot.nav_mode == "base":
            self._servo(data, v, w, periods, self._timestep)
            return
        self._wheels(data, v, w, periods, self._timestep)

    def _wheels(
        self, data: Any, v: float, w: float, periods: tuple[int, ...], h: float, step: bool = True
    ) -> None:
        """The wheel drive for feedback periods of ``periods[i] * h`` s each, MuJoCo stepping
        each period's physics steps (of ``h`` s) in one call if ``step``: the reference
        approaches the command at the acceleration limits, a PI correction of the measured
        forward speed and yaw rate sets the wheel speeds (and Ackermann angles)."""
        r, mj, model = self.robot, self._mj, self.model
        v = _clamp(float(v), r.max_speed)
        w = _clamp(float(w), r.max_yaw_rate)
        ctrl = data.ctrl
        if self.leg_act.size:
            ctrl[self.leg_act] = self.drive_pose
        rv, rw = self._ref
        iv, iw = self._integral
        b, qa, da = self.base_id, self.qadr, self.dadr
        # views bound once: MuJoCo's arrays stay where they are between steps
        quat, vel, xmat = data.qpos[qa + 3 : qa + 7], data.qvel[da : da + 6], data.xmat[b]
        radius, kturn, half_track = r.wheel_radius, r.nav_mode == "ackermann", r.track_width / 2
        max_accel, max_yaw_accel = r.max_accel, r.max_yaw_accel
        left_ids, right_ids, steer = self._left_ids, self._right_ids, bool(self._steer_ids)
        atan2, cos, sin, mj_step = math.atan2, math.cos, math.sin, mj.mj_step
        for m in periods:
            dt = m * h
            # the reference approaches the command at the robot's acceleration limits
            rv += _clamp(v - rv, dt * max_accel)
            rw += _clamp(w - rw, dt * max_yaw_accel)
            drive_v = self._kturn(rv, rw, dt) if kturn else rv
            qw, qx, qy, qz = quat.tolist()
            lx, ly, _, ax, ay, az = vel.tolist()
            _, _, _, _, _, _, r6, r7, r8 = xmat.tolist()  # the free joint's spin is local
            yaw = atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
            ev = drive_v - (cos(yaw) * lx + sin(yaw) * ly)
            ew = rw - (r6 * ax + r7 * ay + r8 * az)
            iv, iw = _clamp(iv + ev * dt, 1.0), _clamp(iw + ew * dt, 1.0)
            vc = drive_v + _WHEEL_P * ev + _WHEEL_I * iv
            wc = rw + _WHEEL_P * ew + _WHEEL_I * iw
            half = wc * half_track
            if steer:
                self._steer(ctrl, vc, wc)
            left, right = (vc - half) / radius, (vc + half) / radius
            for a in left_ids:
                ctrl[a] = left
            for a in right_ids:
                ctrl[a] = right
            if step:
                mj_step(model, data, nstep=m)
        self._ref, self._integral = (rv, rw), (iv, iw)

    def _servo(
        self, data: Any, v: float, w: float, periods: tuple[int, ...], h: float, step: bool = True
    ) -> None:
        """Ideal locomotion for feedback periods of ``periods[i] * h`` s each (MuJoCo stepping
        each period's physics steps of ``h`` s in one call if ``step``): base forces and
        torques that carry the weight at the hover height, keep the trunk level and track the
        ramped ``(v, w)``. The servo is a PD loop split in two: its velocity feedback is
        damping of the base's free joint (``model.dof_damping``, which MuJoCo's integrator
        applies implicitly at every physics step, so it stays stable however long the rest is
        held), and the rest (weight, the height and attitude springs, the velocity
        reference's push) are forces in ``data.xfrc_applied`` held for the period. The hover
        height stands on the highest of the ground under the base (every period: it must
        follow edges and objects as the base passes over them) and the ground under and
        beyond the feet (:meth:`_footprint_probe`, so that they clear a stair riser, a crest
        or a slope); the probe and the composite inertia are recomputed every
        :data:`SERVO_REFRESH_DT`. Arithmetic on plain floats, MuJoCo's arrays read through
        views bound once."""
        r, mj, model = self.robot, self._mj, self.model
        v = _clamp(float(v), r.max_speed)
        w = _clamp(float(w), r.max_yaw_rate)
        if self.leg_act.size:
            data.ctrl[self.leg_act] = self.default
        rv, rw = self._ref
        b, qa = self.base_id, self.qadr
        qpos, xfrc = data.qpos, data.xfrc_applied
        xmat, base_pos, base_com = data.xmat[b], data.xpos[b], data.xipos[b]
        ray, down, gid, mj_step = mj.mj_ray, self._ray_down, self._ray_geom, mj.mj_step
        m, stand = self.mass, r.stand_height
        fv, weight = m * _SERVO_V, m * _GRAVITY
        terrain = self.terrain
        ground_at = terrain.ground_at if terrain is not None else None
        if not self._damped:
            self._damp(self._servo_inertia)
        for k in periods:
            dt = k * h
            rv += _clamp(v - rv, dt * r.max_accel)
            rw += _clamp(w - rw, dt * r.max_yaw_accel)
            self._servo_age += dt
            if self._servo_age >= SERVO_REFRESH_DT - 1e-9:
                self._servo_age = 0.0
                self._servo_inertia = self._inertia(data)
                self._footprint_ground = self._footprint_probe(data)
                self._damp(self._servo_inertia)
            inertia = self._servo_inertia
            if ground_at is not None:
                bx, by, _ = base_pos.tolist()
                self._ground = ground_at(bx, by)
            else:
                dist = ray(model, data, base_pos, down, SCENE_GROUPS, 1, -1, gid)
                if dist >= 0:
                    self._ground = float(base_pos[2]) - dist
            below = self._ground if self._ground is not None else 0.0
            fg = self._footprint_ground
            target = (below if below >= fg else fg) + stand + HOVER_CLEARANCE
            _, _, r2, _, _, r5, _, _, _ = xmat.tolist()
            z, qw, qx, qy, qz = qpos[qa + 2 : qa + 7].tolist()
            yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
            fx, fy = fv * rv * math.cos(yaw), fv * rv * math.sin(yaw)
            # xfrc_applied acts at the base body's centre of mass, the free joint's damping at
            # its origin: the reference's push acts at the origin too (the torque of the
            # offset), so at speed push and damping cancel without tipping a tall trunk.
            ox, oy, oz = base_pos.tolist()
            cx, cy, cz = base_com.tolist()
            dx, dy, dz = ox - cx, oy - cy, oz - cz
            # tilt = (base z axis) x (world z); the damping (_damp) is the loop's D part
            xfrc[b] = (
                fx,
                fy,
                weight + m * _SERVO_KP * (target - z),
                inertia * _SERVO_KP * r5 - dz * fy,
                inertia * _SERVO_KP * -r2 + dz * fx,
                inertia * self.robot.servo_yaw_gain * rw + dx * fy - dy * fx,
            )
            if step:
                mj_step(model, data, nstep=k)
        self._ref = (rv, rw)

    def _damp(self, inertia: float) -> None:
        """The servo's velocity feedback as damping of the base's free joint: its planar
        velocity (gain ``_SERVO_V`` x mass), its height (``_SERVO_KD`` x mass; the free
        joint's linear velocity is in the world frame), its roll and pitch rates
        (``_SERVO_KD`` x ``inertia``) and its yaw rate (:attr:`Robot.servo_yaw_gain` x ``inertia``; the
        angular velocity is in the base's frame, which the servo keeps level)."""
        m, a = self.mass, self.dadr
        self.model.dof_damping[a : a + 6] = (
            m * _SERVO_V, m * _SERVO_V, m * _SERVO_KD,
            inertia * _SERVO_KD, inertia * _SERVO_KD, inertia * self.robot.servo_yaw_gain,
        )  # fmt: skip
        self._damped = True

    def _undamp(self) -> None:
        """The base's free joint as the model had it (locomotion: no servo)."""
        if self._damped:
            self.model.dof_damping[self.dadr : self.dadr + 6] = self._free_damping
            self._damped = False

    def _kturn(self, v: float, w: float, dt: float) -> float:
        """Ackermann steering cannot turn on the spot: a yaw rate ``w`` (rad/s) asked at a
        speed ``v`` (m/s) below both :data:`KTURN_SPEED` and the tightest turn's becomes a
        K-turn (forward and back in turns of :data:`KTURN_PERIOD`, steering the other
        way when reversing, so the yaw keeps its sign); the speed to drive."""
        need = abs(w) * self.robot.wheelbase / math.tan(self.robot.max_steer)
        if abs(v) >= min(need, KTURN_SPEED):
            self._kturn_time = 0.0
            return v
        self._kturn_time += dt
        forward = int(self._kturn_time / KTURN_PERIOD) % 2 == 0
        return min(need, KTURN_SPEED) * (1.0 if forward else -1.0)

    def _steer(self, ctrl: Any, v: float, w: float) -> None:
        """Ackermann steering angles (rad) of the left and right front wheels for forward
        speed ``v`` (m/s) and yaw rate ``w`` (rad/s) about the rear axle's centre."""
        r = self.robot
        if abs(w) < 1e-6:
            ctrl[self._steer_ids] = 0.0
            return
        radius = (v if abs(v) >= 0.05 else 0.05) / w  # signed turn radius (m): + centre on the left
        radius = math.copysign(max(abs(radius), r.track_width), radius)  # inner wheel's side kept
        left = math.atan(r.wheelbase / (radius - r.track_width / 2))
        right = math.atan(r.wheelbase / (radius + r.track_width / 2))
        ctrl[self._steer_ids[0]] = _clamp(left, r.max_steer)
        ctrl[self._steer_ids[1]] = _clamp(right, r.max_steer)

    def _ground_below(self, data: Any) -> float:
        """Height (m) of the first non-robot surface under the base origin (the last one
        found if there is none)."""
        point = self._ray_point
        point[:] = data.xpos[self.base_id]
        dist = self._mj.mj_ray(self.model, data, point, self._ray_down, SCENE_GROUPS, 1, -1, self._ray_geom)
        if dist >= 0:
            self._ground = float(point[2]) - dist
        return self._ground if self._ground is not None else 0.0

    def _footprint_probe(self, data: Any) -> float:
        """Highest ground (m) under the feet and :data:`SERVO_LOOKAHEAD` beyond them along
        the heading (ahead of the front feet, behind the rear ones); -inf for a robot
        without feet."""
        if self.foot_geom_ids.size == 0:
            return -math.inf
        bx, by, top = data.xpos[self.base_id].tolist()
        qw, qx, qy, qz = data.qpos[self.qadr + 3 : self.qadr + 7].tolist()
        yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
        c, s = math.cos(yaw), math.sin(yaw)
        feet = data.geom_xpos[self.foot_geom_ids].tolist()
        if self.terrain is not None:
            ground_at = self.terrain.ground_at
        else:

            def ground_at(x: float, y: float) -> float:
                return self._ground_at(data, x, y, top)

        best = -math.inf
        for fx, fy, _ in feet:  # under the feet
            g = ground_at(fx, fy)
            best = g if g > best else best
        for fx, fy, _ in feet:  # ahead of the front feet, behind the rear ones
            ahead = SERVO_LOOKAHEAD if (fx - bx) * c + (fy - by) * s >= 0 else -SERVO_LOOKAHEAD
            g = ground_at(fx + ahead * c, fy + ahead * s)
            best = g if g > best else best
        return best

    def _inertia(self, data: Any) -> float:
        """Composite inertia (kg m^2) of the robot about its centre of mass, horizontal axes."""
        cx, cy, _ = data.subtree_com[self.base_id].tolist()
        total = 0.0
        for mass, (x, y, _) in zip(self._mass_list, data.xipos[self.body_ids].tolist(), strict=True):
            total += mass * ((x - cx) ** 2 + (y - cy) ** 2)
        return total + self._half_inertia

    def _ground_at(self, data: Any, x: float, y: float, top: float) -> float:
        """Height (m) of the first non-robot surface below ``(x, y, top)`` by a ray through
        the scene; -inf if none (:meth:`_footprint_probe` reads :attr:`terrain` instead when
        it is set)."""
        point = self._ray_point
        point[:] = (x, y, top)
        dist = self._mj.mj_ray(self.model, data, point, self._ray_down, SCENE_GROUPS, 1, -1, self._ray_geom)
        return top - dist if dist >= 0 else -math.inf

    def joint_action(self, data: Any, action: np.ndarray) -> None:
        """Locomotion: leg joint targets ``default_pose + action_scale * clip(action, -1, 1)``
        (rad) for the first :attr:`n_joints` numbers; a robot with wheels on its legs takes
        one more number per wheel (:attr:`loco_wheels`: the wheels' speed targets, a fraction
        of ``max_speed / wheel_radius`` rad/s), and holds its wheels still without them."""
        a = np.asarray(action, dtype=float)
        n, w = self.n_joints, self.loco_wheels.size
        if a.shape not in ((n,), (n + w,)):
            sizes = f"{n} or {n + w}" if w else f"{n}"
            raise ValueError(f"joint_action: expected {sizes} numbers, got shape {a.shape}")
        self._undamp()
        a = np.minimum(np.maximum(a, -1.0), 1.0)  # np.clip's values without its wrapper's cost
        data.ctrl[self.leg_act] = self.default + self.scale * a[:n]
        data.ctrl[self.wheel_act] = 0.0
        if a.size > n:
            data.ctrl[self.loco_wheels] = self.wheel_speed * a[n:]

    def wheel_velocities(self, data: Any) -> np.ndarray:
        """Speeds (rad/s) of the wheels a locomotion action drives (:attr:`loco_wheels`)."""
        return data.qvel[self.loco_wheel_dadr].copy()

    def joint_positions(self, data: Any) -> np.ndarray:
        """Leg joint angles (rad), in action order."""
        return data.qpos[self.leg_qadr].copy()

    def joint_velocities(self, data: Any) -> np.ndarray:
        """Leg joint speeds (rad/s), in action order."""
        return data.qvel[self.leg_dadr].copy()

    def torques(self, data: Any) -> np.ndarray:
        """Forces of the leg actuators (N m), in action order."""
        return data.actuator_force[self.leg_act].copy()

    def body_contacts(self, data: Any) -> np.ndarray:
        """Ids of the non-robot geoms that a robot geom other than a foot touches (a
        collision, or the trunk on the ground), sorted."""
        n = data.ncon
        if n == 0:
            return np.zeros(0, dtype=int)
        g = np.asarray(data.contact.geom[:n], dtype=int)
        hit = self._not_foot[g[:, 0]] & ~self._is_robot_geom[g[:, 1]]
        hit2 = self._not_foot[g[:, 1]] & ~self._is_robot_geom[g[:, 0]]
        return np.unique(np.concatenate([g[hit, 1], g[hit2, 0]]))
