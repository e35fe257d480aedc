"""Real places (issue 48): scenes from the made-up town's OpenStreetMap extract
(tests/data/osm/, self-made, CC0), checked against the extract as read here with pyosmium
and projected with the scene's own recorded projection, not through the generator's code."""

from __future__ import annotations

import math
from collections import Counter, defaultdict

import numpy as np
import osmium
import pytest
import shapely
from pyproj import Transformer
from shapely.geometry import Polygon, box

import citygen
from citygen.generate.places import generate_place
from tests.conftest import ROOT

DATA = ROOT / "tests" / "data" / "osm"
TOWN, TOWN_PBF = DATA / "town.osm", DATA / "town.osm.pbf"
#: The whole town (3 x 2 city blocks, its streets running past the box's edges).
BOX = (8.5397, 47.3697, 8.5443, 47.3720)
#: The signalised junction of the primary road and a street beside it, for the slower checks.
SMALL = (8.54053, 47.370494, 8.542121, 47.371303)
#: A box inside the park: no street.
PARK = (8.540265, 47.37018, 8.541061, 47.370719)


@pytest.fixture(scope="module")
def town():
    return generate_place(TOWN_PBF, BOX, seed=3)


@pytest.fixture(scope="module")
def small():
    return generate_place(TOWN, SMALL, seed=1)


def _project(scene):
    return Transformer.from_crs("EPSG:4326", scene.meta.source.projection, always_xy=True)


def building_of(area, t) -> tuple[str, shapely.Geometry]:
    """A building area's scene id suffix (``w45``, ``r6``) and footprint, projected by ``t``."""
    polys = [
        Polygon(
            [t.transform(n.lon, n.lat) for n in outer],
            [[t.transform(n.lon, n.lat) for n in r] for r in area.inner_rings(outer)],
        )
        for outer in area.outer_rings()
    ]
    return ("w" if area.from_way() else "r") + str(area.orig_id()), shapely.union_all(polys)


def _mapped(scene):
    """The extract's junctions, buildings and tagged nodes inside the scene's bounds, in its metres."""
    t = _project(scene)
    frame = box(*scene.bounds.min, *scene.bounds.max)
    nodes, uses, buildings = {}, Counter(), {}
    for obj in osmium.FileProcessor(str(TOWN)).with_locations().with_areas():
        if isinstance(obj, osmium.osm.Node):
            nodes[obj.id] = (t.transform(obj.location.lon, obj.location.lat), dict(obj.tags))
        elif isinstance(obj, osmium.osm.Way) and obj.tags.get("highway") in (
            "residential",
            "primary",
            "tertiary",
        ):
            refs = [n.ref for n in obj.nodes]
            for k, ref in enumerate(refs):
                uses[ref] += 1 if k in (0, len(refs) - 1) else 2
        elif isinstance(obj, osmium.osm.Area) and "building" in obj.tags:
            fid, shape = building_of(obj, t)
            buildings[fid] = shape
    junctions = [
        nodes[n][0] for n, k in uses.items() if k >= 3 and frame.contains(shapely.Point(nodes[n][0]))
    ]
    inside = {fid: p for fid, p in buildings.items() if frame.contains(p.centroid)}
    return nodes, junctions, inside, frame


def test_the_town_validates_and_records_where_it_came_from(town):
    assert citygen.validate(town) == []
    src = town.meta.source
    assert src.file == "town.osm.pbf" and src.bbox == BOX and src.projection.startswith("+proj=tmerc")
    # The scene covers the box: its corners project inside the scene, within a tile of its far edges.
    (x0, x1), (y0, y1) = _project(town).transform([BOX[0], BOX[2]], [BOX[1], BOX[3]])
    assert abs(x0) < 0.1 and abs(y0) < 0.1
    assert 0 <= town.bounds.max[0] - x1 < 10 and 0 <= town.bounds.max[1] - y1 < 10


def test_junctions_and_buildings_match_the_map(town):
    _, junctions, buildings, frame = _mapped(town)
    blocks = [b for b in town.blocks if b.kind in ("intersection", "t_intersection")]
    assert len(junctions) == 12
    assert abs(len(blocks) - len(junctions)) <= 0.05 * len(junctions)
    for j in junctions:  # each junction block centred on its mapped node
        centres = [
            np.add(b.pose.position, b.arm_length * np.array([math.cos(b.pose.yaw), math.sin(b.pose.yaw)]))
            for b in blocks
        ]
        assert min(math.dist(c, j) for c in centres) < 0.01
    zones = defaultdict(list)
    for z in town.zones:
        if z.kind == "building":
            zones[z.id.removeprefix("building-").split("-")[0]].append(Polygon(z.polygon, z.holes))
    assert len(buildings) == 18
    assert abs(len(zones) - len(buildings)) <= 0.05 * len(buildings)
    for fid, poly in buildings.items():
        if frame.contains(poly):
            area = sum(p.area for p in zones[fid])
            assert abs(area - poly.area) <= 0.05 * poly.area, (fid, area, poly.area)
    assert any(z.holes for z in town.zones if z.id == "building-r1")  # the courtyard


