"""Every registered environment with every built-in robot its task allows, as a new user
would try them: a short episode under zero action, random action and each baseline policy
that applies. Robots and policies come from :mod:`citygen.runner.tasks` (the registry and
the one place that says what fits), so a robot added later is tried the day it is added.

A run fails on an exception, on a non-finite observation or reward, an infinite metric (NaN
is a metric's "undefined", e.g. MCoT after no motion, which the tables leave out), and on a
termination the task's physics does not explain: nothing ends an episode on its first step
(the robot starts standing on the ground, away from the bounds and the goal), and a robot
given zero action or the stand controller does not fall sooner than its base could drop
from its stand height in free fall (on the hardest rough rows it may tip over later: the
bumps there are as high as a quadruped's knees).

Scenes are small versions of each task's test split: its navigation scenes as they are, a
2 x 2 corner of its Urban-Loc grid (the easiest and the hardest row of the paper's test
ranges), two units of the Urban-Tra track (even dynamic, uneven dynamic) and an 80 m route.
"""

from __future__ import annotations

import functools
import math

import gymnasium as gym
import numpy as np
import pytest

from citygen.runner import ENV_IDS
from citygen.runner.envs import DEFAULT_SPLIT
from citygen.runner.policies import make_policy
from citygen.runner.tasks import policies_for, robots_for

#: Steps of each short episode (0.6 s of locomotion, 3 s of navigation).
STEPS = 30
#: Policies that hold the robot still: no termination sooner than a free fall is explained.
STILL = ("zero", "stand")

CASES = [(env_id, robot) for env_id, kind in ENV_IDS.items() for robot in robots_for(kind)]


@functools.cache
def _small_scene(kind: str):
    """A small scene of the task's test split (see the module docstring); None: the split's own."""
    from citygen.generate import generate
    from citygen.generate.splits import resolve

    cfg = resolve(DEFAULT_SPLIT[kind])[0].config
    if kind.startswith("loco"):
        terrain = cfg.terrain.model_copy(update={"grid": (2, 2)})
        return generate(cfg.model_copy(update={"size": (16.0, 16.0), "terrain": terrain}), seed=1)
    if kind == "traverse":
        units = cfg.track.units
        track = cfg.track.model_copy(update={"units": (units[2], units[5]), "route_length": 80.0})
        return generate(cfg.model_copy(update={"size": (40.0, 10.0), "track": track}), seed=1)
    return None


def _finite(obs) -> bool:
    values = obs.values() if isinstance(obs, dict) else [obs]
    return all(np.all(np.isfinite(np.asarray(v, dtype=np.float64))) for v in values)


class _Zero:
    def reset(self, env):
        self.shape = env.action_space.shape

    def act(self, obs):
        return np.zeros(self.shape, dtype=np.float32)


def _episode(env, name: str, seed: int) -> list[str]:
    """Problems of one short episode of policy ``name`` (empty when it ran as it should)."""
    problems = []
    policy = _Zero() if name == "zero" else make_policy(name, seed=seed)
    obs, info = env.reset(seed=seed)
    robot = env.unwrapped.robot
    free_fall = math.ceil(math.sqrt(2 * robot.stand_height / 9.81) / env.unwrapped.dt)
    if not _finite(obs):
        problems.append("non-finite observation after reset")
    policy.reset(env.unwrapped)
    for t in range(1, STEPS + 1):
        obs, reward, terminated, truncated, info = env.step(policy.act(obs))
        if not _finite(obs) or not math.isfinite(reward):
            problems.append(f"non-finite observation or reward at step {t}")
        if terminated and (t == 1 or (name in STILL and t <= free_fall)):
            problems.append(f"terminated at step {t}: {_why(info)}")
        if terminated or truncated:
            metrics = info.get("metrics")
            if metrics is None:
                problems.append(f"episode ended at step {t} without metrics")
            elif any(math.isinf(v) for v in metrics.values() if isinstance(v, float)):
                problems.append(f"infinite metric {metrics}")
            break
    return problems


def _why(info: dict) -> str:
    keys = ("fallen", "success", "lost", "distance", "pose", "region", "index")
    return ", ".join(f"{k}={info[k]}" for k in keys if k in info)


@pytest.mark.slow
@pytest.mark.parametrize(("env_id", "robot"), CASES, ids=[f"{e.split('/')[1]}-{r}" for e, r in CASES])
def test_every_env_robot_and_policy_runs_a_short_episode(env_id, robot):
    kind = ENV_IDS[env_id]
    scene = _small_scene(kind)
    where = {"split": DEFAULT_SPLIT[kind]} if scene is None else {"scene": scene}
    env = gym.make(env_id, robot=robot, max_steps=STEPS, disable_env_checker=True, **where)
    try:
        problems = {}
        for seed, name in enumerate(("zero", *policies_for(kind, robot))):
            found = _episode(env, name, seed)
            if found:
                problems[name] = found
    finally:
        env.close()
    assert not problems, f"{env_id} with {robot}: {problems}"
