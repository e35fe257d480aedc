"""Stage 2: ground planning, the scene's ground divided into functional zones.

Around a road network (:func:`plan_ground`), in priority order:

1. **crosswalk** across each arm of a junction and, by chance, mid-block on straights,
   spanning roadway and curbs;
2. **roadway**: the road surface of the blocks;
3. **curb**: a band of the scene's curb width around the roadway;
4. **vegetation** on roundabout islands;
5. **sidewalk** bands of each block's width, split as street design guides lay them out
   into a *furnishing* strip by the curb (trees, benches, lamps), a *clear* pedestrian
   through zone and a *frontage* strip by the buildings;
6. the land between streets, divided into lots: a setback band along the sidewalks
   (lawn, or plaza), then per lot a **building** footprint (compact lots facing a street),
   a **plaza** (open corners) or **vegetation** crossed by a **trail** when large.

Without roads (:func:`plan_region`, the 10 m and 15 m Urban-Nav squares) a walkable
region (sidewalk, trail or plaza) of one of four shapes (straight path, L-turn, crossing,
open plaza with islands) lies against non-walkable ground (vegetation, roadway).

Zones tile the bounds exactly. Each band is a union of per-block buffers. The scene is
cut into lots by jittered grid lines and each lot is divided on its own, from copies of
the bands clipped by recursive bisection (each cut touches only the geometry near it),
so the work grows with the area and every zone stays a small polygon. Within a lot, all
band boundaries are noded once on a :data:`GRID` and polygonised; each face takes the
kind of the first band covering it (:func:`_arrange`), so neighbouring zones share
every vertex bit for bit; across lots, both sides of a cut compute its crossings the
same way.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import Polygon, box

from citygen.errors import GenerationError
from citygen.geometry.roads import block_geometry
from citygen.seeding import child, uniform
from citygen.spec.base import quantize_array
from citygen.spec.blocks import Straight
from citygen.spec.config import GroundConfig, RegionConfig
from citygen.spec.scene import Bounds
from citygen.spec.zones import Zone

#: Precision grid of every overlay, in metres.
GRID = 1e-3
#: Pieces of ground smaller than this (m^2) join a neighbouring zone.
MIN_AREA = 0.01
#: Segments per quarter circle of buffered corners.
QUAD_SEGS = 4
#: A lot this much farther than the setback from a sidewalk still faces the street, in metres.
FACING = 3.0
#: Trails cross open land along every this many rows and columns of lots.
TRAIL_EVERY = 3


def _snap(value: float) -> float:
    return round(round(value / GRID) * GRID, 6)


def _cuts(lo: float, hi: float, size: Sequence[float], rng: np.random.Generator) -> list[float]:
    """Jittered grid lines from ``lo`` to ``hi``, spaced by draws from ``size``."""
    cuts, x = [lo], lo
    while True:
        x += uniform(rng, size)
        if x >= hi - 0.5 * size[0]:
            break
        cuts.append(_snap(x))
    cuts.append(hi)
    return cuts


def _polygons(geom) -> list[Polygon]:
    if geom is None or geom.is_empty:
        return []
    if geom.geom_type == "Polygon":
        return [geom]
    return [g for part in getattr(geom, "geoms", ()) for g in _polygons(part)]


Layer = tuple[str, "str | None", object]
"""``(kind, strip, shape)``: ground of one kind, in priority order."""


Piece = tuple[str, "str | None", Polygon]


def _arrange(lot: Polygon, layers: list[Layer], fill=None) -> list[Piece]:
    """Divide ``lot`` by ``layers``: each point goes to the first layer that covers it, and
    what no layer covers to ``fill(part) -> pieces`` (vegetation without one).

    All boundaries are noded once on the :data:`GRID` and polygonised into faces, each
    face takes the kind of the first layer holding it, and faces of one kind merge by
    coverage union. Neighbouring zones therefore share every boundary vertex exactly
    (separate overlays could snap a shared edge apart), and the cost is one noding per
    lot however many layers there are.
    """
    layers = [(k, st, g) for k, st, g in layers if g is not None and not g.is_empty]
    if layers:
        lines = shapely.union_all([lot.boundary] + [g.boundary for _, _, g in layers], grid_size=GRID)
        faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(lines)))
        faces = faces[shapely.area(faces) > 0]
    else:
        faces = np.array([lot], dtype=object)
    points = shapely.point_on_surface(faces)
    owner = np.full(len(faces), -1)  # -1: left for ``fill``
    for k, (_, _, shape) in enumerate(layers):
        free = owner < 0
        if not free.any():
            break
        shapely.prepare(shape)
        owner[np.flatnonzero(free)[shapely.intersects(shape, points[free])]] = k
    # Crumbs (a crosswalk's corner, a sliver between two buffers) join the neighbour they
    # share the longest edge with rather than being zones of their own.
    areas = shapely.area(faces)
    big, small = np.flatnonzero(areas >= MIN_AREA), np.flatnonzero(areas < MIN_AREA)
    if len(small) and len(big):
        tree = shapely.STRtree(faces[big])
        for f in small:
            near = big[tree.query(faces[f], predicate="intersects")]
            if len(near):
                shared = shapely.length(shapely.intersection(faces[near], faces[f].boundary))
                owner[f] = owner[near[int(np.argmax(shared))]]
    # Faces merge by kind and strip (the setback's lawn and an island's are one zone).
    keys = [(kind, strip) for kind, strip, _ in layers]
    order = list(dict.fromkeys(keys))
    group = np.array([order.index(keys[k]) if k >= 0 else -1 for k in owner])
    pieces: list[Piece] = []
    for g, (kind, strip) in enumerate(order):
        pieces += [(kind, strip, part) for part in _merge(faces[group == g])]
    for part in _merge(faces[group < 0]):
        pieces += fill(part) if fill else [("vegetation", None, part)]
    return pieces


def _merge(faces: np.ndarray) -> list[Polygon]:
    if not len(faces):
        return []
    return _polygons(faces[0] if len(faces) == 1 else shapely.coverage_union_all(faces))


def _bisect(layers: list, xs: list[float], ys: list[float], i0, i1, j0, j1, out: dict) -> None:
    """Clip every layer to each lot ``[xs[i], xs[i+1]] x [ys[j], ys[j+1]]``, bisecting the
    range of lots so each clip sees only the geometry of its half."""
    layers = [
        None if g is None or g.is_empty else shapely.clip_by_rect(g, xs[i0], ys[j0], xs[i1], ys[j1])
        for g in layers
    ]
    if i1 - i0 == 1 and j1 - j0 == 1:
        out[(j0, i0)] = layers
        return
    if i1 - i0 >= j1 - j0:
        mid = (i0 + i1) // 2
        _bisect(layers, xs, ys, i0, mid, j0, j1, out)
        _bisect(layers, xs, ys, mid, i1, j0, j1, out)
    else:
        mid = (j0 + j1) // 2
        _bisect(layers, xs, ys, i0, i1, j0, mid, out)
        _bisect(layers, xs, ys, i0, i1, mid, j1, out)


def _zones(pieces: list[Piece]) -> tuple[Zone, ...]:
    """Zones from pieces, with ids by kind in order. The pieces are valid polygons and
    every coordinate is quantised here exactly as :class:`~citygen.spec.base.Float` would
    (:func:`~citygen.spec.base.quantize_array`), so the models are built without
    re-validating thousands of coordinates one by one."""
    if not pieces:
        return ()
    # A canonical vertex order, whatever GEOS produced; all rings at once.
    polys = shapely.normalize(np.array([poly for _, _, poly in pieces], dtype=object))
    rings, owner = shapely.get_rings(polys, return_index=True)
    coords, ring_of = shapely.get_coordinates(rings, return_index=True)
    coords = quantize_array(coords).tolist()
    starts = np.searchsorted(ring_of, np.arange(len(rings) + 1)).tolist()
    # Each ring without its closing vertex.
    ring_tuples = [tuple(map(tuple, coords[starts[k] : starts[k + 1] - 1])) for k in range(len(rings))]
    first = np.searchsorted(owner, np.arange(len(polys) + 1)).tolist()
    counters: dict[str, int] = {}
    zones = []
    for k, (kind, strip, _) in enumerate(pieces):
        n = counters[kind] = counters.get(kind, 0) + 1
        zones.append(
            Zone.model_construct(
                id=f"{kind}-{n}",
                kind=kind,
                polygon=ring_tuples[first[k]],
                holes=tuple(ring_tuples[first[k] + 1 : first[k + 1]]),
                strip=strip,
            )
        )
    return tuple(zones)


def ground_margin(cfg: GroundConfig) -> float:
    """Room for curb and sidewalk between a road and the edge of the scene, in metres."""
    return cfg.curb_width[1] + cfg.sidewalk_width[1]


def street_bands(blocks: Sequence, cfg: GroundConfig, rng: np.random.Generator):
    """The ground of the streets, drawn from ``rng`` in this order: the curb width, each
    block's crosswalks (``child(rng, k)``), each block's sidewalk strips
    (``child(rng, len(blocks) + k)``). Returns ``(crosswalks, roads, curbs, islands,
    sidewalks)``, sidewalks a dict of the furnishing, clear and frontage bands."""
    geoms = [block_geometry(b) for b in blocks]
    curb = uniform(rng, cfg.curb_width)
    roads = shapely.union_all([g.outline for g in geoms], grid_size=GRID)
    curbs = roads.buffer(curb, quad_segs=QUAD_SEGS)

    # Crosswalks across every junction arm, and mid-block on some straights.
    walks = []
    for k, (block, g) in enumerate(zip(blocks, geoms, strict=True)):
        r = child(rng, k)
        sites = g.crossings
        if isinstance(block, Straight):
            sites = sites if r.random() < cfg.midblock_crosswalk_probability else ()
        for site in sites:
            depth = uniform(r, cfg.crosswalk_width)
            if site.room < depth + 0.5:
                continue
            offset = site.offset + (site.room - depth) / 2 if isinstance(block, Straight) else site.offset
            d = np.array([math.cos(site.yaw), math.sin(site.yaw)])
            n = np.array([-d[1], d[0]])
            start = np.array(site.origin) + offset * d
            span = site.half_width + curb + 0.01
            ring = [
                start - span * n,
                start + depth * d - span * n,
                start + depth * d + span * n,
                start + span * n,
            ]
            walks.append(Polygon(ring))
    crosswalks = shapely.intersection(shapely.union_all(walks), curbs) if walks else Polygon()
    islands = shapely.union_all([g.island for g in geoms if g.island is not None])

    # Sidewalk strips: furnishing by the curb, the clear through zone, frontage outside.
    bands: dict[str, list] = {"furnishing": [], "clear": [], "frontage": []}
    for k, g in enumerate(geoms):
        r = child(rng, len(blocks) + k)
        width = uniform(r, cfg.sidewalk_width)
        furnishing = width * uniform(r, (0.2, 0.3))
        frontage = width * uniform(r, (0.1, 0.2))
        for strip, reach in (
            ("furnishing", curb + furnishing),
            ("clear", curb + width - frontage),
            ("frontage", curb + width),
        ):
            bands[strip].append(g.outline.buffer(reach, quad_segs=QUAD_SEGS))
    sidewalks = {strip: shapely.union_all(shapes) for strip, shapes in bands.items()}
    return crosswalks, roads, curbs, islands, sidewalks


#: The zone kind and strip of each street band :func:`street_bands` gives, in its order.
STREET_LAYERS = (
    ("crosswalk", None),
    ("roadway", None),
    ("curb", None),
    ("vegetation", None),
    ("sidewalk", "furnishing"),
    ("sidewalk", "clear"),
    ("sidewalk", "frontage"),
)


def street_layers(parts: Sequence) -> list[Layer]:
    """A lot's street bands (crosswalks, roadway, curbs, islands and the sidewalk's three
    strips, clipped to the lot, in :func:`street_bands`' order) as layers for :func:`_arrange`."""
    return [(kind, strip, geom) for (kind, strip), geom in zip(STREET_LAYERS, parts, strict=True)]


