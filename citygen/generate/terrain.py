"""Stage 3: terrain tiles, by Wave Function Collapse or as a locomotion difficulty grid.

**Mixed urban terrain** (``layout="wfc"``, :func:`build_terrain`). WFC
(:mod:`citygen.generate.wfc`) places discrete *level tokens*: flat and rough tiles at a
ground level ``0 .. LEVELS - 1``, and slope and stair flights from one level to the next
in each of the four ascent directions. Their sockets are derived from the spec's own
:func:`~citygen.spec.terrain.edge_profile` of symbolic tiles (heights = level numbers), so
WFC places only neighbours whose shared edges :func:`citygen.validate` accepts. The
continuous parameters are sampled afterwards, once per *level boundary*: each boundary
gets one rise, and every slope across it the angle ``atan(rise / tile_size)``, every
stair across it ``step_count`` risers of ``rise / step_count``. Levels are the running
sums of the rises (the lowest level used at 0), so every shared edge agrees to 1e-4 m
whatever WFC chose, and a flight's side neighbour (a flight must be wide: a stair's side
edge is a staircase only the same flight matches) is the same flight. A boundary's rise is
drawn so that its slope angle *and* its step height and count lie in their configured
ranges: one of the two kinds (picked by the mix weights) is drawn uniformly, the other
derived, retried until both fit; where the two ranges share no rise, the boundary hosts
only one kind (picked by the mix weights) and WFC is told so. Rough tiles draw amplitude,
wavelength and noise seed per tile and get a material: cracked concrete or cobbles on
sidewalks, cobbles or setts on plazas, gravel or soil on trails, grass or soil in
vegetation. WFC weighs kinds by the config's mix (``TerrainMix``), not by how many
variants a kind has.

With the spec's four tile kinds a flight can only end at the edge of the grid (there is
no corner tile), so level changes are straight terraces across the whole grid; they
appear where no pinned tile stands in their way. The mix therefore holds on average, not
in every scene (``benchmarks/bench_wfc.py`` measures it over 10,000 seeds). The stage's
generator is split with :func:`~citygen.seeding.child`: key 0 draws the boundaries, 1
drives WFC, 2 draws the rough tiles.

**Zones.** The grid starts at the bounds' minimum corner with tiles of ``tile_size``.
When a side of the bounds is not a whole number of tiles, the tile side shrinks to the
largest value (down to 3/4 of ``tile_size``) that divides both sides into whole numbers
of tiles; failing that, the grid keeps ``tile_size`` and covers all but a strip of less
than one tile along the far sides, where the ground is at 0 (outside a grid it is at 0),
so the grid's outer edges there are pinned level at 0: no cliff. A tile into which
roadway, bike lane, parking, curb, crosswalk, building or water reaches more than
:data:`HARD_MARGIN` of its side (a sliver along its edges is tolerated) is pinned flat at
level 0, so the street stays flat; this is stricter than "mostly on hard ground", because
a rough or sloped tile reaching into the road would lift the road. Roads, crosswalks and
sidewalks share base height 0 in this model, so a crosswalk meets the sidewalk flush (a
curb ramp with no rise) and needs no ramp tile. Sidewalks, plazas, trails, vegetation and
ground no zone covers get WFC tiles from the mix; level changes there are terraces
between plaza or garden levels (stairs and ramps). Points in ``flat_at`` (the task's
start and goal) get flat tiles (any level) on every tile within :data:`FLAT_RADIUS`.
Every pin admits flat ground at level 0, so the stage's WFC always has a solution.

**Locomotion curriculum** (``layout="curriculum"``, :func:`build_curriculum`), as Isaac
Lab's terrain generator lays it out: ``cfg.grid = [rows, cols]`` regions of one tile each;
row ``r`` has difficulty ``d = r / (rows - 1)``, and the step height and the roughness
amplitude are ``low + d * (high - low)`` of their configured ranges, the slope's grade (rise
over run, ``tan`` of its angle) likewise of the range's grades, as Isaac Lab's
``pyramid_sloped_terrain`` grows its slope; the step
count and the roughness wavelength stay at the middle of theirs (Isaac Lab too scales
only heights and inclinations with difficulty, not step widths or noise steps); columns cycle
through the kinds in proportion to the mix weights (smooth weighted round robin). Slopes
and stairs are pyramids and pits (alternating by column), whose edges are level at 0, so
any two regions meet without a cliff. :func:`loc_config` gives the paper's Urban-Loc train
and test ranges.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from functools import lru_cache
from typing import Literal

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from citygen.errors import GenerationError
from citygen.generate.wfc import Prototype, Tileset, solve
from citygen.geometry.tiles import TILE_KINDS
from citygen.seeding import child, uniform
from citygen.spec import limits
from citygen.spec.base import quantize
from citygen.spec.config import TerrainConfig, TerrainMix
from citygen.spec.scene import Bounds
from citygen.spec.task import Mobility
from citygen.spec.terrain import FlatTile, RoughTile, SlopeTile, StairTile, Terrain, edge_profile
from citygen.spec.zones import Zone

#: The tile kinds' names, in the registry's order (that of ``TerrainMix``'s weights).
KINDS = tuple(kind.name for kind in TILE_KINDS.values())
#: Ground levels WFC may use (level 0 is street level); ``LEVELS - 1`` boundaries between them.
LEVELS = 3
#: Radius (m) around each ``flat_at`` point within which every tile is flat.
FLAT_RADIUS = 0.5
#: A tile is pinned flat at level 0 when hard ground reaches more than this share of the
#: tile's side into it (5 cm of a 2.5 m tile): slivers along its edges are tolerated.
HARD_MARGIN = 0.02
#: Zone kinds whose ground is flat at street level (0 m).
HARD_ZONES = frozenset({"roadway", "bike_lane", "parking", "curb", "crosswalk", "building", "water"})
#: Largest disagreement (m) allowed between a boundary's slope rise and its stair rise.
RISE_TOL = 4e-4
#: Attempts at a rise that suits both slopes and stairs before a boundary keeps one kind.
RISE_TRIES = 64
#: Materials of rough tiles by zone kind (``None``: no zone), one drawn per tile.
ROUGH_MATERIALS: dict[str | None, tuple[str, ...]] = {
    "sidewalk": ("concrete", "cobblestone"),
    "plaza": ("cobblestone", "paving_stone"),
    "trail": ("gravel", "soil"),
    "vegetation": ("grass", "soil"),
    None: ("cobblestone", "concrete", "gravel"),
}
_FREE_KINDS = ("sidewalk", "plaza", "trail", "vegetation")
_ASCENT_OF_ROTATION = ("+y", "+x", "-y", "-x")  # a prototype rises north; each turn is clockwise
_CODE = {k: i for i, k in enumerate(KINDS)}
_MODELS = tuple(TILE_KINDS)  # the tile class of each code

AnyTile = FlatTile | SlopeTile | StairTile | RoughTile


# --- the tileset: level tokens with sockets from the spec's edge profiles -----------------


def _socket(profile: tuple, side: int) -> tuple:
    """An edge profile (read towards +x or +y) as a socket read clockwise around the tile."""
    kind, heights = profile[0], [round(h) for h in profile[1:3]]
    socket = (heights[0], heights[0]) if kind == "level" else (heights[0], kind, heights[1])
    # Clockwise, the north edge reads towards +x and the west edge towards +y, as profiles
    # do; the east and south edges read the other way.
    return socket[::-1] if side in (1, 2) else socket


def _sockets(tile: AnyTile) -> tuple[tuple, tuple, tuple, tuple]:
    sides = ("north", "east", "south", "west")
    return tuple(_socket(edge_profile(tile, s, 1.0), i) for i, s in enumerate(sides))  # type: ignore[return-value]


def symbolic_tile(kind: str, level: int, ascent: str = "+y") -> AnyTile:
    """A tile at height ``level`` whose flights rise exactly one level across a 1 m tile."""
    return _MAKERS[_MODELS[_CODE[kind]]].symbolic(level, ascent)


@dataclass(frozen=True)
class TerrainTileset:
    """The WFC tileset of mixed terrain and what each variant means."""

    tileset: Tileset
    kind: np.ndarray
    """Kind code of each variant (index into :data:`KINDS`)."""
    level: np.ndarray
    """Level of flat and rough variants; lower level of a flight."""
    ascent: tuple[str, ...]
    """Ascent direction of each variant (``+y`` for flat and rough)."""

    def variants(self, kind: str, level: int | None = None) -> np.ndarray:
        """Indices of the variants of ``kind`` (at ``level`` when given)."""
        sel = self.kind == _CODE[kind]
        if level is not None:
            sel &= self.level == level
        return np.flatnonzero(sel)


@lru_cache(maxsize=64)
def terrain_tileset(
    levels: int = LEVELS,
    mix: tuple[float, float, float, float] = (1.0, 1.0, 1.0, 1.0),
    slope_at: tuple[bool, ...] | None = None,
    stair_at: tuple[bool, ...] | None = None,
) -> TerrainTileset:
    """Flat and rough tiles at each of ``levels`` levels, and slope and stair flights (four
    ascents each) across each boundary where ``slope_at`` / ``stair_at`` allow them (default
    everywhere); kinds weighted by ``mix`` (flat, slope, stair, rough). Kinds of weight 0 are
    left out, except flat tiles, which pinned cells need (they are then placed only where
    pinned or forced). ``levels = 3`` gives 22 variants."""
    bounds = levels - 1
    slope_at = (True,) * bounds if slope_at is None else slope_at
    stair_at = (True,) * bounds if stair_at is None else stair_at
    weight = dict(zip(KINDS, mix, strict=True))
    protos, meta = [], []
    for kind in ("flat", "rough"):
        if weight[kind] > 0 or kind == "flat":  # flat tiles also serve pins, whatever their weight
            for lv in range(levels):
                protos.append(Prototype(f"{kind}{lv}", _sockets(symbolic_tile(kind, lv)), group=kind))
                meta.append((kind, lv))
    for kind, where in (("slope", slope_at), ("stair", stair_at)):
        if weight[kind] > 0:
            for b in range(bounds):
                if where[b]:
                    sockets = _sockets(symbolic_tile(kind, b))
                    protos.append(Prototype(f"{kind}{b}", sockets, symmetry="T", group=kind))
                    meta.append((kind, b))
    if not protos:
        raise ValueError("the terrain mix leaves no tile kind with a weight above 0")
    ts = Tileset.from_prototypes(protos, group_weights=weight)
    kinds = np.array([_CODE[meta[p][0]] for p in ts.prototype], dtype=np.int64)
    lv = np.array([meta[p][1] for p in ts.prototype], dtype=np.int64)
    ascent = tuple(
        _ASCENT_OF_ROTATION[r] if meta[p][0] in ("slope", "stair") else "+y"
        for p, r in zip(ts.prototype, ts.rotation, strict=True)
    )
    return TerrainTileset(ts, kinds, lv, ascent)


# --- continuous parameters ---------------------------------------------------------------


@dataclass(frozen=True)
class Boundary:
    """What crosses from one level to the next: its rise and the flights' parameters."""

    rise: float
    """Height (m) from the lower level to the upper one."""
    angle: float | None
    """Slope angle (rad) of slopes across it; ``None`` when slopes may not cross it."""
    steps: tuple[int, float] | None
    """``(step_count, step_height)`` of stairs across it; ``None`` when stairs may not."""


