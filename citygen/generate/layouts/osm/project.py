"""From longitude and latitude to a real place's metres: a transverse Mercator centred on the box.

The scene's x runs east and y north, in metres, the box's south-west corner at the origin; the
scene's size is the box's rounded up to whole :data:`TILE` metres (so the terrain's tiles fit it
exactly), reaching a little past the box's east and north edges.
A transverse Mercator centred on the box (pyproj, PROJ's ``tmerc``) keeps scale within a few
parts per million across the 2 km a scene spans, so lengths and areas on the map are lengths
and areas in the scene. The PROJ string (:attr:`Projection.proj`) is written into the scene's
``meta.source``: ``pyproj.Transformer.from_crs("EPSG:4326", proj, always_xy=True)`` maps any
point of the map into the scene.

>>> p = Projection.for_box((11.0, 48.0, 11.01, 48.005))
>>> [round(v, 1) for v in p.size], [round(float(v), 1) for v in p.xy([11.0], [48.0])[0]]
([750.0, 560.0], [-0.0, 0.0])
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

#: The scene's sides are whole multiples of this (m): the ``osm`` layout's terrain tile.
TILE = 10.0


@dataclass(frozen=True)
class Projection:
    """The projection of one box ``(west, south, east, north)``: its PROJ string and size."""

    proj: str
    size: tuple[float, float]
    """Width (east-west) and depth (south-north) of the scene, in metres: the box's, rounded up
    to whole :data:`TILE` metres."""

    @staticmethod
    def for_box(bbox: tuple[float, float, float, float]) -> Projection:
        """A transverse Mercator centred on ``bbox``, offset so its south-west corner is (0, 0)."""
        from pyproj import Transformer  # 0.1 s to import: only where a real place is made

        west, south, east, north = bbox
        lon0, lat0 = (west + east) / 2, (south + north) / 2
        centred = f"+proj=tmerc +lat_0={lat0!r} +lon_0={lon0!r} +k=1 +x_0=0 +y_0=0 +ellps=WGS84 +units=m"
        t = Transformer.from_crs("EPSG:4326", centred, always_xy=True)
        (xw, xe), _ = t.transform([west, east], [lat0, lat0])
        _, (ys, yn) = t.transform([lon0, lon0], [south, north])
        width, depth = round(float(xe - xw), 3), round(float(yn - ys), 3)
        proj = centred.replace("+x_0=0 +y_0=0", f"+x_0={width / 2!r} +y_0={depth / 2!r}")
        size = (math.ceil(width / TILE - 1e-9) * TILE, math.ceil(depth / TILE - 1e-9) * TILE)
        return Projection(proj, size)

    @cached_property
    def _transformer(self):
        from pyproj import Transformer

        return Transformer.from_crs("EPSG:4326", self.proj, always_xy=True)

    def xy(self, lon, lat) -> np.ndarray:
        """Scene ``(n, 2)`` metres of the points ``lon``, ``lat`` (degrees)."""
        x, y = self._transformer.transform(np.asarray(lon, dtype=float), np.asarray(lat, dtype=float))
        return np.column_stack([np.atleast_1d(x), np.atleast_1d(y)])
