"""Model-based locomotion baselines for the legged robots (``quadruped``, ``wheeled_legged``):
a PD stand controller and a trot with feedback.

Both compute foot positions, turn them into joint angles by each leg's inverse
kinematics (:meth:`citygen.runner.robots.Leg.ik`) and return them as a locomotion action
in ``[-1, 1]^12``, the convention of :meth:`citygen.runner.robots.RobotHandle.joint_action`
(target = default pose + action scale * action); the joints' PD actuators do the rest.

Each foot's height is the ground's under it (:attr:`RobotHandle.terrain`, the scene's 5 cm
ground raster, when the handle has one; else the lowest foot's), and the base is held
:attr:`Robot.stand_height` above the mean of the feet carrying it, as far as every leg
reaches: on a stair the trunk stays level with some feet a step higher than others. A hip
below the base origin's level (the trunk rolled or pitched) gets a longer leg, and the
reverse (levelling); the feet's ``x, y`` stay in the base frame, so the hips' PD also
resists a tilt. An integral correction of the legs' length makes up for the PD's sag.

- :class:`StandController` stands a little wider than the default pose. Its footholds are
  chosen once, when it starts (the robot may still be dropping onto the ground): a foot
  whose shin would come down on a step's edge (on a stair the knees, behind the feet, reach
  over the riser behind) moves forward or back to where it clears, on level ground.
- :class:`TrotController` trots: diagonal leg pairs (FR+RL, FL+RR) alternate stance and swing
  every half period. A stance foot moves back under the body at the commanded velocity
  ``(vx, vy, wz)`` (m/s, m/s, rad/s, robot frame) plus a proportional feedback of the
  speed error; a swing foot leaves and lands at the ground's speed under the body (a cubic
  Hermite curve), ``step_height`` high, on a Raibert foothold (half a stride ahead of the
  default pose, further by ``raibert`` s per m/s the body runs ahead). A heading
  integrator holds the commanded turn; the yaw rate itself is not fed back (it swings at
  the gait's frequency, and feeding it back tipped the robots over). The legs' soft PD
  lags the stance sweep, so the robots walk slower than commanded: about 0.55 m/s (the
  quadruped) and 0.75 m/s (the wheeled-legged robot, on its braked wheels) at a 1 m/s
  command on flat ground. A faster stride (an integral of the speed error did it) made
  them fall within seconds.

Call ``act(handle, data, t)`` at the control rate (50 Hz is fine; ``t`` in s, the
simulation time) and pass the action to ``handle.joint_action``.
"""

from __future__ import annotations

import math
from dataclasses import replace
from typing import Any

import numpy as np

from citygen.errors import CitygenError
from citygen.runner.robots import RobotHandle, yaw_of

#: Order of the legs in a built-in legged robot's action: front right, front left, rear right, rear left.
LEG_ORDER = ("FR", "FL", "RR", "RL")
# Phase offset (fraction of the period) of each leg in a trot: diagonal pairs together.
_TROT_PHASE = (0.0, 0.5, 0.5, 0.0)
# Leg lengths (hip to foot centre, fractions of thigh + calf) the base height keeps within.
_SHORTEST, _LONGEST = 0.4, 0.85
# How far back (fraction of the leg's reach) the stand looks for a foothold that clears its knee.
_KNEE_SEARCH = 0.45
# Points along the shin (fractions of the way from the foot to the knee) the stand keeps clear.
_SHIN = np.array([0.25, 0.5, 0.75, 1.0])
# Half the length (m) of ground a stand's foothold must find level (on a tread, not an edge).
_TREAD = 0.03
# Points (fractions of the way from lift-off to landing) where a swing looks up the ground of its path.
_SWING_PATH = np.linspace(0.0, 1.0, 9)
# How far ahead (m, along a swing) of a swinging foot's centre it looks for a rise, and how
# far over that rise's top (m) it then keeps: the foot (2 cm radius) and the 5 cm raster's ramp.
_PROBE = np.array([0.02, 0.04, 0.06])
_CLEAR = 0.02


def _tilt(data: Any, handle: RobotHandle) -> np.ndarray:
    """Rotation (3x3) of the base relative to its yaw frame: its roll and pitch."""
    R = data.xmat[handle.base_id].reshape(3, 3)
    yaw = yaw_of(data.qpos[handle.qadr + 3 : handle.qadr + 7])
    c, s = math.cos(yaw), math.sin(yaw)
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return Rz.T @ R