def _inside(x: float, lo_hi: Sequence[float]) -> bool:
    return lo_hi[0] <= x <= lo_hi[1]


def draw_boundary(cfg: TerrainConfig, tile_size: float, rng: np.random.Generator) -> Boundary:
    """One level boundary's rise and flight parameters, each inside its configured range."""
    s = tile_size
    wants = {"slope": cfg.mix.slope > 0, "stair": cfg.mix.stair > 0}
    n_lo, n_hi = cfg.step_count

    def slope_only() -> Boundary:
        angle = quantize(uniform(rng, cfg.slope_angle))
        return Boundary(s * math.tan(angle), angle, None)

    def stair_only() -> Boundary:
        n, h = int(rng.integers(n_lo, n_hi + 1)), quantize(uniform(rng, cfg.step_height))
        return Boundary(n * h, None, (n, h))

    if wants["slope"] and wants["stair"]:
        p_slope = cfg.mix.slope / (cfg.mix.slope + cfg.mix.stair)
        for _ in range(RISE_TRIES):
            if rng.random() < p_slope:  # the slope's angle drawn, a step count that fits it
                angle = quantize(uniform(rng, cfg.slope_angle))
                rise = s * math.tan(angle)
                fits = [n for n in range(n_lo, n_hi + 1) if _inside(quantize(rise / n), cfg.step_height)]
                if not fits:
                    continue
                n = fits[int(rng.integers(len(fits)))]
                h = quantize(rise / n)
            else:  # the stair drawn, the angle that matches it
                n, h = int(rng.integers(n_lo, n_hi + 1)), quantize(uniform(rng, cfg.step_height))
                angle = quantize(math.atan(n * h / s))
                if not _inside(angle, cfg.slope_angle):
                    continue
            if abs(s * math.tan(angle) - n * h) <= RISE_TOL:
                return Boundary(n * h, angle, (n, h))
        # The ranges share no rise (or too little): this boundary takes one kind.
        return slope_only() if rng.random() < p_slope else stair_only()
    if wants["slope"]:
        return slope_only()
    if wants["stair"]:
        return stair_only()
    return Boundary(0.0, None, None)


