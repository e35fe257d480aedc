"""``wheeled_legged``: B2-W-like, about 76 kg, 12 leg joints (kp 1500, kd 30) plus a driven
wheel at each foot (4 velocity actuators), standing base height about 0.58 m; in navigation it
drives on its wheels (skid steering) while the legs hold the drive pose, feet under hips."""

from __future__ import annotations

import math

import numpy as np

from citygen.runner.robots.base import Robot, _Doc, _leg_set, _legs, _stand, _v
from citygen.runner.robots.registry import register
from citygen.spec.task import ROBOTS

_WL_LEGS = _leg_set(0.3285, 0.072, 0.12, 0.35, 0.35, 0.09)
# The stance locomotion starts from and acts around: front feet a little behind their hips,
# rear feet in front, legs splayed out: a wheelbase of 0.46 m against a track of 0.72 m.
_WL_POSE = tuple(
    round(float(q), 4)
    for leg in _WL_LEGS
    for q in leg.ik(
        np.array([-0.1 if leg.hip_x > 0 else 0.1, leg.lateral + math.copysign(0.1, leg.lateral), -0.5])
    )
)
# Driving on its wheels (navigation) the feet stand under the hips at the same depth and
# splay: a wheelbase of 0.66 m. On the walking stance a 1.5 m/s start unloaded the front
# wheels (pitch -40 degrees, a wheelie the drive's speed loop then held), a 2 m/s start
# tipped the robot over, and at 1 m/s it turned at 0.93 rad/s when asked 1.5; on this one it
# keeps within 2 degrees of level at 2 m/s and turns at 1.52 rad/s.
_WL_DRIVE_POSE = tuple(
    round(float(q), 4)
    for leg in _WL_LEGS
    for q in leg.ik(np.array([0.0, leg.lateral + math.copysign(0.1, leg.lateral), -0.5]))
)


@register("wheeled_legged")
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
        radius=ROBOTS["wheeled_legged"].radius,
        max_speed=2.0,
        max_yaw_rate=1.5,
        mass=0.0,
        max_accel=1.5,
        max_yaw_accel=3.0,
        stand_height=h,
        max_step=ROBOTS["wheeled_legged"].max_step,
        left_wheels=("FL_wheel", "RL_wheel"),
        right_wheels=("FR_wheel", "RR_wheel"),
        wheel_radius=r,
        track_width=track,
        leg_joints=tuple(joints),
        leg_actuators=tuple(acts),
        default_pose=pose,
        drive_pose=_WL_DRIVE_POSE,
        action_scale=(0.5, 1.0, 1.0) * 4,
        timestep=0.005,  # s: its legs' PD servos hold the stance at 5 ms steps
        foot_geoms=tuple(feet),
        legs=legs,
    )
