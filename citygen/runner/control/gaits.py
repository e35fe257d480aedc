"""Model-based locomotion baselines for the legged robots (``quadruped``, ``wheeled_legged``):
a PD stand controller and an open-loop trot with feedback.

Both compute foot positions, turn them into joint angles by each leg's inverse
kinematics (:meth:`citygen.runner.robots.Leg.ik`) and return them as a locomotion action
in ``[-1, 1]^12``, the convention of :meth:`citygen.runner.robots.RobotHandle.joint_action`
(target = default pose + action scale * action); the joints' PD actuators do the rest.

- :class:`StandController` holds the feet where the default pose puts them, keeps the trunk
  level (feet expressed in the tilted base frame) and the base at the robot's stand height
  above the feet (an integral correction of the legs' length makes up for PD sag).
- :class:`TrotController` trots: diagonal leg pairs (FR+RL, FL+RR) alternate stance and swing
  every half period; stance feet move back under the body at the commanded velocity
  ``(vx, vy, wz)`` (m/s, m/s, rad/s, robot frame), swing feet arc forward ``step_height``
  high to a Raibert foothold. Feedback: forward/lateral speed and yaw-rate errors raise the
  stride (proportional), a heading integrator holds the commanded turn, and the body is
  levelled as by the stand controller.

Call ``act(handle, data, t)`` at the control rate (50 Hz is fine; ``t`` in s, the
simulation time) and pass the action to ``handle.joint_action``.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from citygen.errors import CitygenError
from citygen.runner.robots import RobotHandle, yaw_of

#: Order of the legs in a built-in legged robot's action: front right, front left, rear right, rear left.
LEG_ORDER = ("FR", "FL", "RR", "RL")
# Phase offset (fraction of the period) of each leg in a trot: diagonal pairs together.
_TROT_PHASE = (0.0, 0.5, 0.5, 0.0)


def _tilt(data: Any, handle: RobotHandle) -> np.ndarray:
    """Rotation (3x3) of the base relative to its yaw frame: its roll and pitch."""
    R = data.xmat[handle.base_id].reshape(3, 3)
    yaw = yaw_of(data.qpos[handle.qadr + 3 : handle.qadr + 7])
    c, s = math.cos(yaw), math.sin(yaw)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return Rz.T @ R


class _FootController:
    """Shared machinery: nominal feet, levelling, height integral, IK to an action."""

    def __init__(self, height_gain: float = 2.0, level_gain: float = 1.0) -> None:
        self.height_gain = height_gain  # 1/s: leg-length integral per metre of height error
        self.level_gain = level_gain  # leg extension per metre a hip sits below level
        self._dz = 0.0
        self._t: float | None = None

    def _check(self, handle: RobotHandle) -> None:
        robot = handle.robot
        if len(robot.legs) != 4 or robot.n_joints != 12:
            raise CitygenError(f"the gaits need a built-in four-legged robot, not {robot.name!r}")

    def nominal(self, handle: RobotHandle) -> np.ndarray:
        """Foot centres (4 x 3, m) in the base frame in the default pose."""
        pose = handle.default
        return np.array(
            [
                np.array([leg.hip_x, leg.hip_y, 0.0]) + leg.fk(pose[3 * i : 3 * i + 3])
                for i, leg in enumerate(handle.robot.legs)
            ]
        )

    def _dt(self, t: float) -> float:
        dt = 0.0 if self._t is None else min(max(t - self._t, 0.0), 0.1)
        self._t = t
        return dt

    def _height(self, handle: RobotHandle, data: Any, dt: float) -> None:
        """Integrate the base's height error over the stance feet (ground = lowest foot)."""
        feet = handle.foot_geom_ids
        ground = float(np.min(data.geom_xpos[feet][:, 2])) - handle.robot.legs[0].foot_radius
        err = handle.robot.stand_height - (data.qpos[handle.qadr + 2] - ground)
        self._dz = float(np.clip(self._dz + self.height_gain * err * dt, -0.05, 0.05))

    def _action(self, handle: RobotHandle, data: Any, level_feet: np.ndarray) -> np.ndarray:
        """The action putting the feet at ``level_feet`` (4 x 3, m, base origin, yaw frame)."""
        tilt = _tilt(data, handle)
        q = np.empty(12)
        for i, leg in enumerate(handle.robot.legs):
            # a hip below the base origin's level (tilt) gets a longer leg, and the reverse
            hip_z = float(tilt[2] @ (leg.hip_x, leg.hip_y, 0.0))
            p = level_feet[i] + (0.0, 0.0, self.level_gain * hip_z - self._dz)
            q[3 * i : 3 * i + 3] = leg.ik(p - (leg.hip_x, leg.hip_y, 0.0))
        return np.clip((q - handle.default) / handle.scale, -1.0, 1.0)


