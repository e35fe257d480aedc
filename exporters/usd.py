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
coefficient, restitution 0.

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

import itertools
import json
import math
import os
import re
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType
from typing import Any

import manifold3d
import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.assets import Asset, Box, Capsule, ConvexMesh, Cylinder, Look, UnknownAsset, resolve
from citygen.errors import DependencyMissing, ExportError, Problem, SpecError
from citygen.exporters import ExportWarning, as_scene, lod, output_name, shared_file
from citygen.geometry.features import box_corners, feature_boxes
from citygen.geometry.terrain import DEFAULT_ROUGH_CELLS, MAX_ROUGH_CELLS, height_at, height_grid, tile_mesh
from citygen.spec.agents import Person, Vehicle
from citygen.spec.scene import Scene
from citygen.spec.surfaces import FRICTION
from citygen.spec.task import LocoTask, NavTask, TraverseTask
from citygen.spec.terrain import FlatTile, RoughTile, SlopeTile, Terrain, edge_profile

try:
    from pxr import Gf, Sdf, Usd, Vt
except ImportError:  # pragma: no cover - usd-core is a dependency of citygen
    Usd = None

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
#: Friction of asset part materials that are not ground materials (rubber sole on them).
OBJECT_FRICTION = MappingProxyType({"plastic": 0.5, "glass": 0.4, "foliage": 0.6})
#: Friction of a part material found in neither table.
DEFAULT_OBJECT_FRICTION = 0.5
#: Material and friction of ground no zone covers (as the terrain spec says).
UNZONED_MATERIAL = "concrete"
#: Most triangles of rough tiles at the default sampling; beyond it the sampling coarsens
#: (with an ExportWarning): about 50 MB of usdc.
DEFAULT_TERRAIN_TRIANGLES = 4_000_000
#: Most triangles of rough tiles at a given ``terrain_resolution``; beyond it, an ExportError.
MAX_TERRAIN_TRIANGLES = 16_000_000
#: Semantic class of ground no zone covers, and of mesh-file objects (the spec gives none).
GROUND_CLASS, MESH_CLASS = "ground", "object"
#: Gravity (m/s^2) of the physics scene.
GRAVITY = 9.81

FORMATS = ("usda", "usdc")
_OPTIONS = ("name", "terrain_resolution", "mesh_dir")
_INVALID = re.compile(r"[^A-Za-z0-9_]")
_temp_counter = itertools.count()


# --- authoring at the Sdf level (fast: no composition while writing) --------------------


def _need_pxr() -> None:
    if Usd is None:  # pragma: no cover
        raise DependencyMissing("usd-core", "USD export")


def prim_names(ids: Iterable[str]) -> list[str]:
    """Valid, unique USD prim names for ``ids`` in order: characters other than letters,
    digits and ``_`` become ``_``, a leading digit gets a ``_`` before it, and a name
    already taken gets ``_1``, ``_2`` ... after it.

    >>> prim_names(["bench/0012", "road-0", "road_0", "7"])
    ['bench_0012', 'road_0', 'road_0_1', '_7']
    """
    used: set[str] = set()
    out = []
    for raw in ids:
        base = _INVALID.sub("_", raw) or "_"
        if base[0].isdigit():
            base = "_" + base
        name, n = base, 1
        while name in used:
            name, n = f"{base}_{n}", n + 1
        used.add(name)
        out.append(name)
    return out


