"""Gymnasium environments for the URBAN-BENCH tasks (registered by :mod:`citygen.runner`).

Every environment runs one robot (:mod:`citygen.runner.robots`) in a scene compiled to
MuJoCo by :mod:`citygen.exporters.mjcf`. It is built from a scene (``scene=`` a
:class:`~citygen.spec.Scene` or a scene file) or from a split to sample from (``split=``,
default the task's Urban-Nav / Urban-Loc / Urban-Tra test split): then every
:meth:`reset` draws a scene index from the environment's generator (``options={"index": i}``
picks one; ``scene_pool=k`` draws from the split's first ``k`` scenes only), and compiled
scenes come from a per-process cache.

**Navigation** (:class:`NavEnv`; NavClear, NavStatic, NavDynamic), as in the paper's
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
overlapping the robot's). The horizon is :data:`NAV_HORIZON` steps. NavDynamic's people
move by ORCA and its vehicles by IDM (:mod:`citygen.runner.crowd`); in NavClear and
NavStatic the scene's agents are removed.

**Locomotion** (:class:`LocoEnv`; LocoFlat, LocoSlope, LocoStair, LocoRough): joint-level
actions in [-1, 1] (targets around the robot's standing pose) every :data:`LOCO_DT` s;
the observation is the base's linear and angular velocity, the command, joint positions
and velocities, the last action and the height map. Reward as in the paper: ``-100`` and
the end of the episode when the robot's body (any part but its legs: trunk, head, torso,
arms) presses on the ground with more than 1 N;
``exp(-|v_xy - c_xy|^2 / 0.25^2) + 0.5 exp(-(w_z - c_wz)^2 / 0.25^2)``
for tracking the command; ``-2.0 v_z^2``; ``-0.01 |a_t - a_(t-1)|^2``. Horizon
:data:`LOCO_HORIZON` steps.

**Traverse** (:class:`TraverseEnv`, the quadruped by default): navigation along the task's
route, waypoint by waypoint; a fall, leaving the bounds or :data:`STUCK_SECONDS` without
progress puts the robot back at the last waypoint reached (an *attempt*) instead of ending
the episode; it ends at the route's last point or the task's time limit. Who is driving is told by
:meth:`TraverseEnv.set_operator` (the control modes of :mod:`citygen.runner.policies`).

Each environment fills ``info["metrics"]`` on the last step of an episode with the paper's
metrics of its task (:mod:`citygen.runner.metrics`).

``observations=[...]`` restricts the observation dict (and its space) to those keys, and only
they are computed: the values are the full observation's, bit for bit. ``citygen train``
passes its policy's keys: without the height map and the inside and motion layers, 8
NavStatic sub-environments step about 1.2x as fast (``benchmarks/bench_runner.py``).
"""

from __future__ import annotations

import math
from collections import OrderedDict
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any, NamedTuple

import gymnasium
import numpy as np
from gymnasium import spaces

from citygen.errors import Problem, SpecError
from citygen.geometry.terrain import height_at
from citygen.runner import localmap
from citygen.runner import metrics as M
from citygen.runner.scenes import Prepared, SceneSource, process_cache
from citygen.spec import Scene

#: Control step (s) of navigation and traverse: actions are held this long.
NAV_DT = 0.1
#: Navigation episodes end after this many steps (the paper's horizon).
NAV_HORIZON = 200
#: Control step (s) of locomotion.
LOCO_DT = 0.02
#: Locomotion episodes end after this many steps (the paper's horizon).
LOCO_HORIZON = 1000
#: Height map: forward and lateral extent (m) and spacing (m), centred on the robot.
HEIGHT_MAP = (1.6, 1.0, 0.1)
#: Horizontal rays of the ``rays`` observation, their height above the feet and range (m).
RAY_COUNT, RAY_HEIGHT, RAY_RANGE = 32, 0.3, 8.0
#: Scenes whose MjData and robot handle an environment keeps for coming back to them.
LIVE_SCENES = 8
#: Offscreen renderers (one per model and size) a process keeps.
RENDERERS = 8
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
#: Spawning: clearance (m) between the ground and a robot part that would have touched it.
SPAWN_CLEARANCE = 0.01
#: Traverse: seconds without getting closer to the next waypoint before a reset.
STUCK_SECONDS = 15.0

