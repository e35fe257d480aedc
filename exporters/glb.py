"""GLB: the whole scene as one glTF 2.0 binary, for Blender, three.js and any glTF viewer.

One scene graph holds

- ``ground/terrain``: the terrain's tiles as one closed solid (:func:`terrain_mesh`, rough
  tiles meshed every :data:`RESOLUTION` metres by default), each face in the colour of the
  zone over it;
- ``ground/plane``: the flat ground at ``z = 0`` over the scene's bounds outside the
  terrain grid;
- ``zone/<id>``: each zone's ground surface, draped on the terrain and coloured by kind
  (:data:`~citygen.exporters.ZONE_COLORS`), lifted :data:`ZONE_LIFT` above it;
- ``<id>``: each placement, the asset's visual mesh (one mesh per asset, reused by every
  node that places it: glTF instancing) moved, turned and scaled by the node;
- ``agent/<id>`` and ``agent/<id>/goal``: people as cylinders of their radius, vehicles as
  boxes along their way, coloured by kind, and a disc at each goal;
- ``task/start`` (an arrow along the start yaw), ``task/goal`` (a disc of the goal
  tolerance) and ``task/route/<k>`` (a traverse's waypoints).

Only placement nodes are named by bare ids; every other name holds a ``/``, which ids
cannot, so names never clash. Everything hangs under one node, ``scene/root``, which turns
citygen's Z-up frame into glTF's Y-up (``y_up=False`` leaves it Z-up). Colours are vertex
colours, exact per face. Units are metres. The scene's ``extras`` keep what geometry cannot
say (agents' speeds, the task's kind, time limit and command) as the spec's own JSON, so
nothing is lost. The same scene always gives the same bytes.

>>> from citygen.exporters import glb
>>> graph = glb.build("examples/street_corner.json")
>>> "zone/crosswalk" in graph.graph.nodes and "lamp-1" in graph.graph.nodes
True
"""

from __future__ import annotations

import json
import math
import struct
import warnings
from collections.abc import Sequence
from pathlib import Path, PurePosixPath
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import manifold3d
import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.assets import Asset, UnknownAsset, resolve
from citygen.errors import ExportError
from citygen.exporters import ZONE_COLORS, ExportWarning, as_scene, lod
from citygen.exporters import output_name as shared_output_name
from citygen.geometry.terrain import (
    DEFAULT_ROUGH_CELLS,
    MAX_ROUGH_CELLS,
    height_at,
    terrain_mesh,
)
from citygen.io import write_atomic
from citygen.spec.agents import Vehicle
from citygen.spec.placements import Placement
from citygen.spec.scene import Scene
from citygen.spec.task import NavTask, TraverseTask
from citygen.spec.terrain import RoughTile, SlopeTile, StairTile

if TYPE_CHECKING:  # trimesh is imported where a mesh is made: the occupancy map and the runner
    import trimesh  # use this module's scene helpers and never need it

RGBA = tuple[float, float, float, float]

#: Height (m) of zone surfaces above the ground they cover, so they never z-fight with it.
ZONE_LIFT = 0.005
#: Default cell size (m) of rough tiles' meshes in pictures (GLB, HTML): fine enough to show
#: the bumps, coarse enough to keep a street's file to megabytes.
RESOLUTION = 0.1
#: Most triangles an exporter lets the terrain's mesh have, to keep memory bounded.
MAX_TERRAIN_TRIANGLES = 16_000_000
#: Colour of the terrain solid and of the flat ground outside it (RGBA in [0, 1]).
TERRAIN_RGBA: RGBA = (0.66, 0.62, 0.57, 1.0)
GROUND_RGBA: RGBA = (0.957, 0.945, 0.918, 1.0)
#: Colour of objects read from mesh files that carry no colours of their own.
MESH_RGBA: RGBA = (0.478, 0.243, 0.616, 1.0)
#: Colour of each kind of agent, and of the task's start and goal.
AGENT_COLORS = MappingProxyType(
    {"pedestrian": "#e6194b", "cyclist": "#f58231", "scooter": "#911eb4", "vehicle": "#1f5fd1"}
)
START_COLOR, GOAL_COLOR = "#0b8f3a", "#d11f4a"
#: Height (m) of the cylinder or box that stands for an agent of each kind.
AGENT_HEIGHT = MappingProxyType({"pedestrian": 1.7, "cyclist": 1.8, "scooter": 1.8, "vehicle": 1.5})
#: Thickness (m) of goal discs and of the start arrow.
MARKER_THICKNESS = 0.03

ROOT = "scene/root"
#: Z-up (citygen) to Y-up (glTF): (x, y, z) -> (x, z, -y).
Z_UP_TO_Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0], [0, -1.0, 0, 0], [0, 0, 0, 1.0]])


def rgba(colour: str | Sequence[float]) -> RGBA:
    """A ``#rrggbb`` colour (or RGBA numbers) as an RGBA tuple in [0, 1]."""
    if isinstance(colour, str):
        h = colour.lstrip("#")
        return (int(h[0:2], 16) / 255, int(h[2:4], 16) / 255, int(h[4:6], 16) / 255, 1.0)
    return tuple(float(c) for c in colour)  # type: ignore[return-value]


