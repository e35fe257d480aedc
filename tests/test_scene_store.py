"""The on-disk store of prepared scenes (citygen.runner.scene_store): a second process's first
visit reads what the first prepared and runs the same episode; entries are keyed by the
scene's, the robot's and the code's content; a broken entry or an unwritable folder is never
an error; the store keeps to its budget."""

from __future__ import annotations

import dataclasses
import json
import os
import subprocess
import sys

import numpy as np
import pytest

from citygen.runner import scene_store
from citygen.runner.envs import base as envs_base
from citygen.runner.make import make_env
from citygen.runner.scenes import SceneCache, SceneSource
from tests.conftest import ROOT

SCENE = ROOT / "examples" / "nav_static_10m.json"

EPISODE = """
import hashlib, json, numpy as np
from citygen.runner import scene_store
from citygen.runner.make import make_env
env = make_env("nav-static", split="urban-nav-2-test")
obs, _ = env.reset(seed=5, options={"index": 3})
h = hashlib.sha256()
for t in range(30):
    obs, r, term, trunc, _ = env.step(np.array([0.8, 0.3 * np.sin(t / 5)]))
    h.update(np.concatenate([np.ravel(v) for v in obs.values()]).tobytes() + np.float64(r).tobytes())
s = scene_store.store()
print(json.dumps({"hash": h.hexdigest(), "hits": s.hits, "writes": s.writes}))
"""


