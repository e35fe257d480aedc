"""Geodesic distance fields over a grid's free cells: shortest-path distances from every cell
to a goal cell (:func:`geodesic_distance`, the grid's 8 or 16 directions) and
:class:`DistanceField`, the distance to a goal (or to the goal region, by
:mod:`~citygen.runner.control.regions`) at any point, which the metrics and the scene cache use.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import scipy.ndimage
import scipy.sparse
import scipy.sparse.csgraph

from citygen.geometry.raster import Grid
from citygen.runner.control.grid import Cell, _cell, _free_array, snap_free
from citygen.runner.control.regions import region_distance, region_path_length

# Steps of the grid graph (each an undirected edge) and the cells, relative to the step's
# source, its straight segment passes through and that must be free too.
_STEPS8: tuple[tuple[int, int, tuple[Cell, ...]], ...] = (
    (0, 1, ()),
    (1, 0, ()),
    (1, 1, ((0, 1), (1, 0))),
    (1, -1, ((0, -1), (1, 0))),
)
_STEPS16 = (
    *_STEPS8,
    (1, 2, ((0, 1), (1, 1))),
    (2, 1, ((1, 0), (1, 1))),
    (2, -1, ((1, 0), (1, -1))),
    (1, -2, ((0, -1), (1, -1))),
)


def _grid_graph(free: np.ndarray, connectivity: int) -> tuple[scipy.sparse.csr_matrix, np.ndarray]:
    """Free cells as nodes (row-major), undirected edges weighted by step length in cells."""
    steps = {8: _STEPS8, 16: _STEPS16}[connectivity]
    rows, cols = free.shape
    index = np.full((rows + 4, cols + 4), -1, dtype=np.int32)  # padded by 2: every step in bounds
    n = int(free.sum())
    index[2:-2, 2:-2][free] = np.arange(n, dtype=np.int32)
    padded = index >= 0

    def shifted(a: np.ndarray, dr: int, dc: int) -> np.ndarray:
        return a[2 + dr : 2 + dr + rows, 2 + dc : 2 + dc + cols]

    heads, tails, weights = [], [], []
    for dr, dc, through in steps:
        ok = free & shifted(padded, dr, dc)
        for tr, tc in through:
            ok &= shifted(padded, tr, tc)
        heads.append(index[2:-2, 2:-2][ok])
        tails.append(shifted(index, dr, dc)[ok])
        weights.append(np.full(heads[-1].size, math.hypot(dr, dc)))
    graph = scipy.sparse.csr_matrix(
        (np.concatenate(weights), (np.concatenate(heads), np.concatenate(tails))), shape=(n, n)
    )
    return graph, index[2:-2, 2:-2]


def geodesic_distance(
    free: np.ndarray, goal_cell: Cell, resolution: float, *, connectivity: int = 8
) -> np.ndarray:
    """Shortest-path distance (m) from every cell to ``goal_cell`` through free cells: a
    float64 array of ``free``'s shape, ``inf`` on blocked cells and cells not connected to the
    goal (everywhere when the goal cell is blocked).

    ``connectivity`` 8 uses the steps of :func:`astar` (so ``field[start]`` is the length of
    its path times ``resolution``; up to 8.2 % longer than the straight line in free space);
    16 adds the knight's moves (sqrt(5) cells, the two cells they pass through must be free),
    at most 2.7 % longer than the straight line: the better estimate of a route's length.
    """
    free = _free_array(free)
    goal = _cell(free, goal_cell, "goal_cell")
    if not (resolution > 0 and math.isfinite(resolution)):
        raise ValueError(f"resolution: expected a positive cell size in metres, got {resolution!r}")
    if connectivity not in (8, 16):
        raise ValueError(f"connectivity: expected 8 or 16, got {connectivity!r}")
    out = np.full(free.shape, np.inf)
    if not free[goal]:
        return out
    graph, index = _grid_graph(free, connectivity)
    dist = scipy.sparse.csgraph.dijkstra(graph, directed=False, indices=int(index[goal]))
    out[free] = dist * resolution
    return out


@dataclass(frozen=True, eq=False)
class DistanceField:
    """Geodesic distance (m) to a goal over a grid's free cells, defined at any point: a
    point on a cell that cannot reach the goal (blocked, or in the inflated band) takes the
    distance of the nearest reachable cell plus the straight line to that cell's centre."""

    distance: np.ndarray
    """float64 ``(rows, cols)``: metres to the goal along free cells, ``inf`` where unreachable."""
    grid: Grid

    @classmethod
    def build(
        cls,
        free: np.ndarray,
        grid: Grid,
        goal_xy: Sequence[float],
        *,
        connectivity: int = 16,
        tolerance: float | None = None,
    ) -> DistanceField:
        """The field towards ``goal_xy`` (m): with ``tolerance`` (m), the any-angle distance
        to the disc of that radius around it (:func:`region_distance`); without, or when no
        free cell lies in that disc, the grid distance (``connectivity`` 8 or 16,
        :func:`geodesic_distance`) to the free cell nearest the goal. Raises ValueError when
        ``free`` has no free cell."""
        free = _free_array(free)
        field = None
        if tolerance is not None:
            try:
                field = region_distance(free, grid, goal_xy, tolerance)
            except ValueError:
                field = None
        if field is not None:
            goal = (float(goal_xy[0]), float(goal_xy[1]))
            return cls(field, grid, free, goal, float(tolerance))
        goal = snap_free(free, grid.cell(float(goal_xy[0]), float(goal_xy[1])))
        if goal is None:
            raise ValueError("DistanceField: the grid has no free cell")
        return cls(geodesic_distance(free, goal, grid.resolution, connectivity=connectivity), grid)

    free: np.ndarray | None = None
    """The free cells the field was built on (None when not kept)."""
    goal: tuple[float, float] | None = None
    tolerance: float | None = None
    """Radius (m) of the goal region when the field runs to one (:func:`region_distance`)."""

    @functools.cached_property
    def nearest(self) -> np.ndarray:
        """int ``(2, rows, cols)``: the nearest reachable cell of every cell (itself where
        :attr:`distance` is finite). Computed on first use, by a point off the reachable
        cells: a whole-grid distance transform most episodes never need."""
        _, nearest = scipy.ndimage.distance_transform_edt(~np.isfinite(self.distance), return_indices=True)
        return nearest

    def route(self, x: float, y: float) -> float:
        """Metres from ``(x, y)`` to the goal region along the shortest path: the lesser of
        :meth:`at` and the taut path down the field (:func:`region_path_length`), which
        removes fast marching's excess at corners; :meth:`at` for a grid field."""
        d = self.at(x, y)
        if self.tolerance is None or self.free is None or not math.isfinite(d):
            return d
        r, c = self.grid.cell(float(x), float(y))
        if not math.isfinite(self.distance[r, c]):  # off the reachable cells: not its own nearest
            return d
        return min(
            d, region_path_length(self.free, self.grid, self.distance, (x, y), self.goal, self.tolerance)
        )

    def at(self, x: float, y: float) -> float:
        """Metres from ``(x, y)`` to the goal (see the class docstring)."""
        r, c = self.grid.cell(float(x), float(y))
        d = float(self.distance[r, c])
        if math.isfinite(d):  # a reachable cell is its own nearest
            return d
        rr, cc = int(self.nearest[0, r, c]), int(self.nearest[1, r, c])
        cx, cy = self.grid.centre((rr, cc))
        return float(self.distance[rr, cc] + math.hypot(x - cx, y - cy))
