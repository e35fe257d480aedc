"""Convex pieces of polygons: a polygon with holes cut into convex rings that tile it.

MuJoCo collides a mesh as its convex hull, so the MJCF exporter lays flat ground as convex
slabs: each zone's polygon is kept whole when convex, cut into rectangles when its edges
are axis-aligned, else triangulated (constrained Delaunay) and the triangles merged back
into convex polygons (Hertel-Mehlhorn). Coordinates in metres.
"""

from __future__ import annotations

import math
from itertools import pairwise
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry import box as rect

#: Pieces smaller than this (m^2) are numerical slivers.
AREA_EPS = 1e-6


def polygons(geom: Any) -> list[Polygon]:
    """The polygons of a shapely result (dropping lines, points and slivers), in order."""
    parts = shapely.get_parts(geom).tolist() if not geom.is_empty else []
    out: list[Polygon] = []
    for p in parts:
        if isinstance(p, Polygon):
            if p.area > AREA_EPS:
                out.append(p)
        elif hasattr(p, "geoms"):
            out.extend(polygons(p))
    return out


def _cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    """The z of ``(a - o) x (b - a)``: positive where the path o, a, b turns left."""
    return (a[0] - o[0]) * (b[1] - a[1]) - (a[1] - o[1]) * (b[0] - a[0])


