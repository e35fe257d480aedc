"""Collision ground as convex pieces, for the formats whose readers collide every shape as
its convex hull: the URDF (SAPIEN, Genesis, Isaac Sim's importer) and the MJCF without
heightfields (``terrain="convex"``, for Genesis).

- Flat ground: each polygonal area cut into convex pieces
  (:func:`~citygen.geometry.convex.convex_pieces`), a box where a piece is a rectangle, else
  a prism (:func:`flat_pieces`).
- Terrain tiles: :func:`~citygen.geometry.pieces.tile_pieces`: boxes for flat tiles and
  stairs, prisms for slopes, tilted boxes within a tolerance of ``height_at`` for rough
  tiles; the tolerance is :data:`~citygen.geometry.pieces.ROUGH_TOLERANCE` unless the scene's
  rough tiles would then take more than :data:`PIECE_BUDGETS` pieces, when it is raised
  (:func:`tolerance_option`, one :class:`~citygen.exporters.ExportWarning` saying to what).
- The apron: four boxes :data:`APRON` metres wide around the scene at ``z = 0``
  (:func:`apron_boxes`), so a body rolling off the scene's edge stays on the ground.
"""

from __future__ import annotations

import math
import warnings
from types import MappingProxyType
from typing import Any

import numpy as np
import shapely

from citygen.errors import ExportError
from citygen.exporters import ExportWarning
from citygen.exporters.options import AUTO
from citygen.geometry.convex import as_rectangle, convex_pieces, polygons
from citygen.geometry.pieces import MAX_SAMPLES, ROUGH_TOLERANCE, SAMPLES_PER_SCALE, Pieces, tile_pieces
from citygen.spec.scene import Scene
from citygen.spec.terrain import RoughTile

#: Width (m) of the flat ground around a scene (the MJCF's ``apron`` default too).
APRON = 20.0
#: Most pieces the rough tiles of a scene may take before their tolerance is raised: in one
#: URDF file (a city's tiles: all together, :data:`TILED_PIECE_BUDGET`) and in an MJCF without
#: heightfields. About what SAPIEN and Genesis load in seconds on the CPU.
PIECE_BUDGETS = MappingProxyType({"urdf": 100_000, "mjcf": 200_000})
TILED_PIECE_BUDGET = 1_000_000
#: Pieces a rough tile of side ``s``, amplitude ``A`` and wavelength ``L`` takes at tolerance
#: ``t``, about: ``PIECES_PER_CURVATURE * (s / L)^2 * A / t`` (at least 1, and 1 where ``A <= t``;
#: fitted, above most, to urban-tra-standard's rough tiles at 1 cm).
PIECES_PER_CURVATURE = 2.5
#: Tolerances (m) tried in turn when the default one would exceed a budget.
TOLERANCES = (0.01, 0.015, 0.02, 0.03, 0.05, 0.08, 0.12, 0.2, 0.5)


def flat_pieces(area: shapely.Geometry, bottom: float, top: float) -> Pieces:
    """Flat ground over ``area`` (a shapely geometry, m) from ``bottom`` up to ``top`` as convex
    pieces: a box where a piece is a rectangle (yawed if need be), else a prism."""
    boxes, prisms = [], []
    for poly in polygons(area):
        for ring in convex_pieces(poly):
            rect = as_rectangle(ring)
            if rect is None:
                prisms.append(np.c_[ring, np.full(len(ring), top)])
                continue
            (cx, cy), length, width, yaw = rect
            boxes.append(
                [[cx, cy, (top + bottom) / 2], [length / 2, width / 2, (top - bottom) / 2], [0, 0, yaw]]
            )
    return Pieces(np.array(boxes, dtype=np.float64).reshape(-1, 3, 3), tuple(prisms), bottom)


