"""``citygen train``: PPO (Stable-Baselines3, CPU PyTorch) on citygen's vector environment.

A run writes to its folder ``out``:

- ``config.json``: the :class:`~citygen.runner.learn.config.TrainConfig` it ran with;
- ``checkpoints/model_<steps>.zip`` + ``vecnormalize_<steps>.pkl`` every
  ``checkpoint_every`` steps (the last ``keep_checkpoints`` kept) and on Ctrl-C;
  ``--resume`` continues from the newest;
- ``curve.csv`` (one row per rollout: steps, wall time, steps/s, episodes, success rate and
  mean return of the last 100 episodes; appended across resumes) and ``curve.png``;
- ``logs/run-<k>/``: SB3's own logs (losses; ``progress.csv``, and TensorBoard event files
  when ``tensorboard`` is installed);
- at the end ``model.zip`` + ``vecnormalize.pkl`` (SB3) and ``policy.npz`` + ``policy.json``
  (the exported policy :mod:`citygen.runner.learn.export` runs without PyTorch).

Seeded: the same config and seed give the same run as far as PyTorch's CPU kernels allow
(:func:`torch.use_deterministic_algorithms` is on; the sub-environments are seeded
``seed + i``).
"""

from __future__ import annotations

import collections
import contextlib
import csv
import functools
import json
import signal
import sys
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from citygen.errors import Interrupted, is_interrupt
from citygen.runner.learn.config import TrainConfig
from citygen.runner.learn.extra import TrainError, require_train, stats_of

CURVE_FIELDS = ("steps", "seconds", "steps_per_s", "episodes", "success_rate", "return_mean")


@dataclass(frozen=True)
class TrainResult:
    out: Path
    steps: int
    seconds: float
    success_rate: float | None
    policy: Path


def latest_checkpoint(out: Path) -> tuple[int, Path, Path] | None:
    """``(steps, model.zip, vecnormalize.pkl)`` of the newest complete checkpoint in ``out``."""
    found = []
    for model in (out / "checkpoints").glob("model_*.zip"):
        steps = model.stem.removeprefix("model_")
        stats = stats_of(model)
        if steps.isdigit() and stats.exists():
            found.append((int(steps), model, stats))
    return max(found) if found else None


class _Tracker:
    """Episode outcomes and throughput, shared by the progress bar and the curve."""

    def __init__(self, start_steps: int):
        self.success: collections.deque[float] = collections.deque(maxlen=100)
        self.returns: collections.deque[float] = collections.deque(maxlen=100)
        self.levels: collections.deque[int] = collections.deque(maxlen=100)
        self.episodes = 0
        self.t0 = time.perf_counter()
        self.start_steps = start_steps

    def rate(self, steps: int) -> float:
        return (steps - self.start_steps) / max(time.perf_counter() - self.t0, 1e-9)

    def success_rate(self) -> float | None:
        return 100.0 * sum(self.success) / len(self.success) if self.success else None


