"""The ``track`` layout (Urban-Tra-Standard): units side by side along +x, run in laps.

:class:`~citygen.spec.config.TrackUnit` units lie side by side along +x, one walkable zone each
(``unit-1`` ...). The terrain keeps the even units flat at street level (they are handed to
the terrain stage as hard ground) and fills the uneven ones with WFC tiles of the mix; static
and dynamic units get ``placement.count`` objects each, dynamic units ``agents.people`` people
each, who walk inside their unit. A traverse task on a track runs laps: out along the lane a
quarter of the depth from one side, back along the lane a quarter from the other, turning a
quarter of the depth from the ends, until the route is at least ``track.route_length`` long.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import ClassVar

from shapely.geometry.base import BaseGeometry

from citygen.errors import GenerationError
from citygen.generate.agents import place_agents
from citygen.generate.layouts.base import BaseLayout, Plan
from citygen.generate.placement import place_objects
from citygen.generate.space import walkable_ground, zone_polygon
from citygen.generate.task import LEG, Endpoints, robot_clearance
from citygen.generate.terrain import build_terrain
from citygen.seeding import child, stage_rng
from citygen.spec.agents import Person, Vehicle
from citygen.spec.config import GeneratorConfig, TaskConfig, TrackConfig
from citygen.spec.placements import Placement
from citygen.spec.scene import Bounds, Scene
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone


def _unit_box(bounds: Bounds, cfg: TrackConfig, u: int) -> Bounds:
    x0 = bounds.min[0] + u * cfg.unit_length
    return Bounds(min=(x0, bounds.min[1]), max=(x0 + cfg.unit_length, bounds.max[1]))


def _rect(b: Bounds) -> tuple[tuple[float, float], ...]:
    (x0, y0), (x1, y1) = b.min, b.max
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))


def track_zones(bounds: Bounds, cfg: TrackConfig, *, seed: int | None = None) -> tuple[Zone, ...]:
    """One walkable zone per unit of a track, ``unit-1`` at the minimum x onwards.

    >>> from citygen.spec.config import TrackConfig
    >>> zones = track_zones(Bounds(min=(0, 0), max=(120, 10)), TrackConfig())
    >>> [z.id for z in zones][:2], zones[5].polygon[1], zones[0].kind
    (['unit-1', 'unit-2'], (120.0, 0.0), 'plaza')
    """
    span = len(cfg.units) * cfg.unit_length
    if abs(span - bounds.size[0]) > 1e-4:
        raise GenerationError(
            "ground",
            seed,
            f"{len(cfg.units)} track units of {cfg.unit_length:g} m span {span:g} m, "
            f"not the scene's width of {bounds.size[0]:g} m",
        )
    return tuple(
        Zone(id=f"unit-{u + 1}", kind=unit.zone, polygon=_rect(_unit_box(bounds, cfg, u)))
        for u, unit in enumerate(cfg.units)
    )


class Track(BaseLayout):
    """The stages of a track scene that go unit by unit."""

    kind: ClassVar[str] = "track"

    @staticmethod
    def plan(bounds: Bounds, config: GeneratorConfig, seed: int) -> Plan:
        return Plan(zones=track_zones(bounds, config.track, seed=seed))

    def __init__(self, scene: Scene, config: GeneratorConfig, seed: int):
        super().__init__(scene, config, seed)
        cfg = self.cfg = config.track
        self.bounds = scene.bounds
        span = len(cfg.units) * cfg.unit_length
        if abs(span - scene.bounds.size[0]) > 1e-4:
            raise GenerationError(
                "ground",
                seed,
                f"the config's {len(cfg.units)} track units of {cfg.unit_length:g} m span {span:g} m, "
                f"not the scene's width of {scene.bounds.size[0]:g} m",
            )
        self.boxes = [_unit_box(scene.bounds, cfg, u) for u in range(len(cfg.units))]
        # A unit's zones: those whose inner point lies in it (the unit's own zone, or what a
        # hand edit divided it into).
        inner = [zone_polygon(z).representative_point() for z in scene.zones]
        self.zones = [
            tuple(
                z
                for z, p in zip(scene.zones, inner, strict=True)
                if b.min[0] <= p.x <= b.max[0] and b.min[1] <= p.y <= b.max[1]
            )
            for b in self.boxes
        ]

    def endpoints(self, walkable: BaseGeometry) -> Endpoints | None:
        """A traverse runs :meth:`laps`; any other task's endpoints are chosen as anywhere."""
        if self.config.task.kind == "traverse":
            return self.laps(self.config.task)
        return super().endpoints(walkable)

    def terrain(
        self, ends: Endpoints | None, walkable: BaseGeometry
    ) -> tuple[Terrain | None, BaseGeometry | None]:
        """The uneven units' WFC tiles, the even units flat (:meth:`even_ground`); the robot
        starts on flat ground and the rest of its laps cross the uneven units."""
        scene, seed = self.scene, self.seed
        pins = ends.points if ends is not None else ()
        pins = [ends.start] if ends is not None and ends.route else pins
        zones = (*self.even_ground(), *scene.zones)
        terrain = build_terrain(
            scene.bounds, zones, self.config.terrain, stage_rng(seed, "terrain"), seed=seed, flat_at=pins
        )
        return terrain, None

    def even_ground(self) -> list[Zone]:
        """The even units as hard ground for the terrain stage, which keeps it flat at 0 m
        (the kind is one of :data:`citygen.generate.terrain.HARD_ZONES`); never in the scene."""
        return [
            Zone(id=f"even-{u + 1}", kind="roadway", polygon=_rect(b))
            for u, (unit, b) in enumerate(zip(self.cfg.units, self.boxes, strict=True))
            if unit.surface == "even"
        ]

    def laps(self, task: TaskConfig) -> Endpoints:
        """The traverse route: laps of the track (see the module docstring), legs of at most
        :data:`~citygen.generate.task.LEG` metres, ending where it starts."""
        (x0, y0), (x1, y1) = self.bounds.min, self.bounds.max
        radius = robot_clearance(task)
        lane = (y1 - y0) / 4
        if lane < radius or x1 - x0 <= 2 * lane:
            raise GenerationError(
                "task",
                self.seed,
                f"a {x1 - x0:g} m x {y1 - y0:g} m track has no room for two lanes of laps for the "
                f"{task.robot} robot ({2 * radius:g} m across); make the track deeper",
            )
        corners = [
            (x0 + lane, y0 + lane),
            (x1 - lane, y0 + lane),
            (x1 - lane, y1 - lane),
            (x0 + lane, y1 - lane),
        ]
        lap = 2 * (x1 - x0 - 2 * lane) + 2 * (y1 - y0 - 2 * lane)
        laps = max(1, math.ceil(self.cfg.route_length / lap - 1e-9))
        route: list[tuple[float, float]] = []
        here = corners[0]
        for _ in range(laps):
            for there in (*corners[1:], corners[0]):
                n = max(1, math.ceil(math.dist(here, there) / LEG - 1e-9))
                route += [
                    (here[0] + (there[0] - here[0]) * j / n, here[1] + (there[1] - here[1]) * j / n)
                    for j in range(1, n + 1)
                ]
                here = there
        rounded = tuple((round(x, 3) + 0.0, round(y, 3) + 0.0) for x, y in route)
        start = (round(corners[0][0], 3) + 0.0, round(corners[0][1], 3) + 0.0)
        return Endpoints(start, 0.0, None, rounded, radius=radius)

    def _units(self, settings: Sequence[str]) -> list[int]:
        return [u for u, unit in enumerate(self.cfg.units) if unit.setting in settings]

    def _walkable(self, u: int) -> BaseGeometry:
        b = self.boxes[u]
        return walkable_ground(self.zones[u], (*b.min, *b.max))

    def objects(
        self, terrain: Terrain | None, ends: Endpoints | None, passable: BaseGeometry, level: float
    ) -> tuple[Placement, ...]:
        """Stage 4 in every static and dynamic unit, each from its own child generator."""
        rng = stage_rng(self.seed, "placement")
        found = []
        for u in self._units(("static", "dynamic")):
            found += place_objects(
                self.boxes[u],
                self.zones[u],
                terrain,
                self.config.placement,
                child(rng, u),
                level=level,
                ends=ends,
                seed=self.seed,
                walkable=self._walkable(u),
            )
        return _renumbered(found)

    def people(
        self,
        placements: tuple[Placement, ...],
        ends: Endpoints | None,
        walkable: BaseGeometry,
        level: float,
    ) -> tuple[Person | Vehicle, ...]:
        """Stage 5 in every dynamic unit: people who start and end in it."""
        rng = stage_rng(self.seed, "agents")
        found = []
        for u in self._units(("dynamic",)):
            found += place_agents(
                self.boxes[u],
                self.zones[u],
                (),
                placements,
                self.config.agents,
                child(rng, u),
                level=level,
                ends=ends,
                robot_radius=robot_clearance(self.config.task),
                seed=self.seed,
                walkable=self._walkable(u),
            )
        return _renumbered(found)


def _renumbered(items: list) -> tuple:
    """Items of several units with ids numbered across the scene (``bench-3``), in order."""
    counts: dict[str, int] = {}
    out = []
    for item in items:
        stem = item.id.rpartition("-")[0] or item.id
        counts[stem] = counts.get(stem, 0) + 1
        out.append(item.model_copy(update={"id": f"{stem}-{counts[stem]}"}))
    return tuple(out)
