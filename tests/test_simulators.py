"""citygen's exports in the simulators people load them in, as ``docs/simulators/`` shows.

Each page's recipe runs here as written: its ``citygen`` commands (through the CLI), then its
Python lines (MuJoCo, PyBullet, SAPIEN) with a small robot, which must come to rest on the
ground. Then the sphere drop of ``benchmarks/drop.py`` on the recipe's scene (urban-nav-2-test
scene 3: stairs, slopes and rough ground) with each simulator's default loader: no sphere
through the ground, at least 95 % resting within 3 cm of ``height_at``. Genesis compiles its
kernels for minutes on a first run: its recipe and drop run in ``benchmarks/bench_simulators.py``.
For Isaac Sim and Gazebo (not on the package index) the commands run and what their recipes
rely on in the files is checked.
"""

from __future__ import annotations

import math
import os
import re
import shlex
import warnings
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from benchmarks import drop
from citygen.cli import app
from citygen.exporters import ExportWarning, urdf
from citygen.geometry.terrain import height_at
from citygen.io import load_scene
from tests.conftest import ROOT

PAGES = ROOT / "docs" / "simulators"
SCENE = "out/urban-nav-2/test/0003.json"
SPOT = (7.5, 7.5)  # where the recipes drop the robot
#: A 0.4 m x 0.3 m x 0.2 m box of 5 kg with a free base and a mast: the recipes' robot.
ROBOT_URDF = """<?xml version="1.0"?>
<robot name="box"><link name="base">
  <inertial><mass value="5"/><inertia ixx="0.05" ixy="0" ixz="0" iyy="0.08" iyz="0" izz="0.1"/></inertial>
  <collision><geometry><box size="0.4 0.3 0.2"/></geometry></collision>
</link><link name="mast">
  <inertial><mass value="0.1"/><inertia ixx="1e-4" ixy="0" ixz="0" iyy="1e-4" iyz="0" izz="1e-4"/></inertial>
</link><joint name="mast" type="fixed"><parent link="base"/><child link="mast"/></joint></robot>
"""
ROBOT_XML = """<mujoco><worldbody><body name="base"><freejoint/>
  <geom type="box" size="0.2 0.15 0.1" mass="5"/></body></worldbody></mujoco>
"""


def recipe(page: str) -> tuple[list[str], str | None]:
    """A page's ``citygen`` command lines and its Python recipe (None: not run here)."""
    text = (PAGES / page).read_text()
    shell = re.search(r"<!-- recipe-shell -->\n```bash\n(.*?)```", text, re.S)
    code = re.search(r"<!-- recipe -->\n```python\n(.*?)```", text, re.S)
    assert shell is not None, f"{page}: no <!-- recipe-shell --> block"
    assert code is not None or "<!-- not run: " in text, f"{page}: no <!-- recipe --> block"
    return shell.group(1).strip().splitlines(), code.group(1) if code else None


@pytest.fixture(scope="module")
def workdir(tmp_path_factory) -> dict[str, Path]:
    """For each page, a folder where its commands ran, with the recipes' robot files."""
    folders, here = {}, os.getcwd()
    for page in sorted(p.name for p in PAGES.glob("*.md") if p.name != "index.md"):
        folder = folders[page] = tmp_path_factory.mktemp(page.removesuffix(".md"))
        (folder / "robot.urdf").write_text(ROBOT_URDF)
        (folder / "robot.xml").write_text(ROBOT_XML)
        os.chdir(folder)
        try:
            for line in recipe(page)[0]:
                result = CliRunner().invoke(app, shlex.split(line)[1:])
                assert result.exit_code == 0, (page, line, result.output)
        finally:
            os.chdir(here)
    return folders


def run_recipe(page: str, folder: Path, monkeypatch, marker: str = "<!-- recipe -->") -> dict:
    """The page's Python recipe (the block after ``marker``) run in its ``folder``; its variables."""
    monkeypatch.chdir(folder)
    found = re.search(re.escape(marker) + r"\n```python\n(.*?)```", (PAGES / page).read_text(), re.S)
    assert found is not None, (page, marker)
    namespace: dict = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportWarning)
        exec(compile(found.group(1), str(PAGES / page), "exec"), namespace)
    return namespace


def assert_on_the_ground(folder: Path, xyz) -> None:
    """The robot box (its centre ``xyz``) rests on the ground or an object near SPOT."""
    ground = float(height_at(load_scene(folder / SCENE), *xyz[:2]))
    assert math.dist(xyz[:2], SPOT) < 1.0, xyz
    assert ground + 0.05 < xyz[2] < ground + 2.5, (xyz, ground)


def test_every_simulator_has_a_page_with_a_recipe():
    pages = {p.name for p in PAGES.glob("*.md")}
    assert {"mujoco.md", "pybullet.md", "sapien.md", "genesis.md", "isaac.md", "gazebo.md"} <= pages
    for page in pages - {"index.md"}:
        recipe(page)


def test_the_mujoco_recipe(workdir, monkeypatch):
    ns = run_recipe("mujoco.md", workdir["mujoco.md"], monkeypatch)
    assert_on_the_ground(workdir["mujoco.md"], ns["data"].body("robot:base").xpos)


def test_the_pybullet_recipe(workdir, monkeypatch):
    pybullet = pytest.importorskip("pybullet")
    ns = run_recipe("pybullet.md", workdir["pybullet.md"], monkeypatch)
    try:
        for _ in range(240):
            pybullet.stepSimulation(physicsClientId=ns["client"])
        xyz, _ = pybullet.getBasePositionAndOrientation(ns["robot"], physicsClientId=ns["client"])
    finally:
        pybullet.disconnect(ns["client"])
    assert_on_the_ground(workdir["pybullet.md"], xyz)


