"""Level of detail: how finely each format samples the terrain, chosen from the scene.

Every consumer has limits: MuJoCo's heightfields cost memory and compile time per sample,
PyBullet and browsers per triangle, an occupancy map per cell. An exporter asked for no
resolution (``None``, the default) keeps its usual one where the scene fits the format's
budget (:data:`BUDGETS`) and otherwise picks the finest uniform spacing that fits, saying
so in one :class:`~citygen.exporters.ExportWarning` that also gives the largest error of the
sampled ground against :func:`~citygen.geometry.terrain.height_at` at that spacing. An
explicit resolution is honoured up to the format's hard limit, beyond which it is an
:class:`~citygen.errors.ExportError` naming the finest resolution that fits.

The budgets scale with the scene's counts (rough and slope tiles, cells), never with a
named split, so a denser city gets a coarser sampling, not a failure.

>>> from citygen.exporters import lod
>>> lod.cells_within(budget=10_000, tiles=100, cost=lambda c: (c + 1) ** 2)
9
"""

from __future__ import annotations

import math
from collections.abc import Callable
from types import MappingProxyType

import numpy as np

from citygen.geometry.terrain import tile_grid
from citygen.spec.scene import Scene
from citygen.spec.terrain import RoughTile, SlopeTile

#: What an automatic level of detail keeps each format under: heightfield samples (MJCF),
#: terrain triangles (URDF, GLB, HTML). Chosen so that the consumer loads a 1.2 km city in
#: seconds and a file stays in the tens of megabytes.
BUDGETS = MappingProxyType(
    {
        "mjcf": 4_000_000,  # samples: about 24 MB of XML, 16 MB in the compiled model
        "urdf": 2_000_000,  # triangles: PyBullet builds a BVH of every concave mesh
        "glb": 4_000_000,  # triangles: about 100 MB of GLB, what trimesh and browsers open
        "html": 2_000_000,  # triangles, inlined as base64 into one page
    }
)
#: Terrain triangles a format cut into tiles (:mod:`citygen.exporters.tiles`) holds in all its
#: files together, each file staying within :data:`BUDGETS`: about 400 MB of URDF meshes.
TILED_BUDGETS = MappingProxyType({"urdf": 8_000_000})
#: The error model :func:`allocate` uses: a rough tile of amplitude ``A`` whose noise lattice
#: (spacing ``scale / 2``) is sampled every ``h`` metres is off by about
#: ``A * min(SATURATION, CURVATURE * (2 h / scale) ** 2)`` (fitted, slightly above, to
#: :func:`max_error` on urban-tra-city's rough tiles).
CURVATURE, SATURATION = 2.6, 1.85
#: Fewest cells along a rough tile's side :func:`allocate` gives.
MIN_CELLS = 4
#: Most terrain tiles :func:`max_error` samples to measure the error (evenly spread), and
#: points along a cell's side it measures at.
ERROR_TILES, ERROR_POINTS = 200, 4


def cells_within(budget: int, tiles: int, cost: Callable[[int], int]) -> int:
    """The most cells ``c`` along a tile's side (at least 1) such that ``tiles * cost(c)``
    stays within ``budget``."""
    if tiles <= 0:
        return 1 << 20
    lo, hi = 1, 1
    while tiles * cost(hi * 2) <= budget and hi < 1 << 20:
        hi *= 2
    hi *= 2
    while hi - lo > 1:  # cost(lo) fits (or lo == 1), cost(hi) does not
        mid = (lo + hi) // 2
        lo, hi = (mid, hi) if tiles * cost(mid) <= budget else (lo, mid)
    return lo


