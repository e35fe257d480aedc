"""The taut path's length (:func:`citygen.runner.control.regions.region_path_length`)
compiled with numba: the steepest descent over the cells, pulling it taut, moving its bends
to obstacle corners and the last leg onto the goal's disc, in one call.

A navigation episode that ends short of its goal asks for it once (route completion's
``L*`` from where the robot stopped): in the plain form that is a Python loop over a few
hundred cells and some hundred line-of-sight tests, 5-9 ms, which in a vector environment
stalls every sub-environment stepping in lockstep with it. The plain form stays the
reference (``region_path_length(..., reference=True)``); the kernel runs the same steps, the
same samples along each segment (``linspace`` reproduced) and the same candidate order
(lengths sorted stably), so ``tests/test_regions_kernel.py`` holds the two to 1e-9 m on
every start it tries. ``cache=True``: compiled once, loaded from ``__pycache__`` afterwards.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True)
def _visible(free, x0, y0, res, ax, ay, bx, by):
    """Whether the segment ``a``-``b`` (m) stays on free cells, sampled every quarter cell
    (``regions._visible``)."""
    rows, cols = free.shape
    dx, dy = bx - ax, by - ay
    n = max(2, math.ceil(math.hypot(dx, dy) / (res / 4)) + 1)
    step = 1.0 / (n - 1)
    for k in range(n):
        t = 1.0 if k == n - 1 else k * step
        col = math.floor((ax + t * dx - x0) / res)
        row = math.floor((ay + t * dy - y0) / res)
        if col < 0 or row < 0 or col >= cols or row >= rows or not free[row, col]:
            return False
    return True


@njit(cache=True)
def _off_corner(free, x0, y0, res, qx, qy, eps):
    """``regions._off_corner``: ``(ok, x, y)``, ``ok`` False where two or more of the four
    cells meeting at the corner are blocked."""
    rows, cols = free.shape
    c = round((qx - x0) / res)
    r = round((qy - y0) / res)
    count, sx, sy = 0, 0.0, 0.0
    for dr in (-1, 0):
        for dc in (-1, 0):
            rr, cc = r + dr, c + dc
            if not (0 <= rr < rows and 0 <= cc < cols and free[rr, cc]):
                count += 1
                sx, sy = dc + 0.5, dr + 0.5
    if count == 0:
        return True, qx, qy
    if count > 1:
        return False, qx, qy
    return True, qx - eps * np.sign(sx), qy - eps * np.sign(sy)


@njit(cache=True)
def path_length(free, x0, y0, res, distance, r0, c0, sx, sy, gx, gy, tolerance, reach):
    """:func:`~citygen.runner.control.regions.region_path_length` from the start ``(sx, sy)``
    (m) in cell ``(r0, c0)``, whose distance is finite, to the disc of radius ``tolerance``
    around ``(gx, gy)``; ``reach``: cells searched round a bend (``regions._REACH``)."""
    rows, cols = distance.shape
    # Steepest descent: from each cell the lowest unseen neighbour (the first in scan order).
    seen = np.zeros((rows, cols), dtype=np.bool_)
    cap = 64
    path = np.empty((cap, 2), dtype=np.int64)
    path[0, 0], path[0, 1] = r0, c0
    n = 1
    seen[r0, c0] = True
    while distance[path[n - 1, 0], path[n - 1, 1]] > 0:
        r, c = path[n - 1, 0], path[n - 1, 1]
        best, nr, nc = distance[r, c], -1, -1
        for dr in (-1, 0, 1):
            for dc in (-1, 0, 1):
                qr, qc = r + dr, c + dc
                if 0 <= qr < rows and 0 <= qc < cols and not seen[qr, qc] and distance[qr, qc] < best:
                    best, nr, nc = distance[qr, qc], qr, qc
        if nr < 0:
            return distance[r0, c0]
        if n == cap:
            cap *= 2
            grown = np.empty((cap, 2), dtype=np.int64)
            grown[:n] = path[:n]
            path = grown
        path[n, 0], path[n, 1] = nr, nc
        seen[nr, nc] = True
        n += 1
    if n == 1:  # the start's cell touches the region: the straight way onto the disc
        return max(0.0, math.hypot(sx - gx, sy - gy) - tolerance)
    px = np.empty(n)
    py = np.empty(n)
    px[0], py[0] = sx, sy
    for i in range(1, n):  # cell centres, as Grid.centre
        px[i] = x0 + (path[i, 1] + 0.5) * res
        py[i] = y0 + (path[i, 0] + 0.5) * res
    # Pull taut: from each kept vertex, the farthest later point in sight.
    tx = np.empty(n)
    ty = np.empty(n)
    tx[0], ty[0] = px[0], py[0]
    m, i = 1, 0
    while i < n - 1:
        j = i + 1
        for k in range(n - 1, i + 1, -1):
            if _visible(free, x0, y0, res, px[i], py[i], px[k], py[k]):
                j = k
                break
        tx[m], ty[m] = px[j], py[j]
        m += 1
        i = j
    # Move each bend to the cell corner near it that shortens the path most, both legs in sight.
    eps = 1e-6
    side = 2 * reach + 1
    steps = np.empty(side)
    for s in range(side):
        steps[s] = (s - reach) * res
    cand_x = np.empty(side * side)
    cand_y = np.empty(side * side)
    lengths = np.empty(side * side)
    for _ in range(4):
        moved = False
        k = 1
        while k < m - 1:  # drop bends whose neighbours see each other
            if _visible(free, x0, y0, res, tx[k - 1], ty[k - 1], tx[k + 1], ty[k + 1]):
                for q in range(k, m - 1):
                    tx[q], ty[q] = tx[q + 1], ty[q + 1]
                m -= 1
                moved = True
            else:
                k += 1
        for k in range(1, m - 1):
            ax, ay, bx, by = tx[k - 1], ty[k - 1], tx[k + 1], ty[k + 1]
            now = math.hypot(ax - tx[k], ay - ty[k]) + math.hypot(tx[k] - bx, ty[k] - by)
            cx = x0 + round((tx[k] - x0) / res) * res
            cy = y0 + round((ty[k] - y0) / res) * res
            for a in range(side):  # meshgrid(cx + steps, cy + steps): rows of y, columns of x
                for b in range(side):
                    cand_x[a * side + b] = cx + steps[b]
                    cand_y[a * side + b] = cy + steps[a]
            for q in range(side * side):
                lengths[q] = math.hypot(cand_x[q] - ax, cand_y[q] - ay) + math.hypot(
                    cand_x[q] - bx, cand_y[q] - by
                )
            for q in np.argsort(lengths, kind="mergesort"):
                if lengths[q] >= now - eps:
                    break
                ok, qx, qy = _off_corner(free, x0, y0, res, cand_x[q], cand_y[q], eps)
                if (
                    ok
                    and _visible(free, x0, y0, res, ax, ay, qx, qy)
                    and _visible(free, x0, y0, res, qx, qy, bx, by)
                ):
                    tx[k], ty[k] = qx, qy
                    moved = True
                    break
        if not moved:
            break
    length = 0.0
    for k in range(m - 2):
        length += math.hypot(tx[k + 1] - tx[k], ty[k + 1] - ty[k])
    lx, ly = tx[m - 2], ty[m - 2]
    ahead = math.hypot(lx - gx, ly - gy)
    if ahead <= tolerance:
        return length
    f = 1.0 - tolerance / ahead
    ex, ey = lx + (gx - lx) * f, ly + (gy - ly) * f
    if _visible(free, x0, y0, res, lx, ly, ex, ey):
        return length + ahead - tolerance
    return length + math.hypot(lx - tx[m - 1], ly - ty[m - 1])
