"""The occupancy-map exporter, checked against the spec by independent means.

Cell classes are recomputed here with shapely's ``contains_xy`` on the zone polygons and
on the placements' bases (moved with ``shapely.affinity``), heights with ``height_at``,
tile kinds from the tiles' rectangles; the ROS pair is parsed as map_server would read
it, and the npz with ``np.load(allow_pickle=False)``.
"""

from __future__ import annotations

import hashlib
import io
import json
import os
import re
import subprocess
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import shapely
import shapely.affinity
import trimesh
from PIL import Image
from shapely.geometry import Polygon, box

from citygen.assets import resolve
from citygen.errors import ExportError, SpecError
from citygen.exporters import ExportWarning
from citygen.exporters import occupancy as occ
from citygen.generate import generate
from citygen.geometry.raster import Grid
from citygen.geometry.terrain import height_at
from citygen.io import load_scene, save_scene
from citygen.spec import Scene
from citygen.spec.config import BlocksConfig, GeneratorConfig
from citygen.spec.surfaces import WALKABLE_ZONES, ZONE_KINDS
from citygen.spec.terrain import TILE_TYPES
from tests.conftest import ROOT
from tests.test_export_urdf import terrain_scene, write_terrain_scene

EXAMPLES = [ROOT / "examples" / "street_corner.json", ROOT / "examples" / "nav_static_10m.json"]
REGION_SEEDS = (0, 1, 2)


def region(seed: int) -> Scene:
    """A 15 m Urban-Nav-like region scene: zones, terrain, objects, agents, a task."""
    return generate(GeneratorConfig(size=(15, 15)), seed)


@pytest.fixture(scope="module")
def street_scene() -> Scene:
    """A 250 m street scene of three road blocks with buildings."""
    return generate(GeneratorConfig(size=(250, 250), layout="blocks", blocks=BlocksConfig(count=3)), 1)


@pytest.fixture(scope="module")
def kiosk_street(tmp_path_factory) -> Path:
    """Every tile kind, an uncovered corner, objects scaled and turned, a mesh-file kiosk."""
    return write_terrain_scene(tmp_path_factory.mktemp("street"))


def quiet_export(scene, out, **options) -> list[Path]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportWarning)
        return occ.export(scene, out, **options)


# --- the independent oracle ----------------------------------------------------------------


def base_shapes(scene: Scene, folder: Path | None) -> list[tuple[shapely.Geometry, str]]:
    """Each placement's base in the world and the class it should paint."""
    out = []
    for pl in scene.placements:
        if pl.is_mesh:
            mesh = trimesh.load(folder / pl.asset, force="mesh")
            local, cls = shapely.MultiPoint(mesh.vertices[:, :2]).convex_hull, "obstacle"
        else:
            asset = resolve(pl.asset)
            local = asset.base
            cls = "building" if asset.semantic_class == "building" else "obstacle"
        shape = shapely.affinity.scale(local, pl.scale, pl.scale, origin=(0, 0))
        shape = shapely.affinity.rotate(shape, pl.yaw, origin=(0, 0), use_radians=True)
        out.append((shapely.affinity.translate(shape, *pl.position[:2]), cls))
    return out


def expected_labels(
    scene: Scene, x: np.ndarray, y: np.ndarray, resolution: float, folder: Path | None = None
) -> np.ndarray:
    """The class (by name, from :data:`CLASSES`) of the cells centred on ``x, y``: zones by
    point-in-polygon tests of the centres, objects by intersecting their base with each
    cell's square (any overlap marks the cell)."""
    ids = {name: i for i, name in enumerate(occ.CLASSES)}
    out = np.full(x.shape, ids["ground"], dtype=np.uint8)
    h = resolution / 2 * (1 - 1e-6)
    for shape, cls in [(Polygon(z.polygon, z.holes), z.kind) for z in scene.zones]:
        x0, y0, x1, y1 = shape.bounds
        near = (x >= x0) & (x <= x1) & (y >= y0) & (y <= y1)
        hit = np.zeros(x.shape, dtype=bool)
        hit[near] = shapely.contains_xy(shape, x[near], y[near])
        out[hit] = ids[cls]
    for shape, cls in base_shapes(scene, folder):
        x0, y0, x1, y1 = shape.bounds
        near = (x >= x0 - h) & (x <= x1 + h) & (y >= y0 - h) & (y <= y1 + h)
        hit = np.zeros(x.shape, dtype=bool)
        hit[near] = shapely.intersects(shape, shapely.box(x[near] - h, y[near] - h, x[near] + h, y[near] + h))
        out[hit] = ids[cls]
    (bx0, by0), (bx1, by1) = scene.bounds.min, scene.bounds.max
    out[(x < bx0) | (x > bx1) | (y < by0) | (y > by1)] = ids["out_of_bounds"]
    return out


