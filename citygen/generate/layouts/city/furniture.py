"""Stage 4 for ``layout = "city"``: street furniture along the sidewalks, by frontage.

After the scattered objects of :func:`~citygen.generate.placement.place_objects`, each
sidewalk's furnishing strip (by the curb) gets rows of objects at the spacing street design
guides give, chosen by what the street fronts:

- **downtown** (a street wall: a building nearer the strip than any lawn): trees every 9 m, lamps
  every 27 m, bins and benches every 45 m, parking meters every 24 m, bike racks and
  newspaper boxes every 90 m;
- **residential** (houses behind front yards): trees every 12 m, lamps every 36 m, bins
  every 90 m, mailboxes every 150 m;
- **open** (parks, plazas, parking): lamps every 30 m, benches every 25 m, bins every 50 m,
  bollards every 6 m along plazas;
- **everywhere**: a hydrant every 100 m and a street sign every 120 m.

Each row starts at a random phase along the strip; an object is kept where its base lies
on the sidewalk, keeps its clearance from every object already there, stands on level
ground at the sidewalk's level (not on a curb ramp, steps or a terrace) and off the
traverse route's corridor. Objects placed before that stand on a curb ramp are dropped:
the ramps stay clear for wheels.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from citygen.assets.catalog import CATEGORIES, resolve
from citygen.generate.layouts.city.curbs import CURB
from citygen.generate.placement import _base_ring, _Hash, _Palettes, _pose, base_of
from citygen.geometry.features import feature_polygon
from citygen.geometry.terrain import height_at
from citygen.seeding import child
from citygen.spec.placements import Placement
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

#: Rows of each frontage: (category, spacing in m).
ROWS: dict[str, tuple[tuple[str, float], ...]] = {
    "downtown": (
        ("tree", 9.0), ("lamp_post", 27.0), ("trash_bin", 45.0), ("bench", 45.0),
        ("parking_meter", 24.0), ("bike_rack", 90.0), ("newspaper_box", 90.0),
    ),
    "residential": (("tree", 12.0), ("lamp_post", 36.0), ("recycling_bin", 90.0), ("mailbox", 150.0)),
    "open": (("lamp_post", 30.0), ("bench", 25.0), ("trash_bin", 50.0)),
    "plaza": (("bollard", 6.0), ("lamp_post", 30.0), ("bench", 25.0), ("trash_bin", 50.0)),
}  # fmt: skip
EVERYWHERE = (("fire_hydrant", 100.0), ("street_sign", 120.0))
#: A strip fronts downtown when a building stands this close (m), residential within HOUSES.
WALL, HOUSES = 8.0, 20.0
#: Widest (m) an object's base may be across the strip (its narrower side).
NARROW = 0.9
#: Smallest gap (m) between two objects' bases.
GAP = 0.3
#: Largest rise (m) of the ground under an object's base: level ground.
LEVEL = 0.02


def street_furniture(
    zones: Sequence[Zone],
    terrain: Terrain | None,
    placed: Sequence[Placement],
    rng: np.random.Generator,
    *,
    keep_clear: BaseGeometry | None = None,
) -> tuple[Placement, ...]:
    """``placed`` followed by the rows of furniture of every furnishing strip (see the
    module docstring); ``keep_clear`` (m) is ground no object may reach."""
    polys = [Polygon(z.polygon, z.holes) for z in zones]
    ramps = shapely.STRtree(
        [feature_polygon(f) for f in (terrain.features or ()) if f.id.startswith("curb-ramp-")]
        if terrain is not None
        else []
    )
    placed = [p for p in placed if not len(ramps.query(base_of(p), predicate="intersects"))]
    strips = [
        p for p, z in zip(polys, zones, strict=True) if z.kind == "sidewalk" and z.strip == "furnishing"
    ]
    walk = shapely.STRtree([p for p, z in zip(polys, zones, strict=True) if z.kind == "sidewalk"])
    walk_polys = [p for p, z in zip(polys, zones, strict=True) if z.kind == "sidewalk"]
    buildings = shapely.STRtree([p for p, z in zip(polys, zones, strict=True) if z.kind == "building"])
    plazas = shapely.STRtree([p for p, z in zip(polys, zones, strict=True) if z.kind == "plaza"])
    lawns = shapely.STRtree([p for p, z in zip(polys, zones, strict=True) if z.kind == "vegetation"])
    if keep_clear is not None:
        shapely.prepare(keep_clear)
    taken = _Hash()
    for p in placed:
        taken.add(base_of(p), CATEGORIES[p.asset.split("/")[0]].clearance if "/" in p.asset else 0.0)
    palettes = _Palettes(child(rng, 0))
    counts: dict[str, int] = {}
    for p in placed:
        stem, _, tail = p.id.rpartition("-")
        counts[stem] = max(counts.get(stem, 0), int(tail) if tail.isdigit() else 0)  # bench-n123: mapped
    fits: dict[str, list] = {}

    def fitting(name: str) -> list:
        """The palette's variants of ``name`` narrow enough for a furnishing strip (street
        trees in tree pits, not park trees)."""
        if name not in fits:
            variants = [resolve(v) for v in palettes[name]]
            fits[name] = [a for a in variants if min(_sides(a.base)) <= NARROW]
        return fits[name]

    r = child(rng, 1)
    out = list(placed)
    reach = max(c.clearance for c in CATEGORIES.values()) + GAP
    for strip in strips:
        frontage = _frontage(strip, buildings, plazas, lawns)
        rect = np.asarray(strip.minimum_rotated_rectangle.exterior.coords)[:4]
        e1, e2 = rect[1] - rect[0], rect[2] - rect[1]
        long_e, short_e, a0 = (e1, e2, rect[0]) if np.hypot(*e1) >= np.hypot(*e2) else (e2, e1, rect[1])
        length = float(np.hypot(*long_e))
        if length < 3.0:
            continue
        u = long_e / length
        start = a0 + short_e / 2  # the centre line, from one short side
        yaw = math.atan2(u[1], u[0])
        for name, spacing in (*ROWS[frontage], *EVERYWHERE):
            phase = float(r.uniform(0.0, spacing))
            for s in np.arange(phase, length, spacing):
                spot = _across(strip, start + u * s, short_e)
                if spot is None:
                    continue
                x, y = spot
                choices = fitting(name)
                if not choices:
                    break
                asset = choices[int(r.integers(len(choices)))]
                bx0, by0, bx1, by1 = asset.base.bounds
                turn = yaw + math.pi / 2 if by1 - by0 > bx1 - bx0 else yaw  # long side along the street
                ring = _pose(_base_ring(asset), x, y, turn)
                base = Polygon(ring)
                if not _on_sidewalk(base, walk, walk_polys):
                    continue
                if keep_clear is not None and keep_clear.intersects(base):
                    continue
                z = _level(terrain, ring, x, y)
                if z is None:
                    continue
                clearance = min(asset.clearance, 0.5)
                if not taken.clear(base, clearance, GAP, reach):
                    continue
                taken.add(base, clearance)
                stem = name.replace("_", "-")
                counts[stem] = counts.get(stem, 0) + 1
                out.append(
                    Placement(
                        id=f"{stem}-{counts[stem]}",
                        asset=asset.id,
                        position=(round(x, 4), round(y, 4), z),
                        yaw=round(math.remainder(turn, 2 * math.pi), 6) + 0.0,
                    )
                )
    return tuple(out)


def _level(terrain: Terrain | None, ring: np.ndarray, x: float, y: float) -> float | None:
    """The ground's height (m) under a base, or None where it is not level (a curb ramp, the
    edge of the sidewalk) or higher than a sidewalk (steps, a terrace)."""
    if terrain is None:
        return 0.0
    zs = height_at(terrain, np.append(ring[:, 0], x), np.append(ring[:, 1], y))
    if float(zs.max() - zs.min()) > LEVEL or float(zs.max()) > CURB[1] + 0.05:
        return None
    return round(float(zs.min()), 3) + 0.0


def _frontage(strip: Polygon, buildings, plazas, lawns) -> str:
    """What the street of a furnishing strip fronts (see the module docstring): a plaza, a
    street wall (a building nearer than any lawn), houses behind front yards, or open land."""

    def nearest(tree: shapely.STRtree) -> float:
        if not len(tree.geometries):
            return math.inf
        return float(tree.query_nearest(strip, return_distance=True)[1][0])

    building, lawn = nearest(buildings), nearest(lawns)
    if nearest(plazas) <= WALL and nearest(plazas) < building:
        return "plaza"
    if building <= WALL and building < lawn:
        return "downtown"
    if building <= HOUSES:
        return "residential"
    return "open"


def _sides(base: Polygon) -> tuple[float, float]:
    x0, y0, x1, y1 = base.bounds
    return x1 - x0, y1 - y0


def _across(strip: Polygon, point: np.ndarray, across: np.ndarray) -> tuple[float, float] | None:
    """The middle of the strip's widest piece on the line through ``point`` along ``across``
    (the strip's short side): its centre line there, also where the strip bends."""
    a, b = point - across, point + across
    cut = strip.intersection(shapely.LineString([a.tolist(), b.tolist()]))
    parts = [g for g in shapely.get_parts(cut) if g.geom_type == "LineString" and g.length > 0]
    if not parts:
        return None
    c = max(parts, key=lambda g: g.length).interpolate(0.5, normalized=True)
    return (c.x, c.y)


def _on_sidewalk(base: Polygon, tree: shapely.STRtree, polys: list[Polygon]) -> bool:
    hits = tree.query(base, predicate="intersects")
    if not len(hits):
        return False
    if any(polys[k].covers(base) for k in hits):
        return True
    return bool(shapely.union_all([polys[k] for k in sorted(hits)], grid_size=1e-3).covers(base))
