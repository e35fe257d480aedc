"""Learned locomotion on top of a scripted gait: a residual policy over a gait generator
(Iscen et al. 2018, "Policies Modulating Trajectory Generators"; Johannink et al. 2019,
"Residual Reinforcement Learning for Robot Control").

The humanoid's scripted walk (:class:`~citygen.runner.control.gaits_biped.BipedWalk`) keeps
its balance on flat ground at up to 0.4 m/s from its first step; a policy learnt from scratch
on a laptop's budget of steps does not. With ``gait = "walk"`` (``citygen train``'s config),
the policy's action is the environment's joint action plus one number more:

- the walk's forward speed, ``BASE_SPEED + SPEED_SPAN * a[-1]`` within ``[0, max_speed]``
  m/s (0 gives the speed the walk keeps its balance at; the policy modulates the generator),
  which the walk follows at up to ``SPEED_RATE`` m/s^2. ``max_speed`` (``gait_max_speed`` of
  the config, recorded in the exported file) is a speed curriculum by stages: a policy left
  free to ask for any speed at once raises it faster than it learns to balance it;
- a residual added to the walk's joint action: ``walk + scale * a[:-1]``, clipped to [-1, 1].

With ``gait = "trot"`` (a four-legged robot: the quadruped, or the wheeled-legged robot
on braked wheels) the policy rides the same way on the terrain-aware trot
(:class:`~citygen.runner.control.gaits.TrotController`, whose swing clears the highest
ground of its path, a riser's tread): a residual over all of the environment's actions,
``trot + scale * a[:-1]`` (the wheels' speeds around 0), and one number more, the swing
height, ``HEIGHT + HEIGHT_SPAN * a[-1]`` leg lengths over that ground (0.06 m, 0.02-0.11 m
for the quadruped), followed with a time constant of ``HEIGHT_TAU`` s. The trot follows the
episode's command (its forward part capped at ``max_speed``) and holds the episode's heading
with its own integrator, as ``--policy trot`` does; ``gait_phase`` is the sine and cosine of
the trot's cycle and its start-up ramp.

It reads the environment's observation and the gait's phase (``gait_phase``: the sine and
cosine of the walk's two-step cycle and the walk's start-up ramp), which the gait's clock gives and
the environment does not. The environment, its reward and every ``citygen bench`` metric stay
the paper's: the residual is part of the policy. An exported ``policy.npz`` records
``gait`` in its meta; :func:`~citygen.runner.learn.policy.load_policy` wraps it in
:class:`ResidualPolicy`, numpy only, as with every shipped policy.
"""

from __future__ import annotations

import math
from typing import Any

import gymnasium
import numpy as np

from citygen.errors import CitygenError
from citygen.runner.learn.config import PHASE_KEY, TrainConfig

#: Gait generators a residual policy can ride on (TrainConfig.gait): the biped's walk, the
#: four-legged robots' trot.
GAITS = ("walk", "trot")
#: The walk's speed (m/s) at a zero speed action: the fastest it walks on its own.
BASE_SPEED = 0.4
#: m/s per unit of the speed action (a small action noise still explores speeds).
SPEED_SPAN = 1.2
#: The fastest (m/s) the policy may ever ask the walk for (``gait_max_speed``'s bound).
MAX_SPEED = 1.0
#: How fast (m/s^2) the walk's speed follows the speed action: the stance feet's stride
#: scales with the speed, and a speed that jumps from step to step (action noise) jerks them
#: under the robot (the walk with per-step speed noise of std 0.18 m/s falls within 3-4 s).
SPEED_RATE = 0.5
#: The trot's swing height (fractions of the leg's thigh + calf) over the highest ground of a
#: swing's path at a zero height action (the scripted trot's), per unit of the action, and
#: the least and most it may be.
HEIGHT, HEIGHT_SPAN, HEIGHT_RANGE = 0.15, 0.1, (0.05, 0.25)
#: Time constant (s) with which the trot's swing height follows the height action: per-step
#: action noise would otherwise shake a swinging foot up and down.
HEIGHT_TAU = 0.1


def gait_spec(config: dict[str, Any]) -> dict[str, Any] | None:
    """What an exported policy's meta records of the gait it rides on (``meta["gait"]``),
    from a run's config (a :class:`~citygen.runner.learn.config.TrainConfig` as a dict, as
    its ``config.json`` holds it; a field it lacks, from a run before the field, is the
    config's default); None for a run without a gait."""
    if not config.get("gait"):
        return None
    fields = TrainConfig.model_fields
    scale, cap = (config.get(k, fields[k].default) for k in ("gait_scale", "gait_max_speed"))
    return {"name": config["gait"], "scale": scale, "max_speed": cap}


