"""What the optional ``train`` extra (Stable-Baselines3 and PyTorch) brings, asked without
importing it: the one-line error when it is missing, and where SB3 keeps a model's
observation statistics. :mod:`citygen.runner.learn.policy` reads SB3 models with these, and
:mod:`citygen.runner.learn.train` (which imports the layers that drive environments) starts
runs with them; a module of their own keeps the first from importing the second."""

from __future__ import annotations

from pathlib import Path

from citygen.errors import CitygenError

MISSING = (
    'citygen train needs the optional "train" extra (Stable-Baselines3 and PyTorch), which is not '
    'installed: pip install -e ".[train]" (see docs/training.md for a CPU-only PyTorch)'
)


class TrainError(CitygenError):
    """A training run that cannot start or continue."""


def require_train() -> None:
    """A one-line :class:`TrainError` naming the ``train`` extra when it is not installed."""
    try:
        import stable_baselines3  # noqa: F401
        import torch  # noqa: F401
    except ImportError:
        raise TrainError(MISSING) from None


def stats_of(model: Path) -> Path:
    """The ``VecNormalize`` statistics saved with an SB3 model: ``model_<steps>.zip`` ->
    ``vecnormalize_<steps>.pkl``, ``model.zip`` -> ``vecnormalize.pkl``."""
    return model.with_name(model.stem.replace("model", "vecnormalize") + ".pkl")
