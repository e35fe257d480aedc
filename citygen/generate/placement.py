"""Stage 4: static objects from the asset catalog, placed where real ones stand.

Every object goes into zones its category suits (:attr:`Category.zones`), at the spot
its :data:`~citygen.assets.category.Anchor` names: street furniture in the sidewalk's
furnishing strip lined up with the curb and facing the road, hydrants and traffic
lights near crosswalk ends, cafe tables along the building line, benches and planters
anywhere on a plaza, one building massing fitted into every building lot. The clear
strip of a sidewalk (the pedestrian through zone) stays clear, as street design guides
ask; small region scenes have no strips, so there objects stand anywhere suitable.

A candidate is kept when its base (:attr:`Asset.base`, the parts a robot can walk
into):

1. lies inside the zones its category suits (so never on the roadway or in a building);
2. stands on ground flat enough (:data:`MAX_TILT` of rise under the base);
3. keeps ``max(config.clearance, its clearance, the other's)`` metres from every object;
4. leaves the robot's start and goal discs clear, and, when the task needs a path,
   leaves start and goal in one connected piece of free space for the robot's radius
   (:mod:`citygen.generate.space`): an object may stand in the way, never cut it.

How many: ``config.count`` objects (exact) or ``density_per_100m2`` per 100 m2 of the
ground the categories suit, times the scene's density level (Urban-Nav-2's 50 %, 100 %,
150 %); when an object finds no room in :data:`TRIES` candidates the draw starts again from
the next stream (:data:`ATTEMPTS` draws, then a last one of :data:`PATIENT_TRIES` candidates
an object), and when every draw fails the stage fails with a
:class:`~citygen.errors.GenerationError` giving the numbers, never places fewer in silence.
Buildings fill their lots and are not counted. Each scene draws a small palette
of variants per category, so a street repeats its bench model as real streets do (and
instancing exporters stay small).
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry

from citygen.assets import CATEGORIES, resolve
from citygen.assets.catalog import Asset
from citygen.errors import GenerationError
from citygen.generate.space import GRID, Sampler, free_space, grid_path, walkable_ground, zone_polygon
from citygen.generate.task import Endpoints
from citygen.geometry.terrain import height_at
from citygen.seeding import child
from citygen.spec.config import PlacementConfig
from citygen.spec.placements import Placement
from citygen.spec.scene import Bounds
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

PALETTE = 6
"""Variants of each category one scene draws from."""
TRIES = 60
"""Candidates drawn per object before the stage gives up on it."""
ATTEMPTS = 8
"""Draws of a scene's furniture that ran out of room before the last, patient one."""
PATIENT_TRIES = 600
"""Candidates drawn per object in the last draw: a crowded scene's last gaps are found by
sampling longer (it runs only where every draw of :data:`TRIES` failed, once an error)."""
MAX_TILT = 0.12
"""Most rise (m) of the ground under an object's base."""
CROSSING_REACH = 6.0
"""How far (m) from a crosswalk ``crossing`` objects (hydrants, traffic lights) stand."""
ROADS = ("roadway", "bike_lane", "parking")
MIN_BUILDING_SCALE = 0.25
"""Smallest scale a building massing is shrunk to to fit its lot; smaller lots stay empty."""
EXACT_AREA = 5_000.0
"""Walkable area (m2) up to which placement keeps the task's connection exactly (see :class:`_Path`)."""
HASH = 8.0
"""Cell size (m) of the spatial hash of placed objects."""


class _Region:
    """Zones a base must stay inside, without their union: a base inside one zone is in;
    one straddling neighbours is tested against the union of just those (the zones tile
    the ground without overlap, so that is exact)."""

    def __init__(self, polygons: list[Polygon]):
        self.polygons = np.asarray(polygons, dtype=object)
        self.tree = shapely.STRtree(self.polygons)
        self.area = float(sum(p.area for p in polygons))
        for p in polygons:
            shapely.prepare(p)

    def covers(self, shape: Polygon) -> bool:
        hits = self.tree.query(shape, predicate="intersects")
        if len(hits) == 0:
            return False
        if any(self.polygons[k].covers(shape) for k in hits):
            return True
        return len(hits) > 1 and shapely.union_all(self.polygons[np.sort(hits)], grid_size=GRID).covers(shape)


