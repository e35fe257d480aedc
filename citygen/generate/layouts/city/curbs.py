"""Curbs of a city (part of stage 3 for ``layout = "city"``): raised sidewalks, curb ramps.

A city's roadway and crosswalks are at street level; its sidewalks stand a curb's height
above them (``CURB``: 12-15 cm, one height per city). Both are terrain features
(:mod:`citygen.spec.terrain`), so every consumer of the terrain sees them:

- **sidewalk slabs** (``curb-<k>``): :class:`~citygen.spec.terrain.LandingFeature` s that
  raise the sidewalks and their curbs by the curb's height. The sidewalks' outline (curved at
  corners and roundabouts) is covered by axis-aligned rectangles (:func:`rectangles`): slabs
  between the outline's vertices, at most :data:`SLAB` deep where the outline is not straight
  along y, so the raised ground follows a curve to within a few centimetres;
- **curb ramps** (``curb-ramp-<k>``): at each end of every crosswalk a
  :class:`~citygen.spec.terrain.RampFeature` as wide as the crosswalk, rising at 1:12 from the
  crosswalk into the sidewalk; the slabs leave room for it, so the robot on wheels gets from
  the sidewalk onto the crosswalk down the ramp (a crosswalk end where the sidewalk has no
  room for a ramp and :data:`TOP` of sidewalk beyond it keeps its curb). Where something
  must stand beside the crosswalk (a real place's mapped tree, ``avoid``), the ramp narrows
  to the side away from it, down to :data:`NARROWEST`; narrower, the end keeps its curb.

The streets of a city run along x and y, so the slabs are few (a straight sidewalk is one slab
per 100 m); a street at another angle would be covered in a staircase of thin slabs.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry.base import BaseGeometry

from citygen.geometry.features import feature_polygon
from citygen.seeding import uniform
from citygen.spec.base import quantize
from citygen.spec.terrain import LandingFeature, RampFeature
from citygen.spec.zones import Zone

#: Curb height (m): the sidewalk above the roadway.
CURB = (0.12, 0.15)
#: Curb ramps rise at 1:12 (accessibility codes) ...
RAMP_GRADE = 1.0 / 12.0
#: ... to a landing at least this deep (m) on the sidewalk.
TOP = 0.9
#: Narrowest curb ramp (m) left where it gives way to something standing beside it.
NARROWEST = 1.0
#: Deepest sliver (m) a slab leaves along a slanting or curved part of the outline.
SLAB = 0.5
#: Closest (m) two slab boundaries are (a feature is at least 5 cm deep).
BREAK = 0.06
#: Slabs one above the other whose sides differ by at most this (m) are one slab.
MERGE = 0.02
#: Longest side (m) of a slab (a feature's sides are at most 100 m).
LONGEST = 100.0
#: Thinnest slab (m) kept: thinner slivers stay at street level.
THINNEST = 0.05


def curb_features(
    zones: Sequence[Zone], rng: np.random.Generator, avoid: Sequence[tuple[float, float, float]] = ()
) -> tuple[list, list[Polygon]]:
    """The city's curb ramps, then its sidewalk slabs (see the module docstring), and the
    ramps' rectangles. Each feature stands at street level (``height`` 0). ``avoid`` are
    discs ``(x, y, radius)`` (m) no ramp or its landing may reach."""
    polys = [Polygon(z.polygon, z.holes) for z in zones]
    side = _union([p for p, z in zip(polys, zones, strict=True) if z.kind in ("sidewalk", "curb")])
    walks = _union([p for p, z in zip(polys, zones, strict=True) if z.kind == "crosswalk"])
    # Curbs around a roundabout's island or a median with no sidewalk stay low.
    sidewalks = shapely.STRtree([p for p, z in zip(polys, zones, strict=True) if z.kind == "sidewalk"])
    parts = shapely.get_parts(side)
    side = shapely.multipolygons([p for p in parts if len(sidewalks.query(p, predicate="intersects"))])
    shapely.prepare(side)
    height = quantize(uniform(rng, CURB))
    length = math.ceil(height / RAMP_GRADE * 1e4) / 1e4
    ramps: list[RampFeature] = []
    shapes: list[Polygon] = []
    near: dict[tuple[int, int], list[Polygon]] = {}  # the ramps by 10 m squares
    for walk in shapely.get_parts(walks):
        for centre, yaw, width in _ends(walk, side):
            c, s = math.cos(yaw), math.sin(yaw)
            if len(avoid):
                centre, width = _beside(centre, yaw, width, length + TOP, avoid)
                if width < NARROWEST:
                    continue
            ramp = RampFeature(
                id=f"curb-ramp-{len(ramps) + 1}", kind="ramp",
                center=(quantize(centre[0] + c * length / 2), quantize(centre[1] + s * length / 2)),
                yaw=quantize(yaw), length=length, width=quantize(width), rise=height, material="concrete",
            )  # fmt: skip
            shape = feature_polygon(ramp)
            # The ramp and a landing beyond its top lie on the sidewalk.
            reach = feature_polygon(
                ramp.model_copy(
                    update={
                        "center": (centre[0] + c * (length + TOP) / 2, centre[1] + s * (length + TOP) / 2),
                        "length": length + TOP,
                    }
                )
            )
            if not side.contains(reach.buffer(-0.02, join_style="mitre")):
                continue  # no room in the sidewalk: this end keeps its curb
            x0, y0, x1, y1 = shape.bounds
            keys = [
                (i, j)
                for i in range(int(x0 // 10), int(x1 // 10) + 1)
                for j in range(int(y0 // 10), int(y1 // 10) + 1)
            ]
            if any(shape.intersects(other) for key in keys for other in near.get(key, ())):
                continue
            ramps.append(ramp)
            shapes.append(shape)
            for key in keys:
                near.setdefault(key, []).append(shape)
    # The slabs overlap a ramp's sides and top by 5 mm (no crack at street level between
    # them); the hole reaches past its foot into the crosswalk (no sliver of slab there).
    holes = [
        feature_polygon(
            r.model_copy(
                update={
                    "center": (
                        r.center[0] - math.cos(r.yaw) * 0.0275,
                        r.center[1] - math.sin(r.yaw) * 0.0275,
                    ),
                    "length": r.length + 0.045,
                    "width": r.width - 0.01,
                }
            )
        )
        for r in ramps
    ]
    raised = shapely.difference(side, shapely.union_all(holes)) if holes else side
    slabs = []
    for cx, cy, yaw, size_x, size_y in rectangles(raised):
        slab = LandingFeature(
            id=f"curb-{len(slabs) + 1}", kind="landing", center=(quantize(cx), quantize(cy)),
            yaw=quantize(yaw), length=quantize(size_x), width=quantize(size_y), rise=height,
            material="concrete",
        )  # fmt: skip
        slabs.append(slab)
    return [*ramps, *slabs], shapes


def _beside(centre, yaw: float, width: float, depth: float, avoid) -> tuple[tuple[float, float], float]:
    """The end of a crosswalk (``centre``, ``width``, m) narrowed so that a ramp and landing
    ``depth`` deep into the sidewalk (heading ``yaw``) reach none of the discs ``avoid``: the
    widest span of the end clear of them, its middle and width (0 when none is)."""
    d = np.array([math.cos(yaw), math.sin(yaw)])
    n = np.array([-d[1], d[0]])
    lo, hi = -width / 2, width / 2
    for x, y, r in avoid:
        rel = np.array([x, y]) - np.asarray(centre)
        u, v = float(rel @ d), float(rel @ n)
        if u < -r or u > depth + r or v < lo - r or v > hi + r:
            continue
        if hi - (v + r) >= (v - r) - lo:
            lo = max(lo, v + r)
        else:
            hi = min(hi, v - r)
        if hi <= lo:
            return centre, 0.0
    mid = np.asarray(centre) + n * (lo + hi) / 2
    return (float(mid[0]), float(mid[1])), hi - lo


def _union(polys: list[Polygon]) -> BaseGeometry:
    """The union of zones: they tile the scene, so a coverage union joins them (far quicker
    than a union), unless two meet without sharing their vertices."""
    try:
        return shapely.coverage_union_all(polys)
    except shapely.errors.GEOSException:
        return shapely.union_all(polys, grid_size=1e-3)


def _ends(walk: Polygon, side: BaseGeometry) -> list[tuple[tuple[float, float], float, float]]:
    """The ends of a crosswalk where it meets a sidewalk: for each, the middle of the end
    (m), the direction into the sidewalk (rad) and the end's length (m)."""
    rect = np.asarray(walk.minimum_rotated_rectangle.exterior.coords)[:4]
    centre = rect.mean(axis=0)
    out = []
    for k in range(4):
        a, b = rect[k], rect[(k + 1) % 4]
        mid = (a + b) / 2
        out_dir = mid - centre
        n = out_dir / max(float(np.hypot(*out_dir)), 1e-9)
        probe = shapely.Point(*(mid + n * 0.3))
        if side.contains(probe) and float(np.hypot(*(b - a))) >= 1.0:
            out.append(((float(mid[0]), float(mid[1])), math.atan2(n[1], n[0]), float(np.hypot(*(b - a)))))
    return out


