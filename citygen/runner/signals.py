"""Deprecated: ``citygen.runner.signals`` moved to citygen.runner.agents.signals.

This module re-exports their public names for one release and warns when imported.
"""

import warnings

from citygen.runner.agents.signals import Crossings, SignalCrowd, SignalPlan, crossings_of

warnings.warn(
    "citygen.runner.signals moved to citygen.runner.agents.signals",
    DeprecationWarning,
    stacklevel=2,
)

__all__ = ["Crossings", "SignalCrowd", "SignalPlan", "crossings_of"]
