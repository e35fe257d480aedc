"""The runner's robots: embodiments built in code as MJCF, a user's own MJCF or URDF robot
through a small adapter, and a handle that drives a robot inside a compiled scene.

Built-in robots (:data:`BUILTIN`, mesh-free, every geom a primitive):

- ``wheeled``: a delivery robot, 0.7 m x 0.55 m, 0.5 m tall, about 45 kg; two driven
  wheels (hinge joints with velocity actuators) at mid-length and a frictionless caster
  sphere in front and behind: exact differential drive.
- ``quadruped``: Go2-like, trunk 0.38 x 0.09 x 0.11 m, about 15 kg, 12 hinge joints (hip
  abduction, hip flexion, knee per leg, legs in the order FR, FL, RR, RL) with position
  actuators (kp 50 N m/rad, kd 1 N m s/rad, Go2's torque limits), standing base height 0.30 m.
- ``wheeled_legged``: B2-W-like, about 76 kg, the same 12 leg joints (kp 600, kd 12) plus a
  driven wheel at each foot (4 velocity actuators), standing base height about 0.60 m.
- ``wheelchair``: an electric wheelchair, 0.65 m wide, 1.1 m long, about 110 kg including
  a 70 kg seated person; differential drive on the rear wheels, frictionless front casters.

Units: metres, kilograms, seconds, radians. Frames: a robot's base frame has +x forward,
+z up; a pose is ``(x, y, ground_z, yaw)`` with ``ground_z`` the ground's height under the
robot and the base origin :attr:`Robot.stand_height` above it.

**Navigation** (:meth:`RobotHandle.drive`): wheeled robots (``nav_mode == "wheels"``:
``wheeled``, ``wheelchair``, ``wheeled_legged``) really drive on their wheels: each
wheel's velocity actuator gets the differential-drive wheel speed of the command,
corrected by a proportional feedback on the measured base speed and yaw rate (it makes up
for skid steering and slip; the four-wheel ``wheeled_legged`` turns by skidding). The legs
of ``wheeled_legged`` hold the stand pose by their PD. The ``quadruped`` has no learned
locomotion policy under the navigation policy, so it uses **ideal locomotion**
(``nav_mode == "base"``): the legs hold the stand pose by PD while a servo of forces and
torques on the base (``data.xfrc_applied``) carries the body's weight
:data:`HOVER_CLEARANCE` above the stand height over the ground found by a ray under the
base, keeps the trunk level, and tracks the planar velocity ``(v, w)``. Feet then do not
touch flat ground; legs and trunk still collide with obstacles, curbs and agents. The
open-loop trot of :mod:`citygen.runner.gaits` is the locomotion baseline, not the
navigation drive (it is not precise enough to track a planner's commands).

**Control timing**: :data:`TIMESTEP` (0.002 s) physics step, implicit-fast integrator.
:meth:`RobotHandle.drive` reads the base's state and is a feedback loop: the environments
run a wheel drive at :data:`DRIVE_DT` (100 Hz, every :attr:`RobotHandle.drive_substeps`
physics steps, its outputs held in between, as a real wheel controller does) and the
ideal-locomotion servo at every physics step; called with no ``dt`` it assumes one call
per physics step. :meth:`RobotHandle.joint_action` only writes
position targets and may run at the control rate (50 Hz = every 10 steps is the usual
choice).

>>> robot = load_robot("wheeled")
>>> robot.nav_mode, robot.radius
('wheels', 0.35)
"""

from __future__ import annotations

import functools
import json
import math
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from citygen.errors import CitygenError, ExportError, Problem, SpecError
from citygen.exporters.mjcf import MJCF, ROBOT_BIT, ROBOT_CONAFFINITY, import_mujoco
from citygen.spec.task import ROBOT_RADIUS

#: The robots built in code.
BUILTIN: tuple[str, ...] = ("wheeled", "quadruped", "wheeled_legged", "wheelchair")
#: Physics timestep (s) of a composed model.
TIMESTEP = 0.002
#: Friction-to-normal impedance ratio (with elliptic friction cones) of a composed model:
#: MuJoCo's soft contacts otherwise let planted feet creep (0.3 m/s in a trot at 1).
IMPRATIO = 100.0
#: Prefix of every name of the robot inside a composed model.
PREFIX = "robot/"
#: Height (m) above the stand height at which the ideal-locomotion servo carries the base.
HOVER_CLEARANCE = 0.01
_GRAVITY = 9.81


@dataclass(frozen=True)
class Leg:
    """Geometry of one 3-joint leg (abduction about x, flexion and knee about y), in the
    base frame, metres: the abduction joint at ``(hip_x, hip_y, 0)``, the flexion joint
    ``lateral`` further out along y (signed: + on the left), links ``thigh`` and ``calf``
    long, the foot (a sphere or a wheel centred on the calf's end) of radius ``foot_radius``."""

    name: str
    hip_x: float
    hip_y: float
    lateral: float
    thigh: float
    calf: float
    foot_radius: float

    def fk(self, q: np.ndarray) -> np.ndarray:
        """Foot centre (calf end) relative to the abduction joint, for joint angles
        ``q = (abduction, flexion, knee)`` in rad."""
        q0, q1, q2 = (float(v) for v in q)
        x = -self.thigh * math.sin(q1) - self.calf * math.sin(q1 + q2)
        z = -self.thigh * math.cos(q1) - self.calf * math.cos(q1 + q2)
        d = self.lateral
        return np.array([x, d * math.cos(q0) - z * math.sin(q0), d * math.sin(q0) + z * math.cos(q0)])

    def ik(self, p: np.ndarray) -> np.ndarray:
        """Joint angles (rad, knee bent backwards: knee < 0) putting the foot centre at
        ``p`` relative to the abduction joint; unreachable targets are pulled in."""
        px, py, pz = (float(v) for v in p)
        d = self.lateral
        r2 = max(py * py + pz * pz - d * d, 1e-6)
        zp = -math.sqrt(r2)
        q0 = math.atan2(pz, py) - math.atan2(zp, d)
        reach = self.thigh + self.calf
        length = math.hypot(px, zp)
        if length > 0.999 * reach:
            px, zp = px * 0.999 * reach / length, zp * 0.999 * reach / length
            length = 0.999 * reach
        c = (length**2 - self.thigh**2 - self.calf**2) / (2 * self.thigh * self.calf)
        q2 = -math.acos(min(1.0, max(-1.0, c)))
        ux, uz = -self.calf * math.sin(q2), -(self.thigh + self.calf * math.cos(q2))
        q1 = math.atan2(px, zp) - math.atan2(ux, uz)
        q1 = (q1 + math.pi) % (2 * math.pi) - math.pi
        return np.array([q0, q1, q2])