@dataclass
class _Slot:
    """Where one category's objects may stand: pieces of ground to draw from (each with the
    zone whose principal direction it takes) and the region their bases must stay inside."""

    pieces: list[tuple[Polygon, Polygon]]
    region: _Region
    faces_road: bool
    ground: _Ground
    area: float = 0.0
    _weights: np.ndarray | None = None

    def __post_init__(self) -> None:
        areas = np.array([p.area for p, _ in self.pieces])
        self.area = float(areas.sum())
        self._weights = np.cumsum(areas) / self.area if self.area > 0 else areas

    def draw(self, rng: np.random.Generator) -> tuple[tuple[float, float], float]:
        """A uniform point of the slot and the principal direction of its piece (rad)."""
        k = min(int(np.searchsorted(self._weights, rng.random(), side="right")), len(self.pieces) - 1)
        piece, zone = self.pieces[k]
        return self.ground.sampler(piece).point(rng), self.ground.axis(zone)


def _axis(polygon: Polygon) -> float:
    """Direction (rad, in [0, pi)) of the long side of the polygon's minimum rotated rectangle."""
    rect = np.asarray(polygon.minimum_rotated_rectangle.exterior.coords)
    if len(rect) < 4:
        return 0.0
    e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
    e = e1 if np.hypot(*e1) >= np.hypot(*e2) else e2
    return float(math.atan2(e[1], e[0]) % math.pi)


class _Ground:
    """The scene's zones, grouped the ways placement asks for them."""

    def __init__(self, zones: Sequence[Zone]):
        self.zones = zones
        self.polys = [zone_polygon(z) for z in zones]
        self.strips = any(z.strip is not None for z in zones)
        roads = [p for p, z in zip(self.polys, zones, strict=True) if z.kind in ROADS]
        self.road_tree = shapely.STRtree(roads) if roads else None
        self.roads = roads
        crossings = [p for p, z in zip(self.polys, zones, strict=True) if z.kind == "crosswalk"]
        self.near_crossings = (
            shapely.union_all(crossings, grid_size=GRID).buffer(CROSSING_REACH, quad_segs=4)
            if crossings
            else None
        )
        self._slots: dict[str, _Slot | None] = {}
        self._regions: dict[frozenset[int], _Region] = {}
        # By polygon identity; each entry holds its polygon, so no identity is reused.
        self._axes: dict[int, tuple[Polygon, float]] = {}
        self._samplers: dict[int, tuple[Polygon, Sampler]] = {}

    def axis(self, polygon: Polygon) -> float:
        """:func:`_axis` of a polygon, computed once per scene (many slots share a zone)."""
        hit = self._axes.get(id(polygon))
        if hit is None:
            hit = self._axes[id(polygon)] = (polygon, _axis(polygon))
        return hit[1]

    def sampler(self, polygon: Polygon) -> Sampler:
        """A :class:`Sampler` of a polygon, triangulated once per scene, when first drawn from."""
        hit = self._samplers.get(id(polygon))
        if hit is None:
            hit = self._samplers[id(polygon)] = (polygon, Sampler(polygon))
        return hit[1]

    def usable(self, zone: Zone, kinds: frozenset[str]) -> bool:
        """A zone of one of ``kinds``, and not a sidewalk's clear strip."""
        return zone.kind in kinds and zone.strip != "clear"

    def slot(self, name: str) -> _Slot | None:
        if name not in self._slots:
            self._slots[name] = self._make_slot(name)
        return self._slots[name]

    def _make_slot(self, name: str) -> _Slot | None:
        cat = CATEGORIES[name]
        kinds = frozenset(cat.zones) - {"building"}
        chosen = [
            (p, z)
            for p, z in zip(self.polys, self.zones, strict=True)
            if self.usable(z, kinds) and p.area > 0
        ]
        if not chosen:
            return None
        key = frozenset(id(p) for p, _ in chosen)
        if key not in self._regions:
            self._regions[key] = _Region([p for p, _ in chosen])
        region = self._regions[key]
        anchor = cat.anchor if self.strips else "free"
        if anchor in ("curb", "crossing"):
            draw = [(p, z) for p, z in chosen if z.strip == "furnishing" or z.kind == "curb"]
        elif anchor == "frontage":
            draw = [(p, z) for p, z in chosen if z.strip == "frontage" or z.kind == "plaza"]
        else:
            draw = chosen
        pieces = [(p, p) for p, _ in draw]
        if anchor == "crossing" and self.near_crossings is not None:
            pieces = [
                (g, p)
                for p, _ in pieces
                for g in shapely.get_parts(p.intersection(self.near_crossings))
                if isinstance(g, Polygon) and g.area > 1e-3
            ]
        if not pieces:
            return None
        return _Slot(pieces, region, anchor in ("curb", "crossing", "frontage") and bool(self.roads), self)

    def toward_road(self, x: float, y: float) -> float | None:
        """Heading (rad) from the point to the nearest roadway, or None without roads."""
        if self.road_tree is None:
            return None
        pt = Point(x, y)
        k = int(self.road_tree.query_nearest(pt)[0])
        end = shapely.shortest_line(pt, self.roads[k]).coords[1]
        if math.dist(end, (x, y)) < 1e-9:
            return None
        return math.atan2(end[1] - y, end[0] - x)


