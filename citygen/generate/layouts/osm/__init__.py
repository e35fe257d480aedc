"""The ``osm`` layout: a real place, from an OpenStreetMap extract on disk.

The generator config's ``osm`` table names the extract (``.osm`` XML or ``.osm.pbf``) and the
box (:class:`~citygen.spec.osm.OsmArea`); nothing is fetched from the network.
:mod:`.place` reads and projects it. Then the stages run as a city's, on the map's ground:

- stage 1, :mod:`.streets`: the street graph, junctions and road blocks of the mapped streets;
- stage 2, :mod:`.ground`: buildings (solids as tall as mapped, :mod:`.buildings`),
  crosswalks, roadway, curbs, sidewalks, walkways, plazas, parking, water and vegetation as
  mapped, tiling the box, giving way to the mapped furniture and trees (:mod:`.objects`); a
  signal plan at every junction the map gives traffic signals, its lights where the map puts
  them, at every signalised crossing of its own, and at every signalised crossing of
  tram tracks (a pedestrian signal on no street; :func:`_signals`);
- stage 3: the terrain flat (the config's terrain mix; no height source is read), with the
  city's curbs, curb ramps and front steps (:func:`~citygen.generate.layouts.city.terrain.city_features`);
- stage 4: the mapped furniture and trees where the map puts them (:mod:`.objects`), then
  the city's rows of street furniture around them and traffic lights at the signals;
- stage 5 and the task as in the city: people, vehicles on the road blocks, a traverse along
  the sidewalks and crosswalks (around the mapped objects).

The scene's ``meta.source`` records the file's name, the box and the projection; what came
from the map keeps its OSM id in its own id (``building-w45``, ``bench-n123``, ``j-n12``).
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import ClassVar

import numpy as np
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry

from citygen.assets.catalog import CATEGORIES
from citygen.errors import SpecError
from citygen.generate.layouts.base import BaseLayout, Plan
from citygen.generate.layouts.city import City, _corridor
from citygen.generate.layouts.city.furniture import street_furniture
from citygen.generate.layouts.city.terrain import city_features
from citygen.generate.layouts.osm.buildings import with_heights
from citygen.generate.layouts.osm.ground import plan_ground, street_ground
from citygen.generate.layouts.osm.objects import place_mapped
from citygen.generate.layouts.osm.place import Place, check_area, load_place, rooms
from citygen.generate.layouts.osm.project import Projection
from citygen.generate.layouts.osm.streets import blocks as street_blocks
from citygen.generate.placement import base_of, place_objects
from citygen.generate.signals import signalise, signalise_crossing, signalise_walk
from citygen.generate.task import Endpoints, street_route
from citygen.generate.zoning import polygons
from citygen.geometry.features import feature_polygon
from citygen.geometry.roads import block_geometry, block_kind
from citygen.seeding import child, stage_rng
from citygen.spec.config import (
    AgentsConfig,
    GeneratorConfig,
    PlacementConfig,
    TaskConfig,
    TerrainConfig,
    TerrainMix,
)
from citygen.spec.osm import OsmArea
from citygen.spec.placements import Placement
from citygen.spec.scene import Bounds
from citygen.spec.signals import Signal
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

#: Room (m) kept around a mapped object when the traverse route is chosen.
AROUND = 1.0
#: A light or a crosswalk is on the junction arm within this angle (rad) of the heading from
#: the junction's centre to it.
ARM_ANGLE = 0.5


def place_of(config: GeneratorConfig) -> Place:
    """The place a config's ``osm`` table names (read once per process)."""
    if config.osm is None:
        raise SpecError("$.osm: expected an osm table (file, bbox) for layout 'osm', got none")
    return load_place(config.osm)


def osm_config(file: str, bbox: tuple[float, float, float, float], **updates) -> GeneratorConfig:
    """A generator config of the place ``file`` maps in ``bbox`` (``[west, south, east, north]``,
    degrees): its size that of the projected box, flat terrain tiles of 10 m, the city's street
    furniture and no scattered objects besides, a pedestrian every 2,500 m2 and a vehicle every
    10,000 m2, and a wheeled robot's traverse along the sidewalks of at least a third of the
    box's smaller side. ``updates`` replace any of the config's top-level fields.

    >>> cfg = osm_config("tests/data/osm/town.osm", (8.5397, 47.3697, 8.5443, 47.3720))
    >>> cfg.layout, [round(v) for v in cfg.size], cfg.task.kind
    ('osm', [350, 260], 'traverse')
    """
    area = OsmArea(file=str(file), bbox=tuple(float(v) for v in bbox))
    check_area(area)
    size = Projection.for_box(area.bbox).size
    people, vehicles = max(2, round(size[0] * size[1] / 2_500)), round(size[0] * size[1] / 10_000)
    base = GeneratorConfig(
        size=size,
        layout="osm",
        osm=area,
        terrain=TerrainConfig(tile_size=10.0, mix=TerrainMix(flat=1.0, slope=0.0, stair=0.0, rough=0.0)),
        placement=PlacementConfig(count=0),
        agents=AgentsConfig(people=min(people, 2_000), vehicles=min(vehicles, 200)),
        task=TaskConfig(kind="traverse", min_distance=round(min(size) / 3, 1), time_limit=3_600.0),
    )
    return base.model_copy(update=updates)