@dataclass(frozen=True)
class Robot:
    """A robot as a description (picklable; no MuJoCo object inside).

    ``xml`` is a standalone ``<mujoco>`` model whose worldbody holds one body,
    ``base_body``, with a free joint and everything else; names in it carry no prefix
    (a composed model prefixes them with :data:`PREFIX`). ``assets`` are the files it names
    (mesh file name -> bytes), empty for the built-in robots.
    """

    name: str
    xml: str
    radius: float
    """Radius (m) of the disc the robot occupies: what the planner inflates obstacles by."""
    max_speed: float
    """Fastest forward speed (m/s) :meth:`RobotHandle.drive` commands."""
    max_yaw_rate: float
    """Fastest yaw rate (rad/s) :meth:`RobotHandle.drive` commands."""
    mass: float
    """Total mass (kg)."""
    max_accel: float
    """Largest forward acceleration (m/s^2) :meth:`RobotHandle.drive` asks for."""
    max_yaw_accel: float
    """Largest yaw acceleration (rad/s^2) :meth:`RobotHandle.drive` asks for."""
    stand_height: float
    """Height (m) of the base origin above flat ground when standing in the default pose."""
    max_step: float = 0.04
    """Highest step (m) the robot drives or walks over in navigation: the environments keep
    its centre a radius away from steeper edges of the ground (stair risers, curbs)."""
    base_body: str = "base"
    nav_mode: str = "wheels"
    """``"wheels"`` (differential drive on wheel actuators) or ``"base"`` (ideal locomotion)."""
    left_wheels: tuple[str, ...] = ()
    """Velocity actuators of the left wheels (target in rad/s, positive rolls forward)."""
    right_wheels: tuple[str, ...] = ()
    wheel_radius: float = 0.0
    track_width: float = 0.0
    """Distance (m) between the left and right wheels' contact lines."""
    leg_joints: tuple[str, ...] = ()
    """Hinge joints driven by :meth:`RobotHandle.joint_action`, in action order."""
    leg_actuators: tuple[str, ...] = ()
    """Position actuators of ``leg_joints``, same order."""
    default_pose: tuple[float, ...] = ()
    """Standing angles (rad) of ``leg_joints``."""
    action_scale: tuple[float, ...] = ()
    """Radians one unit of action moves each leg joint's target from the default pose."""
    foot_geoms: tuple[str, ...] = ()
    """Geoms allowed to touch the ground: feet, wheels, casters."""
    legs: tuple[Leg, ...] = ()
    """Leg geometry for the gaits (built-in legged robots; empty otherwise)."""
    timestep: float = TIMESTEP
    assets: tuple[tuple[str, bytes], ...] = field(default=(), repr=False)

    @property
    def n_joints(self) -> int:
        return len(self.leg_joints)


# --- MJCF building helpers ------------------------------------------------------------


def _n(x: float) -> str:
    s = f"{x:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _v(*values: float) -> str:
    return " ".join(_n(float(v)) for v in values)


_COLLIDE = {"contype": str(ROBOT_BIT), "conaffinity": str(ROBOT_CONAFFINITY)}
# A frictionless caster: its priority beats the ground's (1), so its condim 1 is used.
_CASTER = {**_COLLIDE, "priority": "2", "condim": "1"}


def _caster(doc: _Doc, name: str, pos: tuple, radius: float, mass: float) -> None:
    """A frictionless caster ball on a sprung vertical slide: it follows bumps (up to 5 cm
    up) while the driven wheels keep most of the weight, so the robot is not lifted off its
    wheels on rough ground."""
    body = ET.SubElement(doc.base, "body", name=name, pos=_v(*pos))
    ET.SubElement(
        body, "joint", name=name, type="slide", axis="0 0 1", range="-0.01 0.05", stiffness="3000",
        springref="0.017", damping="60", armature="0.01",
    )  # fmt: skip
    doc.geom(body, name, mass, _CASTER, type="sphere", size=_n(radius))


class _Doc:
    """An MJCF document under construction: ``root``, the base body, the actuators."""

    def __init__(self, name: str, stand_height: float, rgba: str) -> None:
        self.root = ET.Element("mujoco", model=name)
        ET.SubElement(self.root, "compiler", angle="radian", autolimits="true")
        ET.SubElement(self.root, "option", timestep=_n(TIMESTEP), integrator="implicitfast")
        world = ET.SubElement(self.root, "worldbody")
        self.base = ET.SubElement(world, "body", name="base", pos=_v(0, 0, stand_height))
        ET.SubElement(self.base, "freejoint", name="root")
        self.actuator = ET.SubElement(self.root, "actuator")
        self.rgba = rgba

    def geom(
        self, parent: ET.Element, name: str, mass: float, extra: dict | None = None, **attrs: str
    ) -> None:
        ET.SubElement(
            parent,
            "geom",
            {"name": name, "mass": _n(mass), "rgba": self.rgba, **(extra or _COLLIDE), **attrs},
        )

    def wheel(
        self,
        parent: ET.Element,
        name: str,
        pos: tuple,
        radius: float,
        width: float,
        mass: float,
        kv: float,
        torque: float,
    ) -> None:
        body = ET.SubElement(parent, "body", name=name, pos=_v(*pos))
        ET.SubElement(body, "joint", name=name, type="hinge", axis="0 1 0", damping="0.01", armature="0.01")
        self.geom(
            body,
            name,
            mass,
            type="cylinder",
            size=_v(radius, width / 2),
            zaxis="0 1 0",
            rgba="0.15 0.15 0.15 1",
            condim="3",
        )
        ET.SubElement(
            self.actuator, "velocity", name=name, joint=name, kv=_n(kv), forcerange=_v(-torque, torque)
        )

    def xml(self) -> str:
        ET.indent(self.root, space="  ")
        return ET.tostring(self.root, encoding="unicode") + "\n"


