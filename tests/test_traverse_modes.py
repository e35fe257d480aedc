"""The traverse on learned legs and the paper's four control modes (issue 47), on the smallest
scene that shows each point: the 10 m NavStatic example with a two-waypoint traverse task,
and hand-made occupancy maps for the dispatch rules. The full track is
``citygen bench --task traverse --split urban-tra-standard --locomotion learned --policy MODE``
(docs/training.md)."""

from __future__ import annotations

import math
from types import SimpleNamespace

import mujoco
import numpy as np
import pytest

from citygen.exporters.occupancy import CLASSES, OccupancyMap
from citygen.geometry.raster import Grid
from citygen.io import load_scene, save_scene
from citygen.runner import policies
from citygen.runner.envs.traverse import RETRY_JITTER
from citygen.runner.make import make_env
from citygen.spec.blocks import Pose2
from citygen.spec.task import TraverseTask
from tests.conftest import EXAMPLES

NAV = next(p for p in EXAMPLES if p.name == "nav_static_10m.json")


def _tiny_traverse(time_limit: float = 3.0):
    """The 10 m example with a traverse of two waypoints from its start."""
    scene = load_scene(NAV)
    task = TraverseTask(
        kind="traverse", robot="quadruped", start=Pose2(position=(0.8, 5.0), yaw=0.0),
        time_limit=time_limit, route=((4.0, 5.0), (9.2, 4.4)), goal_tolerance=0.5,
    )  # fmt: skip
    return scene.model_copy(update={"task": task})


def _flip(env) -> None:
    """Upside down 0.1 m over the ground: the body lies on it, LocoEnv's fall. (Dropped from
    half a metre, the general model that follows navigation's commands rolls over in the air
    and lands on its feet.)"""
    q = env.handle.qadr
    env.data.qpos[q + 2] = env.prepared.ground_at(env.data.qpos[q], env.data.qpos[q + 1]) + 0.1
    env.data.qpos[q + 3 : q + 7] = (0.0, 1.0, 0.0, 0.0)
    mujoco.mj_forward(env.model, env.data)


def test_the_traverse_walks_on_learned_legs_and_a_fall_is_a_failed_trial():
    env = make_env("traverse", _tiny_traverse(), robot="quadruped", locomotion="learned")
    env.reset(seed=0)
    assert env.terrain == "hybrid" and env.legs.model == "general"
    for _ in range(5):
        _, _, terminated, _, info = env.step(np.array([0.5, 0.0]))
    assert not terminated and info["attempts"] == 0 and not env.legs.fell
    _flip(env)
    for _ in range(20):
        _, reward, terminated, truncated, info = env.step(np.zeros(2))
        if info["attempts"]:
            break
    # A failed trial, not the end: put back standing at the last waypoint (the start), the
    # legs' state cleared, one attempt counted.
    assert info["attempts"] == 1 and env.falls == 1 and not (terminated or truncated) and reward < -90
    assert not env.legs.fell and not env.legs.last_action.any() and not env.legs.command.any()
    # Within RETRY_JITTER of it, as a person sets a robot down.
    x, y, _, yaw = env.handle.pose(env.data)
    (jx, jyaw), first = RETRY_JITTER, (x, y, yaw)
    assert max(abs(x - 0.8), abs(y - 5.0)) < jx + 0.02 and abs(yaw) < jyaw + 0.02
    assert env.data.xmat[env.handle.base_id][8] > 0.95
    # The reset step records where the robot was put, so Speed leaves the jump back out.
    assert math.dist(env.recorder.positions[-1], (x, y)) < 1e-9 and env.recorder.reset[-1]
    # Never twice the same: the second trial does not replay the first (MuJoCo is deterministic).
    _flip(env)
    for _ in range(20):
        _, _, terminated, truncated, info = env.step(np.zeros(2))
        if info["attempts"] == 2:
            break
    x, y, _, yaw = env.handle.pose(env.data)
    assert info["attempts"] == 2 and math.dist((x, y), first[:2]) > 1e-3 and abs(yaw - first[2]) > 1e-4
    while not (terminated or truncated):
        _, _, terminated, truncated, info = env.step(np.zeros(2))
    m = info["metrics"]
    assert (m["falls"], m["attempts"], m["labor_cost"], m["terrain_model_time"]) == (2.0, 2.0, 0.0, 0.0)


def _occupancy(slope_x: tuple[float, float] = (5.0, 7.0), building: tuple[float, float] | None = None):
    """A 10 m x 4 m sidewalk with a slope tile across ``slope_x`` and optionally a building
    cell block at ``building``."""
    grid = Grid.covering((0.0, 0.0, 10.0, 4.0), 0.1)
    labels = np.full(grid.shape, CLASSES.index("sidewalk"), dtype=np.uint8)
    terrain = np.zeros(grid.shape, np.uint8)
    xs = grid.xs()
    terrain[:, (xs >= slope_x[0]) & (xs <= slope_x[1])] = OccupancyMap.terrain_classes.index("slope")
    if building is not None:
        labels[grid.cell(*building)] = CLASSES.index("building")
    return OccupancyMap(labels, np.zeros(grid.shape, np.float32), terrain, grid)


