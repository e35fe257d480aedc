"""Search on an occupancy grid: A*, the free cell nearest a cell, line of sight between cells
and line-of-sight shortcuts of a cell path, cell paths in world coordinates.

Grids are boolean ``free`` arrays indexed ``(row, col)`` with rows along +y, as in
:mod:`citygen.exporters.occupancy` (``free = ~occupancy_map.inflated(robot_radius)``: a
robot of that radius keeps its centre on free cells). Paths move between the 8 neighbours
of a cell; a diagonal step needs both cells beside it free (no corner cutting). Lengths on
the grid are in cells; world lengths in metres.

>>> free = np.ones((3, 4), dtype=bool)
>>> free[1, 1:3] = False  # a diagonal step needs both cells beside it free
>>> astar(free, (1, 0), (1, 3))
[(1, 0), (0, 0), (0, 1), (0, 2), (0, 3), (1, 3)]
>>> astar(free, (0, 0), (0, 0))
[(0, 0)]
"""

from __future__ import annotations

import heapq
import math
from collections.abc import Sequence

import numpy as np
import scipy.ndimage

from citygen.exporters.occupancy import OccupancyMap
from citygen.geometry.raster import Grid

Cell = tuple[int, int]

_SQRT2 = math.sqrt(2.0)


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
