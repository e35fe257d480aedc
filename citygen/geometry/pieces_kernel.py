"""A rough tile's cells (:func:`citygen.geometry.pieces._rough_cells`) compiled with numba.

The split-and-fit loop visits tens of thousands of small cells a tile (a 0.2 m-amplitude tile
of the Urban-Loc test grid at 1 cm: about 5,000 cells and 17,000 plane fits), each a handful
of numpy calls on a few dozen samples: numpy's cost per call, not the arithmetic, made a
16-tile rough grid's URDF take 19 s. Here the same fits and splits are loops compiled once
(``cache=True``: later processes load them from ``__pycache__``). The numpy form in
:mod:`citygen.geometry.pieces` stays the reference: ``tests/test_pieces_kernel.py`` holds the
two to the same cells and to float precision in their planes.
"""

from __future__ import annotations

import numpy as np
from numba import njit

#: How much better (m) cutting a square cell across ``j`` must fit than across ``i`` to be
#: chosen, here and in the reference: the two cuts of a symmetric patch tie, and a tie decided
#: by the last bit of two sums would differ between the two, which sum in another order.
TIE = 1e-12


@njit(cache=True)
def _fit(g, z, i0, j0, ni, nj):
    """The reference's ``_fit``: ``(c, a, b, err)`` of the cell's plane about its centre."""
    uc = (g[j0] + g[j0 + nj]) / 2
    vc = (g[i0] + g[i0 + ni]) / 2
    su = 0.0
    for j in range(nj + 1):
        su += (g[j0 + j] - uc) ** 2
    sv = 0.0
    for i in range(ni + 1):
        sv += (g[i0 + i] - vc) ** 2
    szu = 0.0
    szv = 0.0
    for i in range(ni + 1):
        v = g[i0 + i] - vc
        for j in range(nj + 1):
            zz = z[i0 + i, j0 + j]
            szu += zz * (g[j0 + j] - uc)
            szv += zz * v
    a = szu / ((ni + 1) * su)
    b = szv / ((nj + 1) * sv)
    hi = -np.inf
    lo = np.inf
    for i in range(ni + 1):
        v = g[i0 + i] - vc
        for j in range(nj + 1):
            r = z[i0 + i, j0 + j] - a * (g[j0 + j] - uc) - b * v
            hi = max(hi, r)
            lo = min(lo, r)
    return (hi + lo) / 2, a, b, (hi - lo) / 2


@njit(cache=True)
def _worst(g, z, i0, j0, ni, nj, i1, j1, mi, mj):
    return max(_fit(g, z, i0, j0, ni, nj)[3], _fit(g, z, i1, j1, mi, mj)[3])


@njit(cache=True)
def rough_cells(g, z, tolerance):
    """The cells of the reference's split loop over samples ``z`` at ``g`` (one row a cell):
    ``(i0, j0, ni, nj)`` as int64 and ``(c, a, b, err)`` as float64, in the loop's order."""
    n = len(g) - 1
    stack = np.empty((4 * n * n + 8, 4), dtype=np.int64)
    stack[0] = (0, 0, n, n)
    top = 1
    index = np.empty((n * n, 4), dtype=np.int64)
    plane = np.empty((n * n, 4), dtype=np.float64)
    count = 0
    while top > 0:
        top -= 1
        i0, j0, ni, nj = stack[top, 0], stack[top, 1], stack[top, 2], stack[top, 3]
        c, a, b, err = _fit(g, z, i0, j0, ni, nj)
        if err <= tolerance or (ni == 1 and nj == 1):
            index[count] = (i0, j0, ni, nj)
            plane[count] = (c, a, b, err)
            count += 1
            continue
        rows = ni >= nj and ni > 1  # cut across i (the reference's first option)
        if ni >= nj and ni > 1 and nj >= ni and nj > 1:  # a square: the cut that fits better
            h = ni // 2
            k = nj // 2
            across_i = _worst(g, z, i0, j0, h, nj, i0 + h, j0, ni - h, nj)
            across_j = _worst(g, z, i0, j0, ni, k, i0, j0 + k, ni, nj - k)
            rows = not across_j < across_i - TIE
        if rows:
            h = ni // 2
            stack[top] = (i0, j0, h, nj)
            stack[top + 1] = (i0 + h, j0, ni - h, nj)
        else:
            h = nj // 2
            stack[top] = (i0, j0, ni, h)
            stack[top + 1] = (i0, j0 + h, ni, nj - h)
        top += 2
    return index[:count], plane[:count]
