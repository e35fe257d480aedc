"""urban-tra-city (1.2 km x 1.2 km) exported by `citygen export` to every format but PNG and HTML
(the GLB's geometry in a page, :func:`glb.build`'s: test_export_html and test_export_all
check the page), as a user runs it, and every file opened in its real consumer: MJCF compiled
and stepped in MuJoCo (and read by dm_control, a robot attached and the XML it writes stepped
in MuJoCo, on a town of the city's config), the URDF tiles' index checked entry by entry with
every tile read by yourdfpy and the tiles along the traverse route loaded in PyBullet, USD
through usd-core's validators, GLB in trimesh, the occupancy map read back with every object
on an obstacle cell at 0.25 m.

The city is generated once for the run (conftest's ``city_file``, shared with the traffic and
generation tests) and exported once for the module, one `citygen export --format F`
per format, two at a time (the bench times `--format all` in one process); the level of detail
each format chose is what the exporters pick for any scene of this size.
"""

from __future__ import annotations

import json
import math
import os
import struct
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest
import shapely

from citygen.exporters import occupancy, usd
from citygen.exporters.batch import FORMATS
from citygen.exporters.meshes import catalog_asset
from citygen.geometry.terrain import height_at
from citygen.io import load_scene

pytestmark = pytest.mark.slow

NAME = "urban-tra-city-0000"
OCCUPANCY_CELL = 0.25  # m


def run(*args: str) -> subprocess.CompletedProcess:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run(
        [sys.executable, "-m", "citygen", *args], capture_output=True, text=True, env=env, timeout=1200
    )


@pytest.fixture(scope="module")
def city(tmp_path_factory, city_file) -> tuple[Path, Path, dict[str, subprocess.CompletedProcess]]:
    """(scene file, export folder, each format's completed export)."""
    scene = city_file  # conftest's: generated once for the run
    out = tmp_path_factory.mktemp("city") / "export"

    def export(fmt: str) -> subprocess.CompletedProcess:
        extra = ("--occupancy-resolution", str(OCCUPANCY_CELL)) if fmt == "occupancy" else ()
        # Generated scenes are valid; checking the city again for each format costs 9 s of CPU.
        return run("export", str(scene), "--format", fmt, "--out", str(out), "--no-validate", *extra)

    # The longest first. Not png: the city's picture and perspective view (70 s of CPU, a fifth
    # of the fixture) are drawn by bench_export; test_export_all and test_export_view draw them
    # on scenes of every kind, and the view's coarser ground for a large scene. Not html: the
    # GLB's scene graph built again (a sixth of the fixture) and wrapped in a page.
    order = ["urdf", "usd", "glb", "mjcf", "occupancy"]
    assert sorted([*order, "png", "html"]) == sorted(FORMATS)
    with ThreadPoolExecutor(max_workers=2) as pool:
        done = dict(zip(order, pool.map(export, order), strict=True))
    return scene, out, done


@pytest.fixture(scope="module")
def scene(city):
    return load_scene(city[0])


@pytest.fixture(scope="module")
def urdf_index(city) -> dict:
    _, out, _ = city
    return json.loads((out / f"{NAME}-urdf-tiles.json").read_text())


def coarsening(stderr: str, fmt: str) -> list[float]:
    """The errors (cm) of the lines saying how finely ``fmt`` samples the ground."""
    lines = [line for line in stderr.splitlines() if f"$.terrain: {fmt} samples" in line]
    return [float(line.split("(up to ")[1].split(" cm")[0]) for line in lines]


def pieces_tolerance(stderr: str, fmt: str) -> float:
    """How far (cm) ``fmt``'s convex pieces of rough ground may lie from height_at: 1 cm unless
    a line says the budget raised it."""
    lines = [line for line in stderr.splitlines() if f"$.terrain: {fmt} lays the" in line]
    return float(lines[0].split("convex pieces within ")[1].split(" cm")[0]) if lines else 1.0


def test_every_format_is_written_and_each_coarsening_is_one_warning_line(city, scene):
    _, out, done = city
    for fmt, proc in done.items():
        assert proc.returncode == 0, (fmt, proc.stderr[-3000:])
        assert "Traceback" not in proc.stderr, fmt
    suffixes = (
        ".xml",
        ".usda",
        "-urdf-tiles.json",
        ".npz",
        ".yaml",
        ".pgm",
        "-occupancy.png",
        ".glb",
    )
    for suffix in suffixes:
        assert (out / f"{NAME}{suffix}").stat().st_size > 0, suffix
    # MJCF, URDF and GLB each say once how finely they sample the ground and how far off.
    for fmt in ("MJCF", "URDF", "GLB"):
        errors = coarsening(done[fmt.lower()].stderr, fmt)
        assert len(errors) == 1 and 0 < errors[0] < 30, (fmt, errors)
    # URDF samples rougher tiles finer: closer to height_at than the uniform formats.
    assert coarsening(done["urdf"].stderr, "URDF")[0] < coarsening(done["glb"].stderr, "GLB")[0]
    # The occupancy map at its own choice coarsens to fit, saying so in one line.
    res, note = occupancy.auto_resolution(scene)
    assert res > occupancy.DEFAULT_RESOLUTION and "occupancy cells of" in note


def test_the_mjcf_steps_in_mujoco(city):
    from citygen.exporters.mjcf import import_mujoco

    mujoco = import_mujoco()
    _, out, _ = city
    model = mujoco.MjModel.from_xml_path(str(out / f"{NAME}.xml"))
    assert model.ngeom > 10_000 and model.nhfield > 0
    data = mujoco.MjData(model)
    for _ in range(3):
        mujoco.mj_step(model, data)
    assert data.time > 0


