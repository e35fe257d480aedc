"""Learned policies for ``citygen bench --policy FILE|ppo``: loading a trained model, the
baselines that ship with citygen, and the check that a model fits the environment.

- a ``.npz`` exported by ``citygen train`` (:mod:`citygen.runner.learn.export`) runs on
  numpy alone;
- an SB3 ``.zip`` (``model.zip`` or a checkpoint of a run) needs the ``train`` extra; its
  observation statistics come from ``vecnormalize.pkl`` beside it (or the checkpoint's own);
- ``ppo`` is the shipped baseline of the task and robot: ``baselines/<task>-<robot>.npz``
  in this package, each made by the ``citygen train`` command its JSON names.
"""

from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Any

from citygen.errors import CitygenError
from citygen.runner.learn.export import NumpyPolicy, policy_arrays, read_policy

#: Folder of the shipped baselines.
BASELINES = Path(__file__).with_name("baselines")
#: The Urban-Loc split the general locomotion models train on (every terrain kind).
GENERAL_LOCO_SPLIT = "urban-loc-mixed-train"
#: The locomotion tasks a general model serves.
LOCO_TASKS = ("loco-flat", "loco-slope", "loco-stair", "loco-rough")
#: Suffixes of model files ``--policy`` accepts.
MODEL_SUFFIXES = (".npz", ".zip")


class PolicyError(CitygenError):
    """A model file that cannot be used (unreadable, or made for other spaces)."""


def is_model(name: str) -> bool:
    """Whether a ``--policy`` value names a learned policy (``ppo`` or a model file)."""
    return name == "ppo" or name.lower().endswith(MODEL_SUFFIXES)


def _shipped_files() -> tuple[dict[tuple[str, str], Path], dict[str, Path]]:
    """The shipped files: ``(task, robot) -> file`` of the task models and ``robot -> file``
    of the general locomotion models (trained on :data:`GENERAL_LOCO_SPLIT`)."""
    tasks: dict[tuple[str, str], Path] = {}
    general: dict[str, Path] = {}
    for path in sorted(BASELINES.glob("*.npz")):
        meta = read_policy(path).meta
        if meta.get("train", {}).get("split") == GENERAL_LOCO_SPLIT:
            general[meta["robot"]] = path
        else:
            tasks[(meta["task"], meta["robot"])] = path
    return tasks, general


def shipped() -> dict[tuple[str, str], Path]:
    """The shipped baselines: ``(task, robot) -> file``. A robot's general locomotion model
    serves each locomotion task that has no terrain model of its own."""
    out, general = _shipped_files()
    for robot, path in general.items():
        for task in LOCO_TASKS:
            out.setdefault((task, robot), path)
    return out


def general_locomotion(robot: str) -> Path:
    """The shipped general locomotion model of ``robot`` (the paper's "general locomotion
    model", which follows velocity commands on every terrain), or a one-line error naming
    the robots that have one."""
    general = _shipped_files()[1]
    if robot not in general:
        raise PolicyError(
            f"no general locomotion model shipped for robot {robot}; "
            f"shipped for: {', '.join(sorted(general)) or 'none'}"
        )
    return general[robot]


def baseline(task: str, robot: str) -> Path:
    """The shipped baseline of ``task`` and ``robot``, or a one-line error listing those that exist."""
    found = shipped()
    if (task, robot) not in found:
        have = ", ".join(f"{t} {r}" for t, r in found) or "none"
        raise PolicyError(f"--policy ppo: no shipped baseline for {task} with robot {robot}; shipped: {have}")
    return found[(task, robot)]


def _sb3_policy(path: Path) -> NumpyPolicy:
    from citygen.runner.learn.train import require_train, stats_of

    require_train()
    import pickle

    from stable_baselines3 import PPO

    model = PPO.load(path, device="cpu")
    stats = None
    for candidate in (
        stats_of(path),
        path.with_name("vecnormalize.pkl"),
    ):
        if candidate.exists():
            with open(candidate, "rb") as f:
                stats = pickle.load(f)
            break
    run = {}
    for folder in (path.parent, path.parent.parent):
        if (folder / "config.json").is_file():
            run = json.loads((folder / "config.json").read_text())
            break
    meta, arrays = policy_arrays(
        model,
        None if stats is None else stats.obs_rms,
        task=run.get("task", ""),
        robot=run.get("robot_name", ""),
        clip_obs=10.0 if stats is None else float(stats.clip_obs),
        epsilon=1e-8 if stats is None else float(stats.epsilon),
        activation=run.get("activation", "tanh"),
        goal_range=run.get("goal_range"),
    )
    return NumpyPolicy(meta, arrays)


@functools.lru_cache(maxsize=8)
def _load(path: str, mtime: float) -> NumpyPolicy:
    p = Path(path)
    try:
        if p.suffix.lower() == ".zip":
            return _sb3_policy(p)
        return read_policy(p)
    except CitygenError:
        raise
    except Exception as exc:
        detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise PolicyError(f"{path}: expected a policy saved by `citygen train`, got {detail}") from None


def load_policy(path: str | Path) -> NumpyPolicy:
    """A model file as a runner policy (``reset(env)``, ``act(obs)``)."""
    p = Path(path)
    if not p.is_file():
        raise PolicyError(
            f"--policy: expected a model file (.npz or .zip) or ppo, got {str(path)!r} (no such file)"
        )
    return _load(str(p.resolve()), p.stat().st_mtime)


def check_fits(policy: NumpyPolicy, env: Any, name: str) -> None:
    """A one-line error when ``policy`` was made for other observation or action spaces than
    ``env``'s (another task's or robot's)."""
    obs_space, act_space = env.observation_space, env.action_space
    what = f"{env.unwrapped.task_kind} with robot {env.unwrapped.robot.name}"
    for key, shape in policy.shapes.items():
        if key not in obs_space.spaces:
            raise PolicyError(
                f"{name}: made for observation {key!r} of {policy.meta.get('task') or 'another task'}, "
                f"which {what} does not have (it has {', '.join(obs_space.spaces)})"
            )
        if tuple(obs_space[key].shape) != shape:
            raise PolicyError(
                f"{name}: observation {key!r}: expected shape {tuple(obs_space[key].shape)} for {what}, "
                f"the policy reads {shape}"
            )
    if tuple(act_space.shape) != tuple(policy.meta["action_shape"]):
        raise PolicyError(
            f"{name}: action: expected shape {tuple(act_space.shape)} for {what}, the policy gives "
            f"{tuple(policy.meta['action_shape'])} "
            f"(made for {policy.meta.get('task')} {policy.meta.get('robot')})"
        )


def resolve_policy(
    name: str, task: str, robot: str | None, builtin: tuple[str, ...], **env_options: Any
) -> str:
    """What ``--policy NAME`` runs for ``task`` and ``robot``: a baseline's name unchanged, or
    the path of a model file (``ppo``: the shipped baseline) checked against the task's
    environment; a one-line :class:`PolicyError` otherwise. The hook of ``citygen bench``."""
    if name in builtin:
        return name
    if not is_model(name):
        raise PolicyError(
            f"--policy: expected one of {', '.join(builtin)}, ppo, or a model file (.npz, .zip), got {name!r}"
        )
    from citygen.runner.make import make_env

    env = make_env(task, robot=robot, **env_options)
    try:
        path = baseline(task, env.unwrapped.robot.name) if name == "ppo" else Path(name)
        check_fits(load_policy(path), env, str(name))
    finally:
        env.close()
    return str(path)
