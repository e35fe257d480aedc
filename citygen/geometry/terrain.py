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
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from citygen.geometry.features import box_corners, feature_boxes, raise_heights
from citygen.spec.scene import Scene
from citygen.spec.terrain import FlatTile, RoughTile, SlopeTile, StairTile, Terrain, feature_top, peak

if TYPE_CHECKING:
    import trimesh

AnyTile = FlatTile | SlopeTile | StairTile | RoughTile

#: Thinnest solid (m) below a tile's lowest point: a requested floor above it is lowered.
MIN_THICKNESS = 0.05
#: Most samples :func:`heightfield` returns (about 512 MiB of float64).
MAX_HEIGHTFIELD_SAMPLES = 1 << 26
#: Most grid cells along one side of a rough tile's mesh.
MAX_ROUGH_CELLS = 1024
#: Cells along one side of a rough tile's mesh when no resolution is given, at most.
DEFAULT_ROUGH_CELLS = 256

_FLAT, _SLOPE, _STAIR, _ROUGH = 0, 1, 2, 3
_KIND_CODE = {FlatTile: _FLAT, SlopeTile: _SLOPE, StairTile: _STAIR, RoughTile: _ROUGH}
_ASCENTS = ("+x", "-x", "+y", "-y")  # code: bit 1 = along y, bit 0 = descending coordinate
_FADE_MAX_SLOPE = 1.875  # max of d/dt (6t^5 - 15t^4 + 10t^3)
_CHUNK = 1 << 20  # points per block in heightfield(), to bound temporaries


# --- the noise of rough tiles -------------------------------------------------------


def _mix64(z: np.ndarray) -> np.ndarray:
    """SplitMix64's output function (Steele et al. 2014) on uint64 arrays, wrapping."""
    z = z + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def noise_key(seed: int | np.ndarray) -> np.ndarray:
    """The 64-bit key of a rough tile's noise: ``mix64(seed)``."""
    return _mix64(np.atleast_1d(np.asarray(seed, dtype=np.uint64)))


