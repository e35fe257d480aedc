"""What the task families' environments share (:class:`_CitygenEnv`): the scene source and
the compiled scene, the robot and its spawning on the ground, the MuJoCo loop, the contacts and
the observation space; the terrain, images and rays are its :class:`Sensors` part."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

import gymnasium
import numpy as np
from gymnasium import spaces

from citygen.errors import Problem, SpecError
from citygen.geometry.terrain import height_at
from citygen.runner.envs.sensors import Sensors
from citygen.runner.scenes import Prepared, SceneSource, process_cache
from citygen.spec import Scene

#: Control step (s) of navigation and traverse: actions are held this long.
NAV_DT = 0.1
#: Scenes whose MjData and robot handle an environment keeps for coming back to them.
LIVE_SCENES = 8
#: Spawning: clearance (m) between the ground and a robot part that would have touched it.
SPAWN_CLEARANCE = 0.01


def episode_rng(env: Any, *salt: int) -> np.random.Generator:
    """A generator seeded by ``env``'s episode (the state of its ``np_random``, read without
    drawing from it, so the environment's own draws stay as they were) and ``salt``: draws
    a controller adds to a run (a policy's exploration, the legs' unwedging) replay with it."""
    return np.random.default_rng([env.np_random.bit_generator.state["state"]["state"], *salt])


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


class _CitygenEnv(Sensors, gymnasium.Env):
    """What the three task families share: scenes, the robot, the MuJoCo loop, images."""

    metadata = {"render_modes": ["rgb_array"], "render_fps": 10}
    #: The robot when given none: the family's in :data:`citygen.runner.tasks.DEFAULT_ROBOT`.
    default_robot: str
    dt = NAV_DT
    #: How the scene's slopes and rough tiles are compiled (:data:`citygen.runner.scenes.TERRAIN_OPTIONS`):
    #: heightfields for a robot on wheels or the servo, slopes as prisms under feet.
    terrain = "heightfield"

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
        self._index = -1
        self._live: dict[int, tuple] = {}  # id(Prepared) -> _bind's tuple, oldest first
        self._setup_sensors()

    # --- spaces -------------------------------------------------------------------------

    def _set_observation_space(
        self, every: dict[str, spaces.Space], on_request: dict[str, spaces.Space] | None = None
    ) -> None:
        """The observation space: ``every`` key the task has, or those of the constructor's
        ``observations``, which are then the only pieces computed (a policy reading four of
        seven keys does not pay for the other three). Keys ``on_request`` are there only when
        ``observations`` names them (a piece no default policy reads, costly on a city)."""
        keys = self._observations
        if keys is not None:
            every = {**every, **(on_request or {})}
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

    def _dynamic(self) -> bool:
        """Whether the scene's people and vehicles move (NavDynamic and Traverse)."""
        return False

    def _load(self, index: int) -> None:
        self._use(process_cache().get(self.source, index, self.robot, self.terrain, people=self._dynamic()))
        self._index = index

    def _use(self, prepared: Prepared) -> None:
        """Run ``prepared`` (its model, its scene) from now on."""
        if prepared is not self.prepared:
            # A scene this environment ran lately keeps its MjData and robot handle: coming
            # back to it swaps a few references instead of allocating them again.
            live = self._live.pop(id(prepared), None)
            if live is None or live[0] is not prepared:
                live = self._bind(prepared)
            self._live[id(prepared)] = live
            while len(self._live) > LIVE_SCENES:
                self._live.pop(next(iter(self._live)))
            (
                self.prepared, self.data, self.handle, self._robot_geoms, self._foot_geoms, self._robot_ids,
                self._reach,
            ) = live  # fmt: skip
            self.model = prepared.model
            self._substeps = max(1, round(self.dt / self.model.opt.timestep))
        self.scene = prepared.scene

    def _bind(self, prepared: Prepared) -> tuple:
        """What running ``prepared`` needs in this environment: its MjData, the robot's
        handle, the robot's (and its feet's) geoms as masks over the model's geoms, the
        robot's geom ids as a set, and on a scene of city scale the static geoms near the
        robot (:mod:`citygen.runner.envs.reach`; None elsewhere)."""
        import mujoco

        from citygen.runner.envs.reach import reach_of
        from citygen.runner.robots import RobotHandle

        model = prepared.model
        data = mujoco.MjData(model)
        handle = RobotHandle(model, self.robot)
        reach = reach_of(model, data, handle.geom_ids, handle.base_id)
        handle.terrain = prepared.fine_tiles  # the servo reads the 5 cm ground raster, not rays
        robot_geoms = np.zeros(model.ngeom, dtype=bool)
        robot_geoms[handle.geom_ids] = True
        foot_geoms = np.zeros(model.ngeom, dtype=bool)
        foot_geoms[handle.foot_geom_ids] = True
        robot_ids = frozenset(handle.geom_ids.tolist())
        return prepared, data, handle, robot_geoms, foot_geoms, robot_ids, reach

    def _pick_index(self, options: dict | None) -> int:
        if options and "index" in options:
            return int(options["index"])
        if self.source.size == 1:
            return 0
        return int(self.np_random.integers(self.source.size))

    def _spawn(self, x: float, y: float, yaw: float, drive: bool = False) -> float:
        """Put the robot standing at ``(x, y, yaw)`` (:meth:`RobotHandle.reset`; ``drive``: legs
        in the wheel drive's pose) with its feet on the ground under them and no part inside
        the ground: on rough ground, stairs or a slope the ground under a foot is not the
        ground under the base. The feet are lifted
        onto the ground :func:`height_at` gives under each; then MuJoCo's own contacts lift it
        out of whatever it still penetrates, and :data:`SPAWN_CLEARANCE` is added. Returns
        the lift (m) over the ground under the base."""
        import mujoco

        from citygen.runner.robots import lowest_point

        m, d, h = self.model, self.data, self.handle
        ground = self._ground_z(x, y)
        h.reset(d, (x, y, ground, yaw), drive)
        feet = h.foot_geom_ids
        under = height_at(self.scene, d.geom_xpos[feet, 0], d.geom_xpos[feet, 1])
        low = np.array([lowest_point(m, d, int(g)) for g in feet])
        lift = max(0.0, float(np.max(under - low))) if feet.size else 0.0
        robot, ground_geoms = self._robot_geoms, self.prepared.ground_geoms
        for _ in range(20):  # MuJoCo's contacts: what still penetrates the ground
            if lift > 0.0:
                h.reset(d, (x, y, ground + lift, yaw), drive)
            n = d.ncon
            g1, g2, dist = d.contact.geom1[:n], d.contact.geom2[:n], d.contact.dist[:n]
            inside = ((robot[g1] & ground_geoms[g2]) | (robot[g2] & ground_geoms[g1])) & (dist < 0)
            if not inside.any():
                break
            lift += float(-dist[inside].min()) + 1e-3
        if lift <= 1e-6:
            return 0.0
        lift += SPAWN_CLEARANCE
        h.reset(d, (x, y, ground + lift, yaw), drive)
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