# --- the grid over the bounds and what covers each tile -----------------------------------


@dataclass(frozen=True)
class Grid:
    """Where the tiles go: origin (m), tile side (m), rows and columns, and whether the
    grid stops short of the bounds along x (``short_x``) or y (``short_y``)."""

    origin: tuple[float, float]
    tile_size: float
    rows: int
    cols: int
    short_x: bool = False
    short_y: bool = False


def grid_for(bounds: Bounds, tile_size: float) -> Grid:
    """The tile grid over ``bounds`` (see the module docstring for the rule)."""
    w, h = bounds.size
    eps = 1e-6
    for k in range(max(1, math.ceil(w / tile_size - eps)), math.ceil(w / (0.75 * tile_size)) + 1):
        t = quantize(w / k)
        rows = round(h / t)
        if t >= 0.25 and rows >= 1 and abs(rows * t - h) <= 1e-4 and abs(k * t - w) <= 1e-4:
            return Grid(bounds.min, t, rows, k)
    t = min(tile_size, w, h)
    cols, rows = max(1, math.floor(w / t + eps)), max(1, math.floor(h / t + eps))
    return Grid(bounds.min, t, rows, cols, cols * t < w - 1e-4, rows * t < h - 1e-4)


def _zone_cover(grid: Grid, zones: Sequence[Zone]) -> tuple[np.ndarray, np.ndarray]:
    """Per tile (``(rows, cols)`` arrays): whether hard ground reaches more than
    :data:`HARD_MARGIN` of the tile side into it, and the free zone kind under its centre
    (index into ``_FREE_KINDS``, -1 for none)."""
    rows, cols, s = grid.rows, grid.cols, grid.tile_size
    hard = np.zeros(rows * cols, dtype=bool)
    main = np.full(rows * cols, -1, dtype=np.int64)
    if zones:
        polys = [Polygon(z.polygon, z.holes) for z in zones]
        polys = np.asarray([p if p.is_valid else shapely.make_valid(p) for p in polys], dtype=object)
        kinds = np.array([z.kind for z in zones], dtype=object)
        r, c = np.divmod(np.arange(rows * cols), cols)
        x0, y0 = grid.origin[0] + c * s, grid.origin[1] + r * s
        is_hard = np.isin(kinds, list(HARD_ZONES))
        if is_hard.any():
            inset = HARD_MARGIN * s
            inner = shapely.box(x0 + inset, y0 + inset, x0 + s - inset, y0 + s - inset)
            tile, _ = shapely.STRtree(polys[is_hard]).query(inner, predicate="intersects")
            hard[tile] = True
        free_idx = np.flatnonzero(np.isin(kinds, _FREE_KINDS))
        if free_idx.size:
            centres = shapely.points(x0 + s / 2, y0 + s / 2)
            tile, zone = shapely.STRtree(polys[free_idx]).query(centres, predicate="intersects")
            code = np.array([_FREE_KINDS.index(k) for k in kinds[free_idx]], dtype=np.int64)
            order = np.lexsort((zone, tile))  # on a shared border, the first zone listed wins
            tile, zone = tile[order], zone[order]
            first = np.unique(tile, return_index=True)[1]
            main[tile[first]] = code[zone[first]]
    return hard.reshape(rows, cols), main.reshape(rows, cols)