def _new_layer(default_prim: str) -> Sdf.Layer:
    """An empty in-memory layer with the stage metadata: Z up, metres, kilograms."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    layer.defaultPrim = default_prim
    layer.pseudoRoot.SetInfo("upAxis", "Z")
    layer.pseudoRoot.SetInfo("metersPerUnit", 1.0)
    layer.pseudoRoot.SetInfo("kilogramsPerUnit", 1.0)
    return layer


def _define(parent: Sdf.Layer | Sdf.PrimSpec, name: str, type_name: str = "", kind: str = "") -> Sdf.PrimSpec:
    spec = Sdf.PrimSpec(parent, name, Sdf.SpecifierDef, type_name)
    if kind:
        spec.kind = kind
    return spec


def _apply(spec: Sdf.PrimSpec, *schemas: str) -> None:
    """Apply API schemas by name (prepended, each once, in order)."""
    items = list(spec.GetInfo("apiSchemas").prependedItems)
    items += [name for name in schemas if name not in items]
    op = Sdf.TokenListOp()
    op.prependedItems = items
    spec.SetInfo("apiSchemas", op)


def _set(
    spec: Sdf.PrimSpec, name: str, type_name, value=None, *, custom: bool = False, uniform: bool = False
) -> Sdf.AttributeSpec:
    variability = Sdf.VariabilityUniform if uniform else Sdf.VariabilityVarying
    attr = Sdf.AttributeSpec(spec, name, type_name, variability, declaresCustom=custom)
    if value is not None:
        attr.default = value
    return attr


def _xform(spec: Sdf.PrimSpec, translate: Sequence[float], yaw: float = 0.0, scale=None) -> None:
    """xformOps translate (m), rotateZ (``yaw`` in radians, written in degrees), scale."""
    t = Sdf.ValueTypeNames
    order = ["xformOp:translate"]
    _set(spec, "xformOp:translate", t.Double3, Gf.Vec3d(*map(float, translate)))
    if yaw:
        order.append("xformOp:rotateZ")
        _set(spec, "xformOp:rotateZ", t.Double, math.degrees(yaw))
    if scale is not None:
        order.append("xformOp:scale")
        _set(spec, "xformOp:scale", t.Double3, Gf.Vec3d(*map(float, scale)))
    _set(spec, "xformOpOrder", t.TokenArray, order, uniform=True)


def _label(spec: Sdf.PrimSpec, semantic_class: str) -> None:
    """The semantic class as both Isaac Sim schemas have it."""
    t = Sdf.ValueTypeNames
    _apply(spec, "SemanticsLabelsAPI:class", "SemanticsAPI:Semantics")
    _set(spec, "semantics:labels:class", t.TokenArray, [semantic_class])
    _set(spec, "semantic:Semantics:params:semanticType", t.String, "class")
    _set(spec, "semantic:Semantics:params:semanticData", t.String, semantic_class)


def semantic_class(prim: Usd.Prim) -> str | None:
    """The class label of a prim as this exporter writes it (``semantics:labels:class``),
    else ``semantic:Semantics:params:semanticData``; None without either."""
    labels = prim.GetAttribute("semantics:labels:class")
    if labels and labels.Get():
        return str(labels.Get()[0])
    data = prim.GetAttribute("semantic:Semantics:params:semanticData")
    return str(data.Get()) if data and data.Get() is not None else None


def _material(parent: Sdf.PrimSpec, name: str, rgba: Sequence[float], mu: float) -> Sdf.Path:
    """A UsdPreviewSurface material of colour ``rgba`` with friction ``mu`` (static and dynamic)."""
    t = Sdf.ValueTypeNames
    mat = _define(parent, name, "Material")
    _apply(mat, "PhysicsMaterialAPI")
    _set(mat, "physics:staticFriction", t.Float, float(mu))
    _set(mat, "physics:dynamicFriction", t.Float, float(mu))
    _set(mat, "physics:restitution", t.Float, 0.0)
    shader = _define(mat, "Surface", "Shader")
    _set(shader, "info:id", t.Token, "UsdPreviewSurface", uniform=True)
    _set(shader, "inputs:diffuseColor", t.Color3f, Gf.Vec3f(*map(float, rgba[:3])))
    _set(shader, "inputs:roughness", t.Float, 0.8)
    if len(rgba) > 3 and rgba[3] < 1.0:
        _set(shader, "inputs:opacity", t.Float, float(rgba[3]))
    _set(shader, "outputs:surface", t.Token)
    out = _set(mat, "outputs:surface", t.Token)
    out.connectionPathList.explicitItems = [shader.path.AppendProperty("outputs:surface")]
    return mat.path


def _bind(spec: Sdf.PrimSpec, material: Sdf.Path) -> None:
    """Bind ``material`` for every purpose and, explicitly, for physics."""
    _apply(spec, "MaterialBindingAPI")
    for name in ("material:binding", "material:binding:physics"):
        rel = Sdf.RelationshipSpec(spec, name, custom=False)
        rel.targetPathList.explicitItems = [material]
    rel.SetInfo("bindMaterialAs", "weakerThanDescendants")


def _collider(spec: Sdf.PrimSpec, approximation: str | None = None) -> None:
    _apply(spec, "PhysicsCollisionAPI")
    if approximation is not None:
        _apply(spec, "PhysicsMeshCollisionAPI")
        _set(spec, "physics:approximation", Sdf.ValueTypeNames.Token, approximation, uniform=True)


def _extent(spec: Sdf.PrimSpec, lo: Sequence[float], hi: Sequence[float]) -> None:
    value = Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))])
    _set(spec, "extent", Sdf.ValueTypeNames.Float3Array, value)


def _mesh(parent: Sdf.PrimSpec, name: str, verts: np.ndarray, faces: np.ndarray) -> Sdf.PrimSpec:
    """A triangle Mesh prim (points in metres, float32)."""
    t = Sdf.ValueTypeNames
    spec = _define(parent, name, "Mesh")
    pts = np.ascontiguousarray(verts, dtype=np.float32)
    _set(spec, "points", t.Point3fArray, Vt.Vec3fArray.FromNumpy(pts))
    _set(spec, "faceVertexCounts", t.IntArray, Vt.IntArray.FromNumpy(np.full(len(faces), 3, dtype=np.int32)))
    indices = np.ascontiguousarray(faces, dtype=np.int32).ravel()
    _set(spec, "faceVertexIndices", t.IntArray, Vt.IntArray.FromNumpy(indices))
    _set(spec, "subdivisionScheme", t.Token, "none", uniform=True)
    _extent(spec, pts.min(axis=0), pts.max(axis=0))
    return spec


def _write_layer(layer: Sdf.Layer, path: Path) -> None:
    """Export ``layer`` to ``path`` through a temporary file in the same folder (atomic)."""
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.{next(_temp_counter)}.tmp{path.suffix}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if not layer.Export(str(tmp)):
            raise ExportError(f"{path}: usd-core could not write the layer")
        os.replace(tmp, path)
    except OSError as exc:
        raise ExportError(f"{path}: cannot write: {exc.strerror or type(exc).__name__}") from None
    finally:
        tmp.unlink(missing_ok=True)


def _layer_bytes(layer: Sdf.Layer, fmt: str, scratch: Path) -> bytes:
    """The bytes of ``layer`` as a ``fmt`` file (usdc needs a trip through a file)."""
    if fmt == "usda":
        return layer.ExportToString().encode("utf-8")
    tmp = scratch / f".layer.{os.getpid()}.{next(_temp_counter)}.tmp.usdc"
    try:
        scratch.mkdir(parents=True, exist_ok=True)
        if not layer.Export(str(tmp)):
            raise ExportError(f"{tmp}: usd-core could not write the layer")
        return tmp.read_bytes()
    except OSError as exc:
        raise ExportError(f"{scratch}: cannot write: {exc.strerror or type(exc).__name__}") from None
    finally:
        tmp.unlink(missing_ok=True)


# --- asset layers ---------------------------------------------------------------------


def _part_friction(look: Look) -> float:
    return FRICTION.get(look.name, OBJECT_FRICTION.get(look.name, DEFAULT_OBJECT_FRICTION))


def _author_part(parent: Sdf.PrimSpec, name: str, part) -> Sdf.PrimSpec:
    """One convex part as a gprim in the asset frame, with its collision API."""
    t = Sdf.ValueTypeNames
    if isinstance(part, Box):
        spec = _define(parent, name, "Cube")
        _set(spec, "size", t.Double, 1.0)
        _extent(spec, (-0.5,) * 3, (0.5,) * 3)
        _xform(spec, part.pos, part.yaw, part.size)
    elif isinstance(part, ConvexMesh):
        hull = part.to_trimesh()
        spec = _mesh(parent, name, hull.vertices, hull.faces)
        _collider(spec, "convexHull")
        return spec
    elif isinstance(part, Capsule) and part.length == 0:
        spec = _define(parent, name, "Sphere")
        r = part.radius
        _set(spec, "radius", t.Double, r)
        _extent(spec, (-r,) * 3, (r,) * 3)
        _xform(spec, part.pos)
    elif isinstance(part, Cylinder | Capsule):
        capsule = isinstance(part, Capsule)
        spec = _define(parent, name, "Capsule" if capsule else "Cylinder")
        r = part.radius
        h = part.length if capsule else part.height
        _set(spec, "radius", t.Double, r)
        _set(spec, "height", t.Double, h)
        _set(spec, "axis", t.Token, "Z", uniform=True)
        top = h / 2 + (r if capsule else 0.0)
        _extent(spec, (-r, -r, -top), (r, r, top))
        _xform(spec, part.pos)
    else:  # pragma: no cover - the catalog checks part types
        raise TypeError(f"unknown part type {type(part).__name__}")
    _collider(spec)
    return spec


def _asset_root(layer: Sdf.Layer, name: str, asset: str, semantic: str) -> Sdf.PrimSpec:
    root = _define(layer, name, "Xform", kind="component")
    _set(root, "citygen:asset", Sdf.ValueTypeNames.String, asset, custom=True)
    _label(root, semantic)
    return root


def _asset_layer(asset: Asset) -> Sdf.Layer:
    """The asset as a layer of its own: parts, materials, semantics (see the module doc)."""
    (name,) = prim_names([asset.id])
    layer = _new_layer(name)
    with Sdf.ChangeBlock():
        root = _asset_root(layer, name, asset.id, asset.semantic_class)
        looks: list[Look] = []
        for part in asset.parts:
            if part.material not in looks:
                looks.append(part.material)
        scope = _define(root, "Looks", "Scope")
        names = prim_names(f"m{k}_{look.name}" for k, look in enumerate(looks))
        materials = [
            _material(scope, n, look.rgba, _part_friction(look)) for n, look in zip(names, looks, strict=True)
        ]
        for k, part in enumerate(asset.parts):
            _bind(_author_part(root, f"part_{k:02d}", part), materials[looks.index(part.material)])
    return layer


def _mesh_asset_layer(asset: str, file: Path) -> Sdf.Layer:
    """A mesh file beside the scene as an asset layer: its triangles (metres, Z up)."""
    import trimesh

    try:
        mesh = trimesh.load(file, force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise ExportError(f"{file}: cannot read the mesh ({type(exc).__name__})") from None
    if len(mesh.faces) == 0:
        raise ExportError(f"{file}: expected a mesh with triangles, found none")
    (name,) = prim_names([Path(asset).stem])
    layer = _new_layer(name)
    with Sdf.ChangeBlock():
        root = _asset_root(layer, name, asset, MESH_CLASS)
        material = _material(_define(root, "Looks", "Scope"), "m0", (0.6, 0.6, 0.6), FRICTION["concrete"])
        spec = _mesh(root, "mesh", mesh.vertices, mesh.faces)
        _collider(spec, "none")
        _bind(spec, material)
    return layer


def _mesh_file(scene_file: str | None, mesh_dir: Path | None, index: int, asset: str) -> Path:
    where = f"$.placements[{index}].asset"

    def fail(expected: str, found: str) -> SpecError:
        return SpecError([Problem(where, expected, found)], file=scene_file)

    if mesh_dir is None:
        raise fail("a catalog asset id when the scene is not a file (or pass mesh_dir=)", repr(asset))
    base = mesh_dir.resolve()
    file = (base / asset).resolve()
    if not file.is_relative_to(base):
        raise fail("a mesh file inside the scene's folder", repr(asset))
    if not file.is_file():
        raise fail("an existing mesh file", f"no file {asset!r} in {base}")
    return file


def _asset_files(
    scene: Scene, scene_file: str | None, mesh_dir: Path | None, out_dir: Path, fmt: str
) -> dict[str, Path]:
    """Each distinct asset's shared layer file, by asset reference (first use order)."""
    files: dict[str, Path] = {}
    for i, pl in enumerate(scene.placements):
        if pl.asset in files:
            continue
        if pl.is_mesh:
            layer = _mesh_asset_layer(pl.asset, _mesh_file(scene_file, mesh_dir, i, pl.asset))
        else:
            try:
                layer = _asset_layer(resolve(pl.asset))
            except UnknownAsset as exc:
                where = f"$.placements[{i}].asset"
                raise SpecError([Problem(where, exc.expected, repr(pl.asset))], file=scene_file) from None
        data = _layer_bytes(layer, fmt, out_dir / "assets")
        try:
            files[pl.asset] = shared_file(out_dir, data, f".{fmt}")
        except OSError as exc:
            why = exc.strerror or type(exc).__name__
            raise ExportError(f"{out_dir / 'assets'}: cannot write: {why}") from None
    return files