def test_dm_control_reads_a_town_and_a_robot_attached_to_it_steps_in_mujoco(town, tmp_path):
    """dm_control's parser on the city's kinds of street, signal, object and agent, in a town
    of the city's config (conftest's ``town``): on the whole city the check costs minutes of
    parsing in dm_control and again in MuJoCo for the composed XML, which the test above
    already does for the city's own file."""
    pytest.importorskip("dm_control.mjcf")
    from citygen.io import save_scene
    from tests.test_export_dmcontrol import compose_and_settle

    path = tmp_path / "town.json"
    save_scene(town, path)
    done = run("export", str(path), "--format", "mjcf", "--out", str(tmp_path))
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr[-3000:]
    x, y = town.task.start.position
    ground = float(height_at(town, x, y))
    pos = compose_and_settle(tmp_path / "town.xml", x, y, ground, steps=200)
    assert pos[2] == pytest.approx(ground + 0.15, abs=0.05)


def test_the_urdf_tiles_cover_the_city_and_each_reads_in_yourdfpy(city, scene, urdf_index):
    import yourdfpy

    _, out, _ = city
    entries = urdf_index["tiles"]
    assert urdf_index["format"] == "citygen.tiles/1" and urdf_index["scene"] == NAME and len(entries) > 1
    boxes = [shapely.box(*e["min"], *e["max"]) for e in entries]
    bounds = shapely.box(*scene.bounds.min, *scene.bounds.max)
    assert shapely.union_all(boxes).equals(bounds)
    assert sum(b.area for b in boxes) == pytest.approx(bounds.area)  # no overlap
    owners: dict[str, list[str]] = {}
    for e in entries:
        robot = yourdfpy.URDF.load(str(out / e["file"]), build_scene_graph=False, load_meshes=False)
        names = [link.name for link in robot.robot.links]
        assert len(names) == e["links"] < 2_000, e["file"]
        for name in names:
            owners.setdefault(name, []).append(e["file"])
    # Every object is a link of exactly one tile: the one its position lies in.
    for pl in scene.placements:
        (file,) = owners[pl.id]
        entry = next(e for e in entries if e["file"] == file)
        assert shapely.box(*entry["min"], *entry["max"]).covers(shapely.Point(pl.position[:2])), pl.id


# PyBullet 3.2.7 takes about 1 s to free a 1,000-link tile alone in its client, but far longer
# for several tiles in one client: each tile gets a client of its own, as a user streaming
# tiles around a robot would load them.
def test_the_tiles_along_the_route_load_in_pybullet_on_the_ground(city, scene, urdf_index):
    import pybullet

    _, out, done = city
    # Rays meet the collision ground: its convex pieces, within their tolerance.
    error = pieces_tolerance(done["urdf"].stderr, "URDF") / 100
    task = scene.task
    points = [task.start.position, *task.route]
    by_tile: dict[str, list] = {}
    for x, y in points:
        e = next(
            e
            for e in urdf_index["tiles"]
            if e["min"][0] <= x < e["max"][0] and e["min"][1] <= y < e["max"][1]
        )
        by_tile.setdefault(e["file"], []).append((x, y))
    checked = 0
    for file, xys in by_tile.items():
        client = pybullet.connect(pybullet.DIRECT)
        try:
            body = pybullet.loadURDF(str(out / file), useFixedBase=True, physicsClientId=client)
            names = {-1: "scene/world"}
            for j in range(pybullet.getNumJoints(body, physicsClientId=client)):
                names[j] = pybullet.getJointInfo(body, j, physicsClientId=client)[12].decode()
            for x, y in xys:
                hit = pybullet.rayTest([x, y, 50.0], [x, y, -50.0], physicsClientId=client)[0]
                assert hit[0] == body, (file, x, y)
                if names[hit[1]].startswith("ground/"):
                    assert hit[3][2] == pytest.approx(float(height_at(scene, x, y)), abs=error + 0.01), (x, y)
                    checked += 1
        finally:
            pybullet.disconnect(client)
    assert len(by_tile) > 1 and checked >= 0.9 * len(points)


def test_the_usd_stage_passes_the_validators(city):
    _, out, _ = city
    assert usd.check(out / f"{NAME}.usda") == []


def test_the_glb_opens_in_trimesh_with_buffer_view_targets(city):
    import trimesh

    _, out, _ = city
    data = (out / f"{NAME}.glb").read_bytes()
    length = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20 : 20 + length])
    assert all(view.get("target") in (34962, 34963) for view in doc["bufferViews"])
    loaded = trimesh.load(out / f"{NAME}.glb")
    assert len(loaded.geometry) > 10 and len(loaded.graph.nodes_geometry) > 3000


def test_every_object_of_the_city_covers_an_obstacle_cell_at_a_quarter_metre(city, scene):
    _, out, _ = city
    m = occupancy.load(out / f"{NAME}.npz")  # as written by the export, at 0.25 m
    assert m.resolution == OCCUPANCY_CELL
    missing = []
    for i, pl in enumerate(scene.placements):
        # A point of the object's base, in the world: the cell holding it overlaps the base.
        px, py = catalog_asset(pl, i).base.representative_point().coords[0]
        c, s = math.cos(pl.yaw), math.sin(pl.yaw)
        x = pl.position[0] + pl.scale * (c * px - s * py)
        y = pl.position[1] + pl.scale * (s * px + c * py)
        if m.label_at(x, y) not in occupancy.OBSTACLE_CLASSES:
            missing.append(pl.id)
    assert not missing, f"{len(missing)} of {len(scene.placements)} objects: no obstacle cell, {missing[:5]}"
