"""What every robot shares: the :class:`Robot` description, leg geometry, and the helpers
that build a robot's MJCF in code (one builder per file beside this one)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from citygen.exporters.mjcf.contract import ROBOT_BIT, ROBOT_CONAFFINITY

#: Physics timestep (s) of a composed model unless the robot asks for another
#: (:attr:`Robot.timestep`).
TIMESTEP = 0.002
#: Friction-to-normal impedance ratio (with elliptic friction cones) of a composed model:
#: MuJoCo's soft contacts otherwise let planted feet creep (0.3 m/s in a trot at 1).
IMPRATIO = 100.0
#: Prefix of every name of the robot inside a composed model.
PREFIX = "robot:"
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
    """``"wheels"`` (differential drive on wheel actuators), ``"ackermann"`` (steered front
    wheels, driven rear wheels) or ``"base"`` (ideal locomotion)."""
    left_wheels: tuple[str, ...] = ()
    """Velocity actuators of the left wheels (target in rad/s, positive rolls forward)."""
    right_wheels: tuple[str, ...] = ()
    wheel_radius: float = 0.0
    track_width: float = 0.0
    """Distance (m) between the left and right wheels' contact lines."""
    steer_actuators: tuple[str, ...] = ()
    """Ackermann steering: position actuators of the left and right front wheels' steering
    hinges (target in rad, positive turns left)."""
    wheelbase: float = 0.0
    """Ackermann steering: distance (m) between the front and rear axles."""
    max_steer: float = 0.0
    """Ackermann steering: largest steering angle (rad) of the inner wheel."""
    leg_joints: tuple[str, ...] = ()
    """Hinge joints driven by :meth:`RobotHandle.joint_action`, in action order."""
    leg_actuators: tuple[str, ...] = ()
    """Position actuators of ``leg_joints``, same order."""
    default_pose: tuple[float, ...] = ()
    """Standing angles (rad) of ``leg_joints``."""
    drive_pose: tuple[float, ...] = ()
    """Angles (rad) of ``leg_joints`` the legs hold while the wheel drive runs (navigation on
    wheels; empty: ``default_pose``), standing the base at the same ``stand_height``. A
    wheeled-legged robot drives with its feet under its hips: the long wheelbase keeps its
    front wheels loaded when it accelerates, where the walking stance rides a wheelie."""
    action_scale: tuple[float, ...] = ()
    """Radians one unit of action moves each leg joint's target from the default pose."""
    foot_geoms: tuple[str, ...] = ()
    """Geoms allowed to touch the ground: feet, wheels, casters."""
    legs: tuple[Leg, ...] = ()
    """Leg geometry for the gaits (built-in legged robots; empty otherwise)."""
    servo_yaw_gain: float = 50.0
    """Yaw gain (1/s) of the ideal-locomotion servo (``nav_mode == "base"``): its yaw torque
    is this times the robot's composite inertia times the yaw-rate error. A walking robot
    turns with the same feet it pushes with, so the torque should be of the order of its push
    (mass x 10/s per m/s of error) at the feet's lever, ~0.2 m: 50/s gives the quadruped
    (15 kg, 0.57 kg m^2) 28 N m against 30; a robot whose turn is much weaker than its push
    stays pinned, nose on a bench, while it pushes."""
    timestep: float = TIMESTEP
    """Physics step (s) of a model with this robot: the longest its drive, servo and contacts
    behave the same at (planner success unchanged), since the step's cost is its physics."""
    cone: str = "elliptic"
    """MuJoCo's friction cone of a model with this robot: ``"elliptic"`` (with
    :data:`IMPRATIO`: friction hard against slip; legs' contacts) or ``"pyramidal"`` (cheaper
    in MuJoCo's solver; the wheeled robot's, whose drive tolerates it: planner success as
    with the elliptic cone)."""
    assets: tuple[tuple[str, bytes], ...] = field(default=(), repr=False)

    @property
    def n_joints(self) -> int:
        return len(self.leg_joints)

    @property
    def loco_wheels(self) -> tuple[str, ...]:
        """Wheel actuators a locomotion action drives after the leg joints: a legged robot's
        wheels (the wheeled-legged robot's four), left then right; none for the others."""
        return (*self.left_wheels, *self.right_wheels) if self.leg_joints else ()


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
        tyre: str = "cylinder",
    ) -> None:
        """A driven wheel on a hinge about y with a velocity actuator; ``tyre`` its contact
        shape: a ``"cylinder"`` (two contacts on flat ground, a general convex collision
        against a box) or an ``"ellipsoid"`` of the wheel's radius and width (one contact,
        cheaper; the rim rounded off)."""
        body = ET.SubElement(parent, "body", name=name, pos=_v(*pos))
        ET.SubElement(body, "joint", name=name, type="hinge", axis="0 1 0", damping="0.01", armature="0.01")
        shape = {"cylinder": _v(radius, width / 2), "ellipsoid": _v(radius, radius, width / 2)}[tyre]
        self.geom(
            body,
            name,
            mass,
            type=tyre,
            size=shape,
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


def lowest_point(model: Any, data: Any, geom: int) -> float:
    """Lowest z (m) of a geom in the current pose (exact for spheres, capsules, ellipsoids,
    cylinders and boxes; the oriented bounding box otherwise)."""
    R = data.geom_xmat[geom].reshape(3, 3)
    z = data.geom_xpos[geom][2]
    size = model.geom_size[geom]
    kind = int(model.geom_type[geom])
    if kind == 2:  # sphere
        return float(z - size[0])
    if kind == 3:  # capsule
        return float(z - abs(R[2, 2]) * size[1] - size[0])
    if kind == 4:  # ellipsoid: its support along -z
        return float(z - math.sqrt(float(np.sum((size * R[2]) ** 2))))
    if kind == 5:  # cylinder
        return float(z - abs(R[2, 2]) * size[1] - size[0] * math.sqrt(max(0.0, 1 - R[2, 2] ** 2)))
    centre = data.geom_xpos[geom] + R @ model.geom_aabb[geom][:3]
    return float(centre[2] - np.abs(R[2]) @ model.geom_aabb[geom][3:])
