"""Regular grids over a scene: rasterised zones and objects, connectivity, shortest paths.

A :class:`Grid` covers an axis-aligned rectangle with square cells of one
resolution (m); row ``r`` and column ``c`` is the cell whose centre is
``(x0 + (c + 0.5) * resolution, y0 + (r + 0.5) * resolution)``, so rows grow with
+y. A cell takes a shape's value when its *centre* lies in the shape (boundary
included): the convention of the occupancy map, of the task-solvability checks
and of the traverse routes.

Shapes are tested with shapely's vectorised ``intersects_xy`` over the window of
cells under each shape's bounding box, so the cost grows with the area the shapes
cover, not with the grid.

>>> from shapely.geometry import box
>>> grid = Grid.covering((0.0, 0.0, 4.0, 2.0), 1.0)
>>> grid.shape
(2, 4)
>>> rasterize(grid, [box(0, 0, 2, 2), box(1, 0, 4, 1)], [1, 2]).tolist()
[[1, 2, 2, 2], [1, 1, 0, 0]]
>>> shortest_path(np.ones((3, 3), bool), (0, 0), (2, 2))
[(0, 0), (1, 1), (2, 2)]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.ndimage
import scipy.sparse
import scipy.sparse.csgraph
import shapely
from shapely.geometry.base import BaseGeometry

Cell = tuple[int, int]


@dataclass(frozen=True)
class Grid:
    """Square cells of ``resolution`` metres from ``(x0, y0)``: ``rows`` along y, ``cols`` along x."""

    x0: float
    y0: float
    resolution: float
    rows: int
    cols: int

    @classmethod
    def covering(cls, bounds: Sequence[float], resolution: float) -> Grid:
        """The grid from ``(xmin, ymin)`` with enough cells to cover ``(xmin, ymin, xmax, ymax)``."""
        xmin, ymin, xmax, ymax = (float(v) for v in bounds)
        if not (resolution > 0 and math.isfinite(resolution)):
            raise ValueError(f"Grid resolution: expected a positive length (m), got {resolution!r}")
        # A hair below 1 cell of slack so 10 m at 0.05 m is 200 cells, not 201.
        cols = max(1, math.ceil((xmax - xmin) / resolution - 1e-9))
        rows = max(1, math.ceil((ymax - ymin) / resolution - 1e-9))
        return cls(xmin, ymin, float(resolution), rows, cols)

    @property
    def shape(self) -> tuple[int, int]:
        return (self.rows, self.cols)

    def xs(self) -> np.ndarray:
        """x of every column's cell centres (m)."""
        return self.x0 + (np.arange(self.cols) + 0.5) * self.resolution

    def ys(self) -> np.ndarray:
        """y of every row's cell centres (m)."""
        return self.y0 + (np.arange(self.rows) + 0.5) * self.resolution

    def cell(self, x: float, y: float) -> Cell:
        """The (row, col) containing the point, clamped to the grid."""
        col = min(max(math.floor((x - self.x0) / self.resolution), 0), self.cols - 1)
        row = min(max(math.floor((y - self.y0) / self.resolution), 0), self.rows - 1)
        return row, col

    def centre(self, cell: Cell) -> tuple[float, float]:
        """The centre (x, y) of a cell (m)."""
        row, col = cell
        return (self.x0 + (col + 0.5) * self.resolution, self.y0 + (row + 0.5) * self.resolution)

    def bilinear(self, values: np.ndarray, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """``values`` (one per cell, at the cell centres) interpolated bilinearly at the
        points ``(xs, ys)`` (m); points beyond the outermost centres take the edge's values.

        >>> g = Grid(0.0, 0.0, 1.0, 2, 2)
        >>> g.bilinear(np.array([[0.0, 1.0], [2.0, 3.0]]), np.array([1.0, 9.0]), np.array([1.0, 0.0]))
        array([1.5, 1. ])
        """
        rows, cols = self.shape
        flat = np.asarray(values, dtype=np.float64).ravel()
        inv = 1.0 / self.resolution
        # Fractional cell-centre coordinates, clamped a hair inside the last centre so that
        # the corner cells (i, i + 1) always exist; in place: this runs every control step.
        fx = np.multiply(xs, inv, dtype=np.float64)
        fx -= self.x0 * inv + 0.5
        np.clip(fx, 0.0, max(cols - 1 - 1e-9, 0.0), out=fx)
        fy = np.multiply(ys, inv, dtype=np.float64)
        fy -= self.y0 * inv + 0.5
        np.clip(fy, 0.0, max(rows - 1 - 1e-9, 0.0), out=fy)
        ix, iy = fx.astype(np.intp), fy.astype(np.intp)
        fx -= ix
        fy -= iy
        i = iy * cols
        i += ix
        dx, dy = (1 if cols > 1 else 0), (cols if rows > 1 else 0)
        a = flat[i]
        top = flat[i + dx]
        top -= a
        top *= fx
        top += a
        b = flat[i + dy]
        bottom = flat[i + (dy + dx)]
        bottom -= b
        bottom *= fx
        bottom += b
        bottom -= top
        bottom *= fy
        bottom += top
        return bottom

    def bilinear_point(self, values: np.ndarray, x: float, y: float) -> float:
        """:meth:`bilinear` at the one point ``(x, y)``, in plain Python: the same operations
        in the same order, so the same float to the bit (a few microseconds, where the array
        version's numpy calls cost fifty for one point).

        >>> g = Grid(0.0, 0.0, 1.0, 2, 2)
        >>> g.bilinear_point(np.array([[0.0, 1.0], [2.0, 3.0]]), 1.0, 1.0)
        1.5
        """
        rows, cols = self.shape
        flat = np.asarray(values, dtype=np.float64).ravel()
        inv = 1.0 / self.resolution
        fx = min(max(x * inv - (self.x0 * inv + 0.5), 0.0), max(cols - 1 - 1e-9, 0.0))
        fy = min(max(y * inv - (self.y0 * inv + 0.5), 0.0), max(rows - 1 - 1e-9, 0.0))
        ix, iy = int(fx), int(fy)
        fx -= ix
        fy -= iy
        i = iy * cols + ix
        dx, dy = (1 if cols > 1 else 0), (cols if rows > 1 else 0)
        a, b = float(flat[i]), float(flat[i + dy])
        top = (float(flat[i + dx]) - a) * fx + a
        bottom = (float(flat[i + (dy + dx)]) - b) * fx + b
        return (bottom - top) * fy + top

    def window(self, bounds: Sequence[float]) -> tuple[slice, slice]:
        """Rows and columns whose centres can lie in ``(xmin, ymin, xmax, ymax)``."""
        xmin, ymin, xmax, ymax = bounds
        res = self.resolution
        c0 = max(0, math.ceil((xmin - self.x0) / res - 0.5))
        c1 = min(self.cols, math.floor((xmax - self.x0) / res - 0.5) + 1)
        r0 = max(0, math.ceil((ymin - self.y0) / res - 0.5))
        r1 = min(self.rows, math.floor((ymax - self.y0) / res - 0.5) + 1)
        return slice(r0, max(r0, r1)), slice(c0, max(c0, c1))


def paint(grid: Grid, out: np.ndarray, geometry: BaseGeometry, value: object) -> None:
    """Set ``out`` to ``value`` on every cell whose centre lies in ``geometry`` (in place)."""
    if geometry.is_empty:
        return
    rows, cols = grid.window(geometry.bounds)
    if rows.start == rows.stop or cols.start == cols.stop:
        return
    shapely.prepare(geometry)
    xs, ys = grid.xs()[cols], grid.ys()[rows]
    inside = shapely.intersects_xy(geometry, xs[None, :], ys[:, None])
    out[rows, cols][inside] = value


def rasterize(
    grid: Grid,
    geometries: Sequence[BaseGeometry],
    values: Sequence[object],
    *,
    fill: object = 0,
    dtype: type = np.uint8,
) -> np.ndarray:
    """A ``grid.shape`` array of ``fill`` with each geometry's value painted in order (later wins)."""
    out = np.full(grid.shape, fill, dtype=dtype)
    for geometry, value in zip(geometries, values, strict=True):
        paint(grid, out, geometry, value)
    return out


def mask(grid: Grid, geometry: BaseGeometry) -> np.ndarray:
    """Cells whose centres lie in ``geometry``."""
    return rasterize(grid, [geometry], [True], fill=False, dtype=bool)


def components(free: np.ndarray) -> tuple[np.ndarray, int]:
    """Label 8-connected regions of ``free`` (without cutting corners diagonally: a
    diagonal step counts only when both cells beside it are free); 0 is not free.

    A diagonal step that both cells beside it allow joins cells those two already join, so
    these are the 4-connected regions: :func:`scipy.ndimage.label` (numbered, as the graph
    search over :func:`_graph` numbered them, in row-major order of their first cell; tens of
    times faster)."""
    labels, count = scipy.ndimage.label(np.asarray(free, dtype=bool))
    return labels.astype(np.int32, copy=False), int(count)


def _graph(free: np.ndarray) -> tuple[scipy.sparse.csr_matrix, np.ndarray]:
    """The free cells as graph nodes (row-major order) with 8-neighbour edges weighted by
    step length in cells; diagonal steps need both orthogonal neighbours free."""
    rows, cols = free.shape
    index = np.full(free.shape, -1, dtype=np.int64)
    index[free] = np.arange(int(free.sum()))
    heads, tails, weights = [], [], []
    for dr, dc in ((0, 1), (1, 0), (1, 1), (1, -1)):
        a = free[: rows - dr, max(0, -dc) : cols - max(0, dc)]
        b = free[dr:rows, max(0, dc) : cols + min(0, dc)]
        ok = a & b
        if dr and dc:  # no corner cutting
            ok &= free[: rows - dr, max(0, dc) : cols + min(0, dc)]
            ok &= free[dr:rows, max(0, -dc) : cols - max(0, dc)]
        ia = index[: rows - dr, max(0, -dc) : cols - max(0, dc)][ok]
        ib = index[dr:rows, max(0, dc) : cols + min(0, dc)][ok]
        heads.append(ia)
        tails.append(ib)
        weights.append(np.full(ia.size, math.sqrt(dr * dr + dc * dc)))
    n = int(free.sum())
    head, tail, weight = np.concatenate(heads), np.concatenate(tails), np.concatenate(weights)
    graph = scipy.sparse.csr_matrix((weight, (head, tail)), shape=(n, n))
    return graph, index


def shortest_path(free: np.ndarray, start: Cell, goal: Cell) -> list[Cell] | None:
    """The shortest 8-connected path of free cells from ``start`` to ``goal`` (both
    included), or None when they are not connected or either is not free."""
    if not (free[start] and free[goal]):
        return None
    graph, index = _graph(free)
    source, target = int(index[start]), int(index[goal])
    _, previous = scipy.sparse.csgraph.dijkstra(
        graph, directed=False, indices=source, return_predecessors=True
    )
    if source != target and previous[target] < 0:
        return None
    cells = np.argwhere(free)  # row-major, the order of the node numbers
    path, node = [], target
    while node != source:
        path.append(node)
        node = int(previous[node])
    path.append(source)
    return [(int(cells[k][0]), int(cells[k][1])) for k in reversed(path)]


#: Most cells of the disc :func:`erode` shifts the grid by; a wider disc takes the distance
#: transform.
ERODE_SHIFTS = 25


def erode(free: np.ndarray, radius_cells: float) -> np.ndarray:
    """Cells more than ``radius_cells`` (in cells, Euclidean between centres) from any non-free
    cell and from the grid's edge: where a disc of that radius centred on the cell fits.

    A small disc (at most :data:`ERODE_SHIFTS` cells: a city's map of 0.4 m cells under a
    robot of 0.3 m is one cell) is the free grid shifted by each of its offsets, ANDed: the
    offsets whose distance, computed as the distance transform computes it, is not above
    ``radius_cells``, so the same cells as :func:`erode_edt` (the reference), without the
    distance transform of the whole grid (a city's 9 million cells: 1 s)."""
    free = np.asarray(free, dtype=bool)
    reach = math.floor(radius_cells) if radius_cells >= 0 else -1
    if reach < 0:
        return np.ones(free.shape, dtype=bool)
    if (2 * reach + 1) ** 2 > ERODE_SHIFTS:
        return erode_edt(free, radius_cells)
    rows, cols = free.shape
    padded = np.pad(free, reach + 1, constant_values=False)
    out = free.copy()
    for di in range(-reach, reach + 1):
        for dj in range(-reach, reach + 1):
            if (di or dj) and np.sqrt(np.float64(di * di + dj * dj)) <= radius_cells:
                r0, c0 = reach + 1 + di, reach + 1 + dj
                out &= padded[r0 : r0 + rows, c0 : c0 + cols]
    # the grid's edge is one cell beyond it: the distance to it is the row's or column's
    edge = (
        np.minimum.outer(
            np.minimum(np.arange(rows), np.arange(rows)[::-1]),
            np.minimum(np.arange(cols), np.arange(cols)[::-1]),
        )
        + 1
    )
    out &= edge > radius_cells
    return out


def erode_edt(free: np.ndarray, radius_cells: float) -> np.ndarray:
    """:func:`erode` by the distance transform of the whole grid: the plain reference."""
    padded = np.pad(free, 1, constant_values=False)
    distance = scipy.ndimage.distance_transform_edt(padded)[1:-1, 1:-1]
    return distance > radius_cells