def zone_rgba(kind: str) -> RGBA:
    """The colour of a zone kind, the PNG map's palette."""

    return rgba(ZONE_COLORS[kind])


# --- names and options ------------------------------------------------------------------


def output_name(scene: Scene | str | Path, options: dict[str, Any], fmt: str) -> str:
    """The file stem for ``scene`` (:func:`citygen.exporters.output_name` of option ``name``)."""
    return shared_output_name(scene, options.get("name"), fmt)


def check_options(options: dict[str, Any], allowed: Sequence[str], fmt: str) -> None:
    """An :class:`ExportError` naming the first option not in ``allowed``."""
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ExportError(
            f"{fmt} export: unknown option {unknown[0]!r}; expected one of {', '.join(allowed)}"
        )


#: The ``resolution`` that lets an exporter choose (:func:`fit_terrain`).
AUTO = "auto"


def resolution_option(value: Any, fmt: str) -> float | str | None:
    """The ``resolution`` option: None, :data:`AUTO` or a positive number of metres."""
    if value is None or value == AUTO:
        return value
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not (math.isfinite(value) and value > 0)
    ):
        raise ExportError(
            f"{fmt} export: expected a positive number of metres for 'resolution', got {value!r}"
        )
    return float(value)


def rough_cells(tile: RoughTile, tile_size: float, resolution: float | None) -> int:
    """Cells along one side of a rough tile's mesh, as :func:`~citygen.geometry.terrain.tile_mesh`
    chooses them: ``tile_size / resolution`` (1 to 1024), or without a resolution, cells of
    ``scale / 8`` or a quarter of the taper band, whichever is finer (at most 256)."""
    if resolution is not None:
        return int(np.clip(math.ceil(tile_size / resolution - 1e-9), 1, MAX_ROUGH_CELLS))
    cell = min(tile.scale / 8.0, min(tile.scale, tile_size / 4.0) / 4.0)
    return min(math.ceil(tile_size / cell - 1e-9), DEFAULT_ROUGH_CELLS)


def _triangles(cells: np.ndarray, others: int) -> int:
    return int((2 * cells**2 + 12 * cells).sum()) + 200 * others


def fit_terrain(
    scene: Scene, resolution: float | str | None, fmt: str, default: float | None
) -> float | None:
    """The cell size (m) of rough tiles' meshes a format uses: ``resolution`` when given (an
    :class:`ExportError` naming a coarser one when the terrain's mesh would exceed
    :data:`MAX_TERRAIN_TRIANGLES`); for :data:`AUTO`, ``default`` where the mesh fits
    ``lod.BUDGETS[fmt]`` triangles, else the finest uniform spacing that does, with one
    :class:`ExportWarning` giving the error against ``height_at``."""
    t = scene.terrain
    auto = resolution == AUTO
    res = default if auto else resolution
    if t is None:
        return res
    rough = [x for x in t.tiles if isinstance(x, RoughTile)]
    others = len(t.tiles) - len(rough)
    cells = np.array([rough_cells(x, t.tile_size, res) for x in rough], dtype=np.int64)
    if not auto:
        if _triangles(cells, others) <= MAX_TERRAIN_TRIANGLES:
            return res
        room = MAX_TERRAIN_TRIANGLES - 200 * others
    else:
        # What the other tiles cost, closer than the hard limit's 200 each.
        fixed = _fixed_triangles(t)
        triangles = int((2 * cells**2 + 12 * cells).sum()) + fixed
        if triangles <= lod.BUDGETS[fmt]:
            return res
        room = lod.BUDGETS[fmt] - fixed
    limit = lod.BUDGETS[fmt] if auto else MAX_TERRAIN_TRIANGLES
    triangles = _triangles(cells, others)
    room = max(room, 14 * len(rough))
    cap = lod.cells_within(room, len(rough), lambda c: 2 * c * c + 12 * c)
    if not auto:
        raise ExportError(
            f"{fmt} export: the terrain's {len(cells)} rough tiles need about {triangles:,} triangles at "
            f"resolution={resolution!r}, more than {MAX_TERRAIN_TRIANGLES:,}; pass a coarser resolution, "
            f"e.g. {t.tile_size / cap:.3g} (m)"
        )
    spacing = t.tile_size / cap
    error = lod.max_error(scene, lambda x: cap if isinstance(x, RoughTile) else None)
    option = "resolution= (citygen export --terrain-resolution)"
    message = lod.describe(fmt.upper(), "rough tiles", spacing, error, f"{limit:,} triangles", option)
    warnings.warn(ExportWarning(message), stacklevel=3)
    return spacing


def _fixed_triangles(t) -> int:
    """What the terrain's tiles that are not rough cost in a mesh: a flat tile's box, a
    stair's boxes, a slope's (pyramid) faces."""
    return sum(12 * (x.step_count + 1) if isinstance(x, StairTile) else 48 if isinstance(x, SlopeTile)
               else 12 for x in t.tiles if not isinstance(x, RoughTile))  # fmt: skip