def mapped_heights(path) -> dict[str, float]:
    """Each building's height (m) as its tags give it: ``height``, else 3 m a level of
    ``building:levels``, else 3 levels (9 m)."""
    tall = {}
    for obj in osmium.FileProcessor(str(path)).with_areas():
        if isinstance(obj, osmium.osm.Area) and "building" in obj.tags:
            fid = ("w" if obj.from_way() else "r") + str(obj.orig_id())
            height, levels = obj.tags.get("height"), obj.tags.get("building:levels")
            tall[fid] = float(height.removesuffix("m")) if height else 3.0 * float(levels) if levels else 9.0
    return tall


def test_each_building_is_a_solid_as_tall_as_mapped_and_no_massing_stands_in_it(town):
    tall = mapped_heights(TOWN)
    heights = {z.id.removeprefix("building-"): z.height for z in town.zones if z.kind == "building"}
    assert len(heights) == 18 and heights == {fid: tall[fid] for fid in heights}
    assert {z.height for z in town.zones if z.kind != "building"} == {None}
    assert not [p.id for p in town.placements if p.asset.startswith("building/")]


def test_every_bench_tree_and_signal_is_where_the_map_puts_it(town):
    nodes, _, _, frame = _mapped(town)
    placed = {p.id.rsplit("-", 1)[1]: p for p in town.placements if p.id.rsplit("-", 1)[1].startswith("n")}
    wanted = {"amenity": ("bench",), "natural": ("tree",), "barrier": ("bollard",)}
    checked = 0
    for nid, (xy, tags) in nodes.items():
        if not frame.contains(shapely.Point(xy)):
            continue
        if any(tags.get(k) in v for k, v in wanted.items()):
            p = placed.get(f"n{nid}")
            assert p is not None, (nid, tags)
            assert math.dist(p.position[:2], xy) <= 0.5
            checked += 1
        if tags.get("highway") == "traffic_signals":
            signal = next(s for s in town.signals if s.junction == f"j-n{nid}")
            junction = next(b for b in town.blocks if b.id == signal.junction)
            centre = np.add(
                junction.pose.position,
                junction.arm_length * np.array([math.cos(junction.pose.yaw), math.sin(junction.pose.yaw)]),
            )
            assert math.dist(centre, xy) <= 0.5
            checked += 1
    assert checked == 24  # 17 benches and trees, 5 bollards, 2 signals
    assert [p.asset.split("/")[0] for p in town.placements if p.id == "bench-n151"] == ["bench"]


def test_zones_tile_the_box_and_the_map_is_followed(town):
    polys = [Polygon(z.polygon, z.holes) for z in town.zones]
    union = shapely.union_all(polys)
    area = box(*town.bounds.min, *town.bounds.max).area
    assert (area - union.area) / area < 1e-6
    assert (sum(p.area for p in polys) - union.area) / area < 1e-6
    kinds = Counter(z.kind for z in town.zones)
    assert {
        "roadway",
        "curb",
        "sidewalk",
        "crosswalk",
        "building",
        "plaza",
        "parking",
        "water",
        "vegetation",
    } <= set(kinds)
    nodes, *_ = _mapped(town)
    crossings = [n for n, (_, tags) in nodes.items() if tags.get("highway") == "crossing"]
    ids = {z.id for z in town.zones if z.kind == "crosswalk"}
    assert crossings and {f"crosswalk-n{n}" for n in crossings} <= ids  # a mapped crossing node
    assert any(i.startswith("crosswalk-w") for i in ids)  # a mapped footway=crossing way
    assert town.task.kind == "traverse" and town.agents


def test_xml_and_pbf_give_the_same_scene():
    a = generate_place(TOWN, SMALL, seed=1)
    b = generate_place(TOWN_PBF, SMALL, seed=1)
    assert a.model_copy(update={"meta": b.meta}) == b


