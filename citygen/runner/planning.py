"""Deprecated: ``citygen.runner.planning`` moved to :mod:`citygen.runner.control`
(grid, fields, regions, pursuit, planner).

This module re-exports their public names for one release and warns when imported.
"""

import warnings

from citygen.runner.control.fields import DistanceField, geodesic_distance
from citygen.runner.control.grid import (
    Cell,
    astar,
    line_of_sight,
    path_length,
    path_to_world,
    shortcut,
    snap_free,
)
from citygen.runner.control.planner import Planner
from citygen.runner.control.pursuit import avoid, point_ahead, pure_pursuit
from citygen.runner.control.regions import region_distance, region_path_length

warnings.warn(
    "citygen.runner.planning moved to citygen.runner.control (grid, fields, regions, pursuit, planner)",
    DeprecationWarning,
    stacklevel=2,
)

__all__ = [
    "Cell",
    "DistanceField",
    "Planner",
    "astar",
    "avoid",
    "geodesic_distance",
    "line_of_sight",
    "path_length",
    "path_to_world",
    "point_ahead",
    "pure_pursuit",
    "region_distance",
    "region_path_length",
    "shortcut",
    "snap_free",
]