class _Hash:
    """Placed bases in a uniform grid of cells, for distance queries near a candidate."""

    def __init__(self) -> None:
        self.cells: dict[tuple[int, int], list[int]] = defaultdict(list)
        self.shapes: list[Polygon] = []
        self.clearance: list[float] = []

    def _keys(self, bounds: Sequence[float]) -> list[tuple[int, int]]:
        x0, y0, x1, y1 = (math.floor(v / HASH) for v in bounds)
        return [(i, j) for i in range(x0, x1 + 1) for j in range(y0, y1 + 1)]

    def clear(self, shape: Polygon, clearance: float, floor: float, reach: float) -> bool:
        """Whether ``shape`` keeps ``max(floor, clearance, other's)`` from every placed base;
        ``reach`` bounds every clearance."""
        x0, y0, x1, y1 = shape.bounds
        near = sorted({k for key in self._keys((x0 - reach, y0 - reach, x1 + reach, y1 + reach))
                       for k in self.cells.get(key, ())})  # fmt: skip
        if not near:
            return True
        gaps = np.maximum(max(floor, clearance), np.asarray([self.clearance[k] for k in near]))
        others = np.asarray([self.shapes[k] for k in near], dtype=object)
        return not bool(shapely.dwithin(shape, others, gaps - 1e-9).any())

    def add(self, shape: Polygon, clearance: float) -> None:
        k = len(self.shapes)
        self.shapes.append(shape)
        self.clearance.append(clearance)
        for key in self._keys(shape.bounds):
            self.cells[key].append(k)


def _pose(points: np.ndarray, x: float, y: float, yaw: float, scale: float = 1.0) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return points * scale @ np.array([[c, s], [-s, c]]) + (x, y)


def _base_ring(asset: Asset) -> np.ndarray:
    return np.asarray(asset.base.exterior.coords)


def base_of(placement: Placement) -> Polygon:
    """A catalog placement's base (:attr:`Asset.base`) in the scene: scaled, turned, moved."""
    x, y = placement.position[:2]
    ring = _base_ring(resolve(placement.asset))
    return Polygon(_pose(ring, x, y, placement.yaw, placement.scale))


