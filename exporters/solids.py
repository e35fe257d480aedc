"""A scene's solids, built here once for every exporter: each zone with a ``height`` (a
building from its mapped footprint, :attr:`~citygen.spec.zones.Zone.height`) is its polygon,
holes cut out, extruded from the lowest ground under its outline
(:func:`~citygen.geometry.terrain.height_at` at its vertices) up ``height`` metres.

- :meth:`Solid.pieces`: convex pieces tiling it (boxes where a piece is a rectangle, else
  prisms; :func:`~citygen.exporters.pieces.flat_pieces`), for the formats whose readers collide
  a shape as its convex hull (MJCF, URDF): one hull of an L-shaped or courtyard building would
  fill its concave corner and its courtyard.
- :meth:`Solid.mesh`: one closed, outward triangle mesh (:func:`extrude`) for the pictures and
  visuals (GLB, HTML, USD, URDF's visual).

>>> from citygen.spec import Scene
>>> ell = [[0, 0], [10, 0], [10, 4], [4, 4], [4, 10], [0, 10]]
>>> scene = Scene.model_validate({"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [12, 12]},
...     "zones": [{"id": "b", "kind": "building", "height": 6.0, "polygon": ell}]})
>>> (solid,) = solids(scene)
>>> solid.bottom, solid.top, len(solid.pieces())
(0.0, 6.0, 2)
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.exporters.ground import polygon_parts, triangulate
from citygen.exporters.pieces import flat_pieces
from citygen.geometry.pieces import Pieces
from citygen.geometry.terrain import height_at
from citygen.spec.scene import Scene
from citygen.spec.zones import Zone


@dataclass(frozen=True)
class Solid:
    """One zone's solid: ``shape`` (its polygon, repaired if invalid) from ``bottom`` up to
    ``top`` (m); ``index`` is the zone's in ``$.zones``."""

    index: int
    zone: Zone
    shape: shapely.Geometry
    bottom: float
    top: float

    def pieces(self) -> Pieces:
        """Convex pieces tiling the solid (see the module docstring)."""
        return flat_pieces(self.shape, self.bottom, self.top)

    def mesh(self) -> tuple[np.ndarray, np.ndarray]:
        """The solid as one closed, outward triangle mesh: vertices ``(n, 3)``, faces ``(k, 3)``."""
        return extrude(self.shape, self.bottom, self.top)


def solids(scene: Scene, shapes: Sequence[shapely.Geometry] | None = None) -> list[Solid]:
    """The solids of ``scene``'s zones that have a height, in zone order; ``shapes`` are the
    zones' shapes if already made (:func:`~citygen.exporters.ground.zone_polygons`)."""
    out = []
    for i, zone in enumerate(scene.zones):
        if zone.height is None:
            continue
        shape = shapes[i] if shapes is not None else Polygon(zone.polygon, zone.holes)
        if not shape.is_valid:
            shape = shapely.make_valid(shape)
        ring = np.asarray(zone.polygon, dtype=np.float64)
        bottom = float(np.min(height_at(scene, ring[:, 0], ring[:, 1]))) + 0.0
        out.append(Solid(i, zone, shape, bottom, bottom + zone.height))
    return out


def extrude(geom: shapely.Geometry, bottom: float, top: float) -> tuple[np.ndarray, np.ndarray]:
    """A polygonal area (holes included) extruded from ``bottom`` to ``top`` (m): a closed,
    outward mesh, vertices ``(n, 3)`` and faces ``(k, 3)``."""
    verts, faces, count = [], [], 0
    for poly in polygon_parts(geom):
        xy, tri = triangulate(poly)
        n = len(xy)
        poly = shapely.geometry.polygon.orient(poly, 1.0)
        rings = [poly.exterior, *poly.interiors]
        sizes = [len(r.coords) - 1 for r in rings]
        start = np.cumsum([0, *sizes[:-1]])
        ring_i = np.concatenate([np.arange(s) + o for s, o in zip(sizes, start, strict=True)])
        nxt = np.concatenate([(np.arange(s) + 1) % s + o for s, o in zip(sizes, start, strict=True)])
        # np.stack and np.concatenate, not np.r_ / np.c_: the city's URDF extrudes some 30,000
        sides = np.concatenate(
            [np.stack([ring_i, nxt, nxt + n], 1), np.stack([ring_i, nxt + n, ring_i + n], 1)]
        )
        layer = np.empty((2 * n, 3))
        layer[:n, :2] = layer[n:, :2] = xy
        layer[:n, 2], layer[n:, 2] = bottom, top
        verts.append(layer)
        faces.append(np.concatenate([tri[:, ::-1], tri + n, sides]) + count)
        count += 2 * n
    if not verts:
        return np.zeros((0, 3)), np.zeros((0, 3), dtype=np.int64)
    return np.concatenate(verts), np.concatenate(faces)
