"""Learned policies without PyTorch: a trained SB3 PPO policy's MLP as a small ``.npz`` that
numpy evaluates deterministically.

An exported policy file holds (``np.load(path, allow_pickle=False)`` reads it):

- ``meta``: one JSON string: ``format`` (:data:`FORMAT`), ``task``, ``robot``, ``keys`` (the
  observation keys in the order the network reads them) with their ``shapes``, the action
  space (``action_shape``, ``action_low``, ``action_high``), ``activation``, the
  normalisation's ``clip_obs`` and ``epsilon``, and free-form ``train`` notes (steps,
  seed, the command that made it);
- ``obs_mean/<key>``, ``obs_var/<key>``: the running observation statistics (absent when
  the run did not normalise observations);
- ``w<i>``, ``b<i>``: the actor's hidden layers, then the action layer, as float32
  ``(out, in)`` weights and ``(out,)`` biases; ``log_std`` for reference;
- for each key the CNN encodes (:mod:`citygen.runner.learn.nets`; listed in the meta's
  ``encoders`` with each layer's ``strides``): ``enc/<key>/conv<i>/w`` ``(out, in, k, k)``
  and ``.../b``, then its linear layer ``enc/<key>/fc/w`` and ``.../b`` (ReLU after each);
  an encoder whose spec has a ``stack`` reads those keys as its input channels (``key`` the
  first of them), and the others add no features of their own;
- the meta's ``goal_range`` (metres, or absent): goal vectors longer than it reach the network
  scaled to that length (:func:`clip_goal`, as in training).

:meth:`NumpyPolicy.predict` computes what SB3's ``model.predict(obs, deterministic=True)``
computes for the same observation (after ``VecNormalize``): clip the goal's length, normalise
and clip each key that was normalised, encode the map keys with their CNN and flatten the
others, concatenate in ``keys`` order, the hidden layers with their activation, the action
layer's mean, clipped to the action bounds.
"""

from __future__ import annotations

import io
import json
from pathlib import Path
from typing import Any

import numpy as np

#: The exported policy's format tag.
FORMAT = "citygen.policy/1"


def _relu(x: np.ndarray) -> np.ndarray:
    return np.maximum(x, 0.0)


def _elu(x: np.ndarray) -> np.ndarray:
    return np.where(x > 0, x, np.expm1(np.minimum(x, 0.0)))


#: Module-level functions, not lambdas: a policy pickles (``citygen bench`` hands it to its
#: worker processes, which a spawn or forkserver start pickles).
_ACTIVATIONS = {"tanh": np.tanh, "relu": _relu, "elu": _elu}


def conv2d(x: np.ndarray, w: np.ndarray, b: np.ndarray, stride: int) -> np.ndarray:
    """PyTorch's ``Conv2d`` without padding: ``x`` ``(batch, in, H, W)``, ``w`` ``(out, in, k, k)``."""
    k = w.shape[-1]
    windows = np.lib.stride_tricks.sliding_window_view(x, (k, k), axis=(2, 3))[:, :, ::stride, ::stride]
    out = np.tensordot(windows, w, axes=([1, 4, 5], [1, 2, 3]))  # (batch, H', W', out)
    return out.transpose(0, 3, 1, 2) + b[None, :, None, None]


def clip_goal(obs: dict[str, Any], goal_range: float | None) -> dict[str, Any]:
    """``obs`` with its ``goal`` vector (one, or a batch along the first axis) shortened to at
    most ``goal_range`` metres, its direction kept: a policy sees a far goal as one at that
    range straight ahead of it, a distance it met in training (an Urban-Nav test goal is
    7.5-12.5 m away, a training goal 5-9 m). ``None``: ``obs`` unchanged."""
    if not goal_range or "goal" not in obs:
        return obs
    goal = np.asarray(obs["goal"], dtype=np.float32)
    norm = np.linalg.norm(goal, axis=-1, keepdims=True)
    scale = np.minimum(1.0, goal_range / np.maximum(norm, 1e-9)).astype(np.float32)
    return {**obs, "goal": goal * scale}


