"""The whole MJCF model put together (:func:`assemble`): compiler, size, visual settings,
the default classes that set every geom's contact bits, then the ground, the zones' solids,
the objects, the agents (mocap bodies), signals, task sites and custom entries, a light and
two cameras."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from types import MappingProxyType

import numpy as np

from citygen.exporters.mjcf.builder import Builder
from citygen.exporters.mjcf.contract import AGENT_BIT, MJCF, STATIC_BIT, MJCFTree, arena_mb
from citygen.exporters.mjcf.ground import add_ground
from citygen.exporters.mjcf.objects import add_objects, add_solids
from citygen.exporters.mjcf.text import num, nums
from citygen.geometry.terrain import height_at
from citygen.spec.agents import Person
from citygen.spec.task import LocoTask, NavTask, TraverseTask
from citygen.spec.terrain import RoughTile, peak, rise

_AGENT_RGBA = {
    "pedestrian": (0.9, 0.1, 0.29, 1.0),
    "cyclist": (0.96, 0.51, 0.19, 1.0),
    "scooter": (0.57, 0.12, 0.71, 1.0),
    "vehicle": (0.12, 0.37, 0.82, 1.0),
}
_START_RGBA, _GOAL_RGBA = (0.04, 0.56, 0.23, 0.8), (0.82, 0.12, 0.29, 0.45)

SIGNAL_HEIGHT = 3.0
"""Height (m) of a signal head's site above the ground."""
#: Height (m) of the capsule standing for each kind of person.
PERSON_HEIGHT = MappingProxyType({"pedestrian": 1.75, "cyclist": 1.8, "scooter": 1.8})
#: Height (m) of the box standing for a vehicle.
VEHICLE_HEIGHT = 1.5
#: Widest view (m) of the orthographic top camera; wider scenes get a perspective one.
MAX_ORTHOGRAPHIC = 170.0
#: Size (px) of the offscreen buffer written into ``<visual><global>``.
OFFSCREEN = (1280, 960)


def _agents(b: Builder) -> None:
    for a in b.scene.agents:
        (x, y), (gx, gy) = a.start, a.goal
        z = float(height_at(b.scene, x, y))
        yaw = math.atan2(gy - y, gx - x) if (gx, gy) != (x, y) else 0.0
        body = ET.SubElement(
            b.world, "body", name=f"agent:{a.id}", mocap="true", pos=nums((x, y, z)), euler=nums((0, 0, yaw))
        )
        attrs = {"name": f"agent:{a.kind}:{a.id}:0", "class": "agent", "rgba": nums(_AGENT_RGBA[a.kind])}
        if isinstance(a, Person):
            height = PERSON_HEIGHT[a.kind]
            half = height / 2 - a.radius
            if half > 0:
                attrs |= {"type": "capsule", "size": nums((a.radius, half)), "pos": nums((0, 0, height / 2))}
            else:
                height = 2 * a.radius
                attrs |= {"type": "sphere", "size": num(a.radius), "pos": nums((0, 0, a.radius))}
        else:
            height = VEHICLE_HEIGHT
            attrs |= {"type": "box", "size": nums((a.length / 2, a.width / 2, height / 2))}
            attrs["pos"] = nums((0, 0, height / 2))
        ET.SubElement(body, "geom", **attrs)
        b.top = max(b.top, z + height)
        gz = float(height_at(b.scene, gx, gy))
        ET.SubElement(
            b.world, "site", name=f"agent:{a.id}:goal", pos=nums((gx, gy, gz)), size="0.1", group="4"
        )
        b.custom("numeric", f"agent:{a.id}:speed", num(a.speed))
        if getattr(a, "route", ()):
            b.custom("text", f"agent:{a.id}:route", " ".join(a.route))


