"""Where an environment's scenes come from, and the per-process cache of compiled scenes.

An environment is built from one scene (a :class:`~citygen.spec.Scene` or a scene file) or
from a split to sample from (``"urban-nav-2-test"``: a name of :func:`citygen.splits`, a
manifest or a config file). A :class:`SceneSource` turns either into scenes by index; the
:class:`Prepared` form of a scene (its MuJoCo model with the robot attached, occupancy map,
free-space mask and distance fields) is built once per process and kept in a bounded LRU
cache, so a vector environment whose sub-environments draw a new scene on every reset
compiles each scene once (asynchronous scene sampling).
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import warnings
from collections import OrderedDict
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from citygen.errors import Problem, SpecError
from citygen.io import load_scene
from citygen.runner import scene_store

# crossable_cells, free_cells, mobility_of and step_edges, long this module's: imported from here.
from citygen.runner.scene_maps import (  # noqa: F401
    MapsProcess,
    build_maps,
    crossable_cells,
    free_cells,
    mobility_of,
    step_edges,
    worth_a_process,
)
from citygen.spec import Scene
from citygen.spec.base import to_jsonable

#: Occupancy-map cell side (m) for walkability, the planner and the route metrics.
MAP_RESOLUTION = 0.05
#: Largest occupancy map (cells) of a scene; bigger scenes get coarser cells.
MAX_MAP_CELLS = 2**24
#: Most compiled scenes a process keeps, whatever their size.
CACHE_SIZE = 4096
#: How an environment's scene compiles its slopes and rough tiles (the MJCF exporter's
#: ``terrain`` option): ``"heightfield"`` for wheels and the ideal servo (the navigation
#: baselines' physics), ``"hybrid"`` (slopes as exact convex prisms, rough tiles as stiffer
#: heightfields) under feet: MuJoCo's contacts of a small sphere or capsule sunk a centimetre
#: into a heightfield's prisms point sideways, and hold a walking foot where it stands
#: (docs/runner.md, "Terrain under feet").
TERRAIN_OPTIONS = ("heightfield", "hybrid")
#: Memory (MiB) the compiled scenes a process keeps may take, by :meth:`Prepared.footprint`
#: (1.3 MiB for a 10 m Urban-Nav training scene, 2.7 MiB for a 15 m test scene; the process's
#: resident memory grows by 2.3 and 4.4 MiB per scene kept, caches of assets and the
#: allocator's slack included): some 800 training scenes, so that a run on a few hundred
#: compiles each once per process (it kept 64 before, whatever their size). The environment
#: variable :data:`CACHE_ENV` overrides it (0 keeps only the scene in use).
CACHE_MB = 1024
CACHE_ENV = "CITYGEN_SCENE_CACHE_MB"


class SceneSource:
    """Scenes by index: one fixed scene, or the scenes of a split (generated on demand);
    ``pool``: only the split's first ``pool`` scenes (a training set small enough for every
    process's cache to hold, so that resets stop compiling)."""

    def __init__(
        self,
        scene: Scene | str | Path | None = None,
        split: str | None = None,
        seed: int | None = None,
        pool: int | None = None,
    ):
        if (scene is None) == (split is None):
            raise SpecError(
                "environment: expected exactly one of scene= (a Scene or file) and split= (a split name)"
            )
        self.split = split
        self.seed = seed
        self._scene: Scene | None = None
        self._content: str | None = None
        self._path: str | None = None
        self.size = 1
        if scene is not None:
            if isinstance(scene, Scene):
                self._scene = scene
            else:
                self._path = str(scene)
                self._scene = load_scene(scene)
        else:
            from citygen.generate.splits import resolve

            parts = resolve(split, seed=seed)
            self._parts = parts
            self.size = sum(p.scenes for p in parts)
            if pool is not None:
                if pool < 1:
                    raise SpecError([Problem("scene_pool", "a number of scenes >= 1", repr(pool))])
                self.size = min(self.size, int(pool))  # the split's first `pool` scenes

    @property
    def name(self) -> str:
        return self.split if self.split is not None else (self._path or "scene")

    def key(self, index: int) -> tuple:
        """A cache key that names the scene without generating it."""
        if self._scene is not None:
            return ("scene", self.content_key(index))
        return ("split", self.split, self.seed, index % self.size)

    def content_key(self, index: int) -> str:
        """A key that names the scene by its content without generating it (the on-disk
        store's, :mod:`citygen.runner.scene_store`): the scene's digest, or the digest of the
        split part's config, seed and name with the index in it."""
        if self._scene is not None:
            if self._content is None:
                self._content = f"scene {_digest(self._scene)}"
            return self._content
        part, i = self._part(index)
        return f"split {hashlib.sha256(part.model_dump_json().encode()).hexdigest()} {i}"

    def scene(self, index: int) -> Scene:
        if self._scene is not None:
            return self._scene
        from citygen.generate.splits import generate_scene

        return generate_scene(*self._part(index))

    def _part(self, index: int) -> tuple[Any, int]:
        """The split part scene ``index`` falls in, and its index within that part."""
        i = index % self.size
        for part in self._parts:
            if i < part.scenes:
                return part, i
            i -= part.scenes
        raise AssertionError("unreachable")  # pragma: no cover


