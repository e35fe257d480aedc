"""Surface materials and what each kind of ground means for a robot.

These tables are the single source of the semantics the exporters, the
occupancy map and the runner share: which zones are walkable, what a surface is
made of and how much grip it gives.
"""

from __future__ import annotations

from types import MappingProxyType
from typing import Literal, get_args

Material = Literal[
    "asphalt",
    "concrete",
    "paving_stone",
    "brick",
    "cobblestone",
    "gravel",
    "grass",
    "soil",
    "mulch",
    "sand",
    "wood",
    "rubber",
    "metal",
    "water",
]
MATERIALS: tuple[str, ...] = get_args(Material)

#: Default sliding friction coefficient of each material (rubber sole or tyre on it).
FRICTION = MappingProxyType(
    {
        "asphalt": 0.8,
        "concrete": 0.75,
        "paving_stone": 0.7,
        "brick": 0.7,
        "cobblestone": 0.6,
        "gravel": 0.55,
        "grass": 0.45,
        "soil": 0.5,
        "mulch": 0.5,
        "sand": 0.4,
        "wood": 0.6,
        "rubber": 0.9,
        "metal": 0.5,
        "water": 0.1,
    }
)

ZoneKind = Literal[
    "roadway",
    "bike_lane",
    "parking",
    "curb",
    "sidewalk",
    "crosswalk",
    "plaza",
    "trail",
    "building",
    "vegetation",
    "water",
]
ZONE_KINDS: tuple[str, ...] = get_args(ZoneKind)

#: Ground a pedestrian or a micromobility robot is meant to move on (the paper's
#: "walkable region"); everything else is non-walkable (roadway, shrubs, lawns ...).
WALKABLE_ZONES = frozenset({"sidewalk", "crosswalk", "plaza", "trail"})

#: The material a zone is made of when its spec does not say.
ZONE_MATERIAL = MappingProxyType(
    {
        "roadway": "asphalt",
        "bike_lane": "asphalt",
        "parking": "asphalt",
        "curb": "concrete",
        "sidewalk": "concrete",
        "crosswalk": "asphalt",
        "plaza": "paving_stone",
        "trail": "gravel",
        "building": "concrete",
        "vegetation": "grass",
        "water": "water",
    }
)

SidewalkStrip = Literal["frontage", "clear", "furnishing"]
"""The three strips of a sidewalk from the building line to the curb (street design guides)."""
