"""The compiled ORCA solver (citygen.runner.agents.orca_kernel) against the plain-numpy reference
of citygen.runner.agents.orca: the same velocities to float precision (both also against RVO2
itself in tests/test_crowd.py)."""

from __future__ import annotations

import numpy as np
import pytest

from citygen.runner.agents.orca import orca_velocities


@pytest.mark.parametrize("seed", range(4))
def test_kernel_agrees_with_the_numpy_reference(seed):
    # Batches of crowds from sparse to packed (most agents infeasible: linearProgram3), KD-tree
    # and dense neighbour search, static discs (some absent), non-cooperative agents.
    rng = np.random.default_rng(seed)
    constrained = 0
    for _ in range(12):
        e, n, s = int(rng.integers(1, 3)), int(rng.integers(2, 70)), int(rng.integers(0, 4))
        side = rng.uniform(1.5, 10.0)
        pos, vel = rng.uniform(0, side, (e, n, 2)), rng.normal(0, 1, (e, n, 2))
        pref = rng.normal(0, 1.2, (e, n, 2))
        radius, vmax = rng.uniform(0.2, 0.4, (e, n)), rng.uniform(1, 2, (e, n))
        kw = {"dt": 0.1, "neighbor_dist": 4.0, "max_neighbors": int(rng.integers(1, 12))}
        kw["cooperative"] = rng.random((e, n)) > 0.1
        if s:
            kw["static"] = (rng.uniform(0, side, (e, n, s, 2)), rng.uniform(-0.1, 0.3, (e, n, s)))
        fast = orca_velocities(pos, vel, pref, radius, vmax, **kw)
        ref = orca_velocities(pos, vel, pref, radius, vmax, reference=True, **kw)
        np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-8)
        # the preferred velocity (clipped) left alone means the lines bound nothing
        clipped = pref * np.minimum(1.0, vmax / np.maximum(np.linalg.norm(pref, axis=-1), 1e-12))[..., None]
        constrained += int((np.linalg.norm(fast - clipped, axis=-1) > 1e-6).sum())
    assert constrained > 50  # the lines bound many agents: the linear programs did work


def test_kernel_keeps_a_lone_agent_and_a_standing_obstacle_as_the_reference():
    # One agent, its preferred velocity straight into a disc standing 1 m ahead.
    pos, vel, pref = np.zeros((1, 2)), np.array([[1.0, 0.0]]), np.array([[1.5, 0.0]])
    static = (np.array([[[1.0, 0.0]]]), np.array([[0.3]]))
    fast = orca_velocities(pos, vel, pref, 0.3, 1.5, dt=0.1, static=static)
    ref = orca_velocities(pos, vel, pref, 0.3, 1.5, dt=0.1, static=static, reference=True)
    np.testing.assert_allclose(fast, ref, rtol=0, atol=1e-12)
    assert fast[0, 0] < 1.5 - 0.1  # it slows down for the disc
