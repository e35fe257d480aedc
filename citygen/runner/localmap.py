"""The ego-centric local map of the navigation observation (``obs["local_map"]``).

What a robot's mapping stack would give a navigation policy: a ``(2, H, W)`` float32 array
over a :data:`LOCAL_MAP` window (6.4 m x 6.4 m every 0.2 m: 32 x 32 cells) centred on the
robot and turned with its yaw. Row ``i`` is the forward distance ``u`` (ascending, behind
the robot first), column ``j`` the leftward distance ``v`` (ascending, right first):

- channel 0, **elevation** (m) of the highest thing in the cell relative to the ground
  under the robot: the terrain, static objects (their catalog height, a building zone's
  solid its ``height``; buildings and anything taller clipped at :data:`MAX_ELEVATION`),
  and moving people and vehicles as discs of their radius (:data:`AGENT_HEIGHT` tall);
- channel 1, **walkability**: 1 where every part of the cell is walkable ground without an
  object or a moving agent on it, 0 elsewhere (also outside the scene).

Its companion ``obs["local_map_inside"]`` (:meth:`LocalMap.inside`, ``(1, H, W)``) is 1 on
the cells inside the scene's bounds and 0 beyond them: walkability is 0 on grass and past the
scene's edge alike, but leaving the bounds ends an episode at -100. And
``obs["local_map_crossable"]`` (:meth:`LocalMap.crossable`, ``(1, H, W)``) is walkability
for the robot at hand, as a traversability map gives it: 1 where the ground is walkable *and*
the robot can cross it (:func:`citygen.runner.scenes.crossable_cells`: no edge higher than
its step, no stairs for wheels, no slope steeper than it climbs), 0 elsewhere. The planner
plans on that; the elevation layer alone leaves a policy to tell a slope it can drive from
one it would tip over on. ``obs["local_map_motion"]`` (``(2, H, W)``, m/s) is what a
tracker adds to the map: on the cells of each moving person's or vehicle's disc, its
velocity in the robot's frame (forward, leftward), 0 elsewhere. One elevation frame shows
where people are, not where they are going; a policy that must wait for or pass them
needs both.

``obs["local_map_wide"]`` (:func:`observe_wide`, ``(1, H, W)``) is the crossable layer over a
:data:`WIDE_MAP` window, twice the local map's side at half its detail: where a way out of a
dead end or around a wall goes, 3.2-6.4 m away, beyond the local map's edge. The planner sees
the whole scene; a policy with only the local map turns into a pocket whose exit it cannot
see and stays there.

Cheap per step: :func:`static_layers` rasterises the scene once per compiled scene (the
occupancy map's 0.05 m cells max-pooled to :data:`POOL_CELL`, so a thin pole is never lost
between samples) and :class:`LocalMap` samples it at 2 x 2 points per output cell with the
robot's pose (one vectorised gather), then stamps the agents' discs.

>>> ground = StaticLayers(np.zeros((100, 100), np.float32), np.ones((100, 100), bool), 0.0, 0.0, 0.1)
>>> grid = LocalMap()(with_margin(ground), (5.0, 5.0, 0.0), ground=0.0)
>>> grid.shape, float(grid[1].min())
((2, 32, 32), 1.0)
"""

from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

#: Window: forward extent, lateral extent and cell side (m), centred on the robot.
LOCAL_MAP = (6.4, 6.4, 0.2)
#: The wide map's window (``obs["local_map_wide"]``): 12.8 m x 12.8 m every 0.4 m, the local
#: map's 32 x 32 cells at twice the side, centred on the robot and turned with its yaw.
WIDE_MAP = (12.8, 12.8, 0.4)
#: Pooled cell side (m) of the per-scene static layers.
POOL_CELL = 0.1
#: Elevations (m) are clipped to this (a building and a bus shelter both block the way).
MAX_ELEVATION = 2.0
#: Height (m) of a moving agent's disc (a person; a vehicle blocks the same way).
AGENT_HEIGHT = 1.7
#: Speeds (m/s) in ``local_map_motion`` are clipped to this (a vehicle at speed).
MAX_SPEED = 20.0
#: Height (m) of an object whose height the catalog does not know (a mesh file).
UNKNOWN_OBJECT_HEIGHT = 1.0


class StaticLayers(NamedTuple):
    """A scene's pooled static layers: absolute ``elevation`` (m, float32), ``walkable``
    (bool) and, when known, ``crossable`` (bool: walkable ground the robot can cross),
    ``(rows, cols)`` cells of ``cell`` m from ``(x0, y0)``."""

    elevation: np.ndarray
    walkable: np.ndarray
    x0: float
    y0: float
    cell: float
    crossable: np.ndarray | None = None