def centres(m: occ.OccupancyMap) -> tuple[np.ndarray, np.ndarray]:
    xs = m.origin[0] + (np.arange(m.shape[1]) + 0.5) * m.resolution
    ys = m.origin[1] + (np.arange(m.shape[0]) + 0.5) * m.resolution
    return np.meshgrid(xs, ys)


def assert_agrees(actual: np.ndarray, expected: np.ndarray) -> None:
    """At least 99% of cells agree, and every class of 100+ cells overlaps itself by 90%."""
    agree = float((actual == expected).mean())
    assert agree >= 0.99, f"only {agree:.4f} of the cells agree with point-in-polygon tests"
    for cls in np.unique(expected).tolist():
        a, e = actual == cls, expected == cls
        if e.sum() >= 100:
            iou = (a & e).sum() / (a | e).sum()
            assert iou >= 0.9, f"{occ.CLASSES[cls]}: IoU {iou:.3f}"


# --- the class table ---------------------------------------------------------------------


def test_the_class_table_covers_every_zone_and_tile_kind():
    assert occ.CLASSES[:3] == ("out_of_bounds", "ground", "obstacle")
    assert set(ZONE_KINDS) <= set(occ.CLASSES) and len(set(occ.CLASSES)) == len(occ.CLASSES) < 256
    assert {occ.CLASSES[i] for i in occ.WALKABLE_CLASSES} == WALKABLE_ZONES
    assert {occ.CLASSES[i] for i in occ.OBSTACLE_CLASSES} == {"obstacle", "building"}
    assert set(occ.TERRAIN_CLASSES) == {t.model_fields["kind"].annotation.__args__[0] for t in TILE_TYPES}
    assert occ.TERRAIN_CLASSES[0] == "flat"
    assert set(occ.CLASS_COLORS) == set(occ.CLASSES)


# --- agreement with the spec ---------------------------------------------------------------


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_examples_agree_with_point_in_polygon(path):
    scene = load_scene(path)
    m = occ.occupancy(path)
    assert m.shape == (round(scene.bounds.size[1] / 0.05), round(scene.bounds.size[0] / 0.05))
    assert m.origin == tuple(scene.bounds.min) and m.resolution == 0.05
    x, y = centres(m)
    assert_agrees(m.labels, expected_labels(scene, x, y, m.resolution, path.parent))


@pytest.mark.parametrize("seed", REGION_SEEDS)
def test_generated_regions_agree_with_point_in_polygon(seed):
    scene = region(seed)
    assert scene.placements and scene.terrain is not None
    m = occ.occupancy(scene)
    x, y = centres(m)
    assert_agrees(m.labels, expected_labels(scene, x, y, m.resolution))
    assert (m.labels == occ.OBSTACLE).any()


def test_every_tile_kind_and_a_mesh_file_agree_with_point_in_polygon(kiosk_street):
    scene = load_scene(kiosk_street)
    m = occ.occupancy(kiosk_street, resolution=0.05)
    x, y = centres(m)
    expected = expected_labels(scene, x, y, m.resolution, kiosk_street.parent)
    assert_agrees(m.labels, expected)
    # The L-shaped kiosk (a mesh file) is an obstacle where its hull is, the corner no
    # zone covers is ground.
    kiosk = scene.placements[-1]
    assert m.classes[m.label_at(*kiosk.position[:2])] == "obstacle"
    assert m.classes[m.label_at(23.5, 9.5)] == "ground"


def test_a_street_with_buildings_agrees_on_sampled_cells(street_scene):
    m = occ.occupancy(street_scene, resolution=0.2)
    rng = np.random.default_rng(7)
    rows = rng.integers(0, m.shape[0], 40_000)
    cols = rng.integers(0, m.shape[1], 40_000)
    x = m.origin[0] + (cols + 0.5) * m.resolution
    y = m.origin[1] + (rows + 0.5) * m.resolution
    assert_agrees(m.labels[rows, cols], expected_labels(street_scene, x, y, m.resolution))
    # Building massing stands in building lots; its base is labelled building, not obstacle.
    massing = [p for p in street_scene.placements if p.asset.startswith("building/")]
    assert massing
    for p in massing:
        assert m.classes[m.label_at(*p.position[:2])] == "building"