def _signals(b: Builder) -> None:
    """Per signal head a site ``signal:<id>:head:<k>`` where the light hangs (facing the
    traffic it signals); per phase a hidden site ``signal:<id>:<phase>`` over the junction
    and custom entries ``signal:<id>:<phase>:times`` (green, amber, red: s),
    ``signal:<id>:<phase>:lanes`` and ``:crosswalks`` (text), ``signal:<id>:plan`` (cycle,
    offset: s)."""
    for s in b.scene.signals or ():
        heads = [h.position for h in s.heads]
        for k, h in enumerate(s.heads):
            z = float(height_at(b.scene, *h.position))
            ET.SubElement(
                b.world, "site", name=f"signal:{s.id}:head:{k}", type="box", size="0.15 0.15 0.4",
                pos=nums((*h.position, z + SIGNAL_HEIGHT)), euler=nums((0, 0, h.yaw)), rgba="0.1 0.1 0.1 1",
            )  # fmt: skip
        cx, cy = np.mean(heads, axis=0) if heads else (0.0, 0.0)
        for phase in s.phases:
            name = f"signal:{s.id}:{phase.id}"
            ET.SubElement(
                b.world, "site", name=name, pos=nums((cx, cy, SIGNAL_HEIGHT)), size="0.1", group="4"
            )
            b.custom("numeric", f"{name}:times", nums((phase.green, phase.amber, phase.red)))
            if phase.lanes:
                b.custom("text", f"{name}:lanes", " ".join(phase.lanes))
            if phase.crosswalks:
                b.custom("text", f"{name}:crosswalks", " ".join(phase.crosswalks))
        b.custom("numeric", f"signal:{s.id}:plan", nums((s.cycle, s.offset)))


def _task(b: Builder) -> None:
    task = b.scene.task
    if task is None:
        return
    (x, y), yaw = task.start.position, task.start.yaw
    z = float(height_at(b.scene, x, y))
    b.custom("text", "task:kind", task.kind)
    b.custom("text", "task:robot", task.robot)
    b.custom("numeric", "task:time_limit", num(task.time_limit))
    if isinstance(task, LocoTask):
        b.custom("numeric", "task:command", nums(task.command))
    ET.SubElement(
        b.world, "site", name="task:start", type="sphere", size="0.15", pos=nums((x, y, z + 0.15)),
        euler=nums((0, 0, yaw)), rgba=nums(_START_RGBA),
    )  # fmt: skip
    points: list[tuple[str, tuple[float, float], float]] = []
    if isinstance(task, NavTask):
        points.append(("task:goal", task.goal, task.goal_tolerance))
    elif isinstance(task, TraverseTask):
        points += [(f"task:waypoint:{k}", p, task.goal_tolerance) for k, p in enumerate(task.route)]
        points.append(("task:goal", task.route[-1], task.goal_tolerance))
    for name, (px, py), tol in points:
        pz = float(height_at(b.scene, px, py))
        ET.SubElement(
            b.world, "site", name=name, type="cylinder", size=nums((tol, 0.01)),
            pos=nums((px, py, pz + 0.01)), rgba=nums(_GOAL_RGBA),
        )  # fmt: skip


def _extent(b: Builder) -> tuple[np.ndarray, float, float]:
    """The scene's centre (m), the larger side of its rectangle (m) and its height span (m)."""
    scene, terrain = b.scene, b.scene.terrain
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    top, bottom = b.top, b.bottom
    if terrain is not None:
        s = terrain.tile_size
        ox, oy = terrain.origin
        x0, y0 = min(x0, ox), min(y0, oy)
        x1, y1 = max(x1, ox + terrain.cols * s), max(y1, oy + terrain.rows * s)
        for t in terrain.tiles:
            amp = t.amplitude if isinstance(t, RoughTile) else 0.0
            top = max(top, t.height + rise(t, s) + max(0.0, peak(t, s)) + amp)
            bottom = min(bottom, t.height + min(0.0, peak(t, s)) - amp)
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, (top + bottom) / 2])
    return centre, max(x1 - x0, y1 - y0), top - bottom