def _digest(scene: Scene) -> str:
    """The digest of the scene's JSON data as :func:`citygen.io.dumps` writes it (floats
    quantised, so a scene and its file agree), compact: the canonical file's layout cost
    half of the digest's 6 s on a city, on every first visit. Written by pydantic-core
    (``model_dump_json``) in an eighth of the time of ``json.dumps`` of :func:`to_jsonable`
    (:func:`_digest_reference`; a city's 0.5 -> 0.06 s of a reset from the on-disk store):
    the same bytes on generated scenes (``tests/test_scene_store.py``); a float below 1e-5
    would be written otherwise (``1e-6`` for ``1e-06``), a key of its own, never another
    scene's."""
    return hashlib.sha256(scene.model_dump_json(by_alias=True, exclude_none=True).encode()).hexdigest()


def _digest_reference(scene: Scene) -> str:
    """:func:`_digest` through :func:`to_jsonable` and :func:`json.dumps`, as it was computed."""
    text = json.dumps(to_jsonable(scene), allow_nan=False, separators=(",", ":"), ensure_ascii=False)
    return hashlib.sha256(text.encode()).hexdigest()


#: Routes :meth:`Prepared.geodesic` remembers per scene (start points asked at every reset).
ROUTE_MEMO = 256


@dataclass(eq=False)
class Prepared:
    """A scene ready to run: its model with the robot attached and the maps the task uses."""

    scene: Scene
    robot: Any  # citygen.runner.robots.Robot
    model: Any  # mujoco.MjModel
    occupancy: Any  # citygen.exporters.occupancy.OccupancyMap
    free: np.ndarray
    """Cells the robot's centre may occupy: walkable and at least its radius from anything
    else (the occupancy map inflated by the robot's radius, negated)."""
    walkable: np.ndarray
    """Walkable cells of the occupancy map (no object on them)."""
    crossable: np.ndarray
    """Walkable cells this robot can cross (:func:`crossable_cells`): :attr:`free` before
    the robot's radius is taken off."""
    obstacle_geoms: np.ndarray
    """bool per geom: an object or an agent (a contact with one is a collision)."""
    ground_geoms: np.ndarray
    """bool per geom: the ground (zones, terrain, apron)."""
    agent_bodies: dict[str, int] = field(default_factory=dict)
    """agent id -> mocap id."""
    store_key: str | None = None
    """Its entry's key in the on-disk store (:mod:`~citygen.runner.scene_store`), where what
    its episodes derive from it may be kept too; None without a store."""
    _fields: dict = field(default_factory=dict)
    _routes: dict = field(default_factory=dict)
    _windows: dict = field(default_factory=dict)
    """terrain option -> its :class:`~citygen.runner.envs.window.Windows` (False: none)."""

    def footprint(self) -> int:
        """Bytes this scene holds, estimated: its model's buffer, its maps' arrays, and the
        float64 ground raster and distance field to the goal every environment running it
        builds (not counted: the scene spec and the MjData of the environments running it)."""
        occ = self.occupancy
        arrays = (occ.labels, occ.heights, occ.terrain, self.free, self.walkable, self.crossable)
        return int(self.model.nbuffer) + sum(a.nbytes for a in arrays) + 16 * occ.heights.size

    @functools.cached_property
    def obstacle_ids(self) -> frozenset[int]:
        """Ids of :attr:`obstacle_geoms`, for lookups one contact at a time."""
        return frozenset(np.flatnonzero(self.obstacle_geoms).tolist())

    @property
    def fine_ground(self) -> bool:
        """Whether :meth:`ground` is fine enough for the height map (cells of at most
        :data:`MAP_RESOLUTION`; a city's coarser map is not)."""
        return self.occupancy.resolution <= MAP_RESOLUTION + 1e-9

    def ground(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Ground heights (m, float64) at the points ``(xs, ys)``: the occupancy map's
        heights (:func:`~citygen.geometry.terrain.height_at` at its cell centres)
        interpolated bilinearly, as an elevation map of that resolution gives them (at 5 cm,
        95 % of points within a centimetre of ``height_at``; a stair's edge is a ramp one
        cell wide). Tens of microseconds for a height map's points, where evaluating the
        terrain costs hundreds."""
        return self.occupancy.grid.bilinear(self._raster, xs, ys)

    def ground_point(self, x: float, y: float) -> float:
        """:meth:`ground` at one point, to the bit (:meth:`Grid.bilinear_point`; the
        environments' ground under the base, every step)."""
        return self.occupancy.grid.bilinear_point(self._raster, x, y)

    @functools.cached_property
    def ground_at(self) -> Callable[[float, float], float]:
        """:meth:`ground` at one point ``ground_at(x, y)``, as a float, in plain Python (~1
        microsecond: the ideal-locomotion servo asks at every drive period and for every
        foot): :class:`~citygen.runner.ground.TiledGround` over one tile, the map's heights,
        a function with the raster's constants bound reading its cells through a
        ``memoryview`` (a Python float each, where indexing the array makes numpy scalars).
        The same interpolation as :meth:`ground` in another order of operations, so it may
        differ from it in the last bit (about 1e-15 m); :meth:`ground_point` is the bit-exact
        one. The servo keeps this one: its trajectories, and so the shipped quadruped
        baselines, were made with it."""
        return self._map_tiles.ground_at

    @functools.cached_property
    def fine_tiles(self):
        """The 5 cm ground raster the servo stands on (:attr:`RobotHandle.terrain
        <citygen.runner.robots.handle.RobotHandle.terrain>`), a
        :class:`~citygen.runner.ground.TiledGround`: the map's own where :attr:`fine_ground`
        (the one :attr:`ground_at` reads), else (a city's coarser map) made tile by tile as it
        is read."""
        from citygen.runner.ground import TiledGround

        return self._map_tiles if self.fine_ground else TiledGround.of_scene(self.scene, MAP_RESOLUTION)

    @functools.cached_property
    def _map_tiles(self):
        """The map's heights as one tile of a :class:`~citygen.runner.ground.TiledGround`."""
        from citygen.runner.ground import TiledGround

        return TiledGround(self.scene, self.occupancy.grid, self._raster)

    @functools.cached_property
    def _raster(self) -> np.ndarray:
        """The occupancy map's heights as float64 (what :meth:`ground` interpolates)."""
        return self.occupancy.heights.astype(np.float64)

    def field(self, goal: tuple[float, float], tolerance: float | None = None):
        """The :class:`~citygen.runner.control.fields.DistanceField` to ``goal`` (its region of
        radius ``tolerance`` m when given) over :attr:`free`, built once per goal."""
        from citygen.runner.control.fields import DistanceField

        key = (round(float(goal[0]), 4), round(float(goal[1]), 4), tolerance)
        field_ = self._fields.get(key)
        if field_ is None:
            field_ = self._fields[key] = DistanceField.build(
                self.free, self.occupancy.grid, goal, tolerance=tolerance
            )
        return field_

    def geodesic(
        self, xy: tuple[float, float] | np.ndarray, goal: tuple[float, float], tolerance: float | None = None
    ) -> float:
        """Walkable-route distance (m) from ``xy`` over :attr:`free`: with ``tolerance`` (m),
        the any-angle shortest path to the goal *region* (the disc of that radius around
        ``goal``, where a navigation task counts the goal reached), as SPL's ``L*_best``
        wants it; without, the 16-connected grid distance to ``goal`` itself. A point in the
        inflated band takes its nearest reachable cell's distance plus the step to it; inf
        when the goal is unreachable. Fields are cached per goal and tolerance."""
        key = (round(float(goal[0]), 4), round(float(goal[1]), 4), tolerance)
        field_ = self.field(goal, tolerance)
        # A route is a pure function of its field and point: an episode's start is asked for at
        # every reset of the scene (SPL's shortest path, ~40 ms of line-of-sight tests), so keep it.
        where = (key, round(float(xy[0]), 4), round(float(xy[1]), 4))
        length = self._routes.get(where)
        if length is None:
            if len(self._routes) >= ROUTE_MEMO:
                self._routes.clear()
            length = self._routes[where] = field_.route(float(xy[0]), float(xy[1]))
        return length


def map_resolution(scene: Scene) -> float:
    """:data:`MAP_RESOLUTION`, doubled until the map has at most :data:`MAX_MAP_CELLS` cells
    (a 1.2 km city is mapped at 0.4 m)."""
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    res = MAP_RESOLUTION
    while (x1 - x0) * (y1 - y0) / res**2 > MAX_MAP_CELLS:
        res *= 2
    return res


def _scene_mjcf(scene: Scene, terrain: str = "heightfield") -> Any:
    """The scene's MJCF as a tree (:func:`citygen.exporters.mjcf.to_tree`: the model the
    exported file compiles to, without its text), its heightfields sampled every 0.1 m, or
    coarser where a city's terrain would exceed the exporter's sample budget; ``terrain`` is
    the exporter's option (:data:`TERRAIN_OPTIONS`)."""
    from citygen.errors import ExportError
    from citygen.exporters import ExportWarning, mjcf

    resolution = mjcf.DEFAULT_RESOLUTION
    while True:
        try:
            with warnings.catch_warnings():
                # Per-tile friction approximations and the like: the exporter's notes to a
                # user writing files, not news to an environment on every scene it samples.
                warnings.simplefilter("ignore", ExportWarning)
                return mjcf.to_tree(scene, apron=5.0, resolution=resolution, terrain=terrain)
        except ExportError as exc:
            if "coarser resolution" not in str(exc) or resolution >= 1.0:
                raise
            resolution *= 2


def geom_kinds(labels: list) -> tuple[np.ndarray, np.ndarray]:
    """Masks over a model's geoms (their :func:`~citygen.exporters.mjcf.geom_labels`) of the
    obstacles (objects, buildings' solids and agents stand in the way) and of the ground (the
    rest of the scene's named geoms: zones, terrain, apron; the robot's are neither)."""
    obstacle = np.array([lab is not None and lab[0] in ("object", "solid", "agent") for lab in labels])
    ground = np.array([lab is not None and lab[0] not in ("object", "solid", "agent") for lab in labels])
    return obstacle, ground


def start_pose(scene: Scene) -> tuple[float, float, float, float]:
    """``(x, y, ground_z, yaw)`` a scene's model is compiled with the robot at: its task's
    start (the scene's minimum corner without a task)."""
    from citygen.geometry.terrain import height_at

    start = scene.task.start if scene.task is not None else None
    x, y = start.position if start is not None else scene.bounds.min
    yaw = start.yaw if start is not None else 0.0
    return (x, y, float(height_at(scene, x, y)), yaw)


def prepare(
    scene: Scene,
    robot: Any,
    terrain: str = "heightfield",
    people: bool = False,
    process: bool | None = None,
    store: tuple[Any, str] | None = None,
) -> Prepared:
    """Compile ``scene`` with ``robot`` at the task's start (its slopes and rough tiles as
    ``terrain`` says, :data:`TERRAIN_OPTIONS`) and rasterise its maps; ``people``: make its
    crowd's path tables too when the maps are made in a second process (kept for
    :func:`~citygen.runner.agents.crowd.crowd_of` as ``_crowd_tables``). ``process``: make the
    maps in a second process while this one builds the model
    (:class:`~citygen.runner.scene_maps.MapsProcess`; default: for a scene of
    :data:`~citygen.runner.scene_maps.PROCESS_FROM_CELLS` map cells or more), the same maps;
    ``store``: the on-disk store's folder and the scene's key there, where that process keeps
    the crowd's tables."""
    from citygen.exporters import mjcf
    from citygen.runner.robots import compose

    res = map_resolution(scene)
    if process is None:
        process = worth_a_process(scene, res)
    second = MapsProcess(scene, robot, res, people, store) if process else None
    try:
        model = compose(_scene_mjcf(scene, terrain), robot, start_pose(scene))
        obstacle, ground = geom_kinds(mjcf.geom_labels(model))
        agents = {}
        for a in scene.agents:
            body = model.body(f"agent:{a.id}")
            agents[a.id] = int(model.body_mocapid[body.id])
        maps = second.result() if second is not None else build_maps(scene, robot, res)
    finally:
        if second is not None:
            second.close()
    out = Prepared(
        scene=scene,
        robot=robot,
        model=model,
        occupancy=maps.occupancy,
        free=maps.free,
        crossable=maps.crossable,
        walkable=maps.walkable,
        obstacle_geoms=obstacle,
        ground_geoms=ground,
        agent_bodies=agents,
    )
    if maps.tables is not None:
        out._crowd_tables = maps.tables
    return out


def cache_budget() -> int:
    """Bytes of compiled scenes a process keeps: :data:`CACHE_MB`, or the environment
    variable :data:`CACHE_ENV` (MiB, a number >= 0)."""
    import os

    text = os.environ.get(CACHE_ENV)
    if text is None:
        return CACHE_MB << 20
    try:
        mb = float(text)
    except ValueError:
        mb = -1.0
    if not (mb >= 0 and math.isfinite(mb)):
        raise SpecError([Problem(CACHE_ENV, "a size in MiB >= 0", repr(text))])
    return int(mb * 2**20)


class SceneCache:
    """An LRU of :class:`Prepared` scenes keyed by (source key, robot), bounded by count
    (``size``) and by memory (``budget`` bytes, default :func:`cache_budget`, by
    :meth:`Prepared.footprint`); the scene most recently asked for always stays."""

    def __init__(self, size: int = CACHE_SIZE, budget: int | None = None):
        self.size = size
        self.budget = cache_budget() if budget is None else int(budget)
        self._items: OrderedDict[tuple, tuple[Prepared, int]] = OrderedDict()  # with its footprint
        self.bytes = 0
        self.hits = 0
        self.misses = 0

    def get(
        self, source: SceneSource, index: int, robot: Any, terrain: str = "heightfield", people: bool = False
    ) -> Prepared:
        """The scene ``index`` of ``source`` prepared for ``robot`` (from this cache, the
        on-disk store, or :func:`prepare`); ``people``: its crowd will run (:func:`prepare`'s)."""
        digest = hashlib.sha256(robot.xml.encode()).hexdigest()
        key = (source.key(index), robot.name, robot.timestep, robot.cone, digest, terrain)
        hit = self._items.get(key)
        if hit is not None:
            self.hits += 1
            self._items.move_to_end(key)
            return hit[0]
        self.misses += 1
        item = None
        disk = scene_store.store()
        if disk is not None:
            stored = scene_store.entry_key(source.content_key(index), robot, terrain)
            item = disk.load(stored, robot, source._scene)  # a scene held: not read again
        if item is None:
            where = None if disk is None else (disk.root, stored)
            item = prepare(source.scene(index), robot, terrain, people, store=where)
            if disk is not None:
                disk.save(stored, item)
        if disk is not None:
            item.store_key = stored
        size = item.footprint()
        self._items[key] = (item, size)
        self.bytes += size
        while len(self._items) > 1 and (len(self._items) > self.size or self.bytes > self.budget):
            self.bytes -= self._items.popitem(last=False)[1][1]
        return item


@functools.cache
def process_cache() -> SceneCache:
    """The cache shared by every environment of this process."""
    return SceneCache()
