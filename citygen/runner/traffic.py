"""City traffic: vehicles that obey signals, yield in junctions and keep the speed limit.

:class:`CityTraffic` drives the scene's vehicles (the same state and ``step`` as
:class:`~citygen.runner.crowd.Traffic`) by the Intelligent Driver Model along
:func:`drive_path`: the lane of each block of its route, in the turn lane at a junction
(the leftmost for a left turn, the rightmost otherwise), round a roundabout's ring
counter-clockwise. Each junction block on the route is a *passage*: from the stop line
(:data:`STOP_MARGIN` before the crosswalks of the arm it comes in by) to where it leaves
the junction's crosswalks on the way out. A vehicle's front bumper passes a stop line only

- when its lane does not face red (at amber only when it could not stop comfortably);
- when no vehicle inside the junction takes a crossing or merging path (vehicles already
  in a junction or on a roundabout's ring have the right of way: first come, first served);
- when its exit is not blocked by a standing queue (it does not block the box).

Otherwise the stop line is a standing obstacle for IDM. Vehicles keep their distance to
whatever stands on the path ahead of them (other vehicles, people, the robot), keep the
speed limit of each block (:func:`speed_limit`, anticipated over the braking distance),
and a final pass takes back any step that would make two vehicles overlap. Signal states
come from :class:`~citygen.runner.signals.SignalPlan`.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon

from citygen.geometry.roads import block_geometry, road_graph
from citygen.runner.crowd import IDM_ACCEL, IDM_BRAKE, IDM_GAP, IDM_HEADWAY, Traffic
from citygen.runner.signals import Crossings, SignalCrowd, SignalPlan, crossings_of
from citygen.spec.agents import Vehicle
from citygen.spec.blocks import Intersection, Roundabout, TIntersection
from citygen.spec.scene import Scene

STEP = 0.5
"""Spacing (m) of the points of a drive path."""
LOOK = 60.0
"""How far ahead (m) a vehicle looks along its path."""
STOP_MARGIN = 1.0
"""Distance (m) of a stop line before the crosswalk."""
COMFORT = 3.0
"""Deceleration (m/s^2) a driver at amber takes to stop; nearer than ``v^2 / 2 COMFORT`` it goes on."""
ARTERIAL, LOCAL, JUNCTION, ROUNDABOUT = 13.9, 8.3, 8.3, 6.0
"""Speed limits (m/s): streets of two or more lanes each way (50 km/h), other streets and
junctions (30 km/h), roundabouts."""
CLEARANCE = 0.15
"""Lateral room (m) kept between a vehicle and what it passes; less is a thing in its path."""
CANDIDATES = 24
"""Things near its path ahead a vehicle tests point by point (the nearest)."""
JUNCTIONS = (Intersection, TIntersection, Roundabout)


def speed_limit(block) -> float:
    """The speed limit (m/s) on a block."""
    if isinstance(block, Roundabout):
        return ROUNDABOUT
    if isinstance(block, Intersection | TIntersection):
        return JUNCTION
    return ARTERIAL if block.lanes >= 2 else LOCAL


# --- vehicles -------------------------------------------------------------------------------


def _lane_point(block, socket: str, lane: int, inward: bool) -> tuple[np.ndarray, np.ndarray]:
    """Lane ``lane`` (0 rightmost) at a block's road end and the driving direction there."""
    arm = next(a for a in block_geometry(block).arms if a.socket == socket)
    heading = arm.yaw + math.pi if inward else arm.yaw
    fwd = np.array([math.cos(heading), math.sin(heading)])
    right = np.array([fwd[1], -fwd[0]])
    lanes = max(1, round(arm.half_width / block.lane_width))
    lane = min(lane, lanes - 1)
    return np.asarray(arm.position) + right * (lane + 0.5) * block.lane_width, fwd


