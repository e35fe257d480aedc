"""Level of detail: how finely each format samples the terrain, chosen from the scene.

Every consumer has limits: MuJoCo's heightfields cost memory and compile time per sample,
PyBullet and browsers per triangle, an occupancy map per cell. An exporter asked for no
resolution (``None``, the default) keeps its usual one where the scene fits the format's
budget (:data:`BUDGETS`) and otherwise samples each rough tile as finely as its roughness
needs within the budget (:func:`fit`, one code path for MJCF, USD, URDF, GLB and HTML),
saying so in one :class:`~citygen.exporters.ExportWarning` that also gives the largest
error of the sampled ground against :func:`~citygen.geometry.terrain.height_at`. An
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
from collections.abc import Callable, Sequence
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
#: files together, each file staying within :data:`BUDGETS`: about 170 MB of URDF's OBJ
#: meshes (34 bytes a triangle), urban-tra-city's rough ground within about 10 cm of ``height_at``.
TILED_BUDGETS = MappingProxyType({"urdf": 5_000_000})
#: The error model :func:`allocate` uses: a rough tile of amplitude ``A`` whose noise lattice
#: (spacing ``scale / 2``) is sampled every ``h`` metres is off by about ``A * f(2 h / scale)``,
#: ``f(x) = SATURATION * (1 - exp(-CURVATURE * x**2 / SATURATION))``: ``CURVATURE * x**2``
#: for fine sampling, ``SATURATION`` (peak to trough) once cells span the lattice (fitted,
#: slightly above, to :func:`max_error` on urban-tra-city's rough tiles at 4 to 192 cells).
CURVATURE, SATURATION = 3.0, 1.95
#: Fewest cells along a rough tile's side :func:`allocate` gives.
MIN_CELLS = 4
#: Most terrain tiles :func:`max_error` samples to measure the error (half where the model
#: expects it largest, half evenly spread), and points along a cell's side it measures at.
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


def triangles(cells: np.ndarray) -> np.ndarray:
    """Triangles of a closed rough tile's mesh of ``cells`` cells a side: its surface
    (``2 c**2``) and its walls and floor (``12 c``)."""
    return 2 * cells**2 + 12 * cells


def allocate(
    amplitude: np.ndarray, scale: np.ndarray, tile_size: float, budget: int, most: np.ndarray,
    cost: Callable[[np.ndarray], np.ndarray] = triangles,
) -> np.ndarray:  # fmt: skip
    """Cells along each rough tile's side (``amplitude``, ``scale``: per tile, m), at most
    ``most`` each and :data:`MIN_CELLS` at least, such that they ``cost`` (per tile, of its
    cells: by default :func:`triangles`) at most ``budget`` in all and the largest expected
    error (the model of :data:`CURVATURE`) is as small as that allows: rougher tiles get
    finer cells.

    >>> allocate(np.array([0.1, 0.01]), np.array([0.5, 0.5]), 10.0, 20_000, np.array([256, 256])).tolist()
    [96, 4]
    """
    a, scale, most = np.asarray(amplitude, float), np.asarray(scale, float), np.asarray(most, np.int64)
    if not a.size:
        return np.zeros(0, dtype=np.int64)

    def cells(error: float) -> np.ndarray:
        ratio = np.clip(error / np.maximum(a, 1e-12), 1e-12, SATURATION * (1 - 1e-12))
        h = np.sqrt(-np.log1p(-ratio / SATURATION) * SATURATION / CURVATURE) * scale / 2.0
        c = np.where(error >= SATURATION * a, MIN_CELLS, np.ceil(tile_size / h - 1e-9).clip(max=1 << 20))
        return np.minimum(np.maximum(c, MIN_CELLS), most).astype(np.int64)

    def total(c: np.ndarray) -> int:
        return int(cost(c).sum())

    lo, hi = 0.0, float(SATURATION * a.max()) + 1e-9
    if total(cells(lo)) <= budget:
        return cells(lo)
    for _ in range(60):  # hi always fits (or is the coarsest there is)
        mid = (lo + hi) / 2
        lo, hi = (lo, mid) if total(cells(mid)) <= budget else (mid, hi)
    return cells(hi)


def fit(
    scene: Scene, default: np.ndarray, budget: int, *, most: np.ndarray | None = None, fixed: int = 0,
    cost: Callable[[np.ndarray], np.ndarray] = triangles, share: np.ndarray | None = None,
    groups: Sequence[np.ndarray] = (), group_budget: int = 0,
) -> np.ndarray | None:  # fmt: skip
    """The automatic level of detail every mesh and heightfield format shares: None where
    the rough tiles at their ``default`` cells (per terrain tile, indexed like
    ``scene.terrain.tiles``; 0 for a tile that is not rough) ``cost`` with ``fixed`` (what
    the other tiles cost) at most ``budget``, else each tile's cells (0 where not rough)
    from :func:`allocate`: rougher tiles finer, up to ``most`` (per tile; default
    ``default``), within ``budget - fixed``.

    ``share`` (per tile): tiles with the same value share one mesh or heightfield, which
    costs once. ``groups``: tile indices of the files a tiled export writes, each kept
    within ``group_budget`` too (its tiles made coarser where it would not be)."""
    t = scene.terrain
    default = np.asarray(default, dtype=np.int64)
    most = default if most is None else np.maximum(np.asarray(most, dtype=np.int64), default)
    ids = np.flatnonzero(default > 0)
    if t is None or not ids.size:
        return None
    keys = ids if share is None else np.asarray(share)[ids]
    _, first, inverse = np.unique(keys, return_index=True, return_inverse=True)
    reps = ids[first]

    def over(cells: np.ndarray) -> list[np.ndarray]:
        return [g for g in groups if int(cost(cells[g[cells[g] > 0]]).sum()) > group_budget]

    if int(cost(default[reps]).sum()) + fixed <= budget and not over(default):
        return None
    amplitude = np.array([t.tiles[k].amplitude for k in reps.tolist()])
    scale = np.array([t.tiles[k].scale for k in reps.tolist()])
    room = max(budget - fixed, int(cost(np.full(len(reps), MIN_CELLS)).sum()))
    cells = np.zeros(len(t.tiles), dtype=np.int64)
    cells[ids] = allocate(amplitude, scale, t.tile_size, room, most[reps], cost)[inverse]
    for g in over(cells):
        g = g[cells[g] > 0]
        a = np.array([t.tiles[k].amplitude for k in g.tolist()])
        sc = np.array([t.tiles[k].scale for k in g.tolist()])
        cells[g] = np.minimum(cells[g], allocate(a, sc, t.tile_size, group_budget, most[g], cost))
    return cells


def warning(
    fmt: str, scene: Scene, cells: np.ndarray, budget: str, option: str, what: str = "rough tiles"
) -> str:
    """The one warning line of :func:`fit`'s choice ``cells`` (per tile; 0 where the tile is
    exact), with the largest error of the ground it samples (:func:`max_error`)."""
    t = scene.terrain
    rough = np.array([isinstance(x, RoughTile) for x in t.tiles]) & (cells > 0)
    rough = rough if rough.any() else cells > 0
    fine, coarse = t.tile_size / cells[rough].max(), t.tile_size / cells[rough].min()
    error = max_error(scene, cells)
    message = describe(fmt, what, coarse, error, budget, option)
    if f"{fine:.3g}" != f"{coarse:.3g}":
        finer = f"every {fine:.3g} to {coarse:.3g} m, finer where rougher"
        message = message.replace(f"every {coarse:.3g} m", finer)
    return message


def predicted_error(tile: object, tile_size: float, cells: int) -> float:
    """The error :func:`allocate`'s model expects of a rough tile sampled ``cells`` a side."""
    h = tile_size / max(cells, 1)
    x = 2.0 * h / tile.scale
    return float(tile.amplitude * SATURATION * -math.expm1(-CURVATURE * x * x / SATURATION))


