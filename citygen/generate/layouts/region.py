"""The ``region`` layout: the 10 m and 15 m Urban-Nav squares, small scenes without roads.

A walkable region (sidewalk, trail or plaza, one of ``region.walkable``) of one of four
shapes, drawn by ``region.shapes``' weights, lies against non-walkable ground (one of
``region.non_walkable`` per leftover piece: vegetation, roadway):

- **straight**: a path of ``region.path_width`` across the scene, along x or y;
- **l_turn**: from one edge to a corner point, then on to an adjacent edge, each arm
  running to the farther edge, so the path spans at least half the scene both ways (room
  for a task's start and goal);
- **crossing**: two paths crossing;
- **plaza**: the whole scene walkable, with up to three islands (squares or circles)
  of non-walkable ground.

The zones come from the ``ground`` stage's generator; there are no blocks.
"""

from __future__ import annotations

from typing import ClassVar

import numpy as np
import shapely
from shapely import affinity
from shapely.geometry import box

from citygen.errors import GenerationError
from citygen.generate.layouts.base import BaseLayout, Plan
from citygen.generate.zoning import GRID, QUAD_SEGS, Layer, arrange, polygons, to_zones
from citygen.seeding import stage_rng, uniform
from citygen.spec.config import GeneratorConfig, RegionConfig
from citygen.spec.scene import Bounds
from citygen.spec.zones import Zone


class Region(BaseLayout):
    """Stages 1 and 2: a region's zones (:func:`plan_region`); the later stages as :class:`BaseLayout`."""

    kind: ClassVar[str] = "region"

    @staticmethod
    def plan(bounds: Bounds, config: GeneratorConfig, seed: int) -> Plan:
        return Plan(zones=plan_region(bounds, config.region, stage_rng(seed, "ground"), seed=seed))


def _region_shape(shape: str, w: float, h: float, rng: np.random.Generator, cfg: RegionConfig):
    """The walkable region of a ``w`` x ``h`` scene with its minimum corner at the origin."""
    width = min(uniform(rng, cfg.path_width), 0.6 * min(w, h))
    if shape == "plaza":
        region = box(0, 0, w, h)
        islands = []
        for _ in range(int(rng.integers(1, 4)) * 8):
            if len(islands) >= 3:
                break
            radius = uniform(rng, (0.5, 0.12 * min(w, h)))
            cx, cy = rng.uniform(radius + 1.0, w - radius - 1.0), rng.uniform(radius + 1.0, h - radius - 1.0)
            if rng.random() < 0.5:
                island = box(cx - radius, cy - radius, cx + radius, cy + radius)
            else:
                island = shapely.Point(cx, cy).buffer(radius, quad_segs=QUAD_SEGS)
            if all(island.distance(other) > 1.5 for other in islands):
                islands.append(island)
        return region.difference(shapely.union_all(islands))

    def band(along_x: bool, at: float):
        half = width / 2
        return box(0, at - half, w, at + half) if along_x else box(at - half, 0, at + half, h)

    along_x = bool(rng.random() < 0.5)
    cy = rng.uniform(0.3, 0.7) * h
    cx = rng.uniform(0.3, 0.7) * w
    if shape == "straight":
        return band(along_x, cy if along_x else cx)
    if shape == "crossing":
        return band(True, cy).union(band(False, cx))
    # An L-turn: from one edge to the corner point, then on to an adjacent edge; each arm
    # runs to the farther edge, so the path spans at least half the scene both ways (room
    # for a task's start and goal).
    half = width / 2
    if cx < w / 2:
        horizontal = box(cx - half, cy - half, w, cy + half)
    else:
        horizontal = box(0, cy - half, cx + half, cy + half)
    if cy < h / 2:
        vertical = box(cx - half, cy - half, cx + half, h)
    else:
        vertical = box(cx - half, 0, cx + half, cy + half)
    return horizontal.union(vertical)


def plan_region(
    bounds: Bounds, cfg: RegionConfig, rng: np.random.Generator, *, seed: int | None = None
) -> tuple[Zone, ...]:
    """Zones of a small scene without roads: a walkable region against non-walkable ground."""
    (x0, y0), (x1, y1) = bounds.min, bounds.max
    names = ("straight", "l_turn", "crossing", "plaza")
    weights = np.array([getattr(cfg.shapes, n) for n in names], dtype=float)
    shape = names[int(rng.choice(len(names), p=weights / weights.sum()))]
    region = _region_shape(shape, x1 - x0, y1 - y0, rng, cfg)
    region = affinity.translate(region, x0, y0)
    if shape == "plaza" and "plaza" in cfg.walkable:
        kind = "plaza"
    else:
        kind = str(cfg.walkable[int(rng.integers(len(cfg.walkable)))])
    scene = box(x0, y0, x1, y1)
    layers: list[Layer] = [(kind, None, region)]
    for part in polygons(shapely.difference(scene, region, grid_size=GRID)):
        layers.append((str(cfg.non_walkable[int(rng.integers(len(cfg.non_walkable)))]), None, part))
    pieces = arrange(scene, layers)
    if not pieces:
        raise GenerationError("ground", seed, "the region layout left no ground")
    return to_zones(pieces)
