"""Deprecated: ``citygen.runner.gaits_biped`` moved to citygen.runner.control.gaits_biped.

This module re-exports their public names for one release and warns when imported.
"""

import warnings

from citygen.runner.control.gaits_biped import WALK_SPEED, BipedStand, BipedWalk, leg_ik

warnings.warn(
    "citygen.runner.gaits_biped moved to citygen.runner.control.gaits_biped",
    DeprecationWarning,
    stacklevel=2,
)

__all__ = ["WALK_SPEED", "BipedStand", "BipedWalk", "leg_ik"]
