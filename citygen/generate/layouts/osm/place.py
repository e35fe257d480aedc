"""A box of an OpenStreetMap extract in scene metres: what the ``osm`` layout's stages read.

:func:`load_place` reads the extract (:mod:`.read`), projects it (:mod:`.project`), and sorts
what it maps into the streets and their graph (:mod:`.streets`), the walkways, the areas, the
crossings, the signals and the mapped objects. It is cached by the file's path, size and
modification time and the box, so the stages that need the map after the ground (the mapped
objects, the traverse route) read the file once per process.
"""

from __future__ import annotations

import math
import os
from collections import defaultdict
from dataclasses import dataclass, replace
from functools import lru_cache
from pathlib import Path

import numpy as np
import shapely
import shapely.ops
from shapely.geometry import LineString, Polygon

from citygen.errors import SpecError
from citygen.generate.layouts.osm.buildings import LEVEL
from citygen.generate.layouts.osm.ground import CROSSWALK, WALKWAYS, area_kind, crossing_at
from citygen.generate.layouts.osm.objects import SLIM, Mapped, category_of, clearance, direction_of
from citygen.generate.layouts.osm.project import Projection
from citygen.generate.layouts.osm.read import Extract, read_extract
from citygen.generate.layouts.osm.streets import (
    GAP,
    Edge,
    Junction,
    Street,
    edges_of,
    give_way,
    is_street,
    junctions,
    street,
)
from citygen.spec.osm import OsmArea, OsmSource

#: Largest side of a box, in metres: a 3 km x 3 km box stays within the generator's memory
#: bounds (about 2 GiB for a dense city centre).
MAX_SIDE_M = 3_000.0
#: Smallest side of a box, in metres.
MIN_SIDE_M = 20.0
#: A mapped traffic signal on a street this near a junction (m) signalises it.
SIGNAL_REACH = 30.0
#: A signal mapped away from junctions signalises the mapped crossing this near it (m along
#: its street), else it is a signalised crossing of its own.
CROSSING_REACH = 15.0
#: The mapped objects streets give way to: all but bus shelters.
GIVE_WAY = frozenset(SLIM) - {"bus_stop_shelter"}


@dataclass(frozen=True)
class Place:
    """A box of an extract in scene metres (see the module docstring)."""

    source: OsmSource
    projection: Projection
    streets: tuple[Street, ...]
    drawn: tuple[Street, ...]
    """The streets as the ground draws them: a street narrowed somewhere (:func:`.streets.give_way`)
    as its edges, each as wide as it is drawn; the others whole."""
    edges: tuple[Edge, ...]
    junctions: tuple[Junction, ...]
    walkways: tuple[tuple[str, Polygon], ...]
    """``(zone kind, shape)`` of mapped footways, paths and cycleways."""
    areas: tuple[tuple[str, str, Polygon], ...]
    """``(zone kind, OSM id, polygon)`` of mapped areas (buildings, plazas, parks ...)."""
    heights: dict
    """A building's height (m) by its OSM id, where the map gives ``height`` or ``building:levels``."""
    crossings: tuple[tuple[str, Polygon], ...]
    """``(OSM id, crosswalk)`` of mapped crossings."""
    signalised: frozenset[int]
    """Junction nodes with traffic signals (:func:`_lights`)."""
    approaches: tuple[tuple[int, tuple[float, float]], ...]
    """``(junction node, position)`` of the signals mapped on signalised junctions' approaches."""
    junction_walks: tuple[tuple[int, str], ...]
    """``(junction node, OSM id)`` of the signalised crossings a signalised junction serves."""
    signal_crossings: tuple[tuple[str, tuple[float, float], tuple], ...]
    """``(OSM id, position, signals)`` of the crossings signalised on their own, each named by
    its crosswalk's id (``crosswalk-<OSM id>``), with the positions of the signals mapped for
    it on its street (where its lights stand)."""
    track_crossings: tuple[tuple[str, Polygon, tuple], ...]
    """``(OSM id, crosswalk, ends)`` of the footways and cycleways with signalised crossings
    on no street (of tram or rail tracks, which the scene does not draw), by
    :func:`_track_crossings`."""
    mapped: tuple[Mapped, ...]


def check_area(area: OsmArea) -> None:
    """Raise :class:`~citygen.errors.SpecError` (one line) when the box is not a box."""
    west, south, east, north = area.bbox
    if not (west < east and south < north and south >= -85.0 and north <= 85.0):
        raise SpecError(
            f"--bbox: expected WEST,SOUTH,EAST,NORTH in degrees with west < east, south < north and "
            f"latitudes within 85, got {_box(area.bbox)}"
        )