class _Path:
    """Keeps a walkable connection between the robot's start and goal while objects are placed.

    In scenes up to :data:`EXACT_AREA` of walkable ground the connection is kept exactly:
    the connected piece of free space holding the start (the walkable ground shrunk by the
    robot's clearance, minus the objects grown by it) must still cover the goal with each
    new object, so an object may stand in the way but never cut it. In larger scenes that
    test would cost a polygon difference over the whole city per object, so a corridor of
    the robot's clearance along one shortest walkable path is kept free instead.
    """

    def __init__(self, ground: BaseGeometry, ends: Endpoints):
        self.start, self.goal, self.radius = Point(ends.start), Point(ends.goal), ends.radius
        self.piece = self._holding_start(free_space(ground, (), ends.radius))
        self.corridor: BaseGeometry | None = None
        if self.piece is not None and self.piece.area > EXACT_AREA:
            path = grid_path(self.piece, ends.start, ends.goal)
            if path is not None:
                self.corridor = LineString(path).buffer(self.radius, quad_segs=4)
                shapely.prepare(self.corridor)

    def _holding_start(self, free: BaseGeometry) -> BaseGeometry | None:
        for g in shapely.get_parts(free):
            if g.covers(self.start):
                shapely.prepare(g)
                return g
        return None

    def allows(self, base: Polygon) -> bool:
        """Whether start and goal stay connected with ``base`` standing; if so, keep it."""
        if self.corridor is not None:
            return not self.corridor.intersects(base)
        if self.piece is None:
            return True
        grown = base.buffer(self.radius, quad_segs=4)
        if not self.piece.intersects(grown):
            return True
        rest = self._holding_start(shapely.difference(self.piece, grown))
        if rest is None or not rest.covers(self.goal):
            return False
        self.piece = rest
        return True


class _Palettes:
    """The variants of each category one scene draws from (:data:`PALETTE` of its 10,000),
    drawn on first use: category ``k`` of the sorted catalog from ``child(rng, k)``, which
    depends only on the stage's seed and ``k``, so the order of use changes nothing."""

    def __init__(self, rng: np.random.Generator):
        self.rng = rng
        self.keys = {name: k for k, name in enumerate(sorted(CATEGORIES))}
        self.drawn: dict[str, list[str]] = {}

    def __getitem__(self, name: str) -> list[str]:
        hit = self.drawn.get(name)
        if hit is None:
            picks = child(self.rng, self.keys[name]).choice(10_000, PALETTE, replace=False)
            hit = self.drawn[name] = [f"{name}/{int(v):04d}" for v in picks]
        return hit


def target_count(cfg: PlacementConfig, level: float, area: float) -> int:
    """Objects to place: ``count`` or the density over ``area`` (m2), times ``level``."""
    base = cfg.count if cfg.count is not None else cfg.density_per_100m2 * area / 100.0
    return math.floor(base * level + 0.5)


