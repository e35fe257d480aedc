"""Imitation of an expert before PPO: DAgger (Ross, Gordon and Bagnell 2011).

A run with an ``expert`` first teaches its actor to act as the expert does, then trains on
with PPO from there. The experts (:data:`EXPERTS`):

- ``"planner"`` (navigation): :class:`citygen.runner.policies.PlannerPolicy`, A* on the
  scene's maps and pure pursuit;
- ``"terrain"`` (locomotion): :class:`TerrainExpert`, the robot's shipped terrain models
  dispatched by the ground ahead as the traverse's Human-AI-Mode-1 does: one network distilled
  from several specialists (as Barkour distilled its skills into a generalist; Caluwaerts et
  al. 2023) walks every terrain with a single model, the paper's general locomotion model.

The rounds:

1. each of ``dagger_iterations`` rounds drives ``dagger_episodes`` training episodes (the
   run's split, ``--scenes`` and shaping) with the actor's mean action (in the first round,
   each step is the planner's with probability ``dagger_beta``), and labels every state it
   visits with the action the planner would take there;
2. the states and labels of all rounds so far are one data set, on which the actor's mean is
   fitted to the labels (squared error, ``dagger_epochs`` passes, Adam at ``dagger_lr``);
   the observation statistics the policy normalises with follow the visited states, as
   PPO's would.

The policy sees only its observations (the goal, its velocity, the local map); the planner
sees the whole scene, the terrain expert the terrain kind ahead. DAgger's rounds are on the
states the policy itself reaches, so it learns to recover from its own mistakes, which
cloning the expert's own episodes does not teach. ``bc_coef`` keeps a behaviour-cloning term
on the data set in every PPO update (the squared error, weighted), so that PPO does not
unlearn what the expert showed where its own returns are silent (the roll-overs of wheeled
NavClear came back without it).

The rounds' figures (success of the episodes driven, samples, loss) go to
``imitation.csv`` in the run folder; the data set to ``imitation.npz`` when ``bc_coef`` needs
it again on ``--resume``.
"""

from __future__ import annotations

import csv
import time
from pathlib import Path
from typing import Any

import numpy as np

from citygen.runner.learn.config import TrainConfig
from citygen.runner.learn.export import clip_goal

#: The experts a run can imitate.
EXPERTS = ("planner", "terrain")
IMITATION_FIELDS = ["iteration", "episodes", "success_rate", "samples", "loss", "seconds"]
_BATCH = 256


class Demonstrations:
    """The aggregated data set: raw observations (maps as float16, the rest float32) and the
    expert's actions."""

    def __init__(self, keys: tuple[str, ...]):
        self.keys = keys
        self.obs: dict[str, list[np.ndarray]] = {k: [] for k in keys}
        self.labels: list[np.ndarray] = []

    def __len__(self) -> int:
        return len(self.labels)

    def add(self, obs: dict[str, np.ndarray], label: np.ndarray) -> None:
        for k in self.keys:
            v = np.asarray(obs[k])
            self.obs[k].append(v.astype(np.float16 if v.ndim > 1 else np.float32))
        self.labels.append(np.asarray(label, dtype=np.float32))

    def arrays(self) -> tuple[dict[str, np.ndarray], np.ndarray]:
        return {k: np.stack(v) for k, v in self.obs.items()}, np.stack(self.labels)

    def save(self, path: Path) -> None:
        import io

        from citygen.io import write_atomic

        obs, labels = self.arrays()
        buffer = io.BytesIO()
        np.savez(buffer, labels=labels, **{f"obs/{k}": v for k, v in obs.items()})
        write_atomic(path, buffer.getvalue())  # never half a file

    @classmethod
    def load(cls, path: Path, keys: tuple[str, ...]) -> Demonstrations:
        self = cls(keys)
        with np.load(path) as z:
            self.labels = list(z["labels"])
            self.obs = {k: list(z[f"obs/{k}"]) for k in keys}
        return self


