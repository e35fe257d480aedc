"""Convex parts, the pieces every catalog asset is made of (metres, z up).

Every part is convex, so it is at once a collision shape every engine accepts
(box, cylinder, capsule or convex mesh) and a watertight piece of the asset's
visual mesh. Coordinates are in the asset frame: origin at the centre of the
asset's base, at ground level, z up. They are stored as Python floats rounded to
1 micrometre, so a part's ``repr`` is the same on every run and platform.

Round parts are meshed with :data:`SEGMENTS` sides. Their footprint is the
polygon *circumscribing* the exact circle, so it contains both the exact
primitive an engine simulates and its mesh.

>>> Box((0.4, 0.2, 0.1), (0.0, 0.0, 0.05)).footprint().bounds
(-0.2, -0.1, 0.2, 0.1)
>>> round(Cylinder(0.1, 1.0, (0.0, 0.0, 0.5)).to_manifold().volume(), 3)
0.031
"""

from __future__ import annotations

import functools
import math
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING

import manifold3d
import numpy as np
import shapely
from shapely.geometry import Polygon

if TYPE_CHECKING:  # trimesh (and scipy.spatial) takes a third of a second to import: not for generation
    import trimesh

#: Sides of the polygon that stands for a circle in meshes and footprints.
SEGMENTS = 24
#: Decimal places kept for every coordinate and size (1 micrometre).
DECIMALS = 6

Vec3 = tuple[float, float, float]
RGBA = tuple[float, float, float, float]


def _round_array(points: np.ndarray) -> np.ndarray:
    """``round(v, DECIMALS) + 0.0`` of every element of a float array, bit for bit, vectorised:
    ``rint(v * 10**6) / 10**6`` is the float nearest ``k / 10**6`` (as ``round`` gives) unless
    the product rounded across a half; those few elements are rounded one by one."""
    scaled = points * 10.0**DECIMALS
    out = np.rint(scaled) / 10.0**DECIMALS + 0.0
    near_half = np.abs(np.abs(scaled - np.floor(scaled)) - 0.5) < 1e-6
    if near_half.any():
        for index in zip(*np.nonzero(near_half), strict=True):
            out[index] = round(float(points[index]), DECIMALS) + 0.0
    return out


#: Smallest singular value (m) of a convex mesh's vertices about their mean: below it they span no volume.
MIN_SPREAD = 1e-7


def _spans_volume(points: np.ndarray) -> bool:
    """Whether ``(n, 3)`` finite points (m) span a volume: the smallest singular value of the
    points about their mean is at least :data:`MIN_SPREAD` (``numpy.linalg.svd`` decides).

    The SVD is skipped when a cheap bound already settles it: the smallest eigenvalue of the
    3 x 3 Gram matrix ``G`` of the centred points is at least ``4 det(G) / trace(G)**2``;
    when that bound clears ``MIN_SPREAD**2`` by far more than the rounding of ``G`` and its
    determinant (below ``1e-14 * n * trace`` m2), the SVD would have said yes too.
    """
    n = len(points)
    if n < 4:
        return False
    centred = points - np.add.reduce(points, axis=0) / n
    (a, b, c), (d, e, f), (g, h, i) = (centred.T @ centred).tolist()
    trace = a + e + i
    det = a * (e * i - f * h) - b * (d * i - f * g) + c * (d * h - e * g)
    if trace > 0 and 4 * det / (trace * trace) > 100 * MIN_SPREAD**2 + 1e-13 * n * trace:
        return True
    spread = points - np.mean(points, axis=0)
    return bool(np.linalg.svd(spread, compute_uv=False)[-1] >= MIN_SPREAD)


def _floats(field: str, value: Iterable[float], n: int, positive: bool = False) -> tuple[float, ...]:
    """``value`` as ``n`` finite rounded floats, or a ValueError naming the field."""
    try:
        out = tuple([round(float(v), DECIMALS) + 0.0 for v in value])
    except (TypeError, ValueError):
        out = ()
    if len(out) == n and math.isfinite(sum(out)) and (not positive or min(out) > 0):
        return out  # the common case, settled in a few C calls (a NaN or inf makes the sum so)
    if len(out) != n or not all(math.isfinite(v) and (v > 0 or not positive) for v in out):
        kind = "positive" if positive else "finite"
        raise ValueError(f"{field}: expected {n} {kind} numbers (metres), got {value!r}")
    return out