def _callbacks(cfg: TrainConfig, out: Path, venv: Any, tracker: _Tracker, bar: Any, seconds0: float):
    import torch
    from stable_baselines3.common.callbacks import BaseCallback

    from citygen.generate.dataset import default_jobs

    rollout_threads = torch.get_num_threads()  # train() has set torch_threads (0: PyTorch's own)
    update_threads = cfg.update_threads or default_jobs()

    class Callback(BaseCallback):
        def _on_step(self) -> bool:
            for done, info in zip(self.locals["dones"], self.locals["infos"], strict=True):
                if done:
                    tracker.episodes += 1
                    tracker.success.append(float(info.get("is_success", False)))
                    if "episode" in info:
                        tracker.returns.append(float(info["episode"]["r"]))
                    if "terrain_level" in info:  # a locomotion curriculum's row
                        tracker.levels.append(int(info["terrain_level"]))
            n = self.model.num_timesteps
            if bar is not None and self.n_calls % 10 == 0:
                bar.update(n, tracker.rate(n), tracker.success_rate())
            if n // cfg.checkpoint_every > (n - self.training_env.num_envs) // cfg.checkpoint_every:
                save_checkpoint(self.model, venv, out, cfg.keep_checkpoints)
                sr = tracker.success_rate()
                print(
                    f"{n:,} steps: success {'-' if sr is None else f'{sr:.1f} %'} (last 100 episodes), "
                    f"{tracker.rate(n):.0f} steps/s, checkpoint saved",
                    flush=True,
                )
            return True

        def _on_rollout_start(self) -> None:
            cap_log_std(self.model.policy, log_std_cap(cfg, self.model.num_timesteps))
            torch.set_num_threads(rollout_threads)  # the sub-environments' turn

        def _on_training_end(self) -> None:
            # the last update may have widened it again: the policy saved ends on the schedule
            cap_log_std(self.model.policy, log_std_cap(cfg, self.model.num_timesteps))

        def _on_rollout_end(self) -> None:
            n = self.model.num_timesteps
            # The update runs while the sub-environments wait: it may have every core.
            torch.set_num_threads(update_threads)
            # for the update of the rollout just ended
            freeze_actor(self.model.policy, n <= cfg.critic_warmup)
            if tracker.levels:  # into progress.csv with the update's figures
                self.logger.record("rollout/terrain_level", sum(tracker.levels) / len(tracker.levels))
            row = {
                "steps": n,
                "seconds": round(seconds0 + time.perf_counter() - tracker.t0, 2),
                "steps_per_s": round(tracker.rate(n), 1),
                "episodes": tracker.episodes,
                "success_rate": "" if tracker.success_rate() is None else round(tracker.success_rate(), 2),
                "return_mean": round(sum(tracker.returns) / len(tracker.returns), 3)
                if tracker.returns
                else "",
            }
            path = out / "curve.csv"
            new = not path.exists()
            with open(path, "a", newline="") as f:
                w = csv.DictWriter(f, CURVE_FIELDS)
                if new:
                    w.writeheader()
                w.writerow(row)

    return Callback()


def log_std_cap(cfg: TrainConfig, steps: int) -> float | None:
    """The ceiling on the actions' log std at ``steps`` (``log_std_final``): linear from
    ``log_std_init`` at 0 to ``log_std_final`` at ``cfg.steps``; None without one."""
    if cfg.log_std_final is None:
        return None
    f = min(max(steps / cfg.steps, 0.0), 1.0)
    return cfg.log_std_init + f * (cfg.log_std_final - cfg.log_std_init)


def cap_log_std(policy: Any, cap: float | None) -> None:
    """Lower ``policy.log_std`` to at most ``cap`` (nothing when None or the policy has none)."""
    if cap is None or getattr(policy, "log_std", None) is None:
        return
    import torch

    with torch.no_grad():
        policy.log_std.clamp_(max=cap)


def actor_parameters(policy: Any) -> list[Any]:
    """The parameters of an SB3 actor-critic policy that the critic does not own: the
    feature extractor (shared with the critic, as citygen trains), the actor's hidden layers,
    its action layer and ``log_std``."""
    modules = [policy.features_extractor, policy.mlp_extractor.policy_net, policy.action_net]
    found = [p for m in modules for p in m.parameters()]
    own = getattr(policy, "pi_features_extractor", policy.features_extractor)
    if own is not policy.features_extractor:
        found += list(own.parameters())
    return [*found, *([policy.log_std] if hasattr(policy, "log_std") else [])]


def freeze_actor(policy: Any, frozen: bool) -> None:
    """Hold the actor still (``critic_warmup``): its parameters get no gradient, so PPO's
    update (Adam skips a parameter without one) moves the critic alone."""
    for param in actor_parameters(policy):
        param.requires_grad_(not frozen)


@contextlib.contextmanager
def atomically(path: Path):
    """A temporary name beside ``path`` (``part-<name>``) for a library that writes files itself
    (SB3's zips, pickles, matplotlib): renamed to ``path`` when the block succeeds, removed when
    it fails, so a full disk or Ctrl-C leaves no half file; the operating system's refusals
    become one-line :class:`~citygen.errors.OutputError` naming ``path``."""
    from citygen.outputs import OUTPUT_ERRNOS, output_error

    part = path.with_name(f"part-{path.name}")
    try:
        yield part
        part.replace(path)
    except BaseException as exc:
        part.unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.errno in OUTPUT_ERRNOS:
            raise output_error(exc, path) from None
        raise