class Osm(City):
    """A real place (see the module docstring)."""

    kind: ClassVar[str] = "osm"

    @staticmethod
    def plan(bounds: Bounds, config: GeneratorConfig, seed: int) -> Plan:
        place = place_of(config)
        size = place.projection.size
        blocks = street_blocks(list(place.edges), list(place.junctions), size)
        spots = [(m.position, r) for m, r in rooms(place)]
        layers, sidewalks = street_ground(
            list(place.drawn),
            list(place.junctions),
            list(place.crossings),
            spots,
            [(fid, walk) for fid, walk, _ in place.track_crossings],
        )
        room = shapely.union_all([Point(p).buffer(r, quad_segs=4) for p, r in spots])
        zones = plan_ground(size, layers, sidewalks, list(place.walkways), list(place.areas), room)
        zones = with_heights(zones, place.heights)
        signals = _signals(place, blocks, zones) or None
        return Plan(
            zones=zones,
            blocks=blocks,
            signals=signals,
            bounds=Bounds(min=(0.0, 0.0), max=size),
            source=place.source,
        )

    def terrain(
        self, ends: Endpoints | None, walkable: BaseGeometry
    ) -> tuple[Terrain | None, BaseGeometry | None]:
        """The city's terrain and features; the curb ramps narrow beside the mapped objects."""
        terrain, _ = BaseLayout.terrain(self, ends, walkable)
        rng = child(stage_rng(self.seed, "terrain"), 3)
        avoid = [(*m.position, r) for m, r in rooms(place_of(self.config))]
        return city_features(self.scene.zones, terrain, rng, keep_clear=_corridor(ends), avoid=avoid), None

    def endpoints(self, walkable: BaseGeometry) -> Endpoints | None:
        """A traverse runs along the sidewalks and crosswalks, around the mapped objects."""
        if self.config.task.kind != "traverse":
            return BaseLayout.endpoints(self, walkable)
        scene, seed = self.scene, self.seed
        spots = [Point(m.position).buffer(AROUND, quad_segs=4) for m in place_of(self.config).mapped]
        zones = _without(scene.zones, shapely.union_all(spots)) if spots else scene.zones
        return street_route(scene.bounds, zones, self.config.task, stage_rng(seed, "task"), seed=seed)

    def fixed(self, placements: tuple[Placement, ...]) -> frozenset[str]:
        """The mapped objects: a traffic light stands beside them, never moves them."""
        ids = {m.placement_id for m in place_of(self.config).mapped}
        return frozenset(p.id for p in placements if p.id in ids)

    def scatter(
        self, terrain: Terrain | None, ends: Endpoints | None, passable: BaseGeometry, level: float
    ) -> tuple[Placement, ...]:
        """Any scattered objects (no building massing: the buildings are their zones' solids,
        :mod:`.buildings`), the mapped objects (which move the scattered ones they would touch),
        then the city's street furniture around them."""
        place = place_of(self.config)
        others = tuple(c for c in (self.config.placement.categories or CATEGORIES) if c != "building")
        placement = self.config.placement.model_copy(update={"categories": others})
        stage = stage_rng(self.seed, "placement")
        sampled = place_objects(
            self.scene.bounds, self.scene.zones, terrain, placement, stage,
            level=level, ends=ends, seed=self.seed, walkable=passable,
        )  # fmt: skip
        rng = child(stage_rng(self.seed, "placement"), 400)
        lines = shapely.MultiLineString([LineString(s.points) for s in place.streets])
        # Curb ramps stay clear for wheels (street_furniture removes what stands on one): a
        # mapped object moves off a ramp, or takes a slimmer variant, where it can.
        features = (terrain.features or ()) if terrain is not None else ()
        ramps = [feature_polygon(f) for f in features if f.id.startswith("curb-ramp-")]
        mapped, _ = place_mapped(list(place.mapped), list(self.scene.zones), terrain, lines, rng, ramps)
        if mapped:
            tree = shapely.STRtree([base_of(p) for p in mapped])
            sampled = tuple(p for p in sampled if not len(tree.query(base_of(p), predicate="intersects")))
        rows = child(stage_rng(self.seed, "placement"), 300)
        return street_furniture(
            self.scene.zones, terrain, (*sampled, *mapped), rows, keep_clear=_corridor(ends)
        )