def _length(field: str, value: float, minimum: float = 0.0) -> float:
    """A finite length > ``minimum`` (or >= 0 when ``minimum`` is 0 and ``value`` is 0)."""
    (out,) = _floats(field, (value,), 1)
    if out < minimum or (minimum > 0 and out == minimum):
        raise ValueError(f"{field}: expected a length > {minimum} m, got {value!r}")
    return out


@dataclass(frozen=True, slots=True)
class Look:
    """A part's material: what it is made of and what colour it has.

    ``name`` is the material kind (``"metal"``, ``"wood"``, ``"concrete"`` ...),
    matching :data:`citygen.spec.surfaces.MATERIALS` where one fits, so exporters can
    look up friction; ``rgba`` is the colour, each channel in [0, 1].
    """

    name: str
    rgba: RGBA

    def __post_init__(self) -> None:
        if not isinstance(self.name, str) or not self.name:
            raise ValueError(f"Look.name: expected a non-empty string, got {self.name!r}")
        rgba = _floats("Look.rgba", self.rgba, 4)
        if not all(0.0 <= c <= 1.0 for c in rgba):
            raise ValueError(f"Look.rgba: expected 4 numbers in [0, 1], got {self.rgba!r}")
        object.__setattr__(self, "rgba", rgba)


#: The look of a part whose builder did not give one.
DEFAULT_LOOK = Look("metal", (0.5, 0.5, 0.5, 1.0))


class _Convex:
    """Shared behaviour: a part is the convex hull of :meth:`hull_points`."""

    # The vertex array a convex mesh was built from, until :func:`release` drops it; not a
    # dataclass field, so it takes no part in repr, equality, hashing or pickling.
    __slots__ = ("_points",)
    material: Look

    def hull_points(self) -> np.ndarray:
        """``(n, 3)`` points (m) whose convex hull is the part's mesh."""
        raise NotImplementedError

    def _outline(self) -> np.ndarray:
        """``(n, 2)`` points (m) whose convex hull is the part's footprint."""
        return self.hull_points()[:, :2]

    def extent(self) -> tuple[float, float, np.ndarray]:
        """The part's lowest and highest z (m) and the ``(n, 2)`` points (m) whose convex hull
        is its footprint: what :func:`footprints` and the catalog need, computed once."""
        points = self.hull_points()
        z = points[:, 2]
        return float(z.min()), float(z.max()), points[:, :2]

    def footprint(self) -> Polygon:
        """The part's projection on the ground plane (m), in the asset frame."""
        return footprints([self._outline()])[0]

    def to_manifold(self) -> manifold3d.Manifold:
        """The part as a watertight manifold3d solid."""
        return manifold3d.Manifold.hull_points(self.hull_points())

    def to_trimesh(self) -> trimesh.Trimesh:
        """The part as a watertight trimesh, faces coloured by its material."""
        return manifold_to_trimesh(self.to_manifold(), self.material.rgba)


def footprints(outlines: Sequence[np.ndarray]) -> np.ndarray:
    """The normalised convex hull (m) of each ``(n, 2)`` array of points, as an array of
    polygons; a hull seen exactly edge-on (a segment or a point) is grown by 1 micrometre.

    One vectorised shapely call per step for all of them, the same polygons as one by one.
    Each array goes to GEOS as a line string through its points rather than a multipoint (one
    geometry, not one per point): a convex hull is of the distinct coordinates, in the same
    order, whatever geometry holds them.
    """
    counts = [len(o) for o in outlines]
    lines = shapely.linestrings(np.concatenate(outlines), indices=np.repeat(np.arange(len(counts)), counts))
    hulls = shapely.convex_hull(lines)
    flat = shapely.get_type_id(hulls) != shapely.GeometryType.POLYGON
    if flat.any():  # a part seen exactly edge-on from above
        hulls[flat] = shapely.buffer(hulls[flat], 1e-6, quad_segs=1)
    return shapely.normalize(hulls)


def release(parts: Iterable[_Convex]) -> None:
    """Drop the vertex arrays the parts keep from their construction (memory; results unchanged)."""
    for part in parts:
        object.__setattr__(part, "_points", None)