class NumpyPolicy:
    """An exported policy (see the module docstring); ``reset(env)`` and ``act(obs)`` as the
    runner's baselines."""

    def __init__(self, meta: dict[str, Any], arrays: dict[str, np.ndarray]):
        self.meta = meta
        self.keys = tuple(meta["keys"])
        self.shapes = {k: tuple(s) for k, s in zip(self.keys, meta["shapes"], strict=True)}
        layers = sum(1 for k in arrays if k.startswith("w"))
        self.weights = [arrays[f"w{i}"].astype(np.float32) for i in range(layers)]
        self.biases = [arrays[f"b{i}"].astype(np.float32) for i in range(layers)]
        self.log_std = arrays["log_std"].astype(np.float32) if "log_std" in arrays else None
        self.norm = {
            k: (arrays[f"obs_mean/{k}"].astype(np.float32), np.sqrt(arrays[f"obs_var/{k}"] + meta["epsilon"]))
            for k in self.keys
            if f"obs_mean/{k}" in arrays
        }
        specs = meta.get("encoders", {})
        self.encoders = {
            key: (
                [
                    (
                        arrays[f"enc/{key}/conv{i}/w"].astype(np.float32),
                        arrays[f"enc/{key}/conv{i}/b"].astype(np.float32),
                        s,
                    )
                    for i, s in enumerate(spec["strides"])
                ],
                arrays[f"enc/{key}/fc/w"].astype(np.float32),
                arrays[f"enc/{key}/fc/b"].astype(np.float32),
            )
            for key, spec in specs.items()
        }
        self.stacks = {key: tuple(spec.get("stack", (key,))) for key, spec in specs.items()}
        self.stacked = {k for group in self.stacks.values() for k in group[1:]}
        self.activation = _ACTIVATIONS[meta["activation"]]
        self.low = np.asarray(meta["action_low"], dtype=np.float32)
        self.high = np.asarray(meta["action_high"], dtype=np.float32)

    def features(self, obs: dict[str, Any]) -> np.ndarray:
        """The network's input: a ``(batch, n)`` float32 array (``obs`` one observation or a batch)."""
        parts = []
        clip = float(self.meta["clip_obs"])
        obs = clip_goal(obs, self.meta.get("goal_range"))
        inputs = {}
        for k in self.keys:
            try:
                x = np.asarray(obs[k], dtype=np.float32)
            except KeyError:  # named here, not checked on every step
                missing = [key for key in self.keys if key not in obs]
                raise KeyError(
                    f"the policy reads observation keys {missing} that the observation lacks (it has "
                    f"{sorted(obs)}): make the environment with make_env(..., observations={list(self.keys)})"
                ) from None
            x = x.reshape(-1, *self.shapes[k])
            if k in self.norm:
                mean, std = self.norm[k]
                x = np.clip((x - mean) / std.astype(np.float32), -clip, clip)
            inputs[k] = x
        for k in (k for k in self.keys if k not in self.stacked):
            x = inputs[k]
            if k in self.encoders:
                x = np.concatenate([inputs[m] for m in self.stacks[k]], axis=1)
                convs, w, b = self.encoders[k]
                for cw, cb, stride in convs:
                    x = _relu(conv2d(x, cw, cb, stride))
                x = _relu(x.reshape(x.shape[0], -1) @ w.T + b)
            parts.append(x.reshape(x.shape[0], -1))
        return np.concatenate(parts, axis=1)

    def _latent(self, obs: dict[str, Any]) -> np.ndarray:
        """The last hidden layer's output, ``(batch, hidden)``."""
        h = self.features(obs)
        for w, b in zip(self.weights[:-1], self.biases[:-1], strict=True):
            h = self.activation(h @ w.T + b)
        return h

    def mean(self, obs: dict[str, Any]) -> np.ndarray:
        """The action distribution's mean, ``(batch, n)``, before clipping to the action space."""
        return self._latent(obs) @ self.weights[-1].T + self.biases[-1]

    def std(self, obs: dict[str, Any]) -> np.ndarray | None:
        """The action distribution's std, ``(batch, n)``: ``exp(log_std)``, or for a policy
        trained with gSDE (``log_std`` a ``(hidden, n)`` matrix) its state-dependent std
        ``sqrt(latent^2 @ exp(log_std)^2)`` as SB3 computes it; None if not exported."""
        if self.log_std is None:
            return None
        if self.log_std.ndim == 2:
            return np.sqrt(self._latent(obs) ** 2 @ np.exp(self.log_std) ** 2)
        return np.broadcast_to(np.exp(self.log_std), (len(self.features(obs)), self.log_std.size))

    def predict(self, obs: dict[str, Any], rng: np.random.Generator | None = None) -> np.ndarray:
        """Actions, ``(batch, *action_shape)``: the mean (deterministic), or with ``rng`` a draw
        from the trained Gaussian (:meth:`std`) as in training, clipped to the space."""
        a = self.mean(obs)
        if rng is not None and self.log_std is not None:
            a = a + self.std(obs) * rng.standard_normal(a.shape).astype(np.float32)
        return np.clip(a, self.low, self.high).reshape(-1, *self.meta["action_shape"])

    # The runner's Policy protocol (citygen.runner.policies).
    def reset(self, env: Any) -> None:
        pass

    def act(self, obs: dict[str, Any]) -> np.ndarray:
        return self.predict(obs)[0]


