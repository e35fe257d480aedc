"""Training-only reward shaping: progress along the geodesic to the goal.

The paper describes its navigation reward as one "providing positive rewards for progress
towards the target" (supplementary, Eq. of ``r_nav``) but its terms (a tanh tracking kernel
of the distance, +50 on success, -100 out of bounds, walkability and collision penalties)
give almost no signal more than ~2 m from the goal, so a policy finds the goal only by
chance: the paper pays for that with tens of millions of GPU steps. :class:`ProgressReward`
adds ``scale`` reward per metre the robot gets closer to the goal *along the walkable
geodesic* (the fast-marching field SPL measures with, so progress around an obstacle
counts and progress into a dead end does not), and takes it back for moving away.

The paper's tracking term also pays up to 2.4 a step for standing near the goal, and
reaching it (within the tolerance) ends the episode with +50: a policy learns to hover just
outside the tolerance, collecting more than the success is worth (seen: 94 % training success
at 100k steps falling to 21 % by 210k while the mean return rose from 68 to 95). So the
wrapper also treats the goal as the absorbing state it is meant to be: a success earns the
tracking reward of standing on the goal for the rest of the horizon, discounted by ``gamma``
(:attr:`ProgressReward.hold`), so reaching the goal sooner is always worth more.

Nothing in the paper's reward prefers driving forwards, and a policy trained on it alone
drives backwards as readily (the first NavClear baselines reversed on 96 % of their steps:
the robots are as fast in reverse). A delivery robot's sensors, a quadruped's gait and its
stair-climbing look ahead, so the wrapper also takes back ``reverse`` reward per metre the
robot moves backwards along its heading (:attr:`ProgressReward.reverse`); at the default
1.0 progress made in reverse earns nothing. A step that starts in collision (the last step's
``info["collision"]``: touching an object, or a person's disc overlapping the robot's) is
not charged: backing away is the way off a pole the robot has driven into, and a policy
charged for it learns to keep pushing forwards (26 of the NavDynamic quadruped baseline's 96
failed test episodes are in collision on at least 80 % of their steps; the 8 looked at are
all pinned against an object, a pole, a bench or a planter, at full speed: there the robot
cannot turn, where stopping, turning slowly or reversing frees it).

A wheeled robot that turns at full speed across a hillside rolls over (the paper's -100,
as leaving the scene): the shipped wheeled NavClear file loses 9 of its 256 test episodes so,
where the planner, which drives the same physics, loses none. One -100 in some thirty
episodes teaches slowly, so ``tilt`` charges ``tilt x ((a - TILT_FREE) / TILT_SPAN)^2`` a step
where the base leans ``a`` rad past :data:`TILT_FREE` (20 degrees: the scenes' hillsides
reach 24), ``tilt`` at about where it tips (:data:`TILT_FREE` + :data:`TILT_SPAN`, 28.6).

It wraps a training sub-environment only: the environment's reward, its metrics and
``citygen bench`` are the paper's. ``citygen train --config`` sets ``progress = 0`` to train
on the paper's reward alone.
"""

from __future__ import annotations

import math

import gymnasium

#: The paper's tracking reward on the goal itself: 2.0 x [(1 - tanh 0) + 0.2 (1 - tanh 0)].
TRACK_AT_GOAL = 2.4
#: Lean (rad) the ``tilt`` term leaves free, and the further lean at which it charges ``tilt``.
TILT_FREE, TILT_SPAN = 0.35, 0.15


class ProgressReward(gymnasium.Wrapper):
    """Adds ``scale`` x (geodesic distance before - after) to every step's reward, takes
    ``reverse`` x the metres moved backwards, and on a success adds the discounted tracking
    reward of holding the goal until the horizon."""

    def __init__(
        self, env: gymnasium.Env, scale: float, gamma: float = 0.99, reverse: float = 0.0, tilt: float = 0.0
    ):
        super().__init__(env)
        self.tilt = float(tilt)
        self.scale = float(scale)
        self.gamma = float(gamma)
        self.reverse = float(reverse)
        self._d = math.inf
        self._pose = (0.0, 0.0, 0.0)
        self._touching = False

    def hold(self) -> float:
        """The discounted tracking reward of standing on the goal from now to the horizon."""
        env = self.env.unwrapped
        left = max(env.horizon - env.steps, 0)
        return TRACK_AT_GOAL * self.gamma * (1.0 - self.gamma**left) / (1.0 - self.gamma)

    def _where(self) -> tuple[float, tuple[float, float, float]]:
        """The robot's geodesic distance to the goal and its pose ``(x, y, yaw)``."""
        env = self.env.unwrapped
        x, y, _, yaw = env.handle.pose(env.data)
        return env.prepared.field(env._goal(), env.tolerance).at(x, y), (x, y, yaw)

    def lean_cost(self) -> float:
        """``((a - TILT_FREE) / TILT_SPAN)^2`` for the base's lean ``a`` (rad) past
        :data:`TILT_FREE`, else 0."""
        env = self.env.unwrapped
        up = min(max(float(env.data.xmat[env.handle.base_id][8]), -1.0), 1.0)
        past = math.acos(up) - TILT_FREE
        return (past / TILT_SPAN) ** 2 if past > 0 else 0.0

    @staticmethod
    def backwards(before: tuple[float, float, float], after: tuple[float, float, float]) -> float:
        """Metres moved backwards along the heading ``before`` had (0 if forwards)."""
        (x0, y0, yaw0), (x1, y1, _) = before, after
        return max(0.0, -((x1 - x0) * math.cos(yaw0) + (y1 - y0) * math.sin(yaw0)))

    def reset(self, **kwargs):
        out = self.env.reset(**kwargs)
        self._d, self._pose = self._where()
        self._touching = bool(out[1].get("collision", False))
        return out

    def step(self, action):
        obs, reward, terminated, truncated, info = self.env.step(action)
        d, pose = self._where()
        if math.isfinite(d) and math.isfinite(self._d):
            reward = float(reward) + self.scale * (self._d - d)
        if self.reverse and not self._touching:
            reward = float(reward) - self.reverse * self.backwards(self._pose, pose)
        self._touching = bool(info.get("collision", False))
        if self.tilt:
            reward = float(reward) - self.tilt * self.lean_cost()
        if terminated and info.get("is_success"):
            reward = float(reward) + self.hold()
        self._d, self._pose = d, pose
        return obs, reward, terminated, truncated, info
