"""Stage 4 for ``layout = "osm"``: street furniture and trees where the map puts them.

Each mapped node of :data:`MAPPED` (``amenity=bench``, ``natural=tree``, ``barrier=bollard``,
...) becomes an object of citygen's own catalog of the matching category, standing on the
mapped point and named by its OSM id (``bench-n123``). Its variant is one of a small palette
per category drawn from the placement stage's generator; it faces the ``direction`` the map
gives (degrees clockwise from north), else the nearest street.

An object stands only where its category belongs or on open ground (:data:`OPEN_GROUND`: a
bench on a park's lawn; never on the roadway, a curb, parking, water or in a building) and
clear of the objects placed before it. The ground gives way to it where it can: a street is
drawn narrower where the map puts an object beside it, a cycleway, a parking lot or a curb
ramp leaves room around it (:func:`clearance`; :mod:`.streets`, :mod:`.ground`). Where the
mapped point is still not such a place, it moves up to :data:`NUDGE` metres to the nearest spot
that is, else it is left out (and counted).

Its variant is its palette's, else a slimmer one of the palette, else the category's slimmest
(:data:`SLIM`), so a tree mapped in a narrow pit is a thin tree on its point; and while
another mapped object's point is not yet taken, none covers it (a broad tree does not take
the bench mapped under its crown), unless nothing else fits.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Point, Polygon

from citygen.assets.catalog import CATEGORIES, resolve
from citygen.generate.placement import _base_ring, base_of
from citygen.geometry.terrain import height_at
from citygen.spec.placements import Placement
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

#: (key, value, category): what a mapped node is in citygen's catalog, first match wins.
MAPPED = (
    ("amenity", "bench", "bench"),
    ("leisure", "picnic_table", "bench"),
    ("amenity", "waste_basket", "trash_bin"),
    ("amenity", "recycling", "recycling_bin"),
    ("natural", "tree", "tree"),
    ("natural", "shrub", "bush"),
    ("barrier", "bollard", "bollard"),
    ("highway", "street_lamp", "lamp_post"),
    ("amenity", "bicycle_parking", "bike_rack"),
    ("emergency", "fire_hydrant", "fire_hydrant"),
    ("amenity", "post_box", "mailbox"),
    ("amenity", "telephone", "telephone_booth"),
    ("advertising", "column", "advertising_board"),
    ("advertising", "board", "advertising_board"),
    ("amenity", "vending_machine", "parking_meter"),
    ("highway", "bus_stop", "bus_stop_shelter"),
    ("highway", "stop", "street_sign"),
    ("highway", "give_way", "street_sign"),
)
#: Ground any mapped object may stand on besides its category's (a bench on a park's lawn).
OPEN_GROUND = frozenset({"sidewalk", "plaza", "trail", "vegetation"})
#: Variants of each category one scene draws its mapped objects from.
PALETTE = 4
#: Farthest (m) a mapped object moves to stand where it belongs.
NUDGE = 0.45
#: Each category's slimmest variant of 0000-0063 (the smallest base about its origin), the
#: last variant a mapped object tries; its base's radius is the room the ground leaves it.
SLIM = {
    "advertising_board": "advertising_board/0056",
    "bench": "bench/0009",
    "bike_rack": "bike_rack/0020",
    "bollard": "bollard/0026",
    "bus_stop_shelter": "bus_stop_shelter/0014",
    "bush": "bush/0039",
    "fire_hydrant": "fire_hydrant/0010",
    "lamp_post": "lamp_post/0057",
    "mailbox": "mailbox/0044",
    "parking_meter": "parking_meter/0040",
    "recycling_bin": "recycling_bin/0063",
    "street_sign": "street_sign/0007",
    "telephone_booth": "telephone_booth/0001",
    "trash_bin": "trash_bin/0027",
    "tree": "tree/0056",
}


@dataclass(frozen=True)
class Mapped:
    """A mapped object: its OSM id, catalog category, position (m) and heading, if mapped."""

    id: str
    category: str
    position: tuple[float, float]
    direction: float | None

    @property
    def placement_id(self) -> str:
        """The id of its placement in a scene, by category and OSM id (``bench-n123``)."""
        return f"{self.category.replace('_', '-')}-{self.id}"


@functools.cache
def clearance(category: str) -> float:
    """Radius (m) of the base of a category's slimmest variant (:data:`SLIM`) about its
    point: the least room a mapped object of it needs.

    >>> round(clearance("tree"), 3), round(clearance("bench"), 3)
    (0.139, 0.657)
    """
    ring = _base_ring(resolve(SLIM[category]))
    return float(np.max(np.hypot(ring[:, 0], ring[:, 1])))


def category_of(tags: dict) -> str | None:
    """The catalog category of a mapped node, or None."""
    for key, value, category in MAPPED:
        if tags.get(key) == value:
            return category
    return None


def direction_of(tags: dict) -> float | None:
    """The yaw (rad, counter-clockwise from east) of a node's ``direction`` tag in degrees."""
    try:
        return math.radians(90.0 - float(tags["direction"]))
    except (KeyError, ValueError):
        return None