def place_objects(
    bounds: Bounds,
    zones: Sequence[Zone],
    terrain: Terrain | None,
    cfg: PlacementConfig,
    rng: np.random.Generator,
    *,
    level: float = 1.0,
    ends: Endpoints | None = None,
    seed: int = 0,
    walkable: BaseGeometry | None = None,
) -> tuple[Placement, ...]:
    """The scene's static objects: buildings in their lots, then the counted furniture.

    ``rng`` is the placement stage's generator; ``level`` the density factor; ``ends``
    the task's start and goal to keep clear and connected; ``seed`` only labels errors;
    ``walkable`` the walkable ground when the caller has it.
    """
    names = cfg.categories or tuple(CATEGORIES)
    unknown = [n for n in names if n not in CATEGORIES]
    if unknown:
        raise GenerationError(
            "placement", seed, f"unknown categories {unknown}: expected some of {', '.join(CATEGORIES)}"
        )
    ground = _Ground(zones)
    palettes = _Palettes(rng)
    placed: list[Placement] = []
    if "building" in names:
        placed += _buildings(ground, palettes, terrain)
    furniture = [n for n in sorted(set(names)) if CATEGORIES[n].anchor != "lot"]
    slots = {n: s for n in furniture if (s := ground.slot(n)) is not None}
    # The zones tile the ground, so the area they cover is the sum over distinct zones.
    ground_zones = {id(p): p.area for s in slots.values() for p in s.region.polygons}
    area = float(sum(ground_zones.values()))  # in insertion order, never by address
    wanted = target_count(cfg, level, area)
    if not slots or wanted == 0:
        return tuple(placed)
    keep_out = _keep_out(ends)
    if ends is not None and ends.needs_path and walkable is None:
        walkable = walkable_ground(zones, (*bounds.min, *bounds.max))
    reach = max(cfg.clearance, *(CATEGORIES[n].clearance for n in slots))
    # A draw that runs out of room is drawn again from the next child generator, with a last
    # draw of PATIENT_TRIES candidates an object; only a request that fails every draw is an
    # error. The first draw's stream is the one every scene always had, so a scene that fits
    # at once keeps its bytes, and so does every scene that generated before: draws after one
    # far short of its count, and the last patient draw, ran only where placement used to fail
    # (35 and 50 m NavStatic scenes at 4 objects per 100 m2, whose furniture ground is narrow:
    # 23 of 49 and 90 of 150 placed, candidates turned away as too close to those placed).
    for attempt in range(ATTEMPTS + 1):
        stream = child(rng, 200 if attempt == 0 else 200 + attempt)
        path = _Path(walkable, ends) if ends is not None and ends.needs_path else None
        tries = TRIES if attempt < ATTEMPTS else PATIENT_TRIES
        scattered, done = _scatter(
            slots, palettes, ground, terrain, cfg, wanted, reach, keep_out, path, stream, tries
        )
        if scattered is not None:
            return (*placed, *scattered)
    asked = (
        f"placement.count = {cfg.count}"
        if cfg.count is not None
        else f"placement.density_per_100m2 = {cfg.density_per_100m2:g}"
    )
    raise GenerationError("placement", seed, (
        f"placed {done} of the {wanted} objects asked for ({asked}, density level {level:g}): "
        f"{PATIENT_TRIES} candidates for the next found no room in the {area:,.0f} m2 of zones they suit, "
        f"{cfg.clearance:g} m apart; "
        "ask for fewer objects, a smaller clearance or a larger scene"
    ))  # fmt: skip


def _scatter(slots, palettes, ground, terrain, cfg, wanted, reach, keep_out, path, rng, tries):
    """``wanted`` furniture objects drawn from ``rng`` (see :func:`place_objects`), or
    ``(None, n)`` when the ``n + 1``-th finds no room in ``tries`` candidates."""
    placed: list[Placement] = []
    taken = _Hash()
    order = list(slots)
    counts: dict[str, int] = defaultdict(int)
    for done in range(wanted):
        for _ in range(tries):
            name = order[int(rng.integers(len(order)))]
            asset = resolve(palettes[name][int(rng.integers(PALETTE))])
            slot = slots[name]
            (x, y), axis = slot.draw(rng)
            yaw = None
            if slot.faces_road:
                yaw = ground.toward_road(x, y)
            if yaw is None:
                yaw = axis + int(rng.integers(4)) * math.pi / 2
            yaw = round(math.remainder(yaw, 2 * math.pi), 6) + 0.0
            ring = _pose(_base_ring(asset), x, y, yaw)
            base = Polygon(ring)
            if not slot.region.covers(base):
                continue
            if keep_out is not None and keep_out.intersects(base):
                continue
            z = _ground_height(terrain, ring, x, y)
            if z is None:
                continue
            if not taken.clear(base, asset.clearance, cfg.clearance, reach):
                continue
            if path is not None and not path.allows(base):
                continue
            taken.add(base, asset.clearance)
            counts[name] += 1
            placed.append(
                Placement(
                    id=f"{name.replace('_', '-')}-{counts[name]}", asset=asset.id, position=(x, y, z), yaw=yaw
                )
            )
            break
        else:  # no room for one more
            return None, done
    return placed, wanted


def _keep_out(ends: Endpoints | None) -> BaseGeometry | None:
    """The robot's discs at start and goal, and its corridor along a traverse route."""
    if ends is None:
        return None
    if ends.route:
        line = LineString([ends.start, *ends.route])
        shape = line.buffer(ends.radius, quad_segs=4)
    else:
        shape = shapely.union_all([Point(p).buffer(ends.radius, quad_segs=8) for p in ends.points])
    shapely.prepare(shape)
    return shape