def _cells_in(grid: Grid, area: BaseGeometry) -> list[tuple[int, int]]:
    """Cells of every tile ``area`` (m) reaches into."""
    s, (ox, oy) = grid.tile_size, grid.origin
    r, c = np.divmod(np.arange(grid.rows * grid.cols), grid.cols)
    boxes = shapely.box(ox + c * s, oy + r * s, ox + (c + 1) * s, oy + (r + 1) * s)
    hit = shapely.intersects(boxes, area) & ~shapely.touches(boxes, area)
    return [(int(a), int(b)) for a, b in zip(r[hit], c[hit], strict=True)]


def _crossable(tts: TerrainTileset, boundaries: Sequence[Boundary], mobility: Mobility) -> np.ndarray:
    """bool per variant: flat ground, and the slopes and stairs a robot of ``mobility`` climbs."""
    ok = tts.kind == _CODE["flat"]
    for b, boundary in enumerate(boundaries):
        at = tts.level == b
        if boundary.angle is not None and boundary.angle <= mobility.max_slope:
            ok |= at & (tts.kind == _CODE["slope"])
        if boundary.steps is not None and mobility.stairs and boundary.steps[1] <= mobility.max_step:
            ok |= at & (tts.kind == _CODE["stair"])
    return ok


def _flat_cells(grid: Grid, points: Sequence[tuple[float, float]]) -> list[tuple[int, int]]:
    """Cells of every tile within :data:`FLAT_RADIUS` of one of ``points`` (m)."""
    out = []
    s, (ox, oy) = grid.tile_size, grid.origin
    for x, y in points:
        r0 = max(0, math.floor((y - oy - FLAT_RADIUS) / s))
        r1 = min(grid.rows - 1, math.floor((y - oy + FLAT_RADIUS) / s))
        c0 = max(0, math.floor((x - ox - FLAT_RADIUS) / s))
        c1 = min(grid.cols - 1, math.floor((x - ox + FLAT_RADIUS) / s))
        for r in range(r0, r1 + 1):
            dy = max(oy + r * s - y, 0.0, y - oy - (r + 1) * s)
            for c in range(c0, c1 + 1):
                dx = max(ox + c * s - x, 0.0, x - ox - (c + 1) * s)
                if dx * dx + dy * dy <= FLAT_RADIUS**2:
                    out.append((r, c))
    return out


