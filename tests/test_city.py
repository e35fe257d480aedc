"""``layout = "city"``: a street grid that closes into city blocks, the ground of each city
block, people along the streets and a traverse on the sidewalks (issue 19).

The scenes here are small cities (450 m) so the tests stay quick; the 1,200 m split's
figures for 10 seeds are measured by ``benchmarks/bench_city.py``.
"""

from __future__ import annotations

import itertools
import math
from functools import cache

import networkx as nx
import pytest
import shapely
from shapely.geometry import LineString, Point, Polygon, box

import citygen
from citygen.errors import GenerationError
from citygen.generate import generate
from citygen.generate.layouts.city.streets import plan_city
from citygen.generate.pipeline import layout
from citygen.geometry.roads import block_geometry, road_graph
from citygen.seeding import stage_rng
from citygen.spec.config import (
    AgentsConfig,
    CityConfig,
    GeneratorConfig,
    PlacementConfig,
    TaskConfig,
    check_config,
)
from citygen.spec.scene import Bounds
from citygen.spec.surfaces import WALKABLE_ZONES
from tests.test_layout import tiling_error

SMALL = GeneratorConfig(
    size=(450.0, 450.0),
    layout="city",
    city=CityConfig(roundabout_share=0.5, grid_irregularity=0.3),
    placement=PlacementConfig(count=200),
    agents=AgentsConfig(people=30, vehicles=4),
    task=TaskConfig(kind="traverse", robot="quadruped", min_distance=300.0, time_limit=600.0),
)


@cache
def small_city(seed: int):
    return generate(SMALL, seed)


def polygons(scene, *kinds):
    return [Polygon(z.polygon, z.holes) for z in scene.zones if z.kind in kinds]


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_the_street_plan_is_connected_without_dead_ends_and_sockets_meet(seed):
    cfg = GeneratorConfig(size=(1200.0, 1200.0), layout="city", city=CityConfig(roundabout_share=0.3))
    bounds = Bounds(min=(0, 0), max=cfg.size)
    plan = plan_city(bounds, cfg.city, cfg.blocks, cfg.ground, stage_rng(seed, "blocks"), seed=seed)
    graph = road_graph(plan.blocks)
    assert nx.is_connected(graph)
    kinds = {b.kind for b in plan.blocks}
    assert {"straight", "intersection", "t_intersection", "curve", "roundabout"} <= kinds
    by_id = {b.id: b for b in plan.blocks}
    for block in plan.blocks:
        # Every road end meets another: no dead ends at all.
        assert {c.socket for c in block.connections} == {s.id for s in block.sockets}, block.id
        for c in block.connections:
            mine = next(s for s in block.sockets if s.id == c.socket).pose
            theirs = next(s for s in by_id[c.block].sockets if s.id == c.to_socket).pose
            assert math.dist(mine.position, theirs.position) < 1e-3
            assert abs(math.remainder(mine.yaw - theirs.yaw - math.pi, 2 * math.pi)) < 1e-3
    # Roads of blocks that do not meet keep apart; joined ones only touch.
    outlines = [block_geometry(b).outline for b in plan.blocks]
    joined = {frozenset((b.id, c.block)) for b in plan.blocks for c in b.connections}
    tree = shapely.STRtree(outlines)
    for i, j in zip(*tree.query(outlines, predicate="intersects"), strict=True):
        if i < j:
            pair = frozenset((plan.blocks[i].id, plan.blocks[j].id))
            assert pair in joined, pair
            assert outlines[i].intersection(outlines[j]).area < 0.05, pair
    # Streets of two classes: arterials are wider than local streets.
    assert {b.lanes for b in plan.blocks if b.kind == "straight"} == {1, 2}
    # City blocks (between street centre lines) of 80-250 m.
    for line in plan.lines:
        gaps = [b - a for a, b in itertools.pairwise(line)]
        assert min(gaps) >= 80.0 and max(gaps) <= 250.0


def test_a_city_tiles_its_ground_validates_and_is_built_along_its_streets():
    scene = layout(SMALL, 5)
    gap, overlap = tiling_error(scene)
    assert gap < 1e-6 and overlap < 1e-6
    assert citygen.validate(scene) == []
    kinds = {z.kind for z in scene.zones}
    assert {"roadway", "curb", "sidewalk", "crosswalk", "building", "vegetation"} <= kinds
    area = box(*scene.bounds.min, *scene.bounds.max)
    road = shapely.union_all(polygons(scene, "roadway", "crosswalk"))
    closed = [
        p
        for p in shapely.get_parts(area.difference(road))
        if p.area > 2_500 and not p.intersects(area.exterior)
    ]
    assert len(closed) >= 4
    assert road.buffer(60.0).intersection(area).area >= 0.9 * area.area
    sidewalk = shapely.union_all(polygons(scene, "sidewalk"))
    buildings = polygons(scene, "building")
    assert sum(b.area for b in buildings) >= 0.15 * area.area
    assert sum(sidewalk.distance(b) <= 12.0 for b in buildings) >= 0.8 * len(buildings)
    # Every junction arm has its crosswalk.
    walks = polygons(scene, "crosswalk")
    for block in scene.blocks:
        if block.kind in ("intersection", "t_intersection", "roundabout"):
            g = block_geometry(block)
            for site in g.crossings:
                d = (math.cos(site.yaw), math.sin(site.yaw))
                at = (
                    site.origin[0] + (site.offset + 1.0) * d[0],
                    site.origin[1] + (site.offset + 1.0) * d[1],
                )
                assert any(w.distance(Point(at)) < 0.5 for w in walks), (block.id, at)


def test_city_people_walk_along_walkable_ground_and_the_route_follows_the_sidewalks():
    scene = small_city(7)
    assert citygen.validate(scene) == []
    walkable = shapely.union_all(polygons(scene, *WALKABLE_ZONES)).buffer(1e-6)
    people = [a for a in scene.agents if a.kind != "vehicle"]
    assert len(people) == 30
    for person in people:
        # A straight walk from start to goal never crosses a lawn, a road or a building.
        assert walkable.covers(LineString([person.start, person.goal])), person.id
        assert math.dist(person.start, person.goal) >= 5.0
    assert sum(a.kind == "vehicle" for a in scene.agents) == 4
    streets = shapely.union_all(polygons(scene, "sidewalk", "crosswalk")).buffer(1e-6)
    route = [scene.task.start.position, *scene.task.route]
    assert streets.covers(LineString(route))
    assert sum(math.dist(p, q) for p, q in itertools.pairwise(route)) >= 300.0


def test_the_same_seed_gives_the_same_city():
    assert citygen.io.dumps(layout(SMALL, 9)) == citygen.io.dumps(layout(SMALL, 9))


def test_a_scene_too_small_for_a_city_is_a_clear_generation_error():
    with pytest.raises(GenerationError, match="too small for a city's streets"):
        layout(GeneratorConfig(size=(100.0, 100.0), layout="city"), 0)


def test_city_ranges_are_checked():
    problems = check_config(GeneratorConfig(city=CityConfig(street_spacing=(150.0, 100.0))))
    assert [p.path for p in problems] == ["$.city.street_spacing"]
    with pytest.raises(ValueError):
        CityConfig(arterial_share=1.5)
