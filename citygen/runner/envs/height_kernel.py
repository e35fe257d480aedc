"""The height map's ground heights compiled with numba: the grid of points around a pose and
their bilinear interpolation in the scene's 5 cm ground raster, in one call; and, on a scene
whose map is coarser (a locomotion training grid), the terrain's own heights where the points
lie on flat, slope or stair tiles.

The plain-numpy reference is what :meth:`citygen.runner.scenes.Prepared.ground` does with the
points :meth:`~citygen.runner.envs.sensors.Sensors._terrain_around` lays out
(:meth:`citygen.geometry.raster.Grid.bilinear`): the kernel runs the same float operations in
the same order, so its heights are the reference's to the bit (``tests/test_loco_fast.py``;
on a coarse map's tiles the reference is :func:`citygen.geometry.terrain.height_at`);
where the numpy form pays for some twenty calls on 187 points every control step, this is one
(``cache=True``: compiled once, loaded from ``__pycache__`` afterwards).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit


@njit(cache=True, inline="always")
def _point(k, n, u, v, x, y, cs, sn):
    """Point ``k`` of the grid ``(u, v)`` (m, the robot's frame) around ``(x, y)`` turned by
    ``(cs, sn)``, and ``(x, y)`` itself for ``k == n``."""
    if k < n:
        return x + cs * u[k] - sn * v[k], y + sn * u[k] + cs * v[k]
    return x, y


@njit(cache=True)
def ground_around(flat, rows, cols, x0, y0, inv, u, v, x, y, cs, sn):
    """Ground heights (m) at the points ``(x + cs u - sn v, y + sn u + cs v)`` for the grid
    ``(u, v)`` (m, the robot's frame) and, last, at ``(x, y)``: ``(len(u) + 1,)``, from the
    raster ``flat`` (``rows * cols`` cell-centre heights, row-major) of the grid with origin
    ``(x0, y0)`` and ``inv`` = 1 / resolution (1/m), bilinear as ``Grid.bilinear``."""
    n = u.size
    out = np.empty(n + 1)
    off_x, off_y = x0 * inv + 0.5, y0 * inv + 0.5
    max_x, max_y = max(cols - 1 - 1e-9, 0.0), max(rows - 1 - 1e-9, 0.0)
    dx = 1 if cols > 1 else 0
    dy = cols if rows > 1 else 0
    for k in range(n + 1):
        px, py = _point(k, n, u, v, x, y, cs, sn)
        fx = min(max(px * inv - off_x, 0.0), max_x)
        fy = min(max(py * inv - off_y, 0.0), max_y)
        ix, iy = int(fx), int(fy)
        fx -= ix
        fy -= iy
        i = iy * cols + ix
        a = flat[i]
        top = (flat[i + dx] - a) * fx + a
        b = flat[i + dy]
        bottom = (flat[i + dy + dx] - b) * fx + b
        out[k] = (bottom - top) * fy + top
    return out


@njit(cache=True)
def tiles_around(kind, height, a, steps, ascent, sign, codes, size, ox, oy, rows, cols, u, v, x, y, cs, sn):
    """:func:`citygen.geometry.terrain.height_at` at the same points as :func:`ground_around`
    on a terrain without features, where every point inside the grid lies on a flat, slope or
    stair tile: ``(heights, True)``, the same floats as ``height_at``'s (a tile's height plus
    its relief inside the grid, 0 outside, NaN at a NaN coordinate); ``(_, False)`` when a
    point lies on another kind of tile (a rough one: then ask ``height_at``).

    ``kind`` ... ``sign``: the terrain's :class:`~citygen.geometry.tiles.HeightTable` columns
    (``kind``, ``h``, ``a``, ``n``, ``asc``, ``sign``), tile by tile, row by row; ``codes``:
    the flat, slope and stair tiles' kind codes; tiles of ``size`` m from ``(ox, oy)``. The
    arithmetic is :func:`~citygen.geometry.tiles.evaluate`'s (``_flight_frame``,
    ``_slope_relief``, ``_stair_relief``), operation for operation."""
    flat_code, slope_code, stair_code = codes[0], codes[1], codes[2]
    n = u.size
    out = np.zeros(n + 1)
    for k in range(n + 1):
        px, py = _point(k, n, u, v, x, y, cs, sn)
        if math.isnan(px) or math.isnan(py):
            out[k] = math.nan
            continue
        gx, gy = (px - ox) / size, (py - oy) / size
        if not (gx >= 0 and gx <= cols and gy >= 0 and gy <= rows):
            continue
        col = min(math.floor(gx), cols - 1)
        row = min(math.floor(gy), rows - 1)
        t = int(row) * cols + int(col)
        code = kind[t]
        if code == flat_code:
            out[k] = height[t]
            continue
        if code != slope_code and code != stair_code:
            return out, False
        tu = min(max(px - ox - col * size, 0.0), size)
        tv = min(max(py - oy - row * size, 0.0), size)
        along = tv if ascent[t] & 2 else tu
        low = size - along if ascent[t] & 1 else along
        edge = min(min(tu, tv), min(size - tu, size - tv))
        flight = sign[t] == 0
        factor = 1.0 if flight else sign[t]
        if code == stair_code:
            m = steps[t]
            treads = low * (m + 1) / size if flight else edge * (2 * m + 2) / size
            run = min(math.floor(treads + 1e-9), float(m))
        else:
            run = low if flight else min(edge, size / 3.0)
        out[k] = height[t] + factor * a[t] * run
    return out, True
