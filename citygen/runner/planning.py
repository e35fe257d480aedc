"""The navigation baseline's pieces: A* on an inflated occupancy grid, geodesic distance
fields, line-of-sight shortcuts, pure pursuit and reactive avoidance of moving agents.

Grids are boolean ``free`` arrays indexed ``(row, col)`` with rows along +y, as in
:mod:`citygen.exporters.occupancy` (``free = ~occupancy_map.inflated(robot_radius)``: a
robot of that radius keeps its centre on free cells). Paths move between the 8 neighbours
of a cell; a diagonal step needs both cells beside it free (no corner cutting). Lengths on
the grid are in cells; world lengths in metres; angles in radians; speeds in m/s and rad/s.

>>> free = np.ones((3, 4), dtype=bool)
>>> free[1, 1:3] = False  # a diagonal step needs both cells beside it free
>>> astar(free, (1, 0), (1, 3))
[(1, 0), (0, 0), (0, 1), (0, 2), (0, 3), (1, 3)]
>>> astar(free, (0, 0), (0, 0))
[(0, 0)]
"""

from __future__ import annotations

import functools
import heapq
import itertools
import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.ndimage
import scipy.sparse
import scipy.sparse.csgraph

from citygen.exporters.occupancy import OccupancyMap
from citygen.geometry.raster import Grid, components, erode

Cell = tuple[int, int]

_SQRT2 = math.sqrt(2.0)
_AGENT_BERTH = 0.2
"""Extra clearance (m) around an agent's disc when the planner replans around agents: more
than :func:`avoid`'s default margin, so the new path is one avoidance lets the robot follow."""
# Steps of the grid graph (each an undirected edge) and the cells, relative to the step's
# source, its straight segment passes through and that must be free too.
_STEPS8: tuple[tuple[int, int, tuple[Cell, ...]], ...] = (
    (0, 1, ()),
    (1, 0, ()),
    (1, 1, ((0, 1), (1, 0))),
    (1, -1, ((0, -1), (1, 0))),
)
_STEPS16 = (
    *_STEPS8,
    (1, 2, ((0, 1), (1, 1))),
    (2, 1, ((1, 0), (1, 1))),
    (2, -1, ((1, 0), (1, -1))),
    (1, -2, ((0, -1), (1, -1))),
)


# --- checks ----------------------------------------------------------------------------


def _free_array(free: object) -> np.ndarray:
    arr = np.asarray(free)
    if arr.dtype != np.bool_ or arr.ndim != 2 or arr.size == 0:
        raise ValueError(f"free: expected a non-empty 2-D bool array, got {arr.dtype} of shape {arr.shape}")
    return arr


def _cell(free: np.ndarray, cell: object, name: str) -> Cell:
    try:
        r, c = (int(v) for v in cell)  # type: ignore[attr-defined]
    except (TypeError, ValueError):
        raise ValueError(f"{name}: expected a (row, col) cell, got {cell!r}") from None
    if not (0 <= r < free.shape[0] and 0 <= c < free.shape[1]):
        raise ValueError(f"{name}: cell {(r, c)} is outside the grid of shape {free.shape}")
    return r, c


# --- grid search -----------------------------------------------------------------------