def load_place(area: OsmArea) -> Place:
    """The place of ``area`` (cached; see the module docstring)."""
    check_area(area)
    path = Path(area.file)
    stat = os.stat(path) if path.is_file() else None
    key = (stat.st_size, stat.st_mtime_ns) if stat else None
    return _load(str(path), tuple(area.bbox), key)


@lru_cache(maxsize=4)
def _load(file: str, bbox: tuple[float, float, float, float], _key) -> Place:
    projection = Projection.for_box(bbox)
    width, depth = projection.size
    if max(width, depth) > MAX_SIDE_M or min(width, depth) < MIN_SIDE_M:
        raise SpecError(
            f"--bbox: expected a box {MIN_SIDE_M:g} m to {MAX_SIDE_M:,.0f} m a side (the memory bounds), "
            f"got {width:,.0f} m x {depth:,.0f} m ({_box(bbox)})"
        )
    data = read_extract(file, bbox)
    name = Path(file).name
    if data.extent is None or not _overlaps(data.extent, bbox):
        found = "no data" if data.extent is None else f"data within {_box(data.extent)}"
        raise SpecError(f"{name}: expected a --bbox overlapping the file's data, got {_box(bbox)} ({found})")
    return _sort(data, projection, OsmSource(file=name, bbox=bbox, projection=projection.proj), name)


def _sort(data: Extract, projection: Projection, source: OsmSource, name: str) -> Place:
    def xy(coords) -> np.ndarray:
        arr = np.asarray(coords, dtype=float)
        return projection.xy(arr[:, 0], arr[:, 1])

    frame = shapely.box(0.0, 0.0, *projection.size)
    streets, walkways, crossing_ways, paths = [], [], [], []
    for way in data.ways:
        points = xy(way.coords)
        if is_street(way.tags):
            streets.append(street(way.id, way.tags, points, way.nodes))
        elif way.tags.get("highway") in WALKWAYS and way.tags.get("tunnel", "no") == "no":
            width, kind = WALKWAYS[way.tags["highway"]]
            width = _float(way.tags.get("width")) or width
            line = LineString(points)
            walkways.append((kind, line.buffer(width / 2, quad_segs=4)))
            paths.append((way, line, width))
            if way.tags.get("footway") == "crossing":
                crossing_ways.append((way, line, width))
    if not any(LineString(s.points).intersects(frame) for s in streets):
        raise SpecError(
            f"{name}: expected streets (highway=* ways vehicles drive on) inside the box, got none"
        )
    mapped = []
    for f in data.nodes:
        category = category_of(f.tags)
        if category is None:
            continue
        ((x, y),) = xy([f.coords])
        if 0.0 <= x <= projection.size[0] and 0.0 <= y <= projection.size[1]:
            mapped.append(Mapped(f.id, category, (float(x), float(y)), direction_of(f.tags)))
    edges, degree = edges_of(streets)
    # The streets give way to the furniture and trees mapped beside them (a bus shelter, set
    # back from the curb behind its stop's node, does not narrow its street).
    edges = give_way(edges, [(m.position, clearance(m.category)) for m in mapped if m.category in GIVE_WAY])
    position = {n: s.points[k] for s in streets for k, n in enumerate(s.nodes)}
    joints = junctions(edges, degree, position)
    nodes = {int(f.id[1:]): f for f in data.nodes}
    lights = _lights(streets, {j.node for j in joints}, nodes)
    # Mapped crossings: nodes on a street, then crossing ways without such a node, then a
    # crossing at each signal mapped away from junctions and crossings.
    crossings, crossing_nodes = [], set()
    for s in streets:
        for k, n in enumerate(s.nodes):
            f = nodes.get(n)
            if f is not None and f.tags.get("highway") == "crossing" and degree.get(n, 0) < 3:
                crossings.append((f.id, crossing_at(s.points[k], s, k)))
                crossing_nodes.add(n)
    for way, line, width in crossing_ways:
        if not crossing_nodes.intersection(way.nodes):
            crossings.append((way.id, line.buffer(width / 2, cap_style="flat")))
    for s, k in lights.made:
        crossings.append((f"n{s.nodes[k]}", crossing_at(s.points[k], s, k)))
    areas, heights = [], {}
    for f in data.areas:
        kind = area_kind(f.tags)
        if kind is None:
            continue
        polys = [Polygon(xy(outer), [xy(h) for h in holes]) for outer, holes in f.coords]
        shape = (
            shapely.make_valid(shapely.union_all(polys)) if len(polys) > 1 else shapely.make_valid(polys[0])
        )
        shape = shape.intersection(frame)
        if shape.is_empty or shape.area < 0.5:
            continue
        areas.append((kind, f.id, shape))
        if kind == "building" and (h := _height(f.tags)) is not None:
            heights[f.id] = h
    return Place(
        source=source,
        projection=projection,
        streets=tuple(streets),
        drawn=tuple(_drawn(streets, edges)),
        edges=tuple(edges),
        junctions=tuple(joints),
        walkways=tuple(walkways),
        areas=tuple(areas),
        heights=heights,
        crossings=tuple(crossings),
        signalised=lights.junctions,
        approaches=lights.approaches,
        junction_walks=lights.walks,
        signal_crossings=lights.crossings,
        track_crossings=_track_crossings(paths, streets, nodes, frame),
        mapped=tuple(mapped),
    )


