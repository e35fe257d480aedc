"""``wheelchair``: an electric wheelchair, 0.65 m wide, 1.1 m long, about 110 kg including a
70 kg seated person; differential drive on the rear wheels, frictionless front casters."""

from __future__ import annotations

from citygen.runner.robots.base import _CASTER, _COLLIDE, Robot, _Doc, _n, _v
from citygen.runner.robots.registry import register
from citygen.spec.task import ROBOTS


@register("wheelchair")
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
        radius=ROBOTS["wheelchair"].radius,
        max_speed=1.6,
        max_yaw_rate=1.5,
        mass=0.0,
        max_accel=1.0,
        max_yaw_accel=2.0,
        stand_height=h,
        max_step=ROBOTS["wheelchair"].max_step,
        left_wheels=("left_wheel",),
        right_wheels=("right_wheel",),
        wheel_radius=r,
        track_width=track,
        timestep=0.005,  # s: planner success as at 2 ms (10 ms loses 3-4 points: contacts)
        foot_geoms=("left_wheel", "right_wheel", "left_caster", "right_caster"),
    )