# --- the stage ---------------------------------------------------------------------------


def build_terrain(
    bounds: Bounds,
    zones: Sequence[Zone],
    cfg: TerrainConfig,
    rng: np.random.Generator,
    *,
    seed: int = 0,
    flat_at: Sequence[tuple[float, float]] = (),
    corridor: BaseGeometry | None = None,
    mobility: Mobility | None = None,
) -> Terrain:
    """The scene's terrain grid over ``bounds``: WFC tiles on walkable ground and vegetation,
    flat street-level tiles on hard zones, flat tiles around ``flat_at`` (m); or, when
    ``cfg.layout == "curriculum"``, the difficulty grid of :func:`build_curriculum`.

    ``corridor`` (an area, m) with ``mobility``: every tile it reaches is one that robot
    crosses (flat, or a slope or stair it climbs; not rough, whose bumps are drawn after
    WFC), so a path inside the corridor stays crossable (the pipeline asks for one when
    the task's start and goal would otherwise be cut apart, see
    :func:`citygen.generate.layouts.base.keep_crossable`).

    ``rng`` is the terrain stage's generator; ``seed`` only labels errors. Raises
    :class:`~citygen.errors.GenerationError` when WFC cannot tile the grid (naming the cell)
    or a curriculum grid does not fit the bounds.

    >>> from citygen.seeding import stage_rng
    >>> t = build_terrain(Bounds(min=(0, 0), max=(10, 10)), [], TerrainConfig(), stage_rng(7, "terrain"))
    >>> t.rows, t.cols, t.tile_size
    (4, 4, 2.5)
    """
    if cfg.layout == "curriculum":
        rows, cols = cfg.grid if cfg.grid is not None else (None, None)
        w, h = bounds.size
        s = cfg.tile_size
        if rows is None:
            g = grid_for(bounds, s)
            rows, cols, s = g.rows, g.cols, g.tile_size
        if cols * s > w + 1e-4 or rows * s > h + 1e-4:
            raise GenerationError(
                "terrain",
                seed,
                f"a curriculum grid of {rows} x {cols} tiles of {s:g} m ({cols * s:g} m x {rows * s:g} m) "
                f"does not fit the scene's {w:g} m x {h:g} m bounds",
            )
        return build_curriculum(
            cfg.model_copy(update={"grid": (rows, cols), "tile_size": s}), rng, bounds.min
        )
    grid = grid_for(bounds, cfg.tile_size)
    s = grid.tile_size
    if max(grid.rows, grid.cols) > limits.MAX_GRID_SIDE or grid.rows * grid.cols > limits.MAX_TILES:
        raise GenerationError(
            "terrain",
            seed,
            f"{grid.rows} x {grid.cols} tiles of {s:g} m exceed the spec's limits ({limits.MAX_GRID_SIDE} "
            f"a side, {limits.MAX_TILES} in all); use a larger tile_size",
        )
    levels = LEVELS if (cfg.mix.slope > 0 or cfg.mix.stair > 0) else 1
    # 1. One rise per level boundary, and which flights may cross it.
    brng = child(rng, 0)
    boundaries = [draw_boundary(cfg, s, brng) for _ in range(levels - 1)]
    mix = (cfg.mix.flat, cfg.mix.slope, cfg.mix.stair, cfg.mix.rough)
    tts = terrain_tileset(
        levels,
        mix,
        tuple(b.angle is not None for b in boundaries),
        tuple(b.steps is not None for b in boundaries),
    )
    ts = tts.tileset
    # 2. Pins: hard zones flat at level 0, flat patches, level outer edges short of the bounds.
    hard, main = _zone_cover(grid, zones)
    domains = np.ones((grid.rows, grid.cols, len(ts)), dtype=bool)
    flat = np.zeros(len(ts), dtype=bool)
    flat[tts.variants("flat")] = True
    flat0 = np.zeros(len(ts), dtype=bool)
    flat0[tts.variants("flat", 0)] = True
    domains[hard] = flat0
    for r, c in _flat_cells(grid, flat_at):
        domains[r, c] &= flat
    if corridor is not None and mobility is not None:
        crossable = _crossable(tts, boundaries, mobility)
        for r, c in _cells_in(grid, corridor):
            domains[r, c] &= crossable
    level0 = np.array([sk == (0, 0) for sk in (v[1] for v in ts.sockets)])
    if grid.short_x:
        domains[:, -1] &= level0
    if grid.short_y:
        domains[-1, :] &= np.array([v[0] == (0, 0) for v in ts.sockets])
    # 3. WFC.
    cells = solve(
        ts, grid.rows, grid.cols, child(rng, 1), domains=domains, max_restarts=cfg.max_restarts, seed=seed
    )
    tiles = _realise(tts, cells, boundaries, cfg, s, main, child(rng, 2))
    return Terrain(origin=grid.origin, tile_size=s, rows=grid.rows, cols=grid.cols, tiles=tiles)