# --- ground ---------------------------------------------------------------------------


@dataclass(frozen=True)
class _Grid:
    """Which tiles leave their ground to the zones (flat, no material of their own), and where."""

    terrain: Terrain
    flat: np.ndarray
    """``(rows, cols)`` bool: the zones carry this tile's ground."""
    height: np.ndarray
    """``(rows, cols)`` height (m) of flat tiles."""

    @property
    def rect(self) -> tuple[float, float, float, float]:
        t = self.terrain
        (ox, oy), s = t.origin, t.tile_size
        return ox, oy, ox + t.cols * s, oy + t.rows * s


def _level(tile) -> bool:
    """Whether a tile is level ground at its height with no material of its own (the zones
    then carry its ground)."""
    level = (
        isinstance(tile, FlatTile)
        or (isinstance(tile, SlopeTile) and tile.angle == 0.0)
        or (isinstance(tile, RoughTile) and tile.amplitude == 0.0)
    )
    return level and not _own_surface(tile)


def _own_surface(tile) -> bool:
    return tile.material is not None or tile.friction is not None


def _grid(terrain: Terrain | None) -> _Grid | None:
    if terrain is None:
        return None
    flat = np.array([_level(t) for t in terrain.tiles]).reshape(terrain.rows, terrain.cols)
    height = np.array([t.height for t in terrain.tiles], dtype=np.float64).reshape(terrain.rows, terrain.cols)
    return _Grid(terrain, flat, height)


