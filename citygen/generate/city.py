"""Deprecated: this module is now :mod:`citygen.generate.layouts.city.streets`;
the old name goes in the next release."""

import warnings

from citygen.generate.layouts.city.streets import (
    DIRECTIONS,
    MIN_SEGMENT,
    CityPlan,
    plan_city,
)

__all__ = ["DIRECTIONS", "MIN_SEGMENT", "CityPlan", "plan_city"]

warnings.warn(
    "citygen.generate.city is now citygen.generate.layouts.city.streets; "
    "the old name goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