#: Default split of each task kind (the test part of its dataset).
DEFAULT_SPLIT = {
    "nav-clear": "urban-nav-1-test",
    "nav-static": "urban-nav-2-test",
    "nav-dynamic": "urban-nav-3-test",
    "loco-flat": "urban-loc-1-test",
    "loco-slope": "urban-loc-2-test",
    "loco-stair": "urban-loc-3-test",
    "loco-rough": "urban-loc-4-test",
    "traverse": "urban-tra-standard",
}


def _yaw_rotate(vx: np.ndarray, vy: np.ndarray, yaw: float) -> tuple[np.ndarray, np.ndarray]:
    """World vectors into the frame turned by ``yaw``."""
    c, s = math.cos(yaw), math.sin(yaw)
    return c * vx + s * vy, -s * vx + c * vy


_RENDERERS: OrderedDict[tuple[int, int, int], tuple[Any, Any]] = OrderedDict()


def _renderer(model: Any, width: int, height: int) -> Any:
    """A ``mujoco.Renderer`` of ``model`` at ``width`` x ``height``, kept for the process: the
    environments of a process share it, and a reset back to a cached scene finds its renderer
    (and GL context) ready. The :data:`RENDERERS` most recently used are kept."""
    import mujoco

    key = (id(model), width, height)
    hit = _RENDERERS.pop(key, None)
    if hit is None or hit[0] is not model:
        if hit is not None:
            hit[1].close()
        hit = (model, mujoco.Renderer(model, height=height, width=width))
    _RENDERERS[key] = hit
    while len(_RENDERERS) > RENDERERS:
        _RENDERERS.popitem(last=False)[1][1].close()
    return hit[1]


_RENDER_OPTION: list[Any] = []


def _render_option() -> Any:
    """The scene option of every rendering: the scene's geom groups and the robot's."""
    if not _RENDER_OPTION:
        from citygen.runner.robots.handle import render_option

        _RENDER_OPTION.append(render_option())
    return _RENDER_OPTION[0]


class _Around(NamedTuple):
    """The terrain around the last pose asked for: ground height (m) under ``(x, y)`` and
    the height map's grid of ground heights (m, flat)."""

    scene: Any
    x: float
    y: float
    yaw: float
    ground: float
    grid: np.ndarray | None  # None when only the ground under the base was asked for


