"""The noise of rough tiles: value noise from an integer hash, the same on every machine.

A rough tile's deviation from its height is ``amplitude * noise(u, v) * taper(u, v)``
(:mod:`citygen.geometry.terrain` gives the rule): value noise on a square lattice of
spacing ``scale / 2`` whose node values are uniform in ``[-1, 1)``, drawn from a SplitMix64
hash of ``(seed, i, j)`` (integer arithmetic only), blended with the quintic fade
``6t^5 - 15t^4 + 10t^3``; the taper is that fade over a border band of width
``min(scale, tile_size / 4)``.
"""

from __future__ import annotations

import numpy as np

#: Largest slope of the fade curve ``6t^5 - 15t^4 + 10t^3`` on [0, 1] (at t = 1/2).
FADE_MAX_SLOPE = 1.875


def mix64(z: np.ndarray) -> np.ndarray:
    """SplitMix64's output function (Steele et al. 2014) on uint64 arrays, wrapping."""
    z = z + np.uint64(0x9E3779B97F4A7C15)
    z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
    z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
    return z ^ (z >> np.uint64(31))


def noise_key(seed: int | np.ndarray) -> np.ndarray:
    """The 64-bit key of a rough tile's noise: ``mix64(seed)``."""
    return mix64(np.atleast_1d(np.asarray(seed, dtype=np.uint64)))


def node(column: np.ndarray, j: np.ndarray) -> np.ndarray:
    """Node values in [-1, 1) of the lattice: ``mix64(mix64(key ^ i) ^ j)``, top 53 bits as a
    fraction, from the inner hash ``column = mix64(key ^ i)``, which the nodes of one lattice
    column share (so the corners of a cell need two inner hashes, not four)."""
    h = mix64(column ^ j)
    return (h >> np.uint64(11)).astype(np.float64) * (2.0 / 2.0**53) - 1.0


def _fade(t: np.ndarray) -> np.ndarray:
    return t * t * t * (t * (t * 6.0 - 15.0) + 10.0)


def _ramp(t: np.ndarray) -> np.ndarray:
    return _fade(np.clip(t, 0.0, 1.0))


def rough_noise(key: np.ndarray, scale: np.ndarray, s: float, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Tapered value noise in [-1, 1] at local coordinates ``u, v`` (m) of tiles of side ``s``."""
    spacing = scale / 2.0
    gx, gy = u / spacing, v / spacing
    fx0, fy0 = np.floor(gx), np.floor(gy)
    fx, fy = _fade(gx - fx0), _fade(gy - fy0)
    i, j = fx0.astype(np.uint64), fy0.astype(np.uint64)
    one = np.uint64(1)
    west, east, north = mix64(key ^ i), mix64(key ^ (i + one)), j + one
    a, b = node(west, j), node(east, j)
    c, d = node(west, north), node(east, north)
    n = (a * (1.0 - fx) + b * fx) * (1.0 - fy) + (c * (1.0 - fx) + d * fx) * fy
    w = np.minimum(scale, s / 4.0)
    return n * (_ramp(u / w) * _ramp((s - u) / w) * _ramp(v / w) * _ramp((s - v) / w))


def rough_noise_grid(key: np.uint64, scale: float, s: float, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """:func:`rough_noise` of one tile on the grid ``u[None, :], v[:, None]`` (1-d arrays of local
    coordinates in ``[0, s]``, m), bit for bit: every factor that depends on one axis is
    computed once along it, the lattice hashed once per node and interpolated along x once
    per lattice row (``a * (1 - fx) + b * fx`` depends on a sample's row only through its
    lattice row), then the same products are formed in the same order."""
    kx = u.size
    spacing = scale / 2.0
    g = np.concatenate([u, v]) / spacing
    g0 = np.floor(g)
    f = _fade(g - g0)
    fx, fy = f[None, :kx], f[kx:, None]
    idx = g0.astype(np.uint64)
    i, j = idx[:kx], idx[kx:]
    i0, j0 = i.min(), j.min()
    ri, rj = (i - i0).astype(np.intp), (j - j0).astype(np.intp)
    span_i, span_j = int(ri.max()) + 2, int(rj.max()) + 2
    if span_i * span_j > 4 * u.size * v.size + 256:  # a grid much coarser than the lattice
        return rough_noise(key, np.float64(scale), s, u[None, :], v[:, None])
    nodes_i = i0 + np.arange(span_i, dtype=np.uint64)
    nodes_j = j0 + np.arange(span_j, dtype=np.uint64)
    # Node values of the lattice around the grid: rows along j, columns along i.
    table = node(mix64(key ^ nodes_i)[None, :], nodes_j[:, None])
    along_x = table[:, ri] * (1.0 - fx) + table[:, ri + 1] * fx  # [lattice row, sample column]
    n = along_x[rj] * (1.0 - fy) + along_x[rj + 1] * fy
    w = min(scale, s / 4.0)
    r = _ramp(np.concatenate([u / w, (s - u) / w, v / w, (s - v) / w]))
    ky = v.size
    ramp_u = r[:kx] * r[kx : 2 * kx]
    rv1, rv2 = r[2 * kx : 2 * kx + ky], r[2 * kx + ky :]
    return n * ((ramp_u[None, :] * rv1[:, None]) * rv2[:, None])