def manifold_to_trimesh(solid: manifold3d.Manifold, rgba: RGBA | None = None) -> trimesh.Trimesh:
    """A trimesh of a manifold3d solid (float64 vertices), optionally with one face colour."""
    import trimesh

    mesh = solid.to_mesh64()
    vertices = np.asarray(mesh.vert_properties, dtype=np.float64)[:, :3]
    faces = np.asarray(mesh.tri_verts, dtype=np.int64)
    out = trimesh.Trimesh(vertices, faces, process=False)
    if rgba is not None:
        out.visual.face_colors = np.round(np.asarray(rgba) * 255).astype(np.uint8)
    return out


@functools.lru_cache(maxsize=16)
def _unit_circle(sides: int) -> tuple[np.ndarray, np.ndarray]:
    """Cosines and sines of ``sides`` angles evenly spaced from 0 (read-only arrays)."""
    angles = np.arange(sides) * (2 * np.pi / sides)
    cos, sin = np.cos(angles), np.sin(angles)
    cos.flags.writeable = sin.flags.writeable = False
    return cos, sin


def _ring(radius: float, z: float, center: Sequence[float], sides: int = SEGMENTS) -> np.ndarray:
    """``sides`` points on a horizontal circle, the first one on +x."""
    cos, sin = _unit_circle(sides)
    out = np.empty((sides, 3))
    out[:, 0] = center[0] + radius * cos
    out[:, 1] = center[1] + radius * sin
    out[:, 2] = z
    return out


def _circumscribed(radius: float, center: Sequence[float]) -> np.ndarray:
    """The polygon with :data:`SEGMENTS` sides around a circle, in phase with :func:`_ring`."""
    return _ring(radius / math.cos(math.pi / SEGMENTS), 0.0, center)[:, :2]


_CORNERS = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
_CORNERS.flags.writeable = False


@dataclass(frozen=True, slots=True)
class Box(_Convex):
    """A box of ``size`` (x, y, z; m) centred at ``pos`` (m), turned by ``yaw`` (rad) about +Z."""

    size: Vec3
    pos: Vec3
    yaw: float = 0.0
    material: Look = DEFAULT_LOOK

    def __post_init__(self) -> None:
        object.__setattr__(self, "size", _floats("Box.size", self.size, 3, positive=True))
        object.__setattr__(self, "pos", _floats("Box.pos", self.pos, 3))
        object.__setattr__(self, "yaw", _floats("Box.yaw", (self.yaw,), 1)[0])

    def hull_points(self) -> np.ndarray:
        local = _CORNERS * np.asarray(self.size) / 2
        c, s = math.cos(self.yaw), math.sin(self.yaw)
        turn = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
        return local @ turn.T + np.asarray(self.pos)

    def _outline(self) -> np.ndarray:
        if self.yaw != 0.0:
            return self.hull_points()[:, :2]
        # Unturned, hull_points() gives each corner exactly pos -+ size / 2 (the turn's zero
        # terms add signed zeros to a non-zero half size): the same 8 points, in its order.
        (sx, sy, _), (x, y, _) = self.size, self.pos
        x0, x1, y0, y1 = x - sx / 2, x + sx / 2, y - sy / 2, y + sy / 2
        return np.array([[x0, y0], [x0, y0], [x0, y1], [x0, y1], [x1, y0], [x1, y0], [x1, y1], [x1, y1]])

    def extent(self) -> tuple[float, float, np.ndarray]:
        # The turn about +Z leaves each corner's z exactly pos.z -+ size.z / 2.
        half, z = self.size[2] / 2, self.pos[2]
        return z - half, z + half, self._outline()


@dataclass(frozen=True, slots=True)
class Cylinder(_Convex):
    """A cylinder of ``radius`` and ``height`` (m) along +Z, centred at ``pos`` (m)."""

    radius: float
    height: float
    pos: Vec3
    material: Look = DEFAULT_LOOK

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _length("Cylinder.radius", self.radius, 1e-4))
        object.__setattr__(self, "height", _length("Cylinder.height", self.height, 1e-4))
        object.__setattr__(self, "pos", _floats("Cylinder.pos", self.pos, 3))

    def hull_points(self) -> np.ndarray:
        x, y, z = self.pos
        half = self.height / 2
        return np.vstack([_ring(self.radius, z - half, (x, y)), _ring(self.radius, z + half, (x, y))])

    def _outline(self) -> np.ndarray:
        return _circumscribed(self.radius, self.pos)

    def extent(self) -> tuple[float, float, np.ndarray]:
        z, half = self.pos[2], self.height / 2
        return z - half, z + half, self._outline()