class _FootController:
    """Shared machinery: nominal feet, ground under them, posture feedback, IK to an action.

    ``height_gain`` (1/s: leg-length integral per metre of height error), ``level_gain``
    (m of leg per m a hip sits below the base origin's level: 1 levels the trunk as far
    as the legs reach)."""

    def __init__(self, height_gain: float = 2.0, level_gain: float = 1.0) -> None:
        self.height_gain, self.level_gain = height_gain, level_gain
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

    def _ground(self, handle: RobotHandle, data: Any, xy: np.ndarray) -> np.ndarray:
        """Ground heights (m) at the world points ``xy`` (4 x 2): the handle's terrain, or
        everywhere the ground under the lowest foot."""
        if handle.terrain is not None:
            return np.array([handle.terrain.ground_at(float(x), float(y)) for x, y in xy])
        low = float(np.min(data.geom_xpos[handle.foot_geom_ids][:, 2])) - handle.robot.legs[0].foot_radius
        return np.full(len(xy), low)

    def _base_height(self, handle: RobotHandle, ground: np.ndarray) -> float:
        """World height (m) of the base origin over feet on ``ground``: the stand height over
        their mean, within what the shortest and longest leg allow."""
        leg = handle.robot.legs[0]
        reach, r = leg.thigh + leg.calf, leg.foot_radius
        z = float(np.mean(ground)) + handle.robot.stand_height
        low = float(np.max(ground)) + r + _SHORTEST * reach
        high = float(np.min(ground)) + r + _LONGEST * reach
        return min(max(z, low), high) if low <= high else (low + high) / 2

    def _action(self, handle: RobotHandle, data: Any, feet: np.ndarray, ground: np.ndarray,
                stance: np.ndarray, dt: float) -> np.ndarray:  # fmt: skip
        """The action putting the feet at ``feet`` (4 x 3, m: x, y from the base origin in
        the base frame, z above the ground under the foot, ``ground``, 4 world heights);
        ``stance`` (4 bools) the feet that carry the body (they set its height); ``dt`` (s)
        since the last call."""
        tilt = _tilt(data, handle)
        base_z = float(data.qpos[handle.qadr + 2])
        target = self._base_height(handle, ground[stance] if stance.any() else ground)
        self._dz = float(np.clip(self._dz + self.height_gain * (target - base_z) * dt, -0.05, 0.05))
        q = np.empty(12)
        for i, leg in enumerate(handle.robot.legs):
            hip = np.array([leg.hip_x, leg.hip_y, 0.0])
            # a hip below the base origin's level (tilt) gets a longer leg, and the reverse
            lower = float(tilt[2] @ hip)
            height = ground[i] + leg.foot_radius - target - self._dz + self.level_gain * lower
            q[3 * i : 3 * i + 3] = leg.ik(feet[i] + np.array([0.0, 0.0, height]) - hip)
        return np.clip((q - handle.default) / handle.scale, -1.0, 1.0)

    def _world_xy(self, data: Any, handle: RobotHandle, feet: np.ndarray) -> np.ndarray:
        """World ``(x, y)`` (n x 2) of points given (n x 2 or n x 3, m) from the base origin
        along the robot's heading and to its left."""
        yaw = yaw_of(data.qpos[handle.qadr + 3 : handle.qadr + 7])
        c, s = math.cos(yaw), math.sin(yaw)
        x, y = data.qpos[handle.qadr], data.qpos[handle.qadr + 1]
        return np.stack([x + c * feet[:, 0] - s * feet[:, 1], y + s * feet[:, 0] + c * feet[:, 1]], axis=1)