def save_checkpoint(model: Any, venv: Any, out: Path, keep: int) -> None:
    """``checkpoints/model_<steps>.zip`` and its ``vecnormalize_<steps>.pkl``; older ones
    beyond ``keep`` removed, but never the one at 0 steps (the policy imitation rounds made,
    to compare PPO's steps with). Written to temporary names and renamed (never half a file)."""
    folder = out / "checkpoints"
    folder.mkdir(parents=True, exist_ok=True)
    n = model.num_timesteps
    with atomically(folder / f"vecnormalize_{n}.pkl") as part:
        venv.save(str(part))
    with atomically(folder / f"model_{n}.zip") as part:
        model.save(part)
    steps = sorted(
        int(p.stem.removeprefix("model_"))
        for p in folder.glob("model_*.zip")
        if p.stem.removeprefix("model_").isdigit()
    )
    for old in [s for s in steps[:-keep] if s]:
        (folder / f"model_{old}.zip").unlink(missing_ok=True)
        (folder / f"vecnormalize_{old}.pkl").unlink(missing_ok=True)


class _Bar:
    """The rich progress bar: steps, steps/s, success rate, ETA."""

    def __init__(self, total: int, done: int):
        from rich.console import Console
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn

        self.progress = Progress(
            TextColumn("training"),
            BarColumn(),
            MofNCompleteColumn(),
            TextColumn("{task.fields[sps]} steps/s"),
            TextColumn("success {task.fields[success]}"),
            TimeRemainingColumn(),
            console=Console(stderr=True),
        )
        self.task = self.progress.add_task("train", total=total, completed=done, sps="-", success="-")
        self.progress.start()

    def update(self, steps: int, rate: float, success: float | None) -> None:
        self.progress.update(
            self.task,
            completed=steps,
            sps=f"{rate:.0f}",
            success="-" if success is None else f"{success:.1f} %",
        )

    def stop(self) -> None:
        self.progress.stop()


def plot_curve(out: Path) -> Path | None:
    """``curve.png`` from ``curve.csv``: success rate and mean return against steps."""
    path = out / "curve.csv"
    if not path.exists():
        return None
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    steps = [int(r["steps"]) for r in rows]
    success = [float(r["success_rate"]) if r["success_rate"] else float("nan") for r in rows]
    ret = [float(r["return_mean"]) if r["return_mean"] else float("nan") for r in rows]
    fig, ax = plt.subplots(figsize=(7, 4), dpi=100)
    ax.plot(steps, success, color="tab:green", label="success rate (%)")
    ax.set_xlabel("environment steps")
    ax.set_ylabel("success rate (%), last 100 episodes")
    ax.set_ylim(0, 100)
    ax2 = ax.twinx()
    ax2.plot(steps, ret, color="tab:blue", alpha=0.6, label="mean return")
    ax2.set_ylabel("mean episode return")
    config = json.loads((out / "config.json").read_text()) if (out / "config.json").exists() else {}
    ax.set_title(
        f"PPO {config.get('task', '')} {config.get('robot_name', '')} on {config.get('train_split', '')}"
    )
    (h1, l1), (h2, l2) = ax.get_legend_handles_labels(), ax2.get_legend_handles_labels()
    ax.legend(h1 + h2, l1 + l2, loc="upper left")
    fig.tight_layout()
    png = out / "curve.png"
    with atomically(png) as part:
        fig.savefig(part, format="png")
    plt.close(fig)
    return png


def _check_resume(cfg: TrainConfig, out: Path) -> None:
    saved = json.loads((out / "config.json").read_text()) if (out / "config.json").exists() else None
    if saved is None:
        return
    for key in ("task", "robot_name", "train_split"):
        now = getattr(cfg, key)
        if saved.get(key) != now:
            raise TrainError(f"--resume: {out} holds a run of {key} {saved.get(key)!r}, not {now!r}")


def _interrupt(signum: int, frame: Any) -> None:
    raise KeyboardInterrupt


def _main_thread() -> bool:
    import threading

    return threading.current_thread() is threading.main_thread()


