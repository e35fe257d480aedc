"""The ground at 5 cm on a scene whose occupancy map is coarser (a city's): a raster made
tile by tile as the robot reaches it.

An Urban-Nav scene's occupancy map has 5 cm cells and its heights are the ground raster the
ideal-locomotion servo stands on (:meth:`~citygen.runner.scenes.Prepared.ground_at`). A
city's map is coarser (it would be ~600 million cells at 5 cm), and the servo used to cast
rays through the whole scene instead, one per drive period and per foot probe: on the
1.2 km city's town-sized part, 50 rays a step cost 9.4 ms of a 34 ms step. :class:`TiledGround`
is the same raster (the occupancy grid at :data:`~citygen.runner.scenes.MAP_RESOLUTION` over
the scene's bounds, :func:`~citygen.geometry.terrain.height_at` at the cell centres, stored
as float32 then read as float64, as the occupancy map stores its heights) computed one tile
of :data:`TILE_CELLS` cells at a time when first read. ``Prepared.ground_at`` on a 5 cm map
is the same class over one tile, the map's heights: the two agree to the bit.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from citygen.geometry.raster import Grid
from citygen.geometry.terrain import height_grid

#: Cells on a side of one tile (6.4 m at 5 cm); each tile also holds the next tile's first
#: row and column, so that a point's four neighbouring cells always lie on one tile.
TILE_CELLS = 128
#: Tiles kept (each ~130 kB): a 1.4 km traverse route passes about 250 of them.
MAX_TILES = 1024


class TiledGround:
    """The scene's 5 cm ground raster, made a tile at a time (see the module docstring).
    ``ground_at(x, y)`` is the interface the servo reads (:attr:`RobotHandle.terrain
    <citygen.runner.robots.handle.RobotHandle.terrain>`)."""

    def __init__(self, scene, grid: Grid, raster: np.ndarray | None = None) -> None:
        self.scene, self.grid = scene, grid
        self._tiles: dict[tuple[int, int], tuple[memoryview, int]] = {}
        #: Cells on a tile's side: one tile of the whole ``raster`` when one is given.
        self.tile_cells = TILE_CELLS if raster is None else max(grid.rows, grid.cols)
        if raster is not None:
            flat = np.ascontiguousarray(raster, dtype=np.float64).reshape(-1)
            self._tiles[(0, 0)] = (memoryview(flat), grid.cols)
        self.ground_at: Callable[[float, float], float] = self._bind()

    @classmethod
    def of_scene(cls, scene, resolution: float) -> TiledGround:
        """The raster over the scene's bounds at ``resolution``, tiles made as they are read."""
        (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
        return cls(scene, Grid.covering((x0, y0, x1, y1), resolution))

    def tile(self, ty: int, tx: int) -> np.ndarray:
        """The heights (float64, rows along y) of tile ``(ty, tx)``: cells ``ty * TILE_CELLS``
        to ``(ty + 1) * TILE_CELLS`` inclusive (fewer at the grid's last row or column)."""
        g, n = self.grid, self.tile_cells
        r0, c0 = ty * n, tx * n
        rows = np.arange(r0, min(r0 + n, g.rows - 1) + 1)
        cols = np.arange(c0, min(c0 + n, g.cols - 1) + 1)
        # The cell centres as Grid.xs()/ys() compute them: the same floats as the full map's.
        xs = g.x0 + (cols + 0.5) * g.resolution
        ys = g.y0 + (rows + 0.5) * g.resolution
        z = height_grid(self.scene, xs, ys)
        return z.astype(np.float32).astype(np.float64)

    def _cells(self, ty: int, tx: int) -> tuple[memoryview, int]:
        """Tile ``(ty, tx)``'s cells as a flat memoryview and its width, made on first use."""
        if len(self._tiles) >= MAX_TILES:
            self._tiles.pop(next(iter(self._tiles)))
        z = self.tile(ty, tx)
        out = self._tiles[(ty, tx)] = (memoryview(np.ascontiguousarray(z).reshape(-1)), z.shape[1])
        return out

    def _bind(self) -> Callable[[float, float], float]:
        g, n, tiles, cells_of = self.grid, self.tile_cells, self._tiles, self._cells
        x0, y0, res = g.x0, g.y0, g.resolution
        xmax, ymax = max(g.cols - 1 - 1e-9, 0.0), max(g.rows - 1 - 1e-9, 0.0)
        last_col, last_row = g.cols - 1, g.rows - 1

        def ground_at(x: float, y: float) -> float:
            # Bilinear between the four cells around the point, read from its tile.
            fx = (x - x0) / res - 0.5
            fy = (y - y0) / res - 0.5
            fx = 0.0 if fx < 0.0 else xmax if fx > xmax else fx
            fy = 0.0 if fy < 0.0 else ymax if fy > ymax else fy
            ix, iy = int(fx), int(fy)
            fx, fy = fx - ix, fy - iy
            tx, ty = ix // n, iy // n
            found = tiles.get((ty, tx))
            cells, width = found if found is not None else cells_of(ty, tx)
            lx, ly = ix - tx * n, iy - ty * n
            jx = lx + 1 if ix < last_col else lx
            row, below = ly * width, (ly + 1 if iy < last_row else ly) * width
            a, b = cells[row + lx], cells[row + jx]
            c, d = cells[below + lx], cells[below + jx]
            top = a + fx * (b - a)
            return top + fy * (c + fx * (d - c) - top)

        return ground_at