def _object_heights(scene: Any, occ: Any) -> np.ndarray:
    """Height (m) above the ground of the object standing on each occupancy cell (0 where
    none): each catalog placement's base and each building zone's solid (its ``height``)
    painted with its height, tallest last."""
    from shapely.geometry import Polygon

    from citygen.assets import resolve
    from citygen.geometry.raster import paint

    out = np.zeros(occ.shape, dtype=np.float32)
    items = []
    for pl in scene.placements:
        if pl.is_mesh:
            continue
        try:
            asset = resolve(pl.asset)
        except Exception:  # an unknown id: the occupancy map's obstacle label still marks it
            continue
        c, s = math.cos(pl.yaw), math.sin(pl.yaw)
        ring = np.asarray(asset.base.exterior.coords) * pl.scale
        xy = ring @ np.array([[c, s], [-s, c]]) + np.asarray(pl.position[:2])
        items.append((float(asset.height) * pl.scale, Polygon(xy)))
    items += [(float(z.height), Polygon(z.polygon, z.holes)) for z in scene.zones if z.height is not None]
    for height, shape in sorted(items, key=lambda item: item[0]):
        paint(occ.grid, out, shape, height)
    blocked = occ.obstacle_mask()
    out[blocked & (out <= 0)] = UNKNOWN_OBJECT_HEIGHT
    out[~blocked] = 0.0
    return out


def static_layers(
    scene: Any, occ: Any, margin: float = 5.0, crossable: np.ndarray | None = None
) -> StaticLayers:
    """The scene's static layers from its occupancy map ``occ``
    (:class:`~citygen.exporters.occupancy.OccupancyMap`), pooled to about :data:`POOL_CELL`:
    the maximum elevation and "all walkable" (and "all ``crossable``", a mask of ``occ``'s
    cells, when given) of the fine cells in each pooled cell, with a ``margin`` (m) of
    non-walkable cells around (the edge's elevation), so a window around a robot inside the
    scene never reads outside the arrays."""
    k = max(1, round(POOL_CELL / occ.resolution))
    elev = occ.heights.astype(np.float32) + np.minimum(_object_heights(scene, occ), MAX_ELEVATION)
    fine = StaticLayers(elev, occ.walkable_mask(), occ.grid.x0, occ.grid.y0, occ.resolution, crossable)
    return with_margin(pooled(fine, k), margin)


def with_margin(layers: StaticLayers, margin: float = 5.0) -> StaticLayers:
    """``layers`` grown by ``margin`` (m) of non-walkable cells at the edge's elevation:
    :class:`LocalMap` reads a window around the robot without bounds checks."""
    m = math.ceil(margin / layers.cell)
    elev = np.pad(layers.elevation, m, mode="edge")
    walk = np.pad(layers.walkable, m, constant_values=False)
    cross = None if layers.crossable is None else np.pad(layers.crossable, m, constant_values=False)
    x0, y0 = layers.x0 - m * layers.cell, layers.y0 - m * layers.cell
    return StaticLayers(elev, walk, x0, y0, layers.cell, cross)