def place_mapped(
    mapped: list[Mapped],
    zones: list[Zone],
    terrain: Terrain | None,
    streets: shapely.Geometry,
    rng: np.random.Generator,
    taken: list[Polygon] = (),
) -> tuple[list[Placement], int]:
    """The placements of ``mapped`` (see the module docstring) and how many were left out.
    ``streets`` is the street centre lines an object faces when the map gives no direction;
    ``taken`` is ground no object may reach (the curb ramps, which stay clear for wheels)."""
    polys = [Polygon(z.polygon, z.holes) for z in zones]
    kinds = np.array([z.kind for z in zones])
    tree = shapely.STRtree(polys)
    palette = {
        name: [f"{name}/{int(v):04d}" for v in rng.choice(10_000, PALETTE, replace=False)]
        for name in sorted({m.category for m in mapped})
    }
    slimmest = {name: sorted(variants, key=_base_area) for name, variants in palette.items()}
    placed: list[Placement] = []
    bases: list[Polygon] = list(taken)
    # Each mapped point, kept for its own object while that is not placed.
    points = [Point(m.position).buffer(clearance(m.category), quad_segs=4) for m in mapped]
    reserved = shapely.STRtree(points)
    waiting = np.ones(len(mapped), dtype=bool)
    left_out = 0
    for k, m in enumerate(mapped):
        # Its own variant first, then the category's others, slimmest first: a street tree
        # mapped on a narrow sidewalk is a slimmer tree on its point, not left out.
        own = palette[m.category][k % PALETTE]
        assets = [own, *(a for a in slimmest[m.category] if a != own)]
        assets += [SLIM[m.category]] if SLIM[m.category] not in assets else []
        yaw = m.direction if m.direction is not None else _facing(m.position, streets)
        yaw = round(math.remainder(yaw, 2 * math.pi), 6) + 0.0
        suits = CATEGORIES[m.category].zones | OPEN_GROUND
        waiting[k] = False
        found = None
        for spare in (True, False):  # others' points kept free, then (nothing fits) not
            for (dx, dy), asset in ((d, a) for d in _nudges() for a in assets):
                x, y = round(m.position[0] + dx, 3) + 0.0, round(m.position[1] + dy, 3) + 0.0
                probe = Placement(id="probe", asset=asset, position=(x, y, 0.0), yaw=yaw)
                base = base_of(probe)
                if spare and waiting[reserved.query(base, predicate="intersects")].any():
                    continue
                hits = tree.query(base, predicate="intersects")
                if not len(hits) or not all(
                    kinds[i] in suits for i in hits if polys[i].intersection(base).area > 1e-6
                ):
                    continue
                if not shapely.union_all([polys[i] for i in hits]).buffer(1e-4).covers(base):
                    continue
                if any(base.intersects(b) for b in bases):
                    continue
                found = (probe, base, x, y)
                break
            if found is not None:
                break
        if found is None:
            left_out += 1
            continue
        probe, base, x, y = found
        ring = np.asarray(base.exterior.coords)
        z = float(np.min(height_at(terrain, np.append(ring[:, 0], x), np.append(ring[:, 1], y))))
        placed.append(
            probe.model_copy(
                update={
                    "id": m.placement_id,
                    "position": (x, y, round(z, 3) + 0.0),
                }
            )
        )
        bases.append(base)
    return placed, left_out


def _base_area(asset: str) -> float:
    return Polygon(_base_ring(resolve(asset))).area


def _nudges() -> list[tuple[float, float]]:
    """Offsets (m) tried in turn: none, then rings out to :data:`NUDGE`."""
    out = [(0.0, 0.0)]
    for r in (0.15, 0.3, NUDGE):
        out += [(r * math.cos(a), r * math.sin(a)) for a in np.arange(8) * math.pi / 4]
    return out


def _facing(position: tuple[float, float], streets) -> float:
    """Heading from ``position`` to the nearest street centre line (rad), 0 without streets."""
    if streets is None or streets.is_empty:
        return 0.0
    p = Point(position)
    q = streets.interpolate(streets.project(p))
    if q.distance(p) < 1e-6:
        return 0.0
    return math.atan2(q.y - p.y, q.x - p.x)
