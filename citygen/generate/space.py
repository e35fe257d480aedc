"""Free space on walkable ground: where a disc of a given radius can stand and move.

The task, placement and agent stages all ask the same questions: which walkable
ground a body of radius ``r`` can reach (the walkable zones shrunk by ``r``, minus
the objects grown by ``r``), which connected piece a point is in, and a uniform
random point in a piece. A connected piece of that shrunk free space is exactly
the set of centre positions a disc can move between without touching an object or
leaving walkable ground, so "start and goal in one piece" means "a path exists".
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence

import numpy as np
import scipy.ndimage
import shapely
from shapely.geometry import LineString, Point, Polygon
from shapely.geometry.base import BaseGeometry

from citygen.geometry import raster
from citygen.geometry.traversable import blocked_ground
from citygen.spec.surfaces import WALKABLE_ZONES
from citygen.spec.task import Mobility
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

GRID = 1e-3
"""Precision (m) of the unions, as in the ground stage that tiles the zones."""


def zone_polygon(zone: Zone) -> Polygon:
    return Polygon(zone.polygon, zone.holes)


def walkable_ground(zones: Sequence[Zone], bounds: Sequence[float]) -> BaseGeometry:
    """The union of the walkable zones; a scene without zones is walkable everywhere."""
    if not zones:
        return shapely.box(*bounds)
    walk = [zone_polygon(z) for z in zones if z.kind in WALKABLE_ZONES]
    return shapely.union_all(walk, grid_size=GRID) if walk else Polygon()


_SHRUNK: dict[tuple[int, float], tuple[BaseGeometry, BaseGeometry]] = {}
_SHRUNK_KEEP = 8


def shrunk(ground: BaseGeometry, radius: float) -> BaseGeometry:
    """``ground`` shrunk by ``radius`` (m): where the centre of a disc of that radius stays on it.

    The task and placement stages ask this of the same walkable ground with the robot's
    clearance, so the last few answers are kept, by the ground's identity (geometries are
    immutable, and each entry holds its ground, so an identity is never reused while kept).
    """
    if radius <= 0:
        return ground
    key = (id(ground), radius)
    hit = _SHRUNK.get(key)
    if hit is not None and hit[0] is ground:
        return hit[1]
    out = ground.buffer(-radius, quad_segs=4)
    _SHRUNK[key] = (ground, out)
    for old in list(_SHRUNK)[:-_SHRUNK_KEEP]:  # oldest first
        _SHRUNK.pop(old, None)
    return out


def free_space(ground: BaseGeometry, obstacles: Iterable[BaseGeometry], radius: float) -> BaseGeometry:
    """Where the centre of a disc of ``radius`` can be: ``ground`` shrunk by ``radius``
    minus every obstacle grown by ``radius``."""
    free = shrunk(ground, radius)
    grown = np.asarray(list(obstacles), dtype=object)
    if radius > 0:
        grown = shapely.buffer(grown, radius, quad_segs=4)
    if len(grown):
        free = shapely.difference(free, shapely.union_all(grown))
    return free


def pieces(geometry: BaseGeometry) -> list[Polygon]:
    """The connected polygons of a geometry, largest first (ties by position, for determinism)."""
    polys = [g for g in shapely.get_parts(geometry) if isinstance(g, Polygon) and g.area > 1e-9]
    return sorted(polys, key=lambda p: (-round(p.area, 9), p.bounds))


class Sampler:
    """Uniform random points in a polygon, from an area-weighted triangulation.

    The triangles' corners are read straight from the triangulation (no shapely object per
    triangle: a city's free space has tens of thousands) and their areas computed as GEOS
    computes a ring's area (:func:`ring_areas`), so the draws equal those of
    ``shapely.area(shapely.get_parts(triangles))`` to the bit.
    """

    def __init__(self, polygon: BaseGeometry):
        coords = shapely.get_coordinates(shapely.constrained_delaunay_triangles(polygon))
        rings = coords.reshape(-1, 4, 2)  # each triangle a closed ring of 4 points
        areas = ring_areas(rings)
        keep = areas > 0
        rings, areas = rings[keep], areas[keep]
        self.area = float(areas.sum())
        """Area (m²) of the polygon, as the sum of its triangles'."""
        self._corners = rings[:, :3]
        self._cumulative = np.cumsum(areas) / areas.sum() if len(areas) else areas

    def __bool__(self) -> bool:
        return self.area > 0

    def point(self, rng: np.random.Generator) -> tuple[float, float]:
        """One uniform point (m), rounded to the millimetre; draws three uniforms from ``rng``."""
        cumulative = self._cumulative
        k = int(cumulative.searchsorted(rng.random(), side="right"))
        if k >= len(cumulative):
            k = len(cumulative) - 1
        (ax, ay), (bx, by), (cx, cy) = self._corners[k].tolist()
        u, v = rng.random(2).tolist()
        if u + v > 1.0:
            u, v = 1.0 - u, 1.0 - v
        # The same operations, in the same order, as numpy's a + u * (b - a) + v * (c - a).
        x = ax + u * (bx - ax) + v * (cx - ax)
        y = ay + u * (by - ay) + v * (cy - ay)
        return (round(x, 3) + 0.0, round(y, 3) + 0.0)