def plan_ground(
    bounds: Bounds, blocks: Sequence, cfg: GroundConfig, rng: np.random.Generator, *, seed: int | None = None
) -> tuple[Zone, ...]:
    """Zones tiling ``bounds`` around the road ``blocks``."""
    if not blocks:
        raise GenerationError("ground", seed, "a road layout needs at least one block")
    (x0, y0), (x1, y1) = bounds.min, bounds.max
    crosswalks, roads, curbs, islands, sidewalks = street_bands(blocks, cfg, rng)
    setback = uniform(rng, cfg.building_setback)
    street = sidewalks["frontage"]
    near = street.buffer(setback, quad_segs=QUAD_SEGS) if setback > 0.25 else None
    shapely.prepare(street)  # for the distance tests of every lot

    xs = _cuts(x0, x1, cfg.lot_size, rng)
    ys = _cuts(y0, y1, cfg.lot_size, rng)
    layers = [crosswalks, roads, curbs, islands, *sidewalks.values(), near]
    for g in layers:
        if g is not None:
            shapely.prepare(g)
    clipped: dict[tuple[int, int], list] = {}
    _bisect(layers, xs, ys, 0, len(xs) - 1, 0, len(ys) - 1, clipped)
    lot_seed = int(rng.integers(2**63))

    pieces: list[tuple[str, str | None, Polygon]] = []
    for (j, i), parts in sorted(clipped.items()):
        *street_parts, near_band = parts
        lot = box(xs[i], ys[j], xs[i + 1], ys[j + 1])
        layers = street_layers(street_parts)
        r = np.random.default_rng([lot_seed, j, i])
        if near_band is not None:
            layers.append(("plaza" if r.random() < cfg.plaza_probability else "vegetation", None, near_band))
        open_land = all(g is None or g.is_empty for _, _, g in layers)

        def fill(part, r=r, j=j, i=i, open_land=open_land, lot=lot):
            return _fill_lot(lot, part, street, setback, cfg, r, j, i, open_land)

        pieces += _arrange(lot, layers, fill)
    return _zones(pieces)


