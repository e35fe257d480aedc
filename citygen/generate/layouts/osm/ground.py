"""Stage 2 for ``layout = "osm"``: the ground of a real place, as its map draws it.

Layers, in priority order (:func:`~citygen.generate.zoning.arrange`: each point goes to the
first layer covering it, so the zones tile the box exactly):

1. **building** footprints as mapped (closed ways and multipolygons with their courtyards),
   each its own zone named by its OSM id (``building-w45``), never merged with its neighbour;
2. **crosswalks** at mapped crossings (``highway=crossing`` nodes on a street,
   ``footway=crossing`` ways, a footway's signalised crossing of tram tracks), each named by
   its OSM id, then across every arm of every junction (:mod:`.streets`) where no crossing
   is mapped near it;
3. **roadway**: each street's centre line widened to its width, the corners where streets
   meet rounded to the curb radius; **curb** around it;
4. **bike_lane**: mapped cycleways;
5. **sidewalk** beside the streets that have them (furnishing, clear and frontage strips as
   the city lays them out), and mapped footways, pedestrian ways and steps (clear strip);
6. **trail**: mapped paths, tracks and bridleways;
7. **plaza** (squares, pedestrian areas, marketplaces), **parking**, **water**, then
   **vegetation** (parks, grass, woods); the land nobody mapped is vegetation too.

The box is cut into lots of :data:`LOT` metres, each divided on its own; a building or a mapped
crossing cut by a lot's edge is joined again.
"""

from __future__ import annotations

import math
from collections import defaultdict

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon, box
from shapely.geometry.base import BaseGeometry

from citygen.generate.layouts.osm.streets import CORNER, CURB, Junction, Street
from citygen.generate.zoning import GRID, QUAD_SEGS, arrange, clip_to_lots, polygons, to_zones
from citygen.spec.zones import Zone

#: Side of the lots the box is divided in, in metres.
LOT = 100.0
#: Depth of a crosswalk along the street, in metres.
CROSSWALK = 3.0
#: A mapped crossing this near a junction's arm (m past its crosswalk's site) stands for it.
CROSSING_NEAR = 8.0
#: Layers that leave room to a mapped object standing on them (a tree beside a cycleway, in a
#: parking lot): not the roadway, whose streets are drawn narrower instead.
GIVES_ROOM = ("bike_lane", "parking")
#: Marks a layer that is one mapped feature (kept whole and named by its OSM id).
MAPPED = "osm:"

#: Widths (m) of walkways by ``highway`` value, and the zone kind they are.
WALKWAYS = {
    "footway": (2.0, "sidewalk"),
    "pedestrian": (4.0, "sidewalk"),
    "steps": (2.0, "sidewalk"),
    "living_street": (3.0, "sidewalk"),
    "path": (1.5, "trail"),
    "track": (3.0, "trail"),
    "bridleway": (2.0, "trail"),
    "cycleway": (2.0, "bike_lane"),
}


def area_kind(tags: dict) -> str | None:
    """The zone kind a mapped area is, or None when the scene does not draw it."""
    if tags.get("building", "no") != "no":
        return "building"
    if (
        tags.get("place") == "square"
        or tags.get("highway") == "pedestrian"
        or tags.get("area:highway") in ("pedestrian", "footway")
        or tags.get("amenity") == "marketplace"
    ):
        return "plaza"
    if tags.get("amenity") in ("parking", "bicycle_parking") and tags.get("parking", "surface") == "surface":
        return "parking" if tags.get("amenity") == "parking" else None
    if (
        tags.get("natural") == "water"
        or tags.get("waterway") == "riverbank"
        or tags.get("landuse") in ("reservoir", "basin")
    ):
        return "water"
    if (
        tags.get("leisure") in ("park", "garden", "playground", "pitch", "dog_park")
        or tags.get("landuse")
        in ("grass", "meadow", "forest", "recreation_ground", "village_green", "cemetery")
        or tags.get("natural") in ("wood", "scrub", "grassland", "heath")
    ):
        return "vegetation"
    return None


