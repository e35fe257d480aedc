"""``scooter``: a four-wheel mobility scooter, 1.25 m long, 0.62 m wide, about 140 kg
including a 75 kg seated rider; Ackermann steering (``nav_mode == "ackermann"``): the front
wheels turn on steering hinges (position actuators, up to 0.6 rad, kp 400 N m/rad) and roll
freely, the rear wheels are driven (velocity actuators, an electronic differential).
Wheelbase 0.9 m, track 0.56 m, wheels 0.13 m in radius; base origin at the centre of the
footprint, at axle height. Top speed 15 km/h (4.17 m/s), 1.0 rad/s turning, 1.2 m/s^2; it
cannot turn on the spot (tightest turn 1.3 m in radius at the rear axle): see
:meth:`~citygen.runner.robots.RobotHandle.drive`. Sensors: those of every robot in the
environments (base pose and velocity, occupancy patch, optional RGB/depth cameras).
"""

from __future__ import annotations

import xml.etree.ElementTree as ET

from citygen.runner.robots.base import _COLLIDE, Robot, _Doc, _n, _v
from citygen.runner.robots.registry import register
from citygen.spec.task import ROBOTS

WHEEL_R, WHEELBASE, TRACK, MAX_STEER = 0.13, 0.9, 0.56, 0.6
_TYRE = "0.12 0.12 0.12 1"


def _front_wheel(doc: _Doc, side: str, y: float) -> str:
    """A steered, freely rolling front wheel; returns its steering actuator."""
    steer = ET.SubElement(doc.base, "body", name=f"{side}_steer", pos=_v(WHEELBASE / 2, y, 0))
    ET.SubElement(
        steer, "joint", name=f"{side}_steer", axis="0 0 1", range=_v(-MAX_STEER, MAX_STEER), damping="2",
        armature="0.02",
    )  # fmt: skip
    doc.geom(steer, f"{side}_fork", 0.5, {"contype": "0", "conaffinity": "0"}, type="sphere", size="0.03",
             pos=_v(0, 0, 0.1))  # fmt: skip
    wheel = ET.SubElement(steer, "body", name=f"{side}_front_wheel")
    ET.SubElement(wheel, "joint", name=f"{side}_front_wheel", axis="0 1 0", damping="0.01", armature="0.01")
    doc.geom(
        wheel, f"{side}_front_wheel", 2.0, type="cylinder", size=_v(WHEEL_R, 0.035), zaxis="0 1 0",
        rgba=_TYRE, condim="3",
    )  # fmt: skip
    ET.SubElement(
        doc.actuator, "position", name=f"{side}_steer", joint=f"{side}_steer", kp="400", kv="10",
        forcerange="-150 150",
    )  # fmt: skip
    return f"{side}_steer"


@register("scooter")
def _scooter() -> Robot:
    h = WHEEL_R
    doc = _Doc("scooter", h, "0.7 0.1 0.12 1")
    base = doc.base
    doc.geom(base, "deck", 22.0, type="box", size=_v(0.55, 0.22, 0.04), pos=_v(0, 0, 0.02))
    doc.geom(base, "battery", 14.0, type="box", size=_v(0.18, 0.16, 0.06), pos=_v(-0.15, 0, 0.12))
    doc.geom(base, "rear_shroud", 6.0, type="box", size=_v(0.2, 0.25, 0.06), pos=_v(-0.45, 0, 0.17))
    doc.geom(base, "front_shroud", 3.0, type="box", size=_v(0.12, 0.24, 0.05), pos=_v(0.5, 0, 0.17))
    doc.geom(base, "seat_post", 2.0, type="capsule", size="0.03", fromto=_v(-0.15, 0, 0.18, -0.15, 0, 0.42))
    doc.geom(base, "seat", 5.0, type="box", size=_v(0.22, 0.23, 0.05), pos=_v(-0.15, 0, 0.47))
    doc.geom(base, "backrest", 2.0, type="box", size=_v(0.03, 0.22, 0.2), pos=_v(-0.38, 0, 0.72))
    doc.geom(base, "tiller", 2.0, type="capsule", size="0.025", fromto=_v(0.5, 0, 0.2, 0.32, 0, 0.85))
    doc.geom(
        base, "handlebar", 1.0, type="capsule", size="0.02", fromto=_v(0.32, -0.22, 0.85, 0.32, 0.22, 0.85)
    )
    skin, body = {**_COLLIDE}, "0.85 0.6 0.45 1"
    rider = (  # name, mass, half sizes, centre: 75 kg
        ("rider_torso", 38.0, (0.11, 0.19, 0.28), (-0.22, 0, 0.82)),
        ("rider_thighs", 18.0, (0.2, 0.17, 0.08), (-0.02, 0, 0.6)),
        ("rider_shins", 8.0, (0.06, 0.15, 0.2), (0.2, 0, 0.3)),
        ("rider_arms", 6.0, (0.22, 0.2, 0.04), (0.07, 0, 0.85)),
    )
    for name, mass, size, pos in rider:
        doc.geom(base, name, mass, skin, type="box", size=_v(*size), pos=_v(*pos), rgba=body)
    doc.geom(base, "rider_head", 5.0, skin, type="sphere", size=_n(0.1), pos=_v(-0.2, 0, 1.22), rgba=body)
    steer = (_front_wheel(doc, "left", TRACK / 2), _front_wheel(doc, "right", -TRACK / 2))
    for name, y in (("left_wheel", TRACK / 2), ("right_wheel", -TRACK / 2)):
        doc.wheel(base, name, (-WHEELBASE / 2, y, 0), WHEEL_R, 0.07, 2.5, kv=40.0, torque=120.0)
    return Robot(
        name="scooter",
        xml=doc.xml(),
        radius=ROBOTS["scooter"].radius,
        max_speed=15.0 / 3.6,
        max_yaw_rate=1.0,
        mass=0.0,
        max_accel=1.2,
        max_yaw_accel=2.0,
        stand_height=h,
        max_step=ROBOTS["scooter"].max_step,
        nav_mode="ackermann",
        left_wheels=("left_wheel",),
        right_wheels=("right_wheel",),
        wheel_radius=WHEEL_R,
        track_width=TRACK,
        steer_actuators=steer,
        wheelbase=WHEELBASE,
        max_steer=MAX_STEER,
        foot_geoms=("left_wheel", "right_wheel", "left_front_wheel", "right_front_wheel"),
    )
