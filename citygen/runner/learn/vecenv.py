"""The training environment: citygen's Gymnasium vector environment behind Stable-Baselines3's
``VecEnv`` interface, with the scene sampling of the paper's scaling experiment.

- :class:`SceneSchedule` (a Gymnasium wrapper of each sub-environment) picks the scene of
  every reset among ``scenes`` distinct training scenes: ``async`` sampling draws one per
  sub-environment from its own generator (the paper's asynchronous scene sampling);
  ``sync`` gives every sub-environment the same scene, a new one every rollout (the
  synchronous sampling of Isaac Lab: all scenes of a batch identical; an episode that runs
  across a rollout boundary finishes in its old scene).
- :class:`Sb3VecEnv` adapts a Gymnasium ``VectorEnv`` in ``SAME_STEP`` autoreset mode to
  SB3: dict observations restricted to the policy's keys (the goal's length clipped to
  ``goal_range``, as the exported policy does), ``terminal_observation``,
  ``TimeLimit.truncated`` and ``is_success`` in the per-environment infos.
- :func:`make_training_env` builds both from a :class:`~citygen.runner.learn.config.TrainConfig`.
"""

from __future__ import annotations

import functools
import os
from typing import Any

import gymnasium
import numpy as np
from stable_baselines3.common.vec_env import VecEnv

from citygen.runner.learn.config import PHASE_KEY, TrainConfig
from citygen.runner.learn.export import clip_goal