def _legs(
    doc: _Doc,
    legs: tuple[Leg, ...],
    sizes: dict[str, float],
    masses: dict[str, float],
    ranges: dict[str, tuple[float, float]],
    torques: tuple[float, float, float],
    kp: float,
    kd: float,
    wheel: dict[str, float] | None,
) -> tuple[list[str], list[str], list[str]]:
    """Add 3-joint legs to ``doc``; returns leg joints, their actuators and the foot geoms."""
    joints: list[str] = []
    feet: list[str] = []
    for leg in legs:
        side = 1.0 if leg.lateral > 0 else -1.0
        hip = ET.SubElement(doc.base, "body", name=f"{leg.name}_hip", pos=_v(leg.hip_x, leg.hip_y, 0))
        ET.SubElement(
            hip,
            "joint",
            name=f"{leg.name}_hip_joint",
            axis="1 0 0",
            range=_v(*ranges["hip"]),
            armature=_n(sizes["armature"]),
        )
        doc.geom(
            hip,
            f"{leg.name}_hip",
            masses["hip"],
            type="cylinder",
            zaxis="0 1 0",
            size=_v(sizes["hip_r"], sizes["hip_len"] / 2),
            pos=_v(0, side * sizes["hip_len"] / 2, 0),
        )
        thigh = ET.SubElement(hip, "body", name=f"{leg.name}_thigh", pos=_v(0, leg.lateral, 0))
        ET.SubElement(
            thigh,
            "joint",
            name=f"{leg.name}_thigh_joint",
            axis="0 1 0",
            range=_v(*ranges["thigh"]),
            armature=_n(sizes["armature"]),
        )
        doc.geom(
            thigh,
            f"{leg.name}_thigh",
            masses["thigh"],
            type="capsule",
            size=_n(sizes["thigh_r"]),
            fromto=_v(0, 0, 0, 0, 0, -leg.thigh),
        )
        calf = ET.SubElement(thigh, "body", name=f"{leg.name}_calf", pos=_v(0, 0, -leg.thigh))
        ET.SubElement(
            calf,
            "joint",
            name=f"{leg.name}_calf_joint",
            axis="0 1 0",
            range=_v(*ranges["calf"]),
            armature=_n(sizes["armature"]),
        )
        doc.geom(
            calf,
            f"{leg.name}_calf",
            masses["calf"],
            type="capsule",
            size=_n(sizes["calf_r"]),
            fromto=_v(0, 0, 0, 0, 0, -leg.calf + (0 if wheel else sizes["calf_r"])),
        )
        if wheel is None:
            doc.geom(
                calf,
                f"{leg.name}_foot",
                masses["foot"],
                type="sphere",
                size=_n(leg.foot_radius),
                pos=_v(0, 0, -leg.calf),
                rgba="0.1 0.1 0.1 1",
            )
            feet.append(f"{leg.name}_foot")
        else:
            doc.wheel(
                calf,
                f"{leg.name}_wheel",
                (0, side * wheel["offset"], -leg.calf),
                leg.foot_radius,
                wheel["width"],
                wheel["mass"],
                wheel["kv"],
                wheel["torque"],
            )
            feet.append(f"{leg.name}_wheel")
        joints += [f"{leg.name}_{j}_joint" for j in ("hip", "thigh", "calf")]
    for k, joint in enumerate(joints):
        lim = torques[k % 3]
        ET.SubElement(
            doc.actuator,
            "position",
            name=joint.removesuffix("_joint"),
            joint=joint,
            kp=_n(kp),
            kv=_n(kd),
            forcerange=_v(-lim, lim),
        )
    return joints, [j.removesuffix("_joint") for j in joints], feet


def _leg_set(hx: float, hy: float, lateral: float, thigh: float, calf: float, foot: float) -> tuple[Leg, ...]:
    """Four legs FR, FL, RR, RL (front/rear, right/left)."""
    return tuple(
        Leg(name, sx * hx, sy * hy, sy * lateral, thigh, calf, foot)
        for name, sx, sy in (("FR", 1, -1), ("FL", 1, 1), ("RR", -1, -1), ("RL", -1, 1))
    )


def _stand(legs: tuple[Leg, ...], pose: tuple[float, ...]) -> float:
    """Base height (m) over flat ground with the legs at ``pose``."""
    return max(
        -legs[i].fk(np.array(pose[3 * i : 3 * i + 3]))[2] + legs[i].foot_radius for i in range(len(legs))
    )


# --- the built-in robots ----------------------------------------------------------------


def _wheeled() -> Robot:
    r, track, h = 0.12, 0.49, 0.12
    doc = _Doc("wheeled", h, "0.95 0.95 0.92 1")
    doc.geom(doc.base, "chassis", 36.0, type="box", size=_v(0.35, 0.215, 0.19), pos=_v(0, 0, 0.22))
    doc.geom(
        doc.base, "lid", 4.0, type="box", size=_v(0.3, 0.19, 0.02), pos=_v(0, 0, 0.43), rgba="0.2 0.5 0.9 1"
    )
    for name, x in (("front_caster", 0.27), ("rear_caster", -0.27)):
        _caster(doc, name, (x, 0, 0.05 - h), 0.05, 0.5)
    for name, y in (("left_wheel", track / 2), ("right_wheel", -track / 2)):
        doc.wheel(doc.base, name, (0, y, 0), r, 0.06, 2.0, kv=8.0, torque=30.0)
    return Robot(
        name="wheeled",
        xml=doc.xml(),
        radius=ROBOT_RADIUS["wheeled"],
        max_speed=1.5,
        max_yaw_rate=2.0,
        mass=0.0,
        max_accel=1.5,
        max_yaw_accel=3.0,
        stand_height=h,
        max_step=0.05,
        left_wheels=("left_wheel",),
        right_wheels=("right_wheel",),
        wheel_radius=r,
        track_width=track,
        foot_geoms=("left_wheel", "right_wheel", "front_caster", "rear_caster"),
    )


def _wheelchair() -> Robot:
    r, track, h = 0.17, 0.59, 0.17
    doc = _Doc("wheelchair", h, "0.25 0.27 0.3 1")
    ax = -0.25  # rear axle, base origin at the footprint's centre
    base = doc.base
    doc.geom(base, "frame", 18.0, type="box", size=_v(0.3, 0.24, 0.04), pos=_v(-0.05, 0, 0.1))
    doc.geom(base, "battery", 14.0, type="box", size=_v(0.15, 0.15, 0.07), pos=_v(-0.15, 0, 0.0))
    doc.geom(base, "seat", 3.0, type="box", size=_v(0.22, 0.24, 0.03), pos=_v(-0.05, 0, 0.3))
    doc.geom(base, "backrest", 2.0, type="box", size=_v(0.03, 0.24, 0.25), pos=_v(-0.3, 0, 0.58))
    doc.geom(base, "footrest", 1.0, type="box", size=_v(0.08, 0.2, 0.015), pos=_v(0.58, 0, -0.04))
    doc.geom(base, "anti_tip", 1.0, type="box", size=_v(0.04, 0.2, 0.02), pos=_v(-0.42, 0, -0.05))
    skin = {**_COLLIDE}
    body = "0.85 0.6 0.45 1"
    doc.geom(
        base,
        "person_torso",
        38.0,
        skin,
        type="box",
        size=_v(0.11, 0.2, 0.3),
        pos=_v(-0.16, 0, 0.63),
        rgba=body,
    )
    doc.geom(base, "person_head", 5.0, skin, type="sphere", size=_n(0.1), pos=_v(-0.14, 0, 1.05), rgba=body)
    doc.geom(
        base,
        "person_thighs",
        17.0,
        skin,
        type="box",
        size=_v(0.22, 0.18, 0.08),
        pos=_v(0.04, 0, 0.41),
        rgba=body,
    )
    doc.geom(
        base,
        "person_shins",
        8.0,
        skin,
        type="box",
        size=_v(0.06, 0.16, 0.22),
        pos=_v(0.34, 0, 0.18),
        rgba=body,
    )
    for name, y in (("left_caster", 0.2), ("right_caster", -0.2)):
        doc.geom(base, name, 0.5, _CASTER, type="sphere", size=_n(0.07), pos=_v(0.3, y, 0.07 - h))
    for name, y in (("left_wheel", track / 2), ("right_wheel", -track / 2)):
        doc.wheel(base, name, (ax, y, 0), r, 0.06, 2.5, kv=25.0, torque=60.0)
    return Robot(
        name="wheelchair",
        xml=doc.xml(),
        radius=ROBOT_RADIUS["wheelchair"],
        max_speed=1.6,
        max_yaw_rate=1.5,
        mass=0.0,
        max_accel=1.0,
        max_yaw_accel=2.0,
        stand_height=h,
        max_step=0.05,
        left_wheels=("left_wheel",),
        right_wheels=("right_wheel",),
        wheel_radius=r,
        track_width=track,
        foot_geoms=("left_wheel", "right_wheel", "left_caster", "right_caster"),
    )