def _at(occ, x: float, y: float, yaw: float = 0.0, others=()):
    return SimpleNamespace(
        handle=SimpleNamespace(pose=lambda data: (x, y, 0.3, yaw)),
        data=None,
        prepared=SimpleNamespace(occupancy=occ),
        others=lambda: (np.asarray(others, dtype=float).reshape(-1, 2), None, None),
    )


def test_mode_1_dispatches_the_terrain_model_of_the_ground_ahead():
    occ = _occupancy()
    ahead = {
        (3.5, 0.0): "flat",  # the slope starts 1.5 m ahead
        (4.2, 0.0): "slope",  # a metre before it
        (6.0, 0.0): "slope",
        (7.2, 0.0): "slope",  # the hind feet still on it
        (7.5, 0.0): "flat",
        (4.2, math.pi): "flat",  # facing away from it
    }
    for (x, yaw), kind in ahead.items():
        assert policies.ground_ahead(_at(occ, x, 2.0, yaw)) == kind, (x, yaw)
    assert [policies.locomotion_for(k) for k in ("flat", "slope", "stair")] == ["general", "slope", "stair"]


def test_the_foundational_navigation_model_is_the_situations():
    occ = _occupancy(building=(6.0, 2.0))
    assert policies.situation(_at(occ, 1.0, 2.0)) == "nav-clear"
    assert policies.situation(_at(occ, 3.5, 2.0)) == "nav-static"  # the building 2.5 m away
    assert policies.situation(_at(occ, 1.0, 2.0, others=[[5.0, 2.0]])) == "nav-dynamic"  # 4 m away
    nav = policies.foundational_navigator("quadruped")
    assert set(nav.paths) == set(policies.FOUNDATIONAL_NAV)
    assert nav.dispatch(_at(occ, 3.5, 2.0)) == "nav-static" and nav.path.endswith("nav-static-quadruped.npz")
    assert nav.dispatch(_at(occ, 1.0, 2.0)) == "nav-clear" and nav.policy is nav.policies["nav-clear"]


@pytest.mark.parametrize("mode", ["human-ai-mode-1", "human-ai-mode-2"])
def test_which_locomotion_model_walks_in_the_papers_shared_modes(mode, monkeypatch):
    """Mode-1 walks a slope ahead on the slope model trained on navigation's changing commands
    (``loco-slope-quadruped-nav.npz``, not LocoSlope's own) and flat ground on the general
    one, keeping the last action across the swap; Mode-2 stays on the general model. The
    traverse's general model is the one trained on navigation's commands
    (``loco-general-quadruped-nav.npz``), not LocoStair's."""
    env = make_env("traverse", _tiny_traverse(), robot="quadruped", locomotion="learned")
    obs, _ = env.reset(seed=0)
    control = policies.make_policy(mode, task="traverse")
    control.reset(env)
    acted: list[str] = []

    def spy(name: str) -> None:  # the model, recording each 50 Hz step it acts
        inner = env.legs._loaded.get(name) or env.legs._read(env.legs.files[name])
        predict = lambda o, rng=None: acted.append(name) or inner.predict(o, rng)  # noqa: E731
        env.legs._loaded[name] = SimpleNamespace(predict=predict, keys=inner.keys)

    spy("general")
    spy("slope")
    env.legs.use("general")
    slope = "slope" if mode == "human-ai-mode-1" else "general"
    for ground, want in (("slope", slope), ("flat", "general")):
        monkeypatch.setattr(policies, "ground_ahead", lambda e, g=ground: g)
        obs, *_ = env.step(control.act(obs))
        name = {"general": "loco-general-quadruped-nav.npz", "slope": "loco-slope-quadruped-nav.npz"}[want]
        assert env.legs.model == want and env.legs.path.name == name
        assert acted[-env.legs.repeats :] == [want] * env.legs.repeats, acted
    # the swap keeps what the legs were doing: the new model reads the old one's last action
    last = env.legs.last_action.copy()
    env.legs.use("slope")
    np.testing.assert_array_equal(env.legs.last_action, last)
    assert env.legs.observation()["last_action"].tolist() == last.astype(np.float32).tolist()


def test_the_cli_runs_the_traverse_on_learned_legs_and_refuses_legs_it_cannot_have(cli, tmp_path):
    scene = save_scene(_tiny_traverse(time_limit=1.0), tmp_path / "tiny.json")
    result = cli("run", scene, "--locomotion", "learned", "--policy", "human-ai-mode-1")
    assert result.code == 0, result
    assert "quadruped robot on learned legs, human-ai-mode-1 policy" in result.out and "Falls" in result.out
    for robot, word in (("humanoid", "shipped for: quadruped"), ("wheeled", "no legs")):
        result = cli("bench", "--task", "traverse", "-n", "1", "--robot", robot, "--locomotion", "learned")
        lines = result.err.strip().splitlines()
        assert result.code == 2 and len(lines) == 1 and word in lines[0], result
        assert "Traceback" not in result.err