def rectangles(region: BaseGeometry) -> list[tuple[float, float, float, float, float]]:
    """Rectangles ``(cx, cy, yaw, length, width)`` (m, rad; ``length`` along ``yaw``) inside
    ``region``, not overlapping, covering it but for slivers along its outline where it is
    not straight along x or y (axis-aligned slabs: ``yaw`` is 0).

    >>> rectangles(shapely.Polygon([(0, 0), (4, 0), (4, 1), (1, 1), (1, 3), (0, 3)]))
    [(2.0, 0.5, 0.0, 4.0, 1.0), (0.5, 2.0, 0.0, 1.0, 2.0)]
    """
    out: list[tuple[float, float, float, float, float]] = []
    for part in shapely.get_parts(region):
        if part.is_empty or part.area < THINNEST**2:
            continue
        for x0, y0, x1, y1 in _part_rectangles(part):
            out.append(((x0 + x1) / 2, (y0 + y1) / 2, 0.0, x1 - x0, y1 - y0))
    return out


def _edges(part: Polygon) -> np.ndarray:
    rings = [part.exterior, *part.interiors]
    segs = []
    for ring in rings:
        c = np.asarray(ring.coords)
        segs.append(np.c_[c[:-1], c[1:]])
    return np.concatenate(segs)


def _spans_at(edges: np.ndarray, ys: np.ndarray) -> list[list[tuple[float, float]]]:
    """For each ``y`` of ``ys``, the intervals of x inside the polygon of ``edges`` on the
    line at that height."""
    y0, y1 = edges[:, 1], edges[:, 3]
    out: list[list[tuple[float, float]]] = []
    for chunk in range(0, len(ys), 256):
        y = ys[chunk : chunk + 256, None]
        r, e = np.nonzero(((y0 <= y) & (y < y1)) | ((y1 <= y) & (y < y0)))
        yr = ys[chunk + r]
        x = edges[e, 0] + (yr - edges[e, 1]) * (edges[e, 2] - edges[e, 0]) / (edges[e, 3] - edges[e, 1])
        order = np.lexsort((x, r))
        r, x = r[order], x[order]
        bounds = np.searchsorted(r, np.arange(len(y) + 1))
        for k in range(len(y)):
            row = x[bounds[k] : bounds[k + 1]].tolist()
            out.append(list(zip(row[0::2], row[1::2], strict=False)))
    return out


