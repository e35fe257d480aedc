"""Model-based locomotion baselines for the ``humanoid``: a PD stand and a scripted walk.

Both place the ankles relative to the hip joints in the pelvis frame, turn those into leg
angles by each leg's inverse kinematics (:func:`leg_ik`: feet kept parallel to the pelvis)
and return a locomotion action (target = default pose + action scale * action, the
convention of :meth:`citygen.runner.robots.RobotHandle.joint_action`); waist and arms hold
their default pose. The joints' stiff PD servos do the rest.

- :class:`BipedStand` holds the default pose with the feet under the hips.
- :class:`BipedWalk` walks at a fixed step period with a double-support phase. The pelvis
  moves forward at the commanded speed (capped at :data:`WALK_SPEED`) relative to the stance
  feet and sways sideways as a linear inverted pendulum would, with the amplitude that puts
  the zero-moment point over the stance foot in mid-step (``A = w / (1 + (pi/T)^2 / omega^2)``
  for feet ``w`` off the midline, step period ``T``, ``omega^2 = g / z_com``); swing feet arc
  forward ``step_height`` high. Sway, lift and speed ramp up over the first second. Feedback:
  the heading error turns the legs' hip yaw (the next steps turn back), the trunk's pitch and
  roll rate move the stance ankle (ankle strategy). No ZMP preview, no footstep planning: it
  walks on flat ground and gentle slopes, not over stairs or rough ground.

Call ``act(handle, data, t)`` at the control rate (50 Hz; ``t`` in s) and pass the action
to ``handle.joint_action``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from citygen.errors import CitygenError
from citygen.runner.robots import RobotHandle, yaw_of

#: Fastest forward speed (m/s) of the scripted walk.
WALK_SPEED = 0.4
_G = 9.81


def leg_ik(p: np.ndarray, thigh: float, shank: float) -> tuple[float, float, float, float, float, float]:
    """Leg angles ``(hip_pitch, hip_roll, hip_yaw, knee, ankle_pitch, ankle_roll)`` (rad,
    hip yaw 0, knee bent forward: knee > 0) putting the ankle at ``p`` (m) from the hip
    joint, the foot parallel to the pelvis; unreachable targets are pulled in."""
    px, py, pz = (float(v) for v in p)
    roll = math.atan2(py, -pz)
    z = -math.hypot(py, pz)
    reach = 0.999 * (thigh + shank)
    d = math.hypot(px, z)
    if d > reach:
        px, z, d = px * reach / d, z * reach / d, reach
    c = (d * d - thigh * thigh - shank * shank) / (2 * thigh * shank)
    knee = math.acos(min(1.0, max(-1.0, c)))
    a, b = thigh + shank * math.cos(knee), shank * math.sin(knee)
    pitch = math.atan2(-px, -z) - math.atan2(b, a)
    return pitch, roll, 0.0, knee, -(pitch + knee), -roll


class _BipedController:
    """Shared machinery: nominal ankles, IK of both legs to an action."""

    def __init__(self) -> None:
        self._t0: float | None = None

    def _check(self, handle: RobotHandle) -> None:
        robot = handle.robot
        if len(robot.legs) != 2 or robot.n_joints < 12:
            raise CitygenError(f"the biped gaits need a built-in two-legged robot, not {robot.name!r}")

    def _ankle_height(self, handle: RobotHandle) -> float:
        leg = handle.robot.legs[0]
        return -(handle.robot.stand_height - leg.foot_radius)

    def _action(self, handle: RobotHandle, ankles: np.ndarray, yaws: tuple[float, float] = (0.0, 0.0),
                ankle_fb: np.ndarray | None = None) -> np.ndarray:  # fmt: skip
        """The action putting the ankles at ``ankles`` (2 x 3, m, relative to each hip)."""
        q = handle.default.copy()
        for i, leg in enumerate(handle.robot.legs):
            angles = list(leg_ik(ankles[i], leg.thigh, leg.calf))
            angles[2] = yaws[i]
            if ankle_fb is not None:
                angles[4] += ankle_fb[i, 0]
                angles[5] += ankle_fb[i, 1]
            q[6 * i : 6 * i + 6] = angles
        return np.clip((q - handle.default) / handle.scale, -1.0, 1.0)


class BipedStand(_BipedController):
    """Stand still: ankles under the hips at the default height (see the module)."""

    def act(self, handle: RobotHandle, data: Any, t: float) -> np.ndarray:
        """The action (one number in [-1, 1] per joint) for time ``t`` (s)."""
        self._check(handle)
        z = self._ankle_height(handle)
        ankles = np.array([[0.0, 0.0, z], [0.0, 0.0, z]])
        return self._action(handle, ankles)


class BipedWalk(_BipedController):
    """Walk at ``command = (vx, vy, wz)`` (m/s, m/s, rad/s; only ``vx`` >= 0 and ``wz``
    are followed, ``vx`` capped at ``max_speed``, by default :data:`WALK_SPEED`, the
    fastest it walks on its own). ``period`` (s per step), ``double_support`` (fraction of a
    step on both feet), ``step_height`` (m), ``crouch`` (m the pelvis walks lower than it
    stands)."""

    def __init__(
        self,
        command: tuple[float, float, float] = (WALK_SPEED, 0.0, 0.0),
        period: float = 0.45,
        double_support: float = 0.2,
        step_height: float = 0.05,
        crouch: float = 0.02,
        heading_gain: float = 1.0,
        ankle_gain: float = 0.05,
        max_speed: float = WALK_SPEED,
    ) -> None:
        super().__init__()
        self.command = tuple(float(c) for c in command)
        self.max_speed = float(max_speed)
        self.period, self.double_support = period, double_support
        self.step_height, self.crouch = step_height, crouch
        self.heading_gain, self.ankle_gain = heading_gain, ankle_gain
        self._heading: float | None = None
        self._last: float | None = None

    def act(self, handle: RobotHandle, data: Any, t: float) -> np.ndarray:
        """The action (one number in [-1, 1] per joint) for time ``t`` (s)."""
        self._check(handle)
        if self._t0 is None:
            self._t0 = t
        dt = 0.0 if self._last is None else min(max(t - self._last, 0.0), 0.1)
        self._last = t
        tau = t - self._t0
        ramp = min(1.0, max(0.0, (tau - 0.2) / 1.0))
        speed = min(max(self.command[0], 0.0), self.max_speed) * min(1.0, max(0.0, (tau - 0.6) / 1.0))
        yaw = yaw_of(data.qpos[handle.qadr + 3 : handle.qadr + 7])
        self._heading = yaw if self._heading is None else self._heading + self.command[2] * dt
        heading_err = (self._heading - yaw + math.pi) % (2 * math.pi) - math.pi
        legs = handle.robot.legs
        z = self._ankle_height(handle) + self.crouch
        T, d = self.period, self.double_support
        com_z = -z + 0.06
        w = abs(legs[0].hip_y)
        sway = ramp * w / (1.0 + (math.pi / T) ** 2 * com_z / _G)
        phi = tau / T
        y_pelvis = sway * math.sin(math.pi * phi)  # + over the left foot in even steps
        half = speed * T * (1.0 + d) / 2  # stance foot travel either side of the hip
        ankles = np.zeros((2, 3))
        yaws = [0.0, 0.0]
        fb = np.zeros((2, 2))
        rate = data.qvel[handle.dadr + 3 : handle.dadr + 6]
        turn = float(np.clip(self.heading_gain * heading_err, -0.3, 0.3))
        for i in range(2):  # 0 left (stance in even steps), 1 right
            # phase of this foot's cycle (2 steps): stance over [-d/2, 1 + d/2], swing after
            u = ((phi - i + d / 2) % 2.0) / (1.0 + d)  # < 1: stance progress
            x, lift = 0.0, 0.0
            if u < 1.0:
                x = half * (1.0 - 2.0 * u)
                fb[i] = (self.ankle_gain * rate[1], self.ankle_gain * rate[0])
                yaws[i] = turn * (1.0 - 2.0 * u) * 0.5
            else:
                s = (u - 1.0) * (1.0 + d) / (1.0 - d)
                x = -half + 2.0 * half * (0.5 - 0.5 * math.cos(math.pi * s))
                lift = ramp * self.step_height * math.sin(math.pi * s)
                yaws[i] = turn * (-1.0 + 2.0 * (0.5 - 0.5 * math.cos(math.pi * s))) * 0.5
            ankles[i] = (x, -y_pelvis, z + lift)
        return self._action(handle, ankles, (yaws[0], yaws[1]), fb)
