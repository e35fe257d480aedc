"""The compiled rough-tile cells (citygen.geometry.pieces_kernel) against the plain-numpy
reference in citygen.geometry.pieces: the same cells in the same order, planes to float
precision, on tiles from gentle to the Urban-Loc test grid's roughest."""

from __future__ import annotations

import math

import numpy as np
import pytest

from citygen.geometry import pieces, pieces_kernel
from citygen.geometry.terrain import tile_grid
from citygen.spec.terrain import RoughTile

SIDE = 4.0  # m: a tile of the test grid is 8 m; a quarter of one shows every case


@pytest.mark.parametrize(
    ("amplitude", "scale", "seed", "tolerance"),
    [(0.05, 1.0, 3, 0.01), (0.2, 0.5, 11, 0.01), (0.2, 2.0, 7, 0.005), (0.12, 0.3, 1, 0.02)],
)
def test_the_kernel_makes_the_references_cells(amplitude, scale, seed, tolerance):
    tile = RoughTile(kind="rough", amplitude=amplitude, scale=scale, seed=seed)
    n = int(min(max(math.ceil(SIDE * pieces.SAMPLES_PER_SCALE / scale), 2), pieces.MAX_SAMPLES))
    g = np.linspace(0.0, SIDE, n + 1)
    z = tile_grid(tile, SIDE, g, g)
    index, plane = pieces_kernel.rough_cells(g, z, tolerance)
    ref_index, ref_plane = pieces._cells_reference(g, z, tolerance)
    assert len(index) > 20  # the tile was split, not one cell
    np.testing.assert_array_equal(index, ref_index)
    np.testing.assert_allclose(plane, ref_plane, rtol=1e-9, atol=1e-12)
    # the cells tile the sample grid once, each within the tolerance or a single cell
    covered = np.zeros((n, n), dtype=int)
    for i0, j0, ni, nj in index:
        covered[i0 : i0 + ni, j0 : j0 + nj] += 1
    assert (covered == 1).all()
    single = (index[:, 2] == 1) & (index[:, 3] == 1)
    assert (plane[~single, 3] <= tolerance).all()
