"""Moving people: ORCA for pedestrians, cyclists and scooter riders.

People (:class:`Crowd`) avoid each other and the robot by ORCA, *Optimal Reciprocal
Collision Avoidance* (van den Berg, Guy, Lin and Manocha, 2011), as the reference RVO2
library computes it: :func:`citygen.runner.agents.orca.orca_velocities` (re-exported here) does it
for every agent at once with numpy, neighbour search, half-planes and RVO2's linear
programs as array operations over all agents (and over a leading batch of environments).

Static obstacles are discs (a point of blocked ground grown by a radius) with zero
velocity for which the agent takes full responsibility; RVO2 models walls as polygons
instead, so with static obstacles the two differ (without them they agree to float
precision: ``tests/test_crowd.py`` compares with RVO2 through ``pyrvo``). The robot is a
*non-cooperative* agent: it does not avoid anyone, so every person takes full
responsibility (1, not 1/2) for avoiding it.

Each person walks from its ``start`` to its ``goal`` and back, for ever, along the
shortest path on a coarse grid of the walkable ground (a geodesic distance field per
person and target, precomputed once with :func:`scipy.sparse.csgraph.dijkstra`); its
preferred velocity points at a waypoint a few cells ahead on that path. A person stays on
walkable ground: its centre keeps ``need`` metres (its radius, plus half a cell's
diagonal, less where its own start or goal is narrower) from the centre of every
non-walkable cell of the occupancy map. ORCA sees the nearest blocked cells as static
obstacles; a step that would still leave that ground slides along the boundary (the x or
y part of the step alone) or stays. Last, a step that would make two people overlap more
than they already did is taken back (both stay where they were, which never overlapped
beyond the previous step's overlap), unless staying would put one of them inside the
robot, which is pushed out of first. So people never overlap each other (beyond
:data:`OVERLAP_SLACK`) and keep out of the robot's disc unless it pins them against a
wall.

Vehicles (:mod:`citygen.runner.agents.traffic`'s) are non-cooperative too: each is the discs
covering its footprint (:func:`~citygen.runner.agents.footprints.covering_discs`) moving at
its speed, and a step that would take a person deeper into a vehicle's footprint, grown by
the vehicle's next step, is not taken (an escape step or none instead): people never walk
into a vehicle; keeping clear of people ahead is the vehicle's part.

>>> import numpy as np
>>> pos = np.array([[-2.0, 0.05], [2.0, 0.0]])  # walking at each other, 5 cm off the line
>>> pref = np.array([[1.0, 0.0], [-1.0, 0.0]])
>>> orca_velocities(pos, pref, pref, 0.3, 1.5, dt=0.1).round(2).tolist()  # each dodges half
[[0.98, 0.14], [-0.98, -0.14]]
"""

from __future__ import annotations

import copy
import math
from collections.abc import Callable, Mapping

import numpy as np
import scipy.ndimage
import scipy.sparse
import scipy.sparse.csgraph
from scipy.spatial import cKDTree

from citygen.exporters.occupancy import OccupancyMap
from citygen.runner.agents.footprints import Footprints, covering_discs
from citygen.runner.agents.footprints import depth as footprint_depth
from citygen.runner.agents.orca import orca_velocities
from citygen.runner.agents.vec2 import dot
from citygen.spec.agents import Person
from citygen.spec.scene import Scene

OVERLAP_SLACK = 1e-3
"""Overlap (m) of two people's discs the safety pass lets grow in one step (rounding)."""
SPEED_FACTOR = 1.5
"""A person's top speed (ORCA's ``maxSpeed``) over its preferred speed: room to dodge."""
NAV_CELL = 0.2
"""Side (m) of the cells of the grid people plan their path on (coarser in large scenes)."""
MAX_NAV_NODES = 2**18
"""Most cells of that grid: a 1.2 km city plans on 2.4 m cells, so the path tables of 200
people take 0.4 GB instead of tens of GB."""
LOOKAHEAD = 3
"""Cells of the path ahead of a person its preferred velocity aims at."""
ARRIVE = 0.4
"""Distance (m) from a target at which a person has arrived and turns round."""
ROBOT_MARGIN = 0.05
"""Extra radius (m) people give the robot in ORCA: it does not avoid them."""
_ANGLES = np.arange(16) * (np.pi / 8)
_ESCAPES = np.concatenate(
    [[[0.0, 0.0]], *(f * np.stack([np.cos(_ANGLES), np.sin(_ANGLES)], axis=-1) for f in (1 / 3, 2 / 3, 1.0))]
)
"""Steps a conflicted person may try, as fractions of its top speed times ``dt``."""
JITTER = 0.01
"""Size (m/s) of the random nudge added to preferred velocities to break symmetric deadlocks
(RVO2's examples do the same)."""


