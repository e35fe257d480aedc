"""The per-process cache of compiled scenes (citygen.runner.scenes.SceneCache): bounded by
memory, and a scene it kept runs exactly as one compiled afresh."""

from __future__ import annotations

import numpy as np
import pytest

from citygen.errors import SpecError
from citygen.runner import scenes
from citygen.runner.envs import base as envs
from citygen.runner.make import make_env


class _Stub:
    def __init__(self, nbytes: int):
        self.nbytes = nbytes

    def footprint(self) -> int:
        return self.nbytes


class _Source:
    def key(self, index: int) -> tuple:
        return ("stub", index)

    def scene(self, index: int) -> int:
        return index


class _Robot:
    name, timestep, cone, xml = "stub", 0.005, "elliptic", "<robot/>"


def test_the_cache_keeps_what_its_budget_holds_and_always_the_scene_in_use(monkeypatch):
    def prepare(scene, robot, terrain, people=False, store=None):  # prepare's signature
        return _Stub(10 + scene)

    monkeypatch.setattr(scenes, "prepare", prepare)
    cache = scenes.SceneCache(budget=34)
    source, robot = _Source(), _Robot()
    for i in range(4):
        cache.get(source, i, robot)
    assert [k[0][1] for k in cache._items] == [2, 3]  # 12 + 13 fit in 34, 11 more would not
    assert cache.bytes == 25 and cache.misses == 4
    cache.get(source, 2, robot)  # a hit: most recently used now, so 3 goes first
    cache.get(source, 0, robot)
    assert [k[0][1] for k in cache._items] == [2, 0] and cache.hits == 1
    tight = scenes.SceneCache(budget=0)
    for i in range(3):
        assert tight.get(source, i, robot).nbytes == 10 + i
        assert len(tight._items) == 1 and tight.bytes == 10 + i


def test_the_budget_comes_from_the_environment_variable(monkeypatch):
    monkeypatch.delenv(scenes.CACHE_ENV, raising=False)
    assert scenes.cache_budget() == scenes.CACHE_MB << 20
    monkeypatch.setenv(scenes.CACHE_ENV, "1.5")
    assert scenes.cache_budget() == 3 << 19
    monkeypatch.setenv(scenes.CACHE_ENV, "0")
    assert scenes.SceneCache().budget == 0
    for bad in ("lots", "-1", "nan"):
        monkeypatch.setenv(scenes.CACHE_ENV, bad)
        with pytest.raises(SpecError, match=scenes.CACHE_ENV):
            scenes.cache_budget()


def _episode(env, index: int, seed: int, steps: int = 25) -> list[np.ndarray]:
    obs, _ = env.reset(seed=seed, options={"index": index})
    out = [obs["goal"], obs["local_map"]]
    for a in np.random.default_rng(seed).uniform(-1, 1, (steps, 2)).astype(np.float32):
        obs, reward, *_ = env.step(a)
        out += [obs["goal"], obs["velocity"], obs["height_map"], np.float64(reward)]
    return out


def test_a_kept_scene_runs_as_one_compiled_afresh(monkeypatch):
    """Coming back to a scene the cache kept (its model, maps and this environment's MjData
    reused) gives the same episode, to the bit, as compiling it again; and the footprint
    counts the model and the maps."""
    runs = []
    for budget in (scenes.CACHE_MB << 20, 0):
        monkeypatch.setattr(envs, "process_cache", lambda b=budget: _fresh(b))
        _CACHES.clear()
        env = make_env("nav-static", split="urban-nav-2-train")
        _episode(env, 0, seed=1)
        _episode(env, 1, seed=2)
        runs.append(_episode(env, 0, seed=3))
        cache = _CACHES[0]
        assert (cache.hits, len(cache._items)) == ((1, 2) if budget else (0, 1))
        prepared = env.unwrapped.prepared
        cells, model = prepared.occupancy.heights.size, prepared.model.nbuffer
        assert model + 16 * cells < prepared.footprint() < model + 40 * cells
        env.close()
    for kept, fresh in zip(*runs, strict=True):
        np.testing.assert_array_equal(kept, fresh)


_CACHES: list[scenes.SceneCache] = []


def _fresh(budget: int) -> scenes.SceneCache:
    if not _CACHES:
        _CACHES.append(scenes.SceneCache(budget=budget))
    return _CACHES[0]


def test_a_bad_budget_is_one_line_from_train_and_bench_and_writes_nothing(cli, monkeypatch, tmp_path):
    scenes.process_cache()  # built already, as after any earlier test in this process: bench checks anyway
    monkeypatch.setenv(scenes.CACHE_ENV, "lots")
    r = cli("train", "--task", "nav-clear", "--steps", "10", "--out", tmp_path / "run")
    assert r.code == 2 and r.err.count("\n") == 1 and scenes.CACHE_ENV in r.err and "'lots'" in r.err
    assert not (tmp_path / "run").exists()
    r = cli("bench", "--task", "nav-static", "--episodes", "1", "--output", tmp_path / "b.json")
    assert r.code == 2 and r.err.count("\n") == 1 and scenes.CACHE_ENV in r.err
    assert not (tmp_path / "b.json").exists()