def _lattice(key: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Node values in [-1, 1): ``mix64(mix64(key ^ i) ^ j)``, top 53 bits as a fraction."""
    return _node(_mix64(key ^ i), j)


def _node(column: np.ndarray, j: np.ndarray) -> np.ndarray:
    """:func:`_lattice` from its inner hash ``column = mix64(key ^ i)``, which the nodes of
    one lattice column share (so the corners of a cell need two inner hashes, not four)."""
    h = _mix64(column ^ j)
    return (h >> np.uint64(11)).astype(np.float64) * (2.0 / 2.0**53) - 1.0


def _fade(t: np.ndarray) -> np.ndarray:
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def _ramp(t: np.ndarray) -> np.ndarray:
    return _fade(np.clip(t, 0.0, 1.0))


def _rough(key: np.ndarray, scale: np.ndarray, s: float, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Tapered value noise in [-1, 1] at local coordinates ``u, v`` (m) of tiles of side ``s``."""
    spacing = scale / 2.0
    gx, gy = u / spacing, v / spacing
    fx0, fy0 = np.floor(gx), np.floor(gy)
    fx, fy = _fade(gx - fx0), _fade(gy - fy0)
    i, j = fx0.astype(np.uint64), fy0.astype(np.uint64)
    one = np.uint64(1)
    west, east, north = _mix64(key ^ i), _mix64(key ^ (i + one)), j + one
    a, b = _node(west, j), _node(east, j)
    c, d = _node(west, north), _node(east, north)
    n = (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy
    w = np.minimum(scale, s / 4.0)
    return n * (_ramp(u / w) * _ramp((s - u) / w) * _ramp(v / w) * _ramp((s - v) / w))


def _rough_grid(key: np.uint64, scale: float, s: float, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """:func:`_rough` of one tile on the grid ``u[None, :], v[:, None]`` (1-d arrays of local
    coordinates in ``[0, s]``, m), bit for bit: every factor that depends on one axis is
    computed once along it, the lattice hashed once per node and interpolated along x once
    per lattice row (``a * (1 - fx) + b * fx`` depends on a sample's row only through its
    lattice row), then the same products are formed in the same order."""
    kx = u.size
    spacing = scale / 2.0
    g = np.concatenate([u, v]) / spacing
    g0 = np.floor(g)
    f = _fade(g - g0)
    fx, fy = f[None, :kx], f[kx:, None]
    idx = g0.astype(np.uint64)
    i, j = idx[:kx], idx[kx:]
    i0, j0 = i.min(), j.min()
    ri, rj = (i - i0).astype(np.intp), (j - j0).astype(np.intp)
    span_i, span_j = int(ri.max()) + 2, int(rj.max()) + 2
    if span_i * span_j > 4 * u.size * v.size + 256:  # a grid much coarser than the lattice
        return _rough(key, np.float64(scale), s, u[None, :], v[:, None])
    nodes_i = i0 + np.arange(span_i, dtype=np.uint64)
    nodes_j = j0 + np.arange(span_j, dtype=np.uint64)
    # Node values of the lattice around the grid: rows along j, columns along i.
    table = _node(_mix64(key ^ nodes_i)[None, :], nodes_j[:, None])
    along_x = table[:, ri] * (1.0 - fx) + table[:, ri + 1] * fx  # [lattice row, sample column]
    n = along_x[rj] * (1.0 - fy) + along_x[rj + 1] * fy
    w = min(scale, s / 4.0)
    r = _ramp(np.concatenate([u / w, (s - u) / w, v / w, (s - v) / w]))
    ky = v.size
    ramp_u = r[:kx] * r[kx : 2 * kx]
    rv1, rv2 = r[2 * kx : 2 * kx + ky], r[2 * kx + ky :]
    return n * ((ramp_u[None, :] * rv1[:, None]) * rv2[:, None])


# --- tile parameters as arrays --------------------------------------------------------


@dataclass(frozen=True)
class _Table:
    """Every tile's parameters as arrays indexed by tile number, for vectorised lookups."""

    size: float
    kind: np.ndarray  # int8 code
    h: np.ndarray  # base height, m
    a: np.ndarray  # slope: tan(angle); stair: step height (m); rough: amplitude (m)
    n: np.ndarray  # stair: step count
    asc: np.ndarray  # ascent code, index into _ASCENTS
    sign: np.ndarray  # 0 a flight, +1 a pyramid, -1 a pit
    scale: np.ndarray  # rough: wavelength (m); 1 elsewhere
    key: np.ndarray  # rough: noise key


def _build_table(tiles: tuple[AnyTile, ...] | list[AnyTile], size: float) -> _Table:
    m = len(tiles)
    kind = np.array([_KIND_CODE[type(t)] for t in tiles], dtype=np.int8)
    h = np.array([t.height for t in tiles], dtype=np.float64)
    a, n = np.zeros(m), np.zeros(m, dtype=np.int64)
    asc, sign = np.zeros(m, dtype=np.int8), np.zeros(m)
    scale, seed = np.ones(m), np.zeros(m, dtype=np.uint64)
    for k in np.flatnonzero(kind != _FLAT).tolist():
        t = tiles[k]
        if isinstance(t, SlopeTile | StairTile):
            asc[k], sign[k] = _ASCENTS.index(t.ascent), _sign(t)
        if isinstance(t, SlopeTile):
            a[k] = math.tan(t.angle)
        elif isinstance(t, StairTile):
            a[k], n[k] = t.step_height, t.step_count
        else:
            a[k], scale[k], seed[k] = t.amplitude, t.scale, t.seed
    return _Table(size, kind, h, a, n, asc, sign, scale, noise_key(seed))


def _sign(tile: AnyTile) -> float:
    """0 for a flight (or a tile that is neither slope nor stair), +1 a pyramid, -1 a pit."""
    shape = getattr(tile, "shape", None)
    return 0.0 if shape is None else 1.0 if shape == "pyramid" else -1.0


_TABLES: dict[int, tuple[Terrain, _Table]] = {}


def _table(terrain: Terrain) -> _Table:
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
    table = _build_table(terrain.tiles, terrain.tile_size)
    _TABLES[id(terrain)] = (terrain, table)
    for key in list(_TABLES)[:-8]:  # oldest first; tolerant of other threads evicting too
        _TABLES.pop(key, None)
    return table


def _evaluate(tab: _Table, t: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Heights (m) at local coordinates ``u, v`` in ``[0, size]`` of tiles ``t`` (1-d arrays)."""
    s = tab.size
    kind = tab.kind[t]
    z = tab.h[t]
    ramps = np.flatnonzero((kind == _SLOPE) | (kind == _STAIR))
    if ramps.size:
        tr, uu, vv = t[ramps], u[ramps], v[ramps]
        asc, sign, steps = tab.asc[tr], tab.sign[tr], tab.n[tr]
        flight = sign == 0
        along = np.where(asc & 2, vv, uu)
        low = np.where(asc & 1, s - along, along)  # a flight: distance from its low edge
        edge = np.minimum(np.minimum(uu, vv), np.minimum(s - uu, s - vv))  # pyramid, pit
        # Treads of s / (n + 1) along a flight, s / (2n + 2) from a pyramid's edges; a riser
        # belongs to the tread past it, also where rounding puts it a hair before it.
        treads = np.where(flight, low * (steps + 1) / s, edge * (2 * steps + 2) / s)
        treads = np.minimum(np.floor(treads + 1e-9), steps)
        run = np.where(flight, low, np.minimum(edge, s / 3.0))
        climb = np.where(kind[ramps] == _STAIR, treads, run)
        z[ramps] += np.where(flight, 1.0, sign) * tab.a[tr] * climb
    rough = np.flatnonzero(kind == _ROUGH)
    if rough.size:
        tr = t[rough]
        z[rough] += tab.a[tr] * _rough(tab.key[tr], tab.scale[tr], s, u[rough], v[rough])
    return z


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
        z[inside] = _evaluate(tab, t, u, v)
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
    # take the noise computed per axis (the same operations on the same numbers as _rough).
    home_col, home_row = col[:, kx // 2], row[:, ky // 2]
    home = (home_row * cols + home_col).astype(np.int64)
    on_x = in_x & (col == home_col[:, None])
    on_y = in_y & (row == home_row[:, None])
    fast = np.flatnonzero(on_x[:, kx // 2] & on_y[:, ky // 2] & (tab.kind[home] == _ROUGH))
    done = np.zeros(t.shape, dtype=bool)
    if fast.size:
        ht = home[fast][:, None, None]
        noise = _rough(tab.key[ht], tab.scale[ht], s, u[fast][:, None, :], v[fast][:, :, None])
        here = on_y[fast][:, :, None] & on_x[fast][:, None, :]
        z[fast] = np.where(here, tab.h[ht] + tab.a[ht] * noise, 0.0)
        done[fast] = here
    rest = inside & ~done
    if rest.any():
        ub, vb = np.broadcast_to(u[:, None, :], t.shape), np.broadcast_to(v[:, :, None], t.shape)
        z[rest] = _evaluate(tab, t[rest], ub[rest], vb[rest])
    if terrain.features:
        xb, yb = np.broadcast_to(x[:, None, :], t.shape), np.broadcast_to(y[:, :, None], t.shape)
        flat = z.reshape(-1)
        raise_heights(terrain.features, xb.reshape(-1), yb.reshape(-1), flat)
        z = flat.reshape(t.shape)
    z[np.isnan(y)[:, :, None] | np.isnan(x)[:, None, :]] = np.nan
    return z.reshape(*lead, ky, kx)


def tile_height(tile: AnyTile, tile_size: float, u, v) -> np.ndarray:
    """Height (m) of one tile at local coordinates ``u, v`` (m, broadcastable), each clipped
    to ``[0, tile_size]``; the tile's minimum corner is ``u = v = 0``.

    >>> tile_height(SlopeTile(kind="slope", angle=0.1, ascent="-y"), 2.0, 0.5, [0.0, 2.0]).round(4)
    array([0.2007, 0.    ])
    """
    u, v = np.broadcast_arrays(np.asarray(u, dtype=np.float64), np.asarray(v, dtype=np.float64))
    shape = u.shape
    uu = np.clip(u.ravel(), 0.0, tile_size)
    vv = np.clip(v.ravel(), 0.0, tile_size)
    z = _evaluate(_build_table([tile], tile_size), np.zeros(uu.size, dtype=np.int64), uu, vv)
    return z.reshape(shape)


#: Largest slope of the fade curve ``6t^5 - 15t^4 + 10t^3`` on [0, 1] (at t = 1/2).
_FADE_SLOPE = 1.875


def rough_slope_bound(tile: RoughTile, tile_size: float) -> float:
    """An upper bound on the slope (m per m, along x or y) of a rough tile's surface, from its
    lattice alone: the noise changes by at most ``1.875 * max |node step| / spacing`` per
    metre inside a lattice cell (``1.875``, the fade's steepest slope; ``node step``, the
    difference of two neighbouring node values), and the taper by at most ``1.875 / w``
    (its ramps, of width ``w <= tile_size / 4``, never overlap) on a noise of at most
    ``max |node|``. So two points ``d`` m apart differ by at most ``d`` times this (plus
    rounding), for a few hundred node hashes instead of a tile's samples.

    >>> tile = RoughTile(kind="rough", amplitude=0.05, scale=1.0, seed=3)
    >>> g = np.linspace(0.0, 2.5, 201)
    >>> z = tile_grid(tile, 2.5, g, g)
    >>> bool(np.abs(np.diff(z, axis=1)).max() <= rough_slope_bound(tile, 2.5) * (g[1] - g[0]))
    True
    """
    spacing = float(tile.scale) / 2.0
    w = min(float(tile.scale), tile_size / 4.0)
    nodes = np.arange(math.floor(tile_size / spacing) + 2, dtype=np.uint64)
    table = _node(_mix64(noise_key(tile.seed)[0] ^ nodes)[None, :], nodes[:, None])
    step = max(np.abs(np.diff(table, axis=0)).max(), np.abs(np.diff(table, axis=1)).max())
    return abs(float(tile.amplitude)) * _FADE_SLOPE * (float(step) / spacing + float(np.abs(table).max()) / w)


def tile_grid(tile: AnyTile, tile_size: float, us, vs) -> np.ndarray:
    """Heights (m) of one tile on a grid: ``z[i, j]`` is ``tile_height(tile, tile_size, us[j],
    vs[i])`` bit for bit (``us``, ``vs``: 1-d local coordinates in m, each clipped to
    ``[0, tile_size]``), computed per axis where the formula allows (a rough tile's lattice
    is hashed once per node, not four times per sample).

    >>> tile = RoughTile(kind="rough", amplitude=0.1, scale=1.0, seed=3)
    >>> g = np.linspace(0.0, 2.0, 9)
    >>> bool((tile_grid(tile, 2.0, g, g) == tile_height(tile, 2.0, g[None, :], g[:, None])).all())
    True
    """
    u = np.clip(np.asarray(us, dtype=np.float64).ravel(), 0.0, tile_size)
    v = np.clip(np.asarray(vs, dtype=np.float64).ravel(), 0.0, tile_size)
    if not isinstance(tile, RoughTile) or not (u.size and v.size):
        return tile_height(tile, tile_size, u[None, :], v[:, None])
    noise = _rough_grid(noise_key(tile.seed)[0], float(tile.scale), tile_size, u, v)
    return np.float64(tile.height) + np.float64(tile.amplitude) * noise


def max_step(scene_or_terrain: Scene | Terrain | None) -> float:
    """The largest vertical discontinuity (m) the terrain may legitimately have inside its
    grid: its largest stair riser, 0 without stairs, or the rise of a feature's vertical
    side where it is higher. (Where the grid's outer edge is not at z = 0 the ground also
    drops to 0 there; that edge is not counted.)"""
    terrain = _terrain_of(scene_or_terrain)
    if terrain is None:
        return 0.0
    step = max((t.step_height for t in terrain.tiles if isinstance(t, StairTile)), default=0.0)
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
    slopes = np.where(tab.kind == _SLOPE, tab.a, 0.0)
    w = np.minimum(tab.scale, tab.size / 4.0)
    rough = tab.a * math.sqrt(2.0) * _FADE_MAX_SLOPE * (4.0 / tab.scale + 1.0 / w)
    slopes = np.maximum(slopes, np.where(tab.kind == _ROUGH, rough, 0.0))
    return float(slopes.max(initial=0.0))


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


# --- solids -------------------------------------------------------------------------------


def _lowest(tile: AnyTile, s: float) -> float:
    """The tile's lowest point (m): a pit's floor, a rough tile's deepest possible dip."""
    if isinstance(tile, RoughTile):
        return tile.height - tile.amplitude
    return tile.height + min(0.0, peak(tile, s))


def _bottom(lowest: float, floor: float) -> float:
    if not math.isfinite(floor):
        raise ValueError(f"floor must be a finite height in metres, got {floor!r}")
    return min(floor, lowest - MIN_THICKNESS)


def tile_boxes(tile: FlatTile | StairTile, tile_size: float, *, floor: float = -1.0) -> np.ndarray:
    """A flat or stair tile as boxes that tile it without overlapping (convex parts for
    physics engines): an array of shape ``(k, 2, 3)`` of ``[min corner, max corner]`` in
    metres, in the tile's local frame (minimum corner at the origin), each from the floor
    (see :func:`tile_mesh`) up to its tread. A flight has one box per tread; a pyramid or a
    pit four per ring of treads and one for the central platform.

    >>> tile_boxes(StairTile(kind="stair", step_height=0.1, step_count=1), 2.0)[:, 1].tolist()
    [[1.0, 2.0, 0.0], [2.0, 2.0, 0.1]]
    """
    if not isinstance(tile, FlatTile | StairTile):
        raise TypeError(f"only flat and stair tiles are boxes; a {tile.kind} tile is a mesh (tile_mesh)")
    return _boxes(tile, tile_size, _bottom(_lowest(tile, tile_size), floor))


def _boxes(tile: FlatTile | StairTile, s: float, bottom: float) -> np.ndarray:
    if isinstance(tile, FlatTile):
        return np.array([[[0.0, 0.0, bottom], [s, s, tile.height]]])
    n, sign = tile.step_count, _sign(tile)
    if sign:  # rings of treads of depth d around a central platform
        d = s / (2 * n + 2)
        rects = []
        for k in range(n):
            a, b, c, e = k * d, (k + 1) * d, s - (k + 1) * d, s - k * d
            rects += [(a, a, e, b, k), (a, c, e, e, k), (a, b, b, c, k), (c, b, e, c, k)]
        rects.append((n * d, n * d, s - n * d, s - n * d, n))
        r = np.array(rects)
        tops = tile.height + sign * tile.step_height * r[:, 4]
        return np.stack([np.c_[r[:, 0:2], np.full(len(r), bottom)], np.c_[r[:, 2:4], tops]], axis=1)
    edges = np.linspace(0.0, s, n + 2)
    lo, hi = edges[:-1], edges[1:]
    if tile.ascent.startswith("-"):
        lo, hi = s - hi, s - lo
    tops = tile.height + tile.step_height * np.arange(n + 1)
    boxes = np.zeros((n + 1, 2, 3))
    along = 1 if tile.ascent.endswith("y") else 0
    boxes[:, 0, along], boxes[:, 1, along] = lo, hi
    boxes[:, 1, 1 - along] = s
    boxes[:, 0, 2], boxes[:, 1, 2] = bottom, tops
    return boxes


def _union_of_boxes(boxes: np.ndarray):
    """The union of boxes that touch face to face, as one closed solid (manifold3d)."""
    import manifold3d

    parts = [manifold3d.Manifold.cube(tuple(hi - lo)).translate(tuple(lo)) for lo, hi in boxes]
    mesh = manifold3d.Manifold.batch_boolean(parts, manifold3d.OpType.Add).to_mesh64()
    return np.asarray(mesh.vert_properties)[:, :3].astype(np.float64), np.asarray(mesh.tri_verts, np.int64)


def _profile(tile: FlatTile | SlopeTile | StairTile, s: float, bottom: float) -> np.ndarray:
    """The tile's cross-section along its ascent: ``(d, z)`` points, counter-clockwise."""
    h = tile.height
    if isinstance(tile, FlatTile):
        return np.array([[0.0, bottom], [s, bottom], [s, h], [0.0, h]])
    if isinstance(tile, SlopeTile):
        return np.array([[0.0, bottom], [s, bottom], [s, h + s * math.tan(tile.angle)], [0.0, h]])
    n, rise = tile.step_count, tile.step_height
    edges = np.linspace(0.0, s, n + 2)
    top = [[s, h + n * rise]]
    for k in range(n, 0, -1):  # along the treads from the top, down each riser
        top += [[edges[k], h + k * rise], [edges[k], h + (k - 1) * rise]]
    return np.array([[0.0, bottom], [s, bottom], *top, [0.0, h]])


def _prism(tile: FlatTile | SlopeTile | StairTile, s: float, bottom: float):
    """The tile's cross-section extruded across the tile: closed, outward-facing triangles."""
    import manifold3d

    poly = _profile(tile, s, bottom)
    m = len(poly)
    caps = np.asarray(manifold3d.triangulate([poly]), dtype=np.int64)
    # In the frame (d, z, w), counter-clockwise caps face +w.
    dzw = np.concatenate([np.c_[poly, np.zeros(m)], np.c_[poly, np.full(m, s)]])
    ring = np.arange(m)
    nxt = np.roll(ring, -1)
    sides = np.concatenate([np.c_[ring, nxt, nxt + m], np.c_[ring, nxt + m, ring + m]])
    faces = np.concatenate([caps[:, ::-1], caps + m, sides])
    ascent = getattr(tile, "ascent", "+x")
    d, z, w = dzw.T
    d = s - d if ascent.startswith("-") else d
    xyz = np.c_[d, w, z] if ascent.endswith("x") else np.c_[w, d, z]
    # The map (d, z, w) -> world is a permutation, possibly mirrored: keep faces outward.
    mirrored = (ascent.endswith("x")) != ascent.startswith("-")
    return xyz, faces[:, ::-1] if mirrored else faces


def _cells(tile: RoughTile, s: float, resolution: float | None) -> int:
    if resolution is None:
        # Four cells per lattice spacing and per taper band resolve the fade's curvature.
        cell = min(tile.scale / 8.0, min(tile.scale, s / 4.0) / 4.0)
        return min(math.ceil(s / cell - 1e-9), DEFAULT_ROUGH_CELLS)
    if not (math.isfinite(resolution) and resolution > 0):
        raise ValueError(f"resolution must be a positive number of metres, got {resolution!r}")
    return int(np.clip(math.ceil(s / resolution - 1e-9), 1, MAX_ROUGH_CELLS))


def _closed_heightfield(tile: RoughTile | SlopeTile, s: float, bottom: float, g: np.ndarray):
    """A tile's surface sampled at ``g x g`` (local coordinates in m), walled and floored."""
    k = len(g)
    u, v = np.meshgrid(g, g)  # v[i, j] = g[i], u[i, j] = g[j]
    top = np.c_[u.ravel(), v.ravel(), tile_height(tile, s, u, v).ravel()]
    idx = np.arange(k * k).reshape(k, k)
    a, b, c, d = (q.ravel() for q in (idx[:-1, :-1], idx[:-1, 1:], idx[1:, 1:], idx[1:, :-1]))
    # Cut each cell along the diagonal pointing away from the tile's centre, where a
    # pyramid's ridges run, so that its planes are exact.
    mid = (g[:-1] + g[1:]) / 2.0 - s / 2.0
    outward = ((mid[:, None] * mid[None, :]) >= 0).ravel()
    surface = np.concatenate(
        [
            np.where(outward[:, None], np.c_[a, b, c], np.c_[a, b, d]),
            np.where(outward[:, None], np.c_[a, c, d], np.c_[b, c, d]),
        ]
    )
    # The border, counter-clockwise seen from above; its heights are the tile's level.
    loop = np.concatenate([idx[0, :-1], idx[:-1, -1], idx[-1, :0:-1], idx[:0:-1, 0]])
    base = k * k
    low = base + np.arange(loop.size)
    center = base + loop.size
    verts = np.concatenate([top, np.c_[top[loop, :2], np.full(loop.size, bottom)], [[s / 2, s / 2, bottom]]])
    lo_next, hi_next = np.roll(low, -1), np.roll(loop, -1)
    walls = np.concatenate([np.c_[low, lo_next, hi_next], np.c_[low, hi_next, loop]])
    floor = np.c_[np.full(loop.size, center), lo_next, low]
    return verts, np.concatenate([surface, walls, floor])


def _tile_arrays(tile: AnyTile, s: float, bottom: float, resolution: float | None):
    if isinstance(tile, RoughTile):
        return _closed_heightfield(tile, s, bottom, np.linspace(0.0, s, _cells(tile, s, resolution) + 1))
    if _sign(tile) and isinstance(tile, SlopeTile):  # planes between the edges and the platform
        return _closed_heightfield(tile, s, bottom, np.array([0.0, s / 3.0, 2.0 * s / 3.0, s]))
    if _sign(tile):
        return _union_of_boxes(_boxes(tile, s, bottom))
    return _prism(tile, s, bottom)


def tile_mesh(
    tile: AnyTile, tile_size: float, *, floor: float = -1.0, resolution: float | None = None
) -> trimesh.Trimesh:
    """One tile as a closed, watertight solid in its local frame (minimum corner at the
    origin, ``x, y`` in ``[0, tile_size]``, ``z`` the tile's own heights in metres).

    Flat, slope and stair tiles are exact: prisms (a box, a wedge, an extruded flight of
    steps), a pyramid's or pit's planes, or the union of its :func:`tile_boxes`. A rough
    tile is its surface sampled on a square grid of spacing ``resolution`` metres (default
    ``scale / 8``, finer for a narrow taper band, at most 256 cells a side; at most 1024
    when given), whose vertices lie exactly on :func:`tile_height`, with walls and a floor. The bottom is at
    ``z = floor`` (m), lowered to :data:`MIN_THICKNESS` below the tile's lowest point when
    the floor is not that far below it.
    """
    import trimesh

    verts, faces = _tile_arrays(tile, tile_size, _bottom(_lowest(tile, tile_size), floor), resolution)
    return trimesh.Trimesh(verts, faces, process=False)


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
    bottom = _bottom(min(_lowest(t, s) for t in terrain.tiles), floor)
    each = np.asarray(np.nan if resolution is None else resolution, dtype=np.float64)
    each = np.broadcast_to(each, len(terrain.tiles))
    groups: dict[tuple, list[int]] = {}
    for k, tile in enumerate(terrain.tiles):
        res = None if math.isnan(each[k]) else float(each[k])
        groups.setdefault((_geometry_key(tile), res), []).append(k)
    all_verts, all_faces, face_tile = [], [], []
    count = 0
    for (_, res), members in groups.items():  # insertion order: deterministic
        verts, faces = _tile_arrays(terrain.tiles[members[0]], s, bottom, res)
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
