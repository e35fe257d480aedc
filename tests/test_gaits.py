"""The scripted gaits as honest baselines, over whole episodes (1,000 steps, 20 s): ``stand``
keeps every legged robot's balance on LocoFlat, LocoSlope and LocoStair, and ``trot`` (the
humanoid's scripted walk) walks LocoFlat without a fall.

Scenes are small Urban-Loc grids of each task's test ranges (:func:`_grid`): the hardest row
of slopes (0.8 rad) and flat ground from a tile's centre; on stairs, starts drawn by seed in
a 4 x 4 grid (risers up to 0.3 m), two that leave the robot straddling a riser (seed 1: a
pit, seed 26: the hardest row), where the stand before issue 46 fell within 2 s for both
four-legged robots. The walks start in the middle of a 5 x 5 flat grid, 20 m from its
edges: leaving the scene ends an episode as a fall would.
"""

from __future__ import annotations

import functools

import pytest

from citygen.runner.bench import run_episode
from citygen.runner.envs.loco import LOCO_HORIZON
from citygen.runner.make import make_env
from citygen.runner.policies import make_policy
from citygen.runner.tasks import robots_for
from tests.test_envs_loco import _grid

#: Starts of the stand's episodes per task: the grid's size and (seed, reset options) pairs.
STAND = {
    "loco-flat": (2, [(0, {"region": (1, 0)})]),
    "loco-slope": (2, [(0, {"region": (1, 0)}), (1, {"region": (1, 1)})]),
    "loco-stair": (4, [(1, {}), (26, {})]),
}
#: Least X-displacement (m) of a 20 s walk at the 1 m/s command (each walks about 50 % more).
WALKS = {"quadruped": 8.0, "wheeled_legged": 10.0, "humanoid": 5.0}


@functools.cache
def _scene(task: str, n: int):
    return _grid(task, n)


def _whole_episodes(task: str, n: int, robot: str, gait: str, starts: list[tuple[int, dict]]) -> list[dict]:
    """Episodes of ``gait`` on an ``n`` x ``n`` grid from each start (a seed and reset
    options); each must keep its balance to the horizon."""
    env = make_env(task, _scene(task, n), robot=robot)
    try:
        results = [run_episode(env, make_policy(gait), seed=seed, options=opts) for seed, opts in starts]
    finally:
        env.close()
    for start, result in zip(starts, results, strict=True):
        assert result["steps"] == LOCO_HORIZON and result["balance"] == 100.0, (task, robot, start, result)
    return results


@pytest.mark.slow
@pytest.mark.parametrize("robot", robots_for("loco-stair"))
@pytest.mark.parametrize("task", list(STAND))
def test_stand_keeps_its_balance_for_a_whole_episode(task, robot, monkeypatch):
    # The stand does not walk: the starts are the seeds' first draws, kept even where a 20 m
    # walk would leave the small grid (a walking start is redrawn until it has that room).
    monkeypatch.setattr("citygen.runner.envs.loco.START_TRIES", 1)
    n, starts = STAND[task]
    _whole_episodes(task, n, robot, "stand", starts)


@pytest.mark.slow
@pytest.mark.parametrize("robot", list(WALKS))
def test_trot_walks_flat_ground_for_a_whole_episode(robot):
    """Slower than the 1 m/s command (see :mod:`citygen.runner.control.gaits`), but walking."""
    (result,) = _whole_episodes("loco-flat", 5, robot, "trot", [(0, {"region": (2, 2)})])
    assert result["x_displacement"] >= WALKS[robot], result
