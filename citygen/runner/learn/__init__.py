"""Learned policies: PPO training (``citygen train``), exported policies that run on numpy
alone, and the baselines that ship with citygen (``citygen bench --policy FILE|ppo``).

- :mod:`~citygen.runner.learn.config`: :class:`TrainConfig`, the paper's hyperparameters;
- :mod:`~citygen.runner.learn.vecenv`: the vector environment behind SB3's ``VecEnv``, with
  asynchronous or synchronous scene sampling over N training scenes;
- :mod:`~citygen.runner.learn.train`: :func:`train` (needs the ``train`` extra);
- :mod:`~citygen.runner.learn.export`: a policy as ``.npz`` and :class:`NumpyPolicy`;
- :mod:`~citygen.runner.learn.policy`: loading ``.npz`` / ``.zip`` models, the shipped
  baselines (``baselines/``) and :func:`resolve_policy`, the hook of ``citygen bench``.

Only :mod:`train` and :mod:`vecenv` import PyTorch and Stable-Baselines3.
"""

from citygen.runner.learn.config import TrainConfig, load_config
from citygen.runner.learn.export import NumpyPolicy, read_policy
from citygen.runner.learn.policy import baseline, load_policy, resolve_policy, shipped

__all__ = [
    "NumpyPolicy",
    "TrainConfig",
    "baseline",
    "load_config",
    "load_policy",
    "read_policy",
    "resolve_policy",
    "shipped",
]
