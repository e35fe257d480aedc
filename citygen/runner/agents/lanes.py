"""Lanes: the paths vehicles drive through their route of blocks.

:func:`lane_path`, the path of :class:`~citygen.runner.agents.traffic.Traffic`'s vehicles:
from the start through the right lane of each block of the route (a cubic curve from the
block's entry to its exit) to the goal.

:func:`drive_path`, the path of :class:`~citygen.runner.agents.traffic.CityTraffic`'s
vehicles: the lane of each block of its route, in the turn lane at a junction (the leftmost
for a left turn, the rightmost otherwise), round a roundabout's ring counter-clockwise, a
point every :data:`STEP` metres with the speed limit of its block (:func:`speed_limit`).
Each junction block on the route is a *passage* (:class:`Passage`): from the stop line
(:data:`STOP_MARGIN` before the crosswalks of the arm it comes in by) to where it leaves the
junction's crosswalks on the way out. A signal (:func:`signal_stops`) may set the stop line
further out: before the farthest crosswalk it serves on that arm, and at its light there
(a real place's signals mapped on a junction's approaches). A straight block with a signal
(a signalised mid-block crossing) is a passage too, from :data:`STOP_MARGIN` before its
crosswalks to where the path leaves them.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from shapely.geometry import LineString, Point, Polygon

from citygen.geometry.roads import block_geometry, road_graph
from citygen.runner.agents.vec2 import dot
from citygen.spec.agents import Vehicle
from citygen.spec.blocks import Intersection, Junction, Roundabout, TIntersection

STEP = 0.5
"""Spacing (m) of the points of a drive path."""
STOP_MARGIN = 1.0
"""Distance (m) of a stop line before the crosswalk."""
ARTERIAL, LOCAL, JUNCTION, ROUNDABOUT = 13.9, 8.3, 8.3, 6.0
"""Speed limits (m/s): streets of two or more lanes each way (50 km/h), other streets and
junctions (30 km/h), roundabouts."""
CLEARANCE = 0.15
"""Lateral room (m) kept between a vehicle and what it passes; less is a thing in its path."""
JUNCTIONS = (Intersection, TIntersection, Junction, Roundabout)
ALONG = 0.5
"""A crosswalk or a light is on a junction's arm when it lies (and a light faces) within this
angle (rad) of the arm's heading from the junction's centre."""
APPROACH = 3
"""Blocks before a junction searched for a stop line its signal sets out on the approach."""


def speed_limit(block) -> float:
    """The speed limit (m/s) on a block."""
    if isinstance(block, Roundabout):
        return ROUNDABOUT
    if isinstance(block, Intersection | TIntersection | Junction):
        return JUNCTION
    return ARTERIAL if block.lanes >= 2 else LOCAL


# --- curves ---------------------------------------------------------------------------------


def _cubic(p0: np.ndarray, d0: np.ndarray, p1: np.ndarray, d1: np.ndarray, n: int = 12) -> np.ndarray:
    """Points of the cubic from ``p0`` leaving along ``d0`` to ``p1`` arriving along ``d1``."""
    k = np.linalg.norm(p1 - p0) / 3
    c0, c1 = p0 + d0 * k, p1 - d1 * k
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * c0 + 3 * (1 - t) * t**2 * c1 + t**3 * p1


def _project(path: np.ndarray, s: np.ndarray, xy: np.ndarray) -> float:
    """Arc length (m) of the point of ``path`` nearest to ``xy``."""
    a, b = path[:-1], path[1:]
    ab = b - a
    t = np.clip(dot(xy - a, ab) / np.maximum(dot(ab, ab), 1e-12), 0.0, 1.0)
    d = np.linalg.norm(a + t[:, None] * ab - xy, axis=1)
    k = int(np.argmin(d))
    return float(s[k] + t[k] * (s[k + 1] - s[k]))


# --- lanes of the simple traffic ------------------------------------------------------------


def _lane_end(block, socket: str, inward: bool) -> tuple[np.ndarray, np.ndarray]:
    """The rightmost lane's point at a block's road end and the driving direction there."""
    arm = next(a for a in block_geometry(block).arms if a.socket == socket)
    heading = arm.yaw + math.pi if inward else arm.yaw
    fwd = np.array([math.cos(heading), math.sin(heading)])
    right = np.array([fwd[1], -fwd[0]])
    return np.asarray(arm.position) + right * min(block.lane_width, arm.half_width) / 2, fwd


def _nearest_arm(block, xy: np.ndarray) -> str:
    arms = block_geometry(block).arms
    return arms[int(np.argmin([np.hypot(*(np.asarray(a.position) - xy)) for a in arms]))].socket


def lane_path(vehicle: Vehicle, blocks) -> np.ndarray:
    """The polyline ``(K, 2)`` (m) a vehicle drives: from its start through the right lane of
    each block of its route (a cubic curve from the entry to the exit of each block) to its
    goal; a straight line from start to goal when it has no route or the route is not a chain
    of connected blocks."""
    start, goal = np.asarray(vehicle.start, float), np.asarray(vehicle.goal, float)
    by_id = {b.id: b for b in blocks}
    route = [by_id[r] for r in vehicle.route if r in by_id]
    if not route or len(route) != len(vehicle.route):
        return np.stack([start, goal])
    graph = _road_graph(blocks)
    sockets = []
    for k, block in enumerate(route):
        if k == 0:
            entry = _nearest_arm(block, start)
        else:
            edge = graph.get_edge_data(route[k - 1].id, block.id)
            if edge is None:
                return np.stack([start, goal])
            entry = edge["sockets"][block.id]
        if k == len(route) - 1:
            exit_ = _nearest_arm(block, goal)
        else:
            edge = graph.get_edge_data(block.id, route[k + 1].id)
            if edge is None:
                return np.stack([start, goal])
            exit_ = edge["sockets"][block.id]
        sockets.append((block, entry, exit_))
    pts = []
    for block, entry, exit_ in sockets:
        p0, d0 = _lane_end(block, entry, inward=True)
        p1, d1 = _lane_end(block, exit_, inward=False)
        pts.append(_cubic(p0, d0, p1, d1) if entry != exit_ else np.stack([p0, p1]))
    path = np.concatenate(pts)
    # Cut the path at the points nearest to the start and the goal.
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    s = np.concatenate([[0.0], np.cumsum(seg)])
    s0, s1 = _project(path, s, start), _project(path, s, goal)
    if s1 <= s0:
        return np.stack([start, goal])
    inner = path[(s > s0) & (s < s1)]
    return np.concatenate([start[None], inner, goal[None]])


# --- drive paths of city traffic ---------------------------------------------------------


def _lane_point(block, socket: str, lane: int, inward: bool) -> tuple[np.ndarray, np.ndarray]:
    """Lane ``lane`` (0 rightmost) at a block's road end and the driving direction there."""
    arm = next(a for a in block_geometry(block).arms if a.socket == socket)
    heading = arm.yaw + math.pi if inward else arm.yaw
    fwd = np.array([math.cos(heading), math.sin(heading)])
    right = np.array([fwd[1], -fwd[0]])
    width = arm.lane_width or block.lane_width
    lanes = max(1, round(arm.half_width / width))
    lane = min(lane, lanes - 1)
    return np.asarray(arm.position) + right * (lane + 0.5) * width, fwd


