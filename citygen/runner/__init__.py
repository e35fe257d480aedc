"""The MuJoCo runner: Gymnasium environments for the URBAN-BENCH tasks on citygen scenes.

Importing this package registers the environment ids with Gymnasium::

    import gymnasium as gym
    import citygen.runner  # noqa: F401  (registers citygen/NavStatic-v0 ...)

    env = gym.make("citygen/NavStatic-v0", scene="out/urban-nav-2/test/0000.json")

Modules: :mod:`~citygen.runner.envs` (the environments), :mod:`~citygen.runner.make`
(``make_env``, ``make_vector_env`` and the task -> environment class map),
:mod:`~citygen.runner.robots` (embodiments built in code as MJCF),
:mod:`~citygen.runner.agents` (ORCA pedestrians, IDM vehicles, signals),
:mod:`~citygen.runner.control` (A*, distance fields, pure pursuit, scripted gaits),
:mod:`~citygen.runner.metrics` (the paper's metrics) and :mod:`~citygen.runner.policies`
(baselines).
"""

from __future__ import annotations

import gymnasium

from citygen.runner.make import env_class

#: Gymnasium id -> the task kind of :mod:`citygen.spec.task` it runs.
ENV_IDS = {
    "citygen/NavClear-v0": "nav-clear",
    "citygen/NavStatic-v0": "nav-static",
    "citygen/NavDynamic-v0": "nav-dynamic",
    "citygen/LocoFlat-v0": "loco-flat",
    "citygen/LocoSlope-v0": "loco-slope",
    "citygen/LocoStair-v0": "loco-stair",
    "citygen/LocoRough-v0": "loco-rough",
    "citygen/Traverse-v0": "traverse",
}

for _id, _kind in ENV_IDS.items():
    if _id not in gymnasium.registry:
        _cls = env_class(_kind)
        gymnasium.register(id=_id, entry_point=f"{_cls.__module__}:{_cls.__name__}", kwargs={"task": _kind})

__all__ = ["ENV_IDS"]
