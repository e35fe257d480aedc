"""Real places (issue 48): the corner (tests/data/osm/corner.osm, made by make_town.py's
write_corner, CC0), a 160 m x 90 m extract of what a real map puts where a scene draws its
streets: furniture and trees on the drawn roadway, in a rounded corner, on a curb ramp, in a
cycleway and a parking lot; signals on a junction's approach, signalised crossings beside a
junction and mid-block, a signal node mid-block. Checked against the extract as read here
with pyosmium and the scene's own recorded projection."""

from __future__ import annotations

import math

import numpy as np
import osmium
import pytest
import shapely
from pyproj import Transformer
from shapely.geometry import Point, Polygon, box

import citygen
from citygen.generate.layouts.osm.objects import category_of
from citygen.generate.placement import base_of
from citygen.generate.places import generate_place
from citygen.geometry.features import feature_polygon
from citygen.geometry.roads import block_geometry
from citygen.runner.agents.traffic import CityTraffic
from citygen.spec.config import AgentsConfig
from tests.conftest import ROOT

CORNER = ROOT / "tests" / "data" / "osm" / "corner.osm"
#: make_town.CORNER_BOX in degrees.
BOX = (8.53920417, 47.36959576, 8.54132639, 47.37040424)


@pytest.fixture(scope="module")
def corner():
    return generate_place(CORNER, BOX, seed=0, agents=AgentsConfig(people=4, vehicles=8))


@pytest.fixture(scope="module")
def nodes(corner):
    """The extract's tagged nodes inside the box: OSM id to (scene xy, tags)."""
    t = Transformer.from_crs("EPSG:4326", corner.meta.source.projection, always_xy=True)
    frame = box(*corner.bounds.min, *corner.bounds.max)
    out = {}
    for obj in osmium.FileProcessor(str(CORNER)):
        if isinstance(obj, osmium.osm.Node) and obj.tags:
            xy = t.transform(obj.location.lon, obj.location.lat)
            if frame.contains(Point(xy)):
                out[f"n{obj.id}"] = (xy, dict(obj.tags))
    return out


def test_every_mapped_object_stands_within_half_a_metre_of_its_point(corner, nodes):
    # Before the ground gave way, 5 of the 6 trees were left out: on the roadway of a street
    # drawn 6 m wide, in a corner rounded over it, on a curb ramp, in a cycleway, in parking.
    assert citygen.validate(corner) == []
    placed = {p.id.rsplit("-", 1)[1]: p for p in corner.placements}
    mapped = {nid: (xy, tags) for nid, (xy, tags) in nodes.items() if category_of(tags)}
    assert sorted(category_of(t) for _, t in mapped.values()) == ["bench"] + ["tree"] * 5
    for nid, (xy, tags) in mapped.items():
        assert nid in placed, (nid, tags)
        p = placed[nid]
        assert p.asset.startswith(category_of(tags) + "/") and math.dist(p.position[:2], xy) <= 0.5, nid


def test_the_ground_gives_way_where_the_map_puts_an_object(corner, nodes):
    zones = [(z, Polygon(z.polygon, z.holes)) for z in corner.zones]
    trees = [Point(xy) for xy, tags in nodes.values() if tags.get("natural") == "tree"]
    for p in trees:  # no tree point is on a roadway, curb, bike lane or parking zone
        under = [z.kind for z, poly in zones if poly.covers(p)]
        assert under and set(under) <= {"sidewalk", "vegetation", "plaza", "trail"}, under
    # The street with a tree 2.9 m from its centre line is narrowed beside it (not below
    # 2.5 m a lane); the crosswalk's curb ramp where a tree stands narrows beside it.
    road = shapely.union_all([poly for z, poly in zones if z.kind == "roadway"])
    tree = min(trees, key=lambda q: road.distance(q))
    assert road.distance(tree) > 0.15
    ramps = [(f, feature_polygon(f)) for f in corner.terrain.features if f.id.startswith("curb-ramp-")]
    bases = [base_of(p) for p in corner.placements if p.id.startswith("tree-n")]
    beside = [f for f, r in ramps if min(r.distance(b) for b in bases) < 0.5]
    assert beside and all(f.width < 3.0 for f in beside)  # narrower than its crosswalk
    assert not any(r.intersects(b) for _, r in ramps for b in bases)


