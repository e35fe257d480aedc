"""The goal *region* (the disc around the goal where success is declared) as SPL's
``L*_best`` needs it: the any-angle geodesic distance of every free cell to it
(:func:`region_distance`, fast marching) and the length of a taut path down that distance
(:func:`region_path_length`), with the line-of-sight tests both use.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np

from citygen.geometry.raster import Grid, components
from citygen.runner.control.grid import _free_array


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
    tolerance: float, *, reference: bool = False,
) -> float:  # fmt: skip
    """Length (m) of an any-angle path from ``start_xy`` to the goal region along
    :func:`region_distance`'s ``distance``: steepest descent over the cells, pulled taut
    (a vertex dropped wherever the straight leg past it stays on free cells) with each bend
    moved to the corner of its cell that shortens it most, the last leg ending on the disc.
    A path the robot could drive, so never shorter than the geodesic (to the quarter cell
    its legs are checked at); it removes the fast-marching excess at corners. ``inf`` when
    the start's cell cannot reach the region. ``reference``: the plain form below instead of
    its compiled twin (:mod:`citygen.runner.control.regions_kernel`, the same steps)."""
    cell = grid.cell(float(start_xy[0]), float(start_xy[1]))
    if not np.isfinite(distance[cell]):
        return math.inf
    if not reference:
        from citygen.runner.control import regions_kernel

        free_ = np.ascontiguousarray(free, dtype=np.bool_)
        dist_ = np.ascontiguousarray(distance, dtype=np.float64)
        x0, y0, res = float(grid.x0), float(grid.y0), float(grid.resolution)
        start, goal = (float(start_xy[0]), float(start_xy[1])), (float(goal_xy[0]), float(goal_xy[1]))
        length = regions_kernel.path_length(
            free_, x0, y0, res, dist_, cell[0], cell[1], *start, *goal, float(tolerance), _REACH
        )
        return float(length)
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