class _CitygenEnv(gymnasium.Env):
    """What the three task families share: scenes, the robot, the MuJoCo loop, images."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}
    default_robot = "wheeled"
    dt = NAV_DT

    def __init__(
        self,
        task: str,
        scene: Scene | str | Path | None = None,
        *,
        split: str | None = None,
        seed: int | None = None,
        robot: str | Path | None = None,
        adapter: Any = None,
        depth: bool = False,
        rgb: bool = False,
        rays: bool = False,
        image_size: int = 128,
        render_mode: str | None = None,
        max_steps: int | None = None,
        scene_pool: int | None = None,
        observations: Sequence[str] | None = None,
    ):
        from citygen.runner.robots import load_robot

        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise SpecError(
                f"render_mode: expected one of {self.metadata['render_modes']}, got {render_mode!r}"
            )
        if scene is None and split is None:
            split = DEFAULT_SPLIT[task]
        self.task_kind = task
        self.source = SceneSource(scene, split, seed, scene_pool)
        self.robot = load_robot(robot or self.default_robot, adapter)
        self.use_depth, self.use_rgb, self.use_rays = depth, rgb, rays
        self.image_size = int(image_size)
        self.render_mode = render_mode
        self.max_steps = max_steps
        self._observations = None if observations is None else tuple(observations)
        self.prepared: Prepared | None = None
        self.model = None
        self.data = None
        self.handle = None
        self._renderer = None
        self._index = -1
        self._live: dict[int, tuple] = {}  # id(Prepared) -> _bind's tuple, oldest first
        self._around: _Around | None = None  # the last _terrain_around
        hx, hy, step = HEIGHT_MAP
        nx, ny = round(hx / step) + 1, round(hy / step) + 1
        u, v = np.meshgrid(np.linspace(-hx / 2, hx / 2, nx), np.linspace(-hy / 2, hy / 2, ny), indexing="ij")
        self._hm_local = (u.ravel(), v.ravel(), (nx, ny))
        angles = np.linspace(0.0, 2 * np.pi, RAY_COUNT, endpoint=False)
        self._ray_dirs = np.stack([np.cos(angles), np.sin(angles), np.zeros_like(angles)], axis=1)

    # --- spaces -------------------------------------------------------------------------

    def _image_spaces(self) -> dict[str, spaces.Space]:
        n = self.image_size
        out: dict[str, spaces.Space] = {}
        if self.use_depth:
            out["depth"] = spaces.Box(0.0, np.inf, (n, n), np.float32)
        if self.use_rgb:
            out["rgb"] = spaces.Box(0, 255, (n, n, 3), np.uint8)
        if self.use_rays:
            out["rays"] = spaces.Box(0.0, RAY_RANGE, (RAY_COUNT,), np.float32)
        return out

    def _height_space(self) -> spaces.Box:
        return spaces.Box(-np.inf, np.inf, self._hm_local[2], np.float32)

    def _set_observation_space(self, every: dict[str, spaces.Space]) -> None:
        """The observation space: ``every`` key the task has, or those of the constructor's
        ``observations``, which are then the only pieces computed (a policy reading four of
        seven keys does not pay for the other three)."""
        keys = self._observations
        if keys is not None:
            unknown = [k for k in keys if k not in every]
            if unknown or not keys:
                raise SpecError(
                    [
                        Problem(
                            "observations",
                            f"some of {', '.join(every)}",
                            ", ".join(map(repr, unknown)) or "none",
                        )
                    ]
                )
            every = {k: v for k, v in every.items() if k in keys}
        self.observation_space = spaces.Dict(every)

    # --- scenes and the model ------------------------------------------------------------

    def _load(self, index: int) -> None:
        prepared = process_cache().get(self.source, index, self.robot)
        if prepared is not self.prepared:
            # A scene this environment ran lately keeps its MjData and robot handle: coming
            # back to it swaps a few references instead of allocating them again.
            live = self._live.pop(id(prepared), None)
            if live is None or live[0] is not prepared:
                live = self._bind(prepared)
            self._live[id(prepared)] = live
            while len(self._live) > LIVE_SCENES:
                self._live.pop(next(iter(self._live)))
            self.prepared, self.data, self.handle, self._robot_geoms, self._foot_geoms, self._robot_ids = live
            self.model = prepared.model
            self._substeps = max(1, round(self.dt / self.model.opt.timestep))
        self._index = index
        self.scene = prepared.scene

    def _bind(self, prepared: Prepared) -> tuple:
        """What running ``prepared`` needs in this environment: its MjData, the robot's
        handle, the robot's (and its feet's) geoms as masks over the model's geoms, and the
        robot's geom ids as a set."""
        import mujoco

        from citygen.runner.robots import RobotHandle

        model = prepared.model
        handle = RobotHandle(model, self.robot)
        if prepared.fine_ground:
            handle.terrain = prepared  # the servo reads the 5 cm ground raster, not rays
        robot_geoms = np.zeros(model.ngeom, dtype=bool)
        robot_geoms[handle.geom_ids] = True
        foot_geoms = np.zeros(model.ngeom, dtype=bool)
        foot_geoms[handle.foot_geom_ids] = True
        robot_ids = frozenset(handle.geom_ids.tolist())
        return prepared, mujoco.MjData(model), handle, robot_geoms, foot_geoms, robot_ids

    def _pick_index(self, options: dict | None) -> int:
        if options and "index" in options:
            return int(options["index"])
        if self.source.size == 1:
            return 0
        return int(self.np_random.integers(self.source.size))

    def _ground_z(self, x: float, y: float) -> float:
        """Ground height (m) at ``(x, y)``; free at the last :meth:`_terrain_around` centre."""
        c = self._around
        if c is not None and c.scene is self.scene and c.x == x and c.y == y:
            return c.ground
        return float(height_at(self.scene, x, y))

    def _terrain_around(
        self, x: float, y: float, yaw: float, grid: bool = True
    ) -> tuple[float, np.ndarray | None]:
        """The ground height (m) at ``(x, y)`` and the height map's grid of ground heights (m,
        float64, flat) around the pose ``(x, y, yaw)``, from the scene's 5 cm ground raster
        (:meth:`Prepared.ground`; a city's coarser map: one :func:`height_at` call) and
        remembered for the last pose (a step asks for them several times). Without ``grid``,
        the ground alone (grid None unless already computed): the same value, computed
        point by point either way."""
        c = self._around
        same = c is not None and c.scene is self.scene and (c.x, c.y, c.yaw) == (x, y, yaw)
        if same and (c.grid is not None or not grid):
            return c.ground, c.grid
        prepared = self.prepared
        if not grid:
            if prepared.fine_ground:
                ground = prepared.ground_point(x, y)
            else:
                ground = float(height_at(self.scene, np.array([x]), np.array([y]))[0])
            self._around = _Around(self.scene, x, y, yaw, ground, None)
            return ground, None
        u, v, _ = self._hm_local
        cs, sn = math.cos(yaw), math.sin(yaw)
        xs, ys = np.empty(u.size + 1), np.empty(u.size + 1)
        xs[:-1], ys[:-1] = x + cs * u - sn * v, y + sn * u + cs * v
        xs[-1], ys[-1] = x, y
        z = prepared.ground(xs, ys) if prepared.fine_ground else height_at(self.scene, xs, ys)
        self._around = _Around(self.scene, x, y, yaw, float(z[-1]), z[:-1])
        return self._around.ground, self._around.grid

    def _ground_under(self, x: float, y: float, yaw: float) -> float:
        """The ground (m) under the base at the pose, by :meth:`_terrain_around`, with the
        height map's grid only when the height map is observed (it is then needed anyway)."""
        return self._terrain_around(x, y, yaw, grid="height_map" in self.observation_space.spaces)[0]

    def _spawn(self, x: float, y: float, yaw: float) -> float:
        """Put the robot standing at ``(x, y, yaw)`` (:meth:`RobotHandle.reset`) with its feet
        on the ground under them and no part inside the ground: on rough ground, stairs or a
        slope the ground under a foot is not the ground under the base. The feet are lifted
        onto the ground :func:`height_at` gives under each; then MuJoCo's own contacts lift it
        out of whatever it still penetrates, and :data:`SPAWN_CLEARANCE` is added. Returns
        the lift (m) over the ground under the base."""
        import mujoco

        from citygen.runner.robots import lowest_point

        m, d, h = self.model, self.data, self.handle
        ground = self._ground_z(x, y)
        h.reset(d, (x, y, ground, yaw))
        feet = h.foot_geom_ids
        under = height_at(self.scene, d.geom_xpos[feet, 0], d.geom_xpos[feet, 1])
        low = np.array([lowest_point(m, d, int(g)) for g in feet])
        lift = max(0.0, float(np.max(under - low))) if feet.size else 0.0
        robot, ground_geoms = self._robot_geoms, self.prepared.ground_geoms
        for _ in range(20):  # MuJoCo's contacts: what still penetrates the ground
            if lift > 0.0:
                h.reset(d, (x, y, ground + lift, yaw))
            n = d.ncon
            g1, g2, dist = d.contact.geom1[:n], d.contact.geom2[:n], d.contact.dist[:n]
            inside = ((robot[g1] & ground_geoms[g2]) | (robot[g2] & ground_geoms[g1])) & (dist < 0)
            if not inside.any():
                break
            lift += float(-dist[inside].min()) + 1e-3
        if lift <= 1e-6:
            return 0.0
        lift += SPAWN_CLEARANCE
        h.reset(d, (x, y, ground + lift, yaw))
        mujoco.mj_forward(m, d)
        return lift

    def _out_of_bounds(self, x: float, y: float) -> bool:
        """Outside the scene's bounds."""
        (x0, y0), (x1, y1) = self.scene.bounds.min, self.scene.bounds.max
        return not (x0 <= x <= x1 and y0 <= y <= y1)

    def _physics(self, command: Callable[[float], None] | None) -> None:
        """One control step: :attr:`_substeps` physics steps. ``command(dt)`` (the robot's
        drive) runs before every ``handle.drive_substeps`` of them (``dt`` in s: the time
        until its next call); with no command MuJoCo steps them in one call."""
        import mujoco

        n = self._substeps
        if command is None:
            mujoco.mj_step(self.model, self.data, nstep=n)
            return
        k, h = self.handle.drive_substeps, self.model.opt.timestep
        done = 0
        while done < n:
            m = min(k, n - done)
            command(m * h)
            mujoco.mj_step(self.model, self.data, nstep=m)
            done += m

    # --- observations --------------------------------------------------------------------

    def _height_map(self, x: float, y: float, z_feet: float, yaw: float) -> np.ndarray:
        _, heights = self._terrain_around(x, y, yaw)
        return (heights - z_feet).reshape(self._hm_local[2]).astype(np.float32)

    def _images(self, pose: tuple[float, float, float, float]) -> dict[str, np.ndarray]:
        out: dict[str, np.ndarray] = {}
        if not (self.use_depth or self.use_rgb or self.use_rays):
            return out
        x, y, z, yaw = pose
        if self.use_rays:
            out["rays"] = self._ray_ranges(x, y, z, yaw)
        if self.use_depth or self.use_rgb:
            renderer = self._get_renderer(self.image_size, self.image_size)
            cam = self._eye_camera(pose)
            renderer.update_scene(self.data, camera=cam, scene_option=_render_option())  # both images
            if self.use_rgb:
                renderer.disable_depth_rendering()
                out["rgb"] = renderer.render()
            if self.use_depth:
                renderer.enable_depth_rendering()
                out["depth"] = renderer.render().astype(np.float32, copy=False)
                renderer.disable_depth_rendering()
        return out

    def _ray_ranges(self, x: float, y: float, z: float, yaw: float) -> np.ndarray:
        import mujoco

        ground = self._ground_z(x, y)
        c, s = math.cos(yaw), math.sin(yaw)
        d = self._ray_dirs
        dirs = np.stack([c * d[:, 0] - s * d[:, 1], s * d[:, 0] + c * d[:, 1], d[:, 2]], axis=1)
        pnt = np.array([x, y, ground + RAY_HEIGHT])
        out = np.full(RAY_COUNT, RAY_RANGE, dtype=np.float32)
        geomid = np.zeros(RAY_COUNT, dtype=np.int32)
        dist = np.zeros(RAY_COUNT, dtype=np.float64)
        # Group 3 holds nothing of the scene; the robot's own body is excluded by its id.
        mujoco.mj_multiRay(
            self.model, self.data, pnt, dirs.ravel(), None, 1, self.handle.base_id,
            geomid, dist, None, RAY_COUNT, RAY_RANGE,
        )  # fmt: skip
        hit = (geomid >= 0) & (dist >= 0)
        out[hit] = np.minimum(dist[hit], RAY_RANGE)
        return out

    def _eye_camera(self, pose: tuple[float, float, float, float]):
        import mujoco

        x, y, _, yaw = pose
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        ground = self._ground_z(x, y)
        eye = 0.6
        cam.lookat[:] = (x + 1.5 * math.cos(yaw), y + 1.5 * math.sin(yaw), ground + eye - 0.2)
        cam.distance = 1.5 + max(self.robot.radius, 0.2)
        cam.azimuth = math.degrees(yaw)
        cam.elevation = -8.0
        return cam

    def _get_renderer(self, width: int, height: int):
        """This process's renderer of the current model at that size (see :func:`_renderer`)."""
        self._renderer = _renderer(self.model, width, height)
        return self._renderer

    def render(self):
        if self.render_mode != "rgb_array" or self.model is None:
            return None
        renderer = self._get_renderer(
            min(640, self.model.vis.global_.offwidth), min(480, self.model.vis.global_.offheight)
        )
        renderer.update_scene(self.data, camera=self._chase_camera(), scene_option=_render_option())
        return renderer.render().copy()

    def _chase_camera(self):
        import mujoco

        x, y, z, yaw = self.handle.pose(self.data)
        cam = mujoco.MjvCamera()
        cam.type = mujoco.mjtCamera.mjCAMERA_FREE
        cam.lookat[:] = (x, y, z)
        cam.distance = 6.0
        cam.azimuth = math.degrees(yaw)
        cam.elevation = -35.0
        return cam

    def close(self):
        self._renderer = None  # the process's renderers outlive an environment (_renderer)

    # --- contacts ------------------------------------------------------------------------

    def _contacts(self) -> tuple[np.ndarray, np.ndarray]:
        n = self.data.ncon
        if n == 0:
            empty = np.zeros(0, dtype=np.int64)
            return empty, empty
        c = self.data.contact
        return np.asarray(c.geom1[:n]), np.asarray(c.geom2[:n])

    def _touching_obstacle(self) -> bool:
        d = self.data
        if d.ncon == 0:
            return False
        # A handful of contacts: set lookups beat numpy's overhead per call.
        robot, obstacles = self._robot_ids, self.prepared.obstacle_ids
        return any(
            (g1 in robot and g2 in obstacles) or (g2 in robot and g1 in obstacles)
            for g1, g2 in d.contact.geom.tolist()
        )