def max_error(scene: Scene, cells: Callable[[object], int | None] | np.ndarray) -> float:
    """The largest distance (m) between :func:`height_at` and the ground sampled
    ``cells(tile)`` times along each tile's side and cut into triangles (along either
    diagonal, whichever is worse), over rough and slope tiles, measured at
    :data:`ERROR_POINTS` points a cell side and at least every 5 cm; ``cells(tile)`` None
    leaves a tile out (its geometry is exact). ``cells`` may instead be an array (per
    terrain tile; 0 leaves a tile out). Of more than :data:`ERROR_TILES` tiles, it measures
    the half whose error :func:`allocate`'s model expects largest and the rest evenly spread."""
    t = scene.terrain
    if t is None:
        return 0.0
    s = t.tile_size
    kinds = RoughTile | SlopeTile
    if isinstance(cells, np.ndarray):
        pairs = zip(t.tiles, cells.tolist(), strict=True)
        shaped = [(x, int(c)) for x, c in pairs if isinstance(x, kinds) and c]
    else:
        shaped = [(x, c) for x in t.tiles if isinstance(x, kinds) and (c := cells(x))]
    if len(shaped) > ERROR_TILES:
        expected = [predicted_error(x, s, c) if isinstance(x, RoughTile) else 0.0 for x, c in shaped]
        worst_first = np.argsort(expected, kind="stable")[::-1][: ERROR_TILES // 2]
        spread = np.linspace(0, len(shaped) - 1, ERROR_TILES - len(worst_first)).astype(int)
        shaped = [shaped[i] for i in np.unique(np.r_[worst_first, spread]).tolist()]
    worst = 0.0
    for tile, c in shaped:
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
