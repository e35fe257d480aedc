"""Deprecated: this module is now :mod:`citygen.generate.layouts.city.curbs`;
the old name goes in the next release."""

import warnings

from citygen.generate.layouts.city.curbs import (
    BREAK,
    CURB,
    LONGEST,
    MERGE,
    RAMP_GRADE,
    SLAB,
    THINNEST,
    TOP,
    curb_features,
    rectangles,
)

__all__ = [
    "BREAK",
    "CURB",
    "LONGEST",
    "MERGE",
    "RAMP_GRADE",
    "SLAB",
    "THINNEST",
    "TOP",
    "curb_features",
    "rectangles",
]

warnings.warn(
    "citygen.generate.city_curbs is now citygen.generate.layouts.city.curbs; "
    "the old name goes in the next release",
    DeprecationWarning,
    stacklevel=2,
)