def allocate(
    amplitude: np.ndarray, scale: np.ndarray, tile_size: float, budget: int, most: np.ndarray
) -> np.ndarray:
    """Cells along each rough tile's side (``amplitude``, ``scale``: per tile, m), at most
    ``most`` each and :data:`MIN_CELLS` at least, such that their meshes hold at most
    ``budget`` triangles (``2 c**2 + 12 c`` a tile) and the largest expected error (the
    model of :data:`CURVATURE`) is as small as that allows: rougher tiles get finer cells.

    >>> allocate(np.array([0.1, 0.01]), np.array([0.5, 0.5]), 10.0, 20_000, np.array([256, 256])).tolist()
    [96, 4]
    """
    a, scale, most = np.asarray(amplitude, float), np.asarray(scale, float), np.asarray(most, np.int64)
    if not a.size:
        return np.zeros(0, dtype=np.int64)

    def cells(error: float) -> np.ndarray:
        ratio = error / np.maximum(a, 1e-12)
        h = np.sqrt(np.clip(ratio, 1e-12, None) / CURVATURE) * scale / 2.0
        c = np.where(ratio >= SATURATION, MIN_CELLS, np.ceil(tile_size / h - 1e-9).clip(max=1 << 20))
        return np.minimum(np.maximum(c, MIN_CELLS), most).astype(np.int64)

    def triangles(c: np.ndarray) -> int:
        return int((2 * c**2 + 12 * c).sum())

    lo, hi = 0.0, float(SATURATION * a.max()) + 1e-9
    if triangles(cells(lo)) <= budget:
        return cells(lo)
    for _ in range(60):  # hi always fits (or is the coarsest there is)
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if triangles(cells(mid)) <= budget else (mid, hi)
    return cells(hi)


def max_error(scene: Scene, cells: Callable[[object], int | None]) -> float:
    """The largest distance (m) between :func:`height_at` and the ground sampled
    ``cells(tile)`` times along each tile's side and cut into triangles (along either
    diagonal, whichever is worse), over rough and slope tiles (at most :data:`ERROR_TILES`
    of them, evenly spread), measured at :data:`ERROR_POINTS` points a cell side and at
    least every 5 cm; ``cells(tile)`` None leaves a tile out (its geometry is exact)."""
    t = scene.terrain
    if t is None:
        return 0.0
    s = t.tile_size
    shaped = [tile for tile in t.tiles if isinstance(tile, RoughTile | SlopeTile)]
    if len(shaped) > ERROR_TILES:
        shaped = [shaped[i] for i in np.linspace(0, len(shaped) - 1, ERROR_TILES).astype(int).tolist()]
    worst = 0.0
    for tile in shaped:
        c = cells(tile)
        if c is None:
            continue
        g = np.linspace(0.0, s, c + 1)
        z = tile_grid(tile, s, g, g)  # rows along +y
        n = max(ERROR_POINTS * c, math.ceil(s / 0.05))
        f = (np.arange(n) + 0.5) * s / n
        true = tile_grid(tile, s, f, f)
        k = np.minimum((f / s * c).astype(int), c - 1)
        a = f / s * c - k  # position inside the cell along x (columns) and y (rows)
        i, j = k[:, None], k[None, :]
        ay, ax = a[:, None], a[None, :]
        z00, z10, z01, z11 = z[i, j], z[i, j + 1], z[i + 1, j], z[i + 1, j + 1]  # z10: +x, z01: +y
        diag = np.where(
            ax >= ay, z00 + ax * (z10 - z00) + ay * (z11 - z10), z00 + ay * (z01 - z00) + ax * (z11 - z01)
        )
        anti = np.where(
            ax + ay <= 1, z00 + ax * (z10 - z00) + ay * (z01 - z00),
            z11 + (1 - ax) * (z01 - z11) + (1 - ay) * (z10 - z11),
        )  # fmt: skip
        worst = max(worst, float(np.abs(true - diag).max()), float(np.abs(true - anti).max()))
    return worst


def describe(fmt: str, what: str, spacing: float, error: float, budget: str, option: str) -> str:
    """The one warning line an exporter gives when it coarsened ``what``."""
    return (
        f"$.terrain: {fmt} samples {what} every {spacing:.3g} m (up to {error * 100:.1f} cm off "
        f"height_at) to stay within {budget}; pass {option} to choose"
    )