def test_the_sapien_recipe(workdir, monkeypatch):
    pytest.importorskip("sapien")
    folder = workdir["sapien.md"]
    ns = run_recipe("sapien.md", folder, monkeypatch)
    for _ in range(100):
        ns["scene"].step()
    assert_on_the_ground(folder, ns["robot"].get_root_pose().p)
    # Each link got the URDF's friction, not SAPIEN's default 0.3.
    mu = urdf.frictions(folder / "export/urban-nav-2-test-0003.urdf")
    shapes = {link.name: link.collision_shapes for link in ns["ground"][0].links}
    checked = [name for name, found in shapes.items() if found and name in mu]
    assert "ground/apron" in checked and any(name.startswith("ground/terrain/") for name in checked)
    for name in checked:
        assert [s.physical_material.static_friction for s in shapes[name]] == pytest.approx(
            [mu[name]] * len(shapes[name])
        ), name


def _drop_ok(figures: dict) -> None:
    assert figures["spheres"] >= 80, figures
    assert figures["through"] == 0, figures
    assert figures["resting_pct"] >= 95.0, figures


def test_the_sapien_recipe_for_large_scenes(workdir, monkeypatch):
    """The same ground as static actors."""
    pytest.importorskip("sapien")
    folder = workdir["sapien.md"]
    ns = run_recipe("sapien.md", folder, monkeypatch, "<!-- recipe: static -->")
    for _ in range(100):
        ns["scene"].step()
    assert_on_the_ground(folder, ns["robot"].get_root_pose().p)
    scene = load_scene(folder / SCENE)
    points = drop.drop_points(scene, per_side=6)
    final = drop.sapien_drop([folder / "export/urban-nav-2-test-0003.urdf"], points, static=True)
    figures = drop.score(scene, points, final)
    assert figures["through"] == 0 and figures["resting_pct"] >= 95.0, figures


#: Each drop: the page whose files it loads, and how.
DROPS = {
    "mujoco": ("mujoco.md", lambda export, p: drop.mujoco_drop(export / "urban-nav-2-test-0003.xml", p)),
    "mujoco convex": (
        "genesis.md",
        lambda export, p: drop.mujoco_drop(export / "urban-nav-2-test-0003.xml", p),
    ),
    "pybullet": (
        "pybullet.md",
        lambda export, p: drop.pybullet_drop(export / "urban-nav-2-test-0003.urdf", p),
    ),
    "sapien": ("sapien.md", lambda export, p: drop.sapien_drop([export / "urban-nav-2-test-0003.urdf"], p)),
}


@pytest.mark.parametrize("simulator", list(DROPS))
def test_spheres_rest_on_the_ground(workdir, simulator):
    """The drop on the recipes' scene with each simulator's default loader (MuJoCo: the MJCF
    with heightfields, and the convex one Genesis' recipe exports)."""
    if simulator in ("pybullet", "sapien"):
        pytest.importorskip(simulator)
    page, run = DROPS[simulator]
    scene = load_scene(workdir[page] / SCENE)
    points = drop.drop_points(scene)
    figures = drop.score(scene, points, run(workdir[page] / "export", points))
    assert figures["spheres"] >= 80, figures
    assert figures["through"] == 0, figures
    assert figures["resting_pct"] >= 95.0, figures


def test_the_recipes_mjcf_has_no_heightfields_and_the_urdf_no_visuals(workdir):
    """Genesis' MJCF (--mjcf-terrain convex) and SAPIEN's URDF (--no-visual) as their pages say."""
    xml = ET.parse(workdir["genesis.md"] / "export/urban-nav-2-test-0003.xml").getroot()
    assert xml.find(".//hfield") is None and xml.find(".//geom[@type='hfield']") is None
    assert xml.find(".//geom[@type='box']") is not None
    for page in ("sapien.md", "genesis.md"):
        root = ET.parse(workdir[page] / "export/urban-nav-2-test-0003.urdf").getroot()
        assert root.find(".//visual") is None and root.find(".//collision") is not None


def test_what_the_isaac_recipe_relies_on(workdir):
    from pxr import Usd, UsdGeom, UsdPhysics

    stage = Usd.Stage.Open(str(workdir["isaac.md"] / "export/urban-nav-2-test-0003.usda"))
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    approximations = {
        UsdPhysics.MeshCollisionAPI(prim).GetApproximationAttr().Get()
        for prim in stage.Traverse()
        if prim.HasAPI(UsdPhysics.MeshCollisionAPI) and "terrain" in str(prim.GetPath()).lower()
    }
    assert approximations == {"none"}  # static triangle meshes, which PhysX honours


def test_what_the_gazebo_recipe_relies_on(workdir):
    """Every link's friction is also where SDFormat's URDF reader takes it from."""
    path = workdir["gazebo.md"] / "export/urban-nav-2-test-0003.urdf"
    root = ET.parse(path).getroot()
    gazebo = {
        g.get("reference"): (float(g.findtext("mu1")), float(g.findtext("mu2"))) for g in root.iter("gazebo")
    }
    mu = urdf.frictions(path)
    assert mu and gazebo == {name: (m, m) for name, m in mu.items()}
    assert np.isfinite(list(mu.values())).all()