def _cells_hit(grid: _Grid, mask: np.ndarray, r0: int, c0: int, poly) -> Any:
    """The union of the cells where ``mask`` (a window at row ``r0``, column ``c0``) is True
    that meet the (prepared) ``poly``; None when none does."""
    t = grid.terrain
    (ox, oy), s = t.origin, t.tile_size
    rows, cols = np.nonzero(mask)
    rows, cols = rows + r0, cols + c0
    boxes = shapely.box(ox + cols * s, oy + rows * s, ox + (cols + 1) * s, oy + (rows + 1) * s)
    boxes = boxes[shapely.intersects(poly, boxes)]
    return shapely.coverage_union_all(boxes) if len(boxes) else None


def _flat_pieces(poly, grid: _Grid | None) -> list[tuple[float, Any]]:
    """``poly`` cut into the parts lying on flat ground, each with that ground's height (m):
    the cells of tiles the terrain mesh carries are cut out, the rest is split by level."""
    if poly.is_empty:
        return []
    if grid is None:
        return [(0.0, poly)]
    t = grid.terrain
    (ox, oy), s = t.origin, t.tile_size
    gx0, gy0, gx1, gy1 = grid.rect
    minx, miny, maxx, maxy = poly.bounds
    if maxx <= gx0 or minx >= gx1 or maxy <= gy0 or miny >= gy1:
        return [(0.0, poly)]
    c0 = min(max(math.floor((minx - ox) / s), 0), t.cols - 1)
    c1 = min(max(math.ceil((maxx - ox) / s) - 1, c0), t.cols - 1)
    r0 = min(max(math.floor((miny - oy) / s), 0), t.rows - 1)
    r1 = min(max(math.ceil((maxy - oy) / s) - 1, r0), t.rows - 1)
    flat = grid.flat[r0 : r1 + 1, c0 : c1 + 1]
    heights = grid.height[r0 : r1 + 1, c0 : c1 + 1]
    inside = minx >= gx0 and maxx <= gx1 and miny >= gy0 and maxy <= gy1
    levels = np.unique(heights[flat]).tolist()
    if not inside and 0.0 not in levels:
        levels.append(0.0)
    shapely.prepare(poly)
    rest = poly
    if not flat.all():
        cut = _cells_hit(grid, ~flat, r0, c0, poly)
        rest = poly if cut is None else shapely.difference(poly, cut)
    if len(levels) <= 1:
        return [(levels[0], rest)] if levels else []
    shapely.prepare(rest)
    out = []
    if not inside:
        out.append((0.0, shapely.difference(rest, shapely.box(gx0, gy0, gx1, gy1))))
    for h in sorted(set(heights[flat].tolist())):
        region = _cells_hit(grid, flat & (heights == h), r0, c0, rest)
        if region is not None:
            out.append((h, shapely.intersection(rest, region)))
    return out


