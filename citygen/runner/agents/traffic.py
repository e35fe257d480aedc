"""Vehicles: the Intelligent Driver Model along their lanes, and city traffic that obeys
signals, yields in junctions and keeps the speed limit.

Vehicles (:class:`Traffic`) follow their lane through their route of blocks
(:func:`~citygen.runner.agents.lanes.lane_path`) by the *Intelligent Driver Model* (Treiber,
Hennecke and Helbing, 2000), keeping their distance to the nearest vehicle, person or robot
in a corridor ahead of them as wide as the vehicle; at the end of the route a vehicle starts
again from its start when that is clear.

:class:`CityTraffic` drives a city's vehicles (the same state and ``step`` as
:class:`Traffic`) by the Intelligent Driver Model along
:func:`~citygen.runner.agents.lanes.drive_path`, through the *passages* of the junctions on
its route. A vehicle's front bumper passes a stop line only

- when its lane does not face red (at amber only when it could not stop comfortably);
- when no vehicle inside the junction takes a crossing or merging path (vehicles already
  in a junction or on a roundabout's ring have the right of way: first come, first served);
- when its exit is not blocked by a standing queue (it does not block the box).

Otherwise the stop line is a standing obstacle for IDM. A trip starts where the vehicle's
rear has left any junction its body would be in at its start (past the exit's crosswalks,
further on where another vehicle stands there) and ends with its front at its goal, or at the
stop line of a junction its body would be in there: no vehicle waits on a crosswalk or in a
junction box between trips. Vehicles keep their distance to whatever stands on the path ahead
of them (other vehicles, people, the robot; the path goes on past the goal for looking), keep the
speed limit of each block (:func:`~citygen.runner.agents.lanes.speed_limit`, anticipated
over the braking distance), and a final pass takes back any step that would make two
vehicles overlap. Signal states come from :class:`~citygen.runner.agents.signals.SignalPlan`.
"""

from __future__ import annotations

import math

import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.runner.agents.footprints import Footprints, depth, rectangles
from citygen.runner.agents.lanes import (
    CLEARANCE,
    STEP,
    DrivePath,
    Passage,
    drive_path,
    lane_path,
    signal_stops,
)
from citygen.runner.agents.signals import Crossings, SignalCrowd, SignalPlan, crossings_of
from citygen.runner.agents.vec2 import det, dot
from citygen.spec.agents import Vehicle
from citygen.spec.scene import Scene

IDM_ACCEL = 1.5
"""IDM's maximum acceleration ``a`` (m/s^2)."""
IDM_BRAKE = 2.0
"""IDM's comfortable deceleration ``b`` (m/s^2)."""
IDM_GAP = 2.0
"""IDM's jam distance ``s0`` (m): the bumper gap kept when stopped behind something."""
IDM_HEADWAY = 1.5
"""IDM's safe time headway ``T`` (s)."""
LOOK_AHEAD = 60.0
"""How far ahead (m) a vehicle looks for something to keep its distance to."""
LOOK = 60.0
"""How far ahead (m) a vehicle looks along its path."""
COMFORT = 3.0
"""Deceleration (m/s^2) a driver at amber takes to stop; nearer than ``v^2 / 2 COMFORT`` it goes on."""
CANDIDATES = 24
"""Things near its path ahead a vehicle tests point by point (the nearest)."""


# --- vehicles on their lanes ---------------------------------------------------------------


