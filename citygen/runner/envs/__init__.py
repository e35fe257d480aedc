"""Gymnasium environments for the URBAN-BENCH tasks (registered by :mod:`citygen.runner`).

Every environment runs one robot (:mod:`citygen.runner.robots`) in a scene compiled to
MuJoCo by :mod:`citygen.exporters.mjcf`. It is built from a scene (``scene=`` a
:class:`~citygen.spec.Scene` or a scene file) or from a split to sample from (``split=``,
default the task's Urban-Nav / Urban-Loc / Urban-Tra test split): then every
:meth:`reset` draws a scene index from the environment's generator (``options={"index": i}``
picks one; ``scene_pool=k`` draws from the split's first ``k`` scenes only), and compiled
scenes come from a per-process cache.

The task families, one module each: :mod:`~citygen.runner.envs.nav` (:class:`NavEnv`;
NavClear, NavStatic, NavDynamic), :mod:`~citygen.runner.envs.traverse` (:class:`TraverseEnv`)
and :mod:`~citygen.runner.envs.loco` (:class:`LocoEnv`; LocoFlat, LocoSlope, LocoStair,
LocoRough), each with its actions, observations and rewards in its docstring. What they
share is in :mod:`~citygen.runner.envs.base` (scenes, the robot, spawning, physics, contacts)
and :mod:`~citygen.runner.envs.sensors` (terrain around the robot, images, rays).

Each environment fills ``info["metrics"]`` on the last step of an episode with the paper's
metrics of its task (:mod:`citygen.runner.metrics`).

``observations=[...]`` restricts the observation dict (and its space) to those keys, and only
they are computed: the values are the full observation's, bit for bit. ``citygen train``
passes its policy's keys: without the height map and the inside and motion layers, 8
NavStatic sub-environments step about 1.2x as fast (``benchmarks/bench_runner.py``).
"""

from citygen.runner.envs.base import DEFAULT_SPLIT, LIVE_SCENES, NAV_DT, SPAWN_CLEARANCE
from citygen.runner.envs.loco import COMMAND_TURN, FALL_FORCE, LOCO_DT, LOCO_HORIZON, START_JITTER, LocoEnv
from citygen.runner.envs.nav import NAV_HORIZON, NavEnv
from citygen.runner.envs.sensors import HEIGHT_MAP, RAY_COUNT, RAY_HEIGHT, RAY_RANGE, RENDERERS
from citygen.runner.envs.traverse import STUCK_SECONDS, TraverseEnv

__all__ = [
    "COMMAND_TURN",
    "DEFAULT_SPLIT",
    "FALL_FORCE",
    "HEIGHT_MAP",
    "LIVE_SCENES",
    "LOCO_DT",
    "LOCO_HORIZON",
    "NAV_DT",
    "NAV_HORIZON",
    "RAY_COUNT",
    "RAY_HEIGHT",
    "RAY_RANGE",
    "RENDERERS",
    "SPAWN_CLEARANCE",
    "START_JITTER",
    "STUCK_SECONDS",
    "LocoEnv",
    "NavEnv",
    "TraverseEnv",
]
