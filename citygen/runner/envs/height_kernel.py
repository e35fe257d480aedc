"""The height map's ground heights compiled with numba: the grid of points around a pose and
their bilinear interpolation in the scene's 5 cm ground raster, in one call; and, on a scene
whose map is coarser (a locomotion training grid), the terrain's own heights where the points
lie on flat, slope, stair or rough tiles.

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


_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)


@njit(cache=True, inline="always")
def _mix64(z):
    """:func:`citygen.geometry.noise.mix64` of one uint64 (wrapping)."""
    z = z + _GOLDEN
    z = (z ^ (z >> np.uint64(30))) * _MIX1
    z = (z ^ (z >> np.uint64(27))) * _MIX2
    return z ^ (z >> np.uint64(31))


@njit(cache=True, inline="always")
def _node(column, j):
    """:func:`citygen.geometry.noise.node` of one lattice node."""
    return np.float64(_mix64(column ^ j) >> np.uint64(11)) * (2.0 / 2.0**53) - 1.0


@njit(cache=True, inline="always")
def _fade(t):
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


@njit(cache=True, inline="always")
def _ramp(t):
    return _fade(min(max(t, 0.0), 1.0))


@njit(cache=True, inline="always")
def _rough_noise(key, scale, s, u, v):
    """:func:`citygen.geometry.noise.rough_noise` at one point, operation for operation."""
    spacing = scale / 2.0
    gx, gy = u / spacing, v / spacing
    fx0, fy0 = math.floor(gx), math.floor(gy)
    fx, fy = _fade(gx - fx0), _fade(gy - fy0)
    i, j = np.uint64(fx0), np.uint64(fy0)
    one = np.uint64(1)
    west, east, north = _mix64(key ^ i), _mix64(key ^ (i + one)), j + one
    a, b = _node(west, j), _node(east, j)
    c, d = _node(west, north), _node(east, north)
    n = (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy
    w = min(scale, s / 4.0)
    return n * (_ramp(u / w) * _ramp((s - u) / w) * _ramp(v / w) * _ramp((s - v) / w))


@njit(cache=True)
def tiles_around(
    kind, height, a, steps, ascent, sign, scale, key, codes, size, ox, oy, rows, cols, u, v, x, y, cs, sn
):  # fmt: skip
    """:func:`citygen.geometry.terrain.height_at` at the same points as :func:`ground_around`
    on a terrain without features: ``(heights, True)``, the same floats as ``height_at``'s (a
    tile's height plus its relief inside the grid, 0 outside, NaN at a NaN coordinate);
    ``(_, False)`` when a point lies on a kind of tile the kernel does not know (then ask
    ``height_at``).

    ``kind`` ... ``key``: the terrain's :class:`~citygen.geometry.tiles.HeightTable` columns
    (``kind``, ``h``, ``a``, ``n``, ``asc``, ``sign``, ``scale``, ``key``), tile by tile, row
    by row; ``codes``: the flat, slope, stair and rough tiles' kind codes; tiles of ``size``
    m from ``(ox, oy)``. The arithmetic is :func:`~citygen.geometry.tiles.evaluate`'s
    (``_flight_frame``, ``_slope_relief``, ``_stair_relief``, ``_rough_relief``), operation
    for operation."""
    flat_code, slope_code, stair_code, rough_code = codes[0], codes[1], codes[2], codes[3]
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
        if code != slope_code and code != stair_code and code != rough_code:
            return out, False
        tu = min(max(px - ox - col * size, 0.0), size)
        tv = min(max(py - oy - row * size, 0.0), size)
        if code == rough_code:
            out[k] = height[t] + a[t] * _rough_noise(key[t], scale[t], size, tu, tv)
            continue
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