def _normalized(venv: Any, obs: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    return venv.normalize_obs({k: v.astype(np.float32) for k, v in obs.items()})


def _mean_action(policy: Any, nobs: dict[str, np.ndarray]) -> Any:
    """The actor's mean action (a tensor with its graph), as a deterministic test runs it."""
    import torch

    tensors = {k: torch.as_tensor(v) for k, v in nobs.items()}
    return policy.get_distribution(tensors).distribution.mean.clamp(-1.0, 1.0)


def _squared_error(policy: Any, nobs: dict[str, np.ndarray], labels: Any) -> Any:
    """The mean squared error of the actor's mean on normalised observations ``nobs``
    against the expert's actions ``labels`` (a tensor with its graph)."""
    return ((_mean_action(policy, nobs) - labels) ** 2).mean()


def bc_loss(policy: Any, venv: Any, data: Demonstrations, rng: np.random.Generator, batch: int = _BATCH):
    """:func:`_squared_error` on a random minibatch of ``data``."""
    import torch

    idx = rng.integers(len(data), size=min(batch, len(data)))
    obs = {k: np.stack([data.obs[k][i] for i in idx]) for k in data.keys}
    labels = torch.as_tensor(np.stack([data.labels[i] for i in idx]))
    return _squared_error(policy, _normalized(venv, obs), labels)


def _fit(policy: Any, venv: Any, data: Demonstrations, cfg: TrainConfig, rng: np.random.Generator) -> float:
    """``cfg.dagger_epochs`` passes of Adam over ``data``; the last pass's mean loss."""
    import torch

    obs, labels = data.arrays()
    nobs = _normalized(venv, obs)
    targets = torch.as_tensor(labels)
    opt = torch.optim.Adam(policy.parameters(), lr=cfg.dagger_lr)
    total = 0.0
    for _ in range(cfg.dagger_epochs):
        order = rng.permutation(len(labels))
        total = 0.0
        for s in range(0, len(order), _BATCH):
            idx = order[s : s + _BATCH]
            loss = _squared_error(policy, {k: v[idx] for k, v in nobs.items()}, targets[idx])
            opt.zero_grad()
            loss.backward()
            torch.nn.utils.clip_grad_norm_(policy.parameters(), 1.0)
            opt.step()
            total += float(loss.detach()) * len(idx)
    return total / max(len(labels), 1)


class TerrainExpert:
    """The locomotion the traverse's Human-AI-Mode-1 walks on, as an expert: at each step the
    robot's shipped model of the ground ahead (:func:`~citygen.runner.policies.ground_ahead`,
    :func:`~citygen.runner.policies.locomotion_for`: the terrain's model on a slope, stairs
    or rough ground where one ships, else the general model) acts on the observation. The
    general model here is ``loco-general-<robot>.npz``, not the traverse's one distilled from
    this expert (``loco-general-<robot>-nav.npz``), so a distillation never imitates itself."""

    def __init__(self, robot: str):
        from citygen.runner import policies
        from citygen.runner.learn.policy import load_policy
        from citygen.runner.learn.shipped_models import general_locomotion, terrain_locomotion

        #: Model name (``"general"``, a terrain) -> file.
        self.files = {"general": general_locomotion(robot), **terrain_locomotion(robot)}
        self.policies = {name: load_policy(str(path)) for name, path in self.files.items()}
        self._policies = policies  # ground_ahead, locomotion_for: looked up per step, imported once
        self.env: Any = None
        #: The model that acted last.
        self.model = "general"

    def reset(self, env: Any) -> None:
        self.env = env

    def act(self, obs: dict[str, np.ndarray]) -> np.ndarray:
        name = self._policies.locomotion_for(self._policies.ground_ahead(self.env))
        self.model = name if name in self.policies else "general"
        return np.asarray(self.policies[self.model].act(obs), dtype=np.float32)


def make_expert(cfg: TrainConfig) -> Any:
    """The expert ``cfg.expert`` names (:data:`EXPERTS`)."""
    if cfg.expert == "terrain":
        return TerrainExpert(cfg.robot_name)
    from citygen.runner.policies import PlannerPolicy

    return PlannerPolicy()


def expert_env(cfg: TrainConfig) -> Any:
    """One training sub-environment in this process (the run's split, scenes and shaping),
    with a rank of its own so that its scenes are drawn apart from the vector env's."""
    from citygen.runner.learn.vecenv import sub_env_of

    return sub_env_of(cfg, rank=cfg.envs)


def dagger(model: Any, venv: Any, cfg: TrainConfig, out: Path, log: Any = print) -> Demonstrations:
    """Run DAgger on ``model``'s policy (see the module docstring); the data set it gathered."""
    import torch

    policy = model.policy
    expert = make_expert(cfg)
    env = expert_env(cfg)
    rng = np.random.default_rng([cfg.seed, 4231])
    data = Demonstrations(tuple(cfg.obs_keys))
    path = out / "imitation.csv"
    with open(path, "w", newline="") as f:
        csv.DictWriter(f, IMITATION_FIELDS).writeheader()
    seed: int | None = int(rng.integers(2**31))
    try:
        for it in range(cfg.dagger_iterations):
            t0, wins, first = time.perf_counter(), 0, len(data)
            for _ in range(cfg.dagger_episodes):
                obs, _ = env.reset(seed=seed)
                seed = None  # the first reset seeds the scene schedule; the rest continue it
                expert.reset(env.unwrapped)
                while True:
                    obs = clip_goal({k: np.asarray(obs[k]) for k in data.keys}, cfg.goal_range)
                    label = expert.act(obs)
                    data.add(obs, label)
                    if it == 0 and rng.random() < cfg.dagger_beta:
                        action = label
                    else:
                        nobs = _normalized(venv, {k: v[None] for k, v in obs.items()})
                        with torch.no_grad():
                            action = _mean_action(policy, nobs).numpy()[0]
                    obs, _, terminated, truncated, info = env.step(action)
                    if terminated or truncated:
                        wins += bool(info.get("is_success", False))
                        break
            if cfg.normalize and venv.norm_obs:
                for k in venv.norm_obs_keys:  # this round's states
                    venv.obs_rms[k].update(np.stack(data.obs[k][first:]).astype(np.float64))
            loss = _fit(policy, venv, data, cfg, rng)
            row = {
                "iteration": it + 1,
                "episodes": cfg.dagger_episodes,
                "success_rate": round(100.0 * wins / cfg.dagger_episodes, 2),
                "samples": len(data),
                "loss": round(loss, 5),
                "seconds": round(time.perf_counter() - t0, 1),
            }
            with open(path, "a", newline="") as f:
                csv.DictWriter(f, IMITATION_FIELDS).writerow(row)
            log(
                f"DAgger round {it + 1}/{cfg.dagger_iterations}: {len(data) - first:,} new states "
                f"({len(data):,} in all), its episodes {row['success_rate']:.1f} % success, "
                f"loss {loss:.4f}, {row['seconds']:.0f} s"
            )
    finally:
        env.close()
    return data


def keep_cloning(model: Any, venv: Any, data: Demonstrations, coef: float, seed: int) -> None:
    """Add ``coef`` times the behaviour-cloning loss on ``data`` to every PPO gradient step:
    the optimiser's ``step`` first adds that loss's gradient (SB3's PPO calls it once per
    minibatch, after its own loss's backward pass and gradient clipping)."""
    import torch

    policy = model.policy
    optimizer = policy.optimizer
    step = optimizer.step
    rng = np.random.default_rng([seed, 5279])
    params = [p for g in optimizer.param_groups for p in g["params"]]

    def step_with_cloning(*args, **kwargs):
        live = [p for p in params if p.requires_grad]  # none of the actor's in a critic warm-up
        loss = coef * bc_loss(policy, venv, data, rng)
        if live and loss.requires_grad:
            grads = torch.autograd.grad(loss, live, allow_unused=True)
            for p, g in zip(live, grads, strict=True):
                if g is not None:
                    p.grad = g if p.grad is None else p.grad + g
        return step(*args, **kwargs)

    optimizer.step = step_with_cloning
