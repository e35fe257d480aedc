"""Traverse (:class:`TraverseEnv`, the quadruped by default): navigation along the task's
route, waypoint by waypoint; a fall, leaving the bounds or :data:`STUCK_SECONDS` without
progress puts the robot back at the last waypoint reached (an *attempt*) instead of ending
the episode; it ends at the route's last point or the task's time limit.

On learned legs (``locomotion="learned"``, :mod:`citygen.runner.envs.legs`) a fall is
LocoEnv's (the body on the ground) and is what the paper makes of every failed trial: the
robot is put back standing at the last waypoint reached (within :data:`RETRY_JITTER` of it,
as a person sets it down), the legs' command and last action cleared, and one attempt (the
paper's "Attempts to Success", resets of the task) is counted; it is not Labor Cost (the
time a person drives). ``info["metrics"]`` then adds ``falls`` (the attempts that followed a
fall) and ``terrain_model_time`` (s on a terrain locomotion model,
:meth:`~citygen.runner.envs.legs.LearnedLegs.use`). Who is driving is told by
:meth:`TraverseEnv.set_operator` (the control modes of :mod:`citygen.runner.policies`).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from citygen.errors import SpecError
from citygen.runner import metrics as M
from citygen.runner.envs.legs import GENERAL
from citygen.runner.envs.nav import NavEnv
from citygen.runner.tasks import DEFAULT_ROBOT
from citygen.spec import Scene

#: Traverse: seconds without getting closer to the next waypoint before a reset.
STUCK_SECONDS = 15.0
#: On learned legs, how far (m, each axis) and how much turned (rad) from the last waypoint a
#: failed trial puts the robot back, at most: a person sets a robot down by hand, never twice
#: the same. MuJoCo is deterministic, so a model put back exactly where it fell falls there
#: again on every retry: on urban-tra-standard a general model fell 840 times in a row at one
#: spot of rough ground (x = 73.8 m), 41 steps after each reset.
RETRY_JITTER = (0.1, 0.1)


class TraverseEnv(NavEnv):
    """A route of waypoints to the end (see the module docstring).

    The robot defaults to the quadruped, the robot both Urban-Tra scenes are set for (the
    paper's traverse benchmark runs one): the wheeled robot cannot climb the track's stairs.

    Progress for a caller that reports it (a progress bar on ``run_episode``'s
    ``on_step(env, t)``): :attr:`progress` and, every step, ``info["waypoint"]``,
    ``info["waypoints"]`` and ``info["attempts"]``."""

    default_robot = DEFAULT_ROBOT["traverse"]

    def __init__(self, task: str = "traverse", scene: Scene | str | Path | None = None, **kwargs: Any):
        super().__init__(task, scene, **kwargs)
        self.human = False

    @property
    def progress(self) -> dict[str, float]:
        """Where the run is: ``steps`` and ``horizon`` (control steps), ``waypoint`` (the
        next one, 0-based) of ``waypoints``, ``attempts`` (resets so far) and ``done``, the
        fraction of the route's waypoints reached (0 before the first :meth:`reset`)."""
        if self.prepared is None or not hasattr(self, "route"):
            return {"steps": 0, "horizon": 0, "waypoint": 0, "waypoints": 0, "attempts": 0, "done": 0.0}
        n = len(self.route)
        reached = n if self._finished else self.waypoint
        return {
            "steps": self.steps,
            "horizon": self.horizon,
            "waypoint": self.waypoint,
            "waypoints": n,
            "attempts": self.attempts,
            "done": reached / n,
        }

    def set_operator(self, human: bool) -> None:
        """Say who drives the next steps: a person (True) or the AI (False); the Labor Cost and
        Human Intervention metrics count the steps a person drove."""
        self.human = bool(human)

    def _setup_task(self) -> None:
        task = self.scene.task
        if task is None or task.kind != "traverse":
            raise SpecError(
                f"{self.source.name}: $.task: expected a traverse task (with a route), "
                f"got {'none' if task is None else f'a {task.kind} task'}"
            )
        self.route = [tuple(p) for p in task.route]
        self.waypoint = 0
        self.goal = self.route[0]
        self.tolerance = task.goal_tolerance
        self.horizon = self._horizon_for(task)
        self._anchor = (tuple(task.start.position), task.start.yaw)
        self._best = math.inf
        self._since_progress = 0.0
        self.attempts = 0
        #: Resets after a fall (of :attr:`attempts`), and on learned legs the control steps
        #: each locomotion model walked (model name -> steps).
        self.falls = 0
        self.model_steps: dict[str, int] = {}
        self._finished = False

    def _goal(self) -> tuple[float, float]:
        return self.route[self.waypoint]

    def _new_record(self):
        return M.TraverseEpisode(start_xy=self._start, dt=self.dt, mass=self.robot.mass)

    def _legs_metrics(self) -> dict[str, float]:
        """On learned legs: ``falls`` (the resets that followed a fall) and
        ``terrain_model_time`` (s), the time a terrain locomotion model rather than the
        general one walked the robot (Human-AI-Mode-1's dispatch)."""
        terrain = sum(n for name, n in self.model_steps.items() if name != GENERAL)
        return {"falls": float(self.falls), "terrain_model_time": terrain * self.dt}

    def _after_step(self):
        x, y, z, yaw = self.handle.pose(self.data)
        d = self._distance()
        collision = self._collision(x, y)
        walkable = bool(self.prepared.walkable[self.prepared.occupancy.cell(x, y)])
        reset = False
        if d <= self.tolerance:
            # A reset puts the robot back here, facing the next waypoint.
            here = self.route[self.waypoint]
            ahead = self.route[min(self.waypoint + 1, len(self.route) - 1)]
            self._anchor = (
                here,
                math.atan2(ahead[1] - here[1], ahead[0] - here[0]) if ahead != here else yaw,
            )
            self.waypoint += 1
            self._best, self._since_progress = math.inf, 0.0
        elif d < self._best - 0.05:
            self._best, self._since_progress = d, 0.0
        else:
            self._since_progress += self.dt
        done = self.waypoint >= len(self.route)
        fell = self._fallen(z, x, y, yaw)
        if self.legs is not None:  # on learned legs: the steps each model walked (terrain dispatch)
            self.model_steps[self.legs.model] = self.model_steps.get(self.legs.model, 0) + 1
        if not done and (self._out_of_bounds(x, y) or fell or self._since_progress > STUCK_SECONDS):
            (ax, ay), ayaw = self._anchor
            if self.legs is not None:  # set down by hand (RETRY_JITTER); the same run, the same draws
                rng = np.random.default_rng([self.steps, self.attempts])
                dx, dy = rng.uniform(-1.0, 1.0, 2) * RETRY_JITTER[0]
                ax, ay, ayaw = ax + dx, ay + dy, ayaw + rng.uniform(-1.0, 1.0) * RETRY_JITTER[1]
            # feet on the ground under each, as at the start (forwarded); wheels: the drive pose
            self._spawn(ax, ay, ayaw, drive=self.legs is None)
            if self.legs is not None:  # standing, no command or last action, not fallen
                self.legs.reset()
            self.attempts += 1
            self.falls += fell
            # The step ends where the robot was put: its recorded position is the anchor, and
            # the reset step, not the next one, carries the jump that Speed leaves out.
            x, y = self.handle.pose(self.data)[:2]
            self._best, self._since_progress = math.inf, 0.0
            reset = True
        if done:
            self.waypoint = len(self.route) - 1
            self._finished = True
        reward = 2.0 * ((1.0 - math.tanh(d / 1.0)) + 0.2 * (1.0 - math.tanh(d / 0.2)))
        reward -= 0.5 * (not walkable) + 1.0 * collision + 100.0 * reset - 50.0 * done
        truncated = not done and self.steps >= self.horizon
        vel = self.handle.velocity(self.data)
        self.recorder.record_step(
            (x, y),
            torques=np.array(self.data.actuator_force),
            joint_velocities=np.array(self.data.actuator_velocity),
            body_speed=float(math.hypot(vel[0], vel[1])),
            intervene=self.human,
            reset=reset,
            collision=collision and not self._last_collision,  # Collision Times counts contacts, not steps
        )
        self._last_collision = collision
        self._record_traffic(x, y)
        obs = self._observation()
        info = self._info(
            distance=d, waypoint=self.waypoint, waypoints=len(self.route), attempts=self.attempts,
            collision=collision, success=done,
        )  # fmt: skip
        if done or truncated:
            self.recorder.finish()
            info["metrics"] = {
                **M.traverse_metrics(self.recorder),
                "success_rate": 100.0 * done,
                "route_completion": 100.0 * self.progress["done"],
            }
            if self.legs is not None:
                info["metrics"].update(self._legs_metrics())
            if self.traffic_record is not None:
                info["metrics"].update(self.traffic_record.metrics())
        return obs, float(reward), bool(done), bool(truncated), info