def _turns_left(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether o, a, b turns left or goes straight on (within a relative 1e-9)."""
    scale = math.hypot(a[0] - o[0], a[1] - o[1]) * math.hypot(b[0] - a[0], b[1] - a[1])
    return _cross(o, a, b) >= -1e-9 * scale


def _clean_ring(ring: Any) -> np.ndarray:
    """A counter-clockwise ring ``(n, 2)`` without its repeated first vertex or collinear vertices."""
    pts = [(float(x), float(y)) for x, y in np.asarray(ring, dtype=float)[:, :2]]
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts.pop()
    area2 = sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True))
    if area2 < 0:
        pts.reverse()
    changed = True
    while changed and len(pts) > 3:
        changed = False
        for i in range(len(pts)):
            o, a, b = pts[i - 1], pts[i], pts[(i + 1) % len(pts)]
            scale = math.hypot(a[0] - o[0], a[1] - o[1]) * math.hypot(b[0] - a[0], b[1] - a[1])
            if abs(_cross(o, a, b)) <= 1e-9 * scale:
                del pts[i]
                changed = True
                break
    return np.array(pts, dtype=float).reshape(-1, 2)


def _is_convex(ring: np.ndarray) -> bool:
    pts = [tuple(p) for p in np.asarray(ring, dtype=float).tolist()]
    return all(_turns_left(pts[i - 2], pts[i - 1], pts[i]) for i in range(len(pts)))


def _rectilinear(poly: Polygon) -> bool:
    for ring in (poly.exterior, *poly.interiors):
        d = np.diff(np.asarray(ring.coords), axis=0)
        if not np.all((np.abs(d[:, 0]) <= 1e-9) | (np.abs(d[:, 1]) <= 1e-9)):
            return False
    return True


def _rectangles(poly: Polygon) -> list[np.ndarray]:
    """A rectilinear polygon as axis-aligned rectangles: horizontal bands between its
    vertices' y values, equal intervals of neighbouring bands merged."""
    coords = np.concatenate([np.asarray(r.coords) for r in (poly.exterior, *poly.interiors)])
    ys = np.unique(coords[:, 1])
    x0, _, x1, _ = poly.bounds
    out: list[tuple[float, float, float, float]] = []
    open_: dict[tuple[float, float], float] = {}
    for y0, y1 in pairwise(ys.tolist()):
        band = polygons(poly.intersection(rect(x0, y0, x1, y1)))
        spans = sorted((p.bounds[0], p.bounds[2]) for p in band)
        now = {span: open_.pop(span, y0) for span in spans}
        out += [(a, start, b, y0) for (a, b), start in open_.items()]
        open_ = now
    out += [(a, start, b, float(ys[-1])) for (a, b), start in open_.items()]
    return [np.array([[a, b], [c, b], [c, d], [a, d]]) for a, b, c, d in out]


def _hertel_mehlhorn(poly: Polygon) -> list[np.ndarray]:
    """Convex pieces of a polygon with holes: its constrained Delaunay triangles, merged
    across diagonals (longest first) while the union stays convex."""
    index: dict[tuple[float, float], int] = {}
    pieces: list[list[int] | None] = []
    for t in shapely.get_parts(shapely.constrained_delaunay_triangles(poly)).tolist():
        ring = [(float(x), float(y)) for x, y in t.exterior.coords[:3]]
        if _cross(*ring) == 0:
            continue
        if _cross(*ring) < 0:
            ring.reverse()
        pieces.append([index.setdefault(p, len(index)) for p in ring])
    pts = list(index)
    owner: dict[tuple[int, int], int] = {}
    for k, piece in enumerate(pieces):
        for a, b in zip(piece, piece[1:] + piece[:1], strict=True):
            owner[(a, b)] = k
    diagonals = sorted(
        ((a, b) for a, b in owner if a < b and (b, a) in owner),
        key=lambda e: (-math.dist(pts[e[0]], pts[e[1]]), e),
    )
    for a, b in diagonals:
        p, q = owner[(a, b)], owner[(b, a)]
        if p == q:
            continue
        pp, qq = pieces[p], pieces[q]
        i, j = pp.index(a), qq.index(b)  # pp: ... a, b ...; qq: ... b, a ...
        path_p = pp[i + 1 :] + pp[: i + 1]  # b ... a
        path_q = qq[j + 1 :] + qq[: j + 1]  # a ... b
        # Only the corners at a and b change; every other corner is one of a convex piece.
        if not (
            _turns_left(pts[path_p[-2]], pts[a], pts[path_q[1]])
            and _turns_left(pts[path_q[-2]], pts[b], pts[path_p[1]])
        ):
            continue
        merged = path_p + path_q[1:-1]
        pieces[p], pieces[q] = merged, None
        for u, w in zip(merged, merged[1:] + merged[:1], strict=True):
            owner[(u, w)] = p
    return [_clean_ring([pts[k] for k in piece]) for piece in pieces if piece is not None]


def convex_pieces(poly: Polygon) -> list[np.ndarray]:
    """A polygon (with holes) as convex counter-clockwise rings ``(n, 2)`` in metres that
    tile it: itself when convex, rectangles when its edges are axis-aligned, else merged
    triangles (Hertel-Mehlhorn, at most four times the fewest convex pieces).

    >>> from shapely.geometry import Polygon
    >>> len(convex_pieces(Polygon([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)])))
    2
    """
    ring = _clean_ring(np.asarray(poly.exterior.coords))
    if not poly.interiors and _is_convex(ring):
        return [ring]
    if _rectilinear(poly):
        return _rectangles(poly)
    return _hertel_mehlhorn(poly)


def as_rectangle(ring: np.ndarray) -> tuple[np.ndarray, float, float, float] | None:
    """``(centre, length, width, yaw)`` when a convex ring is a rectangle, else None.

    In plain Python on the ring's four corners: the same operations in the same order as
    :func:`as_rectangle_numpy` (the reference), so the same floats to the bit, where numpy's
    calls on a 4 x 2 array cost 30 us a ring (the city's 49,000 ground slabs: 1.4 s)."""
    if len(ring) != 4:
        return None
    pts = np.asarray(ring, dtype=np.float64).tolist()
    ex = [pts[(i + 1) % 4][0] - pts[i][0] for i in range(4)]
    ey = [pts[(i + 1) % 4][1] - pts[i][1] for i in range(4)]
    lengths = [math.sqrt(ex[i] * ex[i] + ey[i] * ey[i]) for i in range(4)]
    for i in range(4):
        j = (i + 1) % 4
        dot = abs(ex[i] * ex[j] + ey[i] * ey[j])
        den = lengths[i] * lengths[j]
        if den == 0.0:  # numpy's 0/0 is nan (not > 1e-9); anything else over 0, inf
            if dot > 0.0:
                return None
        elif dot / den > 1e-9:
            return None
    quarter = math.atan2(ey[0], ex[0]) / (math.pi / 2)
    turns = math.ceil(quarter - 0.5)
    length, width = (lengths[0], lengths[1]) if turns % 2 == 0 else (lengths[1], lengths[0])
    yaw = (quarter - turns) * (math.pi / 2)
    (x0, y0), (x1, y1), (x2, y2), (x3, y3) = pts
    # numpy sums a mean from 0.0 (so a sum of -0.0 is 0.0), in order below 8 terms
    centre = np.array([((((0.0 + x0) + x1) + x2) + x3) / 4, ((((0.0 + y0) + y1) + y2) + y3) / 4])
    return centre, length, width, yaw


def as_rectangle_numpy(ring: np.ndarray) -> tuple[np.ndarray, float, float, float] | None:
    """:func:`as_rectangle` in numpy: the plain reference."""
    if len(ring) != 4:
        return None
    e = np.roll(ring, -1, axis=0) - ring
    lengths = np.linalg.norm(e, axis=1)
    cos = np.abs(np.sum(e * np.roll(e, -1, axis=0), axis=1)) / (lengths * np.roll(lengths, -1))
    if np.any(cos > 1e-9):
        return None
    # The edge nearest the +x axis gives the yaw, in (-pi/4, pi/4]: axis-aligned boxes get none.
    quarter = math.atan2(e[0, 1], e[0, 0]) / (math.pi / 2)
    turns = math.ceil(quarter - 0.5)
    length, width = (lengths[0], lengths[1]) if turns % 2 == 0 else (lengths[1], lengths[0])
    yaw = (quarter - turns) * (math.pi / 2)
    return ring.mean(axis=0), float(length), float(width), yaw
