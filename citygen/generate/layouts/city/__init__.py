"""The ``city`` layout: a city's street grid of city blocks, its curbs, furniture and signals.

- stage 1, :mod:`.streets`: the street plan (:func:`~.streets.plan_city`, from the ``blocks``
  stage's generator), written in road blocks;
- stage 2, :mod:`.ground`: the ground of each city block (:func:`~.ground.plan_city_ground`,
  from the ``ground`` stage's generator), and a signal plan at every junction with traffic
  lights (:func:`~citygen.generate.signals.signalise`);
- stage 3, :mod:`.terrain` and :mod:`.curbs`: front steps, terraces, raised sidewalks and
  curb ramps as terrain features (:func:`~.terrain.city_features`, from child 3 of the
  ``terrain`` stage's generator) on the terrain grid;
- stage 4, :mod:`.furniture`: street furniture along the sidewalks by frontage
  (:func:`~.furniture.street_furniture`, from child 300 of the ``placement`` stage's
  generator) after the scattered objects, then the traffic lights;
- stage 5: people walk straight lines that stay on walkable ground.

A traverse task here runs along the sidewalks and crosswalks
(:func:`~citygen.generate.task.street_route`); the features and the furniture keep clear of
its corridor.
"""

from __future__ import annotations

from typing import ClassVar

from shapely.geometry import LineString
from shapely.geometry.base import BaseGeometry

from citygen.generate.layouts.base import BaseLayout, Plan
from citygen.generate.layouts.city.furniture import street_furniture
from citygen.generate.layouts.city.ground import plan_city_ground
from citygen.generate.layouts.city.streets import plan_city
from citygen.generate.layouts.city.terrain import city_features
from citygen.generate.signals import signalise
from citygen.generate.task import Endpoints, street_route
from citygen.seeding import child, stage_rng
from citygen.spec.config import GeneratorConfig
from citygen.spec.placements import Placement
from citygen.spec.scene import Bounds
from citygen.spec.terrain import Terrain


class City(BaseLayout):
    """A city: its streets, city blocks, curbs, furniture and signals (see the module docstring)."""

    kind: ClassVar[str] = "city"
    straight_walks: ClassVar[bool] = True

    @staticmethod
    def plan(bounds: Bounds, config: GeneratorConfig, seed: int) -> Plan:
        plan = plan_city(
            bounds, config.city, config.blocks, config.ground, stage_rng(seed, "blocks"), seed=seed
        )
        zones = plan_city_ground(
            bounds, plan, config.ground, config.city, stage_rng(seed, "ground"), seed=seed
        )
        return Plan(zones=zones, blocks=plan.blocks, signals=signalise(plan.blocks, zones))

    def endpoints(self, walkable: BaseGeometry) -> Endpoints | None:
        """A traverse runs along the streets' sidewalks and crosswalks."""
        if self.config.task.kind == "traverse":
            scene, seed = self.scene, self.seed
            return street_route(
                scene.bounds, scene.zones, self.config.task, stage_rng(seed, "task"), seed=seed
            )
        return super().endpoints(walkable)

    def terrain(
        self, ends: Endpoints | None, walkable: BaseGeometry
    ) -> tuple[Terrain | None, BaseGeometry | None]:
        """The terrain grid, then the city's features on it (which change what the robot crosses)."""
        terrain, _ = super().terrain(ends, walkable)
        rng = child(stage_rng(self.seed, "terrain"), 3)
        return city_features(self.scene.zones, terrain, rng, keep_clear=_corridor(ends)), None

    def scatter(
        self, terrain: Terrain | None, ends: Endpoints | None, passable: BaseGeometry, level: float
    ) -> tuple[Placement, ...]:
        """The scattered objects, then the street furniture."""
        placements = super().scatter(terrain, ends, passable, level)
        rng = child(stage_rng(self.seed, "placement"), 300)
        return street_furniture(self.scene.zones, terrain, placements, rng, keep_clear=_corridor(ends))


def _corridor(ends: Endpoints | None) -> BaseGeometry | None:
    """The ground a city's features keep clear of: the robot's corridor along the route."""
    if ends is None:
        return None
    line = LineString([ends.start, *ends.route]) if ends.route else LineString([ends.start, ends.start])
    return line.buffer(ends.radius + 0.3, quad_segs=4)
