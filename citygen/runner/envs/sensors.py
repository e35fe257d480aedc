"""What an environment senses around its robot: the terrain (the ground under the base and
the height map's grid of ground heights, from the scene's 5 cm elevation raster), the
``depth`` and ``rgb`` images and the horizontal ``rays``, and the renderers behind the images
and :meth:`render`.

:class:`Sensors` is a part of :class:`~citygen.runner.envs.base._CitygenEnv`: its methods read
the environment's scene, compiled model, data and robot handle.
"""

from __future__ import annotations

import math
from collections import OrderedDict
from typing import Any, NamedTuple

import numpy as np
from gymnasium import spaces

from citygen.geometry.terrain import height_at
from citygen.geometry.tiles import KIND_CODES, build_table
from citygen.runner.envs.height_kernel import ground_around, tiles_around
from citygen.spec.terrain import FlatTile, RoughTile, SlopeTile, StairTile

#: Height map: forward and lateral extent (m) and spacing (m), centred on the robot.
HEIGHT_MAP = (1.6, 1.0, 0.1)
#: Horizontal rays of the ``rays`` observation, their height above the feet and range (m).
RAY_COUNT, RAY_HEIGHT, RAY_RANGE = 32, 0.3, 8.0
#: Offscreen renderers (one per model and size) a process keeps.
RENDERERS = 8


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


class Sensors:
    """The terrain, images and rays of :class:`~citygen.runner.envs.base._CitygenEnv`."""

    def _setup_sensors(self) -> None:
        """The height map's grid and the rays' directions in the robot's frame; no terrain
        remembered and no renderer yet."""
        self._renderer = None
        self._around: _Around | None = None  # the last _terrain_around
        self._kernel: tuple = (None, None)  # the compiled heights' arguments (_kernel_for)
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

    # --- terrain -------------------------------------------------------------------------

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
        (:meth:`Prepared.ground`; on a city's coarser map its tiles, :attr:`Prepared.fine_tiles`,
        for the ground and one :func:`height_at` call for the grid) and
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
            else:  # the same 5 cm raster, made tile by tile (a city's curbs cost height_at ms)
                ground = prepared.fine_tiles.ground_at(x, y)
            self._around = _Around(self.scene, x, y, yaw, ground, None)
            return ground, None
        u, v, _ = self._hm_local
        cs, sn = math.cos(yaw), math.sin(yaw)
        kernel = self._kernel if self._kernel[0] is prepared.occupancy else self._kernel_for(prepared)
        z, done = None, False
        if kernel[1] is ground_around:  # prepared.ground at these points, compiled (to the bit)
            z, done = ground_around(*kernel[2:], u, v, x, y, cs, sn), True
        elif kernel[1] is not None:  # the terrain's heights, compiled (to the bit)
            z, done = tiles_around(*kernel[2:], u, v, x, y, cs, sn)
        if not done:
            xs, ys = np.empty(u.size + 1), np.empty(u.size + 1)
            xs[:-1], ys[:-1] = x + cs * u - sn * v, y + sn * u + cs * v
            xs[-1], ys[-1] = x, y
            z = prepared.ground(xs, ys) if prepared.fine_ground else height_at(self.scene, xs, ys)
        ground = float(z[-1]) if prepared.fine_ground else prepared.fine_tiles.ground_at(x, y)
        self._around = _Around(self.scene, x, y, yaw, ground, z[:-1])
        return self._around.ground, self._around.grid

    def _kernel_for(self, prepared: Any) -> tuple:
        """Which compiled form of the height map's heights ``prepared`` takes, and its
        arguments before the points': ``(occupancy, ground_around, raster ...)`` on a fine
        ground raster, ``(occupancy, tiles_around, tiles ...)`` on a terrain without
        features (a coarse map), ``(occupancy, None)`` for numpy alone (``occupancy``:
        ``prepared``'s map, which a locomotion grid's windows share)."""
        terrain = self.scene.terrain
        occ = prepared.occupancy  # the key: a grid's windows share their scene's maps
        if prepared.fine_ground:
            g = prepared.occupancy.grid
            flat = np.ascontiguousarray(prepared.occupancy.heights, dtype=np.float64).reshape(-1)
            self._kernel = (occ, ground_around, flat, g.rows, g.cols, g.x0, g.y0, 1.0 / g.resolution)
        elif terrain is not None and not terrain.features:
            tab = build_table(terrain.tiles, terrain.tile_size)
            ox, oy = (float(c) for c in terrain.origin)
            codes = np.array([KIND_CODES[k] for k in (FlatTile, SlopeTile, StairTile, RoughTile)])
            self._kernel = (
                occ, tiles_around, tab.kind, tab.h, tab.a, tab.n, tab.asc, tab.sign, tab.scale, tab.key,
                codes, float(terrain.tile_size), ox, oy, terrain.rows, terrain.cols,
            )  # fmt: skip
        else:
            self._kernel = (occ, None)
        return self._kernel

    def _ground_under(self, x: float, y: float, yaw: float) -> float:
        """The ground (m) under the base at the pose, by :meth:`_terrain_around`, with the
        height map's grid only when the height map is observed (it is then needed anyway)."""
        return self._terrain_around(x, y, yaw, grid="height_map" in self.observation_space.spaces)[0]

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