def signal_nodes(nodes) -> dict:
    """The mapped signal nodes: ``highway=traffic_signals``, and crossings with
    ``crossing=traffic_signals``."""
    return {
        nid: (xy, tags)
        for nid, (xy, tags) in nodes.items()
        if tags.get("highway") == "traffic_signals"
        or (tags.get("highway") == "crossing" and tags.get("crossing") == "traffic_signals")
    }


def signal_at(scene, xy) -> float:
    """How far (m) a point is from the nearest place the scene's signals control: the
    outline of a signalised junction block, a crosswalk a signal phase serves (walk), or a
    signal's stop line (the line across the road from a light's foot, perpendicular to the
    way it faces, 15 m long)."""
    blocks = {b.id: b for b in scene.blocks}
    served = {c for s in scene.signals for p in s.phases for c in p.crosswalks}
    p = Point(xy)
    near = [Polygon(z.polygon, z.holes).distance(p) for z in scene.zones if z.id in served]
    for s in scene.signals:
        block = blocks.get(s.junction)  # none: a pedestrian signal's crosswalk (tram tracks)
        if block is not None and block.kind != "straight":
            near.append(block_geometry(block).outline.distance(p))
        for h in s.heads:
            across = (15 * math.sin(h.yaw), -15 * math.cos(h.yaw))  # towards the road's other side
            near.append(shapely.LineString([h.position, np.add(h.position, across)]).distance(p))
    return min(near, default=math.inf)


def test_every_mapped_signal_is_a_signal_where_the_map_puts_it(corner, nodes):
    # Before: only the junction the approach signal is 18 m from got a plan (a junction's
    # node within 30 m); the crossings and the mid-block signal were plain crosswalks.
    lights = signal_nodes(nodes)
    assert len(lights) == 4
    for nid, (xy, tags) in lights.items():
        assert signal_at(corner, xy) <= 0.5, (nid, tags)
    kinds = {s.id: {b.id: b.kind for b in corner.blocks}[s.junction] for s in corner.signals}
    assert sorted(kinds.values()) == ["intersection", "straight", "straight"]
    for s in corner.signals:
        if kinds[s.id] == "straight":  # a mid-block crossing: traffic, then walk
            assert [p.id for p in s.phases] == ["traffic", "walk"] and len(s.heads) == 2
            assert s.phases[1].crosswalks and not s.phases[0].crosswalks
    # the signalised crossing 12 m before the junction is served by the junction's plan
    (junction,) = [s for s in corner.signals if kinds[s.id] == "intersection"]
    near = [nid for nid, (xy, t) in lights.items() if t.get("crossing") and xy[0] > 100]
    assert any(f"crosswalk-{nid}" in p.crosswalks for p in junction.phases for nid in near)


def test_vehicles_stop_at_the_mapped_stop_lines_and_never_pass_one_at_red(corner):
    traffic = CityTraffic(corner, dt=0.2)
    signalled = {s.junction for s in corner.signals}
    passages = [(k, p) for k, d in enumerate(traffic.drives) for p in d.passages if p.junction in signalled]
    straights = {b.id for b in corner.blocks if b.kind == "straight"}
    assert {p.junction for _, p in passages} & straights  # someone drives over a mid-block one
    crossed = 0
    for _ in range(900):
        front = traffic.s + traffic.length / 2
        t = traffic.t
        traffic.step()
        after = traffic.s + traffic.length / 2
        for k, p in passages:
            if front[k] <= p.s_stop < after[k]:
                assert traffic.plan.lane(p.junction, p.lane, t) != "red", (k, p.junction, t)
                crossed += 1
    assert crossed > 0


def test_the_mjcf_carries_every_signal_mid_block_ones_too(corner, tmp_path):
    # (The town's small box exports to every format and runs a traverse in test_osm.py; a
    # traverse env on the corner takes half a minute to build, so only MJCF here.)
    import mujoco

    from citygen.exporters import mjcf

    model = mujoco.MjModel.from_xml_path(str(mjcf.export(corner, tmp_path)[0]))
    sites = {model.site(i).name for i in range(model.nsite)}
    for s in corner.signals:
        assert {f"signal:{s.id}:{p.id}" for p in s.phases} <= sites, s.id
