"""The ground's geometry for USD, without pxr: which tiles leave their ground to the zones,
each zone's flat pieces at their heights and their triangles, and the terrain tiles the
zones do not carry as meshes grouped by the class of their zone, with a material key
(surface, friction) per face."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import manifold3d
import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.errors import ExportError
from citygen.exporters import ExportWarning, lod
from citygen.geometry.features import box_corners, feature_boxes
from citygen.geometry.terrain import DEFAULT_ROUGH_CELLS, MAX_ROUGH_CELLS, height_grid, tile_mesh
from citygen.geometry.tiles import tile_kind
from citygen.spec.scene import Scene
from citygen.spec.surfaces import FRICTION
from citygen.spec.terrain import RoughTile, Terrain, edge_profile

#: Material and friction of ground no zone covers (as the terrain spec says).
UNZONED_MATERIAL = "concrete"
#: Most triangles of rough tiles at the default sampling; beyond it the sampling coarsens
#: (with an ExportWarning): about 50 MB of usdc.
DEFAULT_TERRAIN_TRIANGLES = 4_000_000
#: Most triangles of rough tiles at a given ``terrain_resolution``; beyond it, an ExportError.
MAX_TERRAIN_TRIANGLES = 16_000_000
#: Semantic class of ground no zone covers.
GROUND_CLASS = "ground"


@dataclass(frozen=True)
class FlatGrid:
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
    return tile_kind(tile).level(tile) and not _own_surface(tile)


def _own_surface(tile) -> bool:
    return tile.material is not None or tile.friction is not None


def flat_grid(terrain: Terrain | None) -> FlatGrid | None:
    if terrain is None:
        return None
    flat = np.array([_level(t) for t in terrain.tiles]).reshape(terrain.rows, terrain.cols)
    height = np.array([t.height for t in terrain.tiles], dtype=np.float64).reshape(terrain.rows, terrain.cols)
    return FlatGrid(terrain, flat, height)


def _cells_hit(grid: FlatGrid, mask: np.ndarray, r0: int, c0: int, poly) -> Any:
    """The union of the cells where ``mask`` (a window at row ``r0``, column ``c0``) is True
    that meet the (prepared) ``poly``; None when none does."""
    t = grid.terrain
    (ox, oy), s = t.origin, t.tile_size
    rows, cols = np.nonzero(mask)
    rows, cols = rows + r0, cols + c0
    boxes = shapely.box(ox + cols * s, oy + rows * s, ox + (cols + 1) * s, oy + (rows + 1) * s)
    boxes = boxes[shapely.intersects(poly, boxes)]
    return shapely.coverage_union_all(boxes) if len(boxes) else None


def flat_pieces(poly, grid: FlatGrid | None) -> list[tuple[float, Any]]:
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


def triangulate(pieces: Sequence[tuple[float, Any]]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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


class Ground:
    """Collects the ground's meshes and the materials they use."""

    def __init__(self) -> None:
        self.materials: dict[tuple[str, float], int] = {}

    def key(self, surface: tuple[str, float]) -> int:
        return self.materials.setdefault((surface[0], round(float(surface[1]), 6)), len(self.materials))


def terrain_parts(
    scene: Scene,
    grid: FlatGrid,
    polys: list[Polygon],
    tree: shapely.STRtree,
    ground: Ground,
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
