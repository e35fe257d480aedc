"""The scene spec and the generator config: the contract everything compiles from.

>>> from citygen.spec import Scene
>>> s = Scene(format="citygen.scene/1", bounds={"min": [0, 0], "max": [10, 10]})
>>> s.bounds.size
(10.0, 10.0)
"""

from citygen.spec.agents import AGENT_TYPES, Agent, Person, Vehicle
from citygen.spec.base import PRECISION, SpecModel, quantize
from citygen.spec.blocks import (
    BLOCK_TYPES,
    Block,
    Connection,
    Curve,
    Diverge,
    Intersection,
    Junction,
    JunctionArm,
    Merge,
    Pose2,
    Roundabout,
    Socket,
    Straight,
    TIntersection,
)
from citygen.spec.placements import Placement
from citygen.spec.scene import SCENE_FORMAT, Bounds, Meta, Scene
from citygen.spec.surfaces import FRICTION, WALKABLE_ZONES, ZONE_KINDS, ZONE_MATERIAL
from citygen.spec.task import TASK_KINDS, LocoTask, NavTask, Task, TraverseTask
from citygen.spec.terrain import (
    FEATURE_TYPES,
    TILE_TYPES,
    Feature,
    FlatTile,
    LandingFeature,
    RampFeature,
    RoughTile,
    SlopeTile,
    StairTile,
    StepsFeature,
    Terrain,
    Tile,
    edge_profile,
)
from citygen.spec.zones import Zone

__all__ = [
    "AGENT_TYPES",
    "BLOCK_TYPES",
    "FEATURE_TYPES",
    "FRICTION",
    "PRECISION",
    "SCENE_FORMAT",
    "TASK_KINDS",
    "TILE_TYPES",
    "WALKABLE_ZONES",
    "ZONE_KINDS",
    "ZONE_MATERIAL",
    "Agent",
    "Block",
    "Bounds",
    "Connection",
    "Curve",
    "Diverge",
    "Feature",
    "FlatTile",
    "Intersection",
    "Junction",
    "JunctionArm",
    "LandingFeature",
    "LocoTask",
    "Merge",
    "Meta",
    "NavTask",
    "Person",
    "Placement",
    "Pose2",
    "RampFeature",
    "RoughTile",
    "Roundabout",
    "Scene",
    "SlopeTile",
    "Socket",
    "SpecModel",
    "StairTile",
    "StepsFeature",
    "Straight",
    "TIntersection",
    "Task",
    "Terrain",
    "Tile",
    "TraverseTask",
    "Vehicle",
    "Zone",
    "edge_profile",
    "quantize",
]