class StandController(_FootController):
    """Stand still with a level trunk at the robot's stand height (see the module)."""

    def act(self, handle: RobotHandle, data: Any, t: float) -> np.ndarray:
        """The action (12 numbers in [-1, 1]) for time ``t`` (s)."""
        self._check(handle)
        self._height(handle, data, self._dt(t))
        return self._action(handle, data, self.nominal(handle))


class TrotController(_FootController):
    """Trot at ``command = (vx, vy, wz)`` (m/s, m/s, rad/s in the robot's frame).

    ``frequency`` (Hz, gait cycles per second; default by leg length: 2.5 Hz for the
    quadruped), ``step_height`` (m, default 18 % of the leg's length), ``speed_gain`` and
    ``yaw_gain`` (dimensionless proportional feedback), ``heading_gain`` (1/s),
    ``speed_integral`` (1/s: integral feedback of the speed error, capped at 1 m/s).
    """

    def __init__(
        self,
        command: tuple[float, float, float] = (0.5, 0.0, 0.0),
        frequency: float | None = None,
        step_height: float | None = None,
        speed_gain: float = 0.5,
        yaw_gain: float = 0.5,
        heading_gain: float = 1.0,
        speed_integral: float = 1.0,
    ) -> None:
        super().__init__()
        self.command = tuple(float(c) for c in command)
        self.frequency, self.step_height = frequency, step_height
        self.speed_gain, self.yaw_gain, self.heading_gain = speed_gain, yaw_gain, heading_gain
        self._t0: float | None = None
        self._heading: float | None = None
        self.speed_integral = speed_integral
        self._integral = np.zeros(2)

    def act(self, handle: RobotHandle, data: Any, t: float) -> np.ndarray:
        """The action (12 numbers in [-1, 1]) for time ``t`` (s)."""
        self._check(handle)
        leg0 = handle.robot.legs[0]
        reach = leg0.thigh + leg0.calf
        freq = self.frequency or 2.5 * math.sqrt(0.426 / reach)
        lift = self.step_height if self.step_height is not None else 0.18 * reach
        dt = self._dt(t)
        if self._t0 is None:
            self._t0 = t
        self._height(handle, data, dt)
        vx, vy, wz = self.command
        vel = handle.velocity(data)
        yaw = yaw_of(data.qpos[handle.qadr + 3 : handle.qadr + 7])
        self._heading = yaw if self._heading is None else self._heading + wz * dt
        heading_err = (self._heading - yaw + math.pi) % (2 * math.pi) - math.pi
        err = np.array([vx - vel[0], vy - vel[1]])
        self._integral = np.clip(self._integral + self.speed_integral * err * dt, -1.0, 1.0)
        vx_c, vy_c = np.array([vx, vy]) + self.speed_gain * err + self._integral
        wz_c = wz + self.yaw_gain * (wz - vel[3]) + self.heading_gain * heading_err
        period = 1.0 / freq
        stance = period / 2
        nominal = self.nominal(handle)
        raibert = math.sqrt(handle.robot.stand_height / 9.81)
        feet = nominal.copy()
        for i in range(4):
            fx, fy = nominal[i, 0], nominal[i, 1]
            stride = stance * np.array([vx_c - wz_c * fy, vy_c + wz_c * fx])
            land = stride / 2 + raibert * (vel[:2] - (vx, vy)) * 0.5
            phase = ((t - self._t0) * freq + _TROT_PHASE[i]) % 1.0
            if phase < 0.5:  # stance: from the foothold back under the body
                s = phase / 0.5
                feet[i, :2] += land - s * stride
            else:  # swing: arc forward to the next foothold
                s = (phase - 0.5) / 0.5
                smooth = 0.5 - 0.5 * math.cos(math.pi * s)
                feet[i, :2] += (land - stride) + smooth * stride
                feet[i, 2] += lift * math.sin(math.pi * s)
        return self._action(handle, data, feet)