def _triangulate(pieces: Sequence[tuple[float, Any]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Triangles (counter-clockwise from above) of polygons lying at the given heights (m):
    ``(vertices, faces, piece index of each face)``."""
    geoms = [g for _, g in pieces]
    parts, owner = shapely.get_parts(geoms, return_index=True)
    keep = shapely.get_type_id(parts) == 3  # polygons only (a cut may leave lines or points)
    parts, owner = parts[keep], owner[keep]
    keep = shapely.area(parts) > 1e-9
    parts = shapely.orient_polygons(shapely.remove_repeated_points(parts[keep], 1e-9))
    owner = owner[keep]
    rings, ring_owner = shapely.get_rings(parts, return_index=True)
    sizes = shapely.get_num_coordinates(rings)
    xy = shapely.get_coordinates(rings)
    ends = np.cumsum(sizes)
    starts = ends - sizes
    z = np.array([h for h, _ in pieces], dtype=np.float64)
    verts, faces, face_owner, count = [], [], [], 0
    first = np.searchsorted(ring_owner, np.arange(len(parts)))
    last = np.searchsorted(ring_owner, np.arange(len(parts)), side="right")
    for k in range(len(parts)):
        loops = [xy[starts[r] : ends[r] - 1] for r in range(first[k], last[k])]
        tris = np.asarray(manifold3d.triangulate(loops), dtype=np.int64).reshape(-1, 3)
        if not len(tris):
            continue
        points = np.empty((sum(len(loop) for loop in loops), 3))
        points[:, :2] = np.concatenate(loops)
        points[:, 2] = z[owner[k]]
        verts.append(points)
        faces.append(tris + count)
        face_owner.append(np.full(len(tris), owner[k]))
        count += len(points)
    if not faces:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64)
    return np.concatenate(verts), np.concatenate(faces), np.concatenate(face_owner)


def _rough_cells(tiles: Sequence[RoughTile], s: float, resolution: float | None) -> list[int]:
    """Cells along each rough tile's side: the sampling :func:`tile_mesh` uses (same rule)."""
    if resolution is not None:
        return [int(np.clip(math.ceil(s / resolution - 1e-9), 1, MAX_ROUGH_CELLS))] * len(tiles)
    scale = np.array([t.scale for t in tiles], dtype=np.float64)
    cell = np.minimum(scale / 8.0, np.minimum(scale, s / 4.0) / 4.0)
    return np.minimum(np.ceil(s / cell - 1e-9), DEFAULT_ROUGH_CELLS).astype(int).tolist()


def _cliff(terrain: Terrain, row: int, col: int) -> bool:
    """Whether the tile is on the grid's edge and its edge there is not level at z = 0."""
    tile = terrain.tile(row, col)
    sides = []
    if row == terrain.rows - 1:
        sides.append("north")
    if col == terrain.cols - 1:
        sides.append("east")
    if row == 0:
        sides.append("south")
    if col == 0:
        sides.append("west")
    return any(edge_profile(tile, side, terrain.tile_size) != ("level", 0.0) for side in sides)


def _rough_surfaces(terrain: Terrain, ids: np.ndarray, cells: int) -> tuple[np.ndarray, np.ndarray]:
    """Surfaces of rough tiles ``ids`` (all sampled ``cells`` x ``cells``), heights from
    height_at (through height_grid: the same numbers, the noise computed per axis)."""
    s, (ox, oy) = terrain.tile_size, terrain.origin
    g = np.linspace(0.0, s, cells + 1)
    k = cells + 1
    x0 = ox + (ids % terrain.cols) * s
    y0 = oy + (ids // terrain.cols) * s
    zs = height_grid(terrain, x0[:, None] + g[None, :], y0[:, None] + g[None, :])
    xs = x0[:, None, None] + g[None, None, :]
    ys = y0[:, None, None] + g[None, :, None]
    xs, ys = np.broadcast_arrays(xs, ys)
    verts = np.stack([xs, ys, zs], axis=-1).reshape(-1, 3)
    idx = np.arange(k * k).reshape(k, k)
    a, b, c, d = (q.ravel() for q in (idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]))
    one = np.concatenate([np.c_[a, b, c], np.c_[a, c, d]])
    faces = (one[None, :, :] + (np.arange(len(ids)) * k * k)[:, None, None]).reshape(-1, 3)
    return verts, faces


@dataclass
class _MeshParts:
    """Triangles gathered for one mesh, with a material key per face."""

    verts: list[np.ndarray]
    faces: list[np.ndarray]
    keys: list[np.ndarray]
    count: int = 0

    def add(self, verts: np.ndarray, faces: np.ndarray, keys: np.ndarray) -> None:
        self.verts.append(verts)
        self.faces.append(faces + self.count)
        self.keys.append(keys)
        self.count += len(verts)


def _surface(material: str | None, friction: float | None, fallback: tuple[str, float]) -> tuple[str, float]:
    """A (material, friction) from optional overrides over a fallback."""
    if material is None:
        name, mu = fallback
        return name, friction if friction is not None else mu
    return material, friction if friction is not None else FRICTION[material]


def _tile_zones(
    terrain: Terrain, ids: np.ndarray, polys: list[Polygon], tree: shapely.STRtree, mus: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """For tiles ``ids``: the zone covering most of each (lowest index on a tie; -1 for
    none), and whether grounds of different friction (zones, or no zone) share the tile."""
    s, (ox, oy), cols = terrain.tile_size, terrain.origin, terrain.cols
    x, y = ox + (ids % cols) * s, oy + (ids // cols) * s
    boxes = shapely.box(x, y, x + s, y + s)
    zone = np.full(len(ids), -1, dtype=np.int64)
    mixed = np.zeros(len(ids), dtype=bool)
    if not polys or not len(ids):
        return zone, mixed
    inside, holder = tree.query(boxes, predicate="within")
    zone[inside] = holder  # zones never overlap: at most one holds a tile
    tiles, zones = tree.query(boxes, predicate="intersects")
    straddle = zone[tiles] < 0
    tiles, zones = tiles[straddle], zones[straddle]
    if len(tiles):
        area = shapely.area(shapely.intersection(boxes[tiles], np.asarray(polys, dtype=object)[zones]))
        touch = area > 1e-9
        tiles, zones, area = tiles[touch], zones[touch], area[touch]
        order = np.lexsort((zones, -area, tiles))
        tiles, zones = tiles[order], zones[order]
        first = np.r_[True, tiles[1:] != tiles[:-1]]
        zone[tiles[first]] = zones[first]
        differs = mus[zones] != mus[zone[tiles]]
        mixed[np.unique(tiles[differs])] = True
        # Ground no zone covers has concrete's friction.
        covered = np.bincount(tiles, weights=area, minlength=len(ids))
        bare = np.flatnonzero((covered < s * s - 1e-9) & (zone >= 0))
        mixed[bare[mus[zone[bare]] != FRICTION[UNZONED_MATERIAL]]] = True
    return zone, mixed


class _Ground:
    """Collects the ground's meshes and the materials they use."""

    def __init__(self) -> None:
        self.materials: dict[tuple[str, float], int] = {}

    def key(self, surface: tuple[str, float]) -> int:
        return self.materials.setdefault((surface[0], round(float(surface[1]), 6)), len(self.materials))


def _terrain_parts(
    scene: Scene,
    grid: _Grid,
    polys: list[Polygon],
    tree: shapely.STRtree,
    ground: _Ground,
    resolution: float | None,
    floor: float,
) -> dict[str, _MeshParts]:
    """The terrain tiles the zones do not carry, as meshes grouped by the class of their zone."""
    terrain = grid.terrain
    s, cols = terrain.tile_size, terrain.cols
    n = len(terrain.tiles)
    rows_i, cols_i = np.divmod(np.arange(n), cols)
    edge = (rows_i == 0) | (rows_i == terrain.rows - 1) | (cols_i == 0) | (cols_i == cols - 1)
    cliff = np.zeros(n, dtype=bool)
    for k in np.flatnonzero(edge).tolist():
        cliff[k] = _cliff(terrain, k // cols, k % cols)
    flat = grid.flat.ravel()
    ids = np.flatnonzero(~flat | cliff)
    mus = np.array([z.mu for z in scene.zones], dtype=np.float64)
    zone_of, mixed = _tile_zones(terrain, ids, polys, tree, mus)
    own = np.array([_own_surface(terrain.tiles[k]) for k in ids.tolist()], dtype=bool)
    lossy = np.flatnonzero(mixed & ~own & ~flat[ids])
    if len(lossy):
        warnings.warn(
            ExportWarning(
                f"$.terrain.tiles[{ids[lossy[0]]}]: {len(lossy)} stair, slope or rough tile(s) lie on "
                "zones of different friction; each gets the friction of the zone covering most of it"
            ),
            stacklevel=4,
        )
    classes, keys = {}, {}
    for k, z in zip(ids.tolist(), zone_of.tolist(), strict=True):
        tile = terrain.tiles[k]
        zone = scene.zones[z] if z >= 0 else None
        fallback = (zone.surface, zone.mu) if zone else (UNZONED_MATERIAL, FRICTION[UNZONED_MATERIAL])
        classes[k] = zone.kind if zone else GROUND_CLASS
        keys[k] = ground.key(_surface(tile.material, tile.friction, fallback))
    parts: dict[str, _MeshParts] = {}

    def add(label: str, verts: np.ndarray, faces: np.ndarray, face_keys: np.ndarray) -> None:
        parts.setdefault(label, _MeshParts([], [], [])).add(verts, faces, face_keys)

    # Rough tiles inside the grid: surfaces, batched by sampling and class.
    rough = [k for k in ids.tolist() if isinstance(terrain.tiles[k], RoughTile)]
    cells = dict(zip(rough, _rough_cells([terrain.tiles[k] for k in rough], s, resolution), strict=True))
    triangles = sum(2 * c * c for c in cells.values())
    default = np.zeros(n, dtype=np.int64)
    default[rough] = list(cells.values())
    chosen = None
    if resolution is None:
        chosen = lod.fit(scene, default, DEFAULT_TERRAIN_TRIANGLES, cost=lambda c: 2 * c * c)
    if chosen is not None:
        cells = {k: int(chosen[k]) for k in rough}
        budget = f"{DEFAULT_TERRAIN_TRIANGLES:,} triangles"
        option = "terrain_resolution= (citygen export --terrain-resolution)"
        message = lod.warning("USD", scene, chosen, budget, option)
        warnings.warn(ExportWarning(message), stacklevel=4)
    elif triangles > MAX_TERRAIN_TRIANGLES:
        raise ExportError(
            f"terrain: {len(rough)} rough tiles make {triangles} triangles at this resolution, more than "
            f"{MAX_TERRAIN_TRIANGLES}; pass a coarser terrain_resolution (m), e.g. {s / 2:g}"
        )
    rough = [k for k in rough if not cliff[k]]
    groups: dict[tuple[int, str], list[int]] = {}
    for k in rough:
        groups.setdefault((cells[k], classes[k]), []).append(k)
    for c, label in sorted(groups):
        members = np.asarray(groups[c, label])
        verts, faces = _rough_surfaces(terrain, members, c)
        face_keys = np.repeat(np.array([keys[k] for k in members.tolist()]), 2 * c * c)
        add(label, verts, faces, face_keys)
    # Everything else: tile_mesh solids, built once per geometry; flat tiles the zones carry
    # (here only for their cliff walls) lose their top.
    cache: dict[tuple, tuple[np.ndarray, np.ndarray]] = {}
    for k in ids.tolist():
        tile = terrain.tiles[k]
        if isinstance(tile, RoughTile) and not cliff[k]:
            continue
        top_off = bool(flat[k])
        res = s / cells[k] if k in cells else resolution
        key = (tile.model_copy(update={"material": None, "friction": None}), top_off, res)
        if key not in cache:
            mesh = tile_mesh(tile, s, floor=floor, resolution=res)
            verts, faces = np.asarray(mesh.vertices), np.asarray(mesh.faces)
            if top_off:
                faces = faces[~(verts[faces][:, :, 2] >= tile.height - 1e-9).all(axis=1)]
            cache[key] = verts, faces
        verts, faces = cache[key]
        shift = np.array([terrain.origin[0] + (k % cols) * s, terrain.origin[1] + (k // cols) * s, 0.0])
        add(classes[k], verts + shift, faces, np.full(len(faces), keys[k]))
    # Terrain features: a closed box per part, in the class of the zone under their centre.
    for f in terrain.features or ():
        hit = tree.query(shapely.points(f.center), predicate="intersects")
        zone = scene.zones[int(hit.min())] if len(hit) else None
        fallback = (zone.surface, zone.mu) if zone else (UNZONED_MATERIAL, FRICTION[UNZONED_MATERIAL])
        key = ground.key(_surface(f.material, None, fallback))
        for part in feature_boxes(f):
            add(zone.kind if zone else GROUND_CLASS, box_corners(part), _BOX_FACES, np.full(12, key))
    return parts


#: The 12 outward triangles of a box whose corners are in :func:`box_corners`' order.
_BOX_FACES = np.array(
    [[1, 3, 0], [4, 1, 0], [0, 3, 2], [2, 4, 0], [1, 7, 3], [5, 1, 4],
     [5, 7, 1], [3, 7, 2], [6, 4, 2], [2, 7, 6], [6, 5, 4], [7, 5, 6]]
)  # fmt: skip


def _author_ground(world: Sdf.PrimSpec, scene: Scene, resolution: float | None, floor: float) -> None:
    grid = _grid(scene.terrain)
    polys = [Polygon(z.polygon, z.holes) for z in scene.zones]
    tree = shapely.STRtree(polys)
    ground = _Ground()
    # (group, name, class, vertices, faces, material key per face)
    meshes: list[tuple[str, str, str, np.ndarray, np.ndarray, np.ndarray]] = []
    # Every zone's flat pieces, then the flat ground no zone covers, triangulated at once.
    pieces, owners = [], []
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    rest = shapely.box(x0, y0, x1, y1) if x1 > x0 and y1 > y0 else Polygon()
    if polys and not rest.is_empty:
        rest = shapely.difference(rest, shapely.union_all(polys))
    for i, poly in enumerate([*polys, rest]):
        found = _flat_pieces(poly, grid)
        pieces += found
        owners += [i] * len(found)
    verts, faces, face_piece = _triangulate(pieces)
    # Pieces come in owner order and each triangle's vertices are its piece's own, so every
    # owner's faces and vertices are contiguous runs.
    face_owner = np.asarray(owners, dtype=np.int64)[face_piece]
    face_runs = np.searchsorted(face_owner, np.arange(len(polys) + 2))
    names = [*prim_names(z.id for z in scene.zones), "Unzoned"]
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
        parts = _terrain_parts(scene, grid, polys, tree, ground, resolution, floor)
        for label in sorted(parts):
            p = parts[label]
            verts, faces, keys = np.concatenate(p.verts), np.concatenate(p.faces), np.concatenate(p.keys)
            meshes.append(("Terrain", prim_names([label])[0], label, verts, faces, keys))
    # Materials in a fixed order (by name and friction).
    looks = _define(world, "Looks", "Scope")
    mats: dict[int, Sdf.Path] = {}
    surfaces = sorted(ground.materials.items())
    names = prim_names(name if FRICTION[name] == mu else f"{name}_mu{mu:.4f}" for (name, mu), _ in surfaces)
    for ((name, mu), key), prim in zip(surfaces, names, strict=True):
        mats[key] = _material(looks, prim, SURFACE_COLORS[name], mu)
    root = _define(world, "Ground", "Xform")
    groups = {"": root}
    for group in ("Zones", "Terrain"):
        if any(m[0] == group for m in meshes):
            groups[group] = _define(root, group, "Xform")
    for group, name, label, verts, faces, keys in meshes:
        spec = _mesh(groups[group], name, verts, faces)
        _collider(spec, "none")
        _label(spec, label)
        used = np.unique(keys).tolist()
        if len(used) == 1:
            _bind(spec, mats[used[0]])
            continue
        _apply(spec, "MaterialBindingAPI")
        t = Sdf.ValueTypeNames
        _set(spec, "subsetFamily:materialBind:familyType", t.Token, "partition", uniform=True)
        for key in used:
            subset = _define(spec, mats[key].name, "GeomSubset")
            _set(subset, "elementType", t.Token, "face", uniform=True)
            _set(subset, "familyName", t.Token, "materialBind", uniform=True)
            indices = np.flatnonzero(keys == key).astype(np.int32)
            _set(subset, "indices", t.IntArray, Vt.IntArray.FromNumpy(indices))
            _bind(subset, mats[key])


# --- roads, objects, agents, task -----------------------------------------------------


def _author_roads(world: Sdf.PrimSpec, scene: Scene) -> None:
    if not scene.blocks:
        return
    t = Sdf.ValueTypeNames
    roads = _define(world, "Roads", "Xform")
    for block, name in zip(scene.blocks, prim_names(b.id for b in scene.blocks), strict=True):
        spec = _define(roads, name, "Xform")
        _xform(spec, (*block.pose.position, 0.0), block.pose.yaw)
        _set(spec, "citygen:id", t.String, block.id, custom=True)
        _set(spec, "citygen:kind", t.Token, block.kind, custom=True)
        _set(spec, "citygen:lanes", t.Int, block.lanes, custom=True)
        _set(spec, "citygen:laneWidth", t.Double, block.lane_width, custom=True)
        text = json.dumps(block.model_dump(mode="json"), sort_keys=True, separators=(",", ":"))
        _set(spec, "citygen:json", t.String, text, custom=True)


def _author_objects(world: Sdf.PrimSpec, scene: Scene, refs: dict[str, str]) -> None:
    """Instanceable Xforms, each referencing its asset's layer."""
    if not scene.placements:
        return
    objects = _define(world, "Objects", "Xform", kind="group")
    for pl, name in zip(scene.placements, prim_names(p.id for p in scene.placements), strict=True):
        spec = _define(objects, name, "Xform")
        spec.instanceable = True
        spec.referenceList.Prepend(Sdf.Reference(refs[pl.asset]))
        _set(spec, "citygen:id", Sdf.ValueTypeNames.String, pl.id, custom=True)
        _xform(spec, pl.position, pl.yaw, None if pl.scale == 1.0 else (pl.scale,) * 3)


def _ground_point(scene: Scene, xy: Sequence[float]) -> Gf.Vec3d:
    """``[x, y]`` on the ground: z from :func:`height_at` (m)."""
    return Gf.Vec3d(float(xy[0]), float(xy[1]), float(height_at(scene, xy[0], xy[1])))


def _author_agents(world: Sdf.PrimSpec, scene: Scene) -> None:
    if not scene.agents:
        return
    t = Sdf.ValueTypeNames
    agents = _define(world, "Agents", "Xform")
    for agent, name in zip(scene.agents, prim_names(a.id for a in scene.agents), strict=True):
        start, goal = _ground_point(scene, agent.start), _ground_point(scene, agent.goal)
        heading = math.atan2(goal[1] - start[1], goal[0] - start[0]) if goal != start else 0.0
        spec = _define(agents, name, "Xform")
        _xform(spec, start, heading)
        _set(spec, "citygen:id", t.String, agent.id, custom=True)
        _set(spec, "citygen:kind", t.Token, agent.kind, custom=True)
        _set(spec, "citygen:start", t.Point3d, start, custom=True)
        _set(spec, "citygen:goal", t.Point3d, goal, custom=True)
        _set(spec, "citygen:speed", t.Double, agent.speed, custom=True)
        if isinstance(agent, Person):
            _set(spec, "citygen:radius", t.Double, agent.radius, custom=True)
        elif isinstance(agent, Vehicle):
            _set(spec, "citygen:length", t.Double, agent.length, custom=True)
            _set(spec, "citygen:width", t.Double, agent.width, custom=True)
            _set(spec, "citygen:route", t.StringArray, list(agent.route), custom=True)


def _author_signals(world: Sdf.PrimSpec, scene: Scene) -> None:
    if not scene.signals:
        return
    t = Sdf.ValueTypeNames
    signals = _define(world, "Signals", "Xform")
    for signal, name in zip(scene.signals, prim_names(s.id for s in scene.signals), strict=True):
        spec = _define(signals, name, "Xform")
        _label(spec, "traffic_signal")
        _set(spec, "citygen:id", t.String, signal.id, custom=True)
        _set(spec, "citygen:junction", t.String, signal.junction, custom=True)
        _set(spec, "citygen:cycle", t.Double, signal.cycle, custom=True)
        _set(spec, "citygen:offset", t.Double, signal.offset, custom=True)
        for k, head in enumerate(signal.heads):
            h = _define(spec, f"Head_{k}", "Xform")
            _xform(h, _ground_point(scene, head.position), head.yaw)
            _label(h, "traffic_light")
        for phase, pname in zip(signal.phases, prim_names(p.id for p in signal.phases), strict=True):
            p = _define(spec, f"Phase_{pname}", "Scope")
            _set(p, "citygen:id", t.String, phase.id, custom=True)
            _set(p, "citygen:lanes", t.StringArray, list(phase.lanes), custom=True)
            _set(p, "citygen:crosswalks", t.StringArray, list(phase.crosswalks), custom=True)
            _set(p, "citygen:times", t.Double3, Gf.Vec3d(phase.green, phase.amber, phase.red), custom=True)


def _author_task(world: Sdf.PrimSpec, scene: Scene) -> None:
    task = scene.task
    if task is None:
        return
    t = Sdf.ValueTypeNames
    spec = _define(world, "Task", "Xform")
    _set(spec, "citygen:kind", t.Token, task.kind, custom=True)
    _set(spec, "citygen:robot", t.Token, task.robot, custom=True)
    _set(spec, "citygen:timeLimit", t.Double, task.time_limit, custom=True)
    _xform(_define(spec, "Start", "Xform"), _ground_point(scene, task.start.position), task.start.yaw)
    goal = None
    if isinstance(task, NavTask):
        goal = task.goal
        _set(spec, "citygen:goalTolerance", t.Double, task.goal_tolerance, custom=True)
    elif isinstance(task, TraverseTask):
        goal = task.route[-1]
        _set(spec, "citygen:goalTolerance", t.Double, task.goal_tolerance, custom=True)
        route = [_ground_point(scene, p) for p in task.route]
        _set(spec, "citygen:route", t.Point3dArray, route, custom=True)
    elif isinstance(task, LocoTask):
        _set(spec, "citygen:command", t.Double3, Gf.Vec3d(*task.command), custom=True)
    if goal is not None:
        _xform(_define(spec, "Goal", "Xform"), _ground_point(scene, goal))


# --- public API -----------------------------------------------------------------------


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
    _need_pxr()
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

    assets = _asset_files(model, scene_file, None if mesh_dir is None else Path(mesh_dir), out, format)
    refs = {asset: f"./{file.relative_to(out).as_posix()}" for asset, file in assets.items()}
    layer = _new_layer("World")
    layer.customLayerData = _layer_data(model)
    with Sdf.ChangeBlock():
        world = _define(layer, "World", "Xform", kind="assembly")
        physics = _define(world, "PhysicsScene", "PhysicsScene")
        _set(physics, "physics:gravityDirection", Sdf.ValueTypeNames.Vector3f, Gf.Vec3f(0.0, 0.0, -1.0))
        _set(physics, "physics:gravityMagnitude", Sdf.ValueTypeNames.Float, GRAVITY)
        _author_ground(world, model, resolution, floor=-1.0)  # type: ignore[arg-type]
        _author_roads(world, model)
        _author_objects(world, model, refs)
        _author_agents(world, model)
        _author_signals(world, model)
        _author_task(world, model)
    path = out / f"{name}.{format}"
    _write_layer(layer, path)
    return [path, *sorted(set(assets.values()))]


def check(path: str | Path, *, warnings: bool = False) -> list[str]:
    """Run every validator usd-core registers (``UsdValidation``: stage metadata, composition,
    geometry, shading, physics colliders, rigid bodies, joints ...) over the stage at
    ``path``; returns one line per error (and per warning with ``warnings=True``), sorted:
    ``"<name>: <message>"``. An empty list means the stage passed. Without UsdValidation
    (usd-core before 25.02) the older ``UsdUtils.ComplianceChecker`` runs instead.
    """
    _need_pxr()
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


__all__ = ["FORMATS", "SURFACE_COLORS", "check", "export", "prim_names", "semantic_class"]