def _episode(folder) -> dict:
    env = {**os.environ, "CITYGEN_CACHE_DIR": str(folder)}
    proc = subprocess.run([sys.executable, "-c", EPISODE], capture_output=True, text=True, env=env, cwd=ROOT)
    assert proc.returncode == 0, proc.stderr[-2000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_a_second_process_reads_what_the_first_prepared_and_runs_the_same_episode(tmp_path):
    first, second = _episode(tmp_path), _episode(tmp_path)
    assert (first["hits"], first["writes"]) == (0, 1)
    assert (second["hits"], second["writes"]) == (1, 0)
    assert second["hash"] == first["hash"]
    assert len(list((tmp_path / "scenes").glob("*/*.pkl.z"))) == 1


@pytest.fixture
def store(tmp_path, monkeypatch):
    monkeypatch.setenv("CITYGEN_CACHE_DIR", str(tmp_path))
    return scene_store.store()


def test_entries_are_keyed_by_the_scenes_the_robots_and_the_codes_content(tmp_path):
    env = make_env("nav-static", scene=SCENE)
    wheeled, quadruped = (
        env.unwrapped.robot,
        make_env("nav-static", scene=SCENE, robot="quadruped").unwrapped.robot,
    )
    key = SceneSource(scene=SCENE).content_key(0)
    assert scene_store.entry_key(key, wheeled) != scene_store.entry_key(key, quadruped)
    # the same robot with another friction cone compiles another model
    elliptic = dataclasses.replace(wheeled, cone="elliptic")
    assert scene_store.entry_key(key, elliptic) != scene_store.entry_key(key, wheeled)
    # the same scene in another file is the same entry; an edited one is not
    text = json.loads(SCENE.read_text())
    (tmp_path / "a.json").write_text(json.dumps(text))
    assert SceneSource(scene=tmp_path / "a.json").content_key(0) == key
    text["placements"][0]["position"][0] += 0.5
    (tmp_path / "b.json").write_text(json.dumps(text))
    assert SceneSource(scene=tmp_path / "b.json").content_key(0) != key
    # a split's scenes by their part's config and index, without generating them
    split = SceneSource(split="urban-nav-2-test")
    assert (
        split.content_key(1) != split.content_key(2) == SceneSource(split="urban-nav-2-test").content_key(2)
    )
    assert split.content_key(2) != SceneSource(split="urban-nav-2-test", seed=9).content_key(2)


def test_a_stored_scene_is_the_prepared_one(store):
    source = SceneSource(split="urban-nav-2-test")
    robot = make_env("nav-static", split="urban-nav-2-test").unwrapped.robot
    fresh = SceneCache().get(source, 4, robot)
    again = SceneCache().get(source, 4, robot)
    assert (store.writes, store.hits) == (1, 1)
    assert again.scene == fresh.scene and again.robot is robot
    for name in ("free", "walkable", "crossable", "obstacle_geoms", "ground_geoms"):
        assert np.array_equal(getattr(again, name), getattr(fresh, name)), name
    assert np.array_equal(again.occupancy.heights, fresh.occupancy.heights)
    assert again.model.ngeom == fresh.model.ngeom and again.agent_bodies == fresh.agent_bodies


def test_a_broken_entry_is_a_miss_and_is_written_again(store):
    source = SceneSource(scene=SCENE)
    robot = make_env("nav-static", scene=SCENE).unwrapped.robot
    SceneCache().get(source, 0, robot)
    (entry,) = (store.root).glob("*/*.pkl.z")
    entry.write_bytes(entry.read_bytes()[:100])  # truncated, as by a full disk or a kill
    prepared = SceneCache().get(source, 0, robot)
    assert prepared.model.ngeom > 0 and store.writes == 2 and entry.stat().st_size > 1000


def test_an_unwritable_folder_or_off_keeps_nothing_and_fails_nothing(tmp_path, monkeypatch):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a folder")
    monkeypatch.setenv("CITYGEN_CACHE_DIR", str(blocker))
    # a cache of this test's own: a worker's earlier test may hold this scene in the process's
    # cache, and then the store would never be asked (the CI failure of stop 51)
    cache = SceneCache()
    monkeypatch.setattr(envs_base, "process_cache", lambda: cache)
    env = make_env("nav-static", scene=SCENE)
    env.reset(seed=0)
    env.step(env.action_space.sample())
    assert scene_store.store()._unwritable and scene_store.store().writes == 0
    monkeypatch.setenv("CITYGEN_CACHE_DIR", "off")
    assert scene_store.store() is None


def test_the_store_keeps_to_its_budget_dropping_the_oldest_first(tmp_path):
    s = scene_store.SceneStore(tmp_path, budget_mb=0.5)
    for k in range(6):
        path = s.path(f"{k:02d}" * 32)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_bytes(b"x" * 200_000)
        os.utime(path, (1000 + k, 1000 + k))
    s.prune()
    left = sorted(p.name[:2] for p in tmp_path.glob("*/*.pkl.z"))
    assert left == ["04", "05"]  # 400 KB within 0.5 MiB, the two most recently used


CORNER = ROOT / "examples" / "street_corner.json"


def _walk(crowd, steps: int = 40) -> np.ndarray:
    """The crowd's positions over ``steps`` steps with a robot standing still in it."""
    out = []
    for _ in range(steps):
        crowd.step(np.array([12.0, 6.0]), np.zeros(2), 0.35)
        out.append(crowd.pos.copy())
    return np.array(out)


def test_a_crowds_stored_tables_are_the_computed_ones_and_move_it_the_same(store):
    from citygen.runner.agents.crowd import TABLES_ENTRY, crowd_of

    source = SceneSource(scene=CORNER)
    robot = make_env("nav-dynamic", scene=CORNER).unwrapped.robot
    fresh = SceneCache().get(source, 0, robot)
    first = crowd_of(fresh, fresh.scene, rng=np.random.default_rng(3), dt=0.1)
    assert store.array_path(fresh.store_key, f"{TABLES_ENTRY}-paths").is_file()
    again = SceneCache().get(source, 0, robot)  # a second process's first visit
    second = crowd_of(again, again.scene, rng=np.random.default_rng(3), dt=0.1)
    for name, want in first.tables().items():
        got = second.tables()[name]
        assert isinstance(got, np.memmap) and not isinstance(want, np.memmap), name
        assert got.dtype == want.dtype and np.array_equal(got, want), name
    assert np.array_equal(_walk(second), _walk(first))


@pytest.mark.parametrize("damage", ["truncated", "out of range"])
def test_a_broken_path_table_is_computed_and_written_again(store, damage):
    from citygen.runner.agents.crowd import TABLES_ENTRY, crowd_of

    source = SceneSource(scene=CORNER)
    robot = make_env("nav-dynamic", scene=CORNER).unwrapped.robot
    prepared = SceneCache().get(source, 0, robot)
    want = crowd_of(prepared, prepared.scene, rng=np.random.default_rng(3), dt=0.1)._hop.copy()
    path = store.array_path(prepared.store_key, f"{TABLES_ENTRY}-paths")
    if damage == "truncated":
        path.write_bytes(path.read_bytes()[:-100])
    else:
        bad = want.copy()
        bad.flat[0] = 10**8  # the right size, an entry no node has
        np.save(path, bad)
    again = SceneCache().get(source, 0, robot)
    writes = store.writes
    crowd = crowd_of(again, again.scene, rng=np.random.default_rng(3), dt=0.1)
    assert not isinstance(crowd._hop, np.memmap) and np.array_equal(crowd._hop, want)
    assert store.writes == writes + 3 and np.array_equal(np.load(path), want)  # the three tables


def test_a_big_entry_is_stored_uncompressed_and_reads_the_same(store, monkeypatch):
    monkeypatch.setattr(scene_store, "COMPRESS_BELOW", 0)  # every entry "big"
    source = SceneSource(scene=SCENE)
    robot = make_env("nav-static", scene=SCENE).unwrapped.robot
    fresh = SceneCache().get(source, 0, robot)
    (entry,) = store.root.glob("*/*.pkl.z")
    assert entry.read_bytes()[:1] == b"\x80"  # a pickle, not a zlib stream
    again = SceneCache().get(source, 0, robot)
    assert store.hits == 1 and np.array_equal(again.free, fresh.free)
    assert again.model.ngeom == fresh.model.ngeom
    entry.write_bytes(entry.read_bytes()[:1000])  # truncated: a miss, written again
    assert SceneCache().get(source, 0, robot).model.ngeom == fresh.model.ngeom and store.writes == 2


def test_a_big_model_is_kept_beside_its_entry_in_mujocos_format_and_reads_the_same(store, monkeypatch):
    import mujoco

    monkeypatch.setattr(scene_store, "MJB_FROM", 0)  # every model "big"
    source = SceneSource(scene=SCENE)
    robot = make_env("nav-static", scene=SCENE).unwrapped.robot
    fresh = SceneCache().get(source, 0, robot)
    (model_file,) = store.root.glob("*/*.mjb")
    (entry,) = store.root.glob("*/*.pkl.z")
    assert model_file.name.startswith(entry.name.split(".")[0])
    again = SceneCache().get(source, 0, robot)
    assert store.hits == 1 and again.model is not fresh.model

    def saved(model) -> bytes:
        buffer = np.empty(mujoco.mj_sizeModel(model), dtype=np.uint8)
        mujoco.mj_saveModel(model, None, buffer)
        return buffer.tobytes()

    assert saved(again.model) == saved(fresh.model)
    model_file.write_bytes(model_file.read_bytes()[:1000])  # truncated: a miss, written again
    writes = store.writes
    monkeypatch.chdir(store.root)
    assert SceneCache().get(source, 0, robot).model.ngeom == fresh.model.ngeom
    assert not (store.root / "MUJOCO_LOG.TXT").exists(), "MuJoCo was handed the truncated file"
    assert store.writes == writes + 1 and saved(mujoco.MjModel.from_binary_path(str(model_file))) == saved(
        fresh.model
    )


def test_a_scenes_stored_local_map_layers_are_the_computed_ones(store, monkeypatch):
    from types import SimpleNamespace

    from citygen.runner import localmap

    monkeypatch.setattr(localmap, "STORE_LAYERS_FROM", 0)  # as if it were a town

    source = SceneSource(scene=CORNER)
    robot = make_env("nav-dynamic", scene=CORNER).unwrapped.robot
    fresh = SceneCache().get(source, 0, robot)
    want = localmap._layers_of(SimpleNamespace(prepared=fresh))
    assert store.array_path(fresh.store_key, f"{localmap.LAYERS_ENTRY}-elevation").is_file()
    again = SceneCache().get(source, 0, robot)  # a second process's first visit
    got = localmap._layers_of(SimpleNamespace(prepared=again))
    assert isinstance(got.elevation, np.memmap) and not isinstance(want.elevation, np.memmap)
    for name in ("elevation", "walkable", "crossable"):
        a, b = getattr(got, name), getattr(want, name)
        assert a.dtype == b.dtype and np.array_equal(a, b), name
    assert (got.x0, got.y0, got.cell) == (want.x0, want.y0, want.cell)
    pose = (float(fresh.scene.task.start.position[0]), float(fresh.scene.task.start.position[1]), 0.3)
    assert np.array_equal(localmap.LocalMap()(got, pose, 0.0), localmap.LocalMap()(want, pose, 0.0))


@pytest.mark.parametrize("split", ["urban-nav-2-test", "urban-loc-3-test", "urban-tra-standard"])
def test_a_scenes_digest_is_the_one_json_dumps_gave(split):
    """The store's key of a scene (pydantic-core's JSON) is the digest json.dumps gave."""
    import citygen
    from citygen.runner.scenes import _digest, _digest_reference

    scene = citygen.generate(split, index=0)
    assert _digest(scene) == _digest_reference(scene)
    moved = scene.model_copy(update={"bounds": scene.bounds.model_copy(update={"max": (1.0, 2.0)})})
    assert _digest(moved) == _digest_reference(moved) != _digest(scene)


def test_a_caller_holding_the_scene_gets_it_attached_and_others_the_stored_copy(store):
    """An entry holds its scene after the prepared scene: a source given the scene object
    gets that object back (the stored copy is not read); a source by split, the stored copy."""
    import citygen

    scene = citygen.generate("urban-nav-2-test", index=4)
    robot = make_env("nav-static", scene=scene).unwrapped.robot
    first = SceneCache().get(SceneSource(scene=scene), 0, robot)
    held = SceneCache().get(SceneSource(scene=scene), 0, robot)
    assert store.hits == 1 and held.scene is scene and first.scene is scene
    (entry,) = store.root.glob("*/*.pkl.z")
    read = store.load(entry.name.removesuffix(".pkl.z"), robot)
    assert read.scene == scene and read.scene is not scene
    assert np.array_equal(read.free, held.free)