class StandController(_FootController):
    """Stand still with a level trunk at the robot's stand height over the ground under its
    feet (see the module); ``widen`` (m) moves each foot out sideways from the default pose,
    ``knee_margin`` (m) is the clearance its footholds keep under the knees
    (:meth:`footholds`, chosen at the first call)."""

    def __init__(self, widen: float = 0.03, knee_margin: float = 0.08, **gains: float) -> None:
        super().__init__(**gains)
        self.widen, self.knee_margin = widen, knee_margin
        self._feet: np.ndarray | None = None

    def footholds(self, handle: RobotHandle, data: Any) -> np.ndarray:
        """Feet (4 x 3, m, yaw frame from the base origin, z 0): the default pose's, ``widen``
        further out, each moved forward or back (up to :data:`_KNEE_SEARCH` of the leg's
        reach) as little as puts it on a tread (not an edge) with its shin ``knee_margin``
        above the ground under it at the knee (less towards the foot), the base at the
        height the default footholds give it (a foot moved up a step only raises it), and
        no ground higher than the foot between where it is and there (it would hit a riser)."""
        feet = self.nominal(handle)
        feet[:, 1] += np.sign(feet[:, 1]) * self.widen
        feet[:, 2] = 0.0
        z = self._base_height(handle, self._ground(handle, data, self._world_xy(data, handle, feet)))
        edge = np.array([[-_TREAD, 0.0, 0.0], [0.0, 0.0, 0.0], [_TREAD, 0.0, 0.0]])
        now = data.geom_xpos[handle.foot_geom_ids]
        for i, leg in enumerate(handle.robot.legs):
            hip = np.array([leg.hip_x, leg.hip_y, 0.0])
            knee_leg = replace(leg, calf=0.0)
            steps = np.arange(0.0, _KNEE_SEARCH * (leg.thigh + leg.calf), 0.02)
            for shift in np.stack([steps, -steps], axis=1).ravel()[1:]:
                foot = feet[i] + (shift, 0.0, 0.0)
                g = self._ground(handle, data, self._world_xy(data, handle, foot + edge))
                at = foot + np.array([0.0, 0.0, g[1] + leg.foot_radius - z])
                knee = hip + knee_leg.fk(leg.ik(at - hip))
                shin = at + _SHIN[:, None] * (knee - at)
                under = self._ground(handle, data, self._world_xy(data, handle, shin))
                to = self._world_xy(data, handle, foot[None])[0]
                path = now[i, :2] + np.linspace(0.0, 1.0, 8)[:, None] * (to - now[i, :2])
                bottom = now[i, 2] - leg.foot_radius + 0.01
                if (
                    np.ptp(g) < 0.01
                    and np.all(z + shin[:, 2] - under >= self.knee_margin * _SHIN)
                    and np.all(self._ground(handle, data, path) <= bottom)
                ):
                    feet[i] = foot
                    break
        return feet

    def act(self, handle: RobotHandle, data: Any, t: float) -> np.ndarray:
        """The action (12 numbers in [-1, 1]) for time ``t`` (s)."""
        self._check(handle)
        if self._feet is None:
            self._feet = self.footholds(handle, data)
        ground = self._ground(handle, data, data.geom_xpos[handle.foot_geom_ids][:, :2])
        return self._action(handle, data, self._feet, ground, np.ones(4, dtype=bool), self._dt(t))