def test_out_of_bounds_cells_are_the_partial_last_row_and_column():
    scene = Scene.model_validate(
        {
            "format": "citygen.scene/1",
            "bounds": {"min": [-1.0, 2.0], "max": [1.02, 3.01]},
            "zones": [
                {"id": "w", "kind": "sidewalk", "polygon": [[-1, 2], [1.02, 2], [1.02, 3.01], [-1, 3.01]]}
            ],
        }
    )
    m = occ.occupancy(scene, resolution=0.05)
    assert m.shape == (21, 41) and m.origin == (-1.0, 2.0)
    out = m.labels == occ.OUT_OF_BOUNDS
    assert out[:, -1].all() and out[-1, :].all() and not out[:-1, :-1].any()
    assert (m.labels[:-1, :-1] == occ.ZONE_CLASS["sidewalk"]).all()


# --- heights and terrain ----------------------------------------------------------------------


@pytest.mark.parametrize("which", ["kiosk_street", "region", "nav_static"])
def test_heights_are_height_at_the_cell_centres(which, kiosk_street):
    scene = {"kiosk_street": lambda: load_scene(kiosk_street), "region": lambda: region(1)}.get(
        which, lambda: load_scene(EXAMPLES[1])
    )()
    m = occ.occupancy(scene, resolution=0.05, scene_dir=kiosk_street.parent)
    x, y = centres(m)
    assert m.heights.dtype == np.float32
    np.testing.assert_array_equal(m.heights, height_at(scene, x, y).astype(np.float32))
    assert float(np.abs(m.heights).max()) > 0.1  # there is terrain to get right


def test_terrain_layer_is_the_kind_of_the_tile_under_each_centre(kiosk_street):
    scene = load_scene(kiosk_street)
    t = scene.terrain
    m = occ.occupancy(scene, resolution=0.05, scene_dir=kiosk_street.parent)
    x, y = centres(m)
    expected = np.full(m.shape, -1)
    s = t.tile_size
    grid_box = box(t.origin[0], t.origin[1], t.origin[0] + t.cols * s, t.origin[1] + t.rows * s)
    expected[~shapely.intersects_xy(grid_box, x, y)] = occ.TERRAIN_CLASSES.index("flat")
    for r in range(t.rows):
        for c in range(t.cols):
            x0, y0 = t.origin[0] + c * s, t.origin[1] + r * s
            inside = shapely.contains_xy(box(x0, y0, x0 + s, y0 + s), x, y)
            expected[inside] = occ.TERRAIN_CLASSES.index(t.tile(r, c).kind)
    decided = expected >= 0  # centres on a tile border are left to height_at's rule
    assert decided.mean() > 0.95
    np.testing.assert_array_equal(m.terrain[decided], expected[decided])
    assert set(np.unique(m.terrain).tolist()) == set(range(len(occ.TERRAIN_CLASSES)))


def test_centres_on_tile_borders_follow_height_at():
    """Cell centres exactly on the tile grid's lines: a border belongs to the tile with the
    larger index, the grid's east and north edges to the last tile, beyond them is flat."""
    scene = Scene.model_validate(
        {
            "format": "citygen.scene/1",
            "bounds": {"min": [-0.0625, -0.0625], "max": [3.0625, 1.3125]},
            "terrain": {
                "origin": [0.0, 0.0],
                "tile_size": 1.0,
                "rows": 1,
                "cols": 2,
                "tiles": [
                    {"kind": "flat", "height": 0.2},
                    {"kind": "stair", "step_height": 0.1, "step_count": 1},
                ],
            },
        }
    )
    m = occ.occupancy(scene, resolution=0.125)  # centres exactly on multiples of 0.125 m
    assert m.grid.centre(m.cell(2.0, 1.0)) == (2.0, 1.0)
    kind = {x: m.terrain_classes[m.terrain[m.cell(x, 0.5)]] for x in (0.0, 0.875, 1.0, 2.0, 2.125)}
    assert kind == {0.0: "flat", 0.875: "flat", 1.0: "stair", 2.0: "stair", 2.125: "flat"}
    assert m.terrain_classes[m.terrain[m.cell(1.5, 1.0)]] == "stair"  # the north edge
    assert m.terrain_classes[m.terrain[m.cell(1.5, 1.125)]] == "flat"
    x, y = centres(m)
    np.testing.assert_array_equal(m.heights, height_at(scene, x, y).astype(np.float32))
    assert m.heights[m.cell(0.0, 0.5)] == np.float32(0.2) and m.heights[m.cell(2.125, 0.5)] == 0.0
    assert m.heights[m.cell(2.0, 0.5)] == np.float32(0.1)