class GaitResidual:
    """The arithmetic both training and the exported policy share: the gait of one episode
    (the biped's walk or the trot), its phase, and the environment's action for a residual
    action (see the module docstring)."""

    def __init__(self, gait: str, scale: float, max_speed: float = MAX_SPEED):
        if gait not in GAITS:
            raise CitygenError(f"gait: expected one of {', '.join(GAITS)}, got {gait!r}")
        self.gait, self.scale, self.max_speed = gait, float(scale), float(max_speed)
        self.walk: Any = None  # the episode's BipedWalk or TrotController (reset)
        self.t = 0.0
        self.speed = BASE_SPEED
        self.height = 0.0  # the trot's swing height (m)

    def check(self, robot: Any) -> None:
        """A one-line error unless ``robot`` is one the gait drives (a biped for the walk, a
        built-in four-legged robot for the trot)."""
        if self.gait == "walk" and len(robot.legs) != 2:
            raise CitygenError(
                f"gait {self.gait!r}: a residual over the walk needs a biped, not {robot.name!r}"
            )
        if self.gait == "trot" and (len(robot.legs) != 4 or len(robot.leg_joints) != 12):
            raise CitygenError(
                f"gait {self.gait!r}: a residual over the trot needs a four-legged robot, not {robot.name!r}"
            )

    def _reach(self, env: Any) -> float:
        leg = env.robot.legs[0]
        return leg.thigh + leg.calf

    def reset(self, env: Any) -> None:
        """A new episode of ``env`` (the unwrapped locomotion environment)."""
        from citygen.runner.control.gaits import TrotController
        from citygen.runner.control.gaits_biped import BipedWalk

        self.check(env.robot)
        # the episode's own turn; under heading control the gait holds its heading itself
        turn = float(env.command[2]) if env.held_heading is None else 0.0
        self.t = 0.0  # the gait's clock, summed step by step as the scripted gaits' policy does
        if self.gait == "trot":
            command = (float(env.command[0]), float(env.command[1]), turn)
            self.height = HEIGHT * self._reach(env)
            self.walk = TrotController(command=command, step_height=self.height, max_speed=self.max_speed)
            return
        # the walk may go as fast as any policy may ask; this policy's cap is on the target
        self.walk = BipedWalk(command=(BASE_SPEED, 0.0, turn), max_speed=MAX_SPEED)
        self.speed = BASE_SPEED

    def phase(self, env: Any) -> np.ndarray:
        """``gait_phase`` at ``env``'s step: sin and cos of the gait's cycle (the walk's two
        steps, the trot's two strides), and its start-up ramp."""
        tau = env.steps * env.dt
        if self.gait == "trot":
            angle = 2 * math.pi * tau * self.walk.cycle_frequency(env.handle)
            ramp = min(1.0, tau / self.walk.ramp) if self.walk.ramp > 0 else 1.0
        else:
            angle = math.pi * tau / self.walk.period
            ramp = min(1.0, max(0.0, (tau - 0.2) / 1.0))
        return np.array([math.sin(angle), math.cos(angle), ramp], dtype=np.float32)

    def action(self, env: Any, a: np.ndarray) -> np.ndarray:
        """The environment's action for the residual action ``a`` (one number more)."""
        a = np.asarray(a, dtype=np.float64)
        n = env.n_joints
        knob = float(min(max(a[-1], -1.0), 1.0))
        walk = self.walk
        if self.gait == "trot":
            reach = self._reach(env)
            lo, hi = HEIGHT_RANGE
            target = min(max(HEIGHT + HEIGHT_SPAN * knob, lo), hi) * reach
            self.height += (target - self.height) * min(1.0, env.dt / HEIGHT_TAU)
            walk.step_height = self.height
        else:
            target = min(max(BASE_SPEED + SPEED_SPAN * knob, 0.0), self.max_speed)
            step = SPEED_RATE * env.dt
            self.speed += min(max(target - self.speed, -step), step)
            walk.command = (self.speed, 0.0, walk.command[2])
        base = walk.act(env.handle, env.data, self.t)
        self.t += env.dt
        out = np.zeros(env.action_space.shape)  # the gait's action: the legs', the wheels' at 0 (braked)
        out[:n] = base[:n]
        k = out.shape[0] if self.gait == "trot" else n  # the trot's residual reaches the wheels
        out[:k] += self.scale * a[:k]
        return out.astype(np.float32).clip(-1.0, 1.0)  # as the scripted gaits' actions


class ResidualTraining(gymnasium.Wrapper):
    """A training sub-environment whose actions are residuals over the gait (see the module
    docstring): one action more, and ``gait_phase`` in the observation."""

    def __init__(self, env: gymnasium.Env, *, gait: str, scale: float, max_speed: float = MAX_SPEED):
        super().__init__(env)
        self.residual = GaitResidual(gait, scale, max_speed)
        self.residual.check(env.unwrapped.robot)  # before the run folder is written
        n = env.action_space.shape[0] + 1
        self.action_space = gymnasium.spaces.Box(-1.0, 1.0, (n,), np.float32)
        spaces = dict(env.observation_space.spaces)
        spaces[PHASE_KEY] = gymnasium.spaces.Box(-1.0, 1.0, (3,), np.float32)
        self.observation_space = gymnasium.spaces.Dict(spaces)

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, info = self.env.reset(seed=seed, options=options)
        u = self.env.unwrapped
        self.residual.reset(u)
        return {**obs, PHASE_KEY: self.residual.phase(u)}, info

    def step(self, action):
        u = self.env.unwrapped
        obs, reward, terminated, truncated, info = self.env.step(self.residual.action(u, action))
        return {**obs, PHASE_KEY: self.residual.phase(u)}, reward, terminated, truncated, info


class ResidualPolicy:
    """An exported residual policy as a runner policy (``reset(env)``, ``act(obs)``): the
    network reads the environment's observation and the gait's phase, and its action rides
    on the gait. ``shapes`` and ``meta["action_shape"]`` are the environment's, for
    :func:`~citygen.runner.learn.policy.check_fits`."""

    def __init__(self, inner: Any):
        self.inner = inner
        spec = inner.meta["gait"]
        self.residual = GaitResidual(spec["name"], spec["scale"], spec.get("max_speed", MAX_SPEED))
        shape = list(inner.meta["action_shape"])
        self.meta = {**inner.meta, "action_shape": [shape[0] - 1]}
        self.shapes = {k: s for k, s in inner.shapes.items() if k != PHASE_KEY}
        self.env = None

    def reset(self, env: Any) -> None:
        self.env = env.unwrapped
        self.residual.reset(self.env)

    def act(self, obs: dict[str, Any]) -> np.ndarray:
        env = self.env
        a = self.inner.act({**obs, PHASE_KEY: self.residual.phase(env)})
        return self.residual.action(env, a)
