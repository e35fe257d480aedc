"""Which terrain tiles an embodiment can cross (:class:`~citygen.spec.task.Mobility`).

One rule for the generator, which keeps a task's start and goal connected over the ground
its robot can cross, and for the runner, whose planner and shortest-path metric move over
the same ground:

- flat ground: always;
- a slope: up to the robot's ``max_slope``;
- a stair: when the robot climbs stairs and the risers are at most its ``max_step``;
- rough ground: when no two points :data:`~citygen.spec.task.STEP_RUN` apart along x or y
  differ by more than its ``max_step`` (sampled four times finer than that run, with a
  10 % allowance for the peaks between samples);
- a terrain feature's rectangle: steps as stairs, a ramp as a slope of ``atan(rise /
  length)``; a landing's top is level ground, but its sides are vertical: along a side
  where it stands more than ``max_step`` above the ground beside it, a band
  (:func:`landing_rims`) is not crossed, so a raised landing (a raised sidewalk, a terrace)
  is reached over its steps or ramps, or from a landing beside it at its level.

>>> from citygen.spec.task import ROBOTS
>>> from citygen.spec.terrain import StairTile
>>> stair = StairTile(kind="stair", step_height=0.15, step_count=3)
>>> tile_crossable(stair, 2.5, ROBOTS["wheeled"]), tile_crossable(stair, 2.5, ROBOTS["quadruped"])
(False, True)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import Any

import numpy as np
import shapely
from shapely.geometry.base import BaseGeometry

from citygen.geometry.features import feature_mask, feature_polygon
from citygen.geometry.terrain import height_at, rough_slope_bound, tile_grid
from citygen.spec.task import STEP_RUN, Mobility
from citygen.spec.terrain import (
    FlatTile,
    LandingFeature,
    RampFeature,
    RoughTile,
    SlopeTile,
    StairTile,
    StepsFeature,
    Terrain,
)

#: Samples per :data:`STEP_RUN` when a rough tile's steps are measured.
_SAMPLES = 4
#: Allowance for the peaks of rough ground between samples.
_ALLOWANCE = 1.1
#: Depth (m) of a landing's rim; spacing (m) of the points a landing's sides are probed at,
#: and how far (m) outside the side the ground beside it is measured.
RIM, _PROBE_STEP, _PROBE_OUT = 0.05, 0.25, 0.03


@dataclass(frozen=True)
class Rim:
    """A band along a landing's side (an oriented rectangle, as a feature's)."""

    center: tuple[float, float]
    yaw: float
    length: float
    width: float


@lru_cache(maxsize=4096)
def rough_step(tile: RoughTile, tile_size: float) -> float:
    """The largest rise (m) between two points of a rough tile :data:`STEP_RUN` apart along x
    or y (sampled every ``STEP_RUN / 4``)."""
    g = np.linspace(0.0, tile_size, int(np.ceil(tile_size / STEP_RUN * _SAMPLES)) + 1)
    z = tile_grid(tile, tile_size, g, g)
    lag = _SAMPLES
    return float(max(np.abs(z[lag:] - z[:-lag]).max(), np.abs(z[:, lag:] - z[:, :-lag]).max()))


def _slope_crossable(tile: SlopeTile, tile_size: float, mobility: Mobility) -> bool:
    return tile.angle <= mobility.max_slope


def _stair_crossable(tile: StairTile, tile_size: float, mobility: Mobility) -> bool:
    return mobility.stairs and tile.step_height <= mobility.max_step


def _rough_crossable(tile: RoughTile, tile_size: float, mobility: Mobility) -> bool:
    # Most rough tiles are settled by the bound on their slope, without sampling: when
    # STEP_RUN times it (plus a relative 1e-6 and 1e-9 m for rounding) is within the
    # step, so is rough_step, and the answer is the same.
    bound = rough_slope_bound(tile, float(tile_size)) * STEP_RUN
    if (bound * (1 + 1e-6) + 1e-9) * _ALLOWANCE <= mobility.max_step:
        return True
    return rough_step(tile, float(tile_size)) * _ALLOWANCE <= mobility.max_step


def _always(tile: object, tile_size: float, mobility: Mobility) -> bool:
    return True


#: Whether a robot of a mobility crosses a tile, by the tile's class (the rules of the module
#: docstring), over every kind of :data:`citygen.geometry.tiles.TILE_KINDS`.
CROSSING: dict[type, Callable[[Any, float, Mobility], bool]] = {
    FlatTile: _always,
    SlopeTile: _slope_crossable,
    StairTile: _stair_crossable,
    RoughTile: _rough_crossable,
}


def tile_crossable(tile: object, tile_size: float, mobility: Mobility) -> bool:
    """Whether a robot of ``mobility`` can cross ``tile`` (see the module docstring)."""
    return CROSSING.get(type(tile), _always)(tile, tile_size, mobility)


def feature_crossable(feature: object, mobility: Mobility) -> bool:
    """Whether a robot of ``mobility`` can cross a terrain feature (see the module docstring)."""
    if isinstance(feature, StepsFeature):
        return mobility.stairs and feature.step_height <= mobility.max_step
    if isinstance(feature, RampFeature):
        return math.atan2(feature.rise, feature.length) <= mobility.max_slope
    return True  # a landing's top; its sides: landing_rims


def landing_rims(terrain: Terrain | None, mobility: Mobility, depth: float = RIM) -> list[Rim]:
    """The bands, ``depth`` metres deep, along the sides of ``terrain``'s landings where a
    landing stands more than the robot's ``max_step`` above the ground beside it (sampled
    every 0.25 m along each side, 3 cm outside it: a landing, a ramp's top or the steps
    beside it at its level leave no rim)."""
    if terrain is None or not terrain.features:
        return []
    high = [f for f in terrain.features if isinstance(f, LandingFeature) and f.rise > mobility.max_step]
    if not high:
        return []
    yaw = np.array([f.yaw for f in high])
    u = np.c_[np.cos(yaw), np.sin(yaw)]
    v = np.c_[-u[:, 1], u[:, 0]]
    centre = np.array([f.center for f in high], dtype=np.float64)
    hl = np.array([f.length for f in high])[:, None] / 2
    hw = np.array([f.width for f in high])[:, None] / 2
    # The four sides of each landing, counter-clockwise: start, direction, outward normal, length.
    start = np.stack([centre - u * hl - v * hw, centre + u * hl - v * hw, centre + u * hl + v * hw,
                      centre - u * hl + v * hw], axis=1).reshape(-1, 2)  # fmt: skip
    direction = np.stack([u, v, -u, -v], axis=1).reshape(-1, 2)
    normal = np.stack([-v, u, v, -u], axis=1).reshape(-1, 2)
    span = np.stack([2 * hl[:, 0], 2 * hw[:, 0], 2 * hl[:, 0], 2 * hw[:, 0]], axis=1).ravel()
    top = np.repeat([f.height + f.rise for f in high], 4)
    counts = np.maximum(1, np.ceil(span / _PROBE_STEP - 1e-9)).astype(np.int64)
    side = np.repeat(np.arange(len(span)), counts)
    offset = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    step = span / counts
    along = (offset + 0.5) * step[side]
    probes = start[side] + direction[side] * along[:, None] + normal[side] * _PROBE_OUT
    beside = height_at(terrain, probes[:, 0], probes[:, 1])
    cliff = np.flatnonzero(top[side] - beside > mobility.max_step + 1e-9)
    if not cliff.size:
        return []
    # Runs of consecutive cliff samples along one side.
    new = np.ones(cliff.size, dtype=bool)
    new[1:] = (np.diff(cliff) != 1) | (side[cliff[1:]] != side[cliff[:-1]])
    first = cliff[new]
    last = cliff[np.r_[np.flatnonzero(new)[1:] - 1, cliff.size - 1]]
    k = side[first]
    s0, s1 = offset[first] * step[k], (offset[last] + 1) * step[k]
    mid = start[k] + direction[k] * ((s0 + s1) / 2)[:, None] - normal[k] * depth / 2
    angle = np.arctan2(direction[k, 1], direction[k, 0])
    return [
        Rim((float(x), float(y)), float(a), float(n), depth)
        for x, y, a, n in zip(mid[:, 0], mid[:, 1], angle, s1 - s0, strict=True)
    ]


def blocked_features(terrain: Terrain | None, mobility: Mobility) -> list:
    """The features of ``terrain`` a robot of ``mobility`` cannot cross."""
    if terrain is None or not terrain.features:
        return []
    return [f for f in terrain.features if not feature_crossable(f, mobility)]


def blocked_tiles(terrain: Terrain | None, mobility: Mobility) -> np.ndarray:
    """bool ``(rows, cols)``: the tiles of ``terrain`` the robot cannot cross (row 0 at the
    grid's minimum y); ``(0, 0)`` without terrain."""
    if terrain is None:
        return np.zeros((0, 0), dtype=bool)
    memo: dict[int, bool] = {}
    out = np.zeros(terrain.rows * terrain.cols, dtype=bool)
    for i, tile in enumerate(terrain.tiles):
        ok = memo.get(id(tile))
        if ok is None:
            ok = memo[id(tile)] = tile_crossable(tile, terrain.tile_size, mobility)
        out[i] = not ok
    return out.reshape(terrain.rows, terrain.cols)


def blocked_ground(terrain: Terrain | None, mobility: Mobility) -> BaseGeometry:
    """The union of the squares of the tiles and the rectangles of the features the robot
    cannot cross (empty when none)."""
    blocked = blocked_tiles(terrain, mobility)
    features = [
        feature_polygon(f) for f in [*blocked_features(terrain, mobility), *landing_rims(terrain, mobility)]
    ]
    if not blocked.any() and not features:
        return shapely.Polygon()
    r, c = np.nonzero(blocked)
    s, (ox, oy) = terrain.tile_size, terrain.origin
    boxes = shapely.box(ox + c * s, oy + r * s, ox + (c + 1) * s, oy + (r + 1) * s)
    return shapely.union_all([*boxes, *features])


def blocked_cells(terrain: Terrain | None, mobility: Mobility, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """bool ``(len(ys), len(xs))``: whether each point of the grid ``xs`` (columns) by ``ys``
    (rows), in metres, lies on a tile or a feature the robot cannot cross (False off the
    tile grid)."""
    out = np.zeros((len(ys), len(xs)), dtype=bool)
    # A rim at least one and a half cells deep: no path between cell centres steps over it.
    pitch = max(
        float(np.median(np.diff(xs))) if len(xs) > 1 else 0.0,
        float(np.median(np.diff(ys))) if len(ys) > 1 else 0.0,
    )
    features = [*blocked_features(terrain, mobility), *landing_rims(terrain, mobility, max(RIM, 1.5 * pitch))]
    if features:
        out |= feature_mask(features, np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64))
    blocked = blocked_tiles(terrain, mobility)
    if not blocked.any():
        return out
    s, (ox, oy) = terrain.tile_size, terrain.origin
    c = np.floor((np.asarray(xs) - ox) / s).astype(np.int64)
    r = np.floor((np.asarray(ys) - oy) / s).astype(np.int64)
    cin = (c >= 0) & (c < terrain.cols)
    rin = (r >= 0) & (r < terrain.rows)
    inside = rin[:, None] & cin[None, :]
    rr = np.broadcast_to(np.clip(r, 0, terrain.rows - 1)[:, None], out.shape)
    cc = np.broadcast_to(np.clip(c, 0, terrain.cols - 1)[None, :], out.shape)
    out[inside] |= blocked[rr[inside], cc[inside]]
    return out
