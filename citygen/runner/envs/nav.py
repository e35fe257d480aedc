"""Navigation (:class:`NavEnv`; NavClear, NavStatic, NavDynamic), as in the paper's
appendix: the action is ``[v, w]`` in [-1, 1], scaled to the robot's maximum forward speed
and yaw rate, held for one control step of :data:`NAV_DT` s; the observation is a dict
with ``goal`` (the goal in the robot's frame, m), ``velocity`` (``[vx, vy, wz]`` in the
robot's frame) and ``height_map`` (ground heights relative to the robot's feet on a
1.6 m x 1.0 m grid around it, every 0.1 m, interpolated in the scene's 5 cm elevation
raster of :func:`citygen.height_at`), plus ``depth``
and ``rgb`` (MuJoCo renderer, ``image_size`` square, off unless asked) and ``rays``
(ranges of :data:`RAY_COUNT` horizontal rays, off unless asked), ``local_map``
(elevation of everything and walkability around the robot, :mod:`citygen.runner.localmap`)
``local_map_inside`` (which of its cells lie inside the scene's bounds) and
``local_map_crossable`` (which it is walkable ground this robot can cross: no stairs for
wheels, no slope steeper than it climbs) and ``local_map_motion`` (the velocity of the moving
agent on each cell, in the robot's frame);
the last step's ``info["is_success"]`` says whether the goal was reached. Reward per step:
``+50`` on reaching the goal and ``-100`` on leaving the scene's bounds (both end the
episode; a fall ends it like leaving the bounds), ``2.0 * [(1 - tanh(d / 1.0)) + 0.2 (1 -
tanh(d / 0.2))]`` for the distance ``d`` to the goal, ``-0.5`` on non-walkable ground and
``-1.0`` in collision (a contact with an object or an agent, or a person's disc
overlapping the robot's). An episode lasts the scene's ``task.time_limit`` (20 s by default:
:data:`NAV_HORIZON` steps, the paper's horizon) unless ``max_steps`` cuts it. NavDynamic's people
move by ORCA and its vehicles by IDM (:mod:`citygen.runner.agents`); in NavClear and
NavStatic the scene's agents are removed.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
from gymnasium import spaces

from citygen.errors import SpecError
from citygen.geometry.terrain import height_at
from citygen.runner import localmap
from citygen.runner import metrics as M
from citygen.runner.envs.base import _CitygenEnv
from citygen.runner.envs.legs import learned_legs
from citygen.runner.envs.reach import near
from citygen.runner.tasks import DEFAULT_ROBOT
from citygen.spec import Scene

#: Navigation episodes end after this many steps (the paper's horizon).
NAV_HORIZON = 200
#: Observation keys a navigation environment gives only when ``observations`` names them (no
#: default policy reads them; the wide map costs about 8 % of a NavStatic step, per
#: benchmarks/bench_runner.py): ``citygen bench`` and ``citygen run`` ask for them when a
#: learned policy reads them (:func:`citygen.runner.learn.policy.observations_for`).
ON_REQUEST = ("local_map_wide",)
#: Moving agents (people and vehicles) from which a scene's people move only near the robot
#: (a city's 230; a town's 25 and the Urban-Nav squares' few all move): see :attr:`NavEnv.agents_near`.
NEAR_FROM_AGENTS = 100
#: Distance (m) from the robot within which people move in such a scene.
PEOPLE_NEAR = 30.0


def _yaw_rotate(vx: np.ndarray, vy: np.ndarray, yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """World vectors into the frame turned by ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx + s * vy, -s * vx + c * vy


