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

Zones tile the bounds exactly. Each band is a union of per-block buffers; painting a
band removes what higher-priority bands already cover, with every overlay snapped to a
:data:`GRID` so shared boundaries are computed once and agree bit for bit. The scene is
cut into lots by jittered grid lines, and each lot is painted on its own from clipped
copies of the bands (cut by recursive bisection, so each cut touches only the geometry
near it): the work grows with the area, and every zone stays a small polygon.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import LineString, Polygon, box

from citygen.errors import GenerationError
from citygen.geometry.roads import block_geometry
from citygen.seeding import child
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
#: Lots farther than this from a street are open land (vegetation), in metres.
INTERIOR_DEPTH = 60.0
#: Trails cross open land along every this many rows and columns of lots.
TRAIL_EVERY = 3


def _uniform(rng: np.random.Generator, lo_hi: Sequence[float]) -> float:
    lo, hi = lo_hi
    return float(rng.uniform(lo, hi)) if hi > lo else float(lo)


def _snap(value: float) -> float:
    return round(round(value / GRID) * GRID, 6)


def _cuts(lo: float, hi: float, size: Sequence[float], rng: np.random.Generator) -> list[float]:
    """Jittered grid lines from ``lo`` to ``hi``, spaced by draws from ``size``."""
    cuts, x = [lo], lo
    while True:
        x += _uniform(rng, size)
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


def _polygonal(geom):
    """The polygons of a geometry, without the lines and points an overlay may leave."""
    if geom.geom_type in ("Polygon", "MultiPolygon"):
        return geom
    return shapely.MultiPolygon(_polygons(geom))


class _Painter:
    """Zones of one lot, painted in priority order: each new zone is what is left of its
    shape after the zones before it."""

    def __init__(self, lot: Polygon) -> None:
        self.lot = lot
        self.painted = Polygon()
        self.pieces: list[tuple[str, str | None, Polygon]] = []

    def paint(self, kind: str, shape, strip: str | None = None):
        if shape is None or shape.is_empty:
            return Polygon()
        inside = _polygonal(shapely.intersection(shape, self.lot, grid_size=GRID))
        piece = shapely.difference(inside, self.painted, grid_size=GRID)
        polys = [p for p in _polygons(piece) if p.area > 0]
        if not polys:
            return Polygon()
        self.pieces += [(kind, strip, p) for p in polys]
        self.painted = shapely.union(self.painted, shapely.union_all(polys), grid_size=GRID)
        return piece

    def rest(self):
        return shapely.difference(self.lot, self.painted, grid_size=GRID)

    def finish(self) -> list[tuple[str, str | None, Polygon]]:
        """The pieces rebuilt from one noding of all their boundaries, so neighbours share
        every boundary vertex exactly (separate overlays may snap a shared edge apart)."""
        if len(self.pieces) <= 1:
            return self.pieces
        shapes = np.array([p for _, _, p in self.pieces], dtype=object)
        lines = shapely.union_all([s.boundary for s in shapes] + [self.lot.boundary], grid_size=GRID)
        faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(lines)))
        faces = faces[shapely.area(faces) > 0]
        owner = np.full(len(faces), -1)
        tree = shapely.STRtree(shapes)
        face_idx, piece_idx = tree.query(shapely.point_on_surface(faces), predicate="intersects")
        owner[face_idx[::-1]] = piece_idx[::-1]  # the first piece wins on a shared point
        for f in np.flatnonzero(owner < 0):  # a sliver the snapping made: to its nearest piece
            owner[f] = int(np.argmin(shapely.distance(shapes, faces[f])))
        # Crumbs (the corner of a crosswalk, a sliver between two buffers) join the
        # neighbour they share the longest edge with, rather than being zones of their own.
        areas = shapely.area(faces)
        big = np.flatnonzero(areas >= MIN_AREA)
        if len(big) < len(faces) and len(big):
            big_tree = shapely.STRtree(faces[big])
            for f in np.flatnonzero(areas < MIN_AREA):
                near = big[big_tree.query(faces[f], predicate="intersects")]
                if len(near):
                    shared = shapely.length(shapely.intersection(faces[near], faces[f].boundary))
                    owner[f] = owner[near[int(np.argmax(shared))]]
        pieces = []
        for k, (kind, strip, _) in enumerate(self.pieces):
            mine = faces[owner == k]
            if len(mine):
                merged = mine[0] if len(mine) == 1 else shapely.union_all(mine)
                pieces += [(kind, strip, part) for part in _polygons(merged)]
        return pieces


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