def _cameras(b: Builder, visual: ET.Element) -> None:
    centre, side, span = _extent(b)
    cx, cy, cz = centre
    fovy = 45.0
    if 1.05 * side < MAX_ORTHOGRAPHIC:
        top = {
            "projection": "orthographic",
            "fovy": num(1.05 * side),
            "pos": nums((cx, cy, cz + span / 2 + side)),
        }
    else:  # MuJoCo caps fovy, also an orthographic one's (in metres), below 180
        height = 1.05 * side / 2 / math.tan(math.radians(fovy) / 2)
        top = {"fovy": num(fovy), "pos": nums((cx, cy, cz + span / 2 + height))}
    ET.SubElement(b.world, "camera", name="top", **top)
    diag = math.hypot(side, span)
    dist = 0.6 * diag / math.tan(math.radians(fovy) / 2)
    az, el = math.radians(-125.0), math.radians(38.0)
    forward = -np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    ET.SubElement(
        b.world, "camera", name="perspective", fovy=num(fovy), pos=nums(centre - dist * forward),
        xyaxes=nums(np.concatenate([right, up])),
    )  # fmt: skip
    ET.SubElement(visual, "map", znear="0.01", zfar="50")
    ET.SubElement(b.root, "statistic", center=nums(centre), extent=num(max(diag / 2, 1.0)))


def assemble(b: Builder, name: str) -> MJCF:
    """The model named ``name``: its XML text and the asset files it names."""
    root = build_tree(b, name)
    ET.indent(root, space="  ")
    xml = ET.tostring(root, encoding="unicode") + "\n"
    return MJCF(xml, MappingProxyType(dict(sorted(b.files.items()))))


def assemble_tree(b: Builder, name: str) -> MJCFTree:
    """The model named ``name`` as an element tree, the files it names and its heightfields'
    samples as arrays (``b.binary_hfields`` is set here), for a reader in this process."""
    b.binary_hfields = True
    root = build_tree(b, name)
    return MJCFTree(root, MappingProxyType(dict(sorted(b.files.items()))), MappingProxyType(b.hfields))


def build_tree(b: Builder, name: str) -> ET.Element:
    """The model named ``name``'s root element, not indented."""
    b.root = root = ET.Element("mujoco", model=name)
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    size = ET.SubElement(root, "size")
    visual = ET.SubElement(root, "visual")
    ET.SubElement(visual, "global", offwidth=str(OFFSCREEN[0]), offheight=str(OFFSCREEN[1]))
    ET.SubElement(visual, "headlight", ambient="0.3 0.3 0.3", diffuse="0.3 0.3 0.3", specular="0 0 0")
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "material", specular="0.05", shininess="0.1")
    static = ET.SubElement(default, "default", **{"class": "static"})
    ET.SubElement(static, "geom", contype=str(STATIC_BIT), conaffinity="0", priority="1", group="0")
    agent = ET.SubElement(default, "default", **{"class": "agent"})
    ET.SubElement(agent, "geom", contype=str(AGENT_BIT), conaffinity="0", group="2")
    obj = ET.SubElement(default, "default", **{"class": "object"})
    ET.SubElement(obj, "geom", contype=str(STATIC_BIT), conaffinity="0", priority="1", group="1")
    b.asset = ET.SubElement(root, "asset")
    ET.SubElement(
        b.asset, "texture", name="sky", type="skybox", builtin="gradient", rgb1="0.55 0.7 0.88",
        rgb2="0.95 0.97 1", width="64", height="64",
    )  # fmt: skip
    b.world = ET.SubElement(root, "worldbody")
    add_ground(b)
    add_solids(b)
    add_objects(b)
    _agents(b)
    _signals(b)
    _task(b)
    centre, side, span = _extent(b)
    ET.SubElement(
        b.world, "light", name="sun", type="directional", castshadow="false", dir="0.35 0.45 -1",
        pos=nums(centre + np.array([0.0, 0.0, span + side])), diffuse="0.45 0.45 0.45", specular="0 0 0",
    )  # fmt: skip
    _cameras(b, visual)
    size.set("memory", f"{arena_mb(sum(1 for _ in b.world.iter('geom')))}M")
    if b.customs is not None:
        root.append(b.customs)
    # The statistic element belongs before the worldbody for people reading the file.
    stat = root.find("statistic")
    root.remove(stat)
    root.insert(list(root).index(b.asset), stat)
    return root