def _centre(block) -> np.ndarray:
    """Where a junction block's arms meet (its geometry's ``centre``); a roundabout's island's
    centre (its outline's without one)."""
    g = block_geometry(block)
    if g.centre is not None:
        return np.asarray(g.centre)
    shape = g.island if g.island is not None else g.outline
    return np.asarray(shape.centroid.coords[0])


def _ring(block, entry: str, exit_: str, lane_in: int) -> np.ndarray:
    """A roundabout's path: in along the entry arm, counter-clockwise round the ring's
    centre line, out along the exit arm."""
    c = _centre(block)
    arms = {a.socket: a for a in block_geometry(block).arms}
    p0, _ = _lane_point(block, entry, lane_in, inward=True)
    p1, _ = _lane_point(block, exit_, 0, inward=False)
    a0 = math.atan2(p0[1] - c[1], p0[0] - c[0])
    a1 = math.atan2(p1[1] - c[1], p1[0] - c[0])
    sweep = (a1 - a0) % (2 * math.pi)
    if sweep < 0.2:
        sweep += 2 * math.pi
    r = block.radius
    n = max(4, math.ceil(sweep * r / 2.0))
    ang = a0 + np.linspace(0.0, sweep, n)
    ring = c + r * np.stack([np.cos(ang), np.sin(ang)], axis=1)
    edge = r + block.lanes * block.lane_width + 1.0
    out0 = np.array([math.cos(arms[entry].yaw), math.sin(arms[entry].yaw)])
    out1 = np.array([math.cos(arms[exit_].yaw), math.sin(arms[exit_].yaw)])
    q0 = p0 + out0 * (np.dot(c - p0, out0) + edge)
    q1 = p1 + out1 * (np.dot(c - p1, out1) + edge)
    return np.concatenate([[p0, q0], ring[1:-1], [q1, p1]])


