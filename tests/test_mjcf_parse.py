"""Parsing a scene's MJCF in chunks (citygen.exporters.mjcf.parse): the compiled model is the
one-piece parse's to the byte, the robot attached or not; small models are parsed whole."""

from __future__ import annotations

import warnings

import mujoco
import pytest

from citygen.exporters.mjcf import to_mjcf
from citygen.exporters.mjcf.parse import compile_spec, scene_spec
from citygen.io import load_scene
from citygen.runner.robots import compose, load_robot
from citygen.runner.robots import handle as handle_module
from tests.conftest import ROOT

SCENES = ["nav_static_10m.json", "street_corner.json"]


def _bytes(model, tmp_path) -> bytes:
    path = tmp_path / "model.mjb"
    mujoco.mj_saveModel(model, str(path), None)
    return path.read_bytes()


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("chunk", [1, 7, 20])
def test_a_model_parsed_in_chunks_is_the_one_piece_model_to_the_byte(name, chunk, tmp_path):
    mjcf = to_mjcf(load_scene(ROOT / "examples" / name), apron=5.0)
    whole = mujoco.MjSpec.from_string(mjcf.xml, assets=dict(mjcf.assets)).compile()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no stray MuJoCo warning, nor its log file
        parts = compile_spec(scene_spec(mjcf, chunk=chunk))
    assert parts.ngeom == whole.ngeom > chunk
    assert _bytes(parts, tmp_path) == _bytes(whole, tmp_path)
    assert not (ROOT / "MUJOCO_LOG.TXT").exists()


def test_a_composed_scene_with_its_robot_is_the_same_parsed_in_chunks(monkeypatch, tmp_path):
    scene = load_scene(ROOT / "examples" / "street_corner.json")
    mjcf, robot = to_mjcf(scene, apron=5.0), load_robot("quadruped")
    pose = (*scene.task.start.position, 0.0, scene.task.start.yaw)
    whole = compose(mjcf, robot, pose)
    monkeypatch.setattr(handle_module, "scene_spec", lambda m: scene_spec(m, chunk=5))
    parts = compose(mjcf, robot, pose)
    assert _bytes(parts, tmp_path) == _bytes(whole, tmp_path)
