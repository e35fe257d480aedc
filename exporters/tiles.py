"""Cutting a large scene into square tiles, each exported as its own file, with an index.

A city holds more than some consumers take in one body (PyBullet 3.2.7 loads the
15,000-link URDF of urban-tra-city in about 95 s and crashes freeing it). :func:`plan`
cuts the scene's bounds into a grid of tiles whose edges lie on the terrain grid's lines
(so every terrain tile lies in exactly one tile), and each :class:`Piece` is the scene
seen through one tile: its bounds, the terrain tiles inside it, the zones clipped to it,
the objects whose position lies in it (each in one tile only, even where it overhangs the
edge) and the terrain features that reach into it (a curb across a tile's edge is in both
tiles: a tile loaded alone has all of its ground). :func:`write_index` writes the JSON
index that lists every tile's file, grid cell and bounds.

Tiles are named ``<name>-tile-<row>-<col>`` (``row`` along +y, ``col`` along +x, from 0,
two digits at least) and all share the scene's world frame: load each file at the origin
and they fit together.

>>> from citygen.io import load_scene
>>> scene = load_scene("examples/street_corner.json")
>>> pieces = plan(scene, 8.0, [])  # 24 m x 24 m: 3 x 3 tiles
>>> [(p.row, p.col, p.box) for p in pieces][:2], sum(len(p.placements) for p in pieces)
([(0, 0, (0.0, 0.0, 8.0, 8.0)), (0, 1, (8.0, 0.0, 16.0, 8.0))], 7)
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely

from citygen.io import write_atomic
from citygen.spec.scene import Bounds, Scene

#: The ``format`` field of an index file.
INDEX_FORMAT = "citygen.tiles/1"


@dataclass(frozen=True)
class Piece:
    """The scene seen through one tile."""

    row: int
    col: int
    box: tuple[float, float, float, float]
    """``(x0, y0, x1, y1)`` in metres."""
    scene: Scene
    """The scene with its bounds set to the tile's box, its terrain cut to the tiles inside
    the box (and the features reaching into it) and its zones those that overlap it (not
    validated: a view, not a spec)."""
    zones: list
    """The shapes of ``scene.zones`` clipped to the box, in the same order."""
    zone_index: list[int]
    """Each of ``scene.zones``' index in the whole scene."""
    placements: list[int]
    """Indices (in the whole scene) of the objects whose position lies in the tile."""
    terrain_tiles: np.ndarray
    """Indices (in the whole scene's grid) of ``scene.terrain.tiles``, in their order."""

    def name(self, stem: str, width: int) -> str:
        return f"{stem}-tile-{self.row:0{width}d}-{self.col:0{width}d}"


def _edges(lo: float, hi: float, grid_lo: float | None, cells: int, cell: float, side: float) -> list[float]:
    """Tile edges along one axis: the bounds' ends and, inside them, lines every ``side`` m
    snapped to the terrain grid's lines (``grid_lo + k * cell``, ``cells`` of them) when
    there is a grid."""
    if grid_lo is None:
        n = max(1, math.ceil((hi - lo) / side - 1e-9))
        return [lo + (hi - lo) * k / n for k in range(n)] + [hi]
    step = max(1, round(side / cell))
    inner = [grid_lo + k * cell for k in range(step, cells, step)]
    return [lo, *(x for x in inner if lo < x < hi), hi]