def _meet(a: list[tuple[float, float]], b: list[tuple[float, float]]) -> list[tuple[float, float]]:
    """Intersection of two sorted lists of disjoint intervals."""
    out, i, j = [], 0, 0
    while i < len(a) and j < len(b):
        lo, hi = max(a[i][0], b[j][0]), min(a[i][1], b[j][1])
        if hi - lo > 1e-9:
            out.append((lo, hi))
        if a[i][1] < b[j][1]:
            i += 1
        else:
            j += 1
    return out


def _part_rectangles(part: Polygon) -> list[tuple[float, float, float, float]]:
    """Slabs covering one polygon: between consecutive heights of its vertices, cut where an
    edge crossing the slab slants so that no sliver it leaves is deeper than :data:`SLAB`;
    slabs one above the other of the same width are one."""
    edges = _edges(part)
    # Slab boundaries at the vertices' heights, those within BREAK of the one below dropped
    # (a slab's outline is then read just above its dropped vertices: what lies below them
    # is at most BREAK deep).
    heights = np.unique(np.round(edges[:, [1, 3]].ravel(), 6)).tolist()
    ys, floor = heights[:1], {}
    for y in heights[1:]:
        if y - ys[-1] >= BREAK:
            ys.append(y)
        else:
            floor[ys[-1]] = y
    if ys[-1] != heights[-1]:
        ys[-1] = heights[-1]
    y0, y1 = edges[:, 1], edges[:, 3]
    slabs: list[tuple[float, float]] = []
    bottoms: list[float] = []  # where each slab's outline is read from
    for lo, hi in itertools.pairwise(ys):
        mid = (lo + hi) / 2
        e = edges[((y0 <= mid) & (mid < y1)) | ((y1 <= mid) & (mid < y0))]
        dx = np.abs(e[:, 2] - e[:, 0]) * (hi - lo) / np.maximum(np.abs(e[:, 3] - e[:, 1]), 1e-12)
        dy = hi - lo
        depth = float((dx * dy / np.hypot(dx, dy)).max()) if len(e) and dy > 0 else 0.0
        n = max(1, math.ceil(depth / SLAB - 1e-9))
        slabs += [(lo + dy * k / n, lo + dy * (k + 1) / n) for k in range(n)]
        bottoms += [min(floor.get(lo, lo), lo + dy / n / 2)] + [lo + dy * k / n for k in range(1, n)]
    open_: list[list[float]] = []  # [x0, x1, bottom]
    out = []
    eps = 1e-7
    lines = _spans_at(
        edges,
        np.array(
            [[b + eps, (b + hi) / 2, hi - eps] for b, (_, hi) in zip(bottoms, slabs, strict=True)]
        ).ravel(),
    )
    for k, (lo, _) in enumerate(slabs):
        spans = _meet(_meet(lines[3 * k], lines[3 * k + 2]), lines[3 * k + 1])
        still = []
        for a, b in spans:
            if b - a < THINNEST:
                continue
            # A slab as wide as one begun below (within MERGE) continues it.
            match = next((r for r in open_ if abs(r[0] - a) <= MERGE and abs(r[1] - b) <= MERGE), None)
            if match is None:
                still.append([a, b, lo])
            else:
                open_.remove(match)
                still.append([max(match[0], a), min(match[1], b), match[2]])
        out += [(r[0], r[2], r[1], lo) for r in open_]
        open_ = still
    if slabs:
        out += [(r[0], r[2], r[1], slabs[-1][1]) for r in open_]
    rects = []
    for x0, b0, x1, b1 in out:
        if b1 - b0 < THINNEST + 2e-4:
            # A feature is at least 5 cm deep: a thinner slab overlaps the slabs beside it.
            b0, b1 = (b0 + b1) / 2 - THINNEST / 2 - 2e-4, (b0 + b1) / 2 + THINNEST / 2 + 2e-4
        kx, ky = math.ceil((x1 - x0) / LONGEST), math.ceil((b1 - b0) / LONGEST)
        for i in range(kx):
            for j in range(ky):
                rects.append(
                    (
                        _snap(x0 + (x1 - x0) * i / kx),
                        _snap(b0 + (b1 - b0) * j / ky),
                        _snap(x0 + (x1 - x0) * (i + 1) / kx),
                        _snap(b0 + (b1 - b0) * (j + 1) / ky),
                    )
                )
    return sorted(r for r in rects if r[2] - r[0] >= THINNEST and r[3] - r[1] >= THINNEST)


def _snap(v: float) -> float:
    """``v`` on a 0.2 mm grid: a slab's centre and sides, written to 0.1 mm, then meet its
    neighbours' exactly."""
    return round(round(v / 2e-4) * 2e-4, 4) + 0.0