def street_ground(
    streets: list[Street],
    joints: list[Junction],
    crossings: list[tuple[str, Polygon]],
    rooms: list[tuple[tuple[float, float], float]] = (),
    tracks: list[tuple[str, Polygon]] = (),
):
    """The streets' layers: crosswalks (mapped ones named), roadway, curbs, sidewalk strips.
    ``rooms`` are mapped objects' points and the radius (m) they need: the corners where
    streets meet are not rounded over them (their streets are drawn narrower beside them,
    :func:`.streets.give_way`). ``tracks`` are ``(OSM id, crosswalk)`` of mapped crossings
    of no street (a footway's over tram tracks), crosswalks as mapped."""
    lines = shapely.union_all(
        [LineString(s.points).buffer(s.half, quad_segs=QUAD_SEGS) for s in streets], grid_size=GRID
    )
    roads = lines.buffer(CORNER_FILL, quad_segs=QUAD_SEGS).buffer(-CORNER_FILL, quad_segs=QUAD_SEGS)
    if len(rooms):
        keep = shapely.union_all([Point(p).buffer(r + CURB, quad_segs=4) for p, r in rooms])
        keep = keep.difference(lines.buffer(CURB, quad_segs=QUAD_SEGS))
        if not keep.is_empty and keep.intersects(roads):
            roads = roads.difference(keep)
    curbs = roads.buffer(CURB, quad_segs=QUAD_SEGS)
    mapped = [(f"{MAPPED}{fid}", shapely.intersection(poly, curbs)) for fid, poly in crossings]
    mapped += [(f"{MAPPED}{fid}", poly) for fid, poly in tracks]
    near = shapely.union_all([p for _, p in crossings]).buffer(CROSSING_NEAR) if crossings else Polygon()
    walks = []
    for j in joints:
        for arm in j.arms:
            s = arm.edge.street
            if not any(s.sidewalks):
                continue
            pts = arm.edge.points if arm.outward else arm.edge.points[::-1]
            line = LineString(pts)
            offset = j.half + CORNER + 0.5  # the block's crosswalk site: its half width, corner and a step
            if line.length < offset + CROSSWALK + 1.0:
                continue
            band = _across(line, offset, offset + CROSSWALK, s.half + CURB + 0.01)
            if not band.intersects(near):
                walks.append(band)
    crosswalks = shapely.intersection(shapely.union_all(walks), curbs) if walks else Polygon()
    strips: dict[str, list] = {"furnishing": [], "clear": [], "frontage": []}
    for s in streets:
        width = s.sidewalk_width
        reach = {"furnishing": 0.25 * width, "clear": 0.85 * width, "frontage": width}
        line = LineString(s.points)
        for strip, r in reach.items():
            d = s.half + CURB + r
            if all(s.sidewalks):
                strips[strip].append(line.buffer(d, quad_segs=QUAD_SEGS))
            elif s.sidewalks[0]:
                strips[strip].append(line.buffer(d, single_sided=True))
            elif s.sidewalks[1]:
                strips[strip].append(line.buffer(-d, single_sided=True))
    sidewalks = {k: shapely.union_all(v) if v else Polygon() for k, v in strips.items()}
    layers = [*(("crosswalk", key, g) for key, g in mapped), ("crosswalk", None, crosswalks)]
    layers += [("roadway", None, roads), ("curb", None, curbs)]
    return layers, sidewalks


#: Radius (m) of the fillets where streets meet (the curb's corner radius).
CORNER_FILL = 3.0


def _across(line: LineString, a: float, b: float, span: float) -> Polygon:
    """A band across ``line`` from ``a`` to ``b`` metres along it, ``span`` to each side."""
    p, q = line.interpolate(a), line.interpolate(b)
    d = np.array([q.x - p.x, q.y - p.y])
    d /= max(float(np.hypot(*d)), 1e-9)
    n = np.array([-d[1], d[0]])
    p, q = np.array([p.x, p.y]), np.array([q.x, q.y])
    return Polygon([p - span * n, q - span * n, q + span * n, p + span * n])


