"""Locomotion (:class:`LocoEnv`; LocoFlat, LocoSlope, LocoStair, LocoRough): joint-level
actions in [-1, 1] (targets around the robot's standing pose, then for the wheeled-legged
robot the speeds of its four wheels, :meth:`~citygen.runner.robots.RobotHandle.joint_action`)
every :data:`LOCO_DT` s; the observation is the base's linear and angular velocity, the
command, joint positions and velocities (the wheels' speeds after the legs'), the last action
and the height map, as in the paper, plus ``projected_gravity`` (the unit gravity vector in
the base's frame: the tilt, which the paper's inputs leave to be integrated from the angular
velocity; Isaac Lab's and legged_gym's locomotion policies read it). Reward as in the paper: ``-100`` and
the end of the episode when the robot's body (any part but its legs: trunk, head, torso,
arms) presses on the ground with more than 1 N;
``exp(-|v_xy - c_xy|^2 / 0.25^2) + 0.5 exp(-(w_z - c_wz)^2 / 0.25^2)``
for tracking the command; ``-2.0 v_z^2``; ``-0.01 |a_t - a_(t-1)|^2``. Horizon
:data:`LOCO_HORIZON` steps.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from citygen.errors import SpecError
from citygen.runner import metrics as M
from citygen.runner.envs import legged
from citygen.runner.envs.base import _CitygenEnv
from citygen.runner.envs.window import Window, windows_of
from citygen.runner.scenes import process_cache
from citygen.runner.tasks import DEFAULT_ROBOT, check_robot
from citygen.spec import Scene

#: Control step (s) of locomotion.
LOCO_DT = 0.02
#: Locomotion episodes end after this many steps (the paper's horizon).
LOCO_HORIZON = 1000
#: Contact force (N) on a non-foot part that counts as a fall in locomotion.
FALL_FORCE = 1.0
#: Locomotion: a seed turns the scene's command ``(vx, vy, wz)`` (in the robot's frame) to a
#: direction uniform in this range (rad, about the robot's heading), keeping its speed and yaw
#: rate. The paper's X-displacement is "in the velocity direction under fixed magnitude and
#: random orientation": the orientation drawn is the robot's heading in the world (any angle),
#: while the command stays ahead of it, the direction the scripted trot and biped walk can
#: follow (both tip over within seconds once the command has a sideways part). Widen it for a
#: learned omnidirectional policy.
COMMAND_TURN = (0.0, 0.0)
#: Locomotion: the start is up to this far (m, each axis) from its region's centre.
START_JITTER = 0.25
#: Locomotion: the start leaves room for the walk the command asks for (its speed times the
#: horizon) plus this margin (m) inside the scene, so that walking off the edge of the grid,
#: which ends an episode as a fall, is not what a test measures (Isaac Lab's terrains have a
#: border for the same reason: the paper's robots walk their 20 s, 19.6 m at 1 m/s). Draws
#: are redrawn up to :data:`START_TRIES` times.
START_MARGIN = 1.0
START_TRIES = 64
#: Locomotion: a straight command (no yaw rate) holds the robot's heading, as Isaac Lab's
#: velocity command does (``heading_command``; URBAN-SIM's locomotion is built on it): each
#: step the command's yaw rate becomes this stiffness (1/s) times the heading error (the start
#: heading minus the robot's), within :data:`YAW_RATE_LIMIT`. Without it a robot that drifts
#: a few degrees a second walks off the direction X-displacement is measured in and is never
#: asked to turn back. ``make_env(..., heading_control=False)`` keeps the command fixed.
HEADING_STIFFNESS = 0.5
#: Locomotion: the largest yaw rate (rad/s) heading control asks for (Isaac Lab's default range).
YAW_RATE_LIMIT = 1.0


class LocoEnv(_CitygenEnv):
    """Velocity-command locomotion on an Urban-Loc grid (see the module docstring)."""

    default_robot = DEFAULT_ROBOT["loco"]
    dt = LOCO_DT
    terrain = "hybrid"  # feet stick in a heightfield's slope (citygen.runner.scenes.TERRAIN_OPTIONS)
    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, task: str = "loco-flat", scene: Scene | str | Path | None = None, **kwargs: Any):
        if not task.startswith("loco"):
            raise SpecError(f"task: expected a locomotion task kind, got {task!r}")
        self.randomize = bool(kwargs.pop("randomize", True))
        self.heading_control = bool(kwargs.pop("heading_control", True))
        # a large grid compiled a window at a time (citygen.runner.envs.window); False: whole
        self.windowed = bool(kwargs.pop("windowed", True))
        self._window: Window | None = None  # this episode's, None in the whole grid's model
        self._whole: Any = None  # this episode's scene, prepared whole
        self.held_heading: float | None = None  # set by each reset (heading control)
        super().__init__(task, scene, **kwargs)
        check_robot(task, self.robot)
        n = len(self.robot.leg_joints)
        self.n_joints = n
        self.n_actions = n + len(self.robot.loco_wheels)
        self._fall_model = None
        self.action_space = spaces.Box(-1.0, 1.0, (self.n_actions,), np.float32)
        obs = legged.leg_spaces(n, self.n_actions, self._height_space())
        obs.update(self._image_spaces())
        self._set_observation_space(obs)
        self._keys = tuple(self.observation_space.spaces)
        self._force = np.zeros(6)  # mj_contactForce's output
        self.horizon = self.max_steps or LOCO_HORIZON

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        """A new episode. With ``randomize`` (the default) the seed draws the test region
        (a tile of the Urban-Loc grid; ``options={"region": (row, col)}`` picks one), the
        start pose in it (:data:`START_JITTER` m around the tile's centre, any heading) and
        the command's direction (the scene's command turned by an angle in
        :data:`COMMAND_TURN`; ``options={"command": (vx, vy, wz)}`` sets one); without, the
        scene's own start and command."""
        import mujoco

        super().reset(seed=seed)
        options = options or {}
        index = self._pick_index(options)
        whole = process_cache().get(self.source, index, self.robot, self.terrain)
        self.scene, self._index = whole.scene, index
        task = self.scene.task
        if task is None or not task.kind.startswith("loco"):
            raise SpecError(
                f"{self.source.name}: $.task: expected a locomotion task, got "
                f"{'none' if task is None else task.kind}"
            )
        x, y, yaw, command = self._draw_start(task, options)
        # the grid's regions within the episode's reach, where the grid is large (to the bit
        # the whole grid's physics: citygen.runner.envs.window)
        windows = windows_of(whole, self.terrain) if self.windowed else None
        reach = math.hypot(command[0], command[1]) * self.horizon * self.dt
        self._window = windows.window(x, y, reach) if windows is not None else None
        self._whole = whole
        self._use(whole if self._window is None else windows.prepared_for(self._window))
        self.command = np.asarray(command, dtype=np.float64)
        for mocap in self.prepared.agent_bodies.values():
            self.data.mocap_pos[mocap] = (0.0, 0.0, -100.0)
        self._spawn(x, y, yaw)
        mujoco.mj_forward(self.model, self.data)
        self._fall_geoms_for_model()
        self.steps = 0
        self.base_velocity = self.handle._velocity(self.data)
        self.last_action = np.zeros(self.n_actions)
        heading = yaw + math.atan2(self.command[1], self.command[0])
        # the heading a straight command holds (None: the command stays as drawn)
        self.held_heading = yaw if self.heading_control and self.command[2] == 0.0 else None
        self.recorder = M.LocoEpisode(start_xy=(float(x), float(y)), target_heading=heading, dt=self.dt)
        obs = self._observation()
        info = {"scene": self.source.name, "index": self._index, "region": self.region}
        return obs, {**info, "command": tuple(float(c) for c in self.command)}

    def _draw_start(self, task: Any, options: dict) -> tuple[float, float, float, tuple]:
        """Start ``(x, y, yaw)`` and command of the episode (see :meth:`reset`)."""
        grid = self.scene.terrain
        rng = self.np_random
        command = tuple(task.command)
        x, y = (float(v) for v in task.start.position)
        yaw = float(task.start.yaw)
        size = grid.tile_size if grid is not None else 0.0
        self.region = None
        if grid is not None:
            self.region = (int((y - grid.origin[1]) // size), int((x - grid.origin[0]) // size))
        fixed = None
        if "region" in options and grid is not None:
            fixed = tuple(int(v) for v in options["region"])
            if not (0 <= fixed[0] < grid.rows and 0 <= fixed[1] < grid.cols):
                raise SpecError(
                    f"options.region: expected (row, col) inside the {grid.rows} x {grid.cols} grid, "
                    f"got {fixed}"
                )
        if "command" in options:
            command = tuple(float(c) for c in options["command"])
        if self.randomize and grid is not None:
            speed = math.hypot(command[0], command[1])
            for _ in range(START_TRIES):
                row, col = int(rng.integers(grid.rows)), int(rng.integers(grid.cols))
                jitter = rng.uniform(-START_JITTER, START_JITTER, 2)
                yaw = float(rng.uniform(-math.pi, math.pi))
                turn = float(rng.uniform(*COMMAND_TURN))
                if fixed is not None:
                    (row, col), jitter = fixed, (0.0, 0.0)
                x = grid.origin[0] + (col + 0.5) * size + float(jitter[0])
                y = grid.origin[1] + (row + 0.5) * size + float(jitter[1])
                drawn = command
                if "command" not in options:
                    drawn = (speed * math.cos(turn), speed * math.sin(turn), float(command[2]))
                if self._room_for(x, y, yaw, drawn):
                    break
            command = drawn
            self.region = (row, col)
        elif fixed is not None:
            row, col = fixed
            x, y = grid.origin[0] + (col + 0.5) * size, grid.origin[1] + (row + 0.5) * size
            self.region = fixed
        return x, y, yaw, command

    def _room_for(self, x: float, y: float, yaw: float, command: tuple) -> bool:
        """Whether the walk ``command`` asks for from ``(x, y, yaw)`` over the horizon stays
        :data:`START_MARGIN` inside the scene: the straight path for a straight command, the
        disc an arc can reach (its diameter, at most the path's length) for a turning one."""
        speed = math.hypot(command[0], command[1])
        reach = speed * self.horizon * self.dt
        (x0, y0), (x1, y1) = self.scene.bounds.min, self.scene.bounds.max
        lo_x, lo_y, hi_x, hi_y = x0 + START_MARGIN, y0 + START_MARGIN, x1 - START_MARGIN, y1 - START_MARGIN
        if abs(command[2]) > 1e-6:
            r = min(reach, 2.0 * speed / abs(command[2]))
            return lo_x <= x - r and x + r <= hi_x and lo_y <= y - r and y + r <= hi_y
        heading = yaw + math.atan2(command[1], command[0])
        ex, ey = x + reach * math.cos(heading), y + reach * math.sin(heading)
        return lo_x <= min(x, ex) and max(x, ex) <= hi_x and lo_y <= min(y, ey) and max(y, ey) <= hi_y

    def _leave_window(self) -> None:
        """Carry on in the whole grid's model: the robot came near its window's edge. The
        physics' state (:data:`mujoco.mjtState.mjSTATE_INTEGRATION`: time, positions,
        velocities, controls, the solver's warm start) moves over before the next step,
        which computes everything else from it, as it would have in the window."""
        import mujoco

        what = mujoco.mjtState.mjSTATE_INTEGRATION
        state = np.empty(mujoco.mj_stateSize(self.model, what))
        mujoco.mj_getState(self.model, self.data, state, what)
        self._window = None
        self._use(self._whole)
        mujoco.mj_setState(self.model, self.data, state, what)
        self._fall_geoms_for_model()

    def _fall_geoms_for_model(self) -> None:
        """The robot geoms whose pressing on the ground is a fall (the body, not the legs:
        :func:`~citygen.runner.envs.legged.fall_geoms`), computed once per compiled model,
        with the ids of those geoms and of the ground's as sets (a step looks its few
        contacts up one by one)."""
        if self._fall_model is self.model:
            return
        self._fall_geoms = legged.fall_geoms(self.model, self.handle, self._robot_geoms)
        self._fall_ids = frozenset(np.flatnonzero(self._fall_geoms).tolist())
        self._ground_ids = frozenset(np.flatnonzero(self.prepared.ground_geoms).tolist())
        self._joint_vel_dofs = legged.joint_vel_dofs(self.handle)
        self._fall_model = self.model

    def _ground_force(self) -> float:
        """Largest normal force (N) of a contact between the ground and a robot part that
        must not touch it (:func:`~citygen.runner.envs.legged.body_ground_force`)."""
        return legged.body_ground_force(self.model, self.data, self._fall_ids, self._ground_ids, self._force)

    def step(self, action):
        a = np.asarray(action, dtype=np.float64).reshape(self.n_actions)
        a = np.minimum(np.maximum(a, -1.0), 1.0)  # np.clip's values, without its wrapper
        if self._window is not None:
            q = self.handle.qadr
            if not self._window.holds(*self.data.qpos[q : q + 2].tolist()):
                self._leave_window()
        d, h = self.data, self.handle
        h.joint_action(d, a)
        self._physics(None)
        self.steps += 1
        pose = h.pose(d)
        x, y = pose[0], pose[1]
        # plain floats: the same arithmetic as numpy's float64 scalars; kept for the training
        # wrapper's shaping (learn.loco), which reads the same state after the step
        vel = self.base_velocity = h._velocity(d)
        fallen = self._ground_force() > FALL_FORCE
        # walking off the terrain grid upright ends the episode without a fall: Balance is
        # the share of episodes without one, and the ground there is not the task's
        outside = self._out_of_bounds(x, y)
        c0, c1, c2 = self.command.tolist()
        dv = (vel[0] - c0) ** 2 + (vel[1] - c1) ** 2
        dz = (vel[3] - c2) ** 2
        reward = math.exp(-dv / 0.25**2) + 0.5 * math.exp(-dz / 0.25**2)
        reward += 2.0 * -(vel[2] ** 2)
        reward += 0.01 * -float(np.sum((a - self.last_action) ** 2))
        if fallen:
            reward -= 100.0
        self.last_action = a
        self.recorder.record_step((x, y), np.array(d.actuator_force), fallen=fallen)
        if self.held_heading is not None:  # the next step's yaw rate turns back to it
            err = math.remainder(self.held_heading - pose[3], math.tau)
            self.command[2] = min(max(HEADING_STIFFNESS * err, -YAW_RATE_LIMIT), YAW_RATE_LIMIT)
        truncated = not fallen and (outside or self.steps >= self.horizon)
        obs = self._observation(pose, vel)
        info = {"scene": self.source.name, "index": self._index, "fallen": fallen, "out_of_bounds": outside}
        if fallen or truncated:
            self.recorder.finish()
            info["metrics"] = M.loco_metrics(self.recorder)
            info["is_success"] = not fallen  # the episode kept its balance (the paper's Balance)
        return obs, float(reward), bool(fallen), bool(truncated), info

    def _observation(self, pose: tuple | None = None, vel: tuple | None = None) -> dict[str, np.ndarray]:
        """The observation's keys (only those of the observation space are computed), from
        the base's ``pose`` and ``vel`` (``RobotHandle.pose``, ``._velocity``) when the step
        has them already."""
        pose = self.handle.pose(self.data) if pose is None else pose
        keys = self._keys
        obs = legged.leg_observation(
            self, keys, self.command, self.last_action, self._joint_vel_dofs, pose, vel
        )
        obs.update(self._images(pose))
        return {k: obs[k] for k in keys}