def pooled(layers: StaticLayers, k: int = 2) -> StaticLayers:
    """``layers`` at ``k`` times the cell side: the highest elevation, and "all walkable"
    (crossable) of each ``k x k`` block (the edge's cells repeated, walkability False, past
    an uneven end)."""
    rows, cols = -(-layers.elevation.shape[0] // k), -(-layers.elevation.shape[1] // k)
    pad = ((0, rows * k - layers.elevation.shape[0]), (0, cols * k - layers.elevation.shape[1]))

    def all_of(mask: np.ndarray) -> np.ndarray:
        return np.pad(mask, pad, constant_values=False).reshape(rows, k, cols, k).all(axis=(1, 3))

    elev = np.pad(layers.elevation, pad, mode="edge").reshape(rows, k, cols, k).max(axis=(1, 3))
    cross = None if layers.crossable is None else all_of(layers.crossable)
    return StaticLayers(elev, all_of(layers.walkable), layers.x0, layers.y0, layers.cell * k, cross)


def _all_samples(mask: np.ndarray, flat: np.ndarray) -> np.ndarray:
    """Per output cell, whether ``mask`` holds at all 4 of its sub-samples (``flat``: the
    4 blocks of flat indices :class:`LocalMap` gathers)."""
    m = np.take(mask, flat, mode="clip").reshape(4, -1)
    out = m[0] & m[1]
    out &= m[2]
    out &= m[3]
    return out


#: The kernel's stand-in for a missing crossable layer.
_NO_LAYER = np.zeros((0, 0), dtype=bool)


class LocalMap:
    """Samples :class:`StaticLayers` (with a margin, :func:`with_margin`) around a pose (see
    the module docstring)."""

    def __init__(self, window: tuple[float, float, float] = LOCAL_MAP):
        hx, hy, step = window
        self.shape = (round(hx / step), round(hy / step))
        u = -hx / 2 + (np.arange(self.shape[0]) + 0.5) * step
        v = -hy / 2 + (np.arange(self.shape[1]) + 0.5) * step
        self.step = step
        self.u, self.v = (a.ravel() for a in np.meshgrid(u, v, indexing="ij"))  # cell centres
        q = step / 4  # 2 x 2 sub-samples per cell, a pooled cell apart: 4 blocks of all cells
        su = (np.array([-q, -q, q, q])[:, None] + self.u[None, :]).ravel()
        sv = (np.array([-q, q, -q, q])[:, None] + self.v[None, :]).ravel()
        self._sub = (su, sv)
        self._reach = math.hypot(hx, hy) / 2  # m: the window's farthest cell centre, and more

    def __call__(
        self,
        layers: StaticLayers,
        pose: tuple[float, float, float],
        ground: float,
        agents: tuple[np.ndarray, ...] | None = None,
        crossable: bool = False,
        motion: bool = False,
        reference: bool = False,
    ) -> np.ndarray:
        """The ``(2, H, W)`` map at ``pose = (x, y, yaw)``; elevations relative to ``ground``
        (m); ``agents`` are ``(xy (n, 2), radius (n,))`` of moving people and vehicles, or
        ``(xy, radius, velocity (n, 2))``. With ``crossable``, a further channel:
        :meth:`crossable`'s layer, from the same samples. With ``motion``, two more after
        it: the velocity (m/s, robot frame: forward, leftward) of the agent whose disc
        covers the cell (the one whose centre is deepest inside, where discs overlap), 0
        elsewhere (``local_map_motion``). ``reference``: the static layers sampled by the
        plain-numpy gather below instead of its compiled twin
        (:mod:`citygen.runner.localmap_kernel`, the same maps to the bit)."""
        x, y, yaw = pose
        c, s = math.cos(yaw), math.sin(yaw)
        su, sv = self._sub
        inv = 1.0 / layers.cell
        if reference:
            elev, walk, cross = self._gather_reference(layers, x, y, c, s, inv, ground, crossable)
        else:
            from citygen.runner import localmap_kernel

            cross_layer = layers.crossable if crossable and layers.crossable is not None else _NO_LAYER
            elev, walk, cross = localmap_kernel.gather(
                layers.elevation, layers.walkable, cross_layer, su, sv, c * inv, s * inv,
                (x - layers.x0) * inv, (y - layers.y0) * inv, np.float32(ground),
            )  # fmt: skip
        out = np.empty((2 + crossable + 2 * motion, *self.shape), dtype=np.float32)
        flat_out = out.reshape(len(out), -1)
        if motion:
            flat_out[-2:] = 0.0
        if agents is not None and len(agents[0]):
            xy, radius = agents[0], agents[1]
            du, dv = xy[:, 0] - x, xy[:, 1] - y
            au, av = c * du + s * dv, -s * du + c * dv
            near = (np.abs(au) < self.shape[0] * self.step) & (np.abs(av) < self.shape[1] * self.step)
            if np.any(near):
                d2 = (self.u[None, :] - au[near, None]) ** 2 + (self.v[None, :] - av[near, None]) ** 2
                d2 -= (radius[near, None] + self.step / 2) ** 2  # <= 0 inside a disc
                hit = np.any(d2 <= 0, axis=0)
                if motion and hit.any():
                    cells = np.flatnonzero(hit)  # a few dozen: pick each one's agent there only
                    deepest = d2[:, cells].argmin(axis=0)
                    vx, vy = agents[2][near][deepest].T
                    speed = np.stack([c * vx + s * vy, -s * vx + c * vy])
                    flat_out[-2:, cells] = np.clip(speed, -MAX_SPEED, MAX_SPEED)
                elev[hit] = np.maximum(elev[hit], AGENT_HEIGHT)
                walk[hit] = False
        np.maximum(elev, -MAX_ELEVATION, out=flat_out[0])
        np.minimum(flat_out[0], MAX_ELEVATION, out=flat_out[0])
        flat_out[1] = walk
        if crossable:
            flat_out[2] = walk if layers.crossable is None else walk & cross
        return out

    def _gather_reference(
        self, layers: StaticLayers, x: float, y: float, c: float, s: float, inv: float, ground: float,
        crossable: bool,
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:  # fmt: skip
        """The plain-numpy form of :func:`citygen.runner.localmap_kernel.gather`."""
        su, sv = self._sub
        cols = layers.elevation.shape[1]
        # Row-major flat indices of the sub-samples; inside the margin of static_layers they
        # are never negative (astype truncates). Fewest passes over the 4 x H x W samples.
        col = su * (c * inv)
        col += (x - layers.x0) * inv
        col -= sv * (s * inv)
        row = su * (s * inv)
        row += (y - layers.y0) * inv
        row += sv * (c * inv)
        flat = row.astype(np.int64)
        flat *= cols
        flat += col.astype(np.int64)
        e = np.take(layers.elevation, flat, mode="clip").reshape(4, -1)
        elev = np.maximum(e[0], e[1])
        np.maximum(elev, e[2], out=elev)
        np.maximum(elev, e[3], out=elev)
        elev -= np.float32(ground)
        walk = _all_samples(layers.walkable, flat)
        cross = None
        if crossable and layers.crossable is not None:
            cross = _all_samples(layers.crossable, flat)
        return elev, walk, cross

    def crossable(
        self,
        layers: StaticLayers,
        pose: tuple[float, float, float],
        agents: tuple[np.ndarray, np.ndarray] | None = None,
    ) -> np.ndarray:
        """The ``(1, H, W)`` float32 layer of the cells every part of which the robot can
        cross (``layers.crossable``: walkable, off edges higher than its step and terrain it
        cannot take) with no object or moving agent on it; walkability where ``layers``
        holds no crossable mask."""
        return self(layers, pose, 0.0, agents, crossable=True)[2:]

    def inside(
        self, bounds: tuple[tuple[float, float], tuple[float, float]], pose: tuple[float, float, float]
    ) -> np.ndarray:
        """The ``(1, H, W)`` float32 layer of the cells (their centres) that lie inside the
        scene's ``bounds = ((x0, y0), (x1, y1))`` at ``pose = (x, y, yaw)``: 1 inside, 0
        outside, where the robot may not go (leaving the bounds ends an episode). The map's
        walkability is 0 on both sides of the edge, on grass as beyond it; this tells them
        apart."""
        x, y, yaw = pose
        (x0, y0), (x1, y1) = bounds
        reach = self._reach
        if x - reach >= x0 and x + reach <= x1 and y - reach >= y0 and y + reach <= y1:
            return np.ones((1, *self.shape), dtype=np.float32)  # no edge in any direction
        c, s = math.cos(yaw), math.sin(yaw)
        cx = self.u * c
        cx -= self.v * s
        cx += x
        cy = self.u * s
        cy += self.v * c
        cy += y
        inside = (cx >= x0) & (cx <= x1) & (cy >= y0) & (cy <= y1)
        return inside.astype(np.float32).reshape(1, *self.shape)


#: Per-scene layers by name ("local", "wide"), each kept as long as its compiled scene (_kept).
_KEPT: dict[str, Any] = {}
_DEFAULT = LocalMap()
_WIDE = LocalMap(WIDE_MAP)


def space():
    """The Gymnasium space of ``obs["local_map"]``."""
    from gymnasium import spaces

    return spaces.Box(-MAX_ELEVATION, MAX_ELEVATION, (2, *_DEFAULT.shape), np.float32)


def inside_space():
    """The Gymnasium space of ``obs["local_map_inside"]`` (:meth:`LocalMap.inside`)."""
    from gymnasium import spaces

    return spaces.Box(0.0, 1.0, (1, *_DEFAULT.shape), np.float32)


def crossable_space():
    """The Gymnasium space of ``obs["local_map_crossable"]`` (:meth:`LocalMap.crossable`)."""
    from gymnasium import spaces

    return spaces.Box(0.0, 1.0, (1, *_DEFAULT.shape), np.float32)


def wide_space():
    """The Gymnasium space of ``obs["local_map_wide"]`` (:func:`observe_wide`)."""
    from gymnasium import spaces

    return spaces.Box(0.0, 1.0, (1, *_WIDE.shape), np.float32)


def motion_space():
    """The Gymnasium space of ``obs["local_map_motion"]`` (m/s)."""
    from gymnasium import spaces

    return spaces.Box(-MAX_SPEED, MAX_SPEED, (2, *_DEFAULT.shape), np.float32)


def _kept(env: Any, name: str, build: Any) -> StaticLayers:
    """``build(prepared)`` for ``env``'s compiled scene (:class:`~citygen.runner.scenes.Prepared`),
    made on first use and kept under ``name`` as long as the compiled scene lives."""
    import weakref

    cache = _KEPT.setdefault(name, weakref.WeakKeyDictionary())
    prepared = env.prepared
    layers = cache.get(prepared)
    if layers is None:
        layers = cache[prepared] = build(prepared)
    return layers


def _layers_of(env: Any) -> StaticLayers:
    """The static layers of ``env``'s compiled scene (:func:`_kept`)."""
    return _kept(env, "local", _stored_layers)


#: The prefix of the names of a scene's static layers beside its entry in the on-disk store.
LAYERS_ENTRY = "localmap"
#: Occupancy-map cells from which a scene's static layers are kept in the on-disk store (a
#: town's or a city's map; an Urban-Nav square's layers take milliseconds, not four files).
STORE_LAYERS_FROM = 1 << 20
#: The files of a scene's static layers in the store (name, dtype): the three layers and their
#: frame (``x0``, ``y0``, ``cell``), kept as :func:`static_layers` made them.
_LAYER_FILES = (("elevation", np.float32), ("walkable", bool), ("crossable", bool), ("frame", np.float64))


def _stored_layers(prepared: Any) -> StaticLayers:
    """:func:`static_layers` of ``prepared``'s scene, read from the on-disk store beside its
    entry (:meth:`~citygen.runner.scene_store.SceneStore.load_array`) when they are there,
    else computed and kept there (a map of :data:`STORE_LAYERS_FROM`
    cells or more): painting a city's 7,900 objects and its buildings cost a second of a reset
    from the store."""
    from citygen.runner import scene_store

    key = getattr(prepared, "store_key", None)
    occ = prepared.occupancy
    big = occ.heights.size >= STORE_LAYERS_FROM
    disk = scene_store.store() if key is not None and big else None
    if disk is not None:
        stored = [
            disk.load_array(key, f"{LAYERS_ENTRY}-{name}", check=lambda a, t=dtype: a.dtype == t)
            for name, dtype in _LAYER_FILES
        ]
        if all(a is not None for a in stored):
            elev, walk, cross, frame = stored
            if elev.shape == walk.shape == cross.shape and frame.shape == (3,):
                x0, y0, cell = frame.tolist()
                return StaticLayers(elev, walk, x0, y0, cell, cross)
    layers = static_layers(prepared.scene, occ, crossable=prepared.crossable)
    if disk is not None:
        frame = np.array([layers.x0, layers.y0, layers.cell])
        arrays = (layers.elevation, layers.walkable, layers.crossable, frame)
        for (name, _), array in zip(_LAYER_FILES, arrays, strict=True):
            disk.save_array(key, f"{LAYERS_ENTRY}-{name}", array)
    return layers


def _wide_layers_of(env: Any) -> StaticLayers:
    """:func:`_layers_of` pooled to the wide map's sub-sample spacing (:func:`pooled`) with
    5 m more margin (the wide window reaches 9.1 m from the robot), kept as those are."""
    base = _layers_of(env)
    k = max(1, round(WIDE_MAP[2] / 2 / base.cell))
    return _kept(env, "wide", lambda _: with_margin(pooled(base, k), 5.0))


def _agents_of(env: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    if env.crowd is None and env.traffic is None:
        return None
    xy, vel, radius = env.others()
    return (xy, radius, vel)


def observe_inside(env: Any, x: float, y: float, yaw: float) -> np.ndarray:
    """``obs["local_map_inside"]`` of a navigation environment at the robot's pose."""
    b = env.scene.bounds
    return _DEFAULT.inside(((b.min[0], b.min[1]), (b.max[0], b.max[1])), (x, y, yaw))


def observe(
    env: Any, x: float, y: float, yaw: float, ground: float, crossable: bool = False, motion: bool = False
) -> np.ndarray:
    """``obs["local_map"]`` of a navigation environment (:class:`~citygen.runner.envs.NavEnv`)
    at the robot's pose, with ``obs["local_map_crossable"]`` as a third channel when
    ``crossable`` and ``obs["local_map_motion"]`` as the last two when ``motion``; the
    scene's static layers are built on first use and kept as long as its compiled scene
    (:class:`~citygen.runner.scenes.Prepared`) lives."""
    return _DEFAULT(_layers_of(env), (x, y, yaw), ground, _agents_of(env), crossable, motion)


def observe_wide(env: Any, x: float, y: float, yaw: float) -> np.ndarray:
    """``obs["local_map_wide"]`` of a navigation environment at the robot's pose: the
    ``(1, H, W)`` crossable layer (:meth:`LocalMap.crossable`, moving agents' discs included)
    over the :data:`WIDE_MAP` window."""
    return _WIDE.crossable(_wide_layers_of(env), (x, y, yaw), _agents_of(env))