# --- navigation ---------------------------------------------------------------------------


class NavEnv(_CitygenEnv):
    """Point-goal navigation: NavClear, NavStatic, NavDynamic (see the module docstring)."""

    def __init__(self, task: str = "nav-static", scene: Scene | str | Path | None = None, **kwargs: Any):
        if not task.startswith(("nav", "traverse")):
            raise SpecError(f"task: expected a navigation task kind, got {task!r}")
        super().__init__(task, scene, **kwargs)
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
        self._set_observation_space(obs)
        self.horizon = self.max_steps or NAV_HORIZON
        self.crowd = None
        self.traffic = None

    # The goal of the current step (a traverse moves it along the route).
    def _goal(self) -> tuple[float, float]:
        return self.goal

    def _setup_task(self) -> None:
        task = self.scene.task
        if task is None or not hasattr(task, "goal"):
            raise SpecError(
                f"{self.source.name}: task: expected a navigation task (with a goal), got {task!r}"
            )
        self.goal = tuple(task.goal)
        self.tolerance = task.goal_tolerance

    def _dynamic(self) -> bool:
        return self.task_kind in ("nav-dynamic", "traverse")

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        super().reset(seed=seed)
        self._load(self._pick_index(options))
        self._setup_task()
        task = self.scene.task
        x, y = task.start.position
        self._start = (float(x), float(y))
        self.handle.reset(self.data, (x, y, self._ground_z(x, y), task.start.yaw))
        self._place_agents()
        import mujoco

        mujoco.mj_forward(self.model, self.data)
        self.steps = 0
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
        d = self.data
        if self._dynamic() and self.prepared.agent_bodies:
            from citygen.runner.crowd import Crowd, Traffic
            from citygen.runner.traffic import city_agents

            self.crowd = Crowd(self.scene, self.prepared.occupancy, rng=self.np_random, dt=self.dt)
            if len(self.crowd.ids) == 0:
                self.crowd = None
            if self.scene.signals:  # a city: signals for vehicles and people (runner.traffic)
                self.crowd, self.traffic = city_agents(self.prepared, self.scene, self.crowd, self.dt)
            else:
                self.traffic = Traffic(self.scene, dt=self.dt)
            if len(self.traffic.ids) == 0:
                self.traffic = None
            self._write_agents()
        else:
            # NavClear / NavStatic: no moving agents; their bodies are parked far below.
            for mocap in self.prepared.agent_bodies.values():
                d.mocap_pos[mocap] = (0.0, 0.0, -100.0)

    def _write_agents(self) -> None:
        d, bodies = self.data, self.prepared.agent_bodies
        for group in (self.crowd, self.traffic):
            if group is None:
                continue
            z = height_at(self.scene, group.pos[:, 0], group.pos[:, 1])
            yaw = group.headings() if hasattr(group, "headings") else group.yaw
            for k, aid in enumerate(group.ids):
                m = bodies[aid]
                d.mocap_pos[m] = (group.pos[k, 0], group.pos[k, 1], z[k])
                d.mocap_quat[m] = (math.cos(yaw[k] / 2), 0.0, 0.0, math.sin(yaw[k] / 2))

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
            if self.crowd is not None:
                self.crowd.step(np.array([x, y]), robot_vel, self.robot.radius)
            if self.traffic is not None:
                obstacles = [np.array([[x, y]])]
                radii = [np.array([self.robot.radius])]
                if self.crowd is not None:
                    obstacles.append(self.crowd.pos)
                    radii.append(self.crowd.radius)
                self.traffic.step(np.concatenate(obstacles), np.concatenate(radii))
            self._write_agents()
        self.handle.control(self.data, v, w, self._substeps)
        self.steps += 1
        return self._after_step()

    def _record_traffic(self, x: float, y: float) -> None:
        """Red-light crossings and roadway incursions of the robot, in a city (runner.signals)."""
        if self.traffic_record is not None:
            from citygen.runner.signals import crossings_of

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
        """Tipped over (base tilted more than 60 degrees) or fallen through the ground."""
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
        obs.update(self._images((x, y, z, yaw)))
        return {k: obs[k] for k in self.observation_space.spaces}

    def _info(self, **extra: Any) -> dict[str, Any]:
        x, y, _, yaw = self.handle.pose(self.data)
        return {"scene": self.source.name, "index": self._index, "pose": (x, y, yaw), **extra}


