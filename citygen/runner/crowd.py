"""Deprecated: ``citygen.runner.crowd`` moved to citygen.runner.agents (crowd: people, traffic: vehicles).

This module re-exports their public names for one release and warns when imported.
"""

import warnings

from citygen.runner.agents.crowd import (
    ARRIVE,
    JITTER,
    LOOKAHEAD,
    MAX_NAV_NODES,
    NAV_CELL,
    OVERLAP_SLACK,
    ROBOT_MARGIN,
    SPEED_FACTOR,
    Crowd,
)
from citygen.runner.agents.lanes import lane_path
from citygen.runner.agents.orca import orca_velocities
from citygen.runner.agents.traffic import IDM_ACCEL, IDM_BRAKE, IDM_GAP, IDM_HEADWAY, LOOK_AHEAD, Traffic

warnings.warn(
    "citygen.runner.crowd moved to citygen.runner.agents (crowd: people, traffic: vehicles)",
    DeprecationWarning,
    stacklevel=2,
)

__all__ = [
    "ARRIVE",
    "IDM_ACCEL",
    "IDM_BRAKE",
    "IDM_GAP",
    "IDM_HEADWAY",
    "JITTER",
    "LOOKAHEAD",
    "LOOK_AHEAD",
    "MAX_NAV_NODES",
    "NAV_CELL",
    "OVERLAP_SLACK",
    "ROBOT_MARGIN",
    "SPEED_FACTOR",
    "Crowd",
    "Traffic",
    "lane_path",
    "orca_velocities",
]
