"""The stage's prims under ``/World`` (see :mod:`citygen.exporters.usd`): the ground's
meshes with their materials and labels, the zones' solids (buildings), road blocks, objects
referencing their asset layers, agents, signals and the task."""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from types import MappingProxyType

import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.exporters.solids import solids
from citygen.exporters.usd.assets import bind, define_material
from citygen.exporters.usd.sdf import (
    Gf,
    Sdf,
    Vt,
    add_label,
    apply_schemas,
    attr,
    collider,
    define,
    define_mesh,
    prim_names,
    xform,
)
from citygen.exporters.usd.terrain import (
    GROUND_CLASS,
    UNZONED_MATERIAL,
    Ground,
    flat_grid,
    flat_pieces,
    terrain_parts,
    triangulate,
)
from citygen.geometry.terrain import height_at
from citygen.spec.agents import Person, Vehicle
from citygen.spec.scene import Scene
from citygen.spec.surfaces import FRICTION
from citygen.spec.task import LocoTask, NavTask, TraverseTask

#: Colour (linear RGB in [0, 1]) of each surface material on the ground.
SURFACE_COLORS = MappingProxyType(
    {
        "asphalt": (0.22, 0.23, 0.24),
        "concrete": (0.70, 0.69, 0.66),
        "paving_stone": (0.62, 0.57, 0.50),
        "brick": (0.58, 0.30, 0.22),
        "cobblestone": (0.45, 0.43, 0.40),
        "gravel": (0.60, 0.56, 0.50),
        "grass": (0.33, 0.55, 0.22),
        "soil": (0.36, 0.27, 0.18),
        "mulch": (0.38, 0.24, 0.14),
        "sand": (0.82, 0.74, 0.55),
        "wood": (0.55, 0.40, 0.25),
        "rubber": (0.15, 0.15, 0.15),
        "metal": (0.55, 0.56, 0.58),
        "water": (0.25, 0.45, 0.65),
    }
)
#: Gravity (m/s^2) of the physics scene.
GRAVITY = 9.81