def _signals(place: Place, blocks: tuple, zones: tuple[Zone, ...]) -> tuple[Signal, ...]:
    """The place's signal plans (:func:`.place._lights` says what its signals signalise):

    - at each signalised junction's block (:func:`~citygen.generate.signals.signalise`), its
      plan also serving the signalised crossings mapped on its approaches (each with the
      phases its arm has red), the light of an arm standing where the map puts that
      approach's signal (at the road's edge beside it: the stop line is there);
    - at each signalised crossing of its own, on the straight block it lies on
      (:func:`~citygen.generate.signals.signalise_crossing`), or the junction block's, which
      is then signalised;
    - at each signalised crossing of no street (a footway's over tram tracks), a plan of its
      own crosswalk (:func:`~citygen.generate.signals.signalise_walk`).
    """
    walks: dict[str, list[Zone]] = defaultdict(list)
    for z in zones:
        if z.kind == "crosswalk" and z.id.startswith("crosswalk-"):
            walks[z.id.removeprefix("crosswalk-").split("-")[0]].append(z)
    lit = {f"j-n{n}" for n in place.signalised}
    shapes = [block_geometry(b).outline for b in blocks]
    tree = shapely.STRtree(shapes)
    on_straights: dict[str, tuple[list[Zone], list]] = {}
    inside: dict[str, list[str]] = defaultdict(list)  # crossings inside a junction's block
    for fid, xy, lights in place.signal_crossings:
        p = Point(xy)
        hits = sorted(
            tree.query(p, predicate="dwithin", distance=0.5).tolist(),
            key=lambda i: (shapes[i].distance(p), i),
        )
        if not walks.get(fid) or not hits:
            continue
        block = blocks[hits[0]]
        if block.kind == "straight":
            here = on_straights.setdefault(block.id, ([], []))
            here[0].extend(walks[fid])
            here[1].extend(lights)
        elif block_kind(block).signalised:
            lit.add(block.id)
            inside[block.id] += [z.id for z in walks[fid]]
    by_id = {b.id: b for b in blocks}
    plans = []
    for s in signalise([b for b in blocks if b.id in lit], zones):
        node = int(s.junction.removeprefix("j-n")) if s.junction.startswith("j-n") else None
        here = [xy for j, xy in place.approaches if j == node]
        served = [z.id for j, fid in place.junction_walks if j == node for z in walks.get(fid, ())]
        served += inside[s.junction]
        plans.append(_mapped_lights(s, by_id[s.junction], here, served, zones))
    plans += [signalise_crossing(by_id[bid], here, lights) for bid, (here, lights) in on_straights.items()]
    plans += [signalise_walk(walks[fid], ends) for fid, _, ends in place.track_crossings if walks.get(fid)]
    return tuple(plans)


def _mapped_lights(signal: Signal, block, approaches: list, served: list[str], zones) -> Signal:
    """A junction's ``signal`` with the light of each arm where a signal is mapped on it (the
    farthest out), and serving the crosswalks ``served`` (ids) with the phases whose arms do
    not include the one each lies on. An arm is the one within :data:`ARM_ANGLE` of the
    heading from the junction's centre to the light or crosswalk."""
    g = block_geometry(block)
    c = np.asarray(g.centre)

    def arm_of(xy) -> int | None:
        rel = np.asarray(xy) - c
        off = [abs(math.remainder(math.atan2(rel[1], rel[0]) - a.yaw, 2 * math.pi)) for a in g.arms]
        k = int(np.argmin(off))
        return k if off[k] < ARM_ANGLE else None

    heads, moved = list(signal.heads), set()
    for xy in approaches:
        k = arm_of(xy)
        if k is None or k >= len(heads):
            continue
        arm = g.arms[k]
        d = np.array([math.cos(arm.yaw), math.sin(arm.yaw)])
        n = np.array([-d[1], d[0]])
        p = np.asarray(xy) + n * arm.half_width
        if k not in moved or (p - c) @ d > (np.asarray(heads[k].position) - c) @ d:
            heads[k] = heads[k].model_copy(update={"position": _xy(p)})
            moved.add(k)
    polys = {z.id: Polygon(z.polygon, z.holes) for z in zones if z.id in set(served)}
    phases = list(signal.phases)
    for zid in served:
        k = arm_of(polys[zid].centroid.coords[0])
        if k is None:
            continue
        socket = g.arms[k].socket
        for i, p in enumerate(phases):
            if zid not in p.crosswalks and socket not in {lane.split(":")[0] for lane in p.lanes}:
                phases[i] = p.model_copy(update={"crosswalks": (*p.crosswalks, zid)})
    return signal.model_copy(update={"heads": tuple(heads), "phases": tuple(phases)})


def _xy(p) -> tuple[float, float]:
    return (round(float(p[0]), 4) + 0.0, round(float(p[1]), 4) + 0.0)


def _without(zones: tuple[Zone, ...], holes: BaseGeometry) -> list[Zone]:
    """The sidewalk and crosswalk zones with ``holes`` cut out (the rest left out): the ground
    a traverse route may take."""
    out = []
    for z in zones:
        if z.kind not in ("sidewalk", "crosswalk"):
            continue
        for k, part in enumerate(polygons(Polygon(z.polygon, z.holes).difference(holes))):
            ring = tuple(part.exterior.coords)[:-1]
            inner = tuple(tuple(r.coords)[:-1] for r in part.interiors)
            out.append(Zone.model_construct(id=f"{z.id}-{k}", kind=z.kind, polygon=ring, holes=inner))
    return out