class NavEnv(_CitygenEnv):
    """Point-goal navigation: NavClear, NavStatic, NavDynamic (see the module docstring)."""

    default_robot = DEFAULT_ROBOT["nav"]

    def __init__(
        self,
        task: str = "nav-static",
        scene: Scene | str | Path | None = None,
        *,
        locomotion: str = "servo",
        **kwargs: Any,
    ):
        if not task.startswith(("nav", "traverse")):
            raise SpecError(f"task: expected a navigation task kind, got {task!r}")
        super().__init__(task, scene, **kwargs)
        #: A legged robot's learned legs (``locomotion="learned"``, :mod:`~citygen.runner.envs.legs`)
        #: or None (the robot's own drive: wheels, or the ideal servo on a legged robot's base).
        self.legs = learned_legs(self, locomotion)
        if self.legs is not None:  # feet, as in locomotion (citygen.runner.scenes.TERRAIN_OPTIONS)
            self.terrain = "hybrid"
        self.action_space = spaces.Box(-1.0, 1.0, (2,), np.float32)
        obs = {
            "goal": spaces.Box(-np.inf, np.inf, (2,), np.float32),
            "velocity": spaces.Box(-np.inf, np.inf, (3,), np.float32),
            "height_map": self._height_space(),
            "local_map": localmap.space(),
            "local_map_inside": localmap.inside_space(),
            "local_map_crossable": localmap.crossable_space(),
            "local_map_motion": localmap.motion_space(),
        }
        obs.update(self._image_spaces())
        self._set_observation_space(obs, on_request={"local_map_wide": localmap.wide_space()})
        self.horizon = self.max_steps or NAV_HORIZON
        self.crowd = None
        self.traffic = None
        self._agent_mocap: list[tuple] = []  # (group, its agents' mocap ids): _place_agents
        self.agents_near: float | None = None
        """Distance (m) from the robot beyond which people stand still (ORCA moves those
        within it; they avoid the standing ones as they avoid the robot), or None: the
        default, :data:`PEOPLE_NEAR` in a scene of more than :data:`NEAR_FROM_AGENTS` moving
        agents (a city), everyone moving elsewhere. Set before :meth:`reset`; ``math.inf``:
        everyone moves. Vehicles always drive."""
        self._people_near: float | None = None  # in force this episode (_place_agents)

    # The goal of the current step (a traverse moves it along the route).
    def _goal(self) -> tuple[float, float]:
        return self.goal

    def _setup_task(self) -> None:
        task = self.scene.task
        if task is None or not hasattr(task, "goal"):
            raise SpecError(
                f"{self.source.name}: $.task: expected a navigation task (with a goal), "
                f"got {'none' if task is None else f'a {task.kind} task'}"
            )
        self.goal = tuple(task.goal)
        self.tolerance = task.goal_tolerance
        self.horizon = self._horizon_for(task)

    def _horizon_for(self, task) -> int:
        """Control steps an episode of ``task`` lasts: ``max_steps``, else its time limit (20 s,
        the paper's 200 steps, unless the scene sets another)."""
        return self.max_steps or max(1, math.ceil(task.time_limit / self.dt - 1e-9))

    def _dynamic(self) -> bool:
        return self.task_kind in ("nav-dynamic", "traverse")

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self._load(self._pick_index(options))
        self._setup_task()
        task = self.scene.task
        x, y = task.start.position
        self._start = (float(x), float(y))
        self.handle.reset(self.data, (x, y, self._ground_z(x, y), task.start.yaw), drive=self.legs is None)
        self._place_agents()
        import mujoco

        mujoco.mj_forward(self.model, self.data)
        self.steps = 0
        if self.legs is not None:
            self.legs.reset()
        self.collisions = 0
        self._last_collision = False
        self.recorder = self._new_record()
        self.traffic_record = M.TrafficRecord() if self.scene.signals else None
        obs = self._observation()
        return obs, self._info(distance=self._distance())

    def _new_record(self):
        best = self.prepared.geodesic(self._start, self.goal, self.tolerance)
        if not math.isfinite(best) or best <= 0:  # no walkable route: the straight line
            best = max(math.dist(self._start, self.goal), 1e-6)
        return M.NavEpisode(start_xy=self._start, best_length=best)

    # --- agents --------------------------------------------------------------------------

    def _place_agents(self) -> None:
        self.crowd = self.traffic = None
        self._agent_mocap = []
        self._people_near = None
        d = self.data
        if self._dynamic() and self.prepared.agent_bodies:
            from citygen.runner.agents.crowd import crowd_of
            from citygen.runner.agents.traffic import Traffic, city_agents

            self.crowd = crowd_of(self.prepared, self.scene, rng=self.np_random, dt=self.dt)
            if len(self.crowd.ids) == 0:
                self.crowd = None
            if self.scene.signals:  # a city: signals for vehicles and people (agents.traffic)
                self.crowd, self.traffic = city_agents(self.prepared, self.scene, self.crowd, self.dt)
            else:
                self.traffic = Traffic(self.scene, dt=self.dt)
            if len(self.traffic.ids) == 0:
                self.traffic = None
            near = self.agents_near
            if near is None and len(self.prepared.agent_bodies) > NEAR_FROM_AGENTS:
                near = PEOPLE_NEAR
            if self.crowd is not None and near is not None and math.isfinite(near):
                self._people_near = float(near)
            bodies = self.prepared.agent_bodies
            self._agent_mocap = [
                (group, np.array([bodies[a] for a in group.ids], dtype=np.int64))
                for group in (self.crowd, self.traffic)
                if group is not None
            ]
            self._write_agents()
        else:
            # NavClear / NavStatic: no moving agents; their bodies are parked far below.
            for mocap in self.prepared.agent_bodies.values():
                d.mocap_pos[mocap] = (0.0, 0.0, -100.0)

    def _write_agents(self, people: np.ndarray | None = None) -> None:
        """Each agent's mocap body where the agent is, on the ground, facing its heading (one
        array write per group; the quaternions by :mod:`math`, as one agent at a time had them);
        of the crowd only the people ``people`` (indices; default everyone): the others stood."""
        d = self.data
        for group, mocap in self._agent_mocap:
            pos = group.pos
            yaw = group.headings() if hasattr(group, "headings") else group.yaw
            if people is not None and group is self.crowd:
                if not len(people):
                    continue
                pos, yaw, mocap = pos[people], yaw[people], mocap[people]
            z = height_at(self.scene, pos[:, 0], pos[:, 1])
            d.mocap_pos[mocap, :2] = pos
            d.mocap_pos[mocap, 2] = z
            d.mocap_quat[mocap] = [(math.cos(h), 0.0, 0.0, math.sin(h)) for h in (yaw / 2).tolist()]

    def _active_people(self, x: float, y: float) -> np.ndarray | None:
        """Which people move this step (bool per person, those within :attr:`agents_near` of
        the robot at ``(x, y)``), or None: everyone."""
        if self._people_near is None:
            return None
        pos = self.crowd.pos
        return np.hypot(pos[:, 0] - x, pos[:, 1] - y) <= self._people_near

    def others(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and radii of the moving agents near the robot (people
        and vehicles, a vehicle as a disc of half its length)."""
        xy, vel, rad = [np.zeros((0, 2))], [np.zeros((0, 2))], [np.zeros(0)]
        if self.crowd is not None:
            xy.append(self.crowd.pos)
            vel.append(self.crowd.vel)
            rad.append(self.crowd.radius)
        if self.traffic is not None:
            t = self.traffic
            xy.append(t.pos)
            vel.append(np.stack([t.v * np.cos(t.yaw), t.v * np.sin(t.yaw)], axis=1))
            rad.append(np.asarray(t.length, dtype=np.float64) / 2)
        return np.concatenate(xy), np.concatenate(vel), np.concatenate(rad)

    # --- stepping ------------------------------------------------------------------------

    def step(self, action):
        a = np.clip(np.asarray(action, dtype=np.float64).reshape(2), -1.0, 1.0)
        v, w = a[0] * self.robot.max_speed, a[1] * self.robot.max_yaw_rate
        if self.crowd is not None or self.traffic is not None:
            x, y, _, yaw = self.handle.pose(self.data)
            vel = self.handle.velocity(self.data)
            c, s = math.cos(yaw), math.sin(yaw)
            robot_vel = np.array([c * vel[0] - s * vel[1], s * vel[0] + c * vel[1]])
            active = None
            if self.crowd is not None:
                cars = self.traffic.footprints() if self.traffic is not None else None
                active = self._active_people(x, y)
                self.crowd.step(np.array([x, y]), robot_vel, self.robot.radius, cars, active)
            if self.traffic is not None:
                obstacles = [np.array([[x, y]])]
                radii = [np.array([self.robot.radius])]
                if self.crowd is not None:
                    obstacles.append(self.crowd.pos)
                    radii.append(self.crowd.radius)
                self.traffic.step(np.concatenate(obstacles), np.concatenate(radii))
            self._write_agents(None if active is None else np.flatnonzero(active))
        with near(self._reach, self.data):  # a city's static geoms near the robot only
            if self.legs is not None:
                self.legs.walk(v, w)
            else:
                self.handle.control(self.data, v, w, self._substeps)
        self.steps += 1
        return self._after_step()

    def _record_traffic(self, x: float, y: float) -> None:
        """Red-light crossings and roadway incursions of the robot, in a city (agents.signals)."""
        if self.traffic_record is not None:
            from citygen.runner.agents.signals import crossings_of

            c = crossings_of(self.prepared, self.scene)
            xy = np.array([[x, y]])
            t = self.steps * self.dt
            self.traffic_record.record_step(
                on_roadway=bool(c.on_roadway(xy)[0]), on_red_crosswalk=bool(c.no_walk(xy, t)[0])
            )

    def _distance(self) -> float:
        x, y, _, _ = self.handle.pose(self.data)
        gx, gy = self._goal()
        return math.hypot(gx - x, gy - y)

    def _collision(self, x: float, y: float) -> bool:
        if self._touching_obstacle():
            return True
        if self.crowd is not None:
            gap = np.hypot(self.crowd.pos[:, 0] - x, self.crowd.pos[:, 1] - y) - self.crowd.radius
            if np.any(gap < self.robot.radius):
                return True
        return False

    def _fallen(self, z: float, x: float, y: float, yaw: float) -> bool:
        """Tipped over (base tilted more than 60 degrees) or fallen through the ground; on
        learned legs, LocoEnv's fall or tipped over (:class:`~citygen.runner.envs.legs.LearnedLegs`)."""
        if self.legs is not None:
            return self.legs.fell
        up = self.data.xmat[self.handle.base_id][8]
        return bool(up < 0.5 or z < self._ground_under(x, y, yaw) - 0.5)

    def _after_step(self):
        x, y, z, yaw = self.handle.pose(self.data)
        d = self._distance()
        walkable = bool(
            self.prepared.walkable[self.prepared.occupancy.cell(x, y)]
        ) and not self._out_of_bounds(x, y)
        collision = self._collision(x, y)
        success = d <= self.tolerance
        lost = self._out_of_bounds(x, y) or self._fallen(z, x, y, yaw)
        reward = 2.0 * ((1.0 - math.tanh(d / 1.0)) + 0.2 * (1.0 - math.tanh(d / 0.2)))
        reward -= 0.5 * (not walkable)
        reward -= 1.0 * collision
        if success:
            reward += 50.0
        elif lost:
            reward -= 100.0
        terminated = success or lost
        truncated = not terminated and self.steps >= self.horizon
        self.recorder.record_step((x, y), walkable=walkable, collision=collision)
        self._record_traffic(x, y)
        obs = self._observation()
        info = self._info(distance=d, walkable=walkable, collision=collision, success=success, lost=lost)
        if terminated or truncated:
            left = 0.0 if success else self.prepared.geodesic((x, y), self.goal, self.tolerance)
            self.recorder.finish(success=success, distance_left=left if math.isfinite(left) else d)
            info["metrics"] = M.nav_metrics(self.recorder)
            if self.legs is not None:  # on learned legs: whether the episode ended in a fall
                info["metrics"]["fall_rate"] = 100.0 * self.legs.fell
            if self.traffic_record is not None:
                info["metrics"].update(self.traffic_record.metrics())
            info["is_success"] = success
        return obs, float(reward), bool(terminated), bool(truncated), info

    def _observation(self) -> dict[str, np.ndarray]:
        x, y, z, yaw = self.handle.pose(self.data)
        want = self.observation_space.spaces
        obs: dict[str, np.ndarray] = {}
        if "goal" in want:
            gx, gy = self._goal()
            gu, gv = _yaw_rotate(np.float64(gx - x), np.float64(gy - y), yaw)
            obs["goal"] = np.array([gu, gv], dtype=np.float32)
        if "velocity" in want:
            vel = self.handle.velocity(self.data)
            obs["velocity"] = np.array([vel[0], vel[1], vel[3]], dtype=np.float32)
        feet = self._ground_under(x, y, yaw)
        if "height_map" in want:
            obs["height_map"] = self._height_map(x, y, feet, yaw)
        crossable, motion = "local_map_crossable" in want, "local_map_motion" in want
        if crossable or motion or "local_map" in want:
            # Channels: the local map's two, then crossable's and motion's two when asked for.
            grid = localmap.observe(self, x, y, yaw, feet, crossable=crossable, motion=motion)
            obs["local_map"] = grid[:2]
            if crossable:
                obs["local_map_crossable"] = grid[2:3]
            if motion:
                obs["local_map_motion"] = grid[2 + crossable :]
        if "local_map_inside" in want:
            obs["local_map_inside"] = localmap.observe_inside(self, x, y, yaw)
        if "local_map_wide" in want:
            obs["local_map_wide"] = localmap.observe_wide(self, x, y, yaw)
        obs.update(self._images((x, y, z, yaw)))
        return {k: obs[k] for k in self.observation_space.spaces}

    def _info(self, **extra: Any) -> dict[str, Any]:
        x, y, _, yaw = self.handle.pose(self.data)
        return {"scene": self.source.name, "index": self._index, "pose": (x, y, yaw), **extra}