def _fill_lot(
    lot: Polygon,
    part: Polygon,
    street,
    setback: float,
    cfg: GroundConfig,
    r: np.random.Generator,
    row: int,
    col: int,
    open_land: bool,
) -> list[Piece]:
    """What the streets leave of a lot: a building with its yard, a plaza, or vegetation
    (crossed by a trail on every few rows and columns of open land).

    The pieces are built exactly (a footprint is a hole of its yard, trails are
    axis-aligned boxes on the grid), so no vertex moves on the part's boundary."""
    faces_street = not open_land and shapely.dwithin(street, part, setback + FACING)
    if faces_street and part.area >= 60.0:
        rect = part.minimum_rotated_rectangle
        corners = rect.exterior.coords
        sides = sorted(math.dist(a, b) for a, b in itertools.pairwise(corners))
        if part.area >= 0.6 * rect.area and sides[0] >= 10.0 and r.random() < cfg.building_probability:
            # Side yards keep neighbouring buildings apart; the yards are lawn.
            inset = part.buffer(-uniform(r, (1.0, 3.0)), join_style="mitre")
            footprints = [f for f in _polygons(inset) if f.area >= 40.0]
            if footprints:
                yard = Polygon(part.exterior, [*part.interiors, *(f.exterior for f in footprints)])
                return [*(("building", None, f) for f in footprints), ("vegetation", None, yard)]
    if faces_street and r.random() < cfg.plaza_probability:
        return [("plaza", None, part)]
    trail_row, trail_col = row % TRAIL_EVERY == 1, col % TRAIL_EVERY == 2
    if open_land and (trail_row or trail_col) and part.area >= 300.0:
        # Trails cross open land along every few rows and columns of lots, so they join up.
        x0, y0, x1, y1 = lot.bounds
        x, y = _snap((x0 + x1) / 2), _snap((y0 + y1) / 2)
        half = _snap(uniform(r, (1.5, 2.5)) / 2)
        trail = shapely.union_all(
            ([box(x0, y - half, x1, y + half)] if trail_row else [])
            + ([box(x - half, y0, x + half, y1)] if trail_col else [])
        )
        rest = shapely.difference(lot, trail)
        return [("trail", None, trail), *(("vegetation", None, p) for p in _polygons(rest))]
    return [("vegetation", None, part)]


