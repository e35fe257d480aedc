"""``wheeled``: a delivery robot, 0.7 m x 0.55 m, 0.5 m tall, about 45 kg; two driven wheels
(hinge joints with velocity actuators) at mid-length and a frictionless caster sphere in front
and behind: exact differential drive."""

from __future__ import annotations

from citygen.runner.robots.base import Robot, _caster, _Doc, _v
from citygen.runner.robots.registry import register
from citygen.spec.task import ROBOTS


@register("wheeled")
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
        doc.wheel(doc.base, name, (0, y, 0), r, 0.06, 2.0, kv=8.0, torque=30.0, tyre="ellipsoid")
    return Robot(
        name="wheeled",
        xml=doc.xml(),
        radius=ROBOTS["wheeled"].radius,
        max_speed=1.5,
        max_yaw_rate=2.0,
        mass=0.0,
        max_accel=1.5,
        max_yaw_accel=3.0,
        stand_height=h,
        max_step=ROBOTS["wheeled"].max_step,
        left_wheels=("left_wheel",),
        right_wheels=("right_wheel",),
        wheel_radius=r,
        track_width=track,
        timestep=0.005,  # s: planner success as at 2 ms (10 ms loses 3-4 points: contacts)
        cone="pyramidal",
        foot_geoms=("left_wheel", "right_wheel", "front_caster", "rear_caster"),
    )
