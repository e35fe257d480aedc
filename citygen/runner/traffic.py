"""Deprecated: ``citygen.runner.traffic`` moved to :mod:`citygen.runner.agents`
(traffic: vehicles, lanes: their paths).

This module re-exports their public names for one release and warns when imported.
"""

import warnings

from citygen.runner.agents.lanes import (
    ARTERIAL,
    CLEARANCE,
    JUNCTION,
    JUNCTIONS,
    LOCAL,
    ROUNDABOUT,
    STEP,
    STOP_MARGIN,
    DrivePath,
    Passage,
    drive_path,
    speed_limit,
)
from citygen.runner.agents.traffic import CANDIDATES, COMFORT, LOOK, CityTraffic, city_agents, rectangles

warnings.warn(
    "citygen.runner.traffic moved to citygen.runner.agents (traffic: vehicles, lanes: their paths)",
    DeprecationWarning,
    stacklevel=2,
)

__all__ = [
    "ARTERIAL",
    "CANDIDATES",
    "CLEARANCE",
    "COMFORT",
    "JUNCTION",
    "JUNCTIONS",
    "LOCAL",
    "LOOK",
    "ROUNDABOUT",
    "STEP",
    "STOP_MARGIN",
    "CityTraffic",
    "DrivePath",
    "Passage",
    "city_agents",
    "drive_path",
    "rectangles",
    "speed_limit",
]
