"""Tile kinds: what each terrain tile class is, its heights and its solid, in one registry.

:data:`TILE_KINDS` maps each tile class of the spec (:data:`citygen.spec.terrain.TILE_TYPES`)
to its :class:`TileKind`: its parameters in the vectorised height tables and its relief
formula (what :func:`~citygen.geometry.terrain.height_at` adds to the tile's height), its
lowest point, its closed solid (:func:`tile_mesh`), its boxes where it is made of boxes
(:func:`tile_boxes`), its steepest gradient, its riser, and whether it is level ground.
Readers dispatch through it (``tile_kind(tile).solid(...)``), never on the kind's name; a
new tile kind is its model in the spec, its functions here and its line in the registry.

The rules the formulas follow are :mod:`citygen.geometry.terrain`'s (and
:mod:`citygen.spec.terrain`'s); units are metres, Z up, local coordinates ``u, v`` in
``[0, tile_size]`` from the tile's minimum corner.

>>> tile_kind(StairTile(kind="stair", step_height=0.1, step_count=2)).name
'stair'
>>> [kind.name for kind in TILE_KINDS.values()]
['flat', 'slope', 'stair', 'rough']
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from citygen.geometry.noise import FADE_MAX_SLOPE, mix64, node, noise_key, rough_noise, rough_noise_grid
from citygen.spec.terrain import FlatTile, RoughTile, SlopeTile, StairTile, peak

if TYPE_CHECKING:
    import trimesh

AnyTile = FlatTile | SlopeTile | StairTile | RoughTile

#: Thinnest solid (m) below a tile's lowest point: a requested floor above it is lowered.
MIN_THICKNESS = 0.05
#: Most grid cells along one side of a rough tile's mesh.
MAX_ROUGH_CELLS = 1024
#: Cells along one side of a rough tile's mesh when no resolution is given, at most.
DEFAULT_ROUGH_CELLS = 256

_ASCENTS = ("+x", "-x", "+y", "-y")  # code: bit 1 = along y, bit 0 = descending coordinate


# --- tile parameters as arrays --------------------------------------------------------


@dataclass(frozen=True)
class HeightTable:
    """Every tile's parameters as arrays indexed by tile number, for vectorised lookups."""

    size: float
    kind: np.ndarray  # int8 code: the kind's place in TILE_KINDS
    h: np.ndarray  # base height, m
    a: np.ndarray  # slope: tan(angle); stair: step height (m); rough: amplitude (m)
    n: np.ndarray  # stair: step count
    asc: np.ndarray  # ascent code, index into _ASCENTS
    sign: np.ndarray  # 0 a flight, +1 a pyramid, -1 a pit
    scale: np.ndarray  # rough: wavelength (m); 1 elsewhere
    key: np.ndarray  # rough: noise key


Row = dict[str, Any]
"""A tile's entries in a :class:`HeightTable` beyond its kind and height (``a``, ``n``,
``asc``, ``sign``, ``scale``, ``seed``; those left out keep their defaults 0, 0, 0, 0, 1, 0)."""


def build_table(tiles: tuple[AnyTile, ...] | list[AnyTile], size: float) -> HeightTable:
    """The tiles' parameters as a :class:`HeightTable` (tiles of side ``size`` m)."""
    m = len(tiles)
    kind = np.array([KIND_CODES[type(t)] for t in tiles], dtype=np.int8)
    h = np.array([t.height for t in tiles], dtype=np.float64)
    columns = {
        "a": np.zeros(m),
        "n": np.zeros(m, dtype=np.int64),
        "asc": np.zeros(m, dtype=np.int8),
        "sign": np.zeros(m),
        "scale": np.ones(m),
        "seed": np.zeros(m, dtype=np.uint64),
    }
    for k in np.flatnonzero(kind != KIND_CODES[FlatTile]).tolist():
        t = tiles[k]
        for name, value in TILE_KINDS[type(t)].row(t).items():
            columns[name][k] = value
    c = columns
    return HeightTable(size, kind, h, c["a"], c["n"], c["asc"], c["sign"], c["scale"], noise_key(c["seed"]))


