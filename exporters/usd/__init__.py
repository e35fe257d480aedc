"""USD export: a scene as a Z-up, metre stage for Isaac Sim and any USD reader (usd-core).

``export(scene, out_dir, format="usda")`` writes ``<out_dir>/<name>.usda`` (or ``.usdc``)
and one small layer per distinct asset under ``<out_dir>/assets/``, named by the digest of
its bytes (:func:`citygen.exporters.shared_file`): the scenes of a dataset exported to one
folder share them, and every object is an instanceable reference to its asset's layer,
under a hundred bytes of usdc in the stage however many parts the asset has (10,000
objects of a 1.2 km city: 0.8 MB, where copies of their assets would take 57 MB; see
``benchmarks/bench_export.py``).

Stage (``upAxis = "Z"``, ``metersPerUnit = 1``, ``kilogramsPerUnit = 1``,
``defaultPrim = "World"``; custom layer data ``citygen:format``, ``citygen:split`` ...)::

    /World                       Xform, kind assembly
      PhysicsScene               gravity 9.81 m/s^2 along -Z
      Looks/<material>           ground materials: UsdPreviewSurface + PhysicsMaterialAPI
      Ground/Zones/<zone id>     Mesh of the zone's flat ground (see below), label = zone kind
      Ground/Unzoned             Mesh of flat ground no zone covers, label "ground"
      Ground/Terrain/<kind>      Mesh of the terrain tiles mostly in zones of that kind
                                 ("ground" outside zones), materials as GeomSubsets
      Solids/<zone id>           Mesh of a zone's solid (a building's footprint, holes cut
                                 out, extruded to its height), label = zone kind
      Roads/<block id>           Xform at the block's entry pose; citygen:kind, lanes, json
      Objects/<placement id>     Xform, instanceable, references @./assets/<digest>.usda@;
                                 xformOps translate, rotateZ (degrees), scale
      Agents/<agent id>          Xform at the start (facing the goal); citygen:kind,
                                 start, goal (points, m), radius/speed or length/width/route
      Signals/<signal id>        Xform labelled traffic_signal; citygen:junction, cycle, offset (s);
                                 Head_<k> Xforms where the lights stand (traffic_light),
                                 Phase_<id> Scopes: citygen:lanes, crosswalks, times (s)
      Task                       citygen:kind, robot, timeLimit (s), goalTolerance (m) ...
        Start, Goal              Xforms at the robot's start pose and at the goal

An asset layer holds one prim (its ``defaultPrim``, kind component) named after the
asset id (``bench_0012``) whose children are the asset's convex parts, each both what is
drawn and what collides: ``Cube`` (size 1, scaled), ``Cylinder``, ``Capsule`` or
``Sphere`` along Z, or a ``Mesh`` of the hull with ``MeshCollisionAPI`` approximation
``convexHull``; each part has ``CollisionAPI`` and its material (``Looks/m<k>_<name>``:
colour and, from :data:`~citygen.spec.surfaces.FRICTION` or :data:`OBJECT_FRICTION`,
static and dynamic friction) bound for all purposes and for ``physics``. Objects are
static colliders (no rigid body). Mesh-file placements become asset layers of their
triangle mesh (collision approximation ``none``), labelled ``object``.

**Semantics.** Every object, zone and terrain mesh carries its class twice, as Isaac Sim's
segmentation reads it: the ``UsdSemantics`` labels API (``SemanticsLabelsAPI:class``,
``token[] semantics:labels:class``, Isaac Sim 4.5+) and the older ``SemanticsAPI:Semantics``
(``semantic:Semantics:params:semanticType = "class"``, ``...:semanticData = <class>``).
Both are authored by name, so the bytes do not depend on which schemas usd-core
registers. An object's label sits on its asset's root prim and so is composed onto the
object's instance prim.

**Ground.** Zones are flat, so each zone's mesh is its polygon (holes cut out) at the
ground's height wherever that ground is level: outside the terrain grid at z = 0, on
level tiles (flat, a slope of angle 0, a rough tile of amplitude 0) at the tile's height.
Where a tile is not level or sets its own material or friction, the terrain mesh carries
the ground instead, and the zone's mesh has a hole there; so friction is exact per zone
on level ground. Slope and stair tiles (and tiles on the grid's edge that stand above or
below the ground outside it, for their walls) are
:func:`~citygen.geometry.terrain.tile_mesh` solids; rough tiles are their surfaces
sampled with :func:`~citygen.geometry.terrain.height_at` on the grid ``tile_mesh`` uses
(or every ``terrain_resolution`` metres), all rough tiles at once. A terrain tile has
its own material and friction, else those of the zone covering most of it (as the MJCF
exporter), else concrete's; an :class:`~citygen.exporters.ExportWarning` counts the
tiles where grounds of different friction meet. Every ground mesh is a triangle-mesh
collider (approximation ``none``); static friction = dynamic friction = the spec's
coefficient, restitution 0. A zone with a ``height`` (a building from its mapped footprint)
keeps its ground mesh and has a closed mesh of its solid under ``Solids``, a triangle-mesh
collider too (exact, courtyards open), with the zone's material.

The same scene and options give the same bytes, in usda and usdc: no time, user or
absolute path is written. :func:`check` runs every validator usd-core registers
(``UsdValidation``) over a written stage.

>>> import tempfile
>>> from citygen.exporters import usd
>>> with tempfile.TemporaryDirectory() as out:
...     files = usd.export("examples/street_corner.json", out)
...     print(files[0].name, len(files) - 1, "asset layers;", usd.check(files[0]))
street_corner.usda 6 asset layers; []
"""