def _realise(
    tts: TerrainTileset,
    cells: np.ndarray,
    boundaries: Sequence[Boundary],
    cfg: TerrainConfig,
    s: float,
    main: np.ndarray,
    rng: np.random.Generator,
) -> list[AnyTile]:
    """Spec tiles for the WFC result: heights from the boundaries' rises, rough tiles drawn."""
    flat_v = cells.ravel()
    kind = tts.kind[flat_v]
    level = tts.level[flat_v]
    heights = np.concatenate([[0.0], np.cumsum([b.rise for b in boundaries])])
    heights = heights - heights[int(level.min())]  # the lowest level used is at 0
    n_rough = int((kind == _CODE["rough"]).sum())
    amp = rng.uniform(*cfg.roughness_amplitude, size=n_rough)
    scale = rng.uniform(*cfg.roughness_scale, size=n_rough)
    seeds = rng.integers(0, 2**32, size=n_rough, dtype=np.uint64)
    picks = rng.random(n_rough)
    mains = main.ravel()
    out: list[AnyTile] = []
    shared: dict[int, AnyTile] = {}  # flat, slope and stair tiles repeat: one instance each
    k = 0
    for i, v in enumerate(flat_v.tolist()):
        code = int(kind[i])
        if code != _CODE["rough"]:
            tile = shared.get(v)
            if tile is None:
                lv = int(level[i])
                crossing = boundaries[lv] if lv < len(boundaries) else None  # a flight's
                tile = _MAKERS[_MODELS[code]].level(float(heights[lv]), crossing, tts.ascent[v])
                shared[v] = tile
            out.append(tile)
            continue
        choices = ROUGH_MATERIALS[_FREE_KINDS[mains[i]] if mains[i] >= 0 else None]
        out.append(
            RoughTile(
                kind="rough",
                height=float(heights[level[i]]),
                amplitude=float(amp[k]),
                scale=float(scale[k]),
                seed=int(seeds[k]),
                material=choices[int(picks[k] * len(choices))],
            )
        )
        k += 1
    return out