def ring_areas(rings: np.ndarray) -> np.ndarray:
    """Areas (m²) of closed rings of 4 points (triangles), shape ``(n, 4, 2)``, computed as GEOS's
    ``Area::ofRing`` does (shoelace relative to the first x, summed in ring order, halved),
    so each equals ``shapely.area`` of the triangle to the bit."""
    x0 = rings[:, 0, 0]
    y = rings[:, :, 1]
    s = (rings[:, 1, 0] - x0) * (y[:, 0] - y[:, 2])
    s = s + (rings[:, 2, 0] - x0) * (y[:, 1] - y[:, 3])
    return np.abs(s / 2.0)


def far_pair(
    piece: Polygon, sampler: Sampler, rng: np.random.Generator, min_distance: float, tries: int = 64
) -> tuple[tuple[float, float], tuple[float, float]] | None:
    """Two points of ``piece`` at least ``min_distance`` apart (straight line, so at least
    as far along any path), or None after ``tries`` draws of each end."""
    for _ in range(tries):
        a = sampler.point(rng)
        if not piece.covers(Point(a)):
            continue
        for _ in range(8):
            b = sampler.point(rng)
            if math.dist(a, b) >= min_distance and piece.covers(Point(b)):
                return a, b
    return None


def straighten(points: Sequence[tuple[float, float]], free: BaseGeometry) -> list[tuple[float, float]]:
    """The fewest of ``points`` (first and last kept) such that the straight legs between
    them stay inside ``free``: a grid path turned into waypoints without cutting corners."""
    if len(points) <= 2:
        return list(points)
    shapely.prepare(free)
    out, i = [points[0]], 0
    while i < len(points) - 1:
        j = len(points) - 1
        while j > i + 1 and not free.covers(LineString([points[i], points[j]])):
            j = (i + 1 + j) // 2 if j - i > 8 else j - 1
        out.append(points[j])
        i = j
    return out


def cell_groups(piece: Polygon, res: float) -> tuple[raster.Grid, np.ndarray]:
    """The piece's cells of ``res`` metres whose centres keep half a diagonal inside it (so a
    straight step between neighbouring centres never leaves it), labelled by 8-connected
    group (0: not inside)."""
    x0, y0, x1, y1 = piece.bounds
    grid = raster.Grid.covering((x0 - res, y0 - res, x1 + res, y1 + res), res)
    labels, _ = raster.components(raster.mask(grid, piece.buffer(-0.75 * res, quad_segs=4)))
    return grid, labels


def grid_path(
    piece: Polygon, start: tuple[float, float], goal: tuple[float, float]
) -> list[tuple[float, float]] | None:
    """A walkable path from ``start`` to ``goal`` inside ``piece``: the shortest 8-connected path
    over cells (at most 0.5 m) whose centres keep half a diagonal inside it, so straight steps
    between neighbours stay inside; it runs from the cell nearest ``start`` to the cell
    nearest ``goal`` among those connected to it (a neck narrower than a cell can split the
    grid where the piece itself is connected), then is straightened. None on an empty grid."""
    x0, y0, x1, y1 = piece.bounds
    grid, labels = cell_groups(piece, min(0.5, max(0.1, math.sqrt((x1 - x0) * (y1 - y0) / 4e6))))
    if not labels.any():
        return None
    _, (rows, cols) = scipy.ndimage.distance_transform_edt(labels == 0, return_indices=True)
    a = grid.cell(*start)
    a = (int(rows[a]), int(cols[a]))
    mine = labels == labels[a]
    _, (rows, cols) = scipy.ndimage.distance_transform_edt(~mine, return_indices=True)
    b = grid.cell(*goal)
    b = (int(rows[b]), int(cols[b]))
    cells = raster.shortest_path(mine, a, b)
    if cells is None:
        return None
    return straighten([start, *(grid.centre(c) for c in cells), goal], piece)


def passable_ground(ground: BaseGeometry, terrain: Terrain | None, mobility: Mobility) -> BaseGeometry:
    """``ground`` less the terrain tiles a robot of ``mobility`` cannot cross
    (:func:`citygen.geometry.traversable.blocked_ground`)."""
    blocked = blocked_ground(terrain, mobility)
    if blocked.is_empty:
        return ground
    return shapely.difference(ground, blocked, grid_size=GRID)


def connects(ground: BaseGeometry, radius: float, a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether a disc of ``radius`` (m) can move on ``ground`` from ``a`` to ``b``: both in
    one connected piece of the ground shrunk by the radius."""
    for piece in pieces(free_space(ground, (), radius)):
        if piece.covers(Point(a)):
            return bool(piece.covers(Point(b)))
    return False
