"""Terrain heights and tile solids: the one definition of the ground every reader uses.

:func:`height_at` is the single source of truth for the ground's height: the exporters'
heightfields and meshes, the generator's placement on the ground and the runner's
height-map observation all derive from it (or from :func:`tile_height`, which it calls).
Units are metres, Z up.

Rules (see ``docs/terrain.md`` for pictures and the exact noise):

- Outside the tile grid, and everywhere when a scene has no terrain, the ground is at
  ``z = 0``. The grid includes its border: ``x`` in ``[origin.x, origin.x + cols * tile_size]``.
- A point on the border between two tiles belongs to the tile with the larger index
  (``col = floor((x - origin.x) / tile_size)``, clipped to the grid), so the east and north
  edges of the grid belong to the last column and row. Neighbours that agree on their
  edge profiles (what :func:`citygen.validate` checks) give the same height there.
- A stair riser belongs to the upper tread (in a pit, to the inner one).
- Slopes and stairs with a ``shape`` (``pyramid`` or ``pit``) follow the formulas in
  :mod:`citygen.spec.terrain`; their edges are level at ``height``.
- A rough tile is ``height + amplitude * noise(u, v) * taper(u, v)``: value noise on a
  square lattice of spacing ``scale / 2`` whose node values are uniform in ``[-1, 1)``,
  drawn from a SplitMix64 hash of ``(seed, i, j)`` (integer arithmetic only, so every
  machine and language gets the same numbers), blended with the quintic fade
  ``6t^5 - 15t^4 + 10t^3``; the taper is that fade applied over a border band of width
  ``min(scale, tile_size / 4)``, 0 on the tile's edges and 1 inside, so the tile meets
  its neighbours level at ``height``. The deviation never exceeds ``amplitude``.

>>> from citygen.spec import Terrain
>>> t = Terrain(origin=(0, 0), tile_size=2.0, rows=1, cols=3, tiles=[
...     {"kind": "flat"},
...     {"kind": "stair", "step_height": 0.15, "step_count": 3},
...     {"kind": "flat", "height": 0.45}])
>>> height_at(t, [1.0, 2.9, 3.1, 5.0, 9.0], 1.0).round(4).tolist()
[0.0, 0.15, 0.3, 0.45, 0.0]
>>> max_step(t)
0.15
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from citygen.geometry.features import box_corners, feature_boxes, raise_heights
from citygen.geometry.noise import noise_key, rough_noise
from citygen.geometry.tiles import (
    DEFAULT_ROUGH_CELLS,
    KIND_CODES,
    MAX_ROUGH_CELLS,
    MIN_THICKNESS,
    TILE_KINDS,
    AnyTile,
    HeightTable,
    build_table,
    evaluate,
    rough_slope_bound,
    solid_bottom,
    tile_boxes,
    tile_grid,
    tile_height,
    tile_kind,
    tile_mesh,
)
from citygen.spec.scene import Scene
from citygen.spec.terrain import RoughTile, Terrain, feature_top

if TYPE_CHECKING:
    import trimesh

# Re-exported: one tile's heights and solid (citygen.geometry.tiles) belong to the terrain's API.
__all__ = [
    "DEFAULT_ROUGH_CELLS",
    "MAX_HEIGHTFIELD_SAMPLES",
    "MAX_ROUGH_CELLS",
    "MIN_THICKNESS",
    "AnyTile",
    "height_at",
    "height_grid",
    "heightfield",
    "max_slope",
    "max_step",
    "noise_key",
    "rough_slope_bound",
    "terrain_mesh",
    "tile_boxes",
    "tile_grid",
    "tile_height",
    "tile_mesh",
]

#: Most samples :func:`heightfield` returns (about 512 MiB of float64).
MAX_HEIGHTFIELD_SAMPLES = 1 << 26
_ROUGH = KIND_CODES[RoughTile]
_CHUNK = 1 << 20  # points per block in heightfield(), to bound temporaries


_TABLES: dict[int, tuple[Terrain, HeightTable]] = {}


def _table(terrain: Terrain) -> HeightTable:
    """The terrain's table, cached by identity (terrains are immutable) for the last few
    terrains built; the cache only saves time, never changes a result."""
    hit = _TABLES.get(id(terrain))
    if hit is not None and hit[0] is terrain:
        return hit[1]
    if len(terrain.tiles) != terrain.rows * terrain.cols:
        raise ValueError(
            f"a terrain of {terrain.rows} x {terrain.cols} tiles needs {terrain.rows * terrain.cols} "
            f"tiles, got {len(terrain.tiles)}"
        )
    table = build_table(terrain.tiles, terrain.tile_size)
    _TABLES[id(terrain)] = (terrain, table)
    for key in list(_TABLES)[:-8]:  # oldest first; tolerant of other threads evicting too
        _TABLES.pop(key, None)
    return table


def _terrain_of(obj: Scene | Terrain | None) -> Terrain | None:
    if obj is None or isinstance(obj, Terrain):
        return obj
    if isinstance(obj, Scene):
        return obj.terrain
    raise TypeError(f"expected a Scene, a Terrain or None, got {type(obj).__name__}")


# --- heights ----------------------------------------------------------------------------


def height_at(scene_or_terrain: Scene | Terrain | None, xs, ys) -> np.ndarray:
    """Ground height (m) at world points ``(xs, ys)`` (m; broadcastable arrays or scalars).

    Returns float64 heights of the broadcast shape: the terrain's surface inside its grid,
    0 outside it or without a terrain, NaN where a coordinate is NaN.
    """
    x, y = np.broadcast_arrays(np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64))
    shape = x.shape
    x, y = x.ravel(), y.ravel()
    z = np.zeros(x.size)
    terrain = _terrain_of(scene_or_terrain)
    if terrain is not None and x.size:
        tab = _table(terrain)
        s, (ox, oy) = terrain.tile_size, terrain.origin
        gx, gy = (x - ox) / s, (y - oy) / s
        inside = np.flatnonzero((gx >= 0) & (gx <= terrain.cols) & (gy >= 0) & (gy <= terrain.rows))
        col = np.minimum(np.floor(gx[inside]), terrain.cols - 1)
        row = np.minimum(np.floor(gy[inside]), terrain.rows - 1)
        u = np.clip(x[inside] - ox - col * s, 0.0, s)
        v = np.clip(y[inside] - oy - row * s, 0.0, s)
        t = (row * terrain.cols + col).astype(np.int64)
        z[inside] = evaluate(tab, t, u, v)
        raise_heights(terrain.features, x, y, z)
    z[np.isnan(x) | np.isnan(y)] = np.nan
    return z.reshape(shape)


def height_grid(scene_or_terrain: Scene | Terrain | None, xs, ys) -> np.ndarray:
    """Ground heights (m) on grids: ``z[..., i, j]`` is ``height_at(scene_or_terrain,
    xs[..., j], ys[..., i])`` bit for bit, for ``xs`` of shape ``(..., kx)`` and ``ys`` of
    shape ``(..., ky)`` (world coordinates in m, the same leading shape: one grid each).

    Faster than :func:`height_at` on the broadcast points when a grid mostly lies on one
    rough tile (a tile's surface sampled by an exporter): the parts of the noise that
    depend on one coordinate are computed along that axis only.
    """
    x, y = np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64)
    if x.ndim < 1 or y.ndim < 1 or x.shape[:-1] != y.shape[:-1]:
        raise ValueError(
            f"xs (..., kx) and ys (..., ky) need the same leading shape, got {x.shape} and {y.shape}"
        )
    lead, kx, ky = x.shape[:-1], x.shape[-1], y.shape[-1]
    terrain = _terrain_of(scene_or_terrain)
    if terrain is None or not (kx and ky and x.size and y.size):
        return height_at(terrain, x[..., None, :], y[..., :, None])
    x, y = x.reshape(-1, kx), y.reshape(-1, ky)
    tab = _table(terrain)
    s, (ox, oy), cols = terrain.tile_size, terrain.origin, terrain.cols
    # As height_at does it, per axis: a sample's column (row) depends on its x (y) alone.
    gx, gy = (x - ox) / s, (y - oy) / s
    in_x = (gx >= 0) & (gx <= terrain.cols)
    in_y = (gy >= 0) & (gy <= terrain.rows)
    with np.errstate(invalid="ignore"):
        col = np.where(in_x, np.minimum(np.floor(gx), terrain.cols - 1), 0.0)
        row = np.where(in_y, np.minimum(np.floor(gy), terrain.rows - 1), 0.0)
    u = np.where(in_x, np.clip(x - ox - col * s, 0.0, s), 0.0)
    v = np.where(in_y, np.clip(y - oy - row * s, 0.0, s), 0.0)
    t = (row[:, :, None] * cols + col[:, None, :]).astype(np.int64)
    inside = in_y[:, :, None] & in_x[:, None, :]
    z = np.zeros(t.shape)
    # Each grid's home tile (that of its middle sample); where it is rough, the samples on it
    # take the noise computed per axis (the same operations on the same numbers as rough_noise).
    home_col, home_row = col[:, kx // 2], row[:, ky // 2]
    home = (home_row * cols + home_col).astype(np.int64)
    on_x = in_x & (col == home_col[:, None])
    on_y = in_y & (row == home_row[:, None])
    fast = np.flatnonzero(on_x[:, kx // 2] & on_y[:, ky // 2] & (tab.kind[home] == _ROUGH))
    done = np.zeros(t.shape, dtype=bool)
    if fast.size:
        ht = home[fast][:, None, None]
        noise = rough_noise(tab.key[ht], tab.scale[ht], s, u[fast][:, None, :], v[fast][:, :, None])
        here = on_y[fast][:, :, None] & on_x[fast][:, None, :]
        z[fast] = np.where(here, tab.h[ht] + tab.a[ht] * noise, 0.0)
        done[fast] = here
    rest = inside & ~done
    if rest.any():
        ub, vb = np.broadcast_to(u[:, None, :], t.shape), np.broadcast_to(v[:, :, None], t.shape)
        z[rest] = evaluate(tab, t[rest], ub[rest], vb[rest])
    if terrain.features:
        xb, yb = np.broadcast_to(x[:, None, :], t.shape), np.broadcast_to(y[:, :, None], t.shape)
        flat = z.reshape(-1)
        raise_heights(terrain.features, xb.reshape(-1), yb.reshape(-1), flat)
        z = flat.reshape(t.shape)
    z[np.isnan(y)[:, :, None] | np.isnan(x)[:, None, :]] = np.nan
    return z.reshape(*lead, ky, kx)


def max_step(scene_or_terrain: Scene | Terrain | None) -> float:
    """The largest vertical discontinuity (m) the terrain may legitimately have inside its
    grid: its largest stair riser, 0 without stairs, or the rise of a feature's vertical
    side where it is higher. (Where the grid's outer edge is not at z = 0 the ground also
    drops to 0 there; that edge is not counted.)"""
    terrain = _terrain_of(scene_or_terrain)
    if terrain is None:
        return 0.0
    step = max((tile_kind(t).riser(t) for t in terrain.tiles), default=0.0)
    return max([step, *(feature_top(f) - f.height for f in terrain.features or ())])


def max_slope(scene_or_terrain: Scene | Terrain | None) -> float:
    """An upper bound on the gradient ``|grad z|`` (m/m) of the terrain away from stair
    risers: ``tan(angle)`` of its steepest slope, and for a rough tile of amplitude ``A``,
    scale ``L`` and taper width ``w = min(L, tile_size / 4)``:
    ``A * sqrt(2) * 1.875 * (4 / L + 1 / w)``. Two points ``d`` metres apart on a line inside
    the grid differ by at most ``max_slope * d`` plus every riser crossed between them."""
    terrain = _terrain_of(scene_or_terrain)
    if terrain is None:
        return 0.0
    tab = _table(terrain)
    bound = 0.0
    for code, kind in enumerate(TILE_KINDS.values()):
        rows = np.flatnonzero(tab.kind == code)
        if kind.gradient is not None and rows.size:
            bound = max(bound, float(kind.gradient(tab, rows).max()))
    return bound


def heightfield(
    scene_or_terrain: Scene | Terrain, resolution: float
) -> tuple[np.ndarray, tuple[float, float, float, float]]:
    """The terrain sampled on a regular grid covering its tile grid, via :func:`height_at`.

    ``resolution`` is the largest sample spacing in metres; the spacing along x (y) is the
    grid's width (depth) divided evenly, so the samples include the grid's edges. Returns
    ``(z, (x_min, x_max, y_min, y_max))`` where ``z[i, j]`` (m) is the height at
    ``x = x_min + j * (x_max - x_min) / (z.shape[1] - 1)``, ``y`` likewise with ``i``
    (rows along y, as MuJoCo's ``hfield`` and ``imshow(origin="lower")`` read them).
    """
    terrain = _terrain_of(scene_or_terrain)
    if terrain is None:
        raise ValueError("a heightfield needs a terrain; this scene has none (its ground is z = 0)")
    if not (math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be a positive number of metres, got {resolution!r}")
    width, depth = terrain.cols * terrain.tile_size, terrain.rows * terrain.tile_size
    nx = math.ceil(width / resolution - 1e-9) + 1
    ny = math.ceil(depth / resolution - 1e-9) + 1
    if nx * ny > MAX_HEIGHTFIELD_SAMPLES:
        raise ValueError(
            f"a {width:g} x {depth:g} m terrain at {resolution:g} m needs {nx} x {ny} samples, "
            f"more than {MAX_HEIGHTFIELD_SAMPLES}; use a coarser resolution"
        )
    ox, oy = terrain.origin
    xs = ox + np.linspace(0.0, width, nx)
    ys = oy + np.linspace(0.0, depth, ny)
    z = np.empty((ny, nx))
    block = max(1, _CHUNK // nx)
    for start in range(0, ny, block):
        z[start : start + block] = height_at(terrain, xs[None, :], ys[start : start + block, None])
    return z, (ox, ox + width, oy, oy + depth)


def _geometry_key(tile: AnyTile) -> tuple:
    return tuple(sorted(tile.model_dump(exclude={"material", "friction"}).items()))


def terrain_mesh(
    scene_or_terrain: Scene | Terrain, *, floor: float = -1.0, resolution: float | np.ndarray | None = None
) -> trimesh.Trimesh:
    """Every tile's solid (:func:`tile_mesh`) placed in the world, in one mesh; ``resolution``
    is one cell size (m) for every rough tile or an array of each tile's (indexed like the
    terrain's tiles; NaN for tile_mesh's default).

    Each tile stays a closed body (walls between tiles are kept, so the whole is watertight
    and ``mesh.split()`` gives the tiles back); tiles with the same geometry are built once.
    All tiles share one bottom: ``floor``, lowered to :data:`MIN_THICKNESS` below the
    terrain's lowest point when needed. ``mesh.metadata["face_tile"]`` holds the tile index
    (``row * cols + col``) of every face, for per-tile materials.
    """
    import trimesh

    terrain = _terrain_of(scene_or_terrain)
    if terrain is None:
        raise ValueError("a terrain mesh needs a terrain; this scene has none (its ground is z = 0)")
    _table(terrain)  # checks the tile count
    s = terrain.tile_size
    bottom = solid_bottom(min(tile_kind(t).lowest(t, s) for t in terrain.tiles), floor)
    each = np.asarray(np.nan if resolution is None else resolution, dtype=np.float64)
    each = np.broadcast_to(each, len(terrain.tiles))
    groups: dict[tuple, list[int]] = {}
    for k, tile in enumerate(terrain.tiles):
        res = None if math.isnan(each[k]) else float(each[k])
        groups.setdefault((_geometry_key(tile), res), []).append(k)
    all_verts, all_faces, face_tile = [], [], []
    count = 0
    for (_, res), members in groups.items():  # insertion order: deterministic
        tile = terrain.tiles[members[0]]
        verts, faces = tile_kind(tile).solid(tile, s, bottom, res)
        ids = np.asarray(members)
        ox, oy = terrain.origin
        shift = np.c_[ox + (ids % terrain.cols) * s, oy + (ids // terrain.cols) * s, np.zeros(ids.size)]
        placed = verts[None, :, :] + shift[:, None, :]
        offsets = count + len(verts) * np.arange(ids.size)
        all_verts.append(placed.reshape(-1, 3))
        all_faces.append((faces[None, :, :] + offsets[:, None, None]).reshape(-1, 3))
        face_tile.append(np.repeat(ids, len(faces)))
        count += placed.shape[0] * placed.shape[1]
    # Terrain features: a closed box per part, labelled with the tile under its centre.
    box_faces = trimesh.creation.box().faces
    for f in terrain.features or ():
        col = int(np.clip((f.center[0] - terrain.origin[0]) // s, 0, terrain.cols - 1))
        row = int(np.clip((f.center[1] - terrain.origin[1]) // s, 0, terrain.rows - 1))
        for part in feature_boxes(f):
            corners = box_corners(part)
            all_verts.append(corners)  # in trimesh's box order (x slowest, z fastest)
            all_faces.append(box_faces + count)
            face_tile.append(np.full(len(box_faces), row * terrain.cols + col))
            count += 8
    mesh = trimesh.Trimesh(np.concatenate(all_verts), np.concatenate(all_faces), process=False)
    mesh.metadata["face_tile"] = np.concatenate(face_tile)
    return mesh