@dataclass(frozen=True, slots=True)
class Capsule(_Convex):
    """A capsule along +Z centred at ``pos`` (m): a cylinder of ``radius`` and ``length`` (m)
    capped by two hemispheres, so it is ``length + 2 * radius`` tall. ``length`` 0 is a sphere.
    """

    radius: float
    length: float
    pos: Vec3
    material: Look = DEFAULT_LOOK

    #: Latitude rings per hemisphere in the mesh (the pole is one more point).
    RINGS = 6

    def __post_init__(self) -> None:
        object.__setattr__(self, "radius", _length("Capsule.radius", self.radius, 1e-4))
        object.__setattr__(self, "length", _length("Capsule.length", self.length))
        object.__setattr__(self, "pos", _floats("Capsule.pos", self.pos, 3))

    def hull_points(self) -> np.ndarray:
        x, y, z = self.pos
        r, half = self.radius, self.length / 2
        rings = []
        for k in range(self.RINGS):
            lat = k / self.RINGS * (math.pi / 2)
            rr, dz = r * math.cos(lat), r * math.sin(lat)
            rings += [_ring(rr, z + half + dz, (x, y)), _ring(rr, z - half - dz, (x, y))]
        poles = np.array([[x, y, z + half + r], [x, y, z - half - r]])
        return np.vstack([*rings, poles])

    def _outline(self) -> np.ndarray:
        return _circumscribed(self.radius, self.pos)

    def extent(self) -> tuple[float, float, np.ndarray]:
        z = self.hull_points()[:, 2]
        return float(z.min()), float(z.max()), self._outline()


@dataclass(frozen=True, slots=True)
class ConvexMesh(_Convex):
    """The convex hull of ``vertices`` (x, y, z; m). They must span a volume."""

    vertices: tuple[Vec3, ...]
    material: Look = DEFAULT_LOOK

    def __post_init__(self) -> None:
        try:
            raw = np.asarray(self.vertices, dtype=np.float64)
        except (TypeError, ValueError):
            raw = np.zeros((0, 0))
        if raw.ndim == 2 and raw.shape[1] == 3 and np.isfinite(raw).all():
            _set_vertices(self, _round_array(raw))
            return
        try:
            points = tuple(_floats("ConvexMesh.vertices[]", v, 3) for v in self.vertices)
        except TypeError:
            points = ()
        if not (len(points) >= 4 and _spans_volume(np.asarray(points))):
            _flat(len(points))
        object.__setattr__(self, "vertices", points)
        object.__setattr__(self, "_points", None)

    def hull_points(self) -> np.ndarray:
        kept = getattr(self, "_points", None)
        if kept is not None:
            return kept.copy()
        return np.asarray(self.vertices, dtype=np.float64)

    def extent(self) -> tuple[float, float, np.ndarray]:
        points = getattr(self, "_points", None)
        if points is None:
            points = np.asarray(self.vertices, dtype=np.float64)
        z = points[:, 2]
        return float(z.min()), float(z.max()), points[:, :2]


def _flat(count: int) -> None:
    raise ValueError(
        f"ConvexMesh.vertices: expected >= 4 points (m) spanning a volume, got {count} points that do not"
    )


def _set_vertices(mesh: ConvexMesh, rounded: np.ndarray, solid: bool = False) -> None:
    """Give ``mesh`` the rounded ``(n, 3)`` vertex array, or the ValueError of a flat one
    (``solid``: the caller has shown that the points span a volume)."""
    if not (solid or _spans_volume(rounded)):
        _flat(len(rounded))
    rounded.flags.writeable = False
    object.__setattr__(mesh, "vertices", tuple(zip(*rounded.T.tolist(), strict=True)))
    object.__setattr__(mesh, "_points", rounded)


Part = Box | Cylinder | Capsule | ConvexMesh
"""Any convex part."""


def convex_mesh(points: np.ndarray, material: Look = DEFAULT_LOOK, solid: bool = False) -> ConvexMesh:
    """``ConvexMesh(vertices, material)`` of an ``(n, 3)`` array of points (m), built without
    going through nested tuples: the same vertices, the same errors. ``solid``: the caller
    has shown that the points span a volume even once rounded, so that check is skipped.

    >>> corners = ((1, 0, 0), (0, 1, 0), (0, 0, 1), (0, 0, 0))
    >>> convex_mesh(np.array(corners)) == ConvexMesh(corners)
    True
    """
    points = np.asarray(points, dtype=np.float64)
    if not (points.ndim == 2 and points.shape[1] == 3 and np.isfinite(points).all()):
        return ConvexMesh(tuple(map(tuple, points.tolist())), material)
    mesh = object.__new__(ConvexMesh)
    object.__setattr__(mesh, "material", material)
    _set_vertices(mesh, _round_array(points), solid)
    return mesh