def _zones(pieces: list[tuple[str, str | None, Polygon]]) -> tuple[Zone, ...]:
    counters: dict[str, int] = {}
    zones = []
    for kind, strip, poly in pieces:
        poly = shapely.normalize(poly)  # a canonical vertex order, whatever GEOS produced
        n = counters[kind] = counters.get(kind, 0) + 1
        zones.append(
            Zone(
                id=f"{kind}-{n}",
                kind=kind,
                polygon=tuple(map(tuple, np.asarray(poly.exterior.coords)[:-1].tolist())),
                holes=tuple(tuple(map(tuple, np.asarray(r.coords)[:-1].tolist())) for r in poly.interiors),
                strip=strip,
            )
        )
    return tuple(zones)


def ground_margin(cfg: GroundConfig) -> float:
    """Room for curb and sidewalk between a road and the edge of the scene, in metres."""
    return cfg.curb_width[1] + cfg.sidewalk_width[1]


def plan_ground(
    bounds: Bounds, blocks: Sequence, cfg: GroundConfig, rng: np.random.Generator, *, seed: int | None = None
) -> tuple[Zone, ...]:
    """Zones tiling ``bounds`` around the road ``blocks``."""
    if not blocks:
        raise GenerationError("ground", seed, "a road layout needs at least one block")
    (x0, y0), (x1, y1) = bounds.min, bounds.max
    scene = box(x0, y0, x1, y1)
    geoms = [block_geometry(b) for b in blocks]
    curb = _uniform(rng, cfg.curb_width)
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
            depth = _uniform(r, cfg.crosswalk_width)
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
        width = _uniform(r, cfg.sidewalk_width)
        furnishing = width * _uniform(r, (0.2, 0.3))
        frontage = width * _uniform(r, (0.1, 0.2))
        for strip, reach in (
            ("furnishing", curb + furnishing),
            ("clear", curb + width - frontage),
            ("frontage", curb + width),
        ):
            bands[strip].append(g.outline.buffer(reach, quad_segs=QUAD_SEGS))
    sidewalks = {strip: shapely.union_all(shapes) for strip, shapes in bands.items()}
    setback = _uniform(rng, cfg.building_setback)
    street = sidewalks["frontage"]
    near = street.buffer(setback, quad_segs=QUAD_SEGS) if setback > 0.25 else None
    frontage_reach = street.buffer(setback + 3.0, quad_segs=QUAD_SEGS)
    interior_reach = street.buffer(INTERIOR_DEPTH, quad_segs=2)

    xs = _cuts(x0, x1, cfg.lot_size, rng)
    ys = _cuts(y0, y1, cfg.lot_size, rng)
    layers = [crosswalks, roads, curbs, islands, *sidewalks.values(), near, frontage_reach, interior_reach]
    for g in layers:
        if g is not None:
            shapely.prepare(g)
    clipped: dict[tuple[int, int], list] = {}
    _bisect(layers, xs, ys, 0, len(xs) - 1, 0, len(ys) - 1, clipped)
    lot_seed = int(rng.integers(2**63))

    pieces: list[tuple[str, str | None, Polygon]] = []
    for (j, i), parts in sorted(clipped.items()):
        walk, road, curb_band, island, furnish, clear, front, near_band, facing, inner = parts
        painter = _Painter(box(xs[i], ys[j], xs[i + 1], ys[j + 1]).intersection(scene))
        painter.paint("crosswalk", walk)
        painter.paint("roadway", road)
        painter.paint("curb", curb_band)
        painter.paint("vegetation", island)
        painter.paint("sidewalk", furnish, "furnishing")
        painter.paint("sidewalk", clear, "clear")
        painter.paint("sidewalk", front, "frontage")
        r = np.random.default_rng([lot_seed, j, i])
        if near_band is not None:
            painter.paint("plaza" if r.random() < cfg.plaza_probability else "vegetation", near_band)
        for part in _polygons(painter.rest()):
            _fill_lot(painter, part, facing, inner, cfg, r, j, i)
        pieces += painter.finish()
    return _zones(pieces)


