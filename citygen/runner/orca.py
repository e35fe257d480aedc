"""Deprecated: ``citygen.runner.orca`` moved to citygen.runner.agents.orca.

This module re-exports their public names for one release and warns when imported.
"""

import warnings

from citygen.runner.agents.orca import (
    FAR,
    FEASIBLE_TOL,
    KDTREE_AGENTS,
    RVO_EPSILON,
    half_planes,
    orca_velocities,
)

warnings.warn(
    "citygen.runner.orca moved to citygen.runner.agents.orca",
    DeprecationWarning,
    stacklevel=2,
)

__all__ = ["FAR", "FEASIBLE_TOL", "KDTREE_AGENTS", "RVO_EPSILON", "half_planes", "orca_velocities"]