@dataclass
class Passage:
    """A vehicle's way through one junction: its arcs (m along the path) from the stop line
    to where it has left the junction, the approach lane it comes in by, and the ground its
    body sweeps inside."""

    junction: str
    lane: str
    s_stop: float
    s_exit: float
    swept: object


@dataclass
class DrivePath:
    """A vehicle's path: points every :data:`STEP` metres, their arcs, the speed limit at each
    point, and its passages through junctions."""

    points: np.ndarray
    arc: np.ndarray
    limit: np.ndarray
    passages: list[Passage]


_GRAPH: list = [None, None]  # the blocks last asked for and their road graph


def _road_graph(blocks):
    """:func:`road_graph` of ``blocks``, kept for the last blocks asked for: a city's 30
    vehicles' paths asked for it 30 times, 0.4 s of a city's reset from the on-disk store."""
    if _GRAPH[0] is not blocks:
        _GRAPH[:] = [blocks, road_graph(blocks)]
    return _GRAPH[1]


def _route_sockets(vehicle: Vehicle, blocks, by_id) -> list[tuple] | None:
    route = [by_id[r] for r in vehicle.route if r in by_id]
    if not route or len(route) != len(vehicle.route):
        return None
    graph = _road_graph(blocks)
    start, goal = np.asarray(vehicle.start, float), np.asarray(vehicle.goal, float)

    def nearest(block, xy, other=None):
        """The arm nearest ``xy`` (of those but ``other`` when the block has more)."""
        arms = [a for a in block_geometry(block).arms if a.socket != other] or block_geometry(block).arms
        return arms[int(np.argmin([np.hypot(*(np.asarray(a.position) - xy)) for a in arms]))].socket

    links = []
    for a, b in itertools.pairwise(route):
        edge = graph.get_edge_data(a.id, b.id)
        if edge is None:
            return None
        links.append((edge["sockets"][a.id], edge["sockets"][b.id]))
    out = []
    for k, block in enumerate(route):
        exit_ = links[k][0] if k < len(links) else None
        entry = links[k - 1][1] if k > 0 else nearest(block, start, exit_)
        if exit_ is None:
            exit_ = nearest(block, goal, entry)
        out.append((block, entry, exit_))
    return out


def _turn(block, entry: str, exit_: str) -> float:
    arms = {a.socket: a for a in block_geometry(block).arms}
    return math.remainder(arms[exit_].yaw - (arms[entry].yaw + math.pi), 2 * math.pi)


def _stop_radius(block, socket: str, walks) -> float:
    """Distance (m) from a junction's centre of the stop line on the arm ``socket``."""
    g = block_geometry(block)
    c = _centre(block)
    k = [a.socket for a in g.arms].index(socket)
    arm, site = g.arms[k], g.crossings[k] if k < len(g.crossings) else None
    d = np.array([math.cos(arm.yaw), math.sin(arm.yaw)])
    n = np.array([-d[1], d[0]])
    base = site.offset if site is not None else arm.half_width
    a, b = c + d * base, c + d * (base + 6.0)
    span = arm.half_width + 0.5
    band = Polygon([a - n * span, b - n * span, b + n * span, a + n * span])
    far = base
    if walks is not None:
        tree, polys = walks
        for i in tree.query(band, predicate="intersects").tolist():
            if polys[i].intersection(band).area > 0.5:
                far = max(far, float(np.max(np.asarray(polys[i].exterior.coords) @ d - c @ d)))
    return far + STOP_MARGIN


@dataclass
class Stops:
    """Where a signal stops traffic: its lights (position, yaw) and the crosswalks it serves."""

    heads: list[tuple[np.ndarray, float]]
    walks: list[Polygon]


