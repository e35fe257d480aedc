"""Parsing a scene's MJCF in chunks (citygen.exporters.mjcf.parse): the compiled model is the
one-piece parse's to the byte, the robot attached or not; small models are parsed whole. Its
static bodies read as frames (a town's, a city's): MuJoCo's fused model to the byte. The
runner's tree with heightfields as arrays (to_tree): the text's model to the byte."""

from __future__ import annotations

import functools
import warnings
import xml.etree.ElementTree as ET

import mujoco
import pytest

from citygen.exporters.mjcf import to_mjcf, to_tree
from citygen.exporters.mjcf.parse import compile_spec, scene_spec, static_frames
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
    monkeypatch.setattr(handle_module, "scene_spec", lambda m, **kw: scene_spec(m, chunk=5, **kw))
    parts = compose(mjcf, robot, pose)
    assert _bytes(parts, tmp_path) == _bytes(whole, tmp_path)


def _fused(spec):
    spec.compiler.fusestatic = True
    return compile_spec(spec)


@pytest.mark.parametrize("name", SCENES)
@pytest.mark.parametrize("chunk", [7, 4000])
def test_static_bodies_read_as_frames_make_the_fused_model_to_the_byte(name, chunk, tmp_path):
    """scene_spec(frames=True): the objects' bodies read as frames of the world compile to
    what MuJoCo's fusestatic makes of them, in chunks or whole."""
    mjcf = to_mjcf(load_scene(ROOT / "examples" / name), apron=5.0)
    assert static_frames(ET.fromstring(mjcf.xml)) >= 3  # the objects' bodies
    fused = _fused(mujoco.MjSpec.from_string(mjcf.xml, assets=dict(mjcf.assets)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        framed = _fused(scene_spec(mjcf, chunk=chunk, frames=True))
    assert framed.nbody == fused.nbody
    assert _bytes(framed, tmp_path) == _bytes(fused, tmp_path)


def test_a_composed_town_reads_its_static_bodies_as_frames(monkeypatch, tmp_path):
    """compose on a scene of town size (FUSE_FROM_GEOMS): the same model to the byte as
    MuJoCo fusing the bodies itself, the robot's own static bodies fused as before."""
    scene = load_scene(ROOT / "examples" / "street_corner.json")
    mjcf, robot = to_mjcf(scene, apron=5.0), load_robot("quadruped")
    pose = (*scene.task.start.position, 0.0, scene.task.start.yaw)
    monkeypatch.setattr(handle_module, "FUSE_FROM_GEOMS", 0)
    calls = []
    monkeypatch.setattr(handle_module, "scene_spec", lambda m, **kw: calls.append(kw) or scene_spec(m, **kw))
    framed = compose(mjcf, robot, pose)
    monkeypatch.setattr(handle_module, "scene_spec", lambda m, **kw: scene_spec(m))
    fused = compose(mjcf, robot, pose)
    assert calls == [{"frames": True}]
    assert _bytes(framed, tmp_path) == _bytes(fused, tmp_path)


def test_frames_leave_moving_and_referenced_bodies_as_they_are():
    """Only a static body of geoms alone becomes a frame, placed after the world's own geoms;
    a model whose other sections could name a body is left whole."""
    xml = (
        '<mujoco><worldbody><body name="a" pos="1 0 0"><geom size="1"/></body>'
        '<geom name="g" size="1"/><body name="m" mocap="true"><geom size="1"/></body>'
        '<body name="j"><joint/><geom size="1"/></body><body name="s"><site/><geom size="1"/></body>'
        '<body name="e"/></worldbody></mujoco>'
    )
    root = ET.fromstring(xml)
    assert static_frames(root) == 1
    assert [(el.tag, el.get("name")) for el in root.find("worldbody")] == [
        ("geom", "g"), ("frame", None), ("body", "m"), ("body", "j"), ("body", "s"), ("body", "e"),
    ]  # fmt: skip
    assert root.find("worldbody/frame").get("pos") == "1 0 0"
    exclude = '<contact><exclude body1="a" body2="m"/></contact></mujoco>'
    referring = ET.fromstring(xml.replace("</mujoco>", exclude))
    assert static_frames(referring) == 0


@functools.cache
def _terrain_scene(split: str):
    from citygen.runner.scenes import SceneSource

    return SceneSource(split=split).scene(0)


def _tree_cases():
    """A street corner (objects' bodies, no terrain), a rough grid and a slope grid
    (heightfields), by name -> scene."""
    return {
        "street_corner": lambda: load_scene(ROOT / "examples" / "street_corner.json"),
        "rough": lambda: _terrain_scene("urban-loc-4-test"),
        "slope": lambda: _terrain_scene("urban-loc-2-test"),
    }


@pytest.mark.parametrize("name", ["street_corner", "rough", "slope"])
@pytest.mark.parametrize("terrain", ["heightfield", "hybrid"])
@pytest.mark.parametrize(("chunk", "frames"), [(100000, False), (7, False), (7, True), (4000, True)])
def test_a_tree_with_heightfield_arrays_is_the_text_model_to_the_byte(name, terrain, chunk, frames, tmp_path):
    """to_tree (the runner's: the XML as a tree, heightfields' samples as arrays) reads into
    the model to_mjcf's text does, whole, in chunks or its bodies as frames; the tree
    is left as it was (read twice, the same model)."""
    scene = _tree_cases()[name]()
    text = to_mjcf(scene, apron=5.0, terrain=terrain)
    tree = to_tree(scene, apron=5.0, terrain=terrain)
    hfields = text.xml.count("<hfield ")
    assert sum(1 for _ in tree.root.iter("hfield")) == hfields
    assert len(tree.hfields) == hfields and dict(tree.assets) == dict(text.assets)
    assert (hfields > 0) == (name == "rough" or (name == "slope" and terrain == "heightfield"))
    assert "elevation" not in tree.xml
    compile_ = _fused if frames else compile_spec
    want = compile_(scene_spec(text, chunk=chunk, frames=frames))
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        got = compile_(scene_spec(tree, chunk=chunk, frames=frames))
        again = compile_(scene_spec(tree, chunk=chunk, frames=frames))
    assert got.nhfield == hfields and got.nhfielddata == want.nhfielddata
    assert _bytes(got, tmp_path) == _bytes(want, tmp_path)
    assert _bytes(again, tmp_path) == _bytes(want, tmp_path)


def test_a_composed_tree_is_the_composed_text_and_steps_alike(tmp_path):
    """compose on the tree and on the text: the same model to the byte, the same steps."""
    scene = _terrain_scene("urban-loc-4-test")
    robot = load_robot("quadruped")
    pose = (*scene.task.start.position, 0.5, scene.task.start.yaw)
    a = compose(to_mjcf(scene, apron=5.0, terrain="hybrid"), robot, pose)
    b = compose(to_tree(scene, apron=5.0, terrain="hybrid"), robot, pose)
    assert _bytes(a, tmp_path) == _bytes(b, tmp_path)
    da, db = mujoco.MjData(a), mujoco.MjData(b)
    mujoco.mj_step(a, da, nstep=50)
    mujoco.mj_step(b, db, nstep=50)
    assert (da.qpos == db.qpos).all() and (da.qvel == db.qvel).all()
