"""The robot registry: every module of this package that builds a robot registers its
builder with :func:`register`; :func:`load_robot` finds built-in robots here and reads a
user's MJCF/URDF robot with its adapter otherwise."""

from __future__ import annotations

import functools
import importlib
import pkgutil
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

from citygen.errors import CitygenError
from citygen.exporters.mjcf.contract import import_mujoco
from citygen.runner.robots.base import Robot, lowest_point

#: Builders of the built-in robots by name, in the order of :data:`BUILTIN`.
_BUILDERS: dict[str, Callable[[], Robot]] = {}
#: Modules of the package that hold no robot.
_INFRASTRUCTURE = frozenset({"base", "custom", "handle", "registry"})
#: The built-in robots, the everyday ones first (then any other registered robot by name).
_FIRST = ("wheeled", "quadruped", "wheeled_legged", "humanoid", "wheelchair", "scooter")


def register(name: str) -> Callable[[Callable[[], Robot]], Callable[[], Robot]]:
    """Decorator: ``builder`` (no arguments, returns a :class:`Robot` whose ``mass`` and
    ``stand_height`` :func:`load_robot` measures) is the built-in robot ``name``."""

    def wrap(builder: Callable[[], Robot]) -> Callable[[], Robot]:
        if name in _BUILDERS and _BUILDERS[name] is not builder:
            raise CitygenError(f"robot {name!r} is registered twice")
        _BUILDERS[name] = builder
        return builder

    return wrap


def _discover() -> tuple[str, ...]:
    """Import every robot module of the package; the registered names, in display order."""
    package = __name__.rpartition(".")[0]
    for info in pkgutil.iter_modules([str(Path(__file__).parent)]):
        if info.name not in _INFRASTRUCTURE and not info.name.startswith("_"):
            importlib.import_module(f"{package}.{info.name}")
    first = [n for n in _FIRST if n in _BUILDERS]
    return (*first, *sorted(n for n in _BUILDERS if n not in _FIRST))


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
    from citygen.runner.robots.custom import load_custom

    path = Path(name_or_path)
    if not path.is_file():
        raise CitygenError(
            f"unknown robot {str(name_or_path)!r}: expected one of {', '.join(BUILTIN)} or an MJCF/URDF file"
        )
    return load_custom(path, adapter)


#: The robots built in code, in display order.
BUILTIN: tuple[str, ...] = _discover()