def author_ground(world: Sdf.PrimSpec, scene: Scene, resolution: float | None, floor: float) -> None:
    """``world``'s ``Looks`` (the ground's materials, by surface and friction), ``Ground``:
    each zone's flat mesh, the flat ground no zone covers and the terrain's meshes by class,
    and ``Solids``: each zone's solid (:mod:`citygen.exporters.solids`, a building extruded
    from its footprint) as one closed mesh with its zone's material; each a collider labelled
    with its class (see the module docstring of the package)."""
    grid = flat_grid(scene.terrain)
    polys = [Polygon(z.polygon, z.holes) for z in scene.zones]
    tree = shapely.STRtree(polys)
    ground = Ground()
    # (group, name, class, vertices, faces, material key per face)
    meshes: list[tuple[str, str, str, np.ndarray, np.ndarray, np.ndarray]] = []
    # Every zone's flat pieces, then the flat ground no zone covers, triangulated at once.
    pieces, owners = [], []
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    rest = shapely.box(x0, y0, x1, y1) if x1 > x0 and y1 > y0 else Polygon()
    if polys and not rest.is_empty:
        rest = shapely.difference(rest, shapely.union_all(polys))
    for i, poly in enumerate([*polys, rest]):
        found = flat_pieces(poly, grid)
        pieces += found
        owners += [i] * len(found)
    verts, faces, face_piece = triangulate(pieces)
    # Pieces come in owner order and each triangle's vertices are its piece's own, so every
    # owner's faces and vertices are contiguous runs.
    face_owner = np.asarray(owners, dtype=np.int64)[face_piece]
    face_runs = np.searchsorted(face_owner, np.arange(len(polys) + 2))
    zone_names = prim_names(z.id for z in scene.zones)
    names = [*zone_names, "Unzoned"]
    for i in range(len(polys) + 1):
        f0, f1 = face_runs[i], face_runs[i + 1]
        if f0 == f1:
            continue
        v0, v1 = faces[f0:f1].min(), faces[f0:f1].max() + 1
        local, used = faces[f0:f1] - v0, slice(v0, v1)
        if i < len(polys):
            zone = scene.zones[i]
            group, label, key = "Zones", zone.kind, ground.key((zone.surface, zone.mu))
        else:
            group, label = "", GROUND_CLASS
            key = ground.key((UNZONED_MATERIAL, FRICTION[UNZONED_MATERIAL]))
        meshes.append((group, names[i], label, verts[used], local, np.full(len(local), key)))
    if grid is not None:
        parts = terrain_parts(scene, grid, polys, tree, ground, resolution, floor)
        for label in sorted(parts):
            p = parts[label]
            verts, faces, keys = np.concatenate(p.verts), np.concatenate(p.faces), np.concatenate(p.keys)
            meshes.append(("Terrain", prim_names([label])[0], label, verts, faces, keys))
    for solid in solids(scene, polys):
        zone = solid.zone
        verts, faces = solid.mesh()
        key = ground.key((zone.surface, zone.mu))
        meshes.append(("Solids", zone_names[solid.index], zone.kind, verts, faces, np.full(len(faces), key)))
    # Materials in a fixed order (by name and friction).
    looks = define(world, "Looks", "Scope")
    mats: dict[int, Sdf.Path] = {}
    surfaces = sorted(ground.materials.items())
    names = prim_names(name if FRICTION[name] == mu else f"{name}_mu{mu:.4f}" for (name, mu), _ in surfaces)
    for ((name, mu), key), prim in zip(surfaces, names, strict=True):
        mats[key] = define_material(looks, prim, SURFACE_COLORS[name], mu)
    root = define(world, "Ground", "Xform")
    groups = {"": root}
    for group in ("Zones", "Terrain"):
        if any(m[0] == group for m in meshes):
            groups[group] = define(root, group, "Xform")
    if any(m[0] == "Solids" for m in meshes):
        groups["Solids"] = define(world, "Solids", "Xform")
    for group, name, label, verts, faces, keys in meshes:
        spec = define_mesh(groups[group], name, verts, faces)
        collider(spec, "none")
        add_label(spec, label)
        used = np.unique(keys).tolist()
        if len(used) == 1:
            bind(spec, mats[used[0]])
            continue
        apply_schemas(spec, "MaterialBindingAPI")
        t = Sdf.ValueTypeNames
        attr(spec, "subsetFamily:materialBind:familyType", t.Token, "partition", uniform=True)
        for key in used:
            subset = define(spec, mats[key].name, "GeomSubset")
            attr(subset, "elementType", t.Token, "face", uniform=True)
            attr(subset, "familyName", t.Token, "materialBind", uniform=True)
            indices = np.flatnonzero(keys == key).astype(np.int32)
            attr(subset, "indices", t.IntArray, Vt.IntArray.FromNumpy(indices))
            bind(subset, mats[key])


# --- roads, objects, agents, task -----------------------------------------------------