# --- locomotion curriculum ---------------------------------------------------------------


def cycle_kinds(mix: TerrainMix, count: int) -> list[str]:
    """``count`` kinds in proportion to the mix weights, interleaved (smooth weighted round robin).

    >>> cycle_kinds(TerrainMix(flat=1, slope=2, stair=0, rough=1), 8)
    ['slope', 'flat', 'rough', 'slope', 'slope', 'flat', 'rough', 'slope']
    """
    weights = np.array([getattr(mix, k) for k in KINDS], dtype=np.float64)
    if not weights.sum() > 0:
        raise ValueError("the terrain mix needs at least one weight above 0")
    current = np.zeros(len(KINDS))
    out = []
    for _ in range(count):
        current += weights
        k = int(np.argmax(current))
        current[k] -= weights.sum()
        out.append(KINDS[k])
    return out


def _at(lo_hi: Sequence[float], d: float) -> float:
    return lo_hi[0] + d * (lo_hi[1] - lo_hi[0])


def _grade_at(angles: Sequence[float], d: float) -> float:
    """The angle whose grade is ``d`` of the way between the grades of ``angles``."""
    return math.atan(_at((math.tan(angles[0]), math.tan(angles[1])), d))


def _grade(g: float) -> float:
    """The angle (rad) of a slope of grade ``g`` (rise over run), as the spec rounds it."""
    return quantize(math.atan(g))


def build_curriculum(
    cfg: TerrainConfig, rng: np.random.Generator, origin: tuple[float, float] = (0.0, 0.0)
) -> Terrain:
    """The locomotion difficulty grid: ``cfg.grid = [rows, cols]`` one-tile regions, difficulty
    rising with the row, kinds cycling across the columns (see the module docstring).

    >>> cfg = loc_config("test", "stair")
    >>> t = build_curriculum(cfg, np.random.default_rng(0))
    >>> t.rows, t.cols, t.tile(0, 0).step_height, t.tile(15, 1).step_height, t.tile(15, 1).shape
    (16, 16, 0.1, 0.3, 'pit')
    """
    if cfg.grid is None:
        raise ValueError("a curriculum needs cfg.grid = [rows, cols]")
    rows, cols = cfg.grid
    if rows < 1 or cols < 1:
        raise ValueError(f"a curriculum grid needs at least 1 x 1 regions, got {rows} x {cols}")
    kinds = cycle_kinds(cfg.mix, cols)
    seen = dict.fromkeys(KINDS, 0)
    shapes = []
    for k in kinds:
        shapes.append("pyramid" if seen[k] % 2 == 0 else "pit")
        seen[k] += 1
    seeds = rng.integers(0, 2**32, size=(rows, cols), dtype=np.uint64)
    tiles: list[AnyTile] = []
    for r in range(rows):
        d = r / (rows - 1) if rows > 1 else 0.0
        for c, kind in enumerate(kinds):
            tiles.append(_MAKERS[_MODELS[_CODE[kind]]].curriculum(cfg, d, shapes[c], int(seeds[r, c])))
    return Terrain(origin=origin, tile_size=cfg.tile_size, rows=rows, cols=cols, tiles=tiles)


# --- how the stage makes each tile kind ------------------------------------------------------


@dataclass(frozen=True)
class _Maker:
    """How the terrain stage makes tiles of one kind."""

    symbolic: Callable[[int, str], AnyTile]
    """``(level, ascent)``: at height ``level``, a flight rising one level across a 1 m tile."""
    curriculum: Callable[[TerrainConfig, float, str, int], AnyTile]
    """``(cfg, difficulty, shape, seed)``: a curriculum region (see the module docstring)."""
    level: Callable[[float, Boundary | None, str], AnyTile] | None = None
    """``(height, boundary, ascent)``: a WFC tile at ``height`` (m); a flight crosses
    ``boundary`` (None above the top level). None for rough tiles, whose parameters are drawn
    per tile."""


