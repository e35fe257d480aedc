"""Deprecated: this module is now :mod:`citygen.generate.layouts.city.terrain`;
the old name goes in the next release."""

import warnings

from citygen.generate.layouts.city.terrain import (
    FRONT_REACH,
    FRONT_STEPS,
    RAMP_GRADE,
    RISER,
    SOFT,
    TERRACE_AREA,
    TERRACE_SHARE,
    TREAD,
    city_features,
)

__all__ = [
    "FRONT_REACH",
    "FRONT_STEPS",
    "RAMP_GRADE",
    "RISER",
    "SOFT",
    "TERRACE_AREA",
    "TERRACE_SHARE",
    "TREAD",
    "city_features",
]

warnings.warn(
    "citygen.generate.city_terrain is now citygen.generate.layouts.city.terrain; "
    "the old name goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