def policy_arrays(
    model: Any,
    obs_rms: dict[str, Any] | None,
    *,
    task: str,
    robot: str,
    clip_obs: float = 10.0,
    epsilon: float = 1e-8,
    activation: str = "tanh",
    goal_range: float | None = None,
    train: dict[str, Any] | None = None,
) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """The metadata and arrays of an SB3 PPO ``model`` with an MLP actor (a
    ``MultiInputPolicy`` over Box keys, whose feature extractor flattens and concatenates
    them) and the ``VecNormalize`` statistics ``obs_rms`` (per key, or ``None``);
    ``goal_range`` as :attr:`~citygen.runner.learn.config.TrainConfig.goal_range`."""
    import torch

    policy = model.policy
    space = model.observation_space
    keys = list(space.spaces)
    linears = [m for m in policy.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)]
    linears.append(policy.action_net)
    arrays: dict[str, np.ndarray] = {}
    for i, layer in enumerate(linears):
        arrays[f"w{i}"] = layer.weight.detach().cpu().numpy().astype(np.float32)
        arrays[f"b{i}"] = layer.bias.detach().cpu().numpy().astype(np.float32)
    arrays["log_std"] = policy.log_std.detach().cpu().numpy().astype(np.float32)
    encoders = {}
    extractor = policy.pi_features_extractor
    for key, module in getattr(extractor, "encoders", {}).items():
        convs = [m for m in module.modules() if isinstance(m, torch.nn.Conv2d)]
        if not convs:
            continue
        for i, conv in enumerate(convs):
            arrays[f"enc/{key}/conv{i}/w"] = conv.weight.detach().cpu().numpy().astype(np.float32)
            arrays[f"enc/{key}/conv{i}/b"] = conv.bias.detach().cpu().numpy().astype(np.float32)
        (fc,) = [m for m in module.modules() if isinstance(m, torch.nn.Linear)]
        arrays[f"enc/{key}/fc/w"] = fc.weight.detach().cpu().numpy().astype(np.float32)
        arrays[f"enc/{key}/fc/b"] = fc.bias.detach().cpu().numpy().astype(np.float32)
        encoders[key] = {"strides": [int(c.stride[0]) for c in convs]}
        group = getattr(extractor, "stacks", {}).get(key, (key,))
        if len(group) > 1:
            encoders[key]["stack"] = list(group)
    if obs_rms is not None:
        for k in (k for k in keys if k in obs_rms):
            arrays[f"obs_mean/{k}"] = np.asarray(obs_rms[k].mean, dtype=np.float64)
            arrays[f"obs_var/{k}"] = np.asarray(obs_rms[k].var, dtype=np.float64)
    act = model.action_space
    meta = {
        "format": FORMAT,
        "task": task,
        "robot": robot,
        "keys": keys,
        "shapes": [list(space[k].shape) for k in keys],
        "action_shape": list(act.shape),
        "action_low": np.asarray(act.low, dtype=float).ravel().tolist(),
        "action_high": np.asarray(act.high, dtype=float).ravel().tolist(),
        "activation": activation,
        "encoders": encoders,
        "goal_range": goal_range,
        "clip_obs": float(clip_obs),
        "epsilon": float(epsilon),
        "train": train or {},
    }
    return meta, arrays


def write_policy(path: str | Path, meta: dict[str, Any], arrays: dict[str, np.ndarray]) -> Path:
    """Write an exported policy (compressed ``.npz``) atomically, and its metadata beside it
    as ``<name>.json`` for people to read."""
    from citygen.io import write_atomic

    path = Path(path)
    buf = io.BytesIO()
    np.savez_compressed(buf, meta=np.array(json.dumps(meta, sort_keys=True)), **arrays)
    write_atomic(path, buf.getvalue())
    write_atomic(path.with_suffix(".json"), (json.dumps(meta, indent=1, sort_keys=True) + "\n").encode())
    return path


def read_policy(path: str | Path) -> NumpyPolicy:
    """An exported policy file, or a :class:`ValueError` saying what was found instead (its
    message completes ``expected a policy exported by citygen train, got ...``)."""
    try:
        with open(path, "rb") as f:
            head = f.read(4)
        if head != b"PK\x03\x04":
            raise ValueError("a file that is not an .npz archive (no zip header)")
        with np.load(path, allow_pickle=False) as data:
            arrays = {k: data[k] for k in data.files}
    except ValueError:
        raise
    except Exception as exc:
        raise ValueError(f"a damaged .npz archive ({type(exc).__name__}: {exc})") from None
    if "meta" not in arrays:
        raise ValueError("an .npz archive without the 'meta' entry `citygen train` writes")
    try:
        meta = json.loads(str(arrays.pop("meta")))
    except json.JSONDecodeError as exc:
        raise ValueError(f"unreadable JSON in its 'meta' entry ({exc})") from None
    if not isinstance(meta, dict) or meta.get("format") != FORMAT:
        found = meta.get("format") if isinstance(meta, dict) else type(meta).__name__
        raise ValueError(f"metadata of format {found!r}, not {FORMAT!r}")
    try:
        policy = NumpyPolicy(meta, arrays)
        probe = {k: np.zeros(s, dtype=np.float32) for k, s in policy.shapes.items()}
        width = policy.features(probe).shape[1]
        if policy.weights[0].shape[1] != width:
            raise ValueError(
                f"a first layer reading {policy.weights[0].shape[1]} inputs, its observations {width}"
            )
        policy.predict(probe)
    except (KeyError, TypeError, IndexError, ValueError) as exc:
        raise ValueError(f"an incomplete exported policy ({type(exc).__name__}: {exc})") from None
    return policy
