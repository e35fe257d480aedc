"""The ground as triangle meshes for the mesh exporters: each zone's polygon triangulated
and draped on the terrain's mesh, the flat ground outside the terrain grid, the terrain as
one solid coloured by the zones over it, and how finely rough tiles are meshed within a
format's triangle budget (:mod:`citygen.exporters.lod`)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from typing import TYPE_CHECKING

import manifold3d
import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.errors import ExportError
from citygen.exporters import ExportWarning, lod
from citygen.exporters.meshes import TERRAIN_RGBA, vertex_coloured, zone_rgba
from citygen.exporters.options import AUTO
from citygen.geometry.terrain import DEFAULT_ROUGH_CELLS, MAX_ROUGH_CELLS, terrain_mesh
from citygen.spec.scene import Scene
from citygen.spec.terrain import RoughTile, SlopeTile, StairTile

if TYPE_CHECKING:
    import trimesh

#: Height (m) of zone surfaces above the ground they cover, so they never z-fight with it.
ZONE_LIFT = 0.005
#: Default cell size (m) of rough tiles' meshes in pictures (GLB, HTML): fine enough to show
#: the bumps, coarse enough to keep a street's file to megabytes.
RESOLUTION = 0.1
#: Most triangles an exporter lets the terrain's mesh have, to keep memory bounded.
MAX_TERRAIN_TRIANGLES = 16_000_000


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