def plan(scene: Scene, side: float, zones: Sequence[shapely.Geometry]) -> list[Piece]:
    """The scene cut into tiles of about ``side`` metres (row-major, rows along +y);
    ``zones`` are the zones' shapes (:func:`~citygen.exporters.ground.zone_polygons`)."""
    (bx0, by0), (bx1, by1) = scene.bounds.min, scene.bounds.max
    t = scene.terrain
    if t is None:
        xs, ys = _edges(bx0, bx1, None, 0, 0.0, side), _edges(by0, by1, None, 0, 0.0, side)
    else:
        s = t.tile_size
        xs = _edges(min(bx0, t.origin[0]), max(bx1, t.origin[0] + t.cols * s), t.origin[0], t.cols, s, side)
        ys = _edges(min(by0, t.origin[1]), max(by1, t.origin[1] + t.rows * s), t.origin[1], t.rows, s, side)
    cols, rows = len(xs) - 1, len(ys) - 1
    where = np.array([p.position[:2] for p in scene.placements], dtype=np.float64).reshape(-1, 2)
    pcol = np.clip(np.searchsorted(xs, where[:, 0], side="right") - 1, 0, cols - 1)
    prow = np.clip(np.searchsorted(ys, where[:, 1], side="right") - 1, 0, rows - 1)
    # A terrain feature lies in the tile of the grid cell under its centre (as an object, in
    # one tile only even where it overhangs the edge).
    feature_cell, reach = np.zeros(0, dtype=np.int64), np.zeros((0, 4))
    if t is not None and t.features:
        centres = np.array([f.center for f in t.features], dtype=np.float64)
        fc = np.clip(np.floor((centres[:, 0] - t.origin[0]) / t.tile_size), 0, t.cols - 1).astype(np.int64)
        fr = np.clip(np.floor((centres[:, 1] - t.origin[1]) / t.tile_size), 0, t.rows - 1).astype(np.int64)
        feature_cell = fr * t.cols + fc
        yaw = np.array([f.yaw for f in t.features])
        half_l, half_w = np.array([[f.length / 2, f.width / 2] for f in t.features]).T
        ex = np.abs(np.cos(yaw)) * half_l + np.abs(np.sin(yaw)) * half_w
        ey = np.abs(np.sin(yaw)) * half_l + np.abs(np.cos(yaw)) * half_w
        reach = np.c_[centres[:, 0] - ex, centres[:, 1] - ey, centres[:, 0] + ex, centres[:, 1] + ey]
    shapes = np.asarray(zones, dtype=object)
    tree = shapely.STRtree(shapes) if len(shapes) else None
    pieces = []
    for r in range(rows):
        for c in range(cols):
            box = (xs[c], ys[r], xs[c + 1], ys[r + 1])
            square = shapely.box(*box)
            hit = np.zeros(0, dtype=np.int64)
            if tree is not None:
                hit = np.sort(tree.query(square, predicate="intersects"))
            clipped = shapely.intersection(shapes[hit], square) if len(hit) else np.zeros(0, dtype=object)
            keep = [i for i, g in zip(hit.tolist(), clipped, strict=True) if g.area > 1e-9]
            shapes_kept = [g for g in clipped if g.area > 1e-9]
            terrain, ids, held = None, np.zeros(0, dtype=np.int64), None
            if t is not None:
                s = t.tile_size
                c0, c1 = (np.clip(np.round((np.array(box[0::2]) - t.origin[0]) / s), 0, t.cols)).astype(int)
                r0, r1 = (np.clip(np.round((np.array(box[1::2]) - t.origin[1]) / s), 0, t.rows)).astype(int)
                if c1 > c0 and r1 > r0:
                    ids = (np.arange(r0, r1)[:, None] * t.cols + np.arange(c0, c1)[None, :]).ravel()
                    own = np.isin(feature_cell, ids)
                    near = (reach[:, 0] < box[2]) & (reach[:, 2] > box[0]) & (reach[:, 1] < box[3])
                    near &= reach[:, 3] > box[1]
                    # Every feature reaching in: the ground of a tile loaded alone is whole.
                    held = (
                        tuple(t.features[i] for i in np.flatnonzero(own | near).tolist())
                        if t.features
                        else None
                    )
                    terrain = t.model_copy(
                        update={
                            "origin": (t.origin[0] + c0 * s, t.origin[1] + r0 * s),
                            "rows": int(r1 - r0),
                            "cols": int(c1 - c0),
                            "tiles": tuple(t.tiles[k] for k in ids.tolist()),
                            "features": held if t.features else t.features,
                        }
                    )
            view = scene.model_copy(
                update={
                    "bounds": Bounds(min=box[:2], max=box[2:]),
                    "terrain": terrain,
                    "zones": tuple(scene.zones[i] for i in keep),
                }
            )
            members = np.flatnonzero((prow == r) & (pcol == c)).tolist()
            pieces.append(Piece(r, c, box, view, shapes_kept, keep, members, ids))
    return pieces


def width(pieces: Sequence[Piece]) -> int:
    """Digits of the row and column numbers in tile names: at least two."""
    return max(2, len(str(max((max(p.row, p.col) for p in pieces), default=0))))


def write_index(path: Path, name: str, fmt: str, entries: list[dict]) -> Path:
    """Write the JSON index of a tiled export: the scene's name, the format, and one entry
    per tile (``file`` relative to the index, ``row``, ``col``, ``min``, ``max`` in metres,
    and whatever the exporter adds)."""
    doc = {"format": INDEX_FORMAT, "scene": name, "files": fmt, "tiles": entries}
    write_atomic(path, (json.dumps(doc, indent=1) + "\n").encode("utf-8"))
    return path


def entry(piece: Piece, file: str, **extra: object) -> dict:
    """One tile's index entry."""
    x0, y0, x1, y1 = (round(float(v), 6) for v in piece.box)
    return {"file": file, "row": piece.row, "col": piece.col, "min": [x0, y0], "max": [x1, y1], **extra}
