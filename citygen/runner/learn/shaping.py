"""Training-only reward shaping: progress along the geodesic to the goal.

The paper describes its navigation reward as one "providing positive rewards for progress
towards the target" (supplementary, Eq. of ``r_nav``) but its terms (a tanh tracking kernel
of the distance, +50 on success, -100 out of bounds, walkability and collision penalties)
give almost no signal more than ~2 m from the goal, so a policy finds the goal only by
chance: the paper pays for that with tens of millions of GPU steps. :class:`ProgressReward`
adds ``scale`` reward per metre the robot gets closer to the goal *along the walkable
geodesic* (the fast-marching field SPL measures with, so progress around an obstacle
counts and progress into a dead end does not), and takes it back for moving away.

It wraps a training sub-environment only: the environment's reward, its metrics and
``citygen bench`` are the paper's. ``citygen train --config`` sets ``progress = 0`` to train
on the paper's reward alone.
"""

from __future__ import annotations

import math

import gymnasium


class ProgressReward(gymnasium.Wrapper):
    """Adds ``scale`` x (geodesic distance before - after) to every step's reward."""

    def __init__(self, env: gymnasium.Env, scale: float):
        super().__init__(env)
        self.scale = float(scale)
        self._d = math.inf

    def _geodesic(self) -> float:
        env = self.env.unwrapped
        x, y, _, _ = env.handle.pose(env.data)
        return env.prepared.field(env._goal(), env.tolerance).at(x, y)

    def reset(self, **kwargs):
        out = self.env.reset(**kwargs)
        self._d = self._geodesic()
        return out

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        d = self._geodesic()
        if math.isfinite(d) and math.isfinite(self._d):
            reward = float(reward) + self.scale * (self._d - d)
        self._d = d
        return obs, reward, terminated, truncated, info