def _ground_height(terrain: Terrain | None, ring: np.ndarray, x: float, y: float) -> float | None:
    """The lowest ground under the base (m), or None where it rises more than :data:`MAX_TILT`."""
    if terrain is None:
        return 0.0
    xs = np.append(ring[:, 0], x)
    ys = np.append(ring[:, 1], y)
    zs = height_at(terrain, xs, ys)
    if float(zs.max() - zs.min()) > MAX_TILT:
        return None
    return round(float(zs.min()), 3) + 0.0


def _buildings(ground: _Ground, palettes: _Palettes, terrain: Terrain | None) -> list[Placement]:
    """One building massing per building lot: of the palette's variants, the one that fits
    the lot nearest its real size, turned to the lot's long side with its front toward the
    nearest road, scaled to fill the lot's rectangle and shrunk until it fits inside."""
    out = []
    variants: list[Asset] = []  # resolved at the first lot: most small scenes have none
    for poly, zone in zip(ground.polys, ground.zones, strict=True):
        if zone.kind != "building" or poly.area < 4.0:
            continue
        variants = variants or [resolve(v) for v in palettes["building"]]
        fits = [(f, a) for a in variants if (f := _fit(a, poly, ground)) is not None]
        if not fits:
            continue
        (x, y, yaw, scale), asset = min(fits, key=lambda fa: abs(math.log(fa[0][3])))
        ring = _pose(_base_ring(asset), x, y, yaw, scale)
        z = _ground_height(terrain, ring, x, y)
        out.append(
            Placement(
                id=f"building-{len(out) + 1}",
                asset=asset.id,
                position=(x, y, 0.0 if z is None else z),
                yaw=yaw,
                scale=scale,
            )
        )
    return out


def _fit(asset: Asset, lot: Polygon, ground: _Ground) -> tuple[float, float, float, float] | None:
    """Position, yaw and scale of ``asset`` filling ``lot``, or None when it only fits below
    :data:`MIN_BUILDING_SCALE`. Centred on the lot's minimum rotated rectangle, or, for
    an irregular lot, on the centre of its largest inscribed circle."""
    rect = lot.minimum_rotated_rectangle
    axis = _axis(rect)
    corners = np.asarray(rect.exterior.coords)[:4]
    short_side, long_side = sorted(
        [np.hypot(*(corners[1] - corners[0])), np.hypot(*(corners[2] - corners[1]))]
    )
    inner = shapely.get_point(shapely.maximum_inscribed_circle(lot, 0.1), 0)
    centres = [rect.centroid, inner]
    facing = ground.toward_road(centres[0].x, centres[0].y)
    aim = axis if facing is None else facing
    turns = sorted(range(4), key=lambda k: abs(math.remainder(axis + k * math.pi / 2 - aim, 2 * math.pi)))
    ring = _base_ring(asset)
    c, s = math.cos(axis), math.sin(axis)
    for centre in centres:
        for k in turns[:2]:
            yaw = round(math.remainder(axis + k * math.pi / 2, 2 * math.pi), 6) + 0.0
            local = _pose(ring, 0.0, 0.0, yaw - axis)  # the base in the rectangle's frame
            ext = local.max(axis=0) - local.min(axis=0)
            mid = (local.max(axis=0) + local.min(axis=0)) / 2
            scale = min(0.92 * long_side / ext[0], 0.92 * short_side / ext[1], 2.0)
            while scale >= MIN_BUILDING_SCALE:
                off = mid * scale @ np.array([[c, s], [-s, c]])
                x, y = round(float(centre.x - off[0]), 3) + 0.0, round(float(centre.y - off[1]), 3) + 0.0
                q = round(float(scale), 3)
                if lot.covers(Polygon(_pose(ring, x, y, yaw, q))):
                    return x, y, yaw, q
                scale *= 0.85
    return None