def test_small_scene_exports_to_every_format_and_runs_a_traverse(small, tmp_path, cli):
    from citygen.runner.make import make_env

    assert citygen.validate(small) == [] and small.signals
    path = citygen.save_scene(small, tmp_path / "small.json")
    result = cli(
        "export", path, "--format", "all", "--occupancy-resolution", "0.2", "--out", tmp_path / "out"
    )
    assert result.code == 0, result.err
    assert {p.suffix for p in (tmp_path / "out").iterdir()} >= {
        ".xml",
        ".usda",
        ".urdf",
        ".npz",
        ".glb",
        ".png",
    }
    env = make_env("traverse", small)
    env.reset(seed=0)
    for _ in range(5):
        obs, reward, *_ = env.step(np.zeros(env.action_space.shape, dtype=env.action_space.dtype))
        assert np.isfinite(reward) and all(np.isfinite(v).all() for v in _leaves(obs))
    env.close()


def test_a_navigation_task_runs_on_a_place():
    from citygen.runner.make import make_env
    from citygen.spec.config import TaskConfig

    scene = generate_place(TOWN, SMALL, seed=2, task=TaskConfig(kind="nav-static", min_distance=10.0))
    assert scene.task.kind == "nav-static" and citygen.validate(scene) == []
    env = make_env("nav-static", scene)
    env.reset(seed=0)
    for _ in range(3):
        obs, reward, *_ = env.step(np.zeros(env.action_space.shape, dtype=env.action_space.dtype))
        assert np.isfinite(reward) and all(np.isfinite(v).all() for v in _leaves(obs))
    env.close()


def _leaves(obs):
    return obs.values() if isinstance(obs, dict) else [obs]


def test_generate_command_writes_the_place(tmp_path, cli):
    result = cli(
        "generate", "--osm", TOWN, "--bbox", ",".join(map(str, SMALL)), "--seed", "1", "--out", tmp_path
    )
    assert result.code == 0, result.err
    scene = citygen.load_scene(tmp_path / "town.json")
    assert scene == generate_place(TOWN, SMALL, seed=1)
    # The config written beside it rebuilds the later stages byte for byte.
    edited = tmp_path / "edited.json"
    edited.write_bytes((tmp_path / "town.json").read_bytes())
    result = cli("rebuild", edited, "--from", "placement", "--config", tmp_path / "town.config.json")
    assert result.code == 0, result.err
    assert edited.read_bytes() == (tmp_path / "town.json").read_bytes()


def test_a_split_manifest_names_the_extract_in_an_osm_table(tmp_path, cli):
    manifest = tmp_path / "places.toml"
    manifest.write_text(
        'format = "citygen.splits/1"\n[[splits]]\nname = "town-corner"\nscenes = 1\n'
        f'config.layout = "osm"\nconfig.osm = {{ file = "{TOWN}", bbox = {list(SMALL)} }}\n'
        'config.task.kind = "traverse"\nconfig.task.min_distance = 30.0\n'
    )
    result = cli("generate", "--split", manifest, "--out", tmp_path / "out")
    assert result.code == 0, result.err
    scene = citygen.load_scene(tmp_path / "out" / "town-corner" / "0000.json")
    assert scene.meta.source.bbox == SMALL and citygen.validate(scene) == []
    assert scene.bounds.max == small_size()


def small_size():
    from citygen.generate.layouts.osm.project import Projection

    return Projection.for_box(SMALL).size


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (
            ["--osm", ROOT / "pyproject.toml", "--bbox", ",".join(map(str, BOX))],
            "expected an OpenStreetMap file",
        ),
        (["--osm", TOWN, "--bbox", "9.5,47.3,9.51,47.305"], "overlapping the file's data"),
        (["--osm", TOWN, "--bbox", "8.4,47.3,8.6,47.4"], "the memory bounds"),
        (["--osm", TOWN, "--bbox", ",".join(map(str, PARK))], "expected streets"),
        (["--osm", TOWN, "--bbox", "8.54,47.37"], "--bbox: expected WEST,SOUTH,EAST,NORTH"),
        (["--osm", DATA / "missing.osm", "--bbox", ",".join(map(str, BOX))], "no such file"),
    ],
)
def test_bad_places_are_one_line_and_exit_2(tmp_path, cli, args, needle):
    result = cli("generate", *args, "--out", tmp_path / "out")
    assert result.code == 2
    assert needle in result.err and len(result.err.strip().splitlines()) == 1, result.err
    assert "Traceback" not in result.err and not (tmp_path / "out").exists()
