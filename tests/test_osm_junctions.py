"""Issue 48: every mapped junction is a junction block, vehicles drive through the general ones,
and one-way streets are driven one way. On a small made-up extract written here (self-made
data, CC0): a five-way junction with traffic signals, a sharp Y fork, a one-way street along
its way (``oneway=yes``) and one against it (``oneway=-1``)."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from shapely.geometry import Point, box

import citygen
from citygen.generate.layouts.osm import osm_config
from citygen.generate.layouts.osm.place import load_place
from citygen.generate.pipeline import generate
from citygen.geometry.roads import block_geometry, general_junction
from citygen.runner.agents.lanes import _route_sockets
from citygen.runner.agents.traffic import CityTraffic
from citygen.spec.config import AgentsConfig
from tests.conftest import ROOT

LAT0, LON0 = 47.37, 8.54
M_LAT = 1 / 111_320.0
M_LON = 1 / (111_320.0 * math.cos(math.radians(LAT0)))
#: The box: 240 m x 160 m.
BOX = (LON0, LAT0, LON0 + 240 * M_LON, LAT0 + 160 * M_LAT)
#: Nodes in metres east and north of the box's south-west corner.
NODES = {
    1: (60.0, 80.0),  # the five-way junction (traffic signals)
    2: (140.0, 80.0),  # the Y fork
    3: (-20.0, 80.0),
    4: (60.0, 180.0),
    5: (60.0, -20.0),
    6: (130.0, 180.0),
    7: (260.0, 80.0 + 120.0 * math.tan(math.radians(25))),
    8: (260.0, 80.0 - 120.0 * math.tan(math.radians(25))),
}
WAYS = {  # id: (nodes, extra tags)
    10: ((3, 1), {}),
    11: ((1, 4), {"oneway": "yes"}),  # driven north, away from the junction
    12: ((1, 5), {"oneway": "-1"}),  # drawn south, driven north, towards it
    13: ((1, 6), {}),
    14: ((1, 2), {}),
    15: ((2, 7), {}),
    16: ((2, 8), {}),
}


def _xml() -> str:
    lines = ["<?xml version='1.0' encoding='UTF-8'?>", '<osm version="0.6" generator="citygen test">']
    for nid, (x, y) in NODES.items():
        tags = '<tag k="highway" v="traffic_signals"/>' if nid == 1 else ""
        lat, lon = LAT0 + y * M_LAT, LON0 + x * M_LON
        lines.append(f' <node id="{nid}" version="1" lat="{lat:.8f}" lon="{lon:.8f}">{tags}</node>')
    for wid, (refs, extra) in WAYS.items():
        lines.append(f' <way id="{wid}" version="1">')
        lines += [f'  <nd ref="{r}"/>' for r in refs]
        for k, v in {"highway": "residential", **extra}.items():
            lines.append(f'  <tag k="{k}" v="{v}"/>')
        lines.append(" </way>")
    lines.append("</osm>")
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def fork(tmp_path_factory):
    path = tmp_path_factory.mktemp("osm") / "fork.osm"
    path.write_text(_xml(), encoding="utf-8")
    config = osm_config(str(path), BOX, agents=AgentsConfig(people=2, vehicles=8))
    return config, generate(config, 0)


def _centre(block) -> tuple[float, float]:
    return block_geometry(block).centre


def _junction_nodes(config, scene):
    """The street graph's junction nodes inside the scene's bounds, as the extract maps them."""
    frame = box(*scene.bounds.min, *scene.bounds.max)
    return [j for j in load_place(config.osm).junctions if frame.contains(Point(j.position))]


@pytest.mark.parametrize("where", ["fork", "town"])
def test_every_junction_node_in_the_box_has_one_junction_block_on_it(where, fork):
    if where == "fork":
        config, scene = fork
    else:
        config = osm_config(
            str(ROOT / "tests" / "data" / "osm" / "town.osm"), (8.5397, 47.3697, 8.5443, 47.3720)
        )
        scene = generate(config, 0)
    assert citygen.validate(scene) == []
    joints = _junction_nodes(config, scene)
    blocks = [b for b in scene.blocks if block_geometry(b).centre is not None]
    assert joints and len({b.id for b in blocks}) == len(blocks)
    for j in joints:
        on = [b for b in blocks if math.dist(_centre(b), j.position) <= 1.0]
        assert [b.id for b in on] == [f"j-n{j.node}"], j.node
    # Every arm of every junction is joined to a street's block (none left open in the box).
    for b in blocks:
        assert {c.socket for c in b.connections} == {s.id for s in b.sockets}, b.id


def test_the_five_way_and_the_fork_are_general_junctions_with_a_signal_plan(fork):
    _, scene = fork
    by_id = {b.id: b for b in scene.blocks}
    five, y = by_id["j-n1"], by_id["j-n2"]
    assert (five.kind, len(five.arms), y.kind, len(y.arms)) == ("junction", 5, "junction", 3)
    (signal,) = [s for s in scene.signals if s.junction == "j-n1"]
    # the west-east and the north-south street each share a phase; the fifth arm has its own
    assert sorted(len(p.id.split("-")) for p in signal.phases) == [1, 2, 2]
    assert len(scene.placements) and any(p.id.startswith("signal-j-n1-light") for p in scene.placements)


def test_one_way_streets_are_one_way_blocks_laid_the_way_traffic_drives(fork):
    _, scene = fork
    for way, heading in (("w11", math.pi / 2), ("w12", math.pi / 2), ("w10", None)):
        blocks = [b for b in scene.blocks if b.id.startswith(f"s-{way}-")]
        assert blocks, way
        for b in blocks:
            if heading is None:
                assert b.one_way is None
            else:
                assert b.one_way is True and abs(math.remainder(b.pose.yaw - heading, 2 * math.pi)) < 0.05
    # a two-way block is written as before: no one_way key (old scenes keep their bytes)
    written = {b["id"]: b for b in json.loads(citygen.io.dumps(scene))["blocks"]}
    assert "one_way" not in written["s-w10-1"] and written["s-w11-1"]["one_way"] is True


def test_vehicles_drive_through_the_fork_and_one_way_streets_only_their_way(fork):
    _, scene = fork
    by_id = {b.id: b for b in scene.blocks}
    cars = [a for a in scene.agents if a.kind == "vehicle"]
    for car in cars:  # every route takes a one-way block from its "in" to its "out"
        for block, entry, exit_ in _route_sockets(car, scene.blocks, by_id):
            if getattr(block, "one_way", None):
                assert (entry, exit_) == ("in", "out"), (car.id, block.id)
    traffic = CityTraffic(scene, dt=0.1)
    general = {"j-n1", "j-n2"}
    passages = {
        (k, p.junction): p.s_exit
        for k, d in enumerate(traffic.drives)
        for p in d.passages
        if p.junction in general
    }
    assert {j for _, j in passages} == general
    one_way = [b for b in scene.blocks if getattr(b, "one_way", None)]
    routes = [set(c.route) for c in cars]
    through, moves = set(), 0
    for _ in range(600):
        s0, p0 = traffic.s.copy(), traffic.pos.copy()
        traffic.step()
        rear = traffic.s - traffic.length / 2
        for (k, j), s_exit in passages.items():
            if rear[k] >= s_exit and traffic.s[k] >= s0[k]:
                through.add(j)
        for k in np.flatnonzero(np.linalg.norm(traffic.pos - p0, axis=1) > 1e-3).tolist():
            step = traffic.pos[k] - p0[k]
            if traffic.s[k] < s0[k]:  # a new trip from the start
                continue
            for b in one_way:
                if b.id in routes[k] and block_geometry(b).outline.contains(Point(traffic.pos[k])):
                    moves += 1
                    assert step @ np.array([math.cos(b.pose.yaw), math.sin(b.pose.yaw)]) > 0, (k, b.id)
    assert through == general and moves > 0


def test_a_general_junction_is_checked_and_bad_ones_are_one_line(fork):
    _, scene = fork
    j = general_junction("j", (0.0, 0.0), [{"yaw": 0.0, "length": 10.0}, {"yaw": 2.6, "length": 10.0},
                                           {"yaw": -2.6, "length": 10.0}])  # fmt: skip
    assert [s.id for s in j.sockets] == ["in", "arm1", "arm2"]
    doc = citygen.io.dumps(scene)
    i = [b.id for b in scene.blocks].index("j-n2")
    bad = scene.model_copy(
        update={
            "blocks": (
                *scene.blocks[:i],
                scene.blocks[i].model_copy(
                    update={"pose": scene.blocks[i].pose.model_copy(update={"yaw": 0.5})}
                ),
                *scene.blocks[i + 1 :],
            )
        }
    )
    problems = [str(p) for p in citygen.validate(bad)]
    assert len(problems) == 1 and problems[0].startswith(
        f"$.blocks[{i}].pose: expected the first arm's road end"
    )
    bow = [(0.0, 0.0), (10.0, 10.0), (10.0, 0.0), (0.0, 10.0)]
    tie = scene.blocks[i].model_copy(update={"polygon": tuple(bow)})
    bad = scene.model_copy(update={"blocks": (*scene.blocks[:i], tie, *scene.blocks[i + 1 :])})
    problems = [str(p) for p in citygen.validate(bad)]
    assert problems and problems[0].startswith(f"$.blocks[{i}].polygon: expected a valid polygon")
    assert '"kind":"junction"' in doc.replace(" ", "")


def _ring_xml() -> str:
    """A roundabout (a closed ``junction=roundabout`` way of eight nodes, counter-clockwise,
    radius 15 m round (120, 80)) with four streets joining it."""
    centre, r = (120.0, 80.0), 15.0
    nodes = {
        20 + k: (centre[0] + r * math.cos(k * math.pi / 4), centre[1] + r * math.sin(k * math.pi / 4))
        for k in range(8)
    }
    ends = {30: (260.0, 80.0), 31: (120.0, 180.0), 32: (-20.0, 80.0), 33: (120.0, -20.0)}
    ways = {40: ((*range(20, 28), 20), {"junction": "roundabout"})}
    ways |= {41 + k: ((20 + 2 * k, 30 + k), {}) for k in range(4)}
    lines = ["<?xml version='1.0' encoding='UTF-8'?>", '<osm version="0.6" generator="citygen test">']
    for nid, (x, y) in {**nodes, **ends}.items():
        lines.append(
            f' <node id="{nid}" version="1" lat="{LAT0 + y * M_LAT:.8f}" lon="{LON0 + x * M_LON:.8f}"/>'
        )
    for wid, (refs, extra) in ways.items():
        lines.append(f' <way id="{wid}" version="1">')
        lines += [f'  <nd ref="{n}"/>' for n in refs]
        lines += [f'  <tag k="{k}" v="{v}"/>' for k, v in {"highway": "residential", **extra}.items()]
        lines.append(" </way>")
    return "\n".join([*lines, "</osm>"]) + "\n"


def test_a_roundabout_ring_is_one_way_counter_clockwise_with_a_junction_at_each_arm(tmp_path):
    path = tmp_path / "ring.osm"
    path.write_text(_ring_xml(), encoding="utf-8")
    config = osm_config(str(path), BOX, agents=AgentsConfig(people=2, vehicles=6))
    scene = generate(config, 0)
    assert citygen.validate(scene) == []
    by_id = {b.id: b for b in scene.blocks}
    assert sorted(b for b in by_id if b.startswith("j-")) == ["j-n20", "j-n22", "j-n24", "j-n26"]
    ring = [b for b in scene.blocks if b.id.startswith("s-w40-")]
    assert ring and all(b.one_way for b in ring)
    for b in ring:  # each laid counter-clockwise round the centre
        x, y = np.subtract(b.pose.position, (120.0, 80.0))
        assert x * math.sin(b.pose.yaw) - y * math.cos(b.pose.yaw) > 0, b.id
    for car in (a for a in scene.agents if a.kind == "vehicle"):
        for block, entry, exit_ in _route_sockets(car, scene.blocks, by_id):
            if block.id.startswith("s-w40-"):
                assert (entry, exit_) == ("in", "out"), (car.id, block.id)
    assert any(r.startswith("s-w40-") for a in scene.agents if a.kind == "vehicle" for r in a.route)
