"""Deprecated: this module is now :mod:`citygen.generate.layouts.city.furniture`;
the old name goes in the next release."""

import warnings

from citygen.generate.layouts.city.furniture import (
    EVERYWHERE,
    GAP,
    LEVEL,
    NARROW,
    ROWS,
    street_furniture,
)

__all__ = ["EVERYWHERE", "GAP", "LEVEL", "NARROW", "ROWS", "street_furniture"]

warnings.warn(
    "citygen.generate.city_furniture is now citygen.generate.layouts.city.furniture; "
    "the old name goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