# --- small scenes without roads -----------------------------------------------------------


def _region_shape(shape: str, w: float, h: float, rng: np.random.Generator, cfg: RegionConfig):
    """The walkable region of a ``w`` x ``h`` scene with its minimum corner at the origin."""
    width = min(uniform(rng, cfg.path_width), 0.6 * min(w, h))
    if shape == "plaza":
        region = box(0, 0, w, h)
        islands = []
        for _ in range(int(rng.integers(1, 4)) * 8):
            if len(islands) >= 3:
                break
            radius = uniform(rng, (0.5, 0.12 * min(w, h)))
            cx, cy = rng.uniform(radius + 1.0, w - radius - 1.0), rng.uniform(radius + 1.0, h - radius - 1.0)
            if rng.random() < 0.5:
                island = box(cx - radius, cy - radius, cx + radius, cy + radius)
            else:
                island = shapely.Point(cx, cy).buffer(radius, quad_segs=QUAD_SEGS)
            if all(island.distance(other) > 1.5 for other in islands):
                islands.append(island)
        return region.difference(shapely.union_all(islands))

    def band(along_x: bool, at: float):
        half = width / 2
        return box(0, at - half, w, at + half) if along_x else box(at - half, 0, at + half, h)

    along_x = bool(rng.random() < 0.5)
    cy = rng.uniform(0.3, 0.7) * h
    cx = rng.uniform(0.3, 0.7) * w
    if shape == "straight":
        return band(along_x, cy if along_x else cx)
    if shape == "crossing":
        return band(True, cy).union(band(False, cx))
    # An L-turn: from one edge to the corner point, then on to an adjacent edge; each arm
    # runs to the farther edge, so the path spans at least half the scene both ways (room
    # for a task's start and goal).
    half = width / 2
    if cx < w / 2:
        horizontal = box(cx - half, cy - half, w, cy + half)
    else:
        horizontal = box(0, cy - half, cx + half, cy + half)
    if cy < h / 2:
        vertical = box(cx - half, cy - half, cx + half, h)
    else:
        vertical = box(cx - half, 0, cx + half, cy + half)
    return horizontal.union(vertical)