from __future__ import annotations

import math
from pathlib import Path

from citygen.errors import ExportError
from citygen.exporters import as_scene, output_name
from citygen.exporters.usd.assets import DEFAULT_OBJECT_FRICTION, MESH_CLASS, OBJECT_FRICTION, asset_files
from citygen.exporters.usd.sdf import (
    Gf,
    Sdf,
    Usd,
    attr,
    define,
    need_pxr,
    new_layer,
    prim_names,
    semantic_class,
    write_layer,
)
from citygen.exporters.usd.stage import (
    GRAVITY,
    SURFACE_COLORS,
    author_agents,
    author_ground,
    author_objects,
    author_roads,
    author_signals,
    author_task,
)
from citygen.exporters.usd.terrain import (
    DEFAULT_TERRAIN_TRIANGLES,
    GROUND_CLASS,
    MAX_TERRAIN_TRIANGLES,
    UNZONED_MATERIAL,
)
from citygen.spec.scene import Scene

FORMATS = ("usda", "usdc")
_OPTIONS = ("name", "terrain_resolution", "mesh_dir")


def _name(scene: Scene | str | Path, options: dict[str, object]) -> str:
    return output_name(scene, options.get("name"), "usd")


def _layer_data(scene: Scene) -> dict[str, str | int]:
    data: dict[str, str | int] = {"citygen:format": scene.format}
    meta = scene.meta
    for key in ("generator", "split", "description"):
        if getattr(meta, key) is not None:
            data[f"citygen:{key}"] = getattr(meta, key)
    if meta.index is not None:
        data["citygen:index"] = meta.index
    if meta.seed is not None:
        data["citygen:seed"] = str(meta.seed)  # up to 2**64 - 1: more than a USD int holds
    return data