def _track_crossings(paths: list, streets: list[Street], nodes: dict, frame: Polygon) -> tuple:
    """The signalised crossings (:func:`is_signal_crossing`) mapped in ``frame`` on a footway
    or cycleway of ``paths`` (``(way, line, width)``) and on no street: where it crosses tram
    or rail tracks, which the scene does not draw. Per way, its OSM id, its crosswalk (the
    way as wide as mapped, from :data:`~.ground.CROSSWALK` / 2 before its first such node to
    as far past its last: the tracks it crosses) and its two ends (``((x, y), yaw)``: facing
    out along the way, on the way's edge to the left of that heading), where its lights
    stand."""
    on_streets = {n for s in streets for n in s.nodes}
    out = []
    for way, line, width in paths:
        at = [
            line.project(shapely.Point(line.coords[k]))
            for k, n in enumerate(way.nodes)
            if n not in on_streets
            and n in nodes
            and is_signal_crossing(nodes[n].tags)
            and frame.contains(shapely.Point(line.coords[k]))
        ]
        if not at:
            continue
        a, b = max(min(at) - CROSSWALK / 2, 0.0), min(max(at) + CROSSWALK / 2, line.length)
        walk = shapely.ops.substring(line, a, b)
        p, q = np.asarray(walk.coords[0]), np.asarray(walk.coords[-1])
        d = (q - p) / max(float(np.hypot(*(q - p))), 1e-9)
        left = np.array([-d[1], d[0]]) * width / 2
        ends = (
            ((float(p[0] - left[0]), float(p[1] - left[1])), math.atan2(-d[1], -d[0])),
            ((float(q[0] + left[0]), float(q[1] + left[1])), math.atan2(d[1], d[0])),
        )
        out.append((way.id, walk.buffer(width / 2, cap_style="flat"), ends))
    return tuple(out)


def rooms(place: Place) -> list[tuple[Mapped, float]]:
    """The mapped objects the ground gives way to (:data:`GIVE_WAY`), each with the radius (m)
    kept clear around its point: its slimmest variant's (:func:`.objects.clearance`) and a
    margin (:data:`.streets.GAP`)."""
    return [(m, clearance(m.category) + GAP) for m in place.mapped if m.category in GIVE_WAY]


def _drawn(streets: list[Street], edges: list[Edge]) -> list[Street]:
    """The streets as drawn (see :attr:`Place.drawn`)."""
    pieces: dict[str, list[Edge]] = {}
    for e in edges:
        pieces.setdefault(e.street.id, []).append(e)
    out = []
    for s in streets:
        own = pieces.get(s.id, [])
        if all(e.street is s for e in own):
            out.append(s)
        else:
            out += [replace(e.street, points=e.points, nodes=e.nodes) for e in own]
    return out


@dataclass(frozen=True)
class Lights:
    """What a place's mapped traffic signals signalise (:func:`_lights`)."""

    junctions: frozenset[int]
    """Junction nodes with traffic signals."""
    approaches: tuple[tuple[int, tuple[float, float]], ...]
    """``(junction node, position)`` of the signals mapped on a signalised junction's approaches."""
    walks: tuple[tuple[int, str], ...]
    """``(junction node, OSM id)`` of the signalised crossings a signalised junction's plan serves."""
    crossings: tuple[tuple[str, tuple[float, float], tuple], ...]
    """``(OSM id, position, signals)`` of the crossings signalised on their own, with the
    positions of the signals mapped for them on their street."""
    made: tuple[tuple[Street, int], ...]
    """``(street, vertex)`` of the signals that are signalised crossings of their own."""