# --- traverse -----------------------------------------------------------------------------


class TraverseEnv(NavEnv):
    """A route of waypoints to the end (see the module docstring).

    The robot defaults to the quadruped, the robot both Urban-Tra scenes are set for (the
    paper's traverse benchmark runs one): the wheeled robot cannot climb the track's stairs.

    Progress for a caller that reports it (a progress bar on ``run_episode``'s
    ``on_step(env, t)``): :attr:`progress` and, every step, ``info["waypoint"]``,
    ``info["waypoints"]`` and ``info["attempts"]``."""

    default_robot = "quadruped"

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
                f"{self.source.name}: task: expected a traverse task (with a route), got {task!r}"
            )
        self.route = [tuple(p) for p in task.route]
        self.waypoint = 0
        self.goal = self.route[0]
        self.tolerance = task.goal_tolerance
        if self.max_steps is None:
            self.horizon = max(1, math.ceil(task.time_limit / self.dt))
        self._anchor = (tuple(task.start.position), task.start.yaw)
        self._best = math.inf
        self._since_progress = 0.0
        self.attempts = 0
        self._finished = False

    def _goal(self) -> tuple[float, float]:
        return self.route[self.waypoint]

    def _new_record(self):
        return M.TraverseEpisode(start_xy=self._start, dt=self.dt, mass=self.robot.mass)

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
        if not done and (
            self._out_of_bounds(x, y) or self._fallen(z, x, y, yaw) or self._since_progress > STUCK_SECONDS
        ):
            (ax, ay), ayaw = self._anchor
            self._spawn(ax, ay, ayaw)  # feet on the ground under each, as at the start (forwarded)
            self.attempts += 1
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
            if self.traffic_record is not None:
                info["metrics"].update(self.traffic_record.metrics())
        return obs, float(reward), bool(done), bool(truncated), info