_QUAD_LEGS = _leg_set(0.1934, 0.0465, 0.0955, 0.213, 0.213, 0.022)
_QUAD_POSE = (0.0, 0.85, -1.7) * 4


def _quadruped() -> Robot:
    legs, pose = _QUAD_LEGS, _QUAD_POSE
    h = _stand(legs, pose)
    doc = _Doc("quadruped", h, "0.55 0.57 0.6 1")
    doc.geom(doc.base, "trunk", 6.9, type="box", size=_v(0.19, 0.0465, 0.057))
    doc.geom(doc.base, "head", 0.2, type="box", size=_v(0.03, 0.04, 0.03), pos=_v(0.2, 0, 0.02))
    joints, acts, feet = _legs(
        doc,
        legs,
        sizes={"armature": 0.01, "hip_r": 0.045, "hip_len": 0.04, "thigh_r": 0.02, "calf_r": 0.013},
        masses={"hip": 0.68, "thigh": 1.0, "calf": 0.2, "foot": 0.1},
        ranges={"hip": (-1.05, 1.05), "thigh": (-1.57, 3.49), "calf": (-2.72, -0.84)},
        torques=(23.7, 23.7, 45.4),
        kp=60.0,
        kd=2.0,
        wheel=None,
    )
    return Robot(
        name="quadruped",
        xml=doc.xml(),
        radius=ROBOT_RADIUS["quadruped"],
        max_speed=1.0,
        max_yaw_rate=1.5,
        mass=0.0,
        max_accel=2.0,
        max_yaw_accel=4.0,
        stand_height=h,
        max_step=0.18,
        nav_mode="base",
        leg_joints=tuple(joints),
        leg_actuators=tuple(acts),
        default_pose=pose,
        action_scale=(0.5, 1.0, 1.0) * 4,
        foot_geoms=tuple(feet),
        legs=legs,
    )


_WL_LEGS = _leg_set(0.3285, 0.072, 0.12, 0.35, 0.35, 0.09)
# Front feet a little behind their hips, rear feet in front, legs splayed out: a wheelbase
# near the track width, so the four wheels can skid-steer.
_WL_POSE = tuple(
    round(float(q), 4)
    for leg in _WL_LEGS
    for q in leg.ik(
        np.array([-0.1 if leg.hip_x > 0 else 0.1, leg.lateral + math.copysign(0.1, leg.lateral), -0.5])
    )
)


def _wheeled_legged() -> Robot:
    legs, pose = _WL_LEGS, _WL_POSE
    h = _stand(legs, pose)
    doc = _Doc("wheeled_legged", h, "0.3 0.3 0.32 1")
    doc.geom(doc.base, "trunk", 48.0, type="box", size=_v(0.4, 0.14, 0.09))
    r = legs[0].foot_radius
    joints, acts, feet = _legs(
        doc,
        legs,
        sizes={"armature": 0.05, "hip_r": 0.07, "hip_len": 0.08, "thigh_r": 0.04, "calf_r": 0.025},
        masses={"hip": 1.5, "thigh": 2.5, "calf": 1.0},
        ranges={"hip": (-0.87, 0.87), "thigh": (-1.0, 3.0), "calf": (-2.6, -0.6)},
        torques=(200.0, 200.0, 320.0),
        kp=1500.0,
        kd=30.0,
        wheel={"offset": 0.07, "width": 0.05, "mass": 1.5, "kv": 6.0, "torque": 60.0},
    )
    # the legs' splay: the wheel track is measured between the wheels' contact points
    q = np.array(pose[0:3])
    foot = legs[0].fk(q)
    track = 2 * (abs(legs[0].hip_y + foot[1]) + 0.07)
    return Robot(
        name="wheeled_legged",
        xml=doc.xml(),
        radius=ROBOT_RADIUS["wheeled_legged"],
        max_speed=2.0,
        max_yaw_rate=1.5,
        mass=0.0,
        max_accel=1.5,
        max_yaw_accel=3.0,
        stand_height=h,
        max_step=0.08,
        left_wheels=("FL_wheel", "RL_wheel"),
        right_wheels=("FR_wheel", "RR_wheel"),
        wheel_radius=r,
        track_width=track,
        leg_joints=tuple(joints),
        leg_actuators=tuple(acts),
        default_pose=pose,
        action_scale=(0.5, 1.0, 1.0) * 4,
        foot_geoms=tuple(feet),
        legs=legs,
    )


_BUILDERS = {
    "wheeled": _wheeled,
    "quadruped": _quadruped,
    "wheeled_legged": _wheeled_legged,
    "wheelchair": _wheelchair,
}


# --- a user's robot: MJCF or URDF plus an adapter -----------------------------------------

_ADAPTER_KEYS = (
    "base",
    "radius",
    "max_speed",
    "max_yaw_rate",
    "max_accel",
    "max_yaw_accel",
    "nav",
    "loco",
    "feet",
    "casters",
)
_NAV_KEYS = ("mode", "left", "right", "wheel_radius", "track_width", "wheel_kv", "wheel_torque")
_LOCO_KEYS = ("joints", "default_pose", "action_scale", "kp", "kd", "torque")


class _Adapter:
    """Typed reads from an adapter mapping; every bad value raises a one-line SpecError."""

    def __init__(self, data: Mapping[str, Any], file: str) -> None:
        self.data, self.file = data, file

    def fail(self, path: str, expected: str, found: object) -> SpecError:
        return SpecError(
            [Problem(path, expected, found if isinstance(found, str) else repr(found))], self.file
        )

    def table(self, data: Mapping[str, Any], path: str, keys: tuple[str, ...]) -> Mapping[str, Any]:
        if not isinstance(data, Mapping):
            raise self.fail(path, "a table of keys", data)
        for key in data:
            if key not in keys:
                raise self.fail(f"{path}.{key}", f"one of the keys {', '.join(keys)}", "an unknown key")
        return data

    def number(
        self, data: Mapping[str, Any], path: str, key: str, default: float | None = None, low: float = 0.0
    ) -> float:
        value = data.get(key, default)
        if value is None:
            raise self.fail(f"{path}.{key}", "a number", "nothing (the key is required)")
        if (
            isinstance(value, bool)
            or not isinstance(value, int | float)
            or not math.isfinite(value)
            or value <= low
        ):
            raise self.fail(f"{path}.{key}", f"a number above {low:g}", value)
        return float(value)

    def names(self, data: Mapping[str, Any], path: str, key: str) -> tuple[str, ...]:
        value = data.get(key)
        if not isinstance(value, list | tuple) or not value or not all(isinstance(v, str) for v in value):
            raise self.fail(
                f"{path}.{key}", "a non-empty list of names", value if value is not None else "nothing"
            )
        return tuple(value)