class Traffic:
    """The scene's vehicles, each driving its :func:`lane_path` by the Intelligent Driver Model.

    ``dt`` (s) one control step. State: ``s`` ``(M,)`` (m along each path), ``v`` ``(M,)`` (m/s);
    ``pos`` ``(M, 2)`` (m) and ``yaw`` ``(M,)`` (rad) follow from them. Constant: ``ids``,
    ``length``, ``width`` (m), ``v0`` (desired speed, m/s), ``paths``.
    """

    def __init__(self, scene: Scene, *, dt: float) -> None:
        if not (isinstance(dt, int | float) and dt > 0):
            raise ValueError(f"Traffic dt: expected a step > 0 in seconds, got {dt!r}")
        cars = [a for a in scene.agents if isinstance(a, Vehicle)]
        self.dt = float(dt)
        self.ids: list[str] = [c.id for c in cars]
        self.length = np.array([c.length for c in cars], dtype=np.float64)
        self.width = np.array([c.width for c in cars], dtype=np.float64)
        self.v0 = np.array([c.speed for c in cars], dtype=np.float64)
        self.paths = [lane_path(c, scene.blocks) for c in cars]
        self._arc = [
            np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(p, axis=0), axis=1))]) for p in self.paths
        ]
        self.total = np.array([a[-1] for a in self._arc], dtype=np.float64)
        self.s_start = np.zeros(len(self.ids))
        self.reset()

    def reset(self) -> None:
        """Every vehicle at the start of its trip (``s_start`` m along its path), standing."""
        self.s = self.s_start.copy()
        self.v = np.zeros(len(self.ids))
        self._place()

    def footprints(self) -> Footprints:
        """The vehicles' footprints now, for people to keep clear of."""
        return Footprints(self.pos.copy(), self.yaw.copy(), self.length, self.width, self.v.copy())

    def _place(self) -> None:
        m = len(self.ids)
        self.pos = np.zeros((m, 2))
        self.yaw = np.zeros(m)
        for k in range(m):
            path, arc = self.paths[k], self._arc[k]
            s = min(self.s[k], arc[-1])
            self.pos[k] = [np.interp(s, arc, path[:, 0]), np.interp(s, arc, path[:, 1])]
            j = min(int(np.searchsorted(arc, s, side="right")) - 1, len(path) - 2)
            d = path[j + 1] - path[j]
            self.yaw[k] = math.atan2(d[1], d[0])

    def leaders(self, obstacles_xy, obstacles_radius, obstacles_vel=None) -> tuple[np.ndarray, np.ndarray]:
        """Per vehicle the bumper gap (m) to the nearest thing ahead in a corridor as wide as
        the vehicle along its heading, and that thing's speed along the heading (m/s);
        ``inf`` and 0 where the road is clear for :data:`LOOK_AHEAD` metres. Other vehicles
        and the discs ``obstacles_xy`` ``(K, 2)`` (m) of ``obstacles_radius`` ``(K,)`` (m)
        moving at ``obstacles_vel`` ``(K, 2)`` (m/s, default standing) count."""
        m = len(self.ids)
        oxy = np.asarray(obstacles_xy, dtype=np.float64).reshape(-1, 2)
        orad = np.broadcast_to(np.asarray(obstacles_radius, dtype=np.float64), (len(oxy),))
        ovel = (
            np.zeros_like(oxy) if obstacles_vel is None else np.asarray(obstacles_vel, float).reshape(-1, 2)
        )
        fwd = np.stack([np.cos(self.yaw), np.sin(self.yaw)], axis=-1)
        cars_vel = fwd * self.v[:, None]
        xy = np.concatenate([self.pos, oxy])
        vel = np.concatenate([cars_vel, ovel])
        half_long = np.concatenate([self.length / 2, orad])
        half_lat = np.concatenate([self.width / 2, orad])
        rel = xy[None] - self.pos[:, None]  # (M, M + K, 2)
        along = dot(rel, fwd[:, None])
        side = np.abs(det(fwd[:, None], rel))
        gap = along - self.length[:, None] / 2 - half_long[None]
        ahead = (along > 0) & (side < self.width[:, None] / 2 + half_lat[None]) & (gap < LOOK_AHEAD)
        ahead[np.arange(m), np.arange(m)] = False
        gap = np.where(ahead, gap, np.inf)
        k = np.argmin(gap, axis=1) if gap.shape[1] else np.zeros(m, dtype=np.int64)
        g = gap[np.arange(m), k] if gap.shape[1] else np.full(m, np.inf)
        lead_v = np.where(np.isfinite(g), dot(vel[k], fwd), 0.0)
        return g, lead_v

    def step(self, obstacles_xy=(), obstacles_radius=(), obstacles_vel=None) -> None:
        """Advance every vehicle by ``dt`` by IDM, keeping its distance to the vehicles and the
        discs (the robot, people: see :meth:`leaders`) ahead of it; a vehicle at the end of its
        path starts again from its start when no vehicle is within its length of it."""
        if not self.ids:
            return
        gap, lead_v = self.leaders(obstacles_xy, obstacles_radius, obstacles_vel)
        v = self.v
        dv = v - lead_v
        s_star = IDM_GAP + np.maximum(0.0, v * IDM_HEADWAY + v * dv / (2 * math.sqrt(IDM_ACCEL * IDM_BRAKE)))
        free = 1.0 - (v / np.maximum(self.v0, 1e-6)) ** 4
        free = np.where(self.v0 > 0, free, -1.0)  # a vehicle meant to stand stays (brakes)
        acc = IDM_ACCEL * (free - (s_star / np.maximum(gap, 1e-3)) ** 2)
        acc = np.maximum(acc, -9.0)  # no more than an emergency stop
        new_v = np.maximum(v + acc * self.dt, 0.0)
        adv = 0.5 * (v + new_v) * self.dt
        # Never closer than the jam distance to what is ahead (IDM only tends to it).
        adv = np.minimum(adv, np.maximum(gap - IDM_GAP, 0.0))
        self.v = np.where(adv <= 0, 0.0, new_v)
        self.s = self.s + adv
        done = self.s >= self.total
        if done.any():
            start = np.array([p[0] for p in self.paths])
            for k in np.flatnonzero(done).tolist():
                others = np.delete(np.arange(len(self.ids)), k)
                clear = np.all(np.linalg.norm(self.pos[others] - start[k], axis=1) > self.length[k] + IDM_GAP)
                self.s[k], self.v[k] = (0.0, 0.0) if clear else (self.total[k], 0.0)
        self._place()


