"""Running episodes: one (:func:`run_episode`) and a benchmark of many in a process pool
(:func:`run_bench`, the ``citygen bench`` command). Environments are made by
:mod:`citygen.runner.make`."""

from __future__ import annotations

import copy
import os
import warnings
from collections.abc import Callable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass
from typing import Any

import numpy as np

from citygen.runner import make

#: Names that lived here before :mod:`citygen.runner.make` (kept for one release).
_MOVED = ("make_env", "make_vector_env")


def __getattr__(name: str) -> Any:
    if name in _MOVED:
        warnings.warn(
            f"citygen.runner.bench.{name} moved to citygen.runner.make.{name}",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(make, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def run_episode(
    env: Any,
    policy: Any,
    *,
    seed: int | None = None,
    index: int | None = None,
    on_step: Callable[[Any, int], None] | None = None,
    options: dict[str, Any] | None = None,
) -> dict[str, Any]:
    """One episode of ``policy`` in ``env`` (reset with ``seed``, scene ``index`` and any other
    reset ``options``); returns the task's metrics plus ``return``, ``steps``, ``scene`` and
    ``index``. ``on_step(env, t)`` is called after the reset and after every step (to save
    frames)."""
    options = {**(options or {}), **({} if index is None else {"index": index})} or None
    obs, info = env.reset(seed=seed, options=options)
    policy.reset(env.unwrapped)
    total, t = 0.0, 0
    if on_step is not None:
        on_step(env, t)
    while True:
        obs, reward, terminated, truncated, info = env.step(policy.act(obs))
        total += reward
        t += 1
        if on_step is not None:
            on_step(env, t)
        if terminated or truncated:
            break
    return {
        **info["metrics"],
        "return": total,
        "steps": t,
        "scene": info.get("scene"),
        "index": info.get("index"),
    }


@dataclass(frozen=True)
class BenchSpec:
    task: str
    split: str
    robot: str | None
    policy: str
    seed: int = 0
    env_options: tuple[tuple[str, Any], ...] = ()


_WORKER: dict[str, Any] = {}
#: The learned model a benchmark runs, loaded once by :func:`run_bench` and handed to its
#: workers, by the name it was given: its file may change or go while the episodes run (a
#: training run's checkpoints rotate) and every episode still runs the model of the start.
_MODELS: dict[str, Any] = {}


def _episode(spec: BenchSpec, i: int) -> dict[str, Any]:
    """Episode ``i`` of a benchmark: scene ``i`` of the split, seed ``seed + i`` (one env per
    worker process, reused)."""
    from citygen.runner.policies import make_policy
    from citygen.workers import check_interrupted

    check_interrupted()  # Ctrl-C reached this worker: start no episode the pool had queued
    key = repr(spec)
    if _WORKER.get("key") != key:
        _WORKER.clear()
        _WORKER["key"] = key
        _WORKER["env"] = make.make_env(
            spec.task, split=spec.split, robot=spec.robot, **dict(spec.env_options)
        )
    model = _MODELS.get(spec.policy)
    policy = (
        copy.deepcopy(model)
        if model is not None
        else make_policy(spec.policy, seed=spec.seed + i, task=spec.task)
    )
    return run_episode(_WORKER["env"], policy, seed=spec.seed + i, index=i)


def run_bench(
    task: str,
    split: str,
    *,
    robot: str | None = None,
    policy: str = "planner",
    episodes: int = 16,
    jobs: int | None = None,
    seed: int = 0,
    progress: Callable[[int, int, dict[str, Any]], None] | None = None,
    **env_options: Any,
) -> list[dict[str, Any]]:
    """``episodes`` episodes (scene ``i`` of ``split`` for episode ``i``, seed ``seed + i``) in
    ``jobs`` processes; the per-episode metric rows, in episode order (the same for any
    ``jobs``). ``progress(done, total, row)`` is called as each episode ends. A task, split,
    robot or policy that do not fit together is a one-line :class:`SpecError` before any
    episode runs (:mod:`citygen.runner.tasks`)."""
    from citygen.runner.learn.policy import is_model
    from citygen.runner.scenes import cache_budget
    from citygen.runner.tasks import check_policy, check_robot, check_split, check_task

    cache_budget()  # a bad CITYGEN_SCENE_CACHE_MB fails here, even when this process's cache exists
    check_task(task)
    check_split(task, split)
    if not is_model(policy):  # a learned model's file is checked against the env when loaded
        check_policy(task, check_robot(task, robot, env_options.get("adapter")), policy)
    models: dict[str, Any] = {}
    if is_model(policy) and task != "traverse":  # a traverse's AI loads its navigator itself
        from citygen.runner.learn.policy import load_policy, observations_for

        models[policy] = load_policy(policy)
        env_options = {**observations_for(models[policy]), **env_options}
    spec = BenchSpec(task, split, robot, policy, seed, tuple(sorted(env_options.items())))
    _MODELS.clear()
    _MODELS.update(models)
    jobs = max(1, min(jobs or os.cpu_count() or 1, episodes))
    rows: list[dict[str, Any]] = [{}] * episodes
    if jobs == 1:
        for i in range(episodes):
            rows[i] = _episode(spec, i)
            if progress:
                progress(i + 1, episodes, rows[i])
        return rows
    with ProcessPoolExecutor(jobs, initializer=_worker_init, initargs=(models,)) as pool:
        futures = {pool.submit(_episode, spec, i): i for i in range(episodes)}
        try:
            for done, fut in enumerate(as_completed(futures), start=1):
                rows[futures[fut]] = fut.result()
                if progress:
                    progress(done, episodes, rows[futures[fut]])
        except BaseException:  # Ctrl-C, or an episode failed: run no more episodes
            pool.shutdown(wait=False, cancel_futures=True)
            raise
    return rows


def _worker_init(models: dict[str, Any]) -> None:
    """A bench worker takes Ctrl-C only while it runs an episode (:mod:`citygen.workers`) and
    runs the learned model ``models`` holds, as :func:`run_bench` loaded it."""
    from citygen.workers import die_with_parent, interrupt_only_in

    _MODELS.clear()
    _MODELS.update(models)
    interrupt_only_in(_episode)
    die_with_parent()


def summary_json(rows: Sequence[dict[str, Any]], **header: Any) -> dict[str, Any]:
    """The benchmark's JSON document: the header, the summary (mean, standard error, n per
    metric) and every episode's row."""
    from citygen.runner.metrics import summarise

    numeric = [
        {k: v for k, v in r.items() if isinstance(v, int | float | np.floating) and k != "index"}
        for r in rows
    ]
    return {**header, "episodes": len(rows), "summary": summarise(numeric), "rows": list(rows)}