def crossing_at(point: np.ndarray, street: Street, k: int) -> Polygon:
    """A crosswalk centred on ``street``'s vertex ``k`` (a mapped crossing node)."""
    pts = street.points
    a, b = pts[max(k - 1, 0)], pts[min(k + 1, len(pts) - 1)]
    d = (b - a) / max(float(np.hypot(*(b - a))), 1e-9)
    n = np.array([-d[1], d[0]])
    span, half = street.half + CURB + 0.01, CROSSWALK / 2
    c = np.asarray(point)
    return Polygon(
        [c - half * d - span * n, c + half * d - span * n, c + half * d + span * n, c - half * d + span * n]
    )


def plan_ground(
    size: tuple[float, float],
    street_layers: list,
    sidewalks: dict,
    walkways: list[tuple[str, BaseGeometry]],
    areas: list[tuple[str, str, Polygon]],
    room: BaseGeometry | None = None,
) -> tuple[Zone, ...]:
    """Zones tiling the box of ``size`` from the layers (see the module docstring).

    ``walkways`` are ``(kind, shape)`` of mapped footways, paths and cycleways; ``areas``
    ``(kind, osm id, polygon)`` of mapped areas; ``room`` is ground the cycleways and parking
    leave to the mapped objects standing there (the ground under it is the next layer's)."""
    frame = box(0.0, 0.0, *size)
    buildings = [(f"{MAPPED}{fid}", poly) for kind, fid, poly in areas if kind == "building"]
    layers = [("building", key, poly) for key, poly in buildings] + street_layers
    by_kind: dict[str, list] = defaultdict(list)
    for kind, shape in walkways:
        by_kind[kind].append(shape)
    layers.append(
        ("bike_lane", None, shapely.union_all(by_kind["bike_lane"]) if by_kind["bike_lane"] else None)
    )
    layers += [("sidewalk", strip, g) for strip, g in sidewalks.items()]
    layers.append(
        ("sidewalk", "clear", shapely.union_all(by_kind["sidewalk"]) if by_kind["sidewalk"] else None)
    )
    layers.append(("trail", None, shapely.union_all(by_kind["trail"]) if by_kind["trail"] else None))
    for kind in ("plaza", "parking", "water", "vegetation"):
        shapes = [poly for k, _, poly in areas if k == kind]
        layers.append((kind, None, shapely.union_all(shapes) if shapes else None))
    if room is not None and not room.is_empty:
        layers = [
            (k, s, g.difference(room) if k in GIVES_ROOM and g is not None and g.intersects(room) else g)
            for k, s, g in layers
        ]
    layers = [(k, s, g) for k, s, g in layers if g is not None and not g.is_empty and g.intersects(frame)]
    xs = _cuts(size[0])
    ys = _cuts(size[1])
    shapes = [g for _, _, g in layers]
    for g in shapes:
        shapely.prepare(g)
    clipped: dict[tuple[int, int], list] = {}
    clip_to_lots(shapes, xs, ys, 0, len(xs) - 1, 0, len(ys) - 1, clipped)
    pieces = []
    for (j, i), parts in sorted(clipped.items()):
        lot = box(xs[i], ys[j], xs[i + 1], ys[j + 1])
        pieces += arrange(lot, [(k, s, g) for (k, s, _), g in zip(layers, parts, strict=True)])
    return _named(pieces)


def _cuts(side: float) -> list[float]:
    n = max(1, math.ceil(side / LOT))
    return [round(side * k / n, 3) for k in range(n)] + [side]


def _named(pieces: list) -> tuple[Zone, ...]:
    """Zones of the pieces: a mapped feature's pieces joined again and named by its OSM id."""
    plain, mapped = [], defaultdict(list)
    for kind, strip, poly in pieces:
        if strip is not None and strip.startswith(MAPPED):
            mapped[(kind, strip[len(MAPPED) :])].append(poly)
        else:
            plain.append((kind, strip, poly))
    names = []
    for (kind, fid), parts in mapped.items():
        joined = parts[0] if len(parts) == 1 else shapely.union_all(parts, grid_size=GRID)
        for k, poly in enumerate(polygons(joined)):
            plain.append((kind, None, poly))
            names.append(f"{kind}-{fid}" if k == 0 else f"{kind}-{fid}-{k + 1}")
    zones = to_zones(plain)
    head = len(zones) - len(names)
    return zones[:head] + tuple(
        z.model_copy(update={"id": n}) for z, n in zip(zones[head:], names, strict=True)
    )
