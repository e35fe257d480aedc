"""The terrain's tiles as convex pieces: ground that a physics engine which collides every
shape as its convex hull (SAPIEN's URDF loader, Genesis, MuJoCo's meshes, Isaac Lab's mesh
converter) still gets right.

Each tile becomes pieces each of which is convex, from the floor (see
:func:`~citygen.geometry.terrain.tile_mesh`) up to the ground, in the tile's local frame
(minimum corner at the origin, metres):

- a **flat** tile: one box; a **stair**: its treads' boxes
  (:func:`~citygen.geometry.terrain.tile_boxes`); exact.
- a **slope** flight: one prism under its plane; a pyramid or a pit: five prisms, the
  platform and the four trapezoids around it, each under its own plane; exact.
- a **rough** tile: rectangular cells, each a box tilted so that its top is the best plane
  through the surface over the cell (least squares, centred in its band of residuals), cut in
  two across its longer side until that plane is within ``tolerance`` (m) of
  :func:`~citygen.geometry.terrain.height_at` at every sample of the cell (samples every
  :data:`SAMPLES_PER_SCALE`-th of the noise's wavelength). Flat parts of the tile (its taper
  band) stay whole cells; a cell's box is widened just enough that its tilted top covers the
  cell, so neighbouring cells meet with a step of at most twice the tolerance, never a gap.

Boxes are primitives every format names (URDF ``<box>``, MJCF ``type="box"``) and need no
mesh file; prisms are small closed meshes (:func:`prism_mesh`).

>>> from citygen.spec.terrain import SlopeTile
>>> p = tile_pieces(SlopeTile(kind="slope", angle=0.3, shape="pit"), 3.0)
>>> len(p.prisms), len(p.boxes)
(5, 0)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from citygen.geometry import pieces_kernel
from citygen.geometry.terrain import MIN_THICKNESS, tile_boxes, tile_grid, tile_height
from citygen.spec.terrain import FlatTile, RoughTile, SlopeTile, StairTile, peak

#: Default of the ``tolerance`` of rough tiles' pieces (m): their tops lie within this of
#: ``height_at`` at every sample.
ROUGH_TOLERANCE = 0.01
#: Samples of a rough tile's surface per wavelength (``scale``) of its noise, along a side.
SAMPLES_PER_SCALE = 16
#: Most samples along a rough tile's side.
MAX_SAMPLES = 512


@dataclass(frozen=True)
class Pieces:
    """Convex pieces of ground (m, a tile's local frame unless moved).

    ``boxes``: ``(k, 3, 3)`` rows of centre, half sizes and roll-pitch-yaw (rad, URDF's fixed
    axes: yaw about z, then pitch about y, then roll about x, applied right to left);
    ``prisms``: each ``(n, 3)``, the corners of a convex polygon counter-clockwise seen from
    above, lying on the ground, the prism reaching down to ``bottom``; ``error``: the
    largest distance (m) of the pieces' tops from ``height_at`` over the samples checked."""

    boxes: np.ndarray
    prisms: tuple[np.ndarray, ...]
    bottom: float
    error: float = 0.0

    def __len__(self) -> int:
        return len(self.boxes) + len(self.prisms)


def _bottom(tile, s: float, floor: float) -> float:
    lowest = (
        tile.height - tile.amplitude if isinstance(tile, RoughTile) else tile.height + min(0.0, peak(tile, s))
    )
    if not math.isfinite(floor):
        raise ValueError(f"floor must be a finite height in metres, got {floor!r}")
    return min(floor, lowest - MIN_THICKNESS)


def axis_boxes(corners: np.ndarray) -> np.ndarray:
    """Axis-aligned boxes ``(k, 2, 3)`` of min and max corners as :attr:`Pieces.boxes` rows."""
    corners = np.asarray(corners, dtype=np.float64).reshape(-1, 2, 3)
    lo, hi = corners[:, 0], corners[:, 1]
    return np.stack([(lo + hi) / 2, (hi - lo) / 2, np.zeros_like(lo)], axis=1)


def _box_tile(tile: FlatTile | StairTile, s: float, floor: float, tolerance: float) -> Pieces:
    return Pieces(axis_boxes(tile_boxes(tile, s, floor=floor)), (), _bottom(tile, s, floor))


def _slope_tile(tile: SlopeTile, s: float, floor: float, tolerance: float) -> Pieces:
    if tile.shape is None:
        faces = [np.array([[0.0, 0.0], [s, 0.0], [s, s], [0.0, s]])]
    else:
        a, b = s / 3.0, 2.0 * s / 3.0
        faces = [
            np.array([[a, a], [b, a], [b, b], [a, b]]),  # the platform
            np.array([[0.0, 0.0], [s, 0.0], [b, a], [a, a]]),  # south
            np.array([[s, 0.0], [s, s], [b, b], [b, a]]),  # east
            np.array([[s, s], [0.0, s], [a, b], [b, b]]),  # north
            np.array([[0.0, s], [0.0, 0.0], [a, a], [a, b]]),  # west
        ]
    prisms = tuple(np.c_[f, tile_height(tile, s, f[:, 0], f[:, 1])] for f in faces)
    return Pieces(np.zeros((0, 3, 3)), prisms, _bottom(tile, s, floor))


def _rough_tile(tile: RoughTile, s: float, floor: float, tolerance: float) -> Pieces:
    bottom = _bottom(tile, s, floor)
    boxes, error = _rough_cells(tile.model_copy(update={"height": 0.0, "material": None, "friction": None}),
                                s, tolerance)  # fmt: skip
    boxes = boxes.copy()
    boxes[:, 0, 2] += tile.height
    # Each box reaches from its top down to the floor (measured along its own axis).
    top = boxes[:, 0, 2] + _top_offset(boxes)
    depth = (top - bottom) / np.cos(boxes[:, 2, 0]) / np.cos(boxes[:, 2, 1])
    shift = (depth / 2 - boxes[:, 1, 2])[:, None] * _up(boxes)
    boxes[:, 0] -= shift
    boxes[:, 1, 2] = depth / 2
    return Pieces(boxes, (), bottom, error)


def _up(boxes: np.ndarray) -> np.ndarray:
    """Each box's local +z in world coordinates (its top face's normal)."""
    r, p = boxes[:, 2, 0], boxes[:, 2, 1]
    return np.c_[np.cos(r) * np.sin(p), -np.sin(r), np.cos(r) * np.cos(p)]


def _top_offset(boxes: np.ndarray) -> np.ndarray:
    """Height of each box's top face centre above its centre."""
    return boxes[:, 1, 2] * _up(boxes)[:, 2]


@lru_cache(maxsize=256)
def _rough_cells(tile: RoughTile, s: float, tolerance: float) -> tuple[np.ndarray, float]:
    """A rough tile at height 0 as tilted boxes of zero depth (their top faces) and the
    largest error of their planes at the samples; cached, as a scene repeats tiles. A tile
    whose bumps stay within the tolerance is one level box (its error, the amplitude)."""
    if tile.amplitude <= tolerance:
        return np.array([_plate(0.0, s, 0.0, s, (0.0, 0.0, 0.0))]), tile.amplitude
    n = int(min(max(math.ceil(s * SAMPLES_PER_SCALE / tile.scale), 2), MAX_SAMPLES))
    g = np.linspace(0.0, s, n + 1)
    z = tile_grid(tile, s, g, g)  # z[i, j]: v = g[i], u = g[j]
    index, plane = pieces_kernel.rough_cells(g, z, float(tolerance))
    order = np.lexsort((index[:, 1], index[:, 0]))
    cells = zip(index[order].tolist(), plane[order].tolist(), strict=True)
    boxes = np.array(
        [_plate(g[j0], g[j0 + nj], g[i0], g[i0 + ni], (c, a, b)) for (i0, j0, ni, nj), (c, a, b, _) in cells]
    )
    return boxes, float(plane[:, 3].max())


def _cells_reference(g: np.ndarray, z: np.ndarray, tolerance: float) -> tuple[np.ndarray, np.ndarray]:
    """:func:`~citygen.geometry.pieces_kernel.rough_cells` in numpy, the reference it is
    tested against: split each cell across its longer side until its plane (:func:`_fit`)
    is within ``tolerance`` of its samples; ``(i0, j0, ni, nj)`` and ``(c, a, b, err)``."""
    n = len(g) - 1
    cells: list[tuple[tuple[int, int, int, int], tuple[float, float, float, float]]] = []
    stack = [(0, 0, n, n)]
    while stack:
        i0, j0, ni, nj = stack.pop()
        plane, err = _fit(g, z, i0, j0, ni, nj)
        if err <= tolerance or (ni == 1 and nj == 1):
            cells.append(((i0, j0, ni, nj), (*plane, err)))
            continue
        stack += _split(g, z, i0, j0, ni, nj)
    return np.array([c[0] for c in cells], dtype=np.int64), np.array([c[1] for c in cells])


def _fit(g: np.ndarray, z: np.ndarray, i0: int, j0: int, ni: int, nj: int):
    """The plane ``(c, a, b)``, ``z = c + a (u - uc) + b (v - vc)`` about the cell's centre,
    fitted to the cell's samples (least squares, then centred in its residuals' band), and
    its largest distance from them."""
    sub = z[i0 : i0 + ni + 1, j0 : j0 + nj + 1]
    u = g[j0 : j0 + nj + 1] - (g[j0] + g[j0 + nj]) / 2
    v = g[i0 : i0 + ni + 1] - (g[i0] + g[i0 + ni]) / 2
    a = float((sub * u[None, :]).sum() / (len(v) * (u * u).sum()))
    b = float((sub * v[:, None]).sum() / (len(u) * (v * v).sum()))
    rest = sub - a * u[None, :] - b * v[:, None]
    hi, lo = float(rest.max()), float(rest.min())
    return ((hi + lo) / 2, a, b), (hi - lo) / 2


def _split(
    g: np.ndarray, z: np.ndarray, i0: int, j0: int, ni: int, nj: int
) -> list[tuple[int, int, int, int]]:
    """A cell cut in two across its longer side (a square: across the side whose cut fits better)."""
    halves = []
    if ni >= nj and ni > 1:
        h = ni // 2
        halves.append([(i0, j0, h, nj), (i0 + h, j0, ni - h, nj)])
    if nj >= ni and nj > 1:
        h = nj // 2
        halves.append([(i0, j0, ni, h), (i0, j0 + h, ni, nj - h)])
    if len(halves) == 1:
        return halves[0]
    across_i, across_j = (max(_fit(g, z, *cell)[1] for cell in cut) for cut in halves)
    return halves[1] if across_j < across_i - pieces_kernel.TIE else halves[0]


def _plate(u0: float, u1: float, v0: float, v1: float, plane: tuple[float, float, float]) -> np.ndarray:
    """A box of zero depth whose top face lies on ``plane`` over ``[u0, u1] x [v0, v1]``
    (centre, half sizes, roll-pitch-yaw), widened so that the face covers the rectangle: its
    edges run along the plane over +u (local x) and square to it (local y), so seen from
    above the face is a parallelogram slanted by the plane's twist ``a b / (1 + a^2)``."""
    c, a, b = plane
    du, dv = (u1 - u0) / 2, (v1 - v0) / 2
    ka = math.sqrt(1.0 + a * a)
    norm = math.sqrt(1.0 + a * a + b * b)
    half_v = dv * norm / ka
    half_u = (du + dv * abs(a * b) / (ka * ka)) * ka
    roll, pitch = math.atan2(b, ka), math.atan2(-a, 1.0)
    return np.array([[(u0 + u1) / 2, (v0 + v1) / 2, c], [half_u, half_v, 0.0], [roll, pitch, 0.0]])


#: The pieces of each tile class (a typed registry: a new tile kind adds its line).
BUILDERS: dict[type, Callable[..., Pieces]] = {
    FlatTile: _box_tile,
    SlopeTile: _slope_tile,
    StairTile: _box_tile,
    RoughTile: _rough_tile,
}


def tile_pieces(tile, tile_size: float, *, floor: float = -1.0, tolerance: float = ROUGH_TOLERANCE) -> Pieces:
    """One tile as convex pieces in its local frame (see the module docstring), from
    ``floor`` (m; lowered to ``MIN_THICKNESS`` below the tile's lowest point) up; a rough
    tile's within ``tolerance`` (m) of its surface at the samples."""
    if not (math.isfinite(tolerance) and tolerance > 0):
        raise ValueError(f"tolerance must be a positive number of metres, got {tolerance!r}")
    return BUILDERS[type(tile)](tile, tile_size, floor, tolerance)


def prism_mesh(top: np.ndarray, bottom: float) -> tuple[np.ndarray, np.ndarray]:
    """The closed, outward-facing triangle mesh of a prism: the convex polygon ``top``
    (``(n, 3)``, counter-clockwise seen from above) and its copy at ``z = bottom``;
    vertices ``(2n, 3)`` (top then bottom), faces ``(4n - 4, 3)``."""
    top = np.asarray(top, dtype=np.float64)
    n = len(top)
    verts = np.empty((2 * n, 3))
    verts[:n] = top
    verts[n:, :2] = top[:, :2]
    verts[n:, 2] = bottom
    return verts, _prism_faces(n).copy()


@lru_cache(maxsize=64)
def _prism_faces(n: int) -> np.ndarray:
    """:func:`prism_mesh`'s faces of an ``n``-gon: the city's URDF asks for some 50,000."""
    k = np.arange(1, n - 1)
    ring = np.arange(n)
    nxt = (ring + 1) % n
    return np.r_[
        np.c_[np.zeros(n - 2, dtype=np.int64), k, k + 1],  # top, counter-clockwise: up
        np.c_[np.full(n - 2, n), k + 1 + n, k + n],  # bottom: down
        np.c_[ring, ring + n, nxt + n],  # sides: out
        np.c_[ring, nxt + n, nxt],
    ].astype(np.int64)


def rpy_quat(rpy: np.ndarray) -> np.ndarray:
    """Roll-pitch-yaw rows (URDF's convention) as unit quaternions ``(w, x, y, z)`` (MJCF's)."""
    r, p, y = np.asarray(rpy, dtype=np.float64).reshape(-1, 3).T / 2
    cr, sr, cp, sp, cy, sy = np.cos(r), np.sin(r), np.cos(p), np.sin(p), np.cos(y), np.sin(y)
    return np.c_[
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