def _start_from(model: Any, venv: Any, init: Path) -> None:
    """Load ``init``'s policy weights into ``model`` and its observation statistics into
    ``venv`` (``--init``); a one-line :class:`TrainError` when they do not fit. ``init`` is a
    run folder, a ``model.zip``, or an exported ``policy.npz`` (:func:`_start_from_policy`)."""
    import pickle

    if init.suffix == ".npz":
        _start_from_policy(model, venv, init)
        return
    zip_ = init / "model.zip" if init.is_dir() else init
    stats = stats_of(zip_)
    if not zip_.is_file():
        raise TrainError(
            f"--init: expected a run folder, model.zip or policy.npz saved by citygen train, got {init}"
        )
    try:
        model.set_parameters(str(zip_), exact_match=True, device="cpu")
    except Exception as exc:  # SB3 raises bare exceptions on mismatched state dicts
        if not _start_widened(model, zip_):
            detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise TrainError(
                f"--init: {zip_} does not fit this run's observation keys and action space ({detail})"
            ) from None
    if stats.is_file():
        with open(stats, "rb") as f:
            saved = pickle.load(f)
        if set(saved.obs_rms) != set(venv.obs_rms):
            raise TrainError(
                f"--init: {stats} normalises {sorted(saved.obs_rms)}, this run {sorted(venv.obs_rms)}"
            )
        venv.obs_rms = saved.obs_rms
        venv.ret_rms = saved.ret_rms


def _added_layers(
    new: Mapping[str, Sequence[str]], old: Mapping[str, Sequence[str]]
) -> dict[str, int] | None:
    """A run whose map CNNs read the ``stack`` groups ``new`` starting from one that read
    ``old`` (both keyed by a group's first layer; a key missing from ``old`` read itself
    alone): each group that adds layers at its end -> how many layers it had. None when an
    old group does not lead its new one, in the same order."""
    added = {}
    for key, group in new.items():
        before = tuple(old.get(key, (key,)))
        if tuple(group[: len(before)]) != before:
            return None
        if len(group) > len(before):
            added[key] = len(before)
    return added


def _widened(weight: Any, shape: tuple[int, ...]) -> np.ndarray | None:
    """A first convolution's ``weight`` ``(out, in, k, k)`` for ``shape``, which has more input
    channels: the old channels' weights, the new ones 0 (the widened run starts as the old
    policy). None when the rest of the shape differs."""
    weight = np.asarray(weight, dtype=np.float32)
    if weight.shape[0] != shape[0] or weight.shape[2:] != tuple(shape[2:]) or weight.shape[1] > shape[1]:
        return None
    out = np.zeros(shape, dtype=np.float32)
    out[:, : weight.shape[1]] = weight
    return out


def _start_widened(model: Any, zip_: Path) -> bool:
    """Start from ``zip_`` whose map CNNs read fewer stacked layers than this run's: a run
    that adds a layer at the end of a ``stack`` group (``local_map_motion`` beside the local
    map and the crossable layer) starts from one trained without it. The first convolution's
    weights for the new input channels start at 0 (:func:`_widened`), so the new run begins
    as the old policy and learns what the layer adds; every other weight must fit exactly.
    False (nothing loaded) when the two networks differ in any other way."""
    import torch
    from stable_baselines3.common.save_util import load_from_zip_file

    try:
        data, params, _ = load_from_zip_file(str(zip_), device="cpu")
        saved = params["policy"]
        old_stack = data["policy_kwargs"].get("features_extractor_kwargs", {}).get("stack", ())
    except Exception:
        return False
    new_stack = getattr(model.policy.features_extractor, "stacks", {})
    added = _added_layers(new_stack, {g[0]: tuple(g) for g in old_stack})
    mine = model.policy.state_dict()
    if not added or set(saved) != set(mine):
        return False
    first_convs = {f"encoders.{key}.0.weight" for key in added}
    widened = {}
    for name, value in saved.items():
        want = mine[name]
        if tuple(value.shape) == tuple(want.shape):
            widened[name] = value
            continue
        w = _widened(value, tuple(want.shape)) if name.split("extractor.", 1)[-1] in first_convs else None
        if w is None:
            return False
        widened[name] = torch.as_tensor(w)
    model.policy.load_state_dict(widened)
    return True