def apron_boxes(scene: Scene, width: float, bottom: float, clip: Any = None) -> np.ndarray:
    """Four boxes ``width`` m wide around the scene's bounds and terrain grid, from
    ``bottom`` up to ``z = 0`` (:class:`~citygen.geometry.pieces.Pieces` box rows); none for
    a width of 0. With ``clip`` (a tile's ``(x0, y0, x1, y1)``), only the apron beside it."""
    if width <= 0:
        return np.zeros((0, 3, 3))
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    t = scene.terrain
    if t is not None:
        x0, y0 = min(x0, t.origin[0]), min(y0, t.origin[1])
        x1, y1 = max(x1, t.origin[0] + t.cols * t.tile_size), max(y1, t.origin[1] + t.rows * t.tile_size)
    m = width
    rects = [
        (x0 - m, y0 - m, x1 + m, y0),
        (x0 - m, y1, x1 + m, y1 + m),
        (x0 - m, y0, x0, y1),
        (x1, y0, x1 + m, y1),
    ]
    if clip is not None:  # the tile's box, grown by the apron on the sides where it meets the scene's edge
        c0, d0, c1, d1 = clip
        c0, d0 = c0 - m * (c0 <= x0 + 1e-9), d0 - m * (d0 <= y0 + 1e-9)
        c1, d1 = c1 + m * (c1 >= x1 - 1e-9), d1 + m * (d1 >= y1 - 1e-9)
        rects = [(max(a, c0), max(b, d0), min(c, c1), min(d, d1)) for a, b, c, d in rects]
        rects = [r for r in rects if r[2] - r[0] > 1e-9 and r[3] - r[1] > 1e-9]
    return np.array(
        [[[(a + c) / 2, (b + d) / 2, bottom / 2], [(c - a) / 2, (d - b) / 2, -bottom / 2], [0, 0, 0]]
         for a, b, c, d in rects]
    ).reshape(-1, 3, 3)  # fmt: skip


def _estimate(tile: RoughTile, s: float, tolerance: float) -> float:
    if tile.amplitude <= tolerance:  # one level box
        return 1.0
    samples = min(max(math.ceil(s * SAMPLES_PER_SCALE / tile.scale), 2), MAX_SAMPLES)
    guess = PIECES_PER_CURVATURE * (s / tile.scale) ** 2 * tile.amplitude / tolerance
    return float(np.clip(guess, 1.0, samples * samples))


def estimated_pieces(scene: Scene, tolerance: float, tiles: Any = None) -> float:
    """About how many pieces the rough tiles (of ``tiles``, indices; default all) take at
    ``tolerance`` (m); tiles alike are counted once (an exporter builds them once)."""
    t = scene.terrain
    if t is None:
        return 0.0
    chosen = range(len(t.tiles)) if tiles is None else tiles
    rough = {t.tiles[int(k)] for k in chosen if isinstance(t.tiles[int(k)], RoughTile)}
    return sum(_estimate(x.model_copy(update={"height": 0.0}), t.tile_size, tolerance) for x in rough)


def tolerance_option(value: Any, scene: Scene, fmt: str, budget: int) -> float:
    """The rough tiles' tolerance (m): ``value`` when a positive number; for :data:`AUTO` (or
    None) :data:`ROUGH_TOLERANCE`, or the first of :data:`TOLERANCES` whose pieces fit
    ``budget``, with one :class:`ExportWarning` saying so."""
    if value is None or value == AUTO:
        for tol in TOLERANCES:
            if estimated_pieces(scene, tol) <= budget:
                break
        if tol != ROUGH_TOLERANCE:
            rough = sum(isinstance(x, RoughTile) for x in scene.terrain.tiles)
            warnings.warn(ExportWarning(
                f"$.terrain: {fmt.upper()} lays the {rough} rough tiles as convex pieces within "
                f"{tol * 100:g} cm of height_at (not {ROUGH_TOLERANCE * 100:g} cm) to stay within "
                f"{budget:,} pieces; pass tolerance= (citygen export --piece-tolerance) for another"
            ), stacklevel=3)  # fmt: skip
        return tol
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not (math.isfinite(value) and value > 0)
    ):
        raise ExportError(
            f"{fmt} export: expected a positive number of metres for 'tolerance', got {value!r}"
        )
    return float(value)


def terrain_pieces(scene: Scene, tiles: Any, floor: float, tolerance: float) -> dict[int, Pieces]:
    """The pieces of each terrain tile in ``tiles`` (indices) in its local frame, tiles alike
    built once (:func:`~citygen.geometry.pieces.tile_pieces`)."""
    t = scene.terrain
    built: dict[Any, Pieces] = {}
    out = {}
    for k in tiles:
        tile = t.tiles[int(k)]
        key = tile.model_copy(update={"material": None, "friction": None})
        if key not in built:
            built[key] = tile_pieces(tile, t.tile_size, floor=floor, tolerance=tolerance)
        out[int(k)] = built[key]
    return out