def _read_adapter(adapter: str | Path | Mapping[str, Any] | None, robot_file: str) -> _Adapter:
    if adapter is None:
        raise SpecError(
            [Problem("$", "an adapter (TOML/JSON file or dict) for a robot file", "none")], robot_file
        )
    if isinstance(adapter, Mapping):
        return _Adapter(adapter, "<adapter>")
    path = Path(adapter)
    try:
        text = path.read_bytes()
    except OSError as exc:
        raise SpecError(
            [Problem("$", "a readable adapter file", exc.strerror or type(exc).__name__)], str(path)
        ) from None
    try:
        if path.suffix.lower() == ".toml":
            data = tomllib.loads(text.decode("utf-8"))
        elif path.suffix.lower() == ".json":
            data = json.loads(text)
        else:
            raise SpecError([Problem("$", "a .toml or .json adapter file", repr(path.suffix))], str(path))
    except (tomllib.TOMLDecodeError, json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise SpecError([Problem("$", "valid TOML or JSON", str(exc).splitlines()[0])], str(path)) from None
    return _Adapter(data, str(path))


def _floating_urdf(path: Path) -> str:
    """A URDF's text with its root link floating (MuJoCo fuses a fixed root into the world):
    a ``world`` link and a floating joint ``root`` to the root link are added."""
    tree = ET.parse(path)
    robot = tree.getroot()
    links = [link.get("name") for link in robot.findall("link")]
    children = {j.find("child").get("link") for j in robot.findall("joint") if j.find("child") is not None}
    roots = [name for name in links if name not in children and name != "world"]
    if len(roots) == 1 and "world" not in links:
        ET.SubElement(robot, "link", name="world")
        joint = ET.SubElement(robot, "joint", name="root", type="floating")
        ET.SubElement(joint, "parent", link="world")
        ET.SubElement(joint, "child", link=roots[0])
    return ET.tostring(robot, encoding="unicode")


def lowest_point(model: Any, data: Any, geom: int) -> float:
    """Lowest z (m) of a geom in the current pose (exact for spheres, capsules,
    cylinders and boxes; the oriented bounding box otherwise)."""
    R = data.geom_xmat[geom].reshape(3, 3)
    z = data.geom_xpos[geom][2]
    size = model.geom_size[geom]
    kind = int(model.geom_type[geom])
    if kind == 2:  # sphere
        return float(z - size[0])
    if kind == 3:  # capsule
        return float(z - abs(R[2, 2]) * size[1] - size[0])
    if kind == 5:  # cylinder
        return float(z - abs(R[2, 2]) * size[1] - size[0] * math.sqrt(max(0.0, 1 - R[2, 2] ** 2)))
    centre = data.geom_xpos[geom] + R @ model.geom_aabb[geom][:3]
    return float(centre[2] - np.abs(R[2]) @ model.geom_aabb[geom][3:])


def _custom(path: Path, adapter: str | Path | Mapping[str, Any] | None) -> Robot:
    mujoco = import_mujoco()
    ad = _read_adapter(adapter, str(path))
    top = ad.table(ad.data, "$", _ADAPTER_KEYS)
    try:
        if path.suffix.lower() == ".urdf":
            spec = mujoco.MjSpec.from_string(_floating_urdf(path))
            spec.modelfiledir = str(path.parent)
        else:
            spec = mujoco.MjSpec.from_file(str(path))
        spec.compile()
    except (ValueError, OSError, ET.ParseError) as exc:
        msg = str(exc).replace("\n", " ").strip()
        raise SpecError([Problem("$", "an MJCF or URDF file MuJoCo compiles", msg)], str(path)) from None
    tops = list(spec.worldbody.bodies)
    base_name = top.get("base", tops[0].name if len(tops) == 1 else None)
    base = spec.body(base_name) if isinstance(base_name, str) else None
    if base is None or base.parent.name != spec.worldbody.name:
        raise ad.fail(
            "$.base", f"the name of the top body in {path.name} (the robot's base)", base_name or "nothing"
        )
    others = [b.name for b in tops if b.name != base.name]
    if others:
        raise ad.fail("$.base", f"the only top body of {path.name}", f"other top bodies {others}")
    free = [j for j in base.joints if j.type == mujoco.mjtJoint.mjJNT_FREE]
    if not free:
        if list(base.joints):
            raise ad.fail("$.base", "a base body without joints or with a free joint", "a jointed base")
        base.add_freejoint()
    radius = ad.number(top, "$", "radius")
    max_speed = ad.number(top, "$", "max_speed")
    max_yaw = ad.number(top, "$", "max_yaw_rate")
    accel = (ad.number(top, "$", "max_accel", 1.5), ad.number(top, "$", "max_yaw_accel", 3.0))
    for k, geom in enumerate(spec.geoms):  # the robot's collision bits, whatever the file said
        if geom.contype or geom.conaffinity:
            geom.contype, geom.conaffinity = ROBOT_BIT, ROBOT_CONAFFINITY
        if not geom.name:
            geom.name = f"geom{k}"
    for k, name in enumerate(ad.names(top, "$", "casters") if "casters" in top else ()):
        geom = spec.geom(name)
        if geom is None:
            raise ad.fail(f"$.casters[{k}]", f"a geom of {path.name}", name)
        geom.priority, geom.condim = 2, 1  # frictionless: its priority beats the ground's
    kw: dict[str, Any] = {}
    nav = ad.table(top.get("nav", {}), "$.nav", _NAV_KEYS)
    mode = nav.get("mode")
    if mode not in ("wheels", "base"):
        raise ad.fail("$.nav.mode", "'wheels' or 'base'", mode if mode is not None else "nothing")
    kw["nav_mode"] = mode
    body_mass = float(spec.compile().body_subtreemass[1])
    if mode == "wheels":
        r = ad.number(nav, "$.nav", "wheel_radius")
        kw |= {"wheel_radius": r, "track_width": ad.number(nav, "$.nav", "track_width")}
        wheels = ad.names(nav, "$.nav", "left") + ad.names(nav, "$.nav", "right")
        kv = ad.number(nav, "$.nav", "wheel_kv", 10.0 * body_mass * r * r / len(wheels))
        torque = ad.number(nav, "$.nav", "wheel_torque", 2.0 * body_mass * _GRAVITY * r / len(wheels))
        for side in ("left", "right"):
            acts = []
            for k, name in enumerate(nav[side]):
                if spec.actuator(name) is None:
                    joint = spec.joint(name)
                    if joint is None or joint.type != mujoco.mjtJoint.mjJNT_HINGE:
                        raise ad.fail(
                            f"$.nav.{side}[{k}]", f"an actuator or hinge joint of {path.name}", name
                        )
                    act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
                    act.set_to_velocity(kv=kv)
                    act.forcelimited, act.forcerange = True, [-torque, torque]
                acts.append(name)
            kw[f"{side}_wheels"] = tuple(acts)
    loco = ad.table(top.get("loco", {}), "$.loco", _LOCO_KEYS)
    if loco:
        names = ad.names(loco, "$.loco", "joints")
        pose = loco.get("default_pose")
        if (
            not isinstance(pose, list | tuple)
            or len(pose) != len(names)
            or not all(isinstance(v, int | float) and not isinstance(v, bool) for v in pose)
        ):
            raise ad.fail(
                "$.loco.default_pose", f"{len(names)} angles in rad (one per joint)", pose or "nothing"
            )
        scale = loco.get("action_scale", 0.25)
        scales = scale if isinstance(scale, list | tuple) else [scale] * len(names)
        if len(scales) != len(names) or not all(
            isinstance(v, int | float) and not isinstance(v, bool) and v > 0 for v in scales
        ):
            raise ad.fail("$.loco.action_scale", f"a positive number or {len(names)} of them (rad)", scale)
        kp, kd = ad.number(loco, "$.loco", "kp", 40.0), ad.number(loco, "$.loco", "kd", 1.0, low=-1e-12)
        torque = ad.number(loco, "$.loco", "torque", 50.0)
        joints, acts = [], []
        for k, name in enumerate(names):
            act = spec.actuator(name)
            if act is None:
                joint = spec.joint(name)
                if joint is None or joint.type not in (
                    mujoco.mjtJoint.mjJNT_HINGE,
                    mujoco.mjtJoint.mjJNT_SLIDE,
                ):
                    raise ad.fail(f"$.loco.joints[{k}]", f"an actuator or hinge joint of {path.name}", name)
                act = spec.add_actuator(name=name, target=name, trntype=mujoco.mjtTrn.mjTRN_JOINT)
                act.set_to_position(kp=kp, kv=kd)
                act.forcelimited, act.forcerange = True, [-torque, torque]
            joints.append(act.target)
            acts.append(name)
        kw |= {
            "leg_joints": tuple(joints),
            "leg_actuators": tuple(acts),
            "default_pose": tuple(float(v) for v in pose),
            "action_scale": tuple(float(v) for v in scales),
        }
    model = _compile_checked(spec, str(path))
    data = mujoco.MjData(model)
    b = model.body(base.name).id
    qadr = model.jnt_qposadr[model.body_jntadr[b]]
    data.qpos[qadr : qadr + 7] = (0, 0, 0, 1, 0, 0, 0)
    for joint, q in zip(kw.get("leg_joints", ()), kw.get("default_pose", ()), strict=True):
        data.qpos[model.jnt_qposadr[model.joint(joint).id]] = q
    mujoco.mj_kinematics(model, data)
    colliding = [g for g in range(model.ngeom) if model.geom_contype[g] or model.geom_conaffinity[g]]
    if not colliding:
        raise SpecError([Problem("$", "a robot with collision geoms", "none")], str(path))
    bottoms = {g: lowest_point(model, data, g) for g in colliding}
    low = min(bottoms.values())
    feet = top.get("feet")
    if feet is None:
        feet_ids = [g for g in colliding if bottoms[g] < low + 0.02]
        feet = [model.geom(g).name or "" for g in feet_ids]
        if not all(feet):
            raise ad.fail(
                "$.feet", "names of the geoms touching the ground (they are unnamed in the file)", feet
            )
    else:
        for k, name in enumerate(ad.names(top, "$", "feet")):
            if spec.geom(name) is None:
                raise ad.fail(f"$.feet[{k}]", f"a geom of {path.name}", name)
    assets = _mesh_assets(spec, path)
    return Robot(
        name=path.stem,
        xml=spec.to_xml(),
        radius=radius,
        max_speed=max_speed,
        max_yaw_rate=max_yaw,
        mass=float(model.body_subtreemass[b]),
        max_accel=accel[0],
        max_yaw_accel=accel[1],
        stand_height=-low,
        base_body=base.name,
        foot_geoms=tuple(feet),
        assets=assets,
        **kw,
    )


def _mesh_assets(spec: Any, path: Path) -> tuple[tuple[str, bytes], ...]:
    """The mesh files a robot file names, keyed by the name the saved XML uses, so the
    robot compiles from its XML string alone; ``meshdir`` is cleared."""
    root = path.parent / (spec.meshdir or "")
    out: dict[str, bytes] = {}
    for mesh in spec.meshes:
        if mesh.file:
            file = Path(mesh.file)
            source = file if file.is_absolute() else root / file
            try:
                out[file.name] = source.read_bytes()
            except OSError as exc:
                raise SpecError(
                    [Problem(f"$.mesh[{mesh.name}]", "a readable mesh file", f"{source}: {exc.strerror}")],
                    str(path),
                ) from None
            mesh.file = file.name
    spec.meshdir = ""
    return tuple(sorted(out.items()))


def _compile_checked(spec: Any, file: str) -> Any:
    try:
        return spec.compile()
    except ValueError as exc:
        msg = str(exc).replace("\n", " ").strip()
        raise SpecError(
            [Problem("$", "a robot MuJoCo compiles with its adapter's actuators", msg)], file
        ) from None


@functools.cache
def _builtin(name: str) -> Robot:
    mujoco = import_mujoco()
    robot = _BUILDERS[name]()
    model = mujoco.MjModel.from_xml_string(robot.xml)
    data = mujoco.MjData(model)
    base = model.body(robot.base_body).id
    data.qpos[:7] = (0, 0, 0, 1, 0, 0, 0)  # the base's free joint comes first
    for joint, q in zip(robot.leg_joints, robot.default_pose, strict=True):
        data.qpos[model.jnt_qposadr[model.joint(joint).id]] = q
    mujoco.mj_kinematics(model, data)
    # exact stand height: tilted wheels (splayed legs) reach lower than their radius
    low = min(lowest_point(model, data, model.geom(g).id) for g in robot.foot_geoms)
    mass = float(model.body_subtreemass[base])
    return Robot(**{**robot.__dict__, "mass": round(mass, 3), "stand_height": round(-low, 6)})


def load_robot(name_or_path: str | Path, adapter: str | Path | Mapping[str, Any] | None = None) -> Robot:
    """A built-in robot by name (:data:`BUILTIN`), or a user's MJCF or URDF robot file
    with its adapter (a TOML or JSON file, or a dict).

    The adapter's keys (lengths in m, speeds in m/s, angles in rad)::

        base = "chassis"          # the top body (default: the file's only top body)
        radius = 0.3              # planner radius
        max_speed = 1.0
        max_yaw_rate = 1.5        # rad/s
        max_accel = 1.5           # optional, m/s^2 (and max_yaw_accel, rad/s^2, default 3)
        feet = ["wheel_l", ...]   # geoms allowed on the ground (default: the lowest ones)
        casters = ["caster"]      # optional: geoms made frictionless (ideal casters)
        [nav]
        mode = "wheels"           # or "base": ideal planar servo on the free base
        left = ["wheel_l"]        # velocity actuators, or hinge joints to get one
        right = ["wheel_r"]
        wheel_radius = 0.08
        track_width = 0.3
        wheel_kv = 2.0            # optional, N m s/rad, for joints given without actuator
        wheel_torque = 10.0       # optional, N m
        [loco]                    # optional
        joints = ["hip", ...]     # position actuators, or joints to get one (kp, kd, torque)
        default_pose = [0.0, ...]
        action_scale = 0.25       # rad per unit of action, one number or one per joint

    The base gets a free joint if it has none (a URDF's root link is made floating);
    unnamed geoms are named ``geom<k>`` by their order; every collision geom gets the
    robot's contact bits. Raises :class:`~citygen.errors.SpecError` (one line naming the file and
    the key) for a bad adapter, :class:`~citygen.errors.CitygenError` for an unknown name.
    """
    if isinstance(name_or_path, str) and name_or_path in _BUILDERS:
        if adapter is not None:
            raise CitygenError(f"robot {name_or_path!r} is built in and takes no adapter")
        return _builtin(name_or_path)
    if name_or_path == "humanoid":
        raise CitygenError(
            f"robot 'humanoid' is not built yet; the built-in robots are {', '.join(BUILTIN)} "
            "(or pass an MJCF/URDF file and an adapter)"
        )
    path = Path(name_or_path)
    if not path.is_file():
        raise CitygenError(
            f"unknown robot {str(name_or_path)!r}: expected one of {', '.join(BUILTIN)} or an MJCF/URDF file"
        )
    return _custom(path, adapter)


# --- composing a robot into a scene ---------------------------------------------------------


def flat_ground(size: float = 40.0, friction: float = 0.75) -> MJCF:
    """A scene of flat ground only: a static box ``size`` metres square, top at z = 0, with
    the scene exporter's contact bits and the given sliding friction (concrete's by default)."""
    xml = (
        '<mujoco model="flat">\n  <compiler angle="radian" autolimits="true"/>\n  <worldbody>\n'
        f'    <geom name="zone/none/ground/0" type="box" size="{_v(size / 2, size / 2, 0.5)}" pos="0 0 -0.5" '
        f'contype="1" conaffinity="0" priority="1" friction="{_v(friction, 0.005, 0.0001)}" '
        'rgba="0.8 0.8 0.78 1"/>\n'
        '    <light name="sun" directional="true" dir="0.3 0.4 -1" pos="0 0 10"/>\n'
        "  </worldbody>\n</mujoco>\n"
    )
    return MJCF(xml, {})


def compose(scene_mjcf: MJCF, robot: Robot, pose: tuple[float, float, float, float]) -> Any:
    """The scene with the robot in it, compiled: a ``mujoco.MjModel``.

    ``pose = (x, y, ground_z, yaw)`` in m and rad: the robot stands there (its base
    origin ``robot.stand_height`` above ``ground_z``; :meth:`RobotHandle.reset` puts it
    anywhere later). The robot's names get the prefix :data:`PREFIX`; the physics step
    is ``robot.timestep`` with the implicit-fast integrator.
    """
    mujoco = import_mujoco()
    x, y, z, yaw = (float(v) for v in pose)
    try:
        scene = mujoco.MjSpec.from_string(scene_mjcf.xml, assets=dict(scene_mjcf.assets))
        child = mujoco.MjSpec.from_string(robot.xml, assets=dict(robot.assets))
    except ValueError as exc:
        raise ExportError(f"compose: MuJoCo rejected the {robot.name!r} robot or the scene: {exc}") from None
    base = child.body(robot.base_body)
    base.pos, base.quat = [0.0, 0.0, robot.stand_height], [1.0, 0.0, 0.0, 0.0]
    for geom in child.geoms:
        if geom.contype or geom.conaffinity:
            geom.contype, geom.conaffinity = ROBOT_BIT, ROBOT_CONAFFINITY
    for spec in (scene, child):  # equal options, so attaching has nothing to reconcile
        spec.option.timestep = robot.timestep
        spec.option.integrator = mujoco.mjtIntegrator.mjINT_IMPLICITFAST
        spec.option.cone = mujoco.mjtCone.mjCONE_ELLIPTIC
        spec.option.impratio = IMPRATIO
    # A city holds ~10^4 static bodies: MuJoCo's default arena is too small for its broadphase.
    n = len(scene.geoms)
    if n > 2000:
        scene.memory = max(scene.memory, n * 16 * 1024)
    frame = scene.worldbody.add_frame(pos=[x, y, z], quat=[math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    scene.attach(child, prefix=PREFIX, frame=frame)
    try:
        return scene.compile()
    except ValueError as exc:
        raise ExportError(
            f"compose: MuJoCo rejected the scene with the {robot.name!r} robot: {exc}"
        ) from None


# --- driving a robot in a compiled model ------------------------------------------------------

#: Period (s) of the wheel drive's feedback loop as the environments run it: they call
#: :meth:`RobotHandle.drive` of a wheeled robot once per period and hold its wheel speed
#: targets for the physics steps in between (100 Hz: 5 physics steps of :data:`TIMESTEP`;
#: real wheel controllers run at 100-1000 Hz). The wheels' velocity actuators and the legs'
#: PD act at every physics step inside MuJoCo. The ideal-locomotion servo (``nav_mode ==
#: "base"``) stands in for a locomotion policy with stiff force feedback and runs at every
#: physics step (held 5 steps its attitude loop diverges); only its gain's composite
#: inertia, which changes with the legs' pose alone, is recomputed once per period.
DRIVE_DT = 0.01

# Drive feedback: wheel speeds get the command plus these gains (1) times the error of the
# measured forward speed and yaw rate, and these gains (1/s) times its integral.
_WHEEL_P, _WHEEL_I = 0.5, 3.0
# Ideal-locomotion servo: planar velocity (1/s), height (1/s^2, 1/s), attitude (1/s^2, 1/s).
_SERVO_V, _SERVO_W, _SERVO_KP, _SERVO_KD = 10.0, 10.0, 400.0, 40.0


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
    steps per call of :meth:`drive` in the environments (a :data:`DRIVE_DT` period for
    wheels, 1 for the ideal-locomotion servo).
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
        self.mass = float(model.body_subtreemass[root])
        self.default = np.array(robot.default_pose, dtype=float)
        self.scale = np.array(robot.action_scale, dtype=float)
        self._is_robot_geom = np.zeros(model.ngeom, dtype=bool)
        self._is_robot_geom[self.geom_ids] = True
        self._not_foot = self._is_robot_geom.copy()
        self._not_foot[self.foot_geom_ids] = False
        wheels = robot.nav_mode == "wheels"
        self.drive_substeps = max(1, round(DRIVE_DT / model.opt.timestep)) if wheels else 1
        # Drive state: the integral of the speed and yaw-rate errors, the ramped reference.
        self._integral = (0.0, 0.0)
        self._ref = (0.0, 0.0)
        self._ground: float | None = None
        self._servo_age = math.inf  # s since the servo's inertia was computed
        self._servo_inertia = 0.0  # kg m^2
        # Constants of the drive, read once: plain floats and ids (the drive runs often).
        self._timestep = float(model.opt.timestep)
        self._left_ids = [int(a) for a in self.left]
        self._right_ids = [int(a) for a in self.right]
        self._body_masses = model.body_mass[self.body_ids].copy()
        self._half_inertia = float(model.body_inertia[self.body_ids].sum() / 2)
        self._ray_point = np.zeros(3)
        self._ray_down = np.array([0.0, 0.0, -1.0])
        self._ray_geom = np.zeros(1, dtype=np.int32)

    @property
    def n_joints(self) -> int:
        return self.robot.n_joints

    def reset(self, data: Any, pose: tuple[float, float, float, float]) -> None:
        """Put the robot standing at ``pose = (x, y, ground_z, yaw)`` (m, rad), legs in the
        default pose, every robot velocity, applied force and drive integral zero; runs
        ``mj_forward``."""
        m = self.model
        x, y, z, yaw = (float(v) for v in pose)
        for j in self.joint_ids:
            a, n = m.jnt_qposadr[j], (7 if m.jnt_type[j] == 0 else 4 if m.jnt_type[j] == 1 else 1)
            data.qpos[a : a + n] = m.qpos0[a : a + n]
        q = self.qadr
        data.qpos[q : q + 7] = (x, y, z + self.robot.stand_height, math.cos(yaw / 2), 0, 0, math.sin(yaw / 2))
        data.qpos[self.leg_qadr] = self.default
        data.qvel[self.dof_ids] = 0.0
        data.qacc_warmstart[self.dof_ids] = 0.0
        data.ctrl[self.leg_act] = self.default
        data.ctrl[self.wheel_act] = 0.0
        data.xfrc_applied[self.body_ids] = 0.0
        self._integral = (0.0, 0.0)
        self._ref = (0.0, 0.0)
        self._ground = z
        self._servo_age = math.inf
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
        motion (wheel robots: a PI correction of the wheel speeds; ideal locomotion: the
        base servo's forces in ``data.xfrc_applied``) and its outputs hold until the next
        call. The environments call it every :data:`DRIVE_DT`."""
        r = self.robot
        dt = self._timestep if dt is None else float(dt)
        v = _clamp(float(v), r.max_speed)
        w = _clamp(float(w), r.max_yaw_rate)
        if self.leg_act.size:
            data.ctrl[self.leg_act] = self.default
        # the reference approaches the command at the robot's acceleration limits
        rv, rw = self._ref
        rv += _clamp(v - rv, dt * r.max_accel)
        rw += _clamp(w - rw, dt * r.max_yaw_accel)
        self._ref = (rv, rw)
        if r.nav_mode != "wheels":
            self._servo(data, rv, rw, dt)
            return
        vx, _, _, wz = self._velocity(data)
        ev, ew = rv - vx, rw - wz
        iv, iw = self._integral
        iv, iw = _clamp(iv + ev * dt, 1.0), _clamp(iw + ew * dt, 1.0)
        self._integral = (iv, iw)
        vc = rv + _WHEEL_P * ev + _WHEEL_I * iv
        wc = rw + _WHEEL_P * ew + _WHEEL_I * iw
        half = wc * r.track_width / 2
        ctrl = data.ctrl
        for a in self._left_ids:
            ctrl[a] = (vc - half) / r.wheel_radius
        for a in self._right_ids:
            ctrl[a] = (vc + half) / r.wheel_radius

    def _ground_below(self, data: Any) -> float:
        """Height (m) of the first non-robot surface under the base origin."""
        point, gid = self._ray_point, self._ray_geom
        point[:] = data.xpos[self.base_id]
        for _ in range(8):
            dist = self._mj.mj_ray(self.model, data, point, self._ray_down, None, 1, self.base_id, gid)
            if dist < 0:
                break
            point[2] -= dist
            if not self._is_robot_geom[gid[0]]:
                self._ground = float(point[2])
                break
            point[2] -= 1e-4
        return self._ground if self._ground is not None else 0.0

    def _servo(self, data: Any, v: float, w: float, dt: float) -> None:
        """Ideal locomotion: base forces and torques (``data.xfrc_applied``) that carry the
        weight at the hover height, keep the trunk level and track ``(v, w)``; ``dt`` (s):
        the time since the last call. The composite inertia is recomputed every
        :data:`DRIVE_DT`; the ground under the base at every call (the hover height must
        follow edges and objects as the base passes over them)."""
        b = self.base_id
        self._servo_age += dt
        if self._servo_age >= DRIVE_DT - 1e-9:
            self._servo_age = 0.0
            # composite inertia about the subtree's centre of mass (kg m^2), horizontal axes
            d = data.xipos[self.body_ids] - data.subtree_com[b]
            inertia = float(self._body_masses @ (d[:, 0] ** 2 + d[:, 1] ** 2)) + self._half_inertia
            self._servo_inertia = inertia
        inertia = self._servo_inertia
        target = self._ground_below(data) + self.robot.stand_height + HOVER_CLEARANCE
        r = data.xmat[b].tolist()  # row-major 3x3 rotation of the base
        z, qw, qx, qy, qz = data.qpos[self.qadr + 2 : self.qadr + 7].tolist()
        lx, ly, lz, ax, ay, az = data.qvel[self.dadr : self.dadr + 6].tolist()
        yaw = math.atan2(2 * (qw * qz + qx * qy), 1 - 2 * (qy * qy + qz * qz))
        c, s = math.cos(yaw), math.sin(yaw)
        # world angular velocity (the free joint's is in the base frame)
        wx = r[0] * ax + r[1] * ay + r[2] * az
        wy = r[3] * ax + r[4] * ay + r[5] * az
        wz = r[6] * ax + r[7] * ay + r[8] * az
        m = self.mass
        # tilt = (base z axis) x (world z): the base's z axis is the rotation's third column
        data.xfrc_applied[b] = (
            m * _SERVO_V * (v * c - lx),
            m * _SERVO_V * (v * s - ly),
            m * (_GRAVITY + _SERVO_KP * (target - z) - _SERVO_KD * lz),
            inertia * (_SERVO_KP * r[5] - _SERVO_KD * wx),
            inertia * (_SERVO_KP * -r[2] - _SERVO_KD * wy),
            inertia * _SERVO_W * (w - wz),
        )

    def joint_action(self, data: Any, action: np.ndarray) -> None:
        """Locomotion: leg joint targets ``default_pose + action_scale * clip(action, -1, 1)``
        (rad) for an action of :attr:`n_joints` numbers; wheels (if any) are held still."""
        a = np.asarray(action, dtype=float)
        if a.shape != (self.n_joints,):
            raise ValueError(f"joint_action: expected {self.n_joints} numbers, got shape {a.shape}")
        data.ctrl[self.leg_act] = self.default + self.scale * np.clip(a, -1.0, 1.0)
        data.ctrl[self.wheel_act] = 0.0

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
