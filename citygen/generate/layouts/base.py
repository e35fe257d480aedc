"""The contract of a layout, and the stages after the ground as most layouts run them.

A *layout* (``GeneratorConfig.layout``) decides how a scene's ground is laid out (stages 1
and 2: :meth:`Layout.plan`, from the ``blocks`` and ``ground`` stages' generators) and how
the later stages fill it: the task's endpoints, the terrain, the objects and the people.
:class:`BaseLayout` runs those later stages for any ground; a layout that does something of
its own (a city's curbs and street furniture, a track's units) overrides the step it
changes and calls the rest as they are. The pipeline (:mod:`citygen.generate.pipeline`)
calls the steps in order and keeps those a rebuild keeps.

Every step draws only from its stage's own generator (:func:`citygen.seeding.stage_rng`),
as it did inside the pipeline.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import ClassVar, Protocol

from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry

from citygen.generate.agents import place_agents
from citygen.generate.placement import place_objects
from citygen.generate.signals import place_lights
from citygen.generate.space import connects, free_space, grid_path, passable_ground, pieces
from citygen.generate.task import Endpoints, choose_endpoints, robot_clearance
from citygen.generate.terrain import build_terrain
from citygen.seeding import stage_rng
from citygen.spec.agents import Person, Vehicle
from citygen.spec.blocks import Block
from citygen.spec.config import GeneratorConfig
from citygen.spec.osm import OsmSource
from citygen.spec.placements import Placement
from citygen.spec.scene import Bounds, Scene
from citygen.spec.signals import Signal
from citygen.spec.task import ROBOTS
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone


@dataclass(frozen=True)
class Plan:
    """Stages 1 and 2 of a scene: its road blocks, the zones tiling it, its junctions' signals;
    a layout whose bounds come from its source (a real place's box) says them and the source."""

    zones: tuple[Zone, ...] = ()
    blocks: tuple[Block, ...] = ()
    signals: tuple[Signal, ...] | None = None
    bounds: Bounds | None = None
    source: OsmSource | None = None


class Layout(Protocol):
    """One layout: its ``kind`` (a value of ``GeneratorConfig.layout``), :meth:`plan` for
    stages 1 and 2, and, made from a scene holding those, the steps of the later stages."""

    kind: ClassVar[str]

    @staticmethod
    def plan(bounds: Bounds, config: GeneratorConfig, seed: int) -> Plan:
        """Stages 1 and 2: the blocks, zones and signals of a scene of ``bounds``."""
        ...

    def __init__(self, scene: Scene, config: GeneratorConfig, seed: int) -> None: ...

    def endpoints(self, walkable: BaseGeometry) -> Endpoints | None:
        """The task's start and goal or route (None for locomotion), before the terrain."""
        ...

    def terrain(
        self, ends: Endpoints | None, walkable: BaseGeometry
    ) -> tuple[Terrain | None, BaseGeometry | None]:
        """Stage 3: the terrain, and the ground the task's robot crosses on it where found on the way."""
        ...

    def objects(
        self, terrain: Terrain | None, ends: Endpoints | None, passable: BaseGeometry, level: float
    ) -> tuple[Placement, ...]:
        """Stage 4 at density ``level``, keeping ``passable`` ground connected for the task."""
        ...

    def people(
        self,
        placements: tuple[Placement, ...],
        ends: Endpoints | None,
        walkable: BaseGeometry,
        level: float,
    ) -> tuple[Person | Vehicle, ...]:
        """Stage 5 at density ``level``."""
        ...


class BaseLayout:
    """What the layouts share: the stages after the ground as most layouts run them, on
    ``scene`` (which holds the outputs of stages 1 and 2) with the generator config and seed it
    came from. A layout subclasses it with its ``kind`` and ``plan`` (see :class:`Layout`)."""

    #: People walk straight lines that stay on walkable ground (a city's streets).
    straight_walks: ClassVar[bool] = False

    def __init__(self, scene: Scene, config: GeneratorConfig, seed: int) -> None:
        self.scene, self.config, self.seed = scene, config, seed

    def endpoints(self, walkable: BaseGeometry) -> Endpoints | None:
        """:func:`~citygen.generate.task.choose_endpoints` on the walkable ground."""
        scene, seed = self.scene, self.seed
        return choose_endpoints(
            scene.bounds, scene.zones, self.config.task, stage_rng(seed, "task"), seed=seed, walkable=walkable
        )

    def terrain(
        self, ends: Endpoints | None, walkable: BaseGeometry
    ) -> tuple[Terrain | None, BaseGeometry | None]:
        """:func:`~citygen.generate.terrain.build_terrain`, flat at the task's endpoints and
        made again with a corridor where it would cut them apart (:func:`keep_crossable`)."""
        scene, config, seed = self.scene, self.config, self.seed
        pins = ends.points if ends is not None else ()
        terrain = build_terrain(
            scene.bounds, scene.zones, config.terrain, stage_rng(seed, "terrain"), seed=seed, flat_at=pins
        )
        if ends is not None and ends.needs_path:
            return keep_crossable(scene.bounds, scene.zones, terrain, walkable, ends, config, seed, pins)
        return terrain, None

    def objects(
        self, terrain: Terrain | None, ends: Endpoints | None, passable: BaseGeometry, level: float
    ) -> tuple[Placement, ...]:
        """:meth:`scatter`, then a traffic light at every signal's corners."""
        placements = self.scatter(terrain, ends, passable, level)
        if self.scene.signals:
            keep = self.fixed(placements)
            placements = place_lights(self.scene.signals, self.scene.zones, placements, terrain, keep)
        return placements

    def fixed(self, placements: tuple[Placement, ...]) -> frozenset[str]:
        """Ids of the objects no traffic light moves (none: the lights' spots come first)."""
        return frozenset()

    def scatter(
        self, terrain: Terrain | None, ends: Endpoints | None, passable: BaseGeometry, level: float
    ) -> tuple[Placement, ...]:
        """:func:`~citygen.generate.placement.place_objects` in the zones that suit them."""
        scene, seed = self.scene, self.seed
        return place_objects(
            scene.bounds,
            scene.zones,
            terrain,
            self.config.placement,
            stage_rng(seed, "placement"),
            level=level,
            ends=ends,
            seed=seed,
            walkable=passable,
        )

    def people(
        self,
        placements: tuple[Placement, ...],
        ends: Endpoints | None,
        walkable: BaseGeometry,
        level: float,
    ) -> tuple[Person | Vehicle, ...]:
        """:func:`~citygen.generate.agents.place_agents` on the walkable ground and the roads."""
        scene, config, seed = self.scene, self.config, self.seed
        return place_agents(
            scene.bounds,
            scene.zones,
            scene.blocks,
            placements,
            config.agents,
            stage_rng(seed, "agents"),
            level=level,
            ends=ends,
            robot_radius=robot_clearance(config.task),
            seed=seed,
            walkable=walkable,
            straight=self.straight_walks,
        )


def keep_crossable(
    bounds: Bounds,
    zones: Sequence[Zone],
    terrain: Terrain | None,
    walkable: BaseGeometry,
    ends: Endpoints,
    config: GeneratorConfig,
    seed: int,
    pins: Sequence[tuple[float, float]],
) -> tuple[Terrain | None, BaseGeometry | None]:
    """The terrain, or when it cuts the task's start from its goal for the task's robot
    (a flight of stairs across the scene for wheels, a slope steeper than it climbs, rough
    ground too bumpy), the terrain made again with a corridor of ground that robot crosses
    along a shortest walkable path between them (:func:`build_terrain`'s ``corridor``): the
    rest of the terrain keeps its stairs, slopes and rough tiles. The same seed gives the
    same corridor and terrain. Also the ground the robot can cross on the terrain returned
    (:func:`passable_ground`) where it was found on the way, else None."""
    mobility = ROBOTS[config.task.robot]
    passable = passable_ground(walkable, terrain, mobility)
    if terrain is None or connects(passable, ends.radius, ends.start, ends.goal):
        return terrain, passable
    piece = next(
        (p for p in pieces(free_space(walkable, (), ends.radius)) if p.covers(Point(ends.start))), None
    )
    path = grid_path(piece, ends.start, ends.goal) if piece is not None else None
    if path is None:  # not connected on walkable ground either: placement reports it
        return terrain, passable
    corridor = LineString(path).buffer(ends.radius, quad_segs=4)
    terrain = build_terrain(
        bounds,
        zones,
        config.terrain,
        stage_rng(seed, "terrain"),
        seed=seed,
        flat_at=pins,
        corridor=corridor,
        mobility=mobility,
    )
    return terrain, None