# --- city traffic ---------------------------------------------------------------------------


def _start(d: DrivePath, length: float) -> float:
    """Where (m along its path) a vehicle of ``length`` starts: at its path's start, or where
    its rear bumper has left every junction its body would be in there (past the exit's
    crosswalks), so that it never waits on a crosswalk for a signal it began beyond."""
    s = 0.0
    for p in d.passages:
        if p.s_stop < s + length / 2 and p.s_exit > s - length / 2:
            s = p.s_exit + length / 2 + CLEARANCE
    return s


def _end(d: DrivePath, length: float, goal: float, start: float) -> float:
    """Where (m along its path) a vehicle's trip ends: its front bumper at its goal (``goal``
    m along the path), or at the stop line of a junction its body would be in there (it does
    not enter a junction it would stand in); never before ``start``."""
    s = goal - length / 2
    for p in reversed(d.passages):
        if p.s_stop < s + length / 2 and p.s_exit > s - length / 2:
            s = p.s_stop - length / 2
    return max(s, start)


def _extended(d: DrivePath) -> DrivePath:
    """``d`` with :data:`LOOK` metres more along its last segment: a vehicle near its goal
    still sees what stands ahead of it."""
    seg = d.points[-1] - d.points[-2] if len(d.points) > 1 else np.array([1.0, 0.0])
    seg = seg / max(float(np.linalg.norm(seg)), 1e-9)
    more = np.arange(1, int(LOOK / STEP) + 2) * STEP
    return DrivePath(
        np.concatenate([d.points, d.points[-1] + more[:, None] * seg]),
        np.concatenate([d.arc, d.arc[-1] + more]),
        np.concatenate([d.limit, np.full(len(more), d.limit[-1])]),
        d.passages,
    )


