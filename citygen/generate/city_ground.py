"""Deprecated: this module is now :mod:`citygen.generate.layouts.city.ground`;
the old name goes in the next release."""

import warnings

from citygen.generate.layouts.city.ground import (
    FACING,
    HOUSE,
    POCKET_PLAZA,
    plan_city_ground,
)

__all__ = ["FACING", "HOUSE", "POCKET_PLAZA", "plan_city_ground"]

warnings.warn(
    "citygen.generate.city_ground is now citygen.generate.layouts.city.ground; "
    "the old name goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
