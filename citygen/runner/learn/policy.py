"""Learned policies for ``citygen bench --policy FILE|ppo``: loading a trained model, the
baselines that ship with citygen, and the check that a model fits the environment.

- a ``.npz`` exported by ``citygen train`` (:mod:`citygen.runner.learn.export`) runs on
  numpy alone;
- an SB3 ``.zip`` (``model.zip`` or a checkpoint of a run) needs the ``train`` extra; its
  observation statistics come from ``vecnormalize.pkl`` beside it (or the checkpoint's own);
- ``ppo`` is the shipped baseline of the task and robot: ``baselines/<task>-<robot>.npz``
  in this package, each made by the ``citygen train`` command its JSON names (found by
  :mod:`~citygen.runner.learn.shipped_models`).
"""

from __future__ import annotations

import functools
import json
from pathlib import Path
from typing import Any

from citygen.errors import CitygenError
from citygen.runner.learn.export import NumpyPolicy, policy_arrays, read_policy

# The shipped files, for the importers of this module (found without it: learn.shipped_models).
from citygen.runner.learn.shipped_models import GENERAL_LOCO_SPLIT as GENERAL_LOCO_SPLIT
from citygen.runner.learn.shipped_models import LOCO_TASKS as LOCO_TASKS
from citygen.runner.learn.shipped_models import PolicyError as PolicyError
from citygen.runner.learn.shipped_models import baseline as baseline
from citygen.runner.learn.shipped_models import general_locomotion as general_locomotion
from citygen.runner.learn.shipped_models import shipped as shipped

#: Suffixes of model files ``--policy`` accepts.
MODEL_SUFFIXES = (".npz", ".zip")


def is_model(name: str) -> bool:
    """Whether a ``--policy`` value names a learned policy (``ppo`` or a model file)."""
    return name == "ppo" or name.lower().endswith(MODEL_SUFFIXES)


def _sb3_policy(path: Path) -> NumpyPolicy:
    from citygen.runner.learn.extra import require_train, stats_of

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
    if run.get("gait"):
        from citygen.runner.learn.residual import gait_spec

        meta["gait"] = gait_spec(run)
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


def load_policy(path: str | Path) -> Any:
    """A model file as a runner policy (``reset(env)``, ``act(obs)``): its
    :class:`NumpyPolicy`, or for a policy trained on a gait (its meta's ``gait``) a fresh
    :class:`~citygen.runner.learn.residual.ResidualPolicy` around it."""
    p = Path(path)
    if not p.is_file():
        raise PolicyError(
            f"--policy: expected a model file (.npz or .zip) or ppo, got {str(path)!r} (no such file)"
        )
    policy = _load(str(p.resolve()), p.stat().st_mtime)
    if policy.meta.get("gait"):
        from citygen.runner.learn.residual import ResidualPolicy

        return ResidualPolicy(policy)
    return policy


def observations_for(policy: Any) -> dict[str, tuple[str, ...]]:
    """The environment option a learned ``policy`` needs: ``{"observations": its keys}`` when
    it reads a key environments give only on request (:data:`citygen.runner.envs.nav.ON_REQUEST`,
    the wide map), else ``{}`` (the environment's default keys hold everything it reads)."""
    from citygen.runner.envs.nav import ON_REQUEST

    keys = tuple(getattr(policy, "shapes", {}))
    return {"observations": keys} if set(keys) & set(ON_REQUEST) else {}


def check_fits(policy: NumpyPolicy, env: Any, name: str) -> None:
    """A one-line error when ``policy`` was made for other observation or action spaces than
    ``env``'s (another task's or robot's)."""
    from citygen.runner.envs.nav import ON_REQUEST

    obs_space, act_space = env.observation_space, env.action_space
    what = f"{env.unwrapped.task_kind} with robot {env.unwrapped.robot.name}"
    for key, shape in policy.shapes.items():
        if key not in obs_space.spaces and key in ON_REQUEST:
            raise PolicyError(
                f"{name}: reads observation {key!r}, which environments give only when asked: "
                f"make_env(..., observations={list(policy.shapes)})"
            )
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
        locomotion = env_options.get("locomotion") or "servo"
        path = baseline(task, env.unwrapped.robot.name, locomotion) if name == "ppo" else Path(name)
        policy = load_policy(path)
        if wanted := observations_for(policy):  # keys given on request: the env that gives them
            env.close()
            env = make_env(task, robot=robot, **{**env_options, **wanted})
        check_fits(policy, env, str(name))
    finally:
        env.close()
    return str(path)