def author_roads(world: Sdf.PrimSpec, scene: Scene) -> None:
    if not scene.blocks:
        return
    t = Sdf.ValueTypeNames
    roads = define(world, "Roads", "Xform")
    for block, name in zip(scene.blocks, prim_names(b.id for b in scene.blocks), strict=True):
        spec = define(roads, name, "Xform")
        xform(spec, (*block.pose.position, 0.0), block.pose.yaw)
        attr(spec, "citygen:id", t.String, block.id, custom=True)
        attr(spec, "citygen:kind", t.Token, block.kind, custom=True)
        attr(spec, "citygen:lanes", t.Int, block.lanes, custom=True)
        attr(spec, "citygen:laneWidth", t.Double, block.lane_width, custom=True)
        text = json.dumps(block.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
        attr(spec, "citygen:json", t.String, text, custom=True)


def author_objects(world: Sdf.PrimSpec, scene: Scene, refs: dict[str, str]) -> None:
    """Instanceable Xforms, each referencing its asset's layer."""
    if not scene.placements:
        return
    objects = define(world, "Objects", "Xform", kind="group")
    for pl, name in zip(scene.placements, prim_names(p.id for p in scene.placements), strict=True):
        spec = define(objects, name, "Xform")
        spec.instanceable = True
        spec.referenceList.Prepend(Sdf.Reference(refs[pl.asset]))
        attr(spec, "citygen:id", Sdf.ValueTypeNames.String, pl.id, custom=True)
        xform(spec, pl.position, pl.yaw, None if pl.scale == 1.0 else (pl.scale,) * 3)


def _ground_point(scene: Scene, xy: Sequence[float]) -> Gf.Vec3d:
    """``[x, y]`` on the ground: z from :func:`height_at` (m)."""
    return Gf.Vec3d(float(xy[0]), float(xy[1]), float(height_at(scene, xy[0], xy[1])))


def author_agents(world: Sdf.PrimSpec, scene: Scene) -> None:
    if not scene.agents:
        return
    t = Sdf.ValueTypeNames
    agents = define(world, "Agents", "Xform")
    for agent, name in zip(scene.agents, prim_names(a.id for a in scene.agents), strict=True):
        start, goal = _ground_point(scene, agent.start), _ground_point(scene, agent.goal)
        heading = math.atan2(goal[1] - start[1], goal[0] - start[0]) if goal != start else 0.0
        spec = define(agents, name, "Xform")
        xform(spec, start, heading)
        attr(spec, "citygen:id", t.String, agent.id, custom=True)
        attr(spec, "citygen:kind", t.Token, agent.kind, custom=True)
        attr(spec, "citygen:start", t.Point3d, start, custom=True)
        attr(spec, "citygen:goal", t.Point3d, goal, custom=True)
        attr(spec, "citygen:speed", t.Double, agent.speed, custom=True)
        if isinstance(agent, Person):
            attr(spec, "citygen:radius", t.Double, agent.radius, custom=True)
        elif isinstance(agent, Vehicle):
            attr(spec, "citygen:length", t.Double, agent.length, custom=True)
            attr(spec, "citygen:width", t.Double, agent.width, custom=True)
            attr(spec, "citygen:route", t.StringArray, list(agent.route), custom=True)


def author_signals(world: Sdf.PrimSpec, scene: Scene) -> None:
    if not scene.signals:
        return
    t = Sdf.ValueTypeNames
    signals = define(world, "Signals", "Xform")
    for signal, name in zip(scene.signals, prim_names(s.id for s in scene.signals), strict=True):
        spec = define(signals, name, "Xform")
        add_label(spec, "traffic_signal")
        attr(spec, "citygen:id", t.String, signal.id, custom=True)
        attr(spec, "citygen:junction", t.String, signal.junction, custom=True)
        attr(spec, "citygen:cycle", t.Double, signal.cycle, custom=True)
        attr(spec, "citygen:offset", t.Double, signal.offset, custom=True)
        for k, head in enumerate(signal.heads):
            h = define(spec, f"Head_{k}", "Xform")
            xform(h, _ground_point(scene, head.position), head.yaw)
            add_label(h, "traffic_light")
        for phase, pname in zip(signal.phases, prim_names(p.id for p in signal.phases), strict=True):
            p = define(spec, f"Phase_{pname}", "Scope")
            attr(p, "citygen:id", t.String, phase.id, custom=True)
            attr(p, "citygen:lanes", t.StringArray, list(phase.lanes), custom=True)
            attr(p, "citygen:crosswalks", t.StringArray, list(phase.crosswalks), custom=True)
            attr(p, "citygen:times", t.Double3, Gf.Vec3d(phase.green, phase.amber, phase.red), custom=True)


def author_task(world: Sdf.PrimSpec, scene: Scene) -> None:
    task = scene.task
    if task is None:
        return
    t = Sdf.ValueTypeNames
    spec = define(world, "Task", "Xform")
    attr(spec, "citygen:kind", t.Token, task.kind, custom=True)
    attr(spec, "citygen:robot", t.Token, task.robot, custom=True)
    attr(spec, "citygen:timeLimit", t.Double, task.time_limit, custom=True)
    xform(define(spec, "Start", "Xform"), _ground_point(scene, task.start.position), task.start.yaw)
    goal = None
    if isinstance(task, NavTask):
        goal = task.goal
        attr(spec, "citygen:goalTolerance", t.Double, task.goal_tolerance, custom=True)
    elif isinstance(task, TraverseTask):
        goal = task.route[-1]
        attr(spec, "citygen:goalTolerance", t.Double, task.goal_tolerance, custom=True)
        route = [_ground_point(scene, p) for p in task.route]
        attr(spec, "citygen:route", t.Point3dArray, route, custom=True)
    elif isinstance(task, LocoTask):
        attr(spec, "citygen:command", t.Double3, Gf.Vec3d(*task.command), custom=True)
    if goal is not None:
        xform(define(spec, "Goal", "Xform"), _ground_point(scene, goal))