def _fill_lot(
    painter: _Painter, part: Polygon, facing, inner, cfg: GroundConfig, r, row: int, col: int
) -> None:
    """A building, a plaza or vegetation (with a trail) on what is left of a lot."""
    faces_street = facing is not None and not facing.is_empty and part.intersects(facing)
    interior = inner is None or inner.is_empty or not part.intersects(inner)
    if faces_street and part.area >= 60.0:
        rect = part.minimum_rotated_rectangle
        sides = sorted(
            math.dist(a, b) for a, b in zip(rect.exterior.coords, rect.exterior.coords[1:], strict=False)
        )
        if part.area >= 0.6 * rect.area and sides[0] >= 10.0 and r.random() < cfg.building_probability:
            # Side yards keep neighbouring buildings apart; the yards are lawn.
            footprint = part.buffer(-_uniform(r, (1.0, 3.0)), join_style="mitre")
            if footprint.area >= 40.0:
                painter.paint("building", footprint)
                painter.paint("vegetation", part)
                return
    if faces_street and not interior and r.random() < cfg.plaza_probability:
        painter.paint("plaza", part)
        return
    if part.area >= 300.0 and (row % TRAIL_EVERY == 1 or col % TRAIL_EVERY == 2):
        # Trails run along every few rows and columns of lots, so they join up into paths
        # across open land.
        x0, y0, x1, y1 = painter.lot.bounds
        x, y = (x0 + x1) / 2, (y0 + y1) / 2
        width = _uniform(r, (1.5, 2.5))
        lines = []
        if row % TRAIL_EVERY == 1:
            lines.append(LineString([(x0, y), (x1, y)]))
        if col % TRAIL_EVERY == 2:
            lines.append(LineString([(x, y0), (x, y1)]))
        trail = shapely.union_all(lines).buffer(width / 2, cap_style="flat", join_style="mitre")
        painter.paint("trail", shapely.intersection(trail, part, grid_size=GRID))
        part = shapely.difference(part, painter.painted, grid_size=GRID)
    painter.paint("vegetation", part)


# --- small scenes without roads -----------------------------------------------------------


def _region_shape(shape: str, w: float, h: float, rng: np.random.Generator, cfg: RegionConfig):
    """The walkable region of a ``w`` x ``h`` scene with its minimum corner at the origin."""
    width = min(_uniform(rng, cfg.path_width), 0.6 * min(w, h))
    if shape == "plaza":
        region = box(0, 0, w, h)
        islands = []
        for _ in range(int(rng.integers(1, 4)) * 8):
            if len(islands) >= 3:
                break
            radius = _uniform(rng, (0.5, 0.12 * min(w, h)))
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
    # An L-turn: from one edge to the corner point, then on to an adjacent edge.
    half = width / 2
    horizontal = (
        box(0, cy - half, cx + half, cy + half)
        if rng.random() < 0.5
        else box(cx - half, cy - half, w, cy + half)
    )
    vertical = (
        box(cx - half, 0, cx + half, cy + half)
        if rng.random() < 0.5
        else box(cx - half, cy - half, cx + half, h)
    )
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
    painter = _Painter(box(x0, y0, x1, y1))
    painter.paint(kind, region)
    for part in _polygons(painter.rest()):
        painter.paint(str(cfg.non_walkable[int(rng.integers(len(cfg.non_walkable)))]), part)
    if not painter.pieces:
        raise GenerationError("ground", seed, "the region layout left no ground")
    return _zones(painter.finish())
