"""Making environments: the one map from a task to its environment class
(:data:`ENV_CLASSES`, which the Gymnasium ids of :mod:`citygen.runner` point at), one
environment (:func:`make_env`) and a batch of them (:func:`make_vector_env`).

>>> env_class("nav-static").__name__, env_class("loco-flat").__name__, env_class("traverse").__name__
('NavEnv', 'LocoEnv', 'TraverseEnv')
"""

from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Any

from citygen.errors import SpecError
from citygen.runner.envs import LocoEnv, NavEnv, TraverseEnv
from citygen.runner.tasks import family
from citygen.runner.vector import VectorEnv
from citygen.spec import Scene

#: Task family (:func:`citygen.runner.tasks.family`) -> the environment class that runs it.
ENV_CLASSES: dict[str, type] = {"nav": NavEnv, "loco": LocoEnv, "traverse": TraverseEnv}


def env_class(task: str) -> type:
    """The environment class of a task kind (:data:`ENV_CLASSES`)."""
    return ENV_CLASSES[family(task)]


def make_env(task: str, scene: Scene | str | Path | None = None, **kwargs: Any):
    """The environment of a task kind (``"nav-static"``) on a scene or a split.
    ``locomotion="learned"`` walks a legged robot through a navigation task or the traverse
    on its general locomotion model (:mod:`citygen.runner.envs.legs`) instead of the ideal
    servo (``"servo"``, the default); a locomotion task always runs its legs and takes only
    the default."""
    if family(task) == "loco" and (walk := kwargs.pop("locomotion", "servo")) != "servo":
        raise SpecError(f"--locomotion {walk}: a navigation option; {task} always runs its legs")
    return env_class(task)(task, scene, **kwargs)


def make_vector_env(
    task: str,
    *,
    split: str | None = None,
    num_envs: int | None = None,
    asynchronous: bool = True,
    **kwargs: Any,
):
    """A Gymnasium vector environment (:class:`citygen.runner.vector.VectorEnv`) of ``num_envs``
    (default: one per core) environments of ``task`` sampling ``split``: every sub-environment
    draws its own scene on every reset (from its own generator, seeded ``seed + i``) out of its
    process's cache of compiled scenes -- asynchronous scene sampling. Batched: an array of
    actions in, arrays of observations out. ``asynchronous=True`` steps the sub-environments
    in parallel, in worker processes (shared-memory buffers, nothing pickled per step) and,
    when every process has a core and no images are rendered, the first in this process;
    False steps them one after another in this process. ``kwargs`` go to :func:`make_env`."""
    n = num_envs or os.cpu_count() or 1
    fns = [functools.partial(make_env, task, split=split, **kwargs) for _ in range(n)]
    return VectorEnv(fns, processes=asynchronous)