def _start_from_policy(model: Any, venv: Any, path: Path) -> None:
    """Start from an exported policy (``citygen train``'s ``policy.npz``, or a shipped
    baseline): its actor (hidden layers, action layer, ``log_std``), its map encoders (the
    feature extractor the critic shares) and its observation statistics. The file holds no
    critic: the value head starts fresh, so begin with a small learning rate (the fine-tuning
    ``--config`` of the baselines' README)."""
    import numpy as np
    import torch

    from citygen.runner.learn.export import read_policy

    try:
        policy = read_policy(path)
    except (OSError, ValueError) as exc:
        raise TrainError(
            f"--init: {path}: expected a policy exported by `citygen train`, got {exc}"
        ) from None
    p = model.policy
    stacks = getattr(p.features_extractor, "stacks", {})
    # Layers this run adds at the end of a stack group the file's CNN reads, as _start_widened.
    added = _added_layers({k: g for k, g in stacks.items() if k in policy.stacks}, policy.stacks) or {}
    new_layers = {layer for key, n in added.items() for layer in stacks[key][n:]}
    keys = list(model.observation_space.spaces)
    if list(policy.keys) != [k for k in keys if k not in new_layers]:
        raise TrainError(f"--init: {path} reads the observation keys {list(policy.keys)}, this run {keys}")
    layers = [m for m in p.mlp_extractor.policy_net if isinstance(m, torch.nn.Linear)] + [p.action_net]
    pairs = [(layer.weight, w) for layer, w in zip(layers, policy.weights, strict=False)]
    pairs += [(layer.bias, b) for layer, b in zip(layers, policy.biases, strict=False)]
    if len(layers) != len(policy.weights):
        raise TrainError(f"--init: {path} has {len(policy.weights)} layers, this run's actor {len(layers)}")
    if policy.log_std is not None:
        pairs.append((p.log_std, policy.log_std))
    encoders = getattr(p.features_extractor, "encoders", {})
    for key, (convs, fc_w, fc_b) in policy.encoders.items():
        if key not in encoders:
            raise TrainError(f"--init: {path} encodes {key!r} with a CNN, this run does not")
        mine_stack = stacks.get(key, (key,))
        if tuple(policy.stacks[key]) != tuple(mine_stack)[: added.get(key, len(mine_stack))]:
            raise TrainError(
                f"--init: {path}'s {key!r} CNN reads {list(policy.stacks[key])}, "
                f"this run's {list(mine_stack)}"
            )
        mine = [m for m in encoders[key].modules() if isinstance(m, torch.nn.Conv2d)]
        (fc,) = [m for m in encoders[key].modules() if isinstance(m, torch.nn.Linear)]
        if len(mine) != len(convs):
            raise TrainError(
                f"--init: {path}'s {key!r} encoder has {len(convs)} convolutions, this run's {len(mine)}"
            )
        w0 = _widened(convs[0][0], tuple(mine[0].weight.shape)) if key in added else None
        if w0 is not None:  # else the shape check below names the misfit
            convs = [(w0, *convs[0][1:]), *convs[1:]]
        for conv, (w, b, _) in zip(mine, convs, strict=True):
            pairs += [(conv.weight, w), (conv.bias, b)]
        pairs += [(fc.weight, fc_w), (fc.bias, fc_b)]
    for param, value in pairs:
        if tuple(param.shape) != value.shape:
            raise TrainError(
                f"--init: {path} does not fit this run's network "
                f"(a {value.shape} weight for {tuple(param.shape)})"
            )
    with torch.no_grad():
        for param, value in pairs:
            param.copy_(torch.as_tensor(value))
    for key, (mean, std) in policy.norm.items():
        if key in getattr(venv, "obs_rms", {}):
            rms = venv.obs_rms[key]
            rms.mean = mean.astype(np.float64)
            rms.var = np.square(std.astype(np.float64)) - policy.meta["epsilon"]
            rms.count = 1e6  # statistics of a finished run: new samples move them slowly


def _imitate(model: Any, venv: Any, cfg: TrainConfig, out: Path, resume: bool) -> None:
    """DAgger from ``cfg.expert`` before PPO (:mod:`citygen.runner.learn.imitate`), with a
    checkpoint at 0 steps after it (a ``--resume`` goes on with PPO); then, with
    ``bc_coef``, the cloning term in PPO's updates, on the data set kept in the run folder."""
    from citygen.runner.learn import imitate

    store = out / "imitation.npz"
    if resume:
        if not cfg.bc_coef:
            return
        if not store.is_file():
            raise TrainError(f"--resume: {store}, the DAgger data set bc_coef clones, is missing")
        data = imitate.Demonstrations.load(store, tuple(cfg.obs_keys))
    else:
        data = imitate.dagger(model, venv, cfg, out)
        if cfg.bc_coef:
            data.save(store)
        save_checkpoint(model, venv, out, cfg.keep_checkpoints)
    if cfg.bc_coef:
        imitate.keep_cloning(model, venv, data, cfg.bc_coef, cfg.seed)