def auto_terrain(scene: Scene, fmt: str, default: float | None) -> float | np.ndarray | None:
    """The cell size (m) of rough tiles' meshes when none is asked for: ``default`` where
    the terrain's mesh fits ``lod.BUDGETS[fmt]`` triangles, else each tile's (an array
    indexed like the terrain's tiles, NaN where not rough) as :func:`lod.fit` allocates
    them, rougher tiles finer (up to tile_mesh's own sampling), with one
    :class:`ExportWarning` giving the error against ``height_at``."""
    t = scene.terrain
    if t is None:
        return default
    usual, most = (
        np.array([rough_cells(x, t.tile_size, res) if isinstance(x, RoughTile) else 0 for x in t.tiles])
        for res in (default, None)
    )
    cells = lod.fit(scene, usual, lod.BUDGETS[fmt], most=most, fixed=_fixed_triangles(t))
    if cells is None:
        return default
    option = "resolution= (citygen export --terrain-resolution)"
    message = lod.warning(fmt.upper(), scene, cells, f"{lod.BUDGETS[fmt]:,} triangles", option)
    warnings.warn(ExportWarning(message), stacklevel=3)
    return np.where(cells > 0, t.tile_size / np.maximum(cells, 1), np.nan)


def scene_dir_of(scene: Scene | str | Path, options: dict[str, Any]) -> tuple[Scene, Path | None]:
    """The scene model and the folder its mesh paths are relative to (option ``scene_dir``
    for a model, the file's folder for a path)."""
    model, folder = as_scene(scene)
    given = options.get("scene_dir")
    if given is not None:
        folder = Path(given)  # type: ignore[arg-type]
    return model, folder


# --- meshes -----------------------------------------------------------------------------


def mesh_file(placement: Placement, index: int, scene_dir: Path | None) -> Path:
    """The file of a mesh placement, checked to lie inside the scene's folder."""
    where = f"$.placements[{index}].asset"
    if scene_dir is None:
        raise ExportError(
            f"{where}: the mesh {placement.asset!r} is relative to the scene file's folder; export the "
            "scene from its file or pass the option scene_dir"
        )
    rel = PurePosixPath(placement.asset)
    base = Path(scene_dir).resolve()
    path = (base / rel).resolve()
    if rel.is_absolute() or placement.asset.startswith("~") or not path.is_relative_to(base):
        raise ExportError(f"{where}: expected a path inside the scene's folder, got {placement.asset!r}")
    if not path.is_file():
        raise ExportError(f"{where}: expected an existing mesh file, got no file {placement.asset!r}")
    return path


def load_mesh_file(placement: Placement, index: int, scene_dir: Path | None) -> trimesh.Trimesh:
    """A mesh placement's geometry in its own frame (m), before the placement's transform."""
    import trimesh

    path = mesh_file(placement, index, scene_dir)
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise ExportError(f"$.placements[{index}].asset: cannot read {placement.asset!r}: {exc}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ExportError(f"$.placements[{index}].asset: expected a mesh with faces in {placement.asset!r}")
    return mesh


def flat_coloured(vertices: np.ndarray, faces: np.ndarray, colour: RGBA) -> trimesh.Trimesh:
    """A mesh of one colour (vertex colours, 8 bits per channel)."""
    import trimesh

    mesh = trimesh.Trimesh(np.asarray(vertices, dtype=np.float64), np.asarray(faces, np.int64), process=False)
    c = np.round(np.asarray(colour) * 255).astype(np.uint8)
    mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=np.tile(c, (len(mesh.vertices), 1)))
    return mesh