def _unit(x: float, y: float, z: float) -> np.ndarray:
    """``(x, y, z)`` divided by its length, as ``v / np.linalg.norm(v)`` gives it."""
    v = np.array([x, y, z])
    v /= math.sqrt(v.dot(v))
    return v


def rod(
    radius: float, start: Sequence[float], end: Sequence[float], material: Look = DEFAULT_LOOK
) -> ConvexMesh:
    """A cylinder of ``radius`` (m) from ``start`` to ``end`` (m) in any direction.

    >>> rod(0.05, (0, 0, 1), (1, 0, 1)).footprint().bounds
    (0.0, -0.05, 1.0, 0.05)
    """
    a, b = np.asarray(start, float), np.asarray(end, float)
    axis = b - a
    length = math.sqrt(axis.dot(axis))  # np.linalg.norm
    if not length > 0:
        raise ValueError(f"rod: start and end must differ, got {tuple(start)} and {tuple(end)}")
    axis /= length
    # u = axis x helper and v = axis x u, each term as np.cross computes it.
    ax, ay, az = axis.tolist()
    if abs(az) < 0.9:  # helper +Z
        u = _unit(ay * 1.0 - az * 0.0, az * 0.0 - ax * 1.0, ax * 0.0 - ay * 0.0)
    else:  # helper +X
        u = _unit(ay * 0.0 - az * 0.0, az * 1.0 - ax * 0.0, ax * 0.0 - ay * 1.0)
    ux, uy, uz = u.tolist()
    v = np.array([ay * uz - az * uy, az * ux - ax * uz, ax * uy - ay * ux])
    cos, sin = _unit_circle(SEGMENTS)
    circle = radius * (cos[:, None] * u + sin[:, None] * v)  # np.outer, term by term
    points = np.empty((2 * SEGMENTS, 3))
    points[:SEGMENTS] = a + circle
    points[SEGMENTS:] = b + circle
    # About their mean the two rims have singular values sqrt(24) |radius| (twice) and
    # sqrt(12) length; rounding to DECIMALS moves them by under 6e-6 m, so from 1e-5 m up
    # the rod spans a volume without asking the SVD.
    return convex_mesh(points, material, solid=abs(radius) >= 1e-5 and length >= 1e-5)


def frustum(
    r_bottom: float,
    r_top: float,
    z_bottom: float,
    z_top: float,
    material: Look = DEFAULT_LOOK,
    xy: Sequence[float] = (0.0, 0.0),
    sides: int = SEGMENTS,
) -> ConvexMesh:
    """A truncated cone along +Z from ``z_bottom`` to ``z_top`` (m), radii in m.

    ``sides`` below :data:`SEGMENTS` gives a faceted prism (4 for a square post).
    """
    if not (r_bottom >= 0 and r_top >= 0 and r_bottom + r_top > 0 and z_top > z_bottom):
        raise ValueError(
            f"frustum: expected radii >= 0 (not both 0) and z_top > z_bottom (m), got "
            f"r=({r_bottom}, {r_top}), z=({z_bottom}, {z_top})"
        )
    rings = [_ring(r, z, xy, sides) for r, z in ((r_bottom, z_bottom), (r_top, z_top)) if r > 0]
    apexes = [[xy[0], xy[1], z] for r, z in ((r_bottom, z_bottom), (r_top, z_top)) if r == 0]
    return convex_mesh(np.vstack([*rings, *([np.array(apexes)] if apexes else [])]), material)


def tilted_box(
    size: Sequence[float], pos: Sequence[float], lean: float, material: Look = DEFAULT_LOOK
) -> ConvexMesh:
    """A box of ``size`` (m) centred at ``pos`` (m), its top leaning to +x by ``lean`` (rad)."""
    local = _CORNERS * np.asarray(size, float) / 2
    c, s = math.cos(lean), math.sin(lean)
    turn = np.array([[c, 0.0, s], [0.0, 1.0, 0.0], [-s, 0.0, c]])
    return convex_mesh(local @ turn.T + np.asarray(pos, float), material)