class CityTraffic(Traffic):
    """Vehicles that obey signals, yield in junctions and keep the speed limit (see the module
    docstring). The state is :class:`Traffic`'s, plus the signals'
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
            stops = signal_stops(scene.signals, scene.zones)
            drives = [drive_path(c, scene.blocks, tree, stops) for c in cars]
            if crossings is not None:
                crossings.drives = drives  # kept with the scene's cached data
        # Trips start clear of junctions and end before one they would stand in; the paths
        # go on past their goals, for looking ahead.
        self.s_start = np.array([_start(d, c.length) for d, c in zip(drives, cars, strict=True)])
        self.total = np.array(
            [_end(d, c.length, d.arc[-1], s0) for d, c, s0 in zip(drives, cars, self.s_start, strict=True)]
        )
        self.drives = [_extended(d) for d in drives]
        self.paths = [d.points for d in self.drives]
        self._arc = [d.arc for d in self.drives]
        # All paths in one array, each vehicle's arcs shifted by its own offset, so that one
        # search places every vehicle.
        self._shift = np.concatenate([[0.0], np.cumsum([a[-1] + 1.0 for a in self._arc])])[:-1]
        self._all_arc = np.concatenate([a + o for a, o in zip(self._arc, self._shift, strict=True)])
        self._all_pts = np.concatenate(self.paths) if self.paths else np.zeros((0, 2))
        self._last = np.cumsum([len(a) for a in self._arc]) - 1
        self._spread()
        self.reset()

    def _spread(self) -> None:
        """Vehicles moved out of a junction onto another vehicle start further along their path,
        where they are clear of every vehicle by the jam distance (before the next stop line)."""
        self.s = self.s_start.copy()
        self._place()
        for k in np.flatnonzero(self.s_start > 0).tolist():
            half = self.length[k] / 2
            stops = [p.s_stop - half for p in self.drives[k].passages if p.s_stop >= self.s[k] + half]
            last = min([self.total[k], *stops])
            while (
                self.s[k] + STEP <= last
                and _overlapping(self.pos, self.yaw, self.length + IDM_GAP, self.width)[k].any()
            ):
                self.s[k] += STEP
                self._place()
            self.s_start[k] = self.s[k]

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
        self._restart(obstacles_xy, obstacles_radius)
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

    def _restart(self, obstacles_xy, obstacles_radius) -> None:
        """Vehicles at the end of their trip start it again when their start is clear of the
        other vehicles (by the jam distance) and of the discs ``obstacles_xy`` of
        ``obstacles_radius`` (m: people, the robot); the others wait at their end."""
        oxy = np.asarray(obstacles_xy, dtype=np.float64).reshape(-1, 2)
        orad = np.broadcast_to(np.asarray(obstacles_radius, dtype=np.float64), (len(oxy),))
        for k in np.flatnonzero(self.s >= self.total).tolist():
            s = self.s[k]
            self.s[k], self.v[k] = self.s_start[k], 0.0
            self._place()
            box = Footprints(self.pos[k : k + 1], self.yaw[k : k + 1], self.length[k : k + 1] + 2 * IDM_GAP,
                             self.width[k : k + 1] + 0.5, np.zeros(1))  # fmt: skip
            blocked = _overlapping(self.pos, self.yaw, self.length + 2 * IDM_GAP, self.width + 0.5)[k].any()
            if blocked or (depth(oxy, orad, box) > 0).any():
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
    """A city's people (``crowd`` waiting for *walk*: :class:`~citygen.runner.agents.signals.SignalCrowd`)
    and vehicles (:class:`CityTraffic`), with the scene's crossings and drive paths kept on the
    env's cached scene data ``prepared``."""
    crossings = crossings_of(prepared, scene)
    people = SignalCrowd(crowd, crossings) if crowd is not None else None
    return people, CityTraffic(scene, dt=dt, crossings=crossings)