def colour_groups(mesh: trimesh.Trimesh) -> list[tuple[tuple[int, ...], np.ndarray]]:
    """The mesh's faces grouped by face colour: ``[(rgba bytes, face indices), ...]`` in
    the order each colour first appears."""
    colours = np.asarray(mesh.visual.face_colors, dtype=np.uint8)
    _, first, inverse = np.unique(colours, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    by_colour = np.argsort(inverse, kind="stable")
    groups = np.split(by_colour, np.flatnonzero(np.diff(inverse[by_colour])) + 1)
    order = np.argsort(first, kind="stable")
    return [(tuple(int(c) for c in colours[first[g]]), groups[g]) for g in order.tolist()]


def submesh(mesh: trimesh.Trimesh, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of the given faces of ``mesh``, keeping only the vertices they use."""
    used, inverse = np.unique(mesh.faces[faces].ravel(), return_inverse=True)
    return np.asarray(mesh.vertices)[used], inverse.reshape(-1, 3)


def vertex_coloured(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh with its face colours as exact vertex colours: vertices are split where
    faces of different colours meet (glTF and WebGL colour vertices, not faces)."""
    import trimesh

    parts_v, parts_f, parts_c, count = [], [], [], 0
    for colour, faces in colour_groups(mesh):
        v, f = submesh(mesh, faces)
        parts_v.append(v)
        parts_f.append(f + count)
        parts_c.append(np.tile(np.array(colour, dtype=np.uint8), (len(v), 1)))
        count += len(v)
    out = trimesh.Trimesh(np.concatenate(parts_v), np.concatenate(parts_f), process=False)
    out.visual = trimesh.visual.ColorVisuals(out, vertex_colors=np.concatenate(parts_c))
    return out


def placement_matrix(placement: Placement) -> np.ndarray:
    """The 4x4 transform of a placement: scale, then yaw about +Z, then move to its position."""
    c, s = math.cos(placement.yaw), math.sin(placement.yaw)
    k = placement.scale
    m = np.eye(4)
    m[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) * k
    m[:3, 3] = placement.position
    return m


# --- the ground -------------------------------------------------------------------------


def zone_polygons(scene: Scene) -> list[shapely.Geometry]:
    """Each zone as a shapely geometry (m). An invalid polygon is repaired with
    ``make_valid`` and an :class:`ExportWarning` saying so."""
    out = []
    for i, zone in enumerate(scene.zones):
        poly = Polygon(zone.polygon, zone.holes)
        if not poly.is_valid:
            warnings.warn(
                ExportWarning(f"$.zones[{i}].polygon: not a valid polygon; exported its make_valid repair"),
                stacklevel=3,
            )
            poly = shapely.make_valid(poly)
        out.append(poly)
    return out


def grid_box(scene: Scene) -> Polygon | None:
    """The terrain grid's rectangle (m), None without a terrain."""
    t = scene.terrain
    if t is None:
        return None
    ox, oy = t.origin
    return shapely.box(ox, oy, ox + t.cols * t.tile_size, oy + t.rows * t.tile_size)


def polygon_parts(geom: shapely.Geometry) -> list[Polygon]:
    """The polygons of any shapely geometry, dropping points, lines and empty pieces."""
    parts = shapely.get_parts(shapely.get_parts(geom))  # collections may hold multipolygons
    return [p for p in parts if isinstance(p, Polygon) and not p.is_empty and p.area > 1e-12]


def triangulate(poly: Polygon) -> tuple[np.ndarray, np.ndarray]:
    """A polygon with holes as triangles: ``(xy (n, 2), faces (k, 3))``, counter-clockwise."""
    poly = shapely.geometry.polygon.orient(poly, 1.0)
    rings = [np.asarray(poly.exterior.coords)[:-1]]
    rings += [np.asarray(r.coords)[:-1] for r in poly.interiors]
    xy = np.concatenate(rings)
    faces = np.asarray(manifold3d.triangulate(rings), dtype=np.int64).reshape(-1, 3)
    return xy, faces


def drape(
    scene: Scene,
    geometries: Sequence[shapely.Geometry],
    *,
    resolution: float | None = None,
    mesh: trimesh.Trimesh | None = None,
) -> list[tuple[np.ndarray, np.ndarray]]:
    """The ground surface under each 2-d geometry: ``(vertices (n, 3), faces (k, 3))`` in
    metres, upward-facing, lying exactly on the terrain's mesh (:func:`terrain_mesh` at
    ``resolution``, or ``mesh`` if already built) inside its grid and at ``z = 0`` outside
    it; empty arrays where a geometry covers no ground.

    Tiles that lie inside one geometry give it their top faces as they are; only the
    faces of tiles that a geometry's edge crosses are clipped (shapely, vectorised).
    """
    out: list[list[tuple[np.ndarray, np.ndarray]]] = [[] for _ in geometries]
    grid = grid_box(scene)
    flat = geometries if grid is None else shapely.difference(np.asarray(geometries, dtype=object), grid)
    for i, geom in enumerate(flat):
        for part in polygon_parts(geom):
            xy, faces = triangulate(part)
            out[i].append((np.c_[xy, np.zeros(len(xy))], faces))
    if grid is not None and len(geometries):
        tm = terrain_mesh(scene, resolution=resolution) if mesh is None else mesh
        _drape_on_terrain(scene, np.asarray(geometries, dtype=object), tm, out)
    return [_concat(pieces) for pieces in out]


def tile_owners(scene: Scene, tree: shapely.STRtree) -> np.ndarray:
    """For each terrain tile, the index of the tree's geometry that contains it whole, or -1."""
    t = scene.terrain
    ids = np.arange(t.rows * t.cols)
    x0, y0 = t.origin[0] + (ids % t.cols) * t.tile_size, t.origin[1] + (ids // t.cols) * t.tile_size
    ci, gi = tree.query(shapely.box(x0, y0, x0 + t.tile_size, y0 + t.tile_size), predicate="within")
    owner = np.full(len(ids), -1)
    first = np.unique(ci, return_index=True)[1]  # the first geometry listed, where they overlap
    owner[ci[first]] = gi[first]
    return owner


def _drape_on_terrain(scene: Scene, geoms: np.ndarray, tm: trimesh.Trimesh, out: list) -> None:
    v, f = tm.vertices, tm.faces
    normals = np.cross(v[f[:, 1]] - v[f[:, 0]], v[f[:, 2]] - v[f[:, 0]])
    up = np.flatnonzero(normals[:, 2] > 1e-12 * np.abs(normals).sum(axis=1) + 1e-300)
    faces, normals, face_tile = f[up], normals[up], tm.metadata["face_tile"][up]
    tree = shapely.STRtree(geoms)
    # Tiles wholly inside one geometry: their top faces as they are.
    whole = tile_owners(scene, tree)[face_tile]
    # The other tiles' faces: those no geometry's edge touches belong to the geometry
    # holding their centroid (or to none); the others are clipped by each geometry they meet.
    rest = np.flatnonzero(whole < 0)
    corners = v[faces[rest]]
    tris = shapely.polygons(corners[:, :, :2])
    edges = _segments(shapely.boundary(geoms))
    touched = np.zeros(len(rest), dtype=bool)
    touched[np.unique(shapely.STRtree(tris).query(edges, predicate="intersects")[1])] = True
    centroid = corners[~touched, :, :2].mean(axis=1)
    fi, fg = tree.query(shapely.points(centroid), predicate="intersects")
    inner = np.flatnonzero(~touched)[fi]
    ri, rg = tree.query(tris[touched], predicate="intersects")
    ri = np.flatnonzero(touched)[ri]
    pieces = shapely.intersection(tris[ri], geoms[rg])
    n = normals[rest[ri]]
    plane = np.c_[-n[:, 0] / n[:, 2], -n[:, 1] / n[:, 2]]  # z = a x + b y + c
    plane = np.c_[plane, corners[ri, 0, 2] - (plane * corners[ri, 0, :2]).sum(axis=1)]
    tri_area = n[:, 2] / 2.0
    kept = np.abs(shapely.area(pieces) - tri_area) <= 1e-9 * tri_area  # the face, unclipped
    parts, piece = shapely.get_parts(pieces[~kept], return_index=True)
    piece = np.flatnonzero(~kept)[piece]
    parts, sub = shapely.get_parts(parts, return_index=True)  # collections hold multipolygons too
    piece = piece[sub]
    keep = (shapely.get_type_id(parts) == 3) & (shapely.area(parts) > 1e-12)
    parts, piece = parts[keep], piece[keep]
    area = shapely.area(parts)
    convex = (shapely.get_num_interior_rings(parts) == 0) & (
        shapely.area(shapely.convex_hull(parts)) - area <= 1e-9 * area
    )
    soups = [
        (v, faces[whole >= 0], whole[whole >= 0]),  # whole tiles
        (v, faces[rest[inner]], fg),  # whole faces
        (v, faces[rest[ri[kept]]], rg[kept]),
        _fans(parts[convex], piece[convex], plane, rg),  # convex pieces
    ]
    for part, k in zip(parts[~convex], piece[~convex], strict=True):  # the rare others: ear clipping
        xy, tri = triangulate(part)
        soups.append((np.c_[xy, xy @ plane[k, :2] + plane[k, 2]], tri, np.full(len(tri), rg[k])))
    verts = np.concatenate([s[0] for s in soups])
    offsets = np.cumsum([0] + [len(s[0]) for s in soups[:-1]])
    tris = np.concatenate([s[1] + o for s, o in zip(soups, offsets, strict=True)])
    group = np.concatenate([s[2] for s in soups])
    if len(group) == 0:
        return
    order = np.argsort(group, kind="stable")
    tris, group = tris[order], group[order]
    bounds = np.flatnonzero(np.diff(group)) + 1
    for g_faces, g in zip(np.split(tris, bounds), group[np.r_[0, bounds]], strict=True):
        used, inverse = np.unique(g_faces.ravel(), return_inverse=True)
        out[int(g)].append((verts[used], inverse.reshape(-1, 3)))


def _segments(lines: np.ndarray) -> np.ndarray:
    """Every straight segment of some (multi)linestrings, as separate linestrings."""
    parts = shapely.get_parts(lines)
    coords, index = shapely.get_coordinates(parts, return_index=True)
    same = index[1:] == index[:-1]
    return shapely.linestrings(np.stack([coords[:-1][same], coords[1:][same]], axis=1))


def _fans(parts: np.ndarray, piece: np.ndarray, plane: np.ndarray, group: np.ndarray):
    """Convex polygons as triangle fans lifted onto their face's plane, vectorised:
    ``(vertices, faces, group of each face)``."""
    if len(parts) == 0:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64), np.zeros(0, dtype=np.int64)
    ring = shapely.get_exterior_ring(shapely.orient_polygons(parts, exterior_cw=False))
    coords, index = shapely.get_coordinates(ring, return_index=True)
    last = np.r_[np.flatnonzero(np.diff(index)), len(index) - 1]
    drop = np.zeros(len(index), dtype=bool)
    drop[last] = True  # each ring repeats its first point at its end
    coords, index = coords[~drop], index[~drop]
    counts = np.bincount(index, minlength=len(parts))
    starts = np.r_[0, np.cumsum(counts)[:-1]]
    per = np.maximum(counts - 2, 0)
    owner = np.repeat(np.arange(len(parts)), per)
    k = np.arange(per.sum()) - np.repeat(np.cumsum(per) - per, per) + 1
    first = starts[owner]
    faces = np.c_[first, first + k, first + k + 1]
    p = plane[piece[index]]
    z = p[:, 0] * coords[:, 0] + p[:, 1] * coords[:, 1] + p[:, 2]
    return np.c_[coords, z], faces, group[piece[owner]]


def _concat(pieces: list[tuple[np.ndarray, np.ndarray]]) -> tuple[np.ndarray, np.ndarray]:
    if not pieces:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    offsets = np.cumsum([0] + [len(v) for v, _ in pieces[:-1]])
    return (
        np.concatenate([v for v, _ in pieces]),
        np.concatenate([f + o for (_, f), o in zip(pieces, offsets, strict=True)]),
    )


def ground_plane(scene: Scene) -> tuple[np.ndarray, np.ndarray]:
    """The flat ground at ``z = 0``: the scene's bounds outside the terrain grid (m)."""
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    area = shapely.box(x0, y0, x1, y1)
    grid = grid_box(scene)
    if grid is not None:
        area = area.difference(grid)
    pieces = []
    for part in polygon_parts(area):
        xy, faces = triangulate(part)
        pieces.append((np.c_[xy, np.zeros(len(xy))], faces))
    return _concat(pieces)


# --- markers ----------------------------------------------------------------------------


def _unit_cylinder() -> trimesh.Trimesh:
    """Radius 1, height 1, base at z = 0."""
    import trimesh

    mesh = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=24)
    return trimesh.Trimesh(mesh.vertices + np.array([0.0, 0.0, 0.5]), mesh.faces, process=False)


def _unit_box() -> trimesh.Trimesh:
    """1 x 1 x 1, centred on x and y, base at z = 0."""
    import trimesh

    mesh = trimesh.creation.box((1.0, 1.0, 1.0))
    return trimesh.Trimesh(mesh.vertices + np.array([0.0, 0.0, 0.5]), mesh.faces, process=False)


def _arrow() -> tuple[np.ndarray, np.ndarray]:
    """A flat arrow 1 m long pointing +x, centred on its tail half, base at z = 0."""
    outline = np.array(
        [[-0.5, -0.15], [0.1, -0.15], [0.1, -0.35], [0.5, 0.0], [0.1, 0.35], [0.1, 0.15], [-0.5, 0.15]]
    )
    xy, faces = triangulate(Polygon(outline))
    n = len(xy)
    verts = np.r_[np.c_[xy, np.zeros(n)], np.c_[xy, np.full(n, 1.0)]]
    ring = np.arange(n)
    nxt = np.roll(ring, -1)
    sides = np.r_[np.c_[ring, nxt, nxt + n], np.c_[ring, nxt + n, ring + n]]
    return verts, np.r_[faces[:, ::-1], faces + n, sides]


def _matrix(
    x: float, y: float, z: float, yaw: float = 0.0, size: Sequence[float] = (1.0, 1.0, 1.0)
) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    m = np.eye(4)
    m[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.diag(size)
    m[:3, 3] = (x, y, z)
    return m


# --- the scene graph --------------------------------------------------------------------


class _Graph:
    """A trimesh scene under :data:`ROOT`, adding each geometry once however many nodes use it."""

    def __init__(self, y_up: bool) -> None:
        import trimesh

        self.scene = trimesh.Scene()
        turn = Z_UP_TO_Y_UP if y_up else np.eye(4)
        self.scene.graph.update(frame_from=self.scene.graph.base_frame, frame_to=ROOT, matrix=turn)

    def add(self, node: str, geometry: str, make, matrix: np.ndarray) -> None:
        if geometry not in self.scene.geometry:
            self.scene.geometry[geometry] = make()
        self.scene.graph.update(frame_from=ROOT, frame_to=node, matrix=matrix, geometry=geometry)


def build(
    scene: Scene | str | Path,
    *,
    scene_dir: str | Path | None = None,
    resolution: float | str | None = AUTO,
    y_up: bool = True,
    fmt: str = "glb",
) -> trimesh.Scene:
    """The scene as a :class:`trimesh.Scene` (see the module docstring for its nodes).

    ``scene_dir`` is the folder mesh placements are relative to (default: the scene
    file's folder). ``resolution`` (m) is the cell size of rough terrain tiles' meshes
    (default :data:`AUTO`: :data:`RESOLUTION`, coarser where the terrain would exceed
    ``lod.BUDGETS[fmt]`` triangles, rougher tiles finer: :func:`auto_terrain`; None for
    :func:`~citygen.geometry.terrain.tile_mesh`'s, which resolves every bump). Agents and
    the task's markers stand on the ground (:func:`height_at`).
    """
    model, folder = scene_dir_of(scene, {"scene_dir": scene_dir})
    resolution = resolution_option(resolution, fmt)
    if not isinstance(y_up, bool):
        raise ExportError(f"glb export: expected true or false for 'y_up', got {y_up!r}")
    g = _Graph(y_up)
    polys = zone_polygons(model)
    tm = None
    if model.terrain is not None:
        if resolution == AUTO:
            resolution = auto_terrain(model, fmt, RESOLUTION)
        else:
            resolution = fit_terrain(model, resolution, fmt, RESOLUTION)
        tm = terrain_mesh(model, resolution=resolution)
        solid = terrain_solid(model, polys, mesh=tm)
        g.add("ground/terrain", "terrain", lambda: solid, np.eye(4))
    verts, faces = ground_plane(model)
    if len(faces):
        g.add("ground/plane", "plane", lambda: flat_coloured(verts, faces, GROUND_RGBA), np.eye(4))
    _add_zones(g, model, polys, tm)
    _add_placements(g, model, folder)
    _add_agents(g, model)
    _add_task(g, model)
    extras = {"format": model.format}
    for key in ("meta", "agents", "task"):
        value = getattr(model, key)
        if value:
            extras[key] = (
                [a.model_dump(mode="json", exclude_none=True) for a in value]
                if key == "agents"
                else value.model_dump(mode="json", exclude_none=True)
            )
    g.scene.metadata["citygen"] = extras
    return g.scene


def terrain_solid(
    scene: Scene,
    zones: Sequence[shapely.Geometry] | None = None,
    *,
    resolution: float | None = None,
    mesh: trimesh.Trimesh | None = None,
) -> trimesh.Trimesh:
    """The terrain as one closed solid (:func:`terrain_mesh`, or ``mesh`` if already built),
    each face coloured as the zone under its centroid (so steps and walls take their zone's
    colour, and cracks between the zones' surfaces never show another), else
    :data:`TERRAIN_RGBA` (vertex colours). ``zones`` are the zones' shapes if already made
    (:func:`zone_polygons`)."""
    import trimesh

    solid = terrain_mesh(scene, resolution=resolution) if mesh is None else mesh
    colours = np.tile(np.round(np.asarray(TERRAIN_RGBA) * 255).astype(np.uint8), (len(solid.faces), 1))
    if scene.zones:
        shapes = np.asarray(zone_polygons(scene) if zones is None else zones, dtype=object)
        palette = np.array(
            [np.round(np.asarray(zone_rgba(z.kind)) * 255) for z in scene.zones], dtype=np.uint8
        )
        tree = shapely.STRtree(shapes)
        owner = tile_owners(scene, tree)[solid.metadata["face_tile"]]
        colours[owner >= 0] = palette[owner[owner >= 0]]
        rest = np.flatnonzero(owner < 0)  # faces of tiles that zone edges cross: one by one
        centre = solid.vertices[solid.faces[rest]].mean(axis=1)
        fi, zi = tree.query(shapely.points(centre[:, :2]), predicate="intersects")
        first = np.unique(fi, return_index=True)[1]  # the first zone listed, where zones touch
        colours[rest[fi[first]]] = palette[zi[first]]
    out = trimesh.Trimesh(solid.vertices, solid.faces, process=False)
    out.visual.face_colors = colours
    return vertex_coloured(out)


def _coloured_mesh(mesh: trimesh.Trimesh, colour: RGBA) -> trimesh.Trimesh:
    return flat_coloured(mesh.vertices, mesh.faces, colour)


def _add_zones(g: _Graph, scene: Scene, polys: list, tm: trimesh.Trimesh | None) -> None:
    surfaces = drape(scene, polys, mesh=tm)
    for zone, (verts, faces) in zip(scene.zones, surfaces, strict=True):
        if len(faces):
            lifted = verts + np.array([0.0, 0.0, ZONE_LIFT])
            colour = zone_rgba(zone.kind)
            name = f"zone/{zone.id}"
            g.add(name, name, lambda v=lifted, f=faces, c=colour: flat_coloured(v, f, c), np.eye(4))


def _add_placements(g: _Graph, scene: Scene, folder: Path | None) -> None:
    for i, pl in enumerate(scene.placements):
        if pl.is_mesh:
            geometry = f"mesh/{pl.asset}"
            make = lambda pl=pl, i=i: vertex_coloured(file_mesh(pl, i, folder))  # noqa: E731
        else:
            geometry = f"asset/{pl.asset}"
            make = lambda pl=pl, i=i: vertex_coloured(catalog_asset(pl, i).visual_mesh())  # noqa: E731
        g.add(pl.id, geometry, make, placement_matrix(pl))


def catalog_asset(pl: Placement, index: int) -> Asset:
    """The catalog asset of a placement, or an :class:`ExportError` naming it."""
    try:
        return resolve(pl.asset)
    except UnknownAsset as exc:
        raise ExportError(f"$.placements[{index}].asset: expected {exc.expected}, got {pl.asset!r}") from None


def file_mesh(pl: Placement, index: int, folder: Path | None) -> trimesh.Trimesh:
    """A mesh placement's geometry with face colours: its own where the file has colours,
    else :data:`MESH_RGBA`. A texture cannot be kept: an :class:`ExportWarning` says so."""
    import trimesh

    mesh = load_mesh_file(pl, index, folder)
    visual = mesh.visual
    out = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    if isinstance(visual, trimesh.visual.ColorVisuals) and visual.kind in ("face", "vertex"):
        out.visual.face_colors = visual.face_colors
        return out
    if (
        isinstance(visual, trimesh.visual.TextureVisuals)
        and getattr(visual.material, "image", None) is not None
    ):
        warnings.warn(
            ExportWarning(
                f"$.placements[{index}].asset: the texture of {pl.asset!r} is not kept; one colour"
            ),
            stacklevel=3,
        )
    out.visual.face_colors = np.round(np.asarray(MESH_RGBA) * 255).astype(np.uint8)
    return out


def _add_agents(g: _Graph, scene: Scene) -> None:
    for agent in scene.agents:
        colour = rgba(AGENT_COLORS[agent.kind])
        (sx, sy), (gx, gy) = agent.start, agent.goal
        z0, z1 = (float(z) for z in height_at(scene, [sx, gx], [sy, gy]))
        h = AGENT_HEIGHT[agent.kind]
        if isinstance(agent, Vehicle):
            yaw = math.atan2(gy - sy, gx - sx) if (gx, gy) != (sx, sy) else 0.0
            m = _matrix(sx, sy, z0, yaw, (agent.length, agent.width, h))
            g.add(f"agent/{agent.id}", "agent/vehicle", lambda c=colour: _coloured_mesh(_unit_box(), c), m)
            r = agent.width / 2
        else:
            r = agent.radius
            m = _matrix(sx, sy, z0, 0.0, (r, r, h))
            person = lambda c=colour: _coloured_mesh(_unit_cylinder(), c)  # noqa: E731
            g.add(f"agent/{agent.id}", f"agent/{agent.kind}", person, m)
        disc = _matrix(gx, gy, z1, 0.0, (r, r, MARKER_THICKNESS))
        marker = "agent/vehicle/goal" if isinstance(agent, Vehicle) else f"agent/{agent.kind}"
        g.add(f"agent/{agent.id}/goal", marker, lambda c=colour: _coloured_mesh(_unit_cylinder(), c), disc)


def _add_task(g: _Graph, scene: Scene) -> None:
    task = scene.task
    if task is None:
        return
    (x, y), yaw = task.start.position, task.start.yaw
    z = float(height_at(scene, x, y))
    start = rgba(START_COLOR)
    g.add(
        "task/start",
        "task/arrow",
        lambda: flat_coloured(*_arrow(), start),
        _matrix(x, y, z, yaw, (1, 1, MARKER_THICKNESS)),
    )
    goal = rgba(GOAL_COLOR)
    make_disc = lambda: _coloured_mesh(_unit_cylinder(), goal)  # noqa: E731
    if isinstance(task, NavTask):
        (gx, gy), r = task.goal, task.goal_tolerance
        gz = float(height_at(scene, gx, gy))
        g.add("task/goal", "task/disc", make_disc, _matrix(gx, gy, gz, 0.0, (r, r, MARKER_THICKNESS)))
    elif isinstance(task, TraverseTask):
        pts = np.asarray(task.route, dtype=np.float64)
        zs = height_at(scene, pts[:, 0], pts[:, 1])
        r = task.goal_tolerance
        for k, ((px, py), pz) in enumerate(zip(pts.tolist(), zs.tolist(), strict=True)):
            name = "task/goal" if k == len(pts) - 1 else f"task/route/{k}"
            g.add(name, "task/disc", make_disc, _matrix(px, py, pz, 0.0, (r, r, MARKER_THICKNESS)))


# --- writing ----------------------------------------------------------------------------

_OPTIONS = ("name", "scene_dir", "resolution", "y_up")


#: glTF ``bufferView.target`` values: vertex attributes and indices.
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


def with_targets(glb: bytes) -> bytes:
    """A GLB with ``target`` set on every buffer view its meshes read (``ARRAY_BUFFER`` for
    vertex attributes, ``ELEMENT_ARRAY_BUFFER`` for indices), which trimesh leaves out and
    the Khronos validator hints at; the binary chunk is unchanged."""
    magic, version, _ = struct.unpack_from("<4sII", glb, 0)
    length, kind = struct.unpack_from("<I4s", glb, 12)
    if magic != b"glTF" or kind != b"JSON":
        return glb
    doc = json.loads(glb[20 : 20 + length])
    views, accessors = doc.get("bufferViews", []), doc.get("accessors", [])
    for mesh in doc.get("meshes", []):
        for prim in mesh.get("primitives", []):
            uses = [(a, ARRAY_BUFFER) for a in prim.get("attributes", {}).values()]
            if "indices" in prim:
                uses.append((prim["indices"], ELEMENT_ARRAY_BUFFER))
            for accessor, target in uses:
                view = accessors[accessor].get("bufferView")
                if view is not None:
                    views[view]["target"] = target
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    rest = glb[20 + length :]
    header = struct.pack("<4sII", magic, version, 12 + 8 + len(text) + len(rest))
    return header + struct.pack("<I4s", len(text), b"JSON") + text + rest


def to_bytes(scene: Scene | str | Path, **options: Any) -> bytes:
    """The GLB file's bytes (options as :func:`build`), every buffer view's ``target`` set."""
    return with_targets(build(scene, **options).export(file_type="glb"))


def export(scene: Scene | str | Path, out_dir: str | Path, **options: Any) -> list[Path]:
    """Write ``<out_dir>/<name>.glb``; returns ``[that path]``.

    Options: ``name`` (default: the scene file's stem, ``<split>-<index>`` or ``scene``),
    ``scene_dir``, ``resolution`` (m, default :data:`AUTO`) and ``y_up`` (see :func:`build`).
    """
    check_options(options, _OPTIONS, "glb")
    name = output_name(scene, options, "glb")
    data = to_bytes(scene, **{k: v for k, v in options.items() if k != "name"})
    path = Path(out_dir) / f"{name}.glb"
    write_atomic(path, data)
    return [path]