# --- vector helpers ----------------------------------------------------------------------


def _unit(w: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``w / |w|`` and ``|w|``; a zero vector gives ``(1, 0)`` (RVO2 would divide by zero)."""
    n = np.sqrt(dot(w, w))
    safe = n > 1e-12
    u = np.where(safe[..., None], w / np.where(safe, n, 1.0)[..., None], np.array([1.0, 0.0]))
    return u, n


# --- people ------------------------------------------------------------------------------


def crowd_of(prepared, scene: Scene, *, rng: np.random.Generator, dt: float) -> Crowd:
    """``Crowd(scene, prepared.occupancy, rng=rng, dt=dt)``, its clearance field and paths
    (which depend on the scene alone) built once and kept on the env's cached scene data
    ``prepared``: each call is a copy of them reset with ``rng``, the same crowd a new one is
    (its constructor draws nothing from ``rng``). On a town they took 6 of a 10 s reset. Its
    :meth:`Crowd.tables` are kept in the on-disk store too, beside the scene's entry
    (:meth:`~citygen.runner.scene_store.SceneStore.load_array`): on a city their distance
    transform and Dijkstra runs were most of a reset from the store. On a first visit to a
    town or a city they come made, with the scene's maps, from :func:`~citygen.runner.scenes.prepare`'s
    second process (:mod:`citygen.runner.scene_maps`)."""
    have = getattr(prepared, "_crowd", None)
    if have is None or have[0] is not scene or have[1] != dt:
        disk, key = _store_of(prepared)
        tables = None if disk is None else _load_tables(disk, key, scene, prepared.occupancy)
        # Made beside the model in a second process (citygen.runner.scene_maps) on a first
        # visit to a town or a city: taken once, then kept by the crowd as a stored table is.
        made_apart = getattr(prepared, "_crowd_tables", None)
        if made_apart is not None:
            del prepared._crowd_tables
        fresh = tables is None
        if fresh:
            tables = made_apart
        made = Crowd(scene, prepared.occupancy, rng=rng, dt=dt, tables=tables)
        if disk is not None and fresh and len(made.ids):
            save_tables(disk, key, made.tables())
        have = (scene, dt, made)
        prepared._crowd = have
    crowd = copy.copy(have[2])  # its arrays shared: an episode replaces, never edits, them,
    crowd.speed = crowd.speed.copy()  # but for the speeds (SignalCrowd holds people at red)
    crowd.reset(rng)
    return crowd


#: The prefix of the names of a crowd's tables (:meth:`Crowd.tables`) beside its scene's
#: entry in the on-disk store.
TABLES_ENTRY = "crowd"


def _store_of(prepared) -> tuple:
    """The on-disk store and ``prepared``'s key in it, or ``(None, None)``."""
    from citygen.runner import scene_store

    key = getattr(prepared, "store_key", None)
    disk = scene_store.store() if key is not None else None
    return (disk, key) if disk is not None else (None, None)


def save_tables(disk, key: str, tables: dict[str, np.ndarray]) -> None:
    """Keep a crowd's :meth:`Crowd.tables` beside store entry ``key``, where
    :func:`_load_tables` reads them."""
    for name, array in tables.items():
        disk.save_array(key, f"{TABLES_ENTRY}-{name}", array)


def _load_tables(disk, key: str, scene: Scene, occupancy: OccupancyMap) -> dict[str, np.ndarray] | None:
    """The stored :meth:`Crowd.tables` of ``scene``'s crowd on ``occupancy``, each checked
    (shape and type; every path entry a node or -1, so that a damaged file never indexes off
    the grid), or None when one is missing or fails."""
    n = sum(isinstance(a, Person) for a in scene.agents)
    g = occupancy.grid
    _, rows, cols = _nav_grid(g)

    def fits(shape: tuple, dtype) -> Callable[[np.ndarray], bool]:
        return lambda a: a.dtype == dtype and a.shape == shape

    def paths(hop: np.ndarray) -> bool:
        if not fits((n, 2, rows * cols), np.int32)(hop):
            return False
        return not hop.size or (int(hop.min()) >= -1 and int(hop.max()) < rows * cols)

    checks = {
        "paths": paths,
        "clearance": fits((g.rows, g.cols), np.float64),
        "blocked": fits((g.rows, g.cols, 2), np.float64),
    }
    out = {}
    for name, check in checks.items():
        array = disk.load_array(key, f"{TABLES_ENTRY}-{name}", check=check)
        if array is None:
            return None
        out[name] = array
    return out


def _nav_grid(grid) -> tuple[int, int, int]:
    """The people's path grid over ``grid``: fine cells per side of one of its cells
    (:data:`NAV_CELL`, coarser where the grid would exceed :data:`MAX_NAV_NODES`), its rows
    and its columns."""
    res = grid.resolution
    cell = max(NAV_CELL, math.sqrt(grid.rows * grid.cols * res * res / MAX_NAV_NODES))
    f = max(1, math.ceil(cell / res - 1e-9))
    return f, -(-grid.rows // f), -(-grid.cols // f)


class Crowd:
    """The scene's pedestrians, cyclists and scooter riders, moved by ORCA on walkable ground.

    ``scene``'s :class:`~citygen.spec.agents.Person` agents in spec order; ``occupancy`` the
    scene's :class:`~citygen.exporters.occupancy.OccupancyMap` (its walkable cells are where
    people may be); ``rng`` the generator of the small nudges that break symmetric deadlocks
    (the same generator state gives the same motion); ``dt`` (s) one control step.
    State after :meth:`reset` and each :meth:`step`: ``pos`` ``(N, 2)`` (m), ``vel`` ``(N, 2)``
    (m/s), ``target`` ``(N,)`` (0: heading for the goal, 1: for the start) and ``arrivals``
    ``(N,)`` (targets reached so far). Constant: ``ids``, ``radius`` (m), ``speed`` (preferred,
    m/s), ``max_speed`` (m/s), ``need`` (m: the clearance kept from non-walkable cell centres).
    ``tables``: :meth:`tables` of an earlier crowd of the same scene and map (kept by
    :func:`crowd_of`), taken as they are instead of computed.
    """

    def __init__(
        self,
        scene: Scene,
        occupancy: OccupancyMap,
        *,
        rng: np.random.Generator,
        dt: float,
        tau: float = 2.0,
        neighbor_dist: float = 5.0,
        max_neighbors: int = 10,
        tables: Mapping[str, np.ndarray] | None = None,
    ) -> None:
        if not (isinstance(dt, int | float) and dt > 0):
            raise ValueError(f"Crowd dt: expected a step > 0 in seconds, got {dt!r}")
        people = [a for a in scene.agents if isinstance(a, Person)]
        self.ids: list[str] = [a.id for a in people]
        self.dt, self.tau = float(dt), float(tau)
        self.neighbor_dist, self.max_neighbors = float(neighbor_dist), int(max_neighbors)
        self.radius = np.array([a.radius for a in people], dtype=np.float64)
        self.speed = np.array([a.speed for a in people], dtype=np.float64)
        self.max_speed = SPEED_FACTOR * self.speed
        self.start = np.array([a.start for a in people], dtype=np.float64).reshape(-1, 2)
        self.goal = np.array([a.goal for a in people], dtype=np.float64).reshape(-1, 2)
        self._grid = occupancy.grid
        res = occupancy.resolution
        if tables is None:
            walk = np.pad(occupancy.walkable_mask(), 1)  # off the map is not walkable
            edt, idx = scipy.ndimage.distance_transform_edt(walk, return_indices=True)
            #: Distance (m) from each cell centre to the nearest non-walkable cell centre.
            self.clearance = edt[1:-1, 1:-1] * res
            g = self._grid
            self._blocked_xy = np.stack(
                [g.x0 + (idx[1, 1:-1, 1:-1] - 0.5) * res, g.y0 + (idx[0, 1:-1, 1:-1] - 0.5) * res], axis=-1
            )
        else:
            self.clearance, self._blocked_xy = tables["clearance"], tables["blocked"]
        half_diag = res * math.sqrt(0.5)
        self.need = np.minimum(
            self.radius + half_diag, np.minimum(self._clear_at(self.start), self._clear_at(self.goal))
        )
        self.need = np.maximum(self.need, 0.0)
        self._static_radius = self.need + half_diag - self.radius
        self._build_paths(None if tables is None else tables["paths"])
        self.reset(rng)

    # grid look-ups
    def _cells(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        g = self._grid
        col = np.clip(np.floor((xy[..., 0] - g.x0) / g.resolution), 0, g.cols - 1).astype(np.int64)
        row = np.clip(np.floor((xy[..., 1] - g.y0) / g.resolution), 0, g.rows - 1).astype(np.int64)
        return row, col

    def _clear_at(self, xy: np.ndarray) -> np.ndarray:
        """Clearance (m) of the cells under points ``xy`` ``(..., 2)``; 0 off the map."""
        g = self._grid
        inside = (
            (xy[..., 0] >= g.x0)
            & (xy[..., 0] < g.x0 + g.cols * g.resolution)
            & (xy[..., 1] >= g.y0)
            & (xy[..., 1] < g.y0 + g.rows * g.resolution)
        )
        return np.where(inside, self.clearance[self._cells(xy)], 0.0)

    def allowed(self, xy: np.ndarray) -> np.ndarray:
        """Whether each person ``i`` may stand at ``xy[i]`` (``(N, 2)`` m): its cell keeps ``need[i]``."""
        return self._clear_at(xy) >= self.need

    def _build_paths(self, hop: np.ndarray | None = None) -> None:
        """Per person and target (goal, start) the next hop towards it on a coarse grid of
        :data:`NAV_CELL` cells, whose nodes are each block's best-cleared fine cell (``hop``:
        the tables, already computed)."""
        g, res = self._grid, self._grid.resolution
        f, rows, cols = _nav_grid(g)
        pad = np.full((rows * f, cols * f), -1.0)
        pad[: g.rows, : g.cols] = self.clearance
        blocks = pad.reshape(rows, f, cols, f).transpose(0, 2, 1, 3).reshape(rows, cols, f * f)
        best = blocks.argmax(axis=-1)
        self._node_clear = np.take_along_axis(blocks, best[..., None], -1)[..., 0]
        r = np.arange(rows)[:, None] * f + best // f
        c = np.arange(cols)[None, :] * f + best % f
        self._node_xy = np.stack([g.x0 + (c + 0.5) * res, g.y0 + (r + 0.5) * res], axis=-1).reshape(-1, 2)
        self._f, self._shape = f, (rows, cols)
        n_nodes = rows * cols
        n = len(self.ids)
        if hop is not None:  # a stored table, memory-mapped (kept so for tables()), indexed
            self._paths = hop  # as a plain array: a memmap's own indexing cost a city's step 1 ms
            self._hop = np.asarray(hop)
            return
        # -1 (no next hop) wherever a person's Dijkstra run does not reach: every node off
        # the few its clearance class keeps (a city's table: 200 people x 2 x 250,000 nodes).
        self._hop = np.full((n, 2, n_nodes), -1, dtype=np.int32)
        # One graph per clearance class (5 cm): people of like size share their Dijkstra run.
        groups = np.floor(self.need / 0.05 + 1e-9) * 0.05
        for need in np.unique(groups):
            members = np.flatnonzero(groups == need)
            targets = np.concatenate([self.goal[members], self.start[members]])
            nodes, hops = self._hops(need, self._node_of(targets))
            m = len(members)
            for k, i in enumerate(members.tolist()):
                self._hop[i, 0, nodes] = hops[k]
                self._hop[i, 1, nodes] = hops[m + k]
        self._paths = self._hop

    def _hops(self, need: float, src: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The next hop (node, or -1) towards each node of ``src`` for people keeping ``need``
        (m), from the nodes that clear it and the sources (``nodes``, ascending): ``(nodes,
        hops)``, ``hops`` ``(len(src), len(nodes))``; from every other node there is none.

        Dijkstra runs on those nodes alone (on a city a fifth of the grid's; scipy's
        Dijkstra sets up every node of its graph for each source), numbered in the grid's
        order: every node's neighbours are listed in the same order, so the runs relax the
        same edges in the same order and find the same predecessors as on the whole grid
        (``tests/test_crowd.py``), which :meth:`_hops_whole` keeps as the reference."""
        rows, cols = self._shape
        keep = (self._node_clear >= need).ravel()
        keep[src] = True
        nodes = np.flatnonzero(keep)
        index = np.full(rows * cols, -1, dtype=np.int64)
        index[nodes] = np.arange(nodes.size)
        s, d, w = self._edges(need)
        graph = scipy.sparse.csr_matrix((w, (index[s], index[d])), shape=(nodes.size, nodes.size))
        _, pred = scipy.sparse.csgraph.dijkstra(
            graph, directed=False, indices=index[src], return_predecessors=True
        )
        return nodes, np.where(pred >= 0, nodes.astype(np.int32)[np.maximum(pred, 0)], -1)

    def _hops_whole(self, need: float, src: np.ndarray) -> np.ndarray:
        """:meth:`_hops` by Dijkstra on the whole grid: the plain reference."""
        _, pred = scipy.sparse.csgraph.dijkstra(
            self._graph(need), directed=False, indices=src, return_predecessors=True
        )
        np.maximum(pred, -1, out=pred)  # no predecessor (-9999): -1
        return pred

    def tables(self) -> dict[str, np.ndarray]:
        """What the constructor computes from the scene and its map alone, the costly part
        of a crowd (a city's: 0.6 GB, seconds of distance transform and Dijkstra): ``paths``
        (the next hops), ``clearance`` and ``blocked`` (each cell's nearest blocked cell)."""
        return {"paths": self._paths, "clearance": self.clearance, "blocked": self._blocked_xy}

    def _node_of(self, xy: np.ndarray) -> np.ndarray:
        row, col = self._cells(xy)
        return (row // self._f) * self._shape[1] + col // self._f

    def _edges(self, need: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The path grid's edges for people keeping ``need`` (m): both ends clear it
        (diagonals also both orthogonal nodes beside them), node ids ``(from, to)`` and
        their lengths (m; a hair more, so that none is 0)."""
        rows, cols = self._shape
        ok = self._node_clear >= need
        ids = np.arange(rows * cols).reshape(rows, cols)
        src, dst = [], []
        for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
            a = ok[: rows - dr, max(0, -dc) : cols - max(0, dc)]
            b = ok[dr:, max(0, dc) : cols + min(0, dc)]
            both = a & b
            if dr and dc:  # diagonal: only where both orthogonal cells are free too (no corner cutting)
                both &= (
                    ok[: rows - dr, max(0, dc) : cols + min(0, dc)] & ok[dr:, max(0, -dc) : cols - max(0, dc)]
                )
            src.append(ids[: rows - dr, max(0, -dc) : cols - max(0, dc)][both])
            dst.append(ids[dr:, max(0, dc) : cols + min(0, dc)][both])
        s, d = np.concatenate(src), np.concatenate(dst)
        return s, d, np.linalg.norm(self._node_xy[s] - self._node_xy[d], axis=1) + 1e-9

    def _graph(self, need: float) -> scipy.sparse.csr_matrix:
        """The whole path grid as a graph (edges :meth:`_edges`, weighted by length, m)."""
        rows, cols = self._shape
        s, d, w = self._edges(need)
        return scipy.sparse.csr_matrix((w, (s, d)), shape=(rows * cols, rows * cols))

    # state
    def reset(self, rng: np.random.Generator) -> None:
        """Everyone back at its start, standing, heading for its goal; ``rng`` drives the nudges."""
        self._rng = rng
        self.pos = self.start.copy()
        self.vel = np.zeros_like(self.pos)
        self.target = np.zeros(len(self.ids), dtype=np.int64)
        self.arrivals = np.zeros(len(self.ids), dtype=np.int64)
        d = self.goal - self.start
        self._heading = np.arctan2(d[:, 1], d[:, 0])

    def targets(self) -> np.ndarray:
        """Where each person is heading now ``(N, 2)`` (m)."""
        return np.where((self.target == 0)[:, None], self.goal, self.start)

    def preferred_velocities(self, rows: np.ndarray | None = None) -> np.ndarray:
        """Velocities (m/s) towards a waypoint :data:`LOOKAHEAD` cells ahead on each person's
        path (of the people ``rows``, default everyone)."""
        rows = np.arange(len(self.ids)) if rows is None else rows
        tgt = self.targets()[rows]
        pos, target = self.pos[rows], self.target[rows]
        node = self._node_of(pos)
        for _ in range(LOOKAHEAD):
            nxt = self._hop[rows, target, node]
            node = np.where(nxt >= 0, nxt, node)
        src = self._node_of(tgt)
        lost = self._hop[rows, target, self._node_of(pos)] < 0  # at the target's node, or cut off
        aim = np.where(((node == src) | lost)[:, None], tgt, self._node_xy[node])
        u, dist = _unit(aim - pos)
        return u * np.minimum(self.speed[rows], dist / self.dt)[:, None]

    def _static(self, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The nearest blocked cell centres seen from each person ``rows`` and from 8 points around it."""
        pos, radius, static_radius = self.pos[rows], self.radius[rows], self._static_radius[rows]
        ang = np.arange(8) * (np.pi / 4)
        probe = radius[:, None, None] + 0.3
        around = pos[:, None] + probe * np.stack([np.cos(ang), np.sin(ang)], -1)[None]
        pts = np.concatenate([pos[:, None], around], axis=1)
        row, col = self._cells(pts)
        near = self._blocked_xy[row, col]
        reach = (radius + self.max_speed[rows] * 1.0 + static_radius + 0.5)[:, None]
        far = np.linalg.norm(near - pos[:, None], axis=-1) > reach
        radii = np.where(far, -1.0, static_radius[:, None])
        return near, radii

    def step(
        self, robot_xy, robot_vel, robot_radius: float, vehicles: Footprints | None = None,
        active: np.ndarray | None = None,
    ) -> None:  # fmt: skip
        """Move everyone by one step of ``dt``, avoiding each other, the robot at ``robot_xy``
        (m) moving at ``robot_vel`` (m/s) with radius ``robot_radius`` (m), and the vehicles'
        ``vehicles`` footprints (never stepping into one, nor into the ground its next step
        covers).

        ``active`` (bool ``(N,)``, default everyone): the people who move. The others stand
        where they are (velocity 0, target and arrivals kept) as obstacles that the moving
        ones avoid the way they avoid the robot (ORCA's non-cooperative agents: full
        responsibility) and never step into; with everyone active the step is the same to the
        bit (the nudges are drawn for the moving people only)."""
        n = len(self.ids)
        if n == 0:
            return
        a = np.arange(n) if active is None else np.flatnonzero(active)
        if not len(a):  # no one moves
            self.vel = np.zeros_like(self.pos)
            return
        rxy = np.asarray(robot_xy, dtype=np.float64).reshape(2)
        rvel = np.asarray(robot_vel, dtype=np.float64).reshape(2)
        rrad = float(robot_radius)
        gap = np.linalg.norm(self.targets()[a] - self.pos[a], axis=1)
        arrived = gap < np.maximum(ARRIVE, 0.5 * self.radius[a])
        self.target[a] = np.where(arrived, 1 - self.target[a], self.target[a])
        self.arrivals[a] += arrived
        pref = self.preferred_velocities(a) + self._rng.normal(0.0, JITTER, (len(a), 2))
        pts, radii = self._static(a)
        # Non-cooperative agents: the robot, the discs covering the vehicles near anyone, and
        # the people standing (not active) near a moving one.
        vxy, vvel, vrad = self._vehicle_discs(vehicles, a)
        still = self._standing_near(a)
        m = 1 + len(vxy) + len(still)
        pos = np.concatenate([self.pos[a], rxy[None], vxy, self.pos[still]])
        vel = np.concatenate([self.vel[a], rvel[None], vvel, np.zeros((len(still), 2))])
        coop = np.arange(len(a) + m) < len(a)
        static = (
            np.concatenate([pts, np.full((m, pts.shape[1], 2), np.nan)]),
            np.concatenate([radii, np.full((m, radii.shape[1]), -1.0)]),
        )
        v = orca_velocities(
            pos,
            vel,
            np.concatenate([pref, rvel[None], vvel, np.zeros((len(still), 2))]),
            np.concatenate([self.radius[a], [rrad + ROBOT_MARGIN], vrad + ROBOT_MARGIN, self.radius[still]]),
            np.concatenate(
                [
                    self.max_speed[a],
                    [max(1.0, float(np.hypot(*rvel)))],
                    np.maximum(1.0, np.hypot(*vvel.T)),
                    np.ones(len(still)),
                ]
            ),
            dt=self.dt,
            tau=self.tau,
            neighbor_dist=self.neighbor_dist,
            max_neighbors=self.max_neighbors,
            cooperative=coop,
            static=static,
        )[: len(a)]
        cand = self.pos.copy()
        cand[a] += v * self.dt
        movable = None if active is None else np.asarray(active, dtype=bool)
        new = self._safe(cand, rxy, rvel, rrad, vehicles, movable)
        self.vel = (new - self.pos) / self.dt
        self.pos = new
        moving = np.hypot(self.vel[:, 0], self.vel[:, 1]) > 0.05
        self._heading = np.where(moving, np.arctan2(self.vel[:, 1], self.vel[:, 0]), self._heading)

    def _standing_near(self, rows: np.ndarray) -> np.ndarray:
        """The people not in ``rows`` (standing) within a neighbour's reach of one of them."""
        if len(rows) == len(self.ids):
            return np.zeros(0, dtype=np.int64)
        standing = np.ones(len(self.ids), dtype=bool)
        standing[rows] = False
        others = np.flatnonzero(standing)
        reach = self.neighbor_dist + 2.0 * float(self.radius.max())
        d = np.linalg.norm(self.pos[others][:, None] - self.pos[rows][None], axis=-1)
        return others[np.min(d, axis=1) < reach]

    def _vehicle_discs(
        self, vehicles: Footprints | None, rows: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Centres, velocities and radii of the discs covering the vehicles
        (:func:`~citygen.runner.agents.footprints.covering_discs`) within a neighbour's reach
        of someone of ``rows``."""
        if vehicles is None or not len(vehicles.pos):
            return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros(0)
        xy, rad, vel = covering_discs(vehicles)
        gap = np.min(np.linalg.norm(xy[:, None] - self.pos[rows][None], axis=-1), axis=1) - rad
        near = gap < self.neighbor_dist + float(self.radius.max())
        return xy[near], vel[near], rad[near]

    def _safe(
        self, cand: np.ndarray, rxy: np.ndarray, rvel: np.ndarray, rrad: float, vehicles=None,
        movable: np.ndarray | None = None,
    ) -> np.ndarray:  # fmt: skip
        """``cand`` made safe: on allowed ground (slide along the boundary, else stay), out of the
        robot's disc now and after its next step where the ground allows, no deeper into a
        vehicle's footprint (grown by its next step) than before, and no overlap between two
        people larger than before (take steps back). ``movable`` (bool ``(N,)``, default
        everyone): who may be moved; the others' ``cand`` is where they stand."""
        old = self.pos
        if movable is None:
            movable = np.ones(len(cand), dtype=bool)

        def in_vehicle(xy: np.ndarray, radius: np.ndarray) -> np.ndarray:
            if vehicles is None:
                return np.full(len(xy), -np.inf)
            return footprint_depth(xy, radius, vehicles, ahead=self.dt)

        vfloor = np.maximum(in_vehicle(old, self.radius), 0.0)  # already there (a vehicle's doing)
        step = cand - old
        for trial in (old + step * [1.0, 0.0], old + step * [0.0, 1.0], old):
            bad = ~self.allowed(cand)
            cand = np.where(bad[:, None], trial, cand)
        # The robot sweeps the segment from where it is to where it will be after its next step.
        a, b = rxy, rxy + rvel * self.dt
        ab = b - a
        reach = self.radius + rrad

        def nearest(xy: np.ndarray) -> np.ndarray:
            t = np.clip(dot(xy - a, ab) / max(dot(ab, ab), 1e-12), 0.0, 1.0)
            return a + t[:, None] * ab

        def depth(xy: np.ndarray) -> np.ndarray:
            return reach - np.linalg.norm(xy - nearest(xy), axis=1)

        def in_robot(xy: np.ndarray) -> np.ndarray:
            return depth(xy) > 0.0

        hit = in_robot(cand)
        if hit.any():
            q = nearest(cand)
            away, _ = _unit(cand - q)
            out = q + away * (reach + 1e-3)[:, None]
            fine = hit & ~in_robot(out) & self.allowed(out) & movable
            cand = np.where(fine[:, None], out, cand)
        # Rare conflicts ORCA left (a person squeezed between the robot, others and a wall): each
        # conflicted person takes, of a few steps it could make, the one that overlaps least.
        floor = self._worst_overlap(old)  # overlaps already there may stay
        for _ in range(2):
            conflict = np.flatnonzero(
                (self._worst_overlap(cand) < floor - OVERLAP_SLACK)
                | (depth(cand) > OVERLAP_SLACK)
                | (in_vehicle(cand, self.radius) > vfloor + OVERLAP_SLACK)
            )
            conflict = conflict[movable[conflict]]
            if not len(conflict):
                break
            for i in conflict.tolist():
                opts = np.concatenate([cand[i : i + 1], old[i] + _ESCAPES * self.max_speed[i] * self.dt])
                others = np.delete(np.arange(len(cand)), i)
                d = np.linalg.norm(opts[:, None] - cand[others][None], axis=-1)
                over = np.max(self.radius[i] + self.radius[others] - d, axis=1, initial=0.0) + floor[i]
                dep = reach[i] - np.linalg.norm(
                    opts - (a + np.clip(dot(opts - a, ab) / max(dot(ab, ab), 1e-12), 0.0, 1.0)[:, None] * ab),
                    axis=1,
                )
                veh = in_vehicle(opts, np.full(len(opts), self.radius[i])) - vfloor[i]
                score = np.maximum(np.maximum(np.maximum(over, dep), veh), 0.0)
                score[self._clear_at(opts) < self.need[i]] = np.inf
                best = int(np.argmin(score + 1e-6 * np.linalg.norm(opts - cand[i], axis=1)))
                if np.isfinite(score[best]):
                    cand[i] = opts[best]
        # Steps still into a vehicle are not taken; steps that still make two people overlap
        # more than now are taken back (not into the robot).
        into = in_vehicle(cand, self.radius) > vfloor + OVERLAP_SLACK
        cand[into] = old[into]
        pinned = depth(old) > OVERLAP_SLACK  # a step back would leave them inside the robot
        back = np.zeros(len(cand), dtype=bool)
        for _ in range(len(cand)):
            i, j, gap = self._overlaps(cand)
            worse = (gap < -OVERLAP_SLACK) & (gap < self._gap(old, i, j) - 1e-9)
            i, j = i[worse], j[worse]
            movers = np.unique(np.concatenate([i, j]))
            movers = movers[~back[movers] & ~pinned[movers]]
            if not len(movers):
                break
            back[movers] = True
            cand[movers] = old[movers]
        return cand

    def _gap(self, xy: np.ndarray, i: np.ndarray, j: np.ndarray) -> np.ndarray:
        """Gaps (m) between the discs of people ``i`` and ``j`` at ``xy``."""
        return np.linalg.norm(xy[i] - xy[j], axis=1) - (self.radius[i] + self.radius[j])

    def _overlaps(self, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The pairs ``i < j`` of people whose discs overlap at ``xy`` and their gaps (m, < 0),
        found by a KD-tree: only people within two of the largest radii can overlap."""
        pairs = cKDTree(xy).query_pairs(2 * float(self.radius.max()), output_type="ndarray")
        i, j = pairs[:, 0], pairs[:, 1]
        gap = self._gap(xy, i, j)
        over = gap < 0.0
        return i[over], j[over], gap[over]

    def _worst_overlap(self, xy: np.ndarray) -> np.ndarray:
        """Per person the gap (m) to the person it overlaps most at ``xy``; 0 if none."""
        worst = np.zeros(len(xy))
        i, j, gap = self._overlaps(xy)
        np.minimum.at(worst, i, gap)
        np.minimum.at(worst, j, gap)
        return worst

    def headings(self) -> np.ndarray:
        """Yaw (rad) each person faces: where it moves, or where it last moved when standing."""
        return self._heading.copy()