def export(
    scene: Scene | str | Path, out_dir: str | Path, *, format: str = "usda", **options: object
) -> list[Path]:
    """Write the scene as ``<out_dir>/<name>.<format>`` plus its asset layers; returns the
    stage's path followed by the asset layers it references (sorted).

    ``format`` is ``"usda"`` (text) or ``"usdc"`` (binary crate); asset layers use the same.
    Options: ``name`` (default: the scene file's stem, ``<split>-<index>`` from the scene's
    meta, or ``scene``); ``terrain_resolution`` (m, the largest spacing of rough-tile
    samples; default: ``tile_mesh``'s, 1/8 of the roughness wavelength or finer, coarsened
    with an :class:`~citygen.exporters.ExportWarning` where the rough tiles would exceed
    :data:`DEFAULT_TERRAIN_TRIANGLES`; a given resolution may reach
    :data:`MAX_TERRAIN_TRIANGLES`, beyond which it is an :class:`ExportError`);
    ``mesh_dir`` (the folder mesh-file placements are relative to; default: the scene
    file's folder).
    """
    need_pxr()
    if format not in FORMATS:
        raise ExportError(f"usd export: expected format 'usda' or 'usdc', got {format!r}")
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise ExportError(f"usd export: unknown option {unknown[0]!r}; expected one of {', '.join(_OPTIONS)}")
    resolution = options.get("terrain_resolution")
    if resolution is not None and (
        isinstance(resolution, bool)
        or not isinstance(resolution, int | float)
        or not 0 < resolution < math.inf
    ):
        raise ExportError(f"usd export: expected a positive terrain_resolution in metres, got {resolution!r}")
    name = _name(scene, options)
    model, folder = as_scene(scene)
    mesh_dir = options.get("mesh_dir", folder)
    scene_file = None if isinstance(scene, Scene) else str(scene)
    out = Path(out_dir)

    assets = asset_files(model, scene_file, None if mesh_dir is None else Path(mesh_dir), out, format)
    refs = {asset: f"./{file.relative_to(out).as_posix()}" for asset, file in assets.items()}
    layer = new_layer("World")
    layer.customLayerData = _layer_data(model)
    with Sdf.ChangeBlock():
        world = define(layer, "World", "Xform", kind="assembly")
        physics = define(world, "PhysicsScene", "PhysicsScene")
        attr(physics, "physics:gravityDirection", Sdf.ValueTypeNames.Vector3f, Gf.Vec3f(0.0, 0.0, -1.0))
        attr(physics, "physics:gravityMagnitude", Sdf.ValueTypeNames.Float, GRAVITY)
        author_ground(world, model, resolution, floor=-1.0)  # type: ignore[arg-type]
        author_roads(world, model)
        author_objects(world, model, refs)
        author_agents(world, model)
        author_signals(world, model)
        author_task(world, model)
    path = out / f"{name}.{format}"
    write_layer(layer, path)
    return [path, *sorted(set(assets.values()))]


def check(path: str | Path, *, warnings: bool = False) -> list[str]:
    """Run every validator usd-core registers (``UsdValidation``: stage metadata, composition,
    geometry, shading, physics colliders, rigid bodies, joints ...) over the stage at
    ``path``; returns one line per error (and per warning with ``warnings=True``), sorted:
    ``"<name>: <message>"``. An empty list means the stage passed. Without UsdValidation
    (usd-core before 25.02) the older ``UsdUtils.ComplianceChecker`` runs instead.
    """
    need_pxr()
    stage = Usd.Stage.Open(str(path))
    if stage is None:
        raise ExportError(f"{path}: usd-core cannot open this stage")
    try:
        from pxr import UsdValidation
    except ImportError:  # pragma: no cover - older usd-core
        from pxr.UsdUtils.complianceChecker import ComplianceChecker

        checker = ComplianceChecker(skipARKitRootLayerCheck=True)
        checker.CheckCompliance(str(path))
        found = list(checker.GetErrors()) + list(checker.GetFailedChecks())
        return sorted(found + (list(checker.GetWarnings()) if warnings else []))
    validators = UsdValidation.ValidationRegistry().GetOrLoadAllValidators()
    errors = UsdValidation.ValidationContext(validators).Validate(stage)
    kinds = {UsdValidation.ValidationErrorType.Error}
    if warnings:
        kinds.add(UsdValidation.ValidationErrorType.Warn)
    return sorted(f"{e.GetName()}: {e.GetMessage()}" for e in errors if e.GetType() in kinds)


__all__ = [
    "DEFAULT_OBJECT_FRICTION",
    "DEFAULT_TERRAIN_TRIANGLES",
    "FORMATS",
    "GRAVITY",
    "GROUND_CLASS",
    "MAX_TERRAIN_TRIANGLES",
    "MESH_CLASS",
    "OBJECT_FRICTION",
    "SURFACE_COLORS",
    "UNZONED_MATERIAL",
    "check",
    "export",
    "prim_names",
    "semantic_class",
]