class TrotController(_FootController):
    """Trot at ``command = (vx, vy, wz)`` (m/s, m/s, rad/s in the robot's frame; see the module).

    ``frequency`` (Hz, gait cycles per second; default by leg length, as a pendulum's:
    2.8 Hz for the quadruped, 2.2 Hz for the wheeled-legged robot), ``step_height`` (m,
    default 15 % of the leg's length), ``duty`` (the share of a cycle a foot is down: above
    0.5 all four are, twice a cycle), ``max_speed`` (m/s: the forward command is capped
    there), ``ramp`` (s over which the command grows from 0), ``speed_gain``
    (dimensionless: the stride's feedback of the speed error), ``heading_gain`` (1/s),
    ``raibert`` (s: foothold shift per m/s of speed error). Frequency and step height were
    chosen in the middle of what walks 20 s on flat ground: both robots keep walking with
    either 10 % off and the step 20 % lower or higher.
    """

    def __init__(
        self,
        command: tuple[float, float, float] = (0.5, 0.0, 0.0),
        frequency: float | None = None,
        step_height: float | None = None,
        duty: float = 0.5,
        max_speed: float = 1.0,
        ramp: float = 1.0,
        speed_gain: float = 0.5,
        heading_gain: float = 1.0,
        raibert: float = 0.09,
        **gains: float,
    ) -> None:
        super().__init__(**gains)
        self.command = tuple(float(c) for c in command)
        self.frequency, self.step_height, self.duty = frequency, step_height, duty
        self.max_speed, self.ramp = max_speed, ramp
        self.speed_gain, self.heading_gain, self.raibert = speed_gain, heading_gain, raibert
        self._t0: float | None = None
        self._heading: float | None = None
        self._feet: np.ndarray | None = None  # where each foot is (x, y, base frame)
        self._lift_off = np.zeros((4, 2))  # where each swinging foot left the ground
        self._swinging = np.zeros(4, dtype=bool)
        self._lift_ground = np.zeros(4)  # world height (m) of the ground each swing left

    def cycle_frequency(self, handle: RobotHandle) -> float:
        """Gait cycles per second (Hz): ``frequency``, or by the leg's length as a pendulum's."""
        leg0 = handle.robot.legs[0]
        return self.frequency or 2.8 * math.sqrt(0.426 / (leg0.thigh + leg0.calf))

    def act(self, handle: RobotHandle, data: Any, t: float) -> np.ndarray:
        """The action (12 numbers in [-1, 1]) for time ``t`` (s)."""
        self._check(handle)
        leg0 = handle.robot.legs[0]
        reach = leg0.thigh + leg0.calf
        freq = self.cycle_frequency(handle)
        lift = self.step_height if self.step_height is not None else 0.15 * reach
        dt = self._dt(t)
        nominal = self.nominal(handle)
        if self._t0 is None:
            self._t0 = t
            self._feet = nominal[:, :2].copy()
        ramp = min(1.0, (t - self._t0) / self.ramp) if self.ramp > 0 else 1.0
        vx, vy, wz = (ramp * c for c in self.command)
        vx = min(vx, self.max_speed)
        vel = handle.velocity(data)
        yaw = yaw_of(data.qpos[handle.qadr + 3 : handle.qadr + 7])
        self._heading = yaw if self._heading is None else self._heading + wz * dt
        heading_err = (self._heading - yaw + math.pi) % (2 * math.pi) - math.pi
        vx_c, vy_c = vx + self.speed_gain * (vx - vel[0]), vy + self.speed_gain * (vy - vel[1])
        wz_c = wz + self.heading_gain * heading_err
        stance_time = self.duty / freq
        feet = np.zeros((4, 3))
        stance = np.zeros(4, dtype=bool)
        swing: dict[int, tuple[float, np.ndarray, np.ndarray]] = {}  # leg: (s, path, its direction)
        for i in range(4):
            x, y = self._feet[i]
            phase = ((t - self._t0) * freq + _TROT_PHASE[i]) % 1.0
            fx, fy = nominal[i, :2]
            sweep = np.array([vx_c - wz_c * fy, vy_c + wz_c * fx])  # the body's speed over the foot
            if phase < self.duty:  # stance: the foot moves back under the body
                stance[i] = True
                self._swinging[i] = False
                self._feet[i] -= dt * np.array([vx_c - wz_c * y, vy_c + wz_c * x])
            else:  # swing: forward to the next foothold, leaving and landing at the ground's speed
                if not self._swinging[i]:
                    self._swinging[i], self._lift_off[i] = True, self._feet[i]
                    start_xy = self._world_xy(data, handle, self._feet[i][None])
                    self._lift_ground[i] = self._ground(handle, data, start_xy)[0]
                s = (phase - self.duty) / (1.0 - self.duty)
                land = nominal[i, :2] + stance_time * sweep / 2 + self.raibert * (vel[:2] - (vx, vy))
                swing_time = (1.0 - self.duty) / freq
                # cubic Hermite from lift-off to landing, both at the velocity -sweep
                start = self._lift_off[i]
                along = s * s * (3 - 2 * s) * (land - start) - s * (1 - s) * (1 - 2 * s) * swing_time * sweep
                self._feet[i] = start + along
                u = _SWING_PATH[:, None]  # the same curve at points along the whole swing
                path = (
                    start
                    + u * u * (3 - 2 * u) * (land - start)
                    - u * (1 - u) * (1 - 2 * u) * (swing_time * sweep)
                )
                # where the landing spot is by touchdown: the ground passes under at -sweep
                ahead = land + (1.0 - s) * swing_time * sweep
                swing[i] = (s, np.vstack([path, ahead[None]]), land - start)
            feet[i, :2] = self._feet[i]
        # one look-up for the feet and every swing's path and probe (the ground of each point
        # is its own: the points' world positions and heights one by one)
        points, probes = [feet[:, :2]], {}
        for i, (_, path, ahead) in swing.items():
            norm = float(np.hypot(*ahead))
            xy = feet[i, :2]
            probes[i] = xy + _PROBE[:, None] * (ahead / norm) if norm > 1e-6 else xy[None]
            points += [path, probes[i]]
        heights = self._ground(handle, data, self._world_xy(data, handle, np.vstack(points)))
        ground, k = heights[:4], 4
        for i, (s, path, _) in swing.items():
            g, k = heights[k : k + len(path)], k + len(path)
            edge, k = float(np.max(heights[k : k + len(probes[i])])), k + len(probes[i])
            feet[i, 2] = self._swing_height(i, s, g, edge, ground[i], lift)
        return self._action(handle, data, feet, ground, stance, dt)

    def _swing_height(self, i: int, s: float, g: np.ndarray, edge: float, under: float, lift: float) -> float:
        """Height (m, over the ground ``under`` the foot) of swing foot ``i`` at ``s`` (0 to 1)
        of its swing, ``g`` the ground along its path (lift-off to landing, then the landing
        spot where the ground under it will be at touchdown) and ``edge`` the highest just
        ahead of it (:data:`_PROBE`): up from the ground it left to ``lift`` over the highest
        ground of its path (a riser's tread) by mid-swing, down to the ground it lands on, and
        never lower than ``_CLEAR`` over ``edge`` (a riser's edge it is about to cross). On
        level ground, ``lift`` times ``sin^2(pi s)`` as before, to the bit."""
        start, land = float(self._lift_ground[i]), float(g[-1])
        high = max(float(np.max(g)), start)
        bump = 0.5 - 0.5 * math.cos(2 * math.pi * s)
        if s < 0.5:  # differences first: 0 on level ground, whatever the ground's height
            z = (start - under) + (lift + (high - start)) * bump
        else:
            z = (land - under) + (lift + (high - land)) * bump
        if edge > under + 0.01:  # a rise just ahead: over its top before moving on
            z = max(z, edge - under + _CLEAR)
        return z