def _cubic(p0, d0, p1, d1, n: int) -> np.ndarray:
    k = np.linalg.norm(p1 - p0) / 3
    c0, c1 = p0 + d0 * k, p1 - d1 * k
    t = np.linspace(0.0, 1.0, n)[:, None]
    return (1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * c0 + 3 * (1 - t) * t**2 * c1 + t**3 * p1


def _centre(block) -> np.ndarray:
    g = block_geometry(block)
    if isinstance(block, Roundabout):
        return (
            np.asarray(g.island.centroid.coords[0])
            if g.island is not None
            else np.asarray(g.outline.centroid.coords[0])
        )
    a = block.arm_length
    return np.asarray(block.pose.position) + a * np.array(
        [math.cos(block.pose.yaw), math.sin(block.pose.yaw)]
    )


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


def _from(p: Passage, front: float) -> Passage:
    """``p`` with its stop line no nearer the path's start than ``front`` (m)."""
    if p.s_stop >= front:
        return p
    return Passage(p.junction, p.lane, front, max(p.s_exit, front), p.swept)


@dataclass
class DrivePath:
    """A vehicle's path: points every :data:`STEP` metres, their arcs, the speed limit at each
    point, and its passages through junctions."""

    points: np.ndarray
    arc: np.ndarray
    limit: np.ndarray
    passages: list[Passage]


def _route_sockets(vehicle: Vehicle, blocks, by_id) -> list[tuple] | None:
    route = [by_id[r] for r in vehicle.route if r in by_id]
    if not route or len(route) != len(vehicle.route):
        return None
    graph = road_graph(blocks)
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


def drive_path(vehicle: Vehicle, blocks, walks=None) -> DrivePath:
    """The path a vehicle drives (see the module docstring); ``walks`` an
    ``(STRtree, polygons)`` of the crosswalks, where stop lines stand before them."""
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
        if nxt is not None and isinstance(nxt[0], Intersection | TIntersection) and _turn(*nxt) > 0.5:
            lane = min(block.lanes, nxt[0].lanes) - 1
        lanes_out.append(lane)
    pieces, marks, junctions = [], [], []
    lane_in = 0
    for k, (block, entry, exit_) in enumerate(legs):
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
    begin = [float(arc[owner == i][0]) - s0 for i in range(len(pieces))]
    limits = [(begin[i], lim) for i, lim in marks]
    keep = (arc > s0) & (arc < s1)
    path = np.concatenate([start[None], pts[keep], goal[None]])
    passages = []
    for k, block, entry, exit_, lane in junctions:
        sub, a = pts[owner == k], arc[owner == k]
        c = _centre(block)
        arms = {arm.socket: arm for arm in block_geometry(block).arms}
        s_in = _crossing(sub, a, c, arms[entry].yaw, _stop_radius(block, entry, walks), first=True)
        s_out = _crossing(sub, a, c, arms[exit_].yaw, _stop_radius(block, exit_, walks), first=False)
        if s_in is None or s_out is None:
            continue
        passages.append((block.id, f"{entry}:{lane}", s_in - s0, s_out - s0, sub))
    return _resample(path, limits, passages, [vehicle.width])


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


def _project(path: np.ndarray, s: np.ndarray, xy: np.ndarray) -> float:
    a, b = path[:-1], path[1:]
    ab = b - a
    t = np.clip(np.einsum("ij,ij->i", xy - a, ab) / np.maximum(np.einsum("ij,ij->i", ab, ab), 1e-12), 0, 1)
    d = np.linalg.norm(a + t[:, None] * ab - xy, axis=1)
    k = int(np.argmin(d))
    return float(s[k] + t[k] * (s[k + 1] - s[k]))


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


class CityTraffic(Traffic):
    """Vehicles that obey signals, yield in junctions and keep the speed limit (see the module
    docstring). The state is :class:`~citygen.runner.crowd.Traffic`'s, plus the signals'
    clock ``t`` (s); ``entered_red`` counts passages entered against red (none, by design)."""

    def __init__(self, scene: Scene, *, dt: float, crossings: Crossings | None = None) -> None:
        if not (isinstance(dt, int | float) and dt > 0):
            raise ValueError(f"Traffic dt: expected a step > 0 in seconds, got {dt!r}")
        cars = [a for a in scene.agents if isinstance(a, Vehicle)]
        self.dt = float(dt)
        self.ids = [c.id for c in cars]
        self.length = np.array([c.length for c in cars], dtype=np.float64)
        self.width = np.array([c.width for c in cars], dtype=np.float64)
        self.v0 = np.array([c.speed for c in cars], dtype=np.float64)
        self.plan = crossings.plan if crossings is not None else SignalPlan(scene.signals)
        drives = getattr(crossings, "drives", None)
        if drives is None:
            walks = [Polygon(z.polygon, z.holes) for z in scene.zones if z.kind == "crosswalk"]
            tree = (shapely.STRtree(walks), walks) if walks else None
            drives = [drive_path(c, scene.blocks, tree) for c in cars]
            if crossings is not None:
                crossings.drives = drives  # kept with the scene's cached data
        # A vehicle starting past a stop line (its start on the crosswalk) waits there.
        self.drives = [
            DrivePath(d.points, d.arc, d.limit, [_from(p, c.length / 2) for p in d.passages])
            for d, c in zip(drives, cars, strict=True)
        ]
        self.paths = [d.points for d in self.drives]
        self._arc = [d.arc for d in self.drives]
        self.total = np.array([a[-1] for a in self._arc], dtype=np.float64)
        # All paths in one array, each vehicle's arcs shifted by its own offset, so that one
        # search places every vehicle.
        self._shift = np.concatenate([[0.0], np.cumsum(self.total + 1.0)])[:-1]
        self._all_arc = np.concatenate([a + o for a, o in zip(self._arc, self._shift, strict=True)])
        self._all_pts = np.concatenate(self.paths) if self.paths else np.zeros((0, 2))
        self._last = np.cumsum([len(a) for a in self._arc]) - 1
        self.reset()

    def reset(self) -> None:
        self.t = 0.0
        self.entered_red = 0
        self.waiting = np.zeros(len(self.ids))
        super().reset()

    def _place(self) -> None:
        if not self.ids:
            self.pos, self.yaw = np.zeros((0, 2)), np.zeros(0)
            return
        s = np.clip(self.s, 0.0, self.total) + self._shift
        j = np.searchsorted(self._all_arc, s, side="right") - 1
        j = np.clip(j, self._last - np.array([len(a) for a in self._arc]) + 1, self._last - 1)
        a0, a1 = self._all_arc[j], self._all_arc[j + 1]
        u = np.clip((s - a0) / np.maximum(a1 - a0, 1e-9), 0.0, 1.0)
        p0, p1 = self._all_pts[j], self._all_pts[j + 1]
        self.pos = p0 + u[:, None] * (p1 - p0)
        self.yaw = np.arctan2(p1[:, 1] - p0[:, 1], p1[:, 0] - p0[:, 0])

    def _discs(self, oxy, orad, ovel):
        """Every vehicle as three discs along its axis, then the obstacles: centres, radii,
        velocities and owner (vehicle index, -1 for obstacles)."""
        fwd = np.stack([np.cos(self.yaw), np.sin(self.yaw)], axis=-1)
        off = np.maximum(self.length / 2 - self.width / 2, 0.0)
        cen = np.concatenate([self.pos + fwd * off[:, None] * f for f in (-1.0, 0.0, 1.0)])
        rad = np.tile(self.width / 2, 3)
        vel = np.tile(fwd * self.v[:, None], (3, 1))
        own = np.tile(np.arange(len(self.ids)), 3)
        return (
            np.concatenate([cen, oxy]),
            np.concatenate([rad, orad]),
            np.concatenate([vel, ovel]),
            np.concatenate([own, np.full(len(oxy), -1)]),
        )

    def leaders(self, obstacles_xy, obstacles_radius, obstacles_vel=None):
        """Per vehicle the bumper gap (m) to the first thing on its path ahead (within
        :data:`LOOK`) and that thing's speed along the path (m/s); ``inf`` and 0 where clear.
        Of the other vehicles (three discs each) and the discs ``obstacles_xy`` of
        ``obstacles_radius`` (people, the robot), the :data:`CANDIDATES` nearest to the
        window of path ahead are tested against every point of it."""
        m = len(self.ids)
        oxy = np.asarray(obstacles_xy, dtype=np.float64).reshape(-1, 2)
        orad = np.broadcast_to(np.asarray(obstacles_radius, dtype=np.float64), (len(oxy),))
        ovel = np.zeros_like(oxy) if obstacles_vel is None else np.asarray(obstacles_vel, float)
        cen, rad, vel, own = self._discs(oxy, orad, ovel.reshape(-1, 2))
        front = self.s + self.length / 2
        width = int(LOOK / STEP) + 1
        lo = np.searchsorted(self._all_arc, front + self._shift)
        idx = lo[:, None] + np.arange(width)[None]
        valid = idx <= self._last[:, None]
        idx = np.minimum(idx, self._last[:, None])
        win = self._all_pts[idx]  # (M, W, 2)
        warc = self._all_arc[idx] - self._shift[:, None]
        probes = win[:, [0, width // 2, width - 1]]  # (M, 3, 2)
        rel = cen[None, None] - probes[:, :, None]
        near = np.sqrt(np.min(rel[..., 0] ** 2 + rel[..., 1] ** 2, axis=1))  # (M, D)
        near[own[None] == np.arange(m)[:, None]] = np.inf
        near[near > LOOK / 2 + 5.0] = np.inf
        k = min(CANDIDATES, near.shape[1])
        cand = np.argpartition(near, k - 1, axis=1)[:, :k]
        present = np.isfinite(np.take_along_axis(near, cand, axis=1))
        # Only present candidates can be hit: keep them (in their order) and as many columns
        # as the vehicle with the most has.
        first = np.argsort(~present, axis=1, kind="stable")[:, : max(1, int(present.sum(axis=1).max()))]
        cand, present = np.take_along_axis(cand, first, 1), np.take_along_axis(present, first, 1)
        dx = win[:, :, None, 0] - cen[cand][:, None, :, 0]  # (M, W, K)
        dy = win[:, :, None, 1] - cen[cand][:, None, :, 1]
        hit = dx * dx + dy * dy < ((self.width[:, None] / 2 + rad[cand] + CLEARANCE) ** 2)[:, None]
        hit &= present[:, None] & valid[:, :, None]
        rows = hit.any(axis=2)
        has = rows.any(axis=1)
        r = np.argmax(rows, axis=1)
        at = np.arange(m)
        gap = np.where(has, np.maximum(warc[at, r] - front, 0.0), np.inf)
        who = cand[at, np.argmax(hit[at, r], axis=1)]
        tangent = win[at, np.minimum(r + 1, width - 1)] - win[at, np.maximum(r - 1, 0)]
        tangent /= np.maximum(np.linalg.norm(tangent, axis=1), 1e-9)[:, None]
        lead_v = np.where(has, np.maximum(np.sum(vel[who] * tangent, axis=1), 0.0), 0.0)
        return gap, lead_v

    def _next_passage(self, i: int) -> Passage | None:
        front = self.s[i] + self.length[i] / 2
        for p in self.drives[i].passages:
            if p.s_stop >= front - 1e-6:
                return p
        return None

    def _occupants(self) -> dict[str, list[tuple[int, Passage]]]:
        """Per junction the vehicles inside it and their passages."""
        out: dict[str, list[tuple[int, Passage]]] = {}
        front, rear = self.s + self.length / 2, self.s - self.length / 2
        for j, d in enumerate(self.drives):
            for p in d.passages:
                if front[j] > p.s_stop + 1e-6 and rear[j] < p.s_exit:
                    out.setdefault(p.junction, []).append((j, p))
        return out

    def _may_enter(self, i: int, p: Passage, occupants, granted) -> bool:
        """Whether vehicle ``i`` may pass the stop line of ``p`` now: not against red, at amber
        only when moving and too close to stop, and no crossing path inside the junction."""
        state = self.plan.lane(p.junction, p.lane, self.t)
        if state == "red":
            return False
        dist = p.s_stop - (self.s[i] + self.length[i] / 2)
        if state == "amber" and (self.v[i] < 0.5 or dist > self.v[i] ** 2 / (2 * COMFORT)):
            return False
        for j, q in [*occupants.get(p.junction, ()), *granted]:
            if j == i or q.junction != p.junction:
                continue
            if q.lane == p.lane:
                continue  # ahead in the same lane: followed by IDM
            if q.swept.intersects(p.swept):
                return False
        return True

    def step(self, obstacles_xy=(), obstacles_radius=(), obstacles_vel=None) -> None:
        """Advance every vehicle by ``dt`` (see the module docstring)."""
        if not self.ids:
            self.t += self.dt
            return
        m = len(self.ids)
        gap, lead_v = self.leaders(obstacles_xy, obstacles_radius, obstacles_vel)
        front = self.s + self.length / 2
        # Stop lines the vehicle may not pass yet are standing obstacles.
        nxt = [self._next_passage(i) for i in range(m)]
        occupants = self._occupants()
        for i, p in enumerate(nxt):
            if p is None or p.s_stop - front[i] > LOOK:
                continue
            if not self._may_enter(i, p, occupants, []) or not self._exit_clear(i, p, gap[i], lead_v[i]):
                g = max(p.s_stop - front[i], 0.0)
                if g < gap[i]:
                    gap[i], lead_v[i] = g, 0.0
        # Speed limits over the braking distance ahead.
        v = self.v
        v0 = self.v0.copy()
        for i in range(m):
            d = self.drives[i]
            lo = min(int(np.searchsorted(d.arc, self.s[i] - self.length[i] / 2)), len(d.arc) - 1)
            hi = int(np.searchsorted(d.arc, front[i] + v[i] ** 2 / (2 * IDM_BRAKE) + 2.0))
            v0[i] = min(v0[i], float(d.limit[lo : hi + 1].min()))
        dv = v - lead_v
        s_star = IDM_GAP + np.maximum(0.0, v * IDM_HEADWAY + v * dv / (2 * math.sqrt(IDM_ACCEL * IDM_BRAKE)))
        free = np.where(self.v0 > 0, 1.0 - (v / np.maximum(v0, 1e-6)) ** 4, -1.0)
        acc = np.maximum(IDM_ACCEL * (free - (s_star / np.maximum(gap, 1e-3)) ** 2), -9.0)
        new_v = np.clip(v + acc * self.dt, 0.0, v0)
        adv = np.minimum(0.5 * (v + new_v) * self.dt, np.maximum(gap - IDM_GAP / 2, 0.0))
        # Stop lines crossed in this step: checked one vehicle at a time (first the longest
        # waiting), so two vehicles never enter crossing paths in the same step.
        granted: list[tuple[int, Passage]] = []
        for i in np.argsort(-self.waiting, kind="stable").tolist():
            p = nxt[i]
            if p is None or front[i] + adv[i] <= p.s_stop:
                continue
            if self._may_enter(i, p, occupants, granted):
                granted.append((i, p))
            else:
                adv[i] = max(p.s_stop - front[i], 0.0)
        old_s = self.s.copy()
        self.s = self.s + adv
        self.v = np.where(adv <= 1e-9, 0.0, new_v)
        self.waiting = np.where(self.v < 0.1, self.waiting + self.dt, 0.0)
        self._place()
        self._untangle(old_s)
        self._restart()
        self.t += self.dt

    def _exit_clear(self, i: int, p: Passage, gap: float, lead_v: float) -> bool:
        """Whether the vehicle, once through the junction, has room beyond it (a standing
        queue reaching back into the junction blocks it; a moving one does not)."""
        need = p.s_exit - (self.s[i] + self.length[i] / 2) + self.length[i] + IDM_GAP
        return gap >= need or lead_v > 1.0

    def _untangle(self, old_s: np.ndarray) -> None:
        """Take back steps that would make two vehicles overlap (each stays where it was)."""
        moved = np.ones(len(self.ids), dtype=bool)
        before = None
        for _ in range(len(self.ids)):
            bad = _overlapping(self.pos, self.yaw, self.length, self.width)
            if not bad.any():
                return
            if before is None:
                before = _overlapping_at(self, old_s)
            bad &= ~before
            rows = np.unique(np.nonzero(bad)[0])
            rows = rows[moved[rows] & (self.s[rows] != old_s[rows])]
            if not len(rows):
                return
            self.s[rows] = old_s[rows]
            self.v[rows] = 0.0
            moved[rows] = False
            self._place()

    def _restart(self) -> None:
        done = np.flatnonzero(self.s >= self.total)
        for k in done.tolist():
            s = self.s[k]
            self.s[k], self.v[k] = 0.0, 0.0
            self._place()
            if _overlapping(self.pos, self.yaw, self.length + 2 * IDM_GAP, self.width + 0.5)[k].any():
                self.s[k], self.v[k] = s, 0.0
                self._place()


def _overlapping_at(traffic: CityTraffic, s: np.ndarray) -> np.ndarray:
    now = traffic.s
    traffic.s = s
    traffic._place()
    out = _overlapping(traffic.pos, traffic.yaw, traffic.length, traffic.width)
    traffic.s = now
    traffic._place()
    return out


def rectangles(pos: np.ndarray, yaw: np.ndarray, length: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Corners ``(M, 4, 2)`` of vehicles' footprints."""
    c, s = np.cos(yaw), np.sin(yaw)
    fwd = np.stack([c, s], axis=-1) * (length / 2)[:, None]
    side = np.stack([-s, c], axis=-1) * (width / 2)[:, None]
    return np.stack([pos + fwd + side, pos - fwd + side, pos - fwd - side, pos + fwd - side], axis=1)


def _overlapping(pos, yaw, length, width) -> np.ndarray:
    """``(M, M)`` whether two vehicles' footprints overlap (separating axis test)."""
    m = len(pos)
    out = np.zeros((m, m), dtype=bool)
    if m < 2:
        return out
    near = (
        np.linalg.norm(pos[:, None] - pos[None], axis=-1)
        < (np.hypot(length, width)[:, None] + np.hypot(length, width)[None]) / 2
    )
    np.fill_diagonal(near, False)
    i, j = np.nonzero(np.triu(near, 1))
    if not len(i):
        return out
    box = rectangles(pos, yaw, length, width)
    a, b = box[i], box[j]
    axes = np.concatenate([a[:, 1:3] - a[:, 0:2], b[:, 1:3] - b[:, 0:2]], axis=1)  # (P, 4, 2)
    pa = np.einsum("pkd,pad->pka", a, axes)
    pb = np.einsum("pkd,pad->pka", b, axes)
    sep = (pa.max(axis=1) < pb.min(axis=1)) | (pb.max(axis=1) < pa.min(axis=1))
    hit = ~sep.any(axis=1)
    out[i[hit], j[hit]] = True
    out[j[hit], i[hit]] = True
    return out


def city_agents(prepared, scene: Scene, crowd, dt: float) -> tuple:
    """A city's people (``crowd`` waiting for *walk*: :class:`~citygen.runner.signals.SignalCrowd`)
    and vehicles (:class:`CityTraffic`), with the scene's crossings and drive paths kept on the
    env's cached scene data ``prepared``."""
    crossings = crossings_of(prepared, scene)
    people = SignalCrowd(crowd, crossings) if crowd is not None else None
    return people, CityTraffic(scene, dt=dt, crossings=crossings)
