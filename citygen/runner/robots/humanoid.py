"""``humanoid``: G1-like, 1.32 m tall, about 35 kg, 21 hinge joints with position actuators.

Size and joints (Unitree G1's, rounded): pelvis 0.2 m wide, hips 0.128 m apart, thigh and
shank 0.32 m each, box feet 0.22 x 0.09 x 0.04 m (sole 0.045 m below the ankle), shoulders
0.36 m apart. Joints in action order: per leg (left, then right) ``hip_pitch``,
``hip_roll``, ``hip_yaw``, ``knee``, ``ankle_pitch``, ``ankle_roll``; ``waist_yaw``; per
arm (left, then right) ``shoulder_pitch``, ``shoulder_roll``, ``shoulder_yaw``, ``elbow``.
In a leg the hip roll is the outermost joint, then yaw, then pitch (all three axes meet at
the hip joint); the ankle's two axes meet at the ankle. Limits are G1's; torque limits
88 N m (hips, waist), 139 N m (knees), 50 N m (ankles), 25 N m (arms); position servos
(legs kp 500, kd 10 N m s/rad; arms kp 100, kd 2). Signs follow G1: a negative hip pitch
swings the leg forward, a positive knee bends it. The base (pelvis) origin is the midpoint
of the hip joints, 0.66 m above the ground when standing with knees bent 0.6 rad.

Speed limits (navigation, ideal locomotion ``nav_mode == "base"`` as the quadruped's):
1.2 m/s forward (G1 walks up to 2 m/s), 1.5 rad/s turning; footprint radius and highest step
(0.3 m, 0.2 m) from :data:`citygen.spec.task.ROBOTS`.
Locomotion baselines: :mod:`citygen.runner.control.gaits_biped` (stand, walk). Sensors: those of
every robot in the environments (base pose and velocity, joint positions and speeds, the
height map or occupancy patch, optional RGB/depth cameras).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from citygen.runner.robots.base import Leg, Robot, _Doc, _n, _v
from citygen.runner.robots.registry import register
from citygen.spec.task import ROBOTS

THIGH, SHANK = 0.32, 0.32
#: Height (m) of the ankle joint above the sole.
ANKLE_HEIGHT = 0.045
HIP_Y = 0.064
#: Box foot: half sizes (m) and the box centre's forward offset from the ankle.
FOOT_HALF = (0.11, 0.045, 0.0125)
FOOT_X = 0.03
LEG_NAMES = ("hip_pitch", "hip_roll", "hip_yaw", "knee", "ankle_pitch", "ankle_roll")
ARM_NAMES = ("shoulder_pitch", "shoulder_roll", "shoulder_yaw", "elbow")
# (lower, upper) rad, G1's; roll limits for the left side (mirrored on the right).
_LIMITS = {
    "hip_pitch": (-2.53, 2.88), "hip_roll": (-0.52, 2.97), "hip_yaw": (-2.76, 2.76), "knee": (-0.087, 2.88),
    "ankle_pitch": (-0.87, 0.52), "ankle_roll": (-0.26, 0.26), "waist_yaw": (-2.62, 2.62),
    "shoulder_pitch": (-3.09, 2.67), "shoulder_roll": (-1.59, 2.25), "shoulder_yaw": (-2.62, 2.62),
    "elbow": (-1.05, 2.09),
}  # fmt: skip
# (torque limit N m, kp N m/rad, kd N m s/rad, armature kg m^2)
_DRIVE = {
    "hip_pitch": (88.0, 2000.0, 30.0, 0.03), "hip_roll": (88.0, 2000.0, 30.0, 0.03),
    "hip_yaw": (88.0, 1000.0, 15.0, 0.02), "knee": (139.0, 2000.0, 30.0, 0.03),
    "ankle_pitch": (50.0, 1000.0, 15.0, 0.01), "ankle_roll": (50.0, 1000.0, 15.0, 0.01),
    "waist_yaw": (88.0, 300.0, 6.0, 0.02), "shoulder_pitch": (25.0, 100.0, 2.0, 0.01),
    "shoulder_roll": (25.0, 100.0, 2.0, 0.01), "shoulder_yaw": (25.0, 100.0, 2.0, 0.01),
    "elbow": (25.0, 100.0, 2.0, 0.01),
}  # fmt: skip
#: Standing leg angles: knees bent 0.6 rad, feet flat; arms a little out and bent.
LEG_POSE = (-0.3, 0.0, 0.0, 0.6, -0.3, 0.0)
ARM_POSE = {"left": (0.2, 0.1, 0.0, 0.6), "right": (0.2, -0.1, 0.0, 0.6)}
_GHOST = {"contype": "0", "conaffinity": "0"}
_SKIN = "0.2 0.2 0.22 1"


def _mirror(name: str, side: str) -> tuple[float, float]:
    lo, hi = _LIMITS[name]
    return (-hi, -lo) if side == "right" and name.endswith(("roll", "yaw")) else (lo, hi)


def _joint(doc: _Doc, body: ET.Element, kind: str, side: str, axis: str) -> str:
    full = f"{side}_{kind}" if side else kind
    torque, kp, kd, armature = _DRIVE[kind]
    ET.SubElement(
        body, "joint", name=full, axis=axis, range=_v(*_mirror(kind, side)), armature=_n(armature),
        damping="0.5",
    )  # fmt: skip
    ET.SubElement(
        doc.actuator, "position", name=full, joint=full, kp=_n(kp), kv=_n(kd), forcerange=_v(-torque, torque)
    )
    return full


def _leg(doc: _Doc, side: str) -> list[str]:
    s = 1.0 if side == "left" else -1.0
    roll = ET.SubElement(doc.base, "body", name=f"{side}_hip_roll", pos=_v(0, s * HIP_Y, 0))
    names = {"hip_roll": _joint(doc, roll, "hip_roll", side, "1 0 0")}
    doc.geom(roll, f"{side}_hip_roll", 1.0, _GHOST, type="sphere", size="0.05")
    yaw = ET.SubElement(roll, "body", name=f"{side}_hip_yaw")
    names["hip_yaw"] = _joint(doc, yaw, "hip_yaw", side, "0 0 1")
    doc.geom(yaw, f"{side}_hip_yaw", 0.8, _GHOST, type="sphere", size="0.045")
    thigh = ET.SubElement(yaw, "body", name=f"{side}_thigh")
    names["hip_pitch"] = _joint(doc, thigh, "hip_pitch", side, "0 1 0")
    doc.geom(thigh, f"{side}_thigh", 3.0, type="capsule", size="0.045", fromto=_v(0, 0, -0.05, 0, 0, -THIGH))
    shank = ET.SubElement(thigh, "body", name=f"{side}_shank", pos=_v(0, 0, -THIGH))
    names["knee"] = _joint(doc, shank, "knee", side, "0 1 0")
    doc.geom(
        shank, f"{side}_shank", 2.0, type="capsule", size="0.035", fromto=_v(0, 0, 0, 0, 0, -SHANK + 0.04)
    )
    ankle = ET.SubElement(shank, "body", name=f"{side}_ankle", pos=_v(0, 0, -SHANK))
    names["ankle_pitch"] = _joint(doc, ankle, "ankle_pitch", side, "0 1 0")
    doc.geom(ankle, f"{side}_ankle", 0.1, _GHOST, type="sphere", size="0.02")
    foot = ET.SubElement(ankle, "body", name=f"{side}_foot")
    names["ankle_roll"] = _joint(doc, foot, "ankle_roll", side, "1 0 0")
    doc.geom(
        foot, f"{side}_foot", 0.6, type="box", size=_v(*FOOT_HALF),
        pos=_v(FOOT_X, 0, FOOT_HALF[2] - ANKLE_HEIGHT), rgba="0.1 0.1 0.1 1", condim="3",
    )  # fmt: skip
    return [names[k] for k in LEG_NAMES]


def _arm(doc: _Doc, torso: ET.Element, side: str) -> list[str]:
    s = 1.0 if side == "left" else -1.0
    pitch = ET.SubElement(torso, "body", name=f"{side}_shoulder", pos=_v(0, s * 0.165, 0.34))
    names = {"shoulder_pitch": _joint(doc, pitch, "shoulder_pitch", side, "0 1 0")}
    doc.geom(pitch, f"{side}_shoulder", 0.5, _GHOST, type="sphere", size="0.04")
    roll = ET.SubElement(pitch, "body", name=f"{side}_upper_arm_roll")
    names["shoulder_roll"] = _joint(doc, roll, "shoulder_roll", side, "1 0 0")
    doc.geom(roll, f"{side}_upper_arm_roll", 0.2, _GHOST, type="sphere", size="0.03")
    upper = ET.SubElement(roll, "body", name=f"{side}_upper_arm")
    names["shoulder_yaw"] = _joint(doc, upper, "shoulder_yaw", side, "0 0 1")
    doc.geom(
        upper, f"{side}_upper_arm", 0.8, type="capsule", size="0.035", fromto=_v(0, 0, -0.04, 0, 0, -0.2)
    )
    fore = ET.SubElement(upper, "body", name=f"{side}_forearm", pos=_v(0, 0, -0.2))
    names["elbow"] = _joint(doc, fore, "elbow", side, "0 1 0")
    doc.geom(fore, f"{side}_forearm", 0.7, type="capsule", size="0.03", fromto=_v(0, 0, 0, 0.2, 0, 0))
    doc.geom(fore, f"{side}_hand", 0.2, type="sphere", size="0.04", pos=_v(0.23, 0, 0))
    return [names[k] for k in ARM_NAMES]


@register("humanoid")
def _humanoid() -> Robot:
    h = ANKLE_HEIGHT + (THIGH + SHANK) * 0.955336  # knees bent 0.6 rad: cos(0.3)
    doc = _Doc("humanoid", h, "0.75 0.76 0.78 1")
    doc.geom(doc.base, "pelvis", 4.5, type="box", size=_v(0.07, 0.1, 0.06), pos=_v(0, 0, 0.05))
    torso = ET.SubElement(doc.base, "body", name="torso", pos=_v(0, 0, 0.11))
    waist = _joint(doc, torso, "waist_yaw", "", "0 0 1")
    doc.geom(torso, "torso", 9.0, type="box", size=_v(0.08, 0.13, 0.17), pos=_v(0, 0, 0.2))
    doc.geom(torso, "neck", 0.3, _GHOST, type="capsule", size="0.03", fromto=_v(0, 0, 0.37, 0, 0, 0.4))
    doc.geom(torso, "head", 1.5, type="sphere", size="0.09", pos=_v(0, 0, 0.47), rgba=_SKIN)
    joints = (
        _leg(doc, "left")
        + _leg(doc, "right")
        + [waist]
        + _arm(doc, torso, "left")
        + _arm(doc, torso, "right")
    )
    pose = LEG_POSE * 2 + (0.0,) + ARM_POSE["left"] + ARM_POSE["right"]
    legs = tuple(
        Leg(f"{side}", 0.0, s * HIP_Y, 0.0, THIGH, SHANK, ANKLE_HEIGHT)
        for side, s in (("left", 1), ("right", -1))
    )
    # a unit of action: 0.6 rad at the hips and knees, less at the ankles' short range
    scale = (0.8, 0.4, 0.4, 1.0, 0.6, 0.26) * 2 + (0.5,) + (1.0, 0.5, 0.5, 1.0) * 2
    return Robot(
        name="humanoid",
        xml=doc.xml(),
        radius=ROBOTS["humanoid"].radius,
        max_speed=1.2,
        max_yaw_rate=1.5,
        mass=0.0,
        max_accel=1.5,
        max_yaw_accel=3.0,
        stand_height=h,
        max_step=ROBOTS["humanoid"].max_step,
        nav_mode="base",
        leg_joints=tuple(joints),
        leg_actuators=tuple(joints),
        default_pose=pose,
        action_scale=scale,
        foot_geoms=("left_foot", "right_foot"),
        legs=legs,
        # push 35 kg x 10/s = 351 N per m/s, x 0.2 m = 70 N m; 0.66 kg m^2 x 100/s = 66 N m.
        # At 50/s it turned 32 degrees in 3 s pushing into a wall (the quadruped 140) and
        # spent NavDynamic episodes pinned on a bin, turning +-0.4 rad while it pushed.
        servo_yaw_gain=100.0,
    )