def _lights(streets: list[Street], joints: set[int], nodes: dict) -> Lights:
    """What the map's signals signalise, in three rounds:

    1. a ``highway=traffic_signals`` node on a junction's node, or on a street within
       :data:`SIGNAL_REACH` of one (along it), signalises that junction: the light of the
       approach it is on stands there;
    2. a signalised crossing (``highway=crossing`` with ``crossing=traffic_signals`` or
       ``crossing:signals=yes``) within :data:`SIGNAL_REACH` of a signalised junction is served by
       that junction's plan; any other is signalised on its own;
    3. a signal node further from every junction signalises the mapped crossing on its
       street within :data:`CROSSING_REACH` of it on its own (the light of its approach
       stands there), else it is a signalised crossing itself.
    """
    arcs = {s.id: np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(s.points, axis=0).T))]) for s in streets}

    ends: dict[int, list[Street]] = defaultdict(list)
    for s in streets:
        ends[s.nodes[0]].append(s)
        ends[s.nodes[-1]].append(s)

    def nearest(s: Street, k: int, among) -> int | None:
        """The node of ``among`` nearest along the streets to ``s``'s vertex ``k`` (on ``s``, or
        on a street going on from an end of ``s``), within reach."""
        arc = arcs[s.id]
        near = [(abs(arc[k] - arc[j]), n) for j, n in enumerate(s.nodes) if n in among and j != k]
        for at in (0, len(s.nodes) - 1):
            base = abs(arc[k] - arc[at])
            for t in ends[s.nodes[at]] if s.nodes[at] not in among else ():
                if t is not s:
                    i = 0 if t.nodes[0] == s.nodes[at] else len(t.nodes) - 1
                    near += [
                        (base + abs(arcs[t.id][i] - arcs[t.id][j]), n)
                        for j, n in enumerate(t.nodes)
                        if n in among
                    ]
        near = [x for x in near if x[0] <= SIGNAL_REACH]
        return min(near)[1] if near else None

    def tagged(n: int, test) -> bool:
        f = nodes.get(n)
        return f is not None and test(f.tags)

    def xy(s: Street, k: int) -> tuple[float, float]:
        return (float(s.points[k][0]), float(s.points[k][1]))

    lit, approaches, walks, own, made = set(), {}, {}, {}, []
    for s in streets:
        for k, n in enumerate(s.nodes):
            if not tagged(n, is_signal):
                continue
            if n in joints:
                lit.add(n)
            elif (j := nearest(s, k, joints)) is not None:
                lit.add(j)
                approaches[n] = (j, xy(s, k))
    for s in streets:
        for k, n in enumerate(s.nodes):
            if n in joints or not tagged(n, is_signal_crossing):
                continue
            if (j := nearest(s, k, lit)) is not None:
                walks[n] = (j, f"n{n}")
            else:
                own.setdefault(f"n{n}", (xy(s, k), []))
    for s in streets:
        arc = arcs[s.id]
        for k, n in enumerate(s.nodes):
            if n in joints or not tagged(n, is_signal) or nearest(s, k, joints) is not None:
                continue
            near = [
                (abs(arc[k] - arc[j]), j)
                for j, m in enumerate(s.nodes)
                if m not in joints and tagged(m, lambda t: t.get("highway") == "crossing")
            ]
            near = [w for w in near if w[0] <= CROSSING_REACH]
            j = min(near)[1] if near else k
            if f"n{s.nodes[j]}" not in own:
                own[f"n{s.nodes[j]}"] = (xy(s, j), [])
                if j == k:
                    made.append((s, k))
            if j != k and xy(s, k) not in own[f"n{s.nodes[j]}"][1]:
                own[f"n{s.nodes[j]}"][1].append(xy(s, k))
    return Lights(
        frozenset(lit),
        tuple(v for _, v in sorted(approaches.items())),
        tuple(v for _, v in sorted(walks.items())),
        tuple((fid, at, tuple(sorted(lights))) for fid, (at, lights) in sorted(own.items())),
        tuple(made),
    )


def is_signal(tags: dict) -> bool:
    """A ``highway=traffic_signals`` node."""
    return tags.get("highway") == "traffic_signals"


def is_signal_crossing(tags: dict) -> bool:
    """A signalised crossing node (``crossing=traffic_signals`` or ``crossing:signals=yes``)."""
    return tags.get("highway") == "crossing" and (
        tags.get("crossing") == "traffic_signals" or tags.get("crossing:signals") == "yes"
    )


def _height(tags: dict) -> float | None:
    """A building's height (m): ``height``, else :data:`~.buildings.LEVEL` m a level of
    ``building:levels``; None when the map gives neither."""
    height = _float(tags.get("height"))
    if height is not None:
        return height
    levels = _float(tags.get("building:levels"))
    return LEVEL * levels if levels is not None else None


def _float(text: str | None) -> float | None:
    if not text:
        return None
    try:
        value = float(text.strip().removesuffix("m").strip())
    except ValueError:
        return None
    return value if math.isfinite(value) and value > 0 else None


def _overlaps(a, b) -> bool:
    return a[0] < b[2] and b[0] < a[2] and a[1] < b[3] and b[1] < a[3]


def _box(b) -> str:
    return ",".join(f"{v:.6g}" for v in b)
