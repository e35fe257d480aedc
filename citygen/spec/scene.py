"""The scene spec: one concrete, sampled scene, everything an exporter needs.

Metres, radians and seconds; Z up, right-handed; yaw counter-clockwise about +Z.
The top-level keys (``$schema``, ``format``, ``meta``, ``bounds``, ``blocks``, ``zones``,
``terrain``, ``placements``, ``agents``, ``task``, ``signals``) are a public contract that other
simulators read.
"""

from __future__ import annotations

from typing import Literal

from pydantic import Field

from citygen.spec import limits
from citygen.spec.agents import Agent
from citygen.spec.base import Identifier, SpecModel, Vec2, bounded_int
from citygen.spec.blocks import Block
from citygen.spec.osm import OsmSource
from citygen.spec.placements import Placement
from citygen.spec.signals import Signal
from citygen.spec.task import Task
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

SCENE_FORMAT = "citygen.scene/1"


class Meta(SpecModel):
    """Where the scene came from."""

    generator: str | None = Field(default=None, max_length=200)
    """What wrote the scene, for example ``citygen 0.1.0``; left out in hand-written scenes."""
    split: Identifier | None = None
    """The named split the scene belongs to, for example ``urban-nav-2-train``."""
    index: bounded_int(0, limits.MAX_SCENE_INDEX) | None = None
    """The scene's index within its split."""
    seed: bounded_int(0, 2**64 - 1) | None = None
    """The scene's own seed, derived from the split's master seed and the index."""
    description: str | None = Field(default=None, max_length=limits.MAX_TEXT)
    """Free text for people reading the file."""
    source: OsmSource | None = None
    """The OpenStreetMap extract, box and projection a real place came from (``layout = "osm"``)."""


class Bounds(SpecModel):
    """The axis-aligned rectangle the scene occupies."""

    min: Vec2
    """Minimum ``[x, y]`` corner in metres."""
    max: Vec2
    """Maximum ``[x, y]`` corner in metres."""

    @property
    def size(self) -> tuple[float, float]:
        return (self.max[0] - self.min[0], self.max[1] - self.min[1])


class Scene(SpecModel):
    """A citygen scene: road blocks, zones, terrain, objects, agents and a task."""

    schema_: str | None = Field(default=None, alias="$schema", max_length=1_000)
    """Path or URL of ``scene.schema.json``, so editors validate and complete while you type."""
    format: Literal["citygen.scene/1"]
    """The version of this format."""
    meta: Meta = Meta()
    bounds: Bounds
    blocks: tuple[Block, ...] = Field(default=(), max_length=limits.MAX_BLOCKS)
    """Road blocks, each connected to others by sockets."""
    zones: tuple[Zone, ...] = Field(default=(), max_length=limits.MAX_ZONES)
    """Functional zones; they never overlap."""
    terrain: Terrain | None = None
    """The terrain tile grid; without one the ground is flat at z = 0."""
    placements: tuple[Placement, ...] = Field(default=(), max_length=limits.MAX_PLACEMENTS)
    """Static objects."""
    agents: tuple[Agent, ...] = Field(default=(), max_length=limits.MAX_AGENTS)
    """Pedestrians, cyclists, scooter riders and vehicles."""
    task: Task | None = None
    """The benchmark task; scenes made only to look at or to export may have none."""
    signals: tuple[Signal, ...] | None = Field(default=None, max_length=limits.MAX_BLOCKS)
    """Signalised junctions (left out where no junction has traffic lights)."""
