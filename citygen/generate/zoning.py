"""Zones from layers of ground: the overlay every ground plan ends in (stage 2).

A ground plan (the streets' lots of :func:`~citygen.generate.ground.plan_ground`, a city's
lots, a small region) describes ground as *layers*, ``(kind, strip, shape)`` in priority
order, cuts the scene into lots (:func:`clip_to_lots`) and divides each lot by its layers
(:func:`arrange`): all boundaries are noded once on a :data:`GRID` and polygonised; each face
takes the kind of the first layer covering it, so neighbouring zones share every vertex bit
for bit. :func:`to_zones` turns the pieces into the spec's zones.
"""

from __future__ import annotations

import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.spec.base import quantize_array
from citygen.spec.zones import Zone

#: Precision grid of every overlay, in metres.
GRID = 1e-3
#: Pieces of ground smaller than this (m^2) join a neighbouring zone.
MIN_AREA = 0.01
#: Segments per quarter circle of buffered corners.
QUAD_SEGS = 4


def snap(value: float) -> float:
    """``value`` (m) on the :data:`GRID`."""
    return round(round(value / GRID) * GRID, 6)


def polygons(geom) -> list[Polygon]:
    """The polygons of any geometry (none of an empty one), collections flattened."""
    if geom is None or geom.is_empty:
        return []
    if geom.geom_type == "Polygon":
        return [geom]
    return [g for part in getattr(geom, "geoms", ()) for g in polygons(part)]


Layer = tuple[str, "str | None", object]
"""``(kind, strip, shape)``: ground of one kind, in priority order."""


Piece = tuple[str, "str | None", Polygon]


def arrange(lot: Polygon, layers: list[Layer], fill=None) -> list[Piece]:
    """Divide ``lot`` by ``layers``: each point goes to the first layer that covers it, and
    what no layer covers to ``fill(part) -> pieces`` (vegetation without one).

    All boundaries are noded once on the :data:`GRID` and polygonised into faces, each
    face takes the kind of the first layer holding it, and faces of one kind merge by
    coverage union. Neighbouring zones therefore share every boundary vertex exactly
    (separate overlays could snap a shared edge apart), and the cost is one noding per
    lot however many layers there are.
    """
    layers = [(k, st, g) for k, st, g in layers if g is not None and not g.is_empty]
    if layers:
        lines = shapely.union_all([lot.boundary] + [g.boundary for _, _, g in layers], grid_size=GRID)
        faces = shapely.get_parts(shapely.polygonize(shapely.get_parts(lines)))
        faces = faces[shapely.area(faces) > 0]
    else:
        faces = np.array([lot], dtype=object)
    points = shapely.point_on_surface(faces)
    owner = np.full(len(faces), -1)  # -1: left for ``fill``
    for k, (_, _, shape) in enumerate(layers):
        free = owner < 0
        if not free.any():
            break
        shapely.prepare(shape)
        owner[np.flatnonzero(free)[shapely.intersects(shape, points[free])]] = k
    # Crumbs (a crosswalk's corner, a sliver between two buffers) join the neighbour they
    # share the longest edge with rather than being zones of their own.
    areas = shapely.area(faces)
    big, small = np.flatnonzero(areas >= MIN_AREA), np.flatnonzero(areas < MIN_AREA)
    if len(small) and len(big):
        tree = shapely.STRtree(faces[big])
        for f in small:
            near = big[tree.query(faces[f], predicate="intersects")]
            if len(near):
                shared = shapely.length(shapely.intersection(faces[near], faces[f].boundary))
                owner[f] = owner[near[int(np.argmax(shared))]]
    # Faces merge by kind and strip (the setback's lawn and an island's are one zone).
    keys = [(kind, strip) for kind, strip, _ in layers]
    order = list(dict.fromkeys(keys))
    group = np.array([order.index(keys[k]) if k >= 0 else -1 for k in owner])
    pieces: list[Piece] = []
    for g, (kind, strip) in enumerate(order):
        pieces += [(kind, strip, part) for part in _merge(faces[group == g])]
    for part in _merge(faces[group < 0]):
        pieces += fill(part) if fill else [("vegetation", None, part)]
    return pieces


def _merge(faces: np.ndarray) -> list[Polygon]:
    if not len(faces):
        return []
    return polygons(faces[0] if len(faces) == 1 else shapely.coverage_union_all(faces))


def clip_to_lots(layers: list, xs: list[float], ys: list[float], i0, i1, j0, j1, out: dict) -> None:
    """Clip every layer to each lot ``[xs[i], xs[i+1]] x [ys[j], ys[j+1]]``, bisecting the
    range of lots so each clip sees only the geometry of its half."""
    layers = [
        None if g is None or g.is_empty else shapely.clip_by_rect(g, xs[i0], ys[j0], xs[i1], ys[j1])
        for g in layers
    ]
    if i1 - i0 == 1 and j1 - j0 == 1:
        out[(j0, i0)] = layers
        return
    if i1 - i0 >= j1 - j0:
        mid = (i0 + i1) // 2
        clip_to_lots(layers, xs, ys, i0, mid, j0, j1, out)
        clip_to_lots(layers, xs, ys, mid, i1, j0, j1, out)
    else:
        mid = (j0 + j1) // 2
        clip_to_lots(layers, xs, ys, i0, i1, j0, mid, out)
        clip_to_lots(layers, xs, ys, i0, i1, mid, j1, out)


def to_zones(pieces: list[Piece]) -> tuple[Zone, ...]:
    """Zones from pieces, with ids by kind in order. The pieces are valid polygons and
    every coordinate is quantised here exactly as :class:`~citygen.spec.base.Float` would
    (:func:`~citygen.spec.base.quantize_array`), so the models are built without
    re-validating thousands of coordinates one by one."""
    if not pieces:
        return ()
    # A canonical vertex order, whatever GEOS produced; all rings at once.
    polys = shapely.normalize(np.array([poly for _, _, poly in pieces], dtype=object))
    rings, owner = shapely.get_rings(polys, return_index=True)
    coords, ring_of = shapely.get_coordinates(rings, return_index=True)
    coords = quantize_array(coords).tolist()
    starts = np.searchsorted(ring_of, np.arange(len(rings) + 1)).tolist()
    # Each ring without its closing vertex.
    ring_tuples = [tuple(map(tuple, coords[starts[k] : starts[k + 1] - 1])) for k in range(len(rings))]
    first = np.searchsorted(owner, np.arange(len(polys) + 1)).tolist()
    counters: dict[str, int] = {}
    zones = []
    for k, (kind, strip, _) in enumerate(pieces):
        n = counters[kind] = counters.get(kind, 0) + 1
        zones.append(
            Zone.model_construct(
                id=f"{kind}-{n}",
                kind=kind,
                polygon=ring_tuples[first[k]],
                holes=tuple(ring_tuples[first[k] + 1 : first[k + 1]]),
                strip=strip,
            )
        )
    return tuple(zones)
