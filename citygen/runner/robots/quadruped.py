"""``quadruped``: Go2-like, trunk 0.38 x 0.09 x 0.11 m, about 15 kg, 12 hinge joints (hip
abduction, hip flexion, knee per leg, legs in the order FR, FL, RR, RL) with position actuators
(Go2's torque limits), standing base height 0.30 m. In navigation it uses ideal locomotion
(``nav_mode == "base"``, see :mod:`citygen.runner.robots.handle`)."""

from __future__ import annotations

from citygen.runner.robots.base import Robot, _Doc, _leg_set, _legs, _stand, _v
from citygen.runner.robots.registry import register
from citygen.spec.task import ROBOTS

_QUAD_LEGS = _leg_set(0.1934, 0.0465, 0.0955, 0.213, 0.213, 0.022)
_QUAD_POSE = (0.0, 0.85, -1.7) * 4


@register("quadruped")
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
        radius=ROBOTS["quadruped"].radius,
        max_speed=1.0,
        max_yaw_rate=1.5,
        mass=0.0,
        max_accel=2.0,
        max_yaw_accel=4.0,
        stand_height=h,
        max_step=ROBOTS["quadruped"].max_step,
        nav_mode="base",
        leg_joints=tuple(joints),
        leg_actuators=tuple(acts),
        default_pose=pose,
        action_scale=(0.5, 1.0, 1.0) * 4,
        timestep=0.005,  # s: its legs' PD servos and feet need 5 ms steps (10 ms diverges)
        foot_geoms=tuple(feet),
        legs=legs,
    )