def astar(free: np.ndarray, start: Cell, goal: Cell) -> list[Cell] | None:
    """The shortest 8-connected path of free cells from ``start`` to ``goal`` (both
    included; steps of 1 and sqrt(2) cells, no corner cutting), or None when either cell is
    blocked or they are not connected. Octile heuristic (consistent, so the path is optimal);
    ties go to the node nearer the goal, then the lower flat index, so it is deterministic."""
    free = _free_array(free)
    start, goal = _cell(free, start, "start"), _cell(free, goal, "goal")
    if not (free[start] and free[goal]):
        return None
    width = free.shape[1] + 2  # flat indices into the grid padded by one blocked cell: no bounds checks
    ok = bytearray(np.pad(free, 1).ravel().tobytes())
    source = (start[0] + 1) * width + start[1] + 1
    target = (goal[0] + 1) * width + goal[1] + 1
    moves = (
        (1, 1.0, 0, 0),
        (-1, 1.0, 0, 0),
        (width, 1.0, 0, 0),
        (-width, 1.0, 0, 0),
        (width + 1, _SQRT2, width, 1),
        (width - 1, _SQRT2, width, -1),
        (-width + 1, _SQRT2, -width, 1),
        (-width - 1, _SQRT2, -width, -1),
    )
    size = len(ok)
    # The octile distance to the goal of every (padded) cell, precomputed in numpy.
    dr = np.abs(np.arange(free.shape[0] + 2) - (goal[0] + 1))[:, None]
    dc = np.abs(np.arange(width) - (goal[1] + 1))[None, :]
    heuristic = (dr + dc + (_SQRT2 - 2.0) * np.minimum(dr, dc)).ravel().tolist()
    g = [math.inf] * size
    parent = [-1] * size
    closed = bytearray(size)
    g[source] = 0.0
    heap = [(heuristic[source], heuristic[source], source)]
    pop, push = heapq.heappop, heapq.heappush
    while heap:
        _, _, u = pop(heap)
        if closed[u]:
            continue
        if u == target:
            break
        closed[u] = 1
        gu = g[u]
        for step, cost, side_a, side_b in moves:
            v = u + step
            if not ok[v] or closed[v] or (side_a and not (ok[u + side_a] and ok[u + side_b])):
                continue
            ng = gu + cost
            if ng < g[v]:
                g[v] = ng
                parent[v] = u
                h = heuristic[v]
                push(heap, (ng + h, h, v))
    if not closed[target] and target != source and parent[target] < 0:
        return None
    path = [target]
    while path[-1] != source:
        path.append(parent[path[-1]])
    return [(v // width - 1, v % width - 1) for v in reversed(path)]


def path_length(path: Sequence[Cell]) -> float:
    """Length of a cell path in cells (Euclidean between consecutive cell centres)."""
    p = np.asarray(path, dtype=np.float64).reshape(-1, 2)
    return float(np.hypot(*np.diff(p, axis=0).T).sum()) if len(p) > 1 else 0.0


def _grid_graph(free: np.ndarray, connectivity: int) -> tuple[scipy.sparse.csr_matrix, np.ndarray]:
    """Free cells as nodes (row-major), undirected edges weighted by step length in cells."""
    steps = {8: _STEPS8, 16: _STEPS16}[connectivity]
    rows, cols = free.shape
    index = np.full((rows + 4, cols + 4), -1, dtype=np.int32)  # padded by 2: every step in bounds
    n = int(free.sum())
    index[2:-2, 2:-2][free] = np.arange(n, dtype=np.int32)
    padded = index >= 0

    def shifted(a: np.ndarray, dr: int, dc: int) -> np.ndarray:
        return a[2 + dr : 2 + dr + rows, 2 + dc : 2 + dc + cols]

    heads, tails, weights = [], [], []
    for dr, dc, through in steps:
        ok = free & shifted(padded, dr, dc)
        for tr, tc in through:
            ok &= shifted(padded, tr, tc)
        heads.append(index[2:-2, 2:-2][ok])
        tails.append(shifted(index, dr, dc)[ok])
        weights.append(np.full(heads[-1].size, math.hypot(dr, dc)))
    graph = scipy.sparse.csr_matrix(
        (np.concatenate(weights), (np.concatenate(heads), np.concatenate(tails))), shape=(n, n)
    )
    return graph, index[2:-2, 2:-2]


def geodesic_distance(
    free: np.ndarray, goal_cell: Cell, resolution: float, *, connectivity: int = 8
) -> np.ndarray:
    """Shortest-path distance (m) from every cell to ``goal_cell`` through free cells: a
    float64 array of ``free``'s shape, ``inf`` on blocked cells and cells not connected to the
    goal (everywhere when the goal cell is blocked).

    ``connectivity`` 8 uses the steps of :func:`astar` (so ``field[start]`` is the length of
    its path times ``resolution``; up to 8.2 % longer than the straight line in free space);
    16 adds the knight's moves (sqrt(5) cells, the two cells they pass through must be free),
    at most 2.7 % longer than the straight line: the better estimate of a route's length.
    """
    free = _free_array(free)
    goal = _cell(free, goal_cell, "goal_cell")
    if not (resolution > 0 and math.isfinite(resolution)):
        raise ValueError(f"resolution: expected a positive cell size in metres, got {resolution!r}")
    if connectivity not in (8, 16):
        raise ValueError(f"connectivity: expected 8 or 16, got {connectivity!r}")
    out = np.full(free.shape, np.inf)
    if not free[goal]:
        return out
    graph, index = _grid_graph(free, connectivity)
    dist = scipy.sparse.csgraph.dijkstra(graph, directed=False, indices=int(index[goal]))
    out[free] = dist * resolution
    return out


def snap_free(free: np.ndarray, cell: Cell, within: np.ndarray | None = None) -> Cell | None:
    """The free cell nearest ``cell`` (Euclidean between centres; ``cell`` itself when it is
    free), only among cells where ``within`` is True when given; None when there is none."""
    free = _free_array(free)
    cell = _cell(free, cell, "cell")
    allowed = free if within is None else free & _free_array(within)
    if allowed[cell]:
        return cell
    if not allowed.any():
        return None
    _, (rr, cc) = scipy.ndimage.distance_transform_edt(~allowed, return_indices=True)
    return int(rr[cell]), int(cc[cell])


# --- geometry on the grid ----------------------------------------------------------------


def path_to_world(path: Sequence[Cell], occupancy: OccupancyMap | Grid) -> np.ndarray:
    """Cell centres of a path as an ``(K, 2)`` float64 array of world ``(x, y)`` (m)."""
    grid = occupancy.grid if isinstance(occupancy, OccupancyMap) else occupancy
    p = np.asarray(path, dtype=np.float64).reshape(-1, 2)
    return np.column_stack(
        (grid.x0 + (p[:, 1] + 0.5) * grid.resolution, grid.y0 + (p[:, 0] + 0.5) * grid.resolution)
    )


def line_of_sight(free: np.ndarray, a: Cell, b: Cell) -> bool:
    """Whether the straight segment between the centres of cells ``a`` and ``b`` stays on
    free cells: every cell it passes through, and all four cells around a cell corner it
    passes exactly through (conservative)."""
    (r0, c0), (r1, c1) = (float(a[0]) + 0.5, float(a[1]) + 0.5), (float(b[0]) + 0.5, float(b[1]) + 0.5)
    dr, dc = r1 - r0, c1 - c0
    # Parameters where the segment crosses a grid line (cell (i, j) spans [i, i+1) x [j, j+1)).
    ts = [np.array([0.0, 1.0])]
    for p0, d in ((r0, dr), (c0, dc)):
        if d != 0:
            lines = np.arange(math.ceil(min(p0, p0 + d)), math.floor(max(p0, p0 + d)) + 1)
            ts.append((lines - p0) / d)
    t = np.unique(np.concatenate(ts))
    t = np.concatenate((t, (t[:-1] + t[1:]) / 2))  # crossings and the middle of each cell's stretch
    r, c = r0 + t * dr, c0 + t * dc
    eps = 1e-9
    lo_r, hi_r = np.floor(r - eps).astype(np.int64), np.floor(r + eps).astype(np.int64)
    lo_c, hi_c = np.floor(c - eps).astype(np.int64), np.floor(c + eps).astype(np.int64)
    rr = np.concatenate((lo_r, lo_r, hi_r, hi_r))
    cc = np.concatenate((lo_c, hi_c, lo_c, hi_c))
    if rr.min() < 0 or cc.min() < 0 or rr.max() >= free.shape[0] or cc.max() >= free.shape[1]:
        return False
    return bool(free[rr, cc].all())


def shortcut(free: np.ndarray, path: Sequence[Cell]) -> list[Cell]:
    """The path with every run of cells replaced by one straight segment where
    :func:`line_of_sight` allows (greedy from the start): the corners of an any-angle path."""
    free = _free_array(free)
    cells = [(int(r), int(c)) for r, c in path]
    if len(cells) <= 2:
        return cells
    out = [cells[0]]
    i = 0
    while i < len(cells) - 1:
        j = i + 1
        while j + 1 < len(cells) and line_of_sight(free, cells[i], cells[j + 1]):
            j += 1
        out.append(cells[j])
        i = j
    return out


# --- control -------------------------------------------------------------------------------


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _closest_on_path(path: np.ndarray, xy: np.ndarray) -> tuple[float, np.ndarray]:
    """Arc length (m) of the point of ``path`` nearest ``xy``, and the cumulative arc length
    at each vertex."""
    seg = np.diff(path, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    cum = np.concatenate(([0.0], np.cumsum(lengths)))
    if len(seg) == 0:
        return 0.0, cum
    sq = np.maximum(lengths**2, 1e-18)
    t = np.clip(((xy - path[:-1]) * seg).sum(axis=1) / sq, 0.0, 1.0)
    foot = path[:-1] + t[:, None] * seg
    k = int(np.argmin(np.hypot(*(foot - xy).T)))
    return float(cum[k] + t[k] * lengths[k]), cum


def _point_at(path: np.ndarray, cum: np.ndarray, s: float) -> np.ndarray:
    s = min(max(s, 0.0), float(cum[-1]))
    k = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(path) - 2)) if len(path) > 1 else 0
    if len(path) == 1:
        return path[0].copy()
    length = cum[k + 1] - cum[k]
    t = 0.0 if length <= 0 else (s - cum[k]) / length
    return path[k] + t * (path[k + 1] - path[k])


def point_ahead(path: np.ndarray, xy: Sequence[float], ahead: float) -> np.ndarray:
    """The point ``ahead`` m along ``path`` (``(K, 2)``, m) past the point of it nearest
    ``xy``, at most its end."""
    path = np.asarray(path, dtype=np.float64)
    s, cum = _closest_on_path(path, np.asarray(xy, dtype=np.float64)[:2])
    return _point_at(path, cum, s + ahead)


def pure_pursuit(
    pose: Sequence[float],
    path_xy: np.ndarray,
    lookahead: float,
    max_speed: float,
    max_yaw_rate: float,
    *,
    slow_radius: float = 1.0,
    turn_in_place: float = math.pi / 4,
    sharp_turn: float = math.pi / 6,
    corner_radius: float = 0.1,
    yaw_gain: float = 2.5,
) -> tuple[float, float]:
    """Forward speed ``v`` (m/s) and yaw rate ``w`` (rad/s) that steer a unicycle at
    ``pose = (x, y, yaw)`` (m, m, rad) along ``path_xy`` (``(K, 2)``, m).

    The target is the point ``lookahead`` metres of path beyond the path point nearest the
    robot, but never past a vertex that turns by more than ``sharp_turn`` unless the robot
    is within ``corner_radius`` of it, so the robot does not cut sharp corners. The command
    follows the pure-pursuit arc through the target (curvature ``2 sin(alpha) / d``), at
    ``max_speed`` scaled by ``cos(alpha)`` on turns, linearly down to zero within
    ``slow_radius`` of the path's end, and slower still when the arc would need more than
    ``max_yaw_rate``; when the target lies more than ``turn_in_place`` off the heading the
    robot turns on the spot. The yaw rate never exceeds ``yaw_gain`` (1/s) times the heading
    error, so a robot whose turning lags one control step does not overshoot and weave.
    Returns ``(0, 0)`` at the end of the path.
    """
    x, y, yaw = (float(v) for v in pose)
    path = np.asarray(path_xy, dtype=np.float64).reshape(-1, 2)
    if len(path) == 0:
        raise ValueError("path_xy: expected at least one (x, y) point")
    if not (lookahead > 0 and max_speed > 0 and max_yaw_rate > 0):
        raise ValueError(
            "pure_pursuit: lookahead (m), max_speed (m/s) and max_yaw_rate (rad/s) must be positive, got "
            f"{lookahead!r}, {max_speed!r}, {max_yaw_rate!r}"
        )
    xy = np.array([x, y])
    s0, cum = _closest_on_path(path, xy)
    total = float(cum[-1])
    s_target = s0 + lookahead
    # Stop at the first sharp vertex ahead (beyond corner_radius), so the chord hugs the path.
    for k in range(1, len(path) - 1):
        if cum[k] <= s0 + corner_radius:
            continue
        if cum[k] >= s_target:
            break
        a, b = path[k] - path[k - 1], path[k + 1] - path[k]
        if abs(_wrap(math.atan2(b[1], b[0]) - math.atan2(a[1], a[0]))) > sharp_turn:
            s_target = float(cum[k])
            break
    target = _point_at(path, cum, s_target)
    to_goal = float(np.hypot(*(path[-1] - xy)))
    if s_target >= total - 1e-9:
        target = path[-1]
    d = float(np.hypot(*(target - xy)))
    if d < 1e-6 or to_goal < 1e-3:
        return 0.0, 0.0
    alpha = _wrap(math.atan2(target[1] - y, target[0] - x) - yaw)
    turn_cap = min(max_yaw_rate, yaw_gain * abs(alpha))
    if abs(alpha) > turn_in_place:
        return 0.0, math.copysign(turn_cap, alpha)
    remaining = total - s0 + float(np.hypot(*(path[0] - xy))) * (len(path) == 1)
    v = max_speed * math.cos(alpha) * min(1.0, max(remaining, to_goal) / slow_radius)
    v = min(v, to_goal / 0.1 * max_speed) if to_goal < 0.1 else v
    curvature = 2.0 * math.sin(alpha) / d
    w = v * curvature
    if abs(w) > turn_cap:
        v, w = turn_cap / abs(curvature), math.copysign(turn_cap, w)
    return float(v), float(w)


def _unicycle(
    pose: np.ndarray, v: np.ndarray, w: np.ndarray, times: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Positions ``(C, T)`` x and y of a unicycle at ``pose`` after each time in ``times``
    under each constant command ``(v[c], w[c])`` (exact arcs)."""
    x, y, yaw = pose
    t = times[None, :]
    w_ = w[:, None]
    v_ = v[:, None]
    straight = np.abs(w_) < 1e-9
    safe_w = np.where(straight, 1.0, w_)
    heading = yaw + w_ * t
    xs = np.where(straight, x + v_ * t * math.cos(yaw), x + v_ / safe_w * (np.sin(heading) - math.sin(yaw)))
    ys = np.where(straight, y + v_ * t * math.sin(yaw), y - v_ / safe_w * (np.cos(heading) - math.cos(yaw)))
    return xs, ys


def avoid(
    pose: Sequence[float],
    v: float,
    w: float,
    others_xy: np.ndarray,
    others_vel: np.ndarray,
    others_radius: np.ndarray | float,
    robot_radius: float,
    horizon: float,
    *,
    max_speed: float | None = None,
    max_yaw_rate: float = 1.5,
    min_speed: float = 0.0,
    dt: float = 0.1,
    margin: float = 0.05,
    samples: tuple[int, int] = (7, 15),
    free_at: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    clearance: float = 1.0,
    clearance_weight: float = 0.5,
) -> tuple[float, float]:
    """The command ``(v, w)`` (m/s, rad/s) nearest the desired one whose predicted arc keeps
    clear of moving agents for ``horizon`` seconds.

    Agents are discs at ``others_xy`` (``(N, 2)``, m) moving at constant ``others_vel``
    (``(N, 2)``, m/s) with ``others_radius`` (m, scalar or ``(N,)``); the robot is a disc of
    ``robot_radius`` following the exact arc of each constant command, checked every ``dt``
    seconds. A command is safe when the robot's distance to every agent stays above the sum
    of radii plus ``margin`` (for an agent already closer, when it does not shrink). The
    desired command is returned unchanged when it is safe; otherwise the safe one among a
    ``samples = (n_v, n_w)`` lattice over ``[min_speed, max_speed] x [-max_yaw_rate,
    max_yaw_rate]`` of least cost: the squared distance to the desired command (speeds
    relative to ``max_speed``, default the larger of ``|v|`` and 1 m/s; yaw rates to
    ``max_yaw_rate``) plus ``clearance_weight`` times how far the closest approach falls
    short of ``clearance`` metres of slack (0..1), which keeps it from merely slowing down to
    push a conflict past the horizon and from swapping sides step by step. Arcs must also keep
    ``free_at(xs, ys)`` (a callable giving True where a position is free of static obstacles)
    True when given. When no command is safe, the one with the widest closest approach,
    slowest first.
    """
    others = np.asarray(others_xy, dtype=np.float64).reshape(-1, 2)
    vel = np.asarray(others_vel, dtype=np.float64).reshape(-1, 2)
    if vel.shape != others.shape:
        raise ValueError(f"others_vel: expected shape {others.shape} like others_xy, got {vel.shape}")
    if len(others) == 0:
        return float(v), float(w)
    if not (horizon > 0 and dt > 0):
        raise ValueError(f"avoid: horizon and dt must be positive seconds, got {horizon!r}, {dt!r}")
    radii = np.broadcast_to(np.asarray(others_radius, dtype=np.float64), (len(others),))
    vmax = float(max_speed) if max_speed is not None else max(abs(float(v)), 1.0)
    nv, nw = samples
    vs, ws = np.meshgrid(np.linspace(min_speed, vmax, nv), np.linspace(-max_yaw_rate, max_yaw_rate, nw))
    cand_v = np.concatenate(([float(v)], vs.ravel()))
    cand_w = np.concatenate(([float(w)], ws.ravel()))
    times = np.arange(1, math.ceil(horizon / dt - 1e-9) + 1) * dt
    xs, ys = _unicycle(np.asarray(pose, dtype=np.float64), cand_v, cand_w, times)  # (C, T)
    ox = others[:, 0, None] + vel[:, 0, None] * times[None, :]  # (N, T)
    oy = others[:, 1, None] + vel[:, 1, None] * times[None, :]
    dist = np.hypot(xs[:, None, :] - ox[None], ys[:, None, :] - oy[None])  # (C, N, T)
    d0 = np.hypot(others[:, 0] - pose[0], others[:, 1] - pose[1])
    clear = radii + robot_radius + margin
    limit = np.minimum(clear, d0 - 1e-9)  # an agent already too close must not get closer
    gap = (dist - limit[None, :, None]).min(axis=(1, 2))  # (C,) m: the closest approach's slack
    conflict = (dist < limit[None, :, None]).any(axis=1)  # (C, T)
    if free_at is not None:
        conflict |= ~np.asarray(free_at(xs, ys), dtype=bool)
    safe = ~conflict.any(axis=1)
    if safe[0]:
        return float(v), float(w)
    if safe.any():
        cost = ((cand_v - v) / vmax) ** 2 + ((cand_w - w) / max_yaw_rate) ** 2
        cost += clearance_weight * (1.0 - np.clip(gap, 0.0, clearance) / clearance)
        k = int(np.argmin(np.where(safe, cost, np.inf)))
    else:  # the widest berth, slowest first
        k = int(np.lexsort((np.abs(cand_v), -np.round(gap, 6)))[0])
    return float(cand_v[k]), float(cand_w[k])


# --- the planner -------------------------------------------------------------------------


def region_distance(free: np.ndarray, grid: Grid, goal_xy: Sequence[float], tolerance: float) -> np.ndarray:
    """Any-angle geodesic distance (m) from every free cell's centre to the goal *region*,
    the disc of radius ``tolerance`` (m) around ``goal_xy`` (m), through free cells: a
    float64 array of ``free``'s shape, 0 inside the disc, ``inf`` on blocked cells and cells
    not connected to it.

    Second-order fast marching (scikit-fmm) from the disc's boundary, so the shortest path
    may run at any angle (not only along the grid's 8 or 16 directions): within about 0.5 %
    (and a cell) of the exact Euclidean geodesic, always a little over it. This is the
    ``L*_best`` of SPL as Anderson et al. (2018) define it: the shortest path to where
    success is declared. Raises ValueError when no free cell lies inside the disc.
    """
    import skfmm

    free = _free_array(free)
    if not (tolerance > 0 and math.isfinite(tolerance)):
        raise ValueError(f"tolerance: expected a positive radius in metres, got {tolerance!r}")
    xs, ys = grid.xs(), grid.ys()
    phi = np.hypot(xs[None, :] - float(goal_xy[0]), ys[:, None] - float(goal_xy[1])) - float(tolerance)
    inside = free & (phi <= 0)
    if not inside.any():
        raise ValueError(f"region_distance: no free cell within {tolerance:g} m of the goal {tuple(goal_xy)}")
    # Only the goal's component: fast marching would otherwise start afresh in every piece
    # the disc touches, and a component it does not touch is unreachable.
    labels, _ = components(free)
    mine = np.isin(labels, np.unique(labels[inside]))
    out = np.full(free.shape, np.inf)
    if inside.all() or not (mine & ~inside).any():
        out[inside] = 0.0
        return out
    d = skfmm.distance(np.ma.MaskedArray(phi, ~mine), dx=grid.resolution, order=2)
    d = np.ma.filled(d.astype(np.float64), np.inf)
    out[mine] = np.where(phi[mine] <= 0, 0.0, d[mine])
    return out


_REACH = 3
"""Cells around a bend of a taut path searched for the obstacle corner it bends round."""


def _off_corner(free: np.ndarray, grid: Grid, q: np.ndarray, eps: float) -> np.ndarray | None:
    """A cell corner ``q`` (m) moved a hair away from the one blocked cell of the four that
    meet there (a path bends round it), ``q`` when none is blocked, None when more are."""
    c = round((q[0] - grid.x0) / grid.resolution)
    r = round((q[1] - grid.y0) / grid.resolution)
    blocked = []
    for dr in (-1, 0):
        for dc in (-1, 0):
            rr, cc = r + dr, c + dc
            if not (0 <= rr < grid.rows and 0 <= cc < grid.cols and free[rr, cc]):
                blocked.append((dc + 0.5, dr + 0.5))
    if not blocked:
        return q
    if len(blocked) > 1:
        return None
    sx, sy = blocked[0]
    return q - eps * np.sign(np.array([sx, sy]))


def _cells_along(grid: Grid, a: np.ndarray, dx, dy, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Columns and rows of the points ``a + t * (dx, dy)`` (m): the one formula both line-of-
    sight tests sample with, so that they agree to the cell."""
    col = np.floor((a[0] + t * dx - grid.x0) / grid.resolution).astype(np.int64)
    row = np.floor((a[1] + t * dy - grid.y0) / grid.resolution).astype(np.int64)
    return col, row


def _visible(free: np.ndarray, grid: Grid, a: np.ndarray, b: np.ndarray) -> bool:
    """Whether the segment ``a``-``b`` (m) stays on free cells, sampled every quarter cell."""
    d = b - a
    n = max(2, math.ceil(math.hypot(d[0], d[1]) / (grid.resolution / 4)) + 1)
    t = np.arange(n) * (1.0 / (n - 1))  # np.linspace(0, 1, n), to the bit
    t[-1] = 1.0
    col, row = _cells_along(grid, a, d[0], d[1], t)
    if min(col[0], col[-1]) < 0 or min(row[0], row[-1]) < 0:
        return False
    if max(col[0], col[-1]) >= grid.cols or max(row[0], row[-1]) >= grid.rows:
        return False
    return bool(free[row, col].all())


#: Segments :func:`_farthest_visible` tests in one array pass (from the far end).
_SIGHT_BATCH = 32


def _farthest_visible(free: np.ndarray, grid: Grid, a: np.ndarray, pts: np.ndarray, first: int) -> int | None:
    """The largest ``j >= first`` whose segment ``a``-``pts[j]`` :func:`_visible` finds on
    free cells (None if none): the same samples and cells as ``_visible`` (its ``linspace``
    reproduced exactly), for a batch of segments per array pass instead of one per call."""
    stop = len(pts)
    while stop > first:
        start = max(first, stop - _SIGHT_BATCH)
        b = pts[start:stop]
        d = b - a
        n = np.maximum(2, np.ceil(np.hypot(d[:, 0], d[:, 1]) / (grid.resolution / 4)).astype(np.int64) + 1)
        seg = np.repeat(np.arange(len(b)), n)
        begin = np.cumsum(n) - n
        k = np.arange(seg.size) - begin[seg]
        t = k * (1.0 / (n - 1))[seg]  # np.linspace(0, 1, n): k * step, the last exactly 1
        t[begin + n - 1] = 1.0
        col, row = _cells_along(grid, a, d[seg, 0], d[seg, 1], t)
        # A segment's samples are monotonic along it: inside the grid if its two ends are.
        ends = np.stack([col[begin], col[begin + n - 1], row[begin], row[begin + n - 1]])
        inside = (ends >= 0).all(axis=0) & (ends[:2] < grid.cols).all(axis=0)
        inside &= (ends[2:] < grid.rows).all(axis=0)
        np.clip(col, 0, grid.cols - 1, out=col)
        np.clip(row, 0, grid.rows - 1, out=row)
        seen = np.logical_and.reduceat(free[row, col], begin) & inside
        hits = np.flatnonzero(seen)
        if len(hits):
            return start + int(hits[-1])
        stop = start
    return None


def region_path_length(
    free: np.ndarray, grid: Grid, distance: np.ndarray, start_xy: Sequence[float], goal_xy: Sequence[float],
    tolerance: float,
) -> float:  # fmt: skip
    """Length (m) of an any-angle path from ``start_xy`` to the goal region along
    :func:`region_distance`'s ``distance``: steepest descent over the cells, pulled taut
    (a vertex dropped wherever the straight leg past it stays on free cells) with each bend
    moved to the corner of its cell that shortens it most, the last leg ending on the disc.
    A path the robot could drive, so never shorter than the geodesic (to the quarter cell
    its legs are checked at); it removes the fast-marching excess at corners. ``inf`` when
    the start's cell cannot reach the region."""
    cell = grid.cell(float(start_xy[0]), float(start_xy[1]))
    if not np.isfinite(distance[cell]):
        return math.inf
    rows, cols = distance.shape
    cells = [cell]
    seen = {cell}
    while distance[cells[-1]] > 0:
        r, c = cells[-1]
        best, nxt = distance[r, c], None
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                q = (r + dr, c + dc)
                if 0 <= q[0] < rows and 0 <= q[1] < cols and q not in seen and distance[q] < best:
                    best, nxt = distance[q], q
        if nxt is None:
            return float(distance[cell])
        cells.append(nxt)
        seen.add(nxt)
    goal = np.asarray(goal_xy[:2], dtype=np.float64)
    pts = [np.asarray(start_xy[:2], dtype=np.float64)] + [np.asarray(grid.centre(q)) for q in cells[1:]]
    if len(pts) == 1:  # the start's cell touches the region: the straight way onto the disc
        return max(0.0, math.dist(pts[0], goal) - tolerance)
    # Pull taut: from each kept vertex, the farthest later point in sight.
    taut, i = [pts[0]], 0
    stack = np.asarray(pts)
    while i < len(pts) - 1:
        j = _farthest_visible(free, grid, stack[i], stack, i + 2)
        j = i + 1 if j is None else j
        taut.append(pts[j])
        i = j
    # Move each bend to the cell corner near it (within REACH cells) that shortens the path
    # most, both legs in sight: the taut path bends at obstacle corners, which are cell corners.
    res, eps = grid.resolution, 1e-6
    for _ in range(4):
        moved = False
        k = 1
        while k < len(taut) - 1:  # drop bends whose neighbours see each other
            if _visible(free, grid, taut[k - 1], taut[k + 1]):
                del taut[k]
                moved = True
            else:
                k += 1
        for k in range(1, len(taut) - 1):
            a, b = taut[k - 1], taut[k + 1]
            now = math.dist(a, taut[k]) + math.dist(taut[k], b)
            cx = grid.x0 + round((taut[k][0] - grid.x0) / res) * res
            cy = grid.y0 + round((taut[k][1] - grid.y0) / res) * res
            steps = np.arange(-_REACH, _REACH + 1) * res
            qs = np.stack(np.meshgrid(cx + steps, cy + steps), axis=-1).reshape(-1, 2)
            lengths = np.hypot(*(qs - a).T) + np.hypot(*(qs - b).T)
            for i in np.argsort(lengths, kind="stable"):
                if lengths[i] >= now - eps:
                    break
                q = _off_corner(free, grid, qs[i], eps)
                if q is not None and _visible(free, grid, a, q) and _visible(free, grid, q, b):
                    taut[k], moved = q, True
                    break
        if not moved:
            break
    length = sum(math.dist(p, q) for p, q in itertools.pairwise(taut[:-1]))
    last = taut[-2]
    ahead = math.dist(last, goal)
    if ahead <= tolerance:
        return length
    entry = last + (goal - last) * (1.0 - tolerance / ahead)
    if _visible(free, grid, last, entry):
        return length + ahead - tolerance
    return length + math.dist(last, taut[-1])


@dataclass(frozen=True, eq=False)
class DistanceField:
    """Geodesic distance (m) to a goal over a grid's free cells, defined at any point: a
    point on a cell that cannot reach the goal (blocked, or in the inflated band) takes the
    distance of the nearest reachable cell plus the straight line to that cell's centre."""

    distance: np.ndarray
    """float64 ``(rows, cols)``: metres to the goal along free cells, ``inf`` where unreachable."""
    grid: Grid

    @classmethod
    def build(
        cls,
        free: np.ndarray,
        grid: Grid,
        goal_xy: Sequence[float],
        *,
        connectivity: int = 16,
        tolerance: float | None = None,
    ) -> DistanceField:
        """The field towards ``goal_xy`` (m): with ``tolerance`` (m), the any-angle distance
        to the disc of that radius around it (:func:`region_distance`); without, or when no
        free cell lies in that disc, the grid distance (``connectivity`` 8 or 16,
        :func:`geodesic_distance`) to the free cell nearest the goal. Raises ValueError when
        ``free`` has no free cell."""
        free = _free_array(free)
        field = None
        if tolerance is not None:
            try:
                field = region_distance(free, grid, goal_xy, tolerance)
            except ValueError:
                field = None
        if field is not None:
            goal = (float(goal_xy[0]), float(goal_xy[1]))
            return cls(field, grid, free, goal, float(tolerance))
        goal = snap_free(free, grid.cell(float(goal_xy[0]), float(goal_xy[1])))
        if goal is None:
            raise ValueError("DistanceField: the grid has no free cell")
        return cls(geodesic_distance(free, goal, grid.resolution, connectivity=connectivity), grid)

    free: np.ndarray | None = None
    """The free cells the field was built on (None when not kept)."""
    goal: tuple[float, float] | None = None
    tolerance: float | None = None
    """Radius (m) of the goal region when the field runs to one (:func:`region_distance`)."""

    @functools.cached_property
    def nearest(self) -> np.ndarray:
        """int ``(2, rows, cols)``: the nearest reachable cell of every cell (itself where
        :attr:`distance` is finite). Computed on first use, by a point off the reachable
        cells: a whole-grid distance transform most episodes never need."""
        _, nearest = scipy.ndimage.distance_transform_edt(~np.isfinite(self.distance), return_indices=True)
        return nearest

    def route(self, x: float, y: float) -> float:
        """Metres from ``(x, y)`` to the goal region along the shortest path: the lesser of
        :meth:`at` and the taut path down the field (:func:`region_path_length`), which
        removes fast marching's excess at corners; :meth:`at` for a grid field."""
        d = self.at(x, y)
        if self.tolerance is None or self.free is None or not math.isfinite(d):
            return d
        r, c = self.grid.cell(float(x), float(y))
        if not math.isfinite(self.distance[r, c]):  # off the reachable cells: not its own nearest
            return d
        return min(
            d, region_path_length(self.free, self.grid, self.distance, (x, y), self.goal, self.tolerance)
        )

    def at(self, x: float, y: float) -> float:
        """Metres from ``(x, y)`` to the goal (see the class docstring)."""
        r, c = self.grid.cell(float(x), float(y))
        d = float(self.distance[r, c])
        if math.isfinite(d):  # a reachable cell is its own nearest
            return d
        rr, cc = int(self.nearest[0, r, c]), int(self.nearest[1, r, c])
        cx, cy = self.grid.centre((rr, cc))
        return float(self.distance[rr, cc] + math.hypot(x - cx, y - cy))


class Planner:
    """A* on the occupancy grid inflated by the robot's radius, line-of-sight shortcuts,
    pure pursuit and reactive avoidance of agents: the navigation baseline.

    Paths are planned on the grid inflated by ``robot_radius + margin`` when that connects
    start and goal by a path at most ``detour`` (a fraction) longer than the one on the grid
    inflated by ``robot_radius`` alone (the extra ``margin`` metres leave room for pure
    pursuit's arcs), else on the latter. :meth:`command` replans from the robot's
    position when it is more than ``replan_distance`` metres off the path, and around the
    agents (as discs) after ``patience`` calls in a row in which avoidance held it still.
    """

    def __init__(
        self,
        occupancy: OccupancyMap,
        robot_radius: float,
        *,
        margin: float = 0.1,
        lookahead: float = 0.5,
        max_speed: float = 1.0,
        max_yaw_rate: float = 1.5,
        horizon: float = 1.5,
        replan_distance: float = 0.5,
        patience: int = 10,
        detour: float = 0.05,
        free: np.ndarray | None = None,
    ) -> None:
        if not (max_speed > 0 and max_yaw_rate > 0 and lookahead > 0 and margin >= 0):
            raise ValueError(
                "Planner: max_speed (m/s), max_yaw_rate (rad/s) and lookahead (m) must be positive and "
                f"margin (m) >= 0, got {max_speed!r}, {max_yaw_rate!r}, {lookahead!r}, {margin!r}"
            )
        self.occupancy = occupancy
        self.grid = occupancy.grid
        self.robot_radius = float(robot_radius)
        self.free = ~occupancy.inflated(robot_radius) if free is None else _free_array(free)
        """Cells a robot of this radius may have its centre on (``free`` when given: the
        same mask computed once by the caller)."""
        if self.free.shape != occupancy.shape:
            raise ValueError(f"Planner: free has shape {self.free.shape}, the map {occupancy.shape}")
        self.margin, self.detour = float(margin), float(detour)
        # The free cells at least `margin` further from anything blocked (including whatever
        # a caller's `free` leaves out beyond the map's own obstacles).
        self.roomy = self.free & ~occupancy.inflated(robot_radius + margin) if margin > 0 else self.free
        if margin > 0 and free is not None:
            self.roomy &= erode(self.free, margin / self.grid.resolution)
        self.lookahead, self.max_speed, self.max_yaw_rate = lookahead, max_speed, max_yaw_rate
        self.horizon, self.replan_distance, self.patience = horizon, replan_distance, patience
        self.path: np.ndarray | None = None
        """The current path ``(K, 2)`` (m), None before :meth:`plan` or when none exists."""
        self.goal: np.ndarray | None = None
        self.replans = 0
        """How many times :meth:`command` planned again."""
        self._held = 0
        self._progress = 0
        self._components: dict[str, np.ndarray] = {}

    def free_at(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Whether points (m, broadcastable arrays) lie on free cells (False off the grid)."""
        g = self.grid
        col = np.floor((np.asarray(xs) - g.x0) / g.resolution)
        row = np.floor((np.asarray(ys) - g.y0) / g.resolution)
        inside = (col >= 0) & (col < g.cols) & (row >= 0) & (row < g.rows)
        out = np.zeros(np.broadcast(col, row).shape, dtype=bool)
        out[inside] = self.free[row[inside].astype(np.int64), col[inside].astype(np.int64)]
        return out

    def _ends(
        self, free: np.ndarray, start_xy: np.ndarray, goal_xy: np.ndarray, cache: str | None = None
    ) -> tuple[Cell, Cell] | None:
        """The free cells nearest start and goal, the goal's among those connected to the
        start's (the connected regions of the planner's own masks are computed once)."""
        start = snap_free(free, self.grid.cell(*start_xy))
        if start is None:
            return None
        if cache is None:
            labels, _ = components(free)
        else:
            if cache not in self._components:
                self._components[cache] = components(free)[0]
            labels = self._components[cache]
        goal = snap_free(free, self.grid.cell(*goal_xy), within=labels == labels[start])
        return None if goal is None else (start, goal)

    def plan(
        self, start_xy: Sequence[float], goal_xy: Sequence[float], *, blocked: np.ndarray | None = None
    ) -> np.ndarray | None:
        """Plan from ``start_xy`` to ``goal_xy`` (m); start and goal snap to the nearest free
        cells (the goal to the nearest one connected to the start). ``blocked`` marks extra
        cells to avoid (bool, the grid's shape). The path ``(K, 2)`` (m) runs from the
        robot's position (its snapped cell's centre when that is not free) through the
        corners to the goal (the goal itself when it is on a free cell); None when no cell
        near the start is free."""
        start, goal = np.asarray(start_xy, dtype=np.float64)[:2], np.asarray(goal_xy, dtype=np.float64)[:2]
        self.goal = goal
        extra = np.zeros(self.free.shape, dtype=bool) if blocked is None else np.asarray(blocked, dtype=bool)
        cache = ("free", "roomy") if blocked is None else (None, None)
        ends = self._ends(self.free & ~extra, start, goal, cache[0])
        if ends is None:
            self.path = None
            return None
        # The roomy grid's path when its ends are those of the tight grid (give or take the
        # margin) and it is at most `detour` longer.
        slack = (self.margin / self.grid.resolution + 1.5) ** 2
        roomy = self._ends(self.roomy & ~extra, start, goal, cache[1])
        tight = self.free & ~extra
        cells = astar(tight, *ends)
        if cells is None:  # not reached: the goal was snapped within the start's component
            self.path = None
            return None
        path = shortcut(tight, cells)
        if roomy is not None and all(
            (a[0] - b[0]) ** 2 + (a[1] - b[1]) ** 2 <= slack for a, b in zip(roomy, ends, strict=True)
        ):
            wide = astar(self.roomy & ~extra, *roomy)
            if wide is not None:  # joined to the tight grid's ends
                wide = shortcut(self.roomy & ~extra, wide)
                head, tail = astar(tight, ends[0], wide[0]), astar(tight, wide[-1], ends[1])
                wide = shortcut(tight, head or [ends[0]])[:-1] + wide + shortcut(tight, tail or [ends[1]])[1:]
                if path_length(wide) <= (1.0 + self.detour) * path_length(path) + 2 * slack**0.5:
                    path = wide
        xy = path_to_world(path, self.grid)
        if self.grid.cell(*goal) == ends[1]:
            xy[-1] = goal
        if self.grid.cell(*start) == ends[0]:
            xy[0] = start
        self.path, self._progress, self._held = xy, 0, 0
        return xy

    def off_path(self, xy: Sequence[float]) -> bool:
        """Whether ``xy`` lies more than ``replan_distance`` m from the planned path (or there
        is none)."""
        if self.path is None:
            return True
        s, cum = _closest_on_path(self.path, np.asarray(xy, dtype=np.float64)[:2])
        return math.hypot(*(_point_at(self.path, cum, s) - np.asarray(xy[:2]))) > self.replan_distance

    def _others_blocked(self, xy: np.ndarray, radius: np.ndarray) -> np.ndarray:
        g = self.grid
        xs, ys = g.xs(), g.ys()
        out = np.zeros(self.free.shape, dtype=bool)
        for (ox, oy), r in zip(xy, radius, strict=True):
            reach = r + self.robot_radius + _AGENT_BERTH
            rows, cols = g.window((ox - reach, oy - reach, ox + reach, oy + reach))
            out[rows, cols] |= np.hypot(xs[cols][None, :] - ox, ys[rows][:, None] - oy) <= reach
        return out

    def command(
        self,
        pose: Sequence[float],
        others_xy: np.ndarray | None = None,
        others_vel: np.ndarray | None = None,
        others_radius: np.ndarray | float = 0.3,
        *,
        max_speed: float | None = None,
        max_yaw_rate: float | None = None,
        horizon: float | None = None,
    ) -> tuple[float, float]:
        """``(v, w)`` (m/s, rad/s) for a unicycle at ``pose = (x, y, yaw)`` (m, m, rad),
        avoiding the agents at ``others_xy`` (``(N, 2)``, m) of ``others_radius`` (m) moving at
        ``others_vel`` (m/s). ``max_speed``, ``max_yaw_rate`` and ``horizon`` override the
        planner's settings for this call. ``(0, 0)`` without a path. Call :meth:`plan` first."""
        vmax = self.max_speed if max_speed is None else max_speed
        wmax = self.max_yaw_rate if max_yaw_rate is None else max_yaw_rate
        horizon = self.horizon if horizon is None else horizon
        if self.goal is None:
            raise ValueError("Planner.command: call plan(start_xy, goal_xy) first")
        xy = np.asarray(pose[:2], dtype=np.float64)
        if self.path is None:
            return 0.0, 0.0
        rest = self.path[self._progress :]
        if len(rest) > 1:
            s, cum = _closest_on_path(rest, xy)
            k = int(np.searchsorted(cum, s, side="right") - 1)
            self._progress += max(0, min(k, len(rest) - 2))
            foot = _point_at(rest, cum, s)
            if math.hypot(*(foot - xy)) > self.replan_distance:
                self.replans += 1
                if self.plan(xy, self.goal) is None:
                    return 0.0, 0.0
        v, w = pure_pursuit(
            pose, self.path[self._progress :], self.lookahead, self.max_speed, self.max_yaw_rate
        )
        if others_xy is None or len(others_xy) == 0:
            return v, w
        others = np.asarray(others_xy, dtype=np.float64).reshape(-1, 2)
        vel = np.zeros_like(others) if others_vel is None else np.asarray(others_vel, dtype=np.float64)
        radius = np.broadcast_to(np.asarray(others_radius, dtype=np.float64), (len(others),))
        v2, w2 = avoid(
            pose, v, w, others, vel, radius, self.robot_radius, horizon,
            max_speed=vmax, max_yaw_rate=wmax, free_at=self.free_at,
        )  # fmt: skip
        self._held = self._held + 1 if v > 0.05 and v2 < 0.05 else 0
        if self._held >= self.patience:  # around the agents, unless they close the way: then wait
            self.replans += 1
            kept = (self.path, self._progress)
            around = self.plan(xy, self.goal, blocked=self._others_blocked(others, radius))
            if around is None or math.hypot(*(around[-1] - kept[0][-1])) > self.grid.resolution * 1.5:
                self.path, self._progress = kept
            self._held = 0
        return v2, w2