def signal_stops(signals, zones) -> dict[str, Stops]:
    """The :class:`Stops` of each signalised block of a scene, by block id."""
    polys = {z.id: Polygon(z.polygon, z.holes) for z in zones if z.kind == "crosswalk"}
    out: dict[str, Stops] = {}
    for s in signals or ():
        here = out.setdefault(s.junction, Stops([], []))
        here.heads += [(np.asarray(h.position, dtype=float), float(h.yaw)) for h in s.heads]
        here.walks += [polys[c] for p in s.phases for c in p.crosswalks if c in polys]
    return out


def _signal_radius(block, socket: str, stops: Stops | None) -> float:
    """Distance (m) from a junction's centre of the stop line its signal sets on the arm
    ``socket``: :data:`STOP_MARGIN` before the farthest crosswalk it serves along the arm (within
    :data:`ALONG` of its heading) and at its light facing that way; 0 without a signal."""
    if stops is None:
        return 0.0
    arm = next(a for a in block_geometry(block).arms if a.socket == socket)
    c = _centre(block)
    d = np.array([math.cos(arm.yaw), math.sin(arm.yaw)])
    n = np.array([-d[1], d[0]])
    r = 0.0
    for poly in stops.walks:
        rel = np.asarray(poly.centroid.coords[0]) - c
        if abs(math.atan2(rel @ n, rel @ d)) < ALONG:
            r = max(r, float(np.max(np.asarray(poly.exterior.coords) @ d - c @ d)) + STOP_MARGIN)
    for xy, yaw in stops.heads:
        rel = xy - c
        facing = abs(math.remainder(yaw - arm.yaw, 2 * math.pi)) < ALONG
        if facing and abs(math.atan2(rel @ n, rel @ d)) < ALONG:
            r = max(r, float(rel @ d))
    return r


def drive_path(vehicle: Vehicle, blocks, walks=None, stops: dict[str, Stops] | None = None) -> DrivePath:
    """The path a vehicle drives (see the module docstring); ``walks`` an
    ``(STRtree, polygons)`` of the crosswalks, where stop lines stand before them; ``stops``
    the signals' (:func:`signal_stops`), which may set them further out."""
    stops = stops or {}
    by_id = {b.id: b for b in blocks}
    legs = _route_sockets(vehicle, blocks, by_id)
    start, goal = np.asarray(vehicle.start, float), np.asarray(vehicle.goal, float)
    if legs is None:
        pts = np.stack([start, goal])
        return _resample(pts, [(0.0, LOCAL)], [], [])
    # The lane in each block: at the approach to a left turn, the leftmost.
    lanes_out = []
    for k, (block, _, _) in enumerate(legs):
        nxt = legs[k + 1] if k + 1 < len(legs) else None
        lane = 0
        turning = nxt is not None and isinstance(nxt[0], Intersection | TIntersection | Junction)
        if turning and _turn(*nxt) > 0.5:
            lane = min(block.lanes, nxt[0].lanes) - 1
        lanes_out.append(lane)
    pieces, marks, junctions, crossings = [], [], [], []
    lane_in = 0
    for k, (block, entry, exit_) in enumerate(legs):
        if block.id in stops and not isinstance(block, JUNCTIONS):
            crossings.append((k, block, entry, lane_in))
        if isinstance(block, Roundabout):
            seg = _ring(block, entry, exit_, lane_in)
        else:
            p0, d0 = _lane_point(block, entry, lane_in, inward=True)
            p1, d1 = _lane_point(block, exit_, lanes_out[k], inward=False)
            n = max(4, math.ceil(np.linalg.norm(p1 - p0) / 2.0))
            seg = _cubic(p0, d0, p1, d1, n) if entry != exit_ else np.stack([p0, p1])
        marks.append((len(pieces), speed_limit(block)))
        pieces.append(seg)
        if isinstance(block, JUNCTIONS):
            junctions.append((k, block, entry, exit_, lane_in))
        lane_in = lanes_out[k]
    # Points and arcs of the whole route, then cut at the start and the goal.
    counts = [len(p) for p in pieces]
    pts = np.concatenate(pieces)
    owner = np.repeat(np.arange(len(pieces)), counts)
    seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    s0, s1 = _project(pts, arc, start), _project(pts, arc, goal)
    if s1 <= s0 + 1.0:
        return _resample(np.stack([start, goal]), [(0.0, LOCAL)], [], [])
    keep = (arc > s0) & (arc < s1)
    path = np.concatenate([start[None], pts[keep], goal[None]])
    # Arcs of the route to arcs of the path: the start joins the first kept point in a line.
    first = int(np.argmax(keep)) if keep.any() else None
    shift = -s0 if first is None else float(np.linalg.norm(pts[first] - start)) - float(arc[first])
    begin = [float(arc[owner == i][0]) + shift for i in range(len(pieces))]
    limits = [(begin[i], lim) for i, lim in marks]
    passages = []
    for k, block, entry, exit_, lane in junctions:
        sub, a = pts[owner == k], arc[owner == k]
        c = _centre(block)
        arms = {arm.socket: arm for arm in block_geometry(block).arms}
        r_in = _stop_radius(block, entry, walks)
        far = _signal_radius(block, entry, stops.get(block.id))
        approach, along = sub, a
        if far > r_in + 1e-3:  # a stop line out on the approach: looked for on the blocks before
            r_in, ahead = far, (owner >= k - APPROACH) & (owner <= k)
            approach, along = pts[ahead], arc[ahead]
        s_in = _crossing(approach, along, c, arms[entry].yaw, r_in, first=True)
        s_out = _crossing(sub, a, c, arms[exit_].yaw, _stop_radius(block, exit_, walks), first=False)
        if s_in is None or s_out is None:
            continue
        passages.append((block.id, f"{entry}:{lane}", s_in + shift, s_out + shift, sub))
    for k, block, entry, lane in crossings:
        near = (owner >= k - APPROACH) & (owner <= k + 1)
        line = LineString(pts[near])
        cut = [line.intersection(poly) for poly in stops[block.id].walks]
        ss = [line.project(Point(q)) for g in cut for part in _parts(g) for q in part.coords]
        if not ss:
            continue
        # the stop line: before the crosswalks, or at the light facing this way further back
        stop = min(ss) - STOP_MARGIN
        facing = block.pose.yaw + (math.pi if entry == "in" else 0.0)
        for xy, yaw in stops[block.id].heads:
            if abs(math.remainder(yaw - facing, 2 * math.pi)) < ALONG:
                stop = min(stop, line.project(Point(xy)))
        a0 = float(arc[near][0]) + shift
        passages.append((block.id, f"{entry}:{lane}", a0 + stop, a0 + max(ss), None))
    passages.sort(key=lambda p: p[2])
    return _resample(path, limits, passages, [vehicle.width])