def plan_region(
    bounds: Bounds, cfg: RegionConfig, rng: np.random.Generator, *, seed: int | None = None
) -> tuple[Zone, ...]:
    """Zones of a small scene without roads: a walkable region against non-walkable ground."""
    (x0, y0), (x1, y1) = bounds.min, bounds.max
    names = ("straight", "l_turn", "crossing", "plaza")
    weights = np.array([getattr(cfg.shapes, n) for n in names], dtype=float)
    shape = names[int(rng.choice(len(names), p=weights / weights.sum()))]
    region = _region_shape(shape, x1 - x0, y1 - y0, rng, cfg)
    region = affinity.translate(region, x0, y0)
    if shape == "plaza" and "plaza" in cfg.walkable:
        kind = "plaza"
    else:
        kind = str(cfg.walkable[int(rng.integers(len(cfg.walkable)))])
    scene = box(x0, y0, x1, y1)
    layers: list[Layer] = [(kind, None, region)]
    for part in _polygons(shapely.difference(scene, region, grid_size=GRID)):
        layers.append((str(cfg.non_walkable[int(rng.integers(len(cfg.non_walkable)))]), None, part))
    pieces = _arrange(scene, layers)
    if not pieces:
        raise GenerationError("ground", seed, "the region layout left no ground")
    return _zones(pieces)