def _stair_at(h: float, b: Boundary, ascent: str) -> StairTile:
    n, sh = b.steps
    return StairTile(kind="stair", height=h, step_height=sh, step_count=n, ascent=ascent)


_MAKERS: dict[type, _Maker] = {
    FlatTile: _Maker(
        symbolic=lambda level, ascent: FlatTile(kind="flat", height=level),
        curriculum=lambda cfg, d, shape, seed: FlatTile(kind="flat"),
        level=lambda h, b, ascent: FlatTile(kind="flat", height=h),
    ),
    SlopeTile: _Maker(
        # tan(0.7854) = 1.0000036: one level, to the rounding in _socket
        symbolic=lambda level, ascent: SlopeTile(kind="slope", height=level, angle=0.7854, ascent=ascent),
        curriculum=lambda cfg, d, shape, seed: SlopeTile(
            kind="slope", angle=_grade_at(cfg.slope_angle, d), shape=shape
        ),
        level=lambda h, b, ascent: SlopeTile(kind="slope", height=h, angle=b.angle, ascent=ascent),
    ),
    StairTile: _Maker(
        symbolic=lambda level, ascent: StairTile(
            kind="stair", height=level, step_height=0.5, step_count=2, ascent=ascent
        ),
        curriculum=lambda cfg, d, shape, seed: StairTile(
            kind="stair",
            step_height=_at(cfg.step_height, d),
            step_count=round(_at(cfg.step_count, 0.5)),
            shape=shape,
        ),
        level=_stair_at,
    ),
    RoughTile: _Maker(
        symbolic=lambda level, ascent: RoughTile(kind="rough", height=level, amplitude=0.0, scale=1.0),
        curriculum=lambda cfg, d, shape, seed: RoughTile(
            kind="rough",
            amplitude=_at(cfg.roughness_amplitude, d),
            scale=_at(cfg.roughness_scale, 0.5),
            seed=seed,
        ),
    ),
}


#: The paper's Urban-Loc ranges: stair step height, slope, roughness amplitude, regions. The
#: paper's slope figures (0-0.4 train, 0.05-0.8 test) are grades, rise over run: they are
#: Isaac Lab's ``slope_range`` (its rough-terrain config's is the same 0-0.4), which its
#: ``pyramid_sloped_terrain`` turns into heights as ``slope * width``, though its docstring
#: says radians; read as radians, the test grid's last rows (to 46 degrees) are steeper
#: than a friction of 1 holds a standing robot on.
LOC_RANGES: dict[str, dict] = {
    "train": {
        "step_height": (0.05, 0.23),
        "slope_angle": (_grade(0.0), _grade(0.4)),
        "roughness_amplitude": (0.02, 0.10),
        "grid": (30, 30),
    },
    "test": {
        "step_height": (0.10, 0.30),
        "slope_angle": (_grade(0.05), _grade(0.8)),
        "roughness_amplitude": (0.05, 0.20),
        "grid": (16, 16),
    },
}
#: Side (m) of one curriculum region, as Isaac Lab's sub-terrains.
LOC_TILE_SIZE = 8.0
#: Risers from a pyramid's edge to its platform: treads of 8 m / 18 = 0.44 m.
LOC_STEP_COUNT = (8, 8)


def loc_config(
    split: Literal["train", "test"], kind: Literal["mixed", "flat", "slope", "stair", "rough"] = "mixed"
) -> TerrainConfig:
    """The terrain config of an Urban-Loc split: a curriculum grid with the paper's ranges
    (``kind`` keeps one tile kind, as the LocoFlat/LocoSlope/LocoStair/LocoRough tasks do).

    >>> loc_config("train", "slope").slope_angle, loc_config("train").grid
    ((0.0, 0.3805), (30, 30))
    """
    if split not in LOC_RANGES:
        raise ValueError(f"split must be 'train' or 'test', got {split!r}")
    if kind != "mixed" and kind not in KINDS:
        raise ValueError(f"kind must be 'mixed' or one of {', '.join(KINDS)}, got {kind!r}")
    mix = TerrainMix() if kind == "mixed" else TerrainMix(**{k: float(k == kind) for k in KINDS})
    return TerrainConfig(
        layout="curriculum",
        tile_size=LOC_TILE_SIZE,
        mix=mix,
        step_count=LOC_STEP_COUNT,
        **LOC_RANGES[split],
    )