def _parts(g) -> list:
    """The lines of a line intersection (none when empty)."""
    if g.is_empty:
        return []
    return [p for p in getattr(g, "geoms", [g]) if p.geom_type == "LineString"] or (
        [g] if g.geom_type == "Point" else []
    )


def _crossing(pts: np.ndarray, arc: np.ndarray, c: np.ndarray, yaw: float, r: float, *, first: bool):
    """Arc (m) where the polyline ``pts`` crosses the line ``r`` metres from ``c`` along the arm
    direction ``yaw`` (a stop line across the arm): the first crossing inwards when ``first``,
    else the last outwards; None when it never does."""
    along = (pts - c) @ np.array([math.cos(yaw), math.sin(yaw)]) - r
    inside = along <= 0
    if not inside.any():
        return None
    k = int(np.argmax(inside)) if first else len(inside) - 1 - int(np.argmax(inside[::-1]))
    j = k - 1 if first else k + 1
    if j < 0 or j >= len(pts):
        return float(arc[k])
    t = along[k] / (along[k] - along[j])  # from k towards j, where along crosses 0
    return float(arc[k] + t * (arc[j] - arc[k]))


def _resample(path: np.ndarray, limits, passages, width) -> DrivePath:
    seg = np.linalg.norm(np.diff(path, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    s = np.arange(0.0, arc[-1], STEP)
    s = np.append(s, arc[-1])
    pts = np.stack([np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])], axis=1)
    starts = np.array([b for b, _ in limits])
    lims = np.array([v for _, v in limits])
    idx = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(lims) - 1)
    half = (width[0] if width else 1.8) / 2 + CLEARANCE
    out = []
    for jid, lane, a, b, _ in passages:
        if b <= 0 or a >= arc[-1]:
            continue
        inside = pts[(s >= a) & (s <= b)]
        line = LineString(inside) if len(inside) >= 2 else LineString([pts[0], pts[-1]])
        out.append(Passage(jid, lane, max(a, 0.0), min(b, arc[-1]), line.buffer(half, quad_segs=2)))
    return DrivePath(pts, s, lims[idx], out)
