"""A user's robot: an MJCF or URDF file plus a small adapter (TOML, JSON or a dict) naming
its base, wheels, joints and limits (see :func:`citygen.runner.robots.load_robot`)."""

from __future__ import annotations

import json
import math
import tomllib
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from citygen.errors import Problem, SpecError
from citygen.exporters.mjcf.contract import ROBOT_BIT, ROBOT_CONAFFINITY, import_mujoco
from citygen.runner.robots.base import _GRAVITY, Robot, lowest_point

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


def load_custom(path: Path, adapter: str | Path | Mapping[str, Any] | None) -> Robot:
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