def _schedule(cfg: TrainConfig) -> Any:
    """SB3's learning rate: a number, or a function of the remaining progress (1 -> 0 over
    the run's ``steps``, counted from step 0 also when resuming)."""
    if cfg.lr_schedule == "constant":
        return cfg.learning_rate
    return functools.partial(_linear, cfg.learning_rate)


def _linear(lr: float, remaining: float) -> float:
    return lr * max(remaining, 0.0)


def train(
    cfg: TrainConfig,
    out: str | Path,
    *,
    resume: bool = False,
    progress: bool | None = None,
    command: str | None = None,
) -> TrainResult:
    """Train PPO as ``cfg`` says into the folder ``out`` (see the module docstring); resume
    from its newest checkpoint with ``resume``. ``progress``: the rich bar (default: when
    stderr is a terminal)."""
    require_train()
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.logger import configure
    from stable_baselines3.common.utils import set_random_seed
    from stable_baselines3.common.vec_env import VecMonitor, VecNormalize

    from citygen.io import write_atomic
    from citygen.runner.learn.export import policy_arrays, write_policy
    from citygen.runner.learn.vecenv import make_training_env
    from citygen.runner.scenes import cache_budget

    cache_budget()  # a bad CITYGEN_SCENE_CACHE_MB fails here, before the run folder is written
    out = Path(out)
    ckpt = latest_checkpoint(out)
    if resume:
        if ckpt is None:
            raise TrainError(f"--resume: no checkpoint in {out / 'checkpoints'} to continue from")
        _check_resume(cfg, out)
    elif ckpt is not None or (out / "model.zip").exists():
        raise TrainError(
            f"--out: {out} already holds a training run; pass --resume to continue it, or another --out"
        )

    if cfg.torch_threads:
        torch.set_num_threads(cfg.torch_threads)
    torch.use_deterministic_algorithms(True, warn_only=True)
    set_random_seed(cfg.seed)
    inner = VecMonitor(make_training_env(cfg))
    if resume:
        venv = VecNormalize.load(str(ckpt[2]), inner)
        model = PPO.load(ckpt[1], env=venv, device="cpu")
        print(f"resuming from {ckpt[1]} ({ckpt[0]:,} steps)", flush=True)
    else:
        from citygen.runner.learn.nets import MapEncoder, is_map

        space = inner.observation_space
        maps = [k for k in space.spaces if cfg.conv and is_map(space[k])]
        venv = VecNormalize(
            inner,
            norm_obs=cfg.normalize,
            norm_reward=cfg.normalize,
            gamma=cfg.gamma,
            epsilon=cfg.norm_epsilon,
            # A map's cells keep their metres and 0/1: the CNN's filters slide over them.
            norm_obs_keys=[k for k in space.spaces if k not in maps],
        )
        activation = {"tanh": torch.nn.Tanh, "relu": torch.nn.ReLU, "elu": torch.nn.ELU}[cfg.activation]
        encoder = (
            {
                "features_extractor_class": MapEncoder,
                "features_extractor_kwargs": {
                    "conv": cfg.conv,
                    "map_features": cfg.map_features,
                    "stack": cfg.stack,
                },
            }
            if maps
            else {}
        )
        model = PPO(
            "MultiInputPolicy",
            venv,
            n_steps=cfg.n_steps,
            batch_size=cfg.batch_size,
            n_epochs=cfg.n_epochs,
            learning_rate=_schedule(cfg),
            gamma=cfg.gamma,
            gae_lambda=cfg.gae_lambda,
            clip_range=cfg.clip_range,
            ent_coef=cfg.ent_coef,
            vf_coef=cfg.vf_coef,
            max_grad_norm=cfg.max_grad_norm,
            target_kl=cfg.target_kl,
            use_sde=cfg.use_sde,
            sde_sample_freq=cfg.sde_sample_freq,
            seed=cfg.seed,
            device="cpu",
            verbose=0,
            policy_kwargs={
                "net_arch": {"pi": list(cfg.net_arch), "vf": list(cfg.net_arch)},
                "activation_fn": activation,
                "log_std_init": cfg.log_std_init,
                **encoder,
            },
        )
        if cfg.init:
            _start_from(model, venv, Path(cfg.init))
    # The run folder is made once the environments and the model exist: a run that cannot
    # start (an unknown robot, a split of another task, a bad --init) leaves nothing behind.
    try:
        out.mkdir(parents=True, exist_ok=True)
        doc = {**cfg.model_dump(mode="json"), "robot_name": cfg.robot_name, "train_split": cfg.train_split}
        if command:
            doc["command"] = command
        write_atomic(out / "config.json", (json.dumps(doc, indent=1) + "\n").encode())
    except BaseException:
        venv.close()
        raise
    runs = len(list((out / "logs").glob("run-*"))) if (out / "logs").exists() else 0
    formats = ["csv"]
    try:
        import tensorboard  # noqa: F401

        formats.append("tensorboard")
    except ImportError:
        pass
    model.set_logger(configure(str(out / "logs" / f"run-{runs + 1}"), formats))

    start = model.num_timesteps
    seconds0 = 0.0
    if resume and (out / "curve.csv").exists():
        with open(out / "curve.csv", newline="") as f:
            rows = [r for r in csv.DictReader(f) if int(r["steps"]) <= start]
        seconds0 = float(rows[-1]["seconds"]) if rows else 0.0
        with open(out / "curve.csv", "w", newline="") as f:  # drop rows past the checkpoint
            w = csv.DictWriter(f, CURVE_FIELDS)
            w.writeheader()
            w.writerows(rows)
    tracker = _Tracker(start)
    show = sys.stderr.isatty() if progress is None else progress
    bar = _Bar(cfg.steps, start) if show else None
    # ``kill``, a job scheduler's preemption and a background job (whose shell ignores
    # Ctrl-C) stop a run with SIGTERM: save a checkpoint as Ctrl-C does.
    previous = signal.signal(signal.SIGTERM, _interrupt) if _main_thread() else None
    imitating = False
    try:
        if cfg.expert:
            t0 = time.perf_counter()
            imitating = not resume
            _imitate(model, venv, cfg, out, resume)
            imitating = False
            # the rounds' time counts in the run's seconds, not in PPO's steps/s
            seconds0 += time.perf_counter() - t0
            tracker.t0 = time.perf_counter()
        if cfg.steps > start:
            model.learn(
                total_timesteps=cfg.steps - start,
                reset_num_timesteps=False,
                callback=_callbacks(cfg, out, venv, tracker, bar, seconds0),
            )
    except BaseException as exc:
        if not is_interrupt(exc):
            venv.close()  # no worker process outlives a failed run
            raise
        if bar is not None:
            bar.stop()
            bar = None
        if imitating:  # no checkpoint before the rounds end: the same command starts over
            with contextlib.suppress(BaseException):
                venv.close()
            raise Interrupted(
                f"interrupted in the imitation rounds, before any checkpoint; run the same command "
                f"again (the rounds start over in {out})"
            ) from None
        save_checkpoint(model, venv, out, cfg.keep_checkpoints)
        with contextlib.suppress(BaseException):  # workers that got the Ctrl-C too are gone already
            venv.close()
        raise Interrupted(
            f"interrupted at {model.num_timesteps:,} steps; checkpoint saved, "
            f"continue with --resume --out {out}"
        ) from None
    finally:
        if bar is not None:
            bar.stop()
        if previous is not None:
            signal.signal(signal.SIGTERM, previous)
    with atomically(out / "model.zip") as part:
        model.save(part)
    with atomically(out / "vecnormalize.pkl") as part:
        venv.save(str(part))
    venv.close()
    train_notes = {
        "steps": int(model.num_timesteps),
        "seed": cfg.seed,
        "split": cfg.train_split,
        "success_rate_last_100": tracker.success_rate(),
        "command": command,
    }
    meta, arrays = policy_arrays(
        model,
        venv.obs_rms if cfg.normalize else None,
        task=cfg.task,
        robot=cfg.robot_name,
        clip_obs=venv.clip_obs,
        epsilon=venv.epsilon,
        activation=cfg.activation,
        goal_range=cfg.goal_range,
        train=train_notes,
    )
    if cfg.locomotion == "learned":  # trained on the robot's legs: --policy ppo there (shipped_models)
        meta["locomotion"] = "learned"
    if cfg.gait:  # the policy rides on the gait (learn.residual); load_policy puts it back under it
        from citygen.runner.learn.residual import gait_spec

        meta["gait"] = gait_spec(cfg.model_dump())
    policy = write_policy(out / "policy.npz", meta, arrays)
    plot_curve(out)
    seconds = seconds0 + time.perf_counter() - tracker.t0
    return TrainResult(out, int(model.num_timesteps), seconds, tracker.success_rate(), policy)
