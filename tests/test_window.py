"""Locomotion grids a window at a time (citygen.runner.envs.window): the same physics, fewer geoms."""

from __future__ import annotations

import numpy as np
import pytest

from citygen.runner.envs import window
from citygen.runner.make import make_env

pytest.importorskip("mujoco")

# LocoStair's test grid: 16 x 16 regions of 8 m, 8,400 box geoms; 100 steps (2 s) reach
# 2 m, so a window is the start's block of 4 x 4 regions and 2 regions around it.
SPLIT, STEPS = "urban-loc-3-test", 100


@pytest.fixture(autouse=True)
def _window_the_test_grid(monkeypatch):
    # the test grid (8,400 geoms) runs whole by default; windowed here, as a training grid is
    monkeypatch.setattr(window, "FROM_GEOMS", 3000)


def _pair():
    return [
        make_env("loco-stair", robot="quadruped", split=SPLIT, max_steps=STEPS, windowed=w).unwrapped
        for w in (False, True)
    ]


def _same_obs(a: dict, b: dict) -> None:
    assert a.keys() == b.keys()
    for k in a:
        assert a[k].tobytes() == b[k].tobytes(), k


def test_windowed_grid_steps_the_whole_grids_physics_to_the_bit():
    whole, windowed = _pair()
    rng = np.random.default_rng(0)
    regions = [(0, 0), (7, 9), (15, 15), (3, 12)]  # corners, the middle, an edge
    sizes = set()
    for k, region in enumerate(regions):
        obs = [e.reset(seed=k, options={"region": region})[0] for e in (whole, windowed)]
        _same_obs(*obs)
        assert windowed._window is not None and windowed.model.ngeom < whole.model.ngeom / 2
        sizes.add(windowed.model.ngeom)
        for action in rng.uniform(-0.4, 0.4, (STEPS, whole.n_actions)):
            got = [e.step(action) for e in (whole, windowed)]
            _same_obs(got[0][0], got[1][0])
            assert got[0][1:] == got[1][1:]  # reward, terminated, truncated, info (metrics)
            assert windowed.data.qpos.tobytes() == whole.data.qpos.tobytes()
            if got[0][2] or got[0][3]:
                break
    assert len(sizes) > 1  # windows of different blocks


def test_robot_near_a_windows_edge_moves_to_the_whole_grid_and_carries_on_to_the_bit():
    whole, windowed = _pair()
    for e in (whole, windowed):
        e.reset(seed=5, options={"region": (8, 8)})
    box = windowed._window.box
    # put both robots 1 m from the window's edge (past its guard), as a fast robot would come
    for e in (whole, windowed):
        e.data.qpos[e.handle.qadr] = box[2] - 1.0
        e.data.qvel[:] = 0.0
    model = windowed.model
    rng = np.random.default_rng(1)
    for action in rng.uniform(-0.3, 0.3, (40, whole.n_actions)):
        got = [e.step(action) for e in (whole, windowed)]
        _same_obs(got[0][0], got[1][0])
        assert got[0][1:] == got[1][1:]
        if got[0][2] or got[0][3]:
            break
    assert windowed._window is None and windowed.model is whole.model is not model
    assert windowed.data.qpos.tobytes() == whole.data.qpos.tobytes()


def test_grids_of_fewer_geoms_run_whole(monkeypatch):
    monkeypatch.undo()  # the default threshold: the test grids run whole, as they always did
    for task, split in (("loco-stair", SPLIT), ("loco-flat", "urban-loc-1-test")):
        env = make_env(task, robot="quadruped", split=split, max_steps=STEPS).unwrapped
        env.reset(seed=0)
        env._whole._windows.clear()  # decided once per compiled grid: maybe by another test
        env.reset(seed=0)
        assert env._window is None and env.model is env._whole.model
