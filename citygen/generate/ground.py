"""Stage 2: ground planning around a road network, the scene's ground divided into functional zones.

Around the road blocks (:func:`plan_ground`), in priority order:

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

Without roads, the 10 m and 15 m Urban-Nav squares are laid out by
:mod:`citygen.generate.layouts.region`; a city's lots by :mod:`citygen.generate.layouts.city`,
from the same street bands (:func:`street_bands`).

Zones tile the bounds exactly. Each band is a union of per-block buffers. The scene is
cut into lots by jittered grid lines and each lot is divided on its own, from copies of
the bands clipped by recursive bisection (each cut touches only the geometry near it),
so the work grows with the area and every zone stays a small polygon. Within a lot, all
band boundaries are noded once on a grid and polygonised; each face takes the kind of
the first band covering it (:func:`citygen.generate.zoning.arrange`), so neighbouring zones share
every vertex bit for bit; across lots, both sides of a cut compute its crossings the
same way.
"""

from __future__ import annotations

import itertools
import math
import warnings
from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon, box

from citygen.errors import GenerationError
from citygen.generate.zoning import (
    GRID,
    QUAD_SEGS,
    Layer,
    Piece,
    arrange,
    clip_to_lots,
    polygons,
    snap,
    to_zones,
)
from citygen.geometry.roads import block_geometry, block_kind
from citygen.seeding import child, uniform
from citygen.spec.config import GroundConfig
from citygen.spec.scene import Bounds
from citygen.spec.zones import Zone

#: A lot this much farther than the setback from a sidewalk still faces the street, in metres.
FACING = 3.0
#: Trails cross open land along every this many rows and columns of lots.
TRAIL_EVERY = 3


def _cuts(lo: float, hi: float, size: Sequence[float], rng: np.random.Generator) -> list[float]:
    """Jittered grid lines from ``lo`` to ``hi``, spaced by draws from ``size``."""
    cuts, x = [lo], lo
    while True:
        x += uniform(rng, size)
        if x >= hi - 0.5 * size[0]:
            break
        cuts.append(snap(x))
    cuts.append(hi)
    return cuts


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
        midblock = block_kind(block).midblock
        if midblock:
            sites = sites if r.random() < cfg.midblock_crosswalk_probability else ()
        for site in sites:
            depth = uniform(r, cfg.crosswalk_width)
            if site.room < depth + 0.5:
                continue
            offset = site.offset + (site.room - depth) / 2 if midblock else site.offset
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
    clip_to_lots(layers, xs, ys, 0, len(xs) - 1, 0, len(ys) - 1, clipped)
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

        pieces += arrange(lot, layers, fill)
    return to_zones(pieces)


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
            footprints = [f for f in polygons(inset) if f.area >= 40.0]
            if footprints:
                yard = Polygon(part.exterior, [*part.interiors, *(f.exterior for f in footprints)])
                return [*(("building", None, f) for f in footprints), ("vegetation", None, yard)]
    if faces_street and r.random() < cfg.plaza_probability:
        return [("plaza", None, part)]
    trail_row, trail_col = row % TRAIL_EVERY == 1, col % TRAIL_EVERY == 2
    if open_land and (trail_row or trail_col) and part.area >= 300.0:
        # Trails cross open land along every few rows and columns of lots, so they join up.
        x0, y0, x1, y1 = lot.bounds
        x, y = snap((x0 + x1) / 2), snap((y0 + y1) / 2)
        half = snap(uniform(r, (1.5, 2.5)) / 2)
        trail = shapely.union_all(
            ([box(x0, y - half, x1, y + half)] if trail_row else [])
            + ([box(x - half, y0, x + half, y1)] if trail_col else [])
        )
        rest = shapely.difference(lot, trail)
        return [("trail", None, trail), *(("vegetation", None, p) for p in polygons(rest))]
    return [("vegetation", None, part)]


def __getattr__(name: str):
    """``plan_region``, moved to :mod:`citygen.generate.layouts.region` (the old name warns, for
    one release)."""
    if name == "plan_region":
        from citygen.generate.layouts import region

        warnings.warn(
            "citygen.generate.ground.plan_region moved to citygen.generate.layouts.region.plan_region; "
            "the old name goes in the next release",
            DeprecationWarning,
            stacklevel=2,
        )
        return region.plan_region
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
