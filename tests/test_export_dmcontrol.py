"""Exported MJCF in dm_control: its ``mjcf`` parser reads the file, a robot is attached to the
scene, and the XML dm_control writes back compiles and steps in MuJoCo (dm_control 1.0.50's
``Physics`` itself does not support MuJoCo 4, so MuJoCo steps the composed model)."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest

from citygen.exporters import ExportWarning, mjcf
from citygen.generate import generate
from citygen.geometry.terrain import height_at
from citygen.io import load_scene, save_scene
from citygen.spec.config import AgentsConfig, BlocksConfig, GeneratorConfig, PlacementConfig, TaskConfig

dm_mjcf = pytest.importorskip("dm_control.mjcf", reason="dm_control is in the dev extra")
mujoco = mjcf.import_mujoco()

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.json"))

#: A small robot (no name holds a "/"): a box base on four sphere feet, touching the static
#: world only (people may stand at the start).
ROBOT = """
<mujoco model="bot">
  <worldbody>
    <body name="base">
      <geom name="trunk" type="box" size="0.25 0.15 0.08" mass="8" contype="2" conaffinity="1"/>
      <geom name="foot_fl" type="sphere" size="0.05" pos="0.2 0.12 -0.1" contype="2" conaffinity="1"/>
      <geom name="foot_fr" type="sphere" size="0.05" pos="0.2 -0.12 -0.1" contype="2" conaffinity="1"/>
      <geom name="foot_hl" type="sphere" size="0.05" pos="-0.2 0.12 -0.1" contype="2" conaffinity="1"/>
      <geom name="foot_hr" type="sphere" size="0.05" pos="-0.2 -0.12 -0.1" contype="2" conaffinity="1"/>
    </body>
  </worldbody>
</mujoco>
"""


def quiet_export(scene, out: Path) -> Path:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportWarning)
        return mjcf.export(scene, out)[0]


def compose_and_settle(xml_path: Path, x: float, y: float, ground: float, steps: int = 400) -> np.ndarray:
    """Parse with dm_control, attach the robot 0.3 m above the ground at (x, y) with a free
    joint, write the XML back, compile it in MuJoCo and step; the robot base's final position."""
    scene = dm_mjcf.from_path(str(xml_path))
    robot = dm_mjcf.from_xml_string(ROBOT)
    frame = scene.attach(robot)
    frame.pos = [x, y, ground + 0.3]
    frame.add("freejoint")
    xml, assets = scene.to_xml_string(), scene.get_assets()
    model = mujoco.MjModel.from_xml_string(xml, assets)
    data = mujoco.MjData(model)
    for _ in range(steps):
        mujoco.mj_step(model, data)
    assert np.all(np.isfinite(data.qpos))
    return data.xpos[model.body("bot/").id].copy()


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_examples_load_in_dm_control_and_a_robot_lands_on_the_ground(path: Path, tmp_path: Path) -> None:
    scene = load_scene(path)
    xml = quiet_export(path, tmp_path)
    x, y = scene.task.start.position
    ground = float(height_at(scene, x, y))
    pos = compose_and_settle(xml, x, y, ground)
    # The base's centre rests 0.15 m above the ground on its feet (0.1 m down, radius 0.05).
    assert pos[2] == pytest.approx(ground + 0.15, abs=0.03)
    assert np.hypot(pos[0] - x, pos[1] - y) < 0.1


def test_a_street_network_with_every_layer_loads_in_dm_control(tmp_path: Path) -> None:
    config = GeneratorConfig(
        size=(120.0, 120.0),
        layout="blocks",
        blocks=BlocksConfig(count=2, straight_length=(25.0, 40.0)),
        placement=PlacementConfig(count=None, density_per_100m2=1.0),
        agents=AgentsConfig(people=4, vehicles=2),
        task=TaskConfig(kind="traverse", min_distance=30.0, time_limit=100.0),
    )
    scene = generate(config, 11)
    path = tmp_path / "streets.json"
    save_scene(scene, path)
    xml = quiet_export(path, tmp_path)
    parsed = dm_mjcf.from_path(str(xml))
    names = {g.name for g in parsed.find_all("geom")}
    layers = {name.split(mjcf.SEP)[0] for name in names if name}
    assert {"zone", "terrain", "object", "agent"} <= layers
    assert not any("/" in name for name in names if name)
    x, y = scene.task.start.position
    ground = float(height_at(scene, x, y))
    pos = compose_and_settle(xml, x, y, ground, steps=300)
    assert pos[2] == pytest.approx(ground + 0.15, abs=0.05)
