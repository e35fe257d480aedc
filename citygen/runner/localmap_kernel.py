"""The local map's gather compiled with numba: for every output cell, its 2 x 2 sub-samples'
flat indices in the pooled static layers, the highest elevation among them (relative to the
ground) and whether all of them are walkable (and crossable), in one pass.

The plain-numpy reference is :meth:`citygen.runner.localmap.LocalMap.__call__` with
``reference=True``: index arrays of all 4 x H x W sub-samples, four gathers and their
reductions, some fifteen numpy calls a step. The kernel runs the same float operations in
the same order (no fused multiply-adds: numba's default), so its indices, and therefore its
maps, are the reference's to the bit (``tests/test_localmap.py``). ``cache=True``: compiled
once, loaded from ``__pycache__`` afterwards.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def gather(elevation, walkable, crossable, su, sv, ci, si, ox, oy, ground):
    """``(elev, walk, cross)`` over the ``n = len(su) // 4`` output cells: ``su``, ``sv`` the
    sub-samples' offsets (m, the robot's frame; 4 blocks of n), ``ci = cos(yaw) / cell``,
    ``si = sin(yaw) / cell``, ``(ox, oy)`` the robot's position in cells from the layers'
    origin, ``ground`` (float32) the height the elevations are relative to; ``crossable`` an
    array of ``walkable``'s shape, or of size 0 (``cross`` is then all False)."""
    rows, cols = elevation.shape
    last = rows * cols - 1
    n = su.size // 4
    flat_e = elevation.ravel()
    flat_w = walkable.ravel()
    has_cross = crossable.size > 0
    flat_c = crossable.ravel()
    elev = np.empty(n, dtype=np.float32)
    walk = np.empty(n, dtype=np.bool_)
    cross = np.zeros(n, dtype=np.bool_)
    for k in range(n):
        e = np.float32(0.0)
        w = True
        c = has_cross
        for b in range(4):
            i = b * n + k
            col = su[i] * ci
            col += ox
            col -= sv[i] * si
            row = su[i] * si
            row += oy
            row += sv[i] * ci
            f = int(row) * cols + int(col)
            f = min(max(f, 0), last)  # np.take(mode="clip")
            v = flat_e[f]
            e = v if b == 0 or v > e else e
            w = w and flat_w[f]
            if has_cross:
                c = c and flat_c[f]
        elev[k] = e - ground
        walk[k] = w
        cross[k] = c
    return elev, walk, cross