def test_empty_bounds_are_a_spec_error():
    scene = Scene.model_validate({"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [0, 5]}})
    with pytest.raises(SpecError, match=r"\$\.bounds: expected max greater than min"):
        occ.occupancy(scene)


# --- the Python API -----------------------------------------------------------------------------


def test_masks_and_inflation(kiosk_street):
    m = occ.occupancy(kiosk_street, resolution=0.1)
    walk = m.walkable_mask()
    assert walk.any() and not walk.all()
    assert np.array_equal(walk, np.isin(m.labels, occ.WALKABLE_CLASSES))
    assert np.array_equal(m.obstacle_mask(), np.isin(m.labels, occ.OBSTACLE_CLASSES))
    assert not (walk & m.obstacle_mask()).any()
    assert np.array_equal(m.inflated(0.0), m.occupied_mask())
    small, big = m.inflated(0.2), m.inflated(0.6)
    assert (small >= m.occupied_mask()).all() and (big >= small).all() and big.sum() > small.sum()
    # Brute force: every cell left free is more than 0.6 m from every occupied centre.
    x, y = centres(m)
    occupied = np.c_[x[m.occupied_mask()], y[m.occupied_mask()]]
    free = np.c_[x[~big], y[~big]]
    rng = np.random.default_rng(3)
    for px, py in free[rng.choice(len(free), 300, replace=False)]:
        assert np.hypot(occupied[:, 0] - px, occupied[:, 1] - py).min() > 0.6 - 1e-9
    with pytest.raises(ValueError, match="radius"):
        m.inflated(-1.0)


def test_cell_label_at_and_class_id(kiosk_street):
    m = occ.occupancy(kiosk_street, resolution=0.1)
    assert m.cell(0.05, 0.05) == (0, 0) and m.cell(23.99, 9.99) == (99, 239)
    assert m.cell(-5.0, 50.0) == (99, 0)  # clamped
    labels = m.label_at([12.0, 5.0, -1.0, 30.0], [5.0, 0.5, 5.0, 5.0])
    assert [m.classes[v] for v in labels.tolist()] == [
        "sidewalk",
        "roadway",
        "out_of_bounds",
        "out_of_bounds",
    ]
    assert m.class_id("crosswalk") == occ.CLASSES.index("crosswalk")
    with pytest.raises(ValueError, match="class: expected one of"):
        m.class_id("lawn")


def test_mesh_files_need_their_folder(kiosk_street):
    scene = load_scene(kiosk_street)
    with pytest.raises(ExportError, match=r"\$\.placements\[6\]\.asset"):
        occ.occupancy(scene, resolution=0.1)
    a = occ.occupancy(scene, resolution=0.1, scene_dir=kiosk_street.parent)
    b = occ.occupancy(kiosk_street, resolution=0.1)
    assert np.array_equal(a.labels, b.labels)


def test_scale_is_bounded_with_a_resolution_that_fits():
    scene = Scene.model_validate(
        {"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [1200, 1200]}}
    )
    with pytest.raises(ExportError, match=r"24,000 x 24,000 cells.*resolution=0\.21 \(m\)") as err:
        occ.occupancy(scene)
    finest = float(re.search(r"resolution=([0-9.]+) \(m\)", str(err.value)).group(1))
    fits = Grid.covering((0, 0, 1200, 1200), finest)
    assert fits.rows * fits.cols <= occ.MAX_CELLS
    coarser = Grid.covering((0, 0, 1200, 1200), finest - 0.01)
    assert coarser.rows * coarser.cols > occ.MAX_CELLS


# --- files --------------------------------------------------------------------------------------


def read_pgm(data: bytes) -> np.ndarray:
    """A binary P5 PGM as map_server reads it: header tokens, then rows top (max y) first."""
    match = re.match(rb"P5\s+(\d+)\s+(\d+)\s+(\d+)\s", data)
    assert match, data[:40]
    width, height, maxval = (int(g) for g in match.groups())
    assert maxval == 255
    pixels = np.frombuffer(data[match.end() :], dtype=np.uint8)
    assert pixels.size == width * height
    return pixels.reshape(height, width)


def read_yaml(text: str) -> dict:
    """The flat ``key: value`` YAML map_server reads (values as YAML scalars or a flow list)."""
    out = {}
    for line in text.splitlines():
        key, _, value = line.partition(":")
        value = value.strip()
        out[key.strip()] = value if key.strip() in ("image", "mode") else json.loads(value)
    return out


def test_export_writes_a_ros_pair_npz_and_png(kiosk_street, tmp_path):
    with pytest.warns(ExportWarning) as caught:
        paths = occ.export(kiosk_street, tmp_path, resolution=0.1)
    assert [p.name for p in paths] == ["street.npz", "street.yaml", "street.pgm", "street-occupancy.png"]
    messages = [str(w.message) for w in caught]
    assert any(m.startswith("$.agents:") for m in messages) and any(m.startswith("$.task:") for m in messages)

    with np.load(paths[0], allow_pickle=False) as npz:
        data = {k: npz[k] for k in npz.files}
    assert set(data) >= {"labels", "heights", "origin", "resolution", "classes"}
    assert data["labels"].dtype == np.uint8 and data["heights"].dtype == np.float32
    assert data["labels"].shape == data["heights"].shape == data["terrain"].shape == (100, 240)
    assert data["origin"].tolist() == [0.0, 0.0] and float(data["resolution"]) == 0.1
    assert tuple(data["classes"].tolist()) == occ.CLASSES
    assert data["walkable"].tolist() == [c in WALKABLE_ZONES for c in occ.CLASSES]
    m = occ.occupancy(kiosk_street, resolution=0.1)
    assert np.array_equal(data["labels"], m.labels) and np.array_equal(data["heights"], m.heights)

    ros = read_yaml(paths[1].read_text())
    assert ros == {
        "image": "street.pgm",
        "resolution": 0.1,
        "origin": [0.0, 0.0, 0.0],
        "negate": 0,
        "occupied_thresh": 0.65,
        "free_thresh": 0.196,
        "mode": "trinary",
    }
    image = read_pgm(paths[2].read_bytes())
    assert image.shape == (100, 240)
    # map_server: p = (255 - v) / 255; free below free_thresh, occupied above occupied_thresh.
    p = (255 - image.astype(float)) / 255
    free, occupied = p < ros["free_thresh"], p > ros["occupied_thresh"]
    assert (free | occupied).all()
    walkable = data["walkable"][data["labels"]]
    assert np.array_equal(free[::-1], walkable)  # the image's top row is max y
    assert free.any() and occupied.any()
    # A cell near the top left corner of the scene (the plaza) is free in the top image row.
    assert free[0, 5] and m.classes[m.label_at(0.55, 9.95)] == "plaza"

    with Image.open(paths[3]) as png:
        assert png.format == "PNG" and max(png.size) == 1600


def test_load_gives_the_map_back(kiosk_street, tmp_path):
    paths = quiet_export(kiosk_street, tmp_path, resolution=0.1)
    m, back = occ.occupancy(kiosk_street, resolution=0.1), occ.load(paths[0])
    for key in ("labels", "heights", "terrain"):
        assert np.array_equal(getattr(m, key), getattr(back, key))
    assert back.grid == m.grid and back.classes == m.classes and back.terrain_classes == m.terrain_classes
    assert np.array_equal(back.inflated(0.3), m.inflated(0.3))


def test_load_rejects_what_is_not_an_occupancy_map(tmp_path):
    (tmp_path / "junk.npz").write_bytes(b"not a zip")
    with pytest.raises(SpecError, match=r"junk\.npz: \$: expected an occupancy map"):
        occ.load(tmp_path / "junk.npz")
    np.savez(tmp_path / "other.npz", labels=np.zeros((2, 2), np.uint8))
    with pytest.raises(SpecError, match=r"other\.npz: format: expected an array of that name"):
        occ.load(tmp_path / "other.npz")


def test_png_legend_lists_what_the_map_holds(kiosk_street):
    m = occ.occupancy(kiosk_street, resolution=0.1)
    fig = occ.figure(m, size_px=800)
    texts = [t.get_text() for t in fig.legends[0].get_texts()]
    present = [m.classes[i] for i in np.unique(m.labels).tolist()]
    present = [f"{c} (walkable)" if c in WALKABLE_ZONES else c for c in present]
    assert texts[: len(present)] == present
    # A tinted tile shows its class's colour under the tint: the legend has that blend for
    # each (class, tile kind) pair the picture draws.
    k = max(1, -(-max(m.grid.rows, m.grid.cols) // 800))
    sampled = (m.labels[k // 2 :: k, k // 2 :: k].ravel(), m.terrain[k // 2 :: k, k // 2 :: k].ravel())
    drawn = zip(*sampled, strict=True)
    pairs = {
        (m.classes[c], m.terrain_classes[t])
        for c, t in set(drawn)
        if m.terrain_classes[t] in occ.TERRAIN_TINTS
    }
    tinted = {tuple(t.removesuffix(" tile").split(" on a ")): t for t in texts[len(present) :]}
    assert set(tinted) == pairs and {kind for _, kind in pairs} == {"slope", "stair", "rough"}
    faces = {
        t.get_text(): h.get_facecolor()
        for t, h in zip(fig.legends[0].get_texts(), fig.legends[0].legend_handles, strict=True)
    }
    for (name, kind), label in tinted.items():
        tint, alpha = occ.TERRAIN_TINTS[kind]
        a = round(alpha * 255) / 255
        rgb = [
            a * int(tint[i : i + 2], 16) + (1 - a) * int(occ.CLASS_COLORS[name][i : i + 2], 16)
            for i in (1, 3, 5)
        ]
        assert np.allclose(np.array(faces[label][:3]) * 255, rgb, atol=0.6), label
    assert fig.canvas.get_width_height()[0] == 800


def test_same_scene_same_bytes_twice(kiosk_street, tmp_path):
    a = quiet_export(kiosk_street, tmp_path / "a", resolution=0.1, size_px=600)
    b = quiet_export(kiosk_street, tmp_path / "b", resolution=0.1, size_px=600)
    for pa, pb in zip(a, b, strict=True):
        assert pa.read_bytes() == pb.read_bytes(), pa.name
    # numpy's own savez stamps each entry with the time; this writer does not.
    with np.load(a[0], allow_pickle=False) as npz:
        assert npz.zip.getinfo("labels.npy").date_time == (1980, 1, 1, 0, 0, 0)


def test_same_bytes_across_processes_and_hash_seeds(tmp_path):
    path = save_scene(region(2), tmp_path / "region.json")
    local = quiet_export(path, tmp_path / "local")
    digests = {p.name: hashlib.sha256(p.read_bytes()).hexdigest() for p in local}
    code = (
        "import hashlib, sys, warnings\n"
        "from citygen.exporters import occupancy\n"
        "warnings.simplefilter('ignore')\n"
        "for p in occupancy.export(sys.argv[1], sys.argv[2]):\n"
        "    print(p.name, hashlib.sha256(p.read_bytes()).hexdigest())\n"
    )
    for seed in ("0", "4242"):
        env = {**os.environ, "PYTHONHASHSEED": seed}
        out = subprocess.run(
            [sys.executable, "-c", code, str(path), str(tmp_path / seed)],
            capture_output=True, text=True, env=env, cwd=ROOT, timeout=120, check=True,
        ).stdout  # fmt: skip
        assert dict(line.split() for line in out.splitlines()) == digests


def test_npz_bytes_do_not_depend_on_the_clock(kiosk_street, monkeypatch):
    m = occ.occupancy(kiosk_street, resolution=0.2)
    first = occ.npz_bytes(m)
    monkeypatch.setattr("time.time", lambda: 2_000_000_000.0)
    monkeypatch.setattr("time.localtime", lambda *a: __import__("time").gmtime(2_000_000_000))
    assert occ.npz_bytes(m) == first
    assert np.load(io.BytesIO(first), allow_pickle=False)["labels"].shape == m.shape


# --- errors and warnings ------------------------------------------------------------------------


def test_in_memory_maps_do_not_warn():
    with warnings.catch_warnings():
        warnings.simplefilter("error", ExportWarning)
        occ.occupancy(region(0), resolution=0.1)


@pytest.mark.parametrize(
    ("options", "message"),
    [
        ({"resolution": 0}, "positive number of metres for 'resolution', got 0"),
        ({"resolution": -0.1}, "got -0.1"),
        ({"resolution": float("nan")}, "got nan"),
        ({"resolution": True}, "got True"),
        ({"resolution": "0.1"}, "got '0.1'"),
        ({"name": "a/b"}, "file name without folders"),
        ({"size_px": 10}, "size_px: expected 64 to 8192"),
        ({"legend": "yes"}, "True or False for 'legend'"),
        ({"colour": 1}, "unknown option 'colour'"),
    ],
)
def test_bad_options_are_one_line_errors(options, message, tmp_path):
    with pytest.raises(ExportError, match=re.escape(message)) as err:
        quiet_export(EXAMPLES[1], tmp_path, **options)
    assert "\n" not in str(err.value)
    assert not list(tmp_path.iterdir())


def test_a_scene_model_is_named_from_its_meta(tmp_path):
    scene = terrain_scene(placements=[], meta={"split": "urban-nav-2-train", "index": 3})
    paths = quiet_export(scene, tmp_path, resolution=0.2)
    assert paths[0].name == "urban-nav-2-train-00003.npz"


def test_a_loc_map_has_the_robot_start_on_free_ground():
    """Urban-Loc grids have no zones: all their ground is open and walkable, in the map and
    in the ROS PGM, so a planner sees the robot's start free."""
    import citygen

    name = sorted(n for n in citygen.splits() if n.startswith("urban-loc-") and n.endswith("-test"))[0]
    scene = citygen.generate(name, index=0)
    assert not scene.zones and scene.task is not None
    m = occ.occupancy(scene, resolution=0.1)
    assert m.walkable_mask()[m.cell(*scene.task.start.position)]
    assert m.walkable_mask()[m.labels != occ.OUT_OF_BOUNDS].all()
    back = occ.load(io.BytesIO(occ.npz_bytes(m)))
    assert back.walkable_mask()[back.cell(*scene.task.start.position)]
    pgm = occ.pgm_bytes(m)
    image = np.frombuffer(pgm[-m.shape[0] * m.shape[1] :], dtype=np.uint8).reshape(m.shape)[::-1]
    assert image[m.cell(*scene.task.start.position)] == occ.PGM_FREE


@pytest.mark.parametrize("seed", REGION_SEEDS)
def test_every_object_occupies_a_cell_at_a_quarter_metre(seed):
    """Conservative rasterisation: a post thinner than a cell still marks the cell it stands in."""
    scene = region(seed)
    m = occ.occupancy(scene, resolution=0.25)
    for shape, _ in base_shapes(scene, None):
        x, y = shape.representative_point().coords[0]
        assert m.label_at(x, y) in occ.OBSTACLE_CLASSES


@pytest.mark.parametrize("resolution", [0.05, 0.4])
def test_conservative_all_paints_the_cells_conservative_does(resolution):
    """occupancy.conservative_all (convex bases as one vectorised hull each, the rest edge by
    edge): the same cells as conservative shape by shape, on a street corner's bases (convex
    and not) and a few shapes made to test the turn check."""
    from citygen.exporters.occupancy import _bases, _convex_ring, conservative, conservative_all
    from citygen.geometry.raster import paint

    scene = load_scene(ROOT / "examples" / "street_corner.json")
    shapes = [shape for shape, _ in _bases(scene, None)]
    shapes += [
        Polygon([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)]),  # an L: not convex
        Polygon([(0, 0), (1, 0), (2, 0), (2, 1), (0, 1)]),  # a rectangle with a straight corner
        shapely.affinity.rotate(box(0, 0, 0.03, 1.1), 33.0),  # a thin rotated post
        box(0, 0, 3, 3).difference(box(1, 1, 2, 2)),  # a hole
    ]
    kinds = {_convex_ring(s) is not None for s in shapes}
    assert kinds == {True, False}
    grid = Grid.covering((-3.0, -3.0, 40.0, 40.0), resolution)
    for shape, grown in zip(shapes, conservative_all(shapes, resolution), strict=True):
        want = np.zeros(grid.shape, dtype=bool)
        got = np.zeros(grid.shape, dtype=bool)
        paint(grid, want, conservative(shape, resolution), True)
        paint(grid, got, grown, True)
        assert want.any() and np.array_equal(got, want)