# --- locomotion ---------------------------------------------------------------------------


class LocoEnv(_CitygenEnv):
    """Velocity-command locomotion on an Urban-Loc grid (see the module docstring)."""

    default_robot = "quadruped"
    dt = LOCO_DT
    metadata = {"render_modes": ["rgb_array"], "render_fps": 50}

    def __init__(self, task: str = "loco-flat", scene: Scene | str | Path | None = None, **kwargs: Any):
        if not task.startswith("loco"):
            raise SpecError(f"task: expected a locomotion task kind, got {task!r}")
        self.randomize = bool(kwargs.pop("randomize", True))
        super().__init__(task, scene, **kwargs)
        from citygen.runner.tasks import check_robot

        check_robot(task, self.robot)
        n = len(self.robot.leg_joints)
        self.n_joints = n
        self._fall_model = None
        self.action_space = spaces.Box(-1.0, 1.0, (n,), np.float32)
        obs = {
            "base_lin_vel": spaces.Box(-np.inf, np.inf, (3,), np.float32),
            "base_ang_vel": spaces.Box(-np.inf, np.inf, (3,), np.float32),
            "command": spaces.Box(-np.inf, np.inf, (3,), np.float32),
            "joint_pos": spaces.Box(-np.inf, np.inf, (n,), np.float32),
            "joint_vel": spaces.Box(-np.inf, np.inf, (n,), np.float32),
            "last_action": spaces.Box(-1.0, 1.0, (n,), np.float32),
            "height_map": self._height_space(),
        }
        obs.update(self._image_spaces())
        self._set_observation_space(obs)
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
        self._load(self._pick_index(options))
        task = self.scene.task
        if task is None or not task.kind.startswith("loco"):
            raise SpecError(
                f"{self.source.name}: $.task: expected a locomotion task, got "
                f"{'none' if task is None else task.kind}"
            )
        x, y, yaw, command = self._draw_start(task, options)
        self.command = np.asarray(command, dtype=np.float64)
        for mocap in self.prepared.agent_bodies.values():
            self.data.mocap_pos[mocap] = (0.0, 0.0, -100.0)
        self._spawn(x, y, yaw)
        mujoco.mj_forward(self.model, self.data)
        self._fall_geoms_for_model()
        self.steps = 0
        self.last_action = np.zeros(self.n_joints)
        heading = yaw + math.atan2(self.command[1], self.command[0])
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
        if self.randomize and grid is not None:
            row, col = int(rng.integers(grid.rows)), int(rng.integers(grid.cols))
            jitter = rng.uniform(-START_JITTER, START_JITTER, 2)
            x = grid.origin[0] + (col + 0.5) * size + float(jitter[0])
            y = grid.origin[1] + (row + 0.5) * size + float(jitter[1])
            yaw = float(rng.uniform(-math.pi, math.pi))
            speed, turn = math.hypot(command[0], command[1]), float(rng.uniform(*COMMAND_TURN))
            command = (speed * math.cos(turn), speed * math.sin(turn), float(command[2]))
            self.region = (row, col)
        if "region" in options and grid is not None:
            row, col = (int(v) for v in options["region"])
            if not (0 <= row < grid.rows and 0 <= col < grid.cols):
                raise SpecError(
                    f"options.region: expected (row, col) inside the {grid.rows} x {grid.cols} grid, "
                    f"got {(row, col)}"
                )
            x, y = grid.origin[0] + (col + 0.5) * size, grid.origin[1] + (row + 0.5) * size
            self.region = (row, col)
        if "command" in options:
            command = tuple(float(c) for c in options["command"])
        return x, y, yaw, command

    def _fall_geoms_for_model(self) -> None:
        """The robot geoms whose pressing on the ground is a fall: the body, not the legs.
        A leg is every link from a foot (or wheel) up to the base, so a knee brushing a
        knee-high bump is not a fall, the trunk, head, torso or an arm touching down is (the
        base-contact termination of Isaac Lab's locomotion tasks, on which URBAN-SIM's are
        built). Computed once per compiled model."""
        if self._fall_model is self.model:
            return
        m, h = self.model, self.handle
        legs: set[int] = set()
        for body in m.geom_bodyid[h.foot_geom_ids].tolist():
            while body != h.base_id and body > 0 and body not in legs:
                legs.add(body)
                body = int(m.body_parentid[body])
        self._fall_geoms = self._robot_geoms & ~np.isin(m.geom_bodyid, sorted(legs))
        self._fall_model = self.model

    def _ground_force(self) -> float:
        """Largest normal force (N) of a contact between the ground and a robot part that
        must not touch it (:meth:`_fall_geoms_for_model`)."""
        import mujoco

        g1, g2 = self._contacts()
        if g1.size == 0:
            return 0.0
        body = self._fall_geoms
        ground = self.prepared.ground_geoms
        hits = np.flatnonzero((body[g1] & ground[g2]) | (body[g2] & ground[g1]))
        force = np.zeros(6)
        worst = 0.0
        for i in hits:
            mujoco.mj_contactForce(self.model, self.data, int(i), force)
            worst = max(worst, abs(force[0]))
        return worst

    def step(self, action):
        a = np.clip(np.asarray(action, dtype=np.float64).reshape(self.n_joints), -1.0, 1.0)
        self.handle.joint_action(self.data, a)
        self._physics(None)
        self.steps += 1
        x, y, _, _ = self.handle.pose(self.data)
        vel = self.handle.velocity(self.data)
        fallen = self._ground_force() > FALL_FORCE or self._out_of_bounds(x, y)
        dv = (vel[0] - self.command[0]) ** 2 + (vel[1] - self.command[1]) ** 2
        dz = (vel[3] - self.command[2]) ** 2
        reward = math.exp(-dv / 0.25**2) + 0.5 * math.exp(-dz / 0.25**2)
        reward += 2.0 * -(vel[2] ** 2)
        reward += 0.01 * -float(np.sum((a - self.last_action) ** 2))
        if fallen:
            reward -= 100.0
        self.last_action = a
        self.recorder.record_step((x, y), np.array(self.data.actuator_force), fallen=fallen)
        truncated = not fallen and self.steps >= self.horizon
        obs = self._observation()
        info = {"scene": self.source.name, "index": self._index, "fallen": fallen}
        if fallen or truncated:
            self.recorder.finish()
            info["metrics"] = M.loco_metrics(self.recorder)
        return obs, float(reward), bool(fallen), bool(truncated), info

    def _observation(self) -> dict[str, np.ndarray]:
        x, y, z, yaw = self.handle.pose(self.data)
        vel = self.handle.velocity(self.data)
        obs = {
            "base_lin_vel": np.asarray(vel[:3], dtype=np.float32),
            "base_ang_vel": np.asarray(
                self.data.qvel[self.handle.dadr + 3 : self.handle.dadr + 6], dtype=np.float32
            ),
            "command": self.command.astype(np.float32),
            "joint_pos": np.asarray(
                self.handle.joint_positions(self.data) - self.handle.default, dtype=np.float32
            ),
            "joint_vel": np.asarray(self.handle.joint_velocities(self.data), dtype=np.float32),
            "last_action": self.last_action.astype(np.float32),
        }
        if "height_map" in self.observation_space.spaces:
            obs["height_map"] = self._height_map(x, y, self._terrain_around(x, y, yaw)[0], yaw)
        obs.update(self._images((x, y, z, yaw)))
        return {k: obs[k] for k in self.observation_space.spaces}