class SceneSchedule(gymnasium.Wrapper):
    """Chooses the scene index of every reset (see the module docstring)."""

    def __init__(
        self, env: gymnasium.Env, *, scenes: int | None, sampling: str, seed: int, rank: int, period: int
    ):
        super().__init__(env)
        source = env.unwrapped.source
        if scenes is not None and scenes > source.size and len(getattr(source, "_parts", ())) == 1:
            # More scenes than the split lists: the same config and seed derivation, further on.
            source._parts = [source._parts[0].model_copy(update={"scenes": scenes})]
            source.size = scenes
        self.count = min(scenes or source.size, source.size)
        self.sampling = sampling
        self.period = period
        self._rng = np.random.default_rng([seed, rank, 7919])
        self._order = np.random.default_rng([seed, self.count, 104729]).permutation(self.count)
        self._steps = 0

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        if seed is not None:
            self._rng = np.random.default_rng([seed, 7919])
        if options and "index" in options:
            index = int(options["index"])
        elif self.sampling == "sync":
            index = int(self._order[(self._steps // self.period) % self.count])
        else:
            index = int(self._rng.integers(self.count))
        return self.env.reset(seed=seed, options={**(options or {}), "index": index})

    def step(self, action):
        self._steps += 1
        return self.env.step(action)


def _sub_env(
    task: str, split: str, robot: str, scenes: int | None, sampling: str, seed: int, rank: int, period: int,
    progress: float = 0.0, gamma: float = 0.99, reverse: float = 0.0, keys: tuple[str, ...] | None = None,
    loco: dict[str, Any] | None = None, locomotion: str = "servo",
    gait: tuple[str, float, float] | None = None, max_steps: int | None = None, tilt: float = 0.0,
) -> gymnasium.Env:  # fmt: skip
    import multiprocessing
    import signal

    from citygen.runner.make import make_env

    if multiprocessing.parent_process() is not None:
        # A worker of the vector env: Ctrl-C is the trainer's to handle (it saves a checkpoint
        # and closes the workers), not a traceback in every worker.
        signal.signal(signal.SIGINT, signal.SIG_IGN)
    walk = {} if locomotion == "servo" else {"locomotion": locomotion}  # learned legs (envs.legs)
    if keys is not None:  # the walk's phase is the gait's to give (learn.residual)
        keys = tuple(k for k in keys if k != PHASE_KEY)
    limit = {} if max_steps is None else {"max_steps": max_steps}  # else the task's horizon
    # Only the keys the policy reads.
    env = make_env(task, split=split, robot=robot, observations=keys, **walk, **limit)
    if (progress or reverse or tilt) and task.startswith("nav"):
        from citygen.runner.learn.shaping import ProgressReward

        env = ProgressReward(env, progress, gamma, reverse, tilt)
    if task.startswith("loco"):
        from citygen.runner.learn.loco import LocoTraining

        env = LocoTraining(env, seed=seed, rank=rank, **(loco or {}))
    if gait is not None:
        from citygen.runner.learn.residual import ResidualTraining

        env = ResidualTraining(env, gait=gait[0], scale=gait[1], max_speed=gait[2])
    return SceneSchedule(env, scenes=scenes, sampling=sampling, seed=seed, rank=rank, period=period)


def _unbatch(info: dict[str, Any], i: int) -> dict[str, Any]:
    """Sub-environment ``i``'s entries of a Gymnasium vector info dict (masks ``_key``)."""
    out: dict[str, Any] = {}
    for key, value in info.items():
        if key.startswith("_"):
            continue
        mask = info.get("_" + key)
        if mask is not None and not mask[i]:
            continue
        out[key] = _unbatch(value, i) if isinstance(value, dict) else value[i]
    return out


def _final(infos: dict[str, Any], key: str, i: int) -> Any:
    """Sub-environment ``i``'s ``final_obs`` or ``final_info``: Gymnasium batches them as an
    object array of per-environment dicts, or as a dict of batched arrays."""
    value = infos.get(key)
    if value is None:
        return None
    if isinstance(value, dict):
        return _unbatch(value, i)
    return value[i]


class Sb3VecEnv(VecEnv):
    """A Gymnasium ``VectorEnv`` (autoreset ``SAME_STEP``) as an SB3 ``VecEnv``."""

    def __init__(self, venv: Any, keys: tuple[str, ...], seed: int = 0, goal_range: float | None = None):
        mode = venv.metadata.get("autoreset_mode")
        if mode is not None and getattr(mode, "value", mode) != "SameStep":
            raise ValueError(f"vector env: expected autoreset_mode SAME_STEP, got {mode}")
        space = venv.single_observation_space
        obs_space = gymnasium.spaces.Dict({k: space[k] for k in keys})
        self.venv = venv
        super().__init__(venv.num_envs, obs_space, venv.single_action_space)
        self.keys = tuple(obs_space.spaces)
        self._seed = seed
        self._actions = None
        self.goal_range = goal_range

    def _obs(self, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
        return clip_goal({k: np.asarray(obs[k]) for k in self.keys}, self.goal_range)

    def reset(self):
        obs, infos = self.venv.reset(seed=self._seed)
        self._seed = None  # only the first reset is seeded; later ones continue the generators
        self.reset_infos = [_unbatch(infos, i) for i in range(self.num_envs)]
        return self._obs(obs)

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self):
        obs, rewards, terminated, truncated, infos = self.venv.step(self._actions)
        dones = np.logical_or(terminated, truncated)
        out = []
        for i in range(self.num_envs):
            if not dones[i]:
                out.append({})
                continue
            final, final_obs = _final(infos, "final_info", i) or {}, _final(infos, "final_obs", i)
            info = {
                "terminal_observation": self._obs(final_obs),
                "TimeLimit.truncated": bool(truncated[i] and not terminated[i]),
                "is_success": bool(final.get("is_success", False)),
            }
            if "metrics" in final:
                info["metrics"] = final["metrics"]
            if "terrain_level" in final:  # LocoTraining's curriculum row, logged by train
                info["terrain_level"] = final["terrain_level"]
            out.append(info)
        return self._obs(obs), np.asarray(rewards, dtype=np.float32), dones, out

    def close(self) -> None:
        self.venv.close()

    def seed(self, seed: int | None = None):
        self._seed = seed
        return [None if seed is None else seed + i for i in range(self.num_envs)]

    # The rest of VecEnv's interface reaches the sub-environments through the vector env.
    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        values = self.venv.get_attr(attr_name)
        return [values[i] for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        self.venv.set_attr(attr_name, value)

    def env_method(self, method_name: str, *args, indices=None, **kwargs) -> list[Any]:
        values = self.venv.call(method_name, *args, **kwargs)
        return [values[i] for i in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


def _sub_env_args(cfg: TrainConfig, rank: int) -> tuple[Any, ...]:
    """:func:`_sub_env`'s arguments for sub-environment ``rank`` of the run ``cfg``."""
    return (
        cfg.task,
        cfg.train_split,
        cfg.robot_name,
        cfg.scenes,
        cfg.sampling,
        cfg.seed,
        rank,
        cfg.n_steps,
        cfg.progress,
        cfg.gamma,
        cfg.reverse,
        tuple(cfg.obs_keys),
        {
            "shaping": cfg.gait_shaping,
            "command_mix": cfg.command_mix,
            "command_resample": cfg.command_resample,
            "level_on_commands": cfg.level_on_commands,
            "curriculum": cfg.curriculum,
            "random_rows": cfg.random_rows,
            "start_rows": cfg.start_rows,
            "edge_stop": cfg.edge_stop,
            "edge_height": cfg.edge_height,
            "edge_drop": cfg.edge_drop,
            "descent_speed": cfg.descent_speed,
            "descent_drop": cfg.descent_drop,
            "only_positive": cfg.only_positive,
            "effort_scale": cfg.effort_scale,
            "alive": cfg.alive,
            "fall_penalty": cfg.fall_penalty,
            "foot_clearance": cfg.foot_clearance,
            "clearance_height": cfg.clearance_height,
            "leg_collision": cfg.leg_collision,
            "turn_progress": cfg.turn_progress,
            "heading_progress": cfg.heading_progress,
            "base_height": cfg.base_height,
            "orientation": cfg.orientation,
        },
        cfg.locomotion,
        (cfg.gait, cfg.gait_scale, cfg.gait_max_speed) if cfg.gait else None,
        cfg.max_steps,
        cfg.tilt,
    )


def sub_env_of(cfg: TrainConfig, rank: int) -> gymnasium.Env:
    """Sub-environment ``rank`` of the run ``cfg``, built in this process (the imitation
    rounds of :mod:`citygen.runner.learn.imitate` drive one beside the vector env)."""
    return _sub_env(*_sub_env_args(cfg, rank))


def make_training_env(cfg: TrainConfig) -> Sb3VecEnv:
    """The SB3 vector environment of a training run: ``cfg.envs`` sub-environments of
    ``cfg.task`` on ``cfg.train_split``, spread over a process per core or all in this one
    (:attr:`TrainConfig.processes`)."""
    from gymnasium.vector import AutoresetMode

    from citygen.runner.vector import VectorEnv

    fns = [functools.partial(_sub_env, *_sub_env_args(cfg, rank)) for rank in range(cfg.envs)]
    processes = cfg.processes if cfg.processes is not None else int((os.cpu_count() or 1) > 1)
    # citygen's vector env: observations through shared memory, nothing pickled per step.
    venv = VectorEnv(fns, processes=bool(processes and cfg.envs > 1), autoreset_mode=AutoresetMode.SAME_STEP)
    return Sb3VecEnv(venv, cfg.obs_keys, seed=cfg.seed, goal_range=cfg.goal_range)
