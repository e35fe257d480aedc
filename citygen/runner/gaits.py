"""Deprecated: ``citygen.runner.gaits`` moved to citygen.runner.control.gaits.

This module re-exports their public names for one release and warns when imported.
"""

import warnings

from citygen.runner.control.gaits import LEG_ORDER, StandController, TrotController

warnings.warn(
    "citygen.runner.gaits moved to citygen.runner.control.gaits",
    DeprecationWarning,
    stacklevel=2,
)

__all__ = ["LEG_ORDER", "StandController", "TrotController"]
