"""citygen.geometry.features: the buckets of the terrain features' index, computed for all
features at once, are those one ``np.mgrid`` per feature gave, in the same order."""

from __future__ import annotations

import numpy as np

from citygen.geometry.features import _buckets


def _buckets_reference(i0, i1, j0, j1, nx):
    ids, owners = [], []
    for k in range(len(i0)):
        jj, ii = np.mgrid[j0[k] : j1[k] + 1, i0[k] : i1[k] + 1]
        ids.append((jj * nx + ii).ravel())
        owners.append(np.full(jj.size, k))
    return np.concatenate(ids), np.concatenate(owners)


def test_the_buckets_are_the_ones_a_grid_per_feature_gave():
    rng = np.random.default_rng(0)
    i0, j0 = rng.integers(0, 40, 300), rng.integers(0, 30, 300)
    i1, j1 = i0 + rng.integers(0, 5, 300), j0 + rng.integers(0, 4, 300)
    nx = int(i1.max()) + 1
    got, want = _buckets(i0, i1, j0, j1, nx), _buckets_reference(i0, i1, j0, j1, nx)
    assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
    assert len(got[0]) > 300  # features over several buckets