def evaluate(tab: HeightTable, t: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Heights (m) at local coordinates ``u, v`` in ``[0, size]`` of tiles ``t`` (1-d arrays):
    each tile's height plus its kind's relief."""
    kind = tab.kind[t]
    z = tab.h[t]
    for code, entry in enumerate(TILE_KINDS.values()):
        if entry.relief is None:
            continue
        sel = np.flatnonzero(kind == code)
        if sel.size:
            z[sel] += entry.relief(tab, t[sel], u[sel], v[sel])
    return z


def _sign(tile: AnyTile) -> float:
    """0 for a flight (or a tile that is neither slope nor stair), +1 a pyramid, -1 a pit."""
    shape = getattr(tile, "shape", None)
    return 0.0 if shape is None else 1.0 if shape == "pyramid" else -1.0


def _flight_row(tile: SlopeTile | StairTile) -> Row:
    return {"asc": _ASCENTS.index(tile.ascent), "sign": _sign(tile)}


def _flight_frame(tab: HeightTable, t: np.ndarray, u: np.ndarray, v: np.ndarray):
    """For slope and stair tiles ``t``: whether each is a flight, its distance (m) from a
    flight's low edge, and from a pyramid's (or pit's) nearest edge."""
    s = tab.size
    asc, flight = tab.asc[t], tab.sign[t] == 0
    along = np.where(asc & 2, v, u)
    low = np.where(asc & 1, s - along, along)  # a flight: distance from its low edge
    edge = np.minimum(np.minimum(u, v), np.minimum(s - u, s - v))  # pyramid, pit
    return flight, low, edge


# --- heights of one tile ------------------------------------------------------------------


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
    z = evaluate(build_table([tile], tile_size), np.zeros(uu.size, dtype=np.int64), uu, vv)
    return z.reshape(shape)


def tile_grid(tile: AnyTile, tile_size: float, us, vs) -> np.ndarray:
    """Heights (m) of one tile on a grid: ``z[i, j]`` is ``tile_height(tile, tile_size, us[j],
    vs[i])`` bit for bit (``us``, ``vs``: 1-d local coordinates in m, each clipped to
    ``[0, tile_size]``), computed per axis where the kind's formula allows (a rough tile's
    lattice is hashed once per node, not four times per sample).

    >>> tile = RoughTile(kind="rough", amplitude=0.1, scale=1.0, seed=3)
    >>> g = np.linspace(0.0, 2.0, 9)
    >>> bool((tile_grid(tile, 2.0, g, g) == tile_height(tile, 2.0, g[None, :], g[:, None])).all())
    True
    """
    u = np.clip(np.asarray(us, dtype=np.float64).ravel(), 0.0, tile_size)
    v = np.clip(np.asarray(vs, dtype=np.float64).ravel(), 0.0, tile_size)
    grid = tile_kind(tile).grid
    if grid is None or not (u.size and v.size):
        return tile_height(tile, tile_size, u[None, :], v[:, None])
    return grid(tile, tile_size, u, v)


# --- slope and stair tiles ------------------------------------------------------------------


def _slope_row(tile: SlopeTile) -> Row:
    return {**_flight_row(tile), "a": math.tan(tile.angle)}


def _slope_relief(tab: HeightTable, t: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """A flight rises ``tan(angle)`` per metre from its low edge; a pyramid (pit) as far as
    its platform, a third of the tile from the edges."""
    flight, low, edge = _flight_frame(tab, t, u, v)
    run = np.where(flight, low, np.minimum(edge, tab.size / 3.0))
    return np.where(flight, 1.0, tab.sign[t]) * tab.a[t] * run


def _stair_row(tile: StairTile) -> Row:
    return {**_flight_row(tile), "a": tile.step_height, "n": tile.step_count}


def _stair_relief(tab: HeightTable, t: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """A riser per tread passed: treads of s / (n + 1) along a flight, s / (2n + 2) from a
    pyramid's edges; a riser belongs to the tread past it, also where rounding puts it a
    hair before it."""
    s, steps = tab.size, tab.n[t]
    flight, low, edge = _flight_frame(tab, t, u, v)
    treads = np.where(flight, low * (steps + 1) / s, edge * (2 * steps + 2) / s)
    treads = np.minimum(np.floor(treads + 1e-9), steps)
    return np.where(flight, 1.0, tab.sign[t]) * tab.a[t] * treads


# --- rough tiles ------------------------------------------------------------------------------


def _rough_row(tile: RoughTile) -> Row:
    return {"a": tile.amplitude, "scale": tile.scale, "seed": tile.seed}


def _rough_relief(tab: HeightTable, t: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    return tab.a[t] * rough_noise(tab.key[t], tab.scale[t], tab.size, u, v)


def _rough_grid(tile: RoughTile, tile_size: float, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    noise = rough_noise_grid(noise_key(tile.seed)[0], float(tile.scale), tile_size, u, v)
    return np.float64(tile.height) + np.float64(tile.amplitude) * noise


def _rough_gradient(tab: HeightTable, t: np.ndarray) -> np.ndarray:
    """For amplitude ``A``, scale ``L`` and taper width ``w = min(L, tile_size / 4)``:
    ``A * sqrt(2) * 1.875 * (4 / L + 1 / w)``."""
    w = np.minimum(tab.scale[t], tab.size / 4.0)
    return tab.a[t] * math.sqrt(2.0) * FADE_MAX_SLOPE * (4.0 / tab.scale[t] + 1.0 / w)


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
    table = node(mix64(noise_key(tile.seed)[0] ^ nodes)[None, :], nodes[:, None])
    step = max(np.abs(np.diff(table, axis=0)).max(), np.abs(np.diff(table, axis=1)).max())
    return (
        abs(float(tile.amplitude)) * FADE_MAX_SLOPE * (float(step) / spacing + float(np.abs(table).max()) / w)
    )


# --- solids -------------------------------------------------------------------------------


def _level_lowest(tile: FlatTile | SlopeTile | StairTile, s: float) -> float:
    """A flat, slope or stair tile's lowest point (m): its height, or a pit's floor."""
    return tile.height + min(0.0, peak(tile, s))


def _rough_lowest(tile: RoughTile, s: float) -> float:
    """A rough tile's deepest possible dip (m)."""
    return tile.height - tile.amplitude


def _slope_solid(tile: SlopeTile, s: float, bottom: float, resolution: float | None):
    """A flight's wedge; a pyramid's or pit's planes between the edges and the platform."""
    if _sign(tile):
        return _closed_heightfield(tile, s, bottom, np.array([0.0, s / 3.0, 2.0 * s / 3.0, s]))
    return _prism(tile, s, bottom)


def _stair_solid(tile: StairTile, s: float, bottom: float, resolution: float | None):
    """A flight of steps extruded; a pyramid or pit as the union of its boxes."""
    if _sign(tile):
        return _union_of_boxes(_stair_boxes(tile, s, bottom))
    return _prism(tile, s, bottom)


def _rough_solid(tile: RoughTile, s: float, bottom: float, resolution: float | None):
    """The surface sampled on a grid of :func:`_cells` cells a side, walled and floored."""
    return _closed_heightfield(tile, s, bottom, np.linspace(0.0, s, _cells(tile, s, resolution) + 1))


def solid_bottom(lowest: float, floor: float) -> float:
    """The bottom (m) of a solid whose top's lowest point is ``lowest``: ``floor``, lowered to
    :data:`MIN_THICKNESS` below that point where needed."""
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
    kind = tile_kind(tile)
    if kind.boxes is None:
        raise TypeError(f"only flat and stair tiles are boxes; a {tile.kind} tile is a mesh (tile_mesh)")
    return kind.boxes(tile, tile_size, solid_bottom(kind.lowest(tile, tile_size), floor))


def _flat_boxes(tile: FlatTile, s: float, bottom: float) -> np.ndarray:
    return np.array([[[0.0, 0.0, bottom], [s, s, tile.height]]])


def _stair_boxes(tile: StairTile, s: float, bottom: float) -> np.ndarray:
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

    kind = tile_kind(tile)
    verts, faces = kind.solid(tile, tile_size, solid_bottom(kind.lowest(tile, tile_size), floor), resolution)
    return trimesh.Trimesh(verts, faces, process=False)


# --- the registry ---------------------------------------------------------------------------


Solid = Callable[[Any, float, float, "float | None"], tuple[np.ndarray, np.ndarray]]
"""``(tile, tile_size, bottom, resolution) -> (vertices, faces)``: the tile's closed solid in
its local frame, from ``bottom`` (m) up; ``resolution`` (m) is the sample spacing of a
sampled surface (None: the kind's default)."""


@dataclass(frozen=True)
class TileKind:
    """One tile class and what every reader of the terrain needs of it (see the module docstring)."""

    model: type
    """The spec's tile class."""
    row: Callable[[Any], Row]
    """Its parameters in a :class:`HeightTable`."""
    relief: Callable[[HeightTable, np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None
    """``(table, tiles, u, v)``: height (m) above the tiles' own at local points; None: level."""
    lowest: Callable[[Any, float], float]
    """``(tile, tile_size)``: its lowest point (m)."""
    solid: Solid
    level: Callable[[Any], bool]
    """Whether the tile is level ground at its height throughout (no incline, step or bump)."""
    riser: Callable[[Any], float] = lambda tile: 0.0
    """Its highest vertical step (m) inside it (a stair's riser; 0 elsewhere)."""
    boxes: Callable[[Any, float, float], np.ndarray] | None = None
    """``(tile, tile_size, bottom)``: the boxes it is made of, when it is (flat and stair tiles)."""
    gradient: Callable[[HeightTable, np.ndarray], np.ndarray] | None = None
    """``(table, tiles)``: a bound on each tile's gradient (m/m) away from risers; None: 0."""
    grid: Callable[[Any, float, np.ndarray, np.ndarray], np.ndarray] | None = None
    """``(tile, tile_size, us, vs)``: :func:`tile_grid` computed per axis, where faster."""

    @property
    def name(self) -> str:
        """The kind's name in the spec (its ``kind`` field)."""
        return self.model.model_fields["kind"].annotation.__args__[0]


#: Every tile kind, by its spec class, in the spec's order (:data:`~citygen.spec.terrain.TILE_TYPES`).
TILE_KINDS: dict[type, TileKind] = {
    FlatTile: TileKind(
        FlatTile,
        row=lambda tile: {},
        relief=None,
        lowest=_level_lowest,
        solid=lambda tile, s, bottom, resolution: _prism(tile, s, bottom),
        level=lambda tile: True,
        boxes=_flat_boxes,
    ),
    SlopeTile: TileKind(
        SlopeTile,
        row=_slope_row,
        relief=_slope_relief,
        lowest=_level_lowest,
        solid=_slope_solid,
        level=lambda tile: tile.angle == 0.0,
        gradient=lambda tab, t: tab.a[t],
    ),
    StairTile: TileKind(
        StairTile,
        row=_stair_row,
        relief=_stair_relief,
        lowest=_level_lowest,
        solid=_stair_solid,
        level=lambda tile: False,
        riser=lambda tile: tile.step_height,
        boxes=_stair_boxes,
    ),
    RoughTile: TileKind(
        RoughTile,
        row=_rough_row,
        relief=_rough_relief,
        lowest=_rough_lowest,
        solid=_rough_solid,
        level=lambda tile: tile.amplitude == 0.0,
        gradient=_rough_gradient,
        grid=_rough_grid,
    ),
}
#: Each kind's code in a :class:`HeightTable`: its place in :data:`TILE_KINDS`.
KIND_CODES: dict[type, int] = {model: code for code, model in enumerate(TILE_KINDS)}


def tile_kind(tile: AnyTile) -> TileKind:
    """The registry's entry for ``tile``'s class.

    Raises :class:`TypeError` for anything but a tile of the spec.
    """
    try:
        return TILE_KINDS[type(tile)]
    except KeyError:
        raise TypeError(f"not a terrain tile: {tile!r}") from None
