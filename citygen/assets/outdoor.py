"""Builders of larger outdoor things: bus stop shelters, trees, bushes, bike racks, traffic
cones, parked scooters, cafe tables with chairs and building massing.

Same conventions as :mod:`citygen.assets.furniture`: every dimension is drawn from the
generator the builder is given (metres, to the millimetre), parts are convex and given in
the asset frame (origin at the centre of the base on the ground, z up, front facing +x),
and parts that belong together overlap by :data:`~citygen.assets.furniture.EMBED` so
their union is one solid. Footprint ranges include everything seen from above (a tree's
crown, a shelter's roof, a parasol), because that is what ``Asset.footprint`` is.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence

import numpy as np

from citygen.assets.category import Category, zones
from citygen.assets.furniture import (
    CONCRETE,
    EMBED,
    FOLIAGE,
    PAINT,
    STEEL,
    WOOD,
    dim,
    pick,
)
from citygen.assets.parts import Box, Capsule, ConvexMesh, Cylinder, Look, Part, convex_mesh, frustum, rod
from citygen.assets.parts import tilted_box as tilted


def _looks(name: str, *rgbas: tuple[float, float, float, float]) -> tuple[Look, ...]:
    return tuple(Look(name, rgba) for rgba in rgbas)


GLAZING = _looks("glass", (0.80, 0.88, 0.92, 0.35), (0.70, 0.80, 0.85, 0.40), (0.85, 0.85, 0.80, 0.30))
BARK = _looks("wood", (0.35, 0.26, 0.18, 1.0), (0.45, 0.40, 0.35, 1.0), (0.28, 0.22, 0.18, 1.0),
              (0.55, 0.50, 0.45, 1.0))  # fmt: skip
LEAVES = (
    *FOLIAGE,
    Look("foliage", (0.35, 0.50, 0.20, 1.0)),  # light spring green
    Look("foliage", (0.55, 0.45, 0.15, 1.0)),  # turning yellow
    Look("foliage", (0.60, 0.30, 0.12, 1.0)),  # autumn red-brown
)
NEEDLES = _looks("foliage", (0.08, 0.22, 0.12, 1.0), (0.12, 0.26, 0.18, 1.0), (0.15, 0.30, 0.22, 1.0))
BLOSSOM = _looks("foliage", (0.85, 0.60, 0.70, 1.0), (0.92, 0.90, 0.85, 1.0), (0.90, 0.78, 0.25, 1.0))
MULCH = Look("mulch", (0.36, 0.24, 0.15, 1.0))
GRATE = Look("metal", (0.20, 0.20, 0.21, 1.0))
RUBBER = Look("rubber", (0.06, 0.06, 0.06, 1.0))
CONE = _looks("plastic", (0.95, 0.42, 0.05, 1.0), (0.85, 0.12, 0.08, 1.0), (0.95, 0.80, 0.10, 1.0),
              (0.60, 0.85, 0.15, 1.0))  # fmt: skip
RETRO = _looks("plastic", (0.95, 0.95, 0.95, 1.0), (0.80, 0.82, 0.85, 1.0))  # retroreflective white, silver
BRAND = _looks("plastic", (0.45, 0.80, 0.20, 1.0), (0.95, 0.45, 0.10, 1.0), (0.10, 0.60, 0.60, 1.0),
               (0.12, 0.12, 0.13, 1.0), (0.90, 0.30, 0.55, 1.0), (0.85, 0.85, 0.85, 1.0))  # fmt: skip
PASTEL = _looks("metal", (0.60, 0.85, 0.75, 1.0), (0.95, 0.90, 0.75, 1.0), (0.75, 0.10, 0.10, 1.0),
                (0.10, 0.10, 0.12, 1.0), (0.55, 0.75, 0.90, 1.0), (0.95, 0.95, 0.95, 1.0))  # fmt: skip
LEATHER = _looks("plastic", (0.08, 0.08, 0.08, 1.0), (0.40, 0.25, 0.15, 1.0))
TABLETOP = (*WOOD[:3], Look("stone", (0.92, 0.91, 0.88, 1.0)), Look("metal", (0.75, 0.76, 0.78, 1.0)))
SEATING = (
    *PAINT[:3],
    *WOOD[:2],
    Look("plastic", (0.93, 0.93, 0.91, 1.0)),
    Look("wood", (0.62, 0.48, 0.30, 1.0)),
)
CANVAS = _looks("fabric", (0.93, 0.92, 0.86, 1.0), (0.60, 0.10, 0.12, 1.0), (0.15, 0.30, 0.20, 1.0),
                (0.20, 0.25, 0.40, 1.0), (0.85, 0.70, 0.40, 1.0))  # fmt: skip
FACADE = (
    *_looks("brick", (0.60, 0.30, 0.22, 1.0), (0.48, 0.24, 0.18, 1.0)),
    *_looks("plaster", (0.88, 0.84, 0.74, 1.0), (0.93, 0.92, 0.89, 1.0), (0.80, 0.70, 0.55, 1.0)),
    *CONCRETE,
    *_looks("glass", (0.45, 0.58, 0.68, 1.0), (0.30, 0.38, 0.42, 1.0)),  # curtain walls, opaque in massing
)
ROOFING = (
    *_looks("tile", (0.62, 0.28, 0.18, 1.0), (0.30, 0.30, 0.32, 1.0)),
    Look("metal", (0.35, 0.42, 0.40, 1.0)),
)
MEMBRANE = Look("roofing", (0.25, 0.25, 0.26, 1.0))


def _fibonacci(n: int) -> np.ndarray:
    """``n`` unit vectors spread evenly over the sphere (a Fibonacci spiral), deterministic."""
    z = 1 - (np.arange(n) + 0.5) * 2 / n
    angle = np.arange(n) * math.pi * (3 - math.sqrt(5))
    ring = np.sqrt(1 - z**2)
    return np.column_stack([ring * np.cos(angle), ring * np.sin(angle), z])


#: Unit directions a blob (crown, shrub) is the hull of: the six axis directions first.
_SPHERE = np.vstack([np.eye(3), -np.eye(3), _fibonacci(26)])


def _mesh(points: np.ndarray, look: Look) -> ConvexMesh:
    return convex_mesh(points, look)


def _blob(
    rng: np.random.Generator, centre: Sequence[float], radii: Sequence[float], look: Look, floor: float = -1e9
) -> ConvexMesh:
    """A lumpy ellipsoid: the hull of :data:`_SPHERE` scaled to ``radii`` (m) about ``centre``.

    The six axis points lie exactly on the ellipsoid, so its extent along x, y and up is
    exactly ``radii``; the others are pulled in by up to 14 % for a natural outline.
    Points below ``floor`` (m) are lifted onto it, giving a flat bottom.
    """
    scale = np.ones(len(_SPHERE))
    scale[6:] = rng.uniform(0.86, 1.0, len(_SPHERE) - 6)
    points = _SPHERE * scale[:, None] * np.asarray(radii, float) + np.asarray(centre, float)
    points[:, 2] = np.maximum(points[:, 2], floor)
    return _mesh(points, look)


def _polyline(points: Sequence[Sequence[float]], radius: float, look: Look) -> list[Part]:
    """A bent tube of ``radius`` (m) through ``points`` (m): one rod per segment.

    At each bend both rods run on by ``radius * tan(turn / 2)`` (at least :data:`EMBED`),
    closing the outside of the bend up to its mitre and no further; the two ends stop
    exactly at the first and last point.
    """
    pts = [np.asarray(p, float) for p in points]
    dirs = [(b - a) / np.linalg.norm(b - a) for a, b in itertools.pairwise(pts)]
    run = [0.0]
    for d0, d1 in itertools.pairwise(dirs):
        turn = math.acos(float(np.clip(d0 @ d1, -1.0, 1.0)))
        run.append(max(radius * math.tan(min(turn, 2.0) / 2), EMBED))
    run.append(0.0)
    return [
        rod(radius, a - d * run[i], b + d * run[i + 1], look)
        for i, (a, b, d) in enumerate(zip(pts[:-1], pts[1:], dirs, strict=True))
    ]


def _block(x0: float, x1: float, y0: float, y1: float, z0: float, z1: float, look: Look) -> Box:
    """The box spanning x0..x1, y0..y1, z0..z1 (m)."""
    return Box((x1 - x0, y1 - y0, z1 - z0), ((x0 + x1) / 2, (y0 + y1) / 2, (z0 + z1) / 2), 0.0, look)


def _plank(a: Sequence[float], b: Sequence[float], across: float, thick: float, look: Look) -> ConvexMesh:
    """A board from ``a`` to ``b`` (m), ``across`` wide along x (or y for a board along x)
    and ``thick`` thick at right angles to both (m)."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    d = (b - a) / np.linalg.norm(b - a)
    side = np.array([1.0, 0.0, 0.0]) if abs(d[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    side = side - (side @ d) * d
    side /= np.linalg.norm(side)
    normal = np.cross(d, side)
    corners = [
        end + sx * side * across / 2 + sn * normal * thick / 2
        for end in (a, b)
        for sx in (-1, 1)
        for sn in (-1, 1)
    ]
    return _mesh(np.array(corners), look)


def _turn(xyz: np.ndarray, yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.asarray(xyz, float) @ np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])


def _moved(part: Part, yaw: float) -> Part:
    """``part`` turned by ``yaw`` (rad) about the z axis through the origin (a box stays a box)."""
    if isinstance(part, Box):
        return Box(part.size, tuple(_turn(part.pos, yaw).tolist()), part.yaw + yaw, part.material)
    return _mesh(_turn(part.hull_points(), yaw), part.material)


# --------------------------------------------------------------------------- bus stop shelter


def bus_stop_shelter(rng: np.random.Generator) -> list[Part]:
    """A bus stop shelter: a roof on a row of posts, glass at the back and the sides, open
    towards +x (the roadway).

    Roof 1.3-2.1 m deep (x) and 2.6-6.2 m long (y), 80-200 mm thick, flat, mono-pitched
    (front edge 0.25 m lower to 0.35 m higher than the back) or barrel-vaulted (rise
    0.1-0.3 m); its underside 2.3-2.6 m above the ground at the back. Square posts 60-100 mm
    on the back line, 1-4 bays of glass 8-12 mm thick between them, standing 0-0.15 m off
    the ground; front corner posts (50 %) or a cantilevered roof. Each end has a glass
    side panel (55 %), a lit advertising panel 1.1-1.25 m wide and 1.75-1.9 m high (25 %)
    or nothing; a bench (75 %) against the back glass, seat 0.42-0.48 m high, and a
    timetable case 0.4-0.6 m wide (60 %) on the back glass at eye height. Overall:
    2.38-3.15 m high, 1.3-2.1 m (x), 2.6-6.2 m (y).
    """
    depth, length = dim(rng, 1.3, 2.1), dim(rng, 2.6, 6.2)
    clear, thick, post = dim(rng, 2.3, 2.6), dim(rng, 0.08, 0.20), dim(rng, 0.06, 0.10)
    frame, glass, roof_look = pick(rng, (*PAINT, STEEL)), pick(rng, GLAZING), pick(rng, (*PAINT, STEEL))
    roof_style = int(rng.integers(3))  # flat, mono-pitch, barrel
    rise = dim(rng, -0.25, 0.35) if roof_style == 1 else 0.0
    back_in, front_in, side_in = dim(rng, 0.0, 0.1), dim(rng, 0.1, 0.4), dim(rng, 0.08, 0.25)
    x0, x1 = -depth / 2, depth / 2
    xb, xf = x0 + back_in + post / 2, x1 - front_in - post / 2  # back and front post lines

    def under(x: float) -> float:  # the roof's underside (m) above x
        return clear + rise * (x - x0) / depth

    arch = dim(rng, 0.1, 0.3) if roof_style == 2 else 0.0
    xs = np.linspace(x0, x1, 9)
    top = [under(x) + thick + arch * (1 - (2 * x / depth) ** 2) for x in xs.tolist()]
    roof_pts = [(x, y, z) for x, z in ((x0, under(x0)), (x1, under(x1))) for y in (-length / 2, length / 2)]
    roof_pts += [(x, y, z) for x, z in zip(xs.tolist(), top, strict=True) for y in (-length / 2, length / 2)]
    parts: list[Part] = [_mesh(np.array(roof_pts), roof_look)]

    inner = length - 2 * side_in - post
    bays = int(np.clip(round(inner / dim(rng, 1.2, 1.9)), 1, 4))
    ys = np.linspace(-inner / 2, inner / 2, bays + 1).tolist()
    grip = min(thick / 2, 0.03)  # how far posts reach into the roof

    def upright(x: float, y: float) -> Box:
        h = under(x) + grip
        return Box((post, post, h), (x, y, h / 2), 0.0, frame)

    parts += [upright(xb, y) for y in ys]
    four_posts = rng.random() < 0.5
    if four_posts:
        parts += [upright(xf, y) for y in (ys[0], ys[-1])]
    g0, gt = dim(rng, 0.0, 0.15), dim(rng, 0.008, 0.012)
    g1 = min(under(xb), under(xb + post)) - dim(rng, 0.0, 0.3)
    for ya, yb in itertools.pairwise(ys):
        parts.append(Box((gt, yb - ya, g1 - g0), (xb, (ya + yb) / 2, (g0 + g1) / 2), 0.0, glass))
    reach = xf - xb if four_posts else dim(rng, 0.6, xf - xb)
    for y in (ys[0], ys[-1]):
        side = rng.random()
        if side < 0.55:  # glass side panel, from the back post forward
            g1s = min(under(xb), under(xb + reach)) - dim(rng, 0.0, 0.3)
            parts.append(Box((reach, gt, g1s - g0), (xb + reach / 2, y, (g0 + g1s) / 2), 0.0, glass))
        elif side < 0.8:  # lit advertising panel (a 1.2 m x 1.8 m poster case)
            wide, ad_h, ad_t = min(reach, dim(rng, 1.1, 1.25)), dim(rng, 1.75, 1.9), dim(rng, 0.10, 0.14)
            ad_h = min(ad_h, min(under(xb), under(xb + wide)) - g0 - 0.05)
            parts.append(Box((wide, ad_t, ad_h), (xb + wide / 2, y, g0 + ad_h / 2), 0.0, frame))
            parts.append(
                Box(
                    (wide - 0.08, ad_t + 0.004, ad_h - 0.08),
                    (xb + wide / 2, y, g0 + ad_h / 2),
                    0.0,
                    Look("plastic", (0.95, 0.95, 0.90, 1.0)),
                )
            )
    if rng.random() < 0.75:  # bench against the back glass
        seat, seat_d, seat_t = dim(rng, 0.42, 0.48), dim(rng, 0.30, 0.40), dim(rng, 0.03, 0.05)
        span = ys[-1] - ys[0] - post
        seat_l = min(dim(rng, 1.2, 2.4), span - 0.1)
        yc = dim(rng, -(span - seat_l) / 2, (span - seat_l) / 2)
        look = pick(rng, (*WOOD, *PAINT))
        x_back = xb - gt / 2
        parts.append(Box((seat_d, seat_l, seat_t), (x_back + seat_d / 2, yc, seat - seat_t / 2), 0.0, look))
        for sy in (-1, 1):
            leg_h = seat - seat_t + EMBED
            leg_y = yc + sy * (seat_l / 2 - 0.1)
            parts.append(
                Box((seat_d * 0.8, 0.04, leg_h), (x_back + seat_d * 0.45, leg_y, leg_h / 2), 0.0, frame)
            )
    if rng.random() < 0.6:  # timetable case on a back post, facing the stop
        wide, high, case = dim(rng, 0.4, 0.6), dim(rng, 0.55, 0.8), dim(rng, 0.025, 0.05)
        y = float(np.clip(ys[int(rng.integers(len(ys)))], ys[0] + wide / 2, ys[-1] - wide / 2))
        z = dim(rng, 1.35, 1.6)
        parts.append(Box((case, wide, high), (xb + gt / 2 + case / 2 - EMBED, y, z), 0.0, frame))
    return parts


# --------------------------------------------------------------------------------------- tree


def tree(rng: np.random.Generator) -> list[Part]:
    """A street or park tree: a tapered trunk and a crown of 1-4 convex lumps.

    Four habits: broad (an oval crown of 1-4 lumps, 5-14 m tall, clear stem 1.5-3 m),
    columnar (a capsule 1.5-3 m across, 5-14 m, from 0.5-2.5 m), conifer (1-4 stacked
    cones, 3-14 m, branching from 0.3-1.5 m) and young street tree (3-5.5 m, clear stem
    1.5-2.2 m, 2-3 stakes tied to a thin trunk). The crown is 1.5-7 m across and reaches
    exactly its radius along x and y, so the footprint is the crown's diameter both ways.
    Trunk radius 1.5-2.5 % of the height at the base (40-70 mm for young trees) tapering
    to 50-80 %, optional root flare (40 %). All but conifers may stand in a tree grate or
    mulched pit (50 %) 1.0-1.8 m square, 20-40 mm high. Overall: 3-14 m high, 1.5-7 m
    (x and y).

    Anchored ``free``, not ``curb``: a tree belongs in a park's vegetation or on a plaza as
    much as in a furnishing strip, and placement draws curb-anchored objects from
    furnishing strips and curbs only.
    """
    habit = int(rng.choice(4, p=[0.4, 0.15, 0.25, 0.2]))  # broad, columnar, conifer, young
    bark = pick(rng, BARK)
    if habit == 0:
        h = dim(rng, 5.0, 14.0)
        d = dim(rng, max(1.5, 0.35 * h), min(7.0, 0.7 * h))
        base = dim(rng, 1.5, min(3.0, 0.45 * h))
    elif habit == 1:
        h = dim(rng, 5.0, 14.0)
        d = dim(rng, 1.5, min(3.0, 0.3 * h))
        base = dim(rng, 0.5, min(2.5, 0.3 * h))
    elif habit == 2:
        h = dim(rng, 3.0, 14.0)
        d = dim(rng, max(1.5, 0.3 * h), min(7.0, 0.55 * h))
        base = dim(rng, 0.3, min(1.5, 0.2 * h))
    else:
        h = dim(rng, 3.0, 5.5)
        d = dim(rng, 1.5, min(3.0, 0.6 * h))
        base = dim(rng, 1.5, min(2.2, h - 1.2))
    r, crown = d / 2, h - base
    r0 = dim(rng, 0.04, 0.07) if habit == 3 else round(h * dim(rng, 0.015, 0.025), 3)
    r1 = round(r0 * dim(rng, 0.5, 0.8), 3)
    leaves = pick(rng, NEEDLES if habit == 2 else (LEAVES if rng.random() < 0.85 else BLOSSOM))
    parts: list[Part] = []
    if habit == 2:  # stacked cones; the bottom one is exactly d across
        tiers = int(rng.integers(1, 5))
        tier_h = crown if tiers == 1 else crown * min(0.9, dim(rng, 1.2, 1.6) / tiers)
        step = 0.0 if tiers == 1 else (crown - tier_h) / (tiers - 1)
        for i in range(tiers):
            z0 = base + i * step
            parts.append(frustum(r * (1 - 0.6 * i / tiers), 0.0, z0, min(h, z0 + tier_h), leaves))
        trunk_top = base + 0.3 * tier_h
    elif habit == 1:  # a capsule whose circumscribed outline is exactly d across
        cap = r * math.cos(math.pi / 24)
        parts.append(Capsule(cap, crown - 2 * cap, (0.0, 0.0, base + crown / 2), leaves))
        trunk_top = base + crown / 2
    else:  # a main oval lump and up to three more inside its outline
        zc = base + crown / 2
        parts.append(_blob(rng, (0.0, 0.0, zc), (r, r, crown / 2), leaves))
        for _ in range(int(rng.integers(0, 4)) if habit == 0 else 0):
            angle = rng.uniform(0, 2 * math.pi)
            cz = zc + crown * dim(rng, -0.05, 0.15)
            centre = (0.45 * r * math.cos(angle), 0.45 * r * math.sin(angle), cz)
            vertical = min(crown * dim(rng, 0.3, 0.45), h - cz, cz - base)
            lump = 0.55 * r * dim(rng, 0.7, 1.0)
            parts.append(_blob(rng, centre, (lump, lump, vertical), leaves))
        trunk_top = zc
    parts.append(frustum(r0, r1, 0.0, trunk_top, bark))
    if rng.random() < 0.4:
        flare = dim(rng, 0.15, 0.4)
        parts.append(frustum(r0 * dim(rng, 1.3, 1.6), r0, 0.0, flare, bark))
    if habit == 3:  # stakes tied to the trunk
        stakes, reach, stake_h = int(rng.integers(2, 4)), dim(rng, 0.3, 0.4), dim(rng, 1.2, min(1.8, base))
        turn = rng.uniform(0, 2 * math.pi)
        for k in range(stakes):
            a = turn + 2 * math.pi * k / stakes
            x, y = reach * math.cos(a), reach * math.sin(a)
            parts.append(Cylinder(0.035, stake_h, (x, y, stake_h / 2), WOOD[2]))
            parts.append(rod(0.012, (x, y, stake_h - 0.1), (0.0, 0.0, stake_h - 0.1), RUBBER))
    if habit != 2 and rng.random() < 0.5:  # tree grate or mulched pit
        side = dim(rng, 1.0, min(1.8, d))
        pit = dim(rng, 0.02, 0.04)
        parts.append(Box((side, side, pit), (0.0, 0.0, pit / 2), 0.0, GRATE if rng.random() < 0.5 else MULCH))
    return parts


# --------------------------------------------------------------------------------------- bush


def bush(rng: np.random.Generator) -> list[Part]:
    """A shrub of 1-5 overlapping lumps with a flat bottom, or a clipped hedge block.

    Shrub: 0.4-2.0 m across in x and y independently, 0.4-2.0 m high (at most 1.3 times
    its widest side); one main lump spans the whole width, up to four more sit inside it.
    Hedge (30 %): 0.4-1.2 m deep (x), 0.8-2.0 m long (y), 0.4-1.8 m high, top edges
    chamfered 50-200 mm. Green, yellow-green, red-leaved or flowering. Overall:
    0.4-2.0 m high, 0.4-2.0 m (x and y).
    """
    leaves = pick(rng, LEAVES + BLOSSOM if rng.random() < 0.2 else LEAVES)
    if rng.random() < 0.3:  # clipped hedge block
        sx, sy, h = dim(rng, 0.4, 1.2), dim(rng, 0.8, 2.0), dim(rng, 0.4, 1.8)
        c = min(dim(rng, 0.05, 0.2), sx / 3, h / 3)
        taper = dim(rng, 0.0, 0.06)  # the top is narrower than the bottom
        pts = [(x * sx / 2, y * sy / 2, 0.0) for x in (-1, 1) for y in (-1, 1)]
        pts += [(x * (sx / 2 - taper), y * (sy / 2 - taper), h - c) for x in (-1, 1) for y in (-1, 1)]
        pts += [(x * (sx / 2 - taper - c), y * (sy / 2 - taper - c), h) for x in (-1, 1) for y in (-1, 1)]
        return [_mesh(np.array(pts), pick(rng, FOLIAGE))]
    sx, sy = dim(rng, 0.4, 2.0), dim(rng, 0.4, 2.0)
    h = dim(rng, 0.4, min(2.0, 1.3 * max(sx, sy)))
    zc = h * dim(rng, 0.3, 0.42)  # the main lump's centre; below it, it is cut flat at the ground
    rz = h - zc
    parts: list[Part] = [_blob(rng, (0.0, 0.0, zc), (sx / 2, sy / 2, rz), leaves, floor=0.0)]
    for _ in range(int(rng.integers(0, 5))):
        d = rng.normal(size=3)
        d = 0.5 * d / np.linalg.norm(d)
        cx, cy, cz = d[0] * sx / 2, d[1] * sy / 2, zc + d[2] * rz
        radii = (
            (sx / 2 - abs(cx)) * dim(rng, 0.6, 1.0),
            (sy / 2 - abs(cy)) * dim(rng, 0.6, 1.0),
            (h - cz) * dim(rng, 0.6, 1.0),
        )
        parts.append(_blob(rng, (cx, cy, cz), radii, leaves, floor=0.0))
    return parts


# ---------------------------------------------------------------------------------- bike rack


def _hoop(y: float, half: float, high: float, r: float, top: int, look: Look, chamfer: float) -> list[Part]:
    """An inverted U in the x-z plane at ``y``: legs at x = +-``half`` from the ground to
    ``high`` (m) at the tube's top; ``top`` 0 round, 1 chamfered, 2 square-cornered."""
    z = high - r
    if top == 0:  # a half circle of four segments, its mitred top vertex r / cos(22.5 deg) below the top
        zc = high - r / math.cos(math.pi / 8) - half
        arc = [(half * math.cos(a), y, zc + half * math.sin(a)) for a in np.linspace(0, math.pi, 5).tolist()]
        pts = [(half, y, 0.0), *arc, (-half, y, 0.0)]
    elif top == 1:
        pts = [
            (half, y, 0.0),
            (half, y, z - chamfer),
            (half - chamfer, y, z),
            (-half + chamfer, y, z),
            (-half, y, z - chamfer),
            (-half, y, 0.0),
        ]
    else:
        pts = [(half, y, 0.0), (half, y, z), (-half, y, z), (-half, y, 0.0)]
    return _polyline(pts, r, look)


def bike_rack(rng: np.random.Generator) -> list[Part]:
    """A bike rack on flat base rails: a row of inverted-U stands, a wheel-bay rack or a wave.

    Stands (Sheffield): 2-5 hoops 0.75-1.0 m apart, 0.6-0.9 m long (x), 0.75-0.95 m high,
    tube radius 24-32 mm, round, chamfered or square tops. Wheel bays: 4-9 low hoops
    0.35-0.5 m apart, 0.4-0.65 m long, 0.3-0.45 m high, either alternating high and low
    (40 %) or all alike and joined by a top tube; more than six get square tops. Wave: one
    tube snaking along y over 2-4 humps 0.75-0.95 m high on a centre rail with end feet
    0.3-0.5 m long. Rails 8-15 mm thick, 60-110 mm wide, reaching 0.1-0.25 m past the end
    hoops. Bikes park along x. Overall: 0.3-0.95 m high, 0.3-1.01 m (x), 0.95-4.5 m (y).
    """
    look = pick(rng, (STEEL, STEEL, *PAINT))
    style = int(rng.integers(3))
    r, rail_t, end = dim(rng, 0.024, 0.032), dim(rng, 0.008, 0.015), dim(rng, 0.1, 0.25)
    rail_w = round(2 * r + dim(rng, 0.01, 0.045), 3)
    parts: list[Part] = []
    if style == 2:  # wave
        humps, high, half_x = int(rng.integers(2, 5)), dim(rng, 0.75, 0.95), dim(rng, 0.15, 0.25)
        wide, gap, c = dim(rng, 0.4, 0.6), dim(rng, 0.2, 0.35), dim(rng, 0.08, 0.15)
        total = humps * wide + (humps - 1) * gap
        zb, z = rail_t + r - EMBED, high - r
        pts = [(0.0, -total / 2, 0.0)]
        for i in range(humps):
            y0 = -total / 2 + i * (wide + gap)
            if i:
                pts.append((0.0, y0, zb))
            pts += [(0.0, y0, z - c), (0.0, y0 + c, z), (0.0, y0 + wide - c, z), (0.0, y0 + wide, z - c)]
            pts.append((0.0, y0 + wide, zb) if i < humps - 1 else (0.0, y0 + wide, 0.0))
        parts += _polyline(pts, r, look)
        length = total + 2 * end
        parts.append(Box((rail_w, length, rail_t), (0.0, 0.0, rail_t / 2), 0.0, look))
        parts += [
            Box((2 * half_x, rail_w, rail_t), (0.0, s * (length - rail_w) / 2, rail_t / 2), 0.0, look)
            for s in (-1, 1)
        ]
        return parts
    if style == 0:  # Sheffield stands
        n, spacing = int(rng.integers(2, 6)), dim(rng, 0.75, 1.0)
        half, high = dim(rng, 0.3, 0.45), dim(rng, 0.75, 0.95)
        highs = [high] * n
    else:  # wheel bays
        n, spacing = int(rng.integers(4, 10)), dim(rng, 0.35, 0.5)
        half, high = dim(rng, 0.2, 0.325), dim(rng, 0.3, 0.45)
        low = round(high * dim(rng, 0.7, 0.85), 3) if rng.random() < 0.4 else high
        highs = [high if i % 2 == 0 else low for i in range(n)]
    # round tops need legs under the arc; more than six hoops get square tops (fewer parts)
    top = int(rng.integers(3)) if n <= 6 else 2
    if top == 0 and min(highs) - 1.1 * r - half < 0.1:
        top = int(rng.integers(1, 3))
    chamfer = dim(rng, 0.04, min(0.15, half / 2, (min(highs) - r) / 2))
    ys = ((np.arange(n) - (n - 1) / 2) * spacing).tolist()
    for y, hi in zip(ys, highs, strict=True):
        parts += _hoop(y, half, hi, r, top, look, chamfer)
    length = (n - 1) * spacing + 2 * end
    parts += [Box((rail_w, length, rail_t), (s * half, 0.0, rail_t / 2), 0.0, look) for s in (-1, 1)]
    if style == 1 and low == high:  # a top tube along the bays
        z = min(highs) - r
        parts.append(rod(r, (0.0, ys[0], z), (0.0, ys[-1], z), look))
    return parts


# ------------------------------------------------------------------------------- traffic cone


def traffic_cone(rng: np.random.Generator) -> list[Part]:
    """A traffic cone on a square or octagonal base, with retroreflective collars.

    Height 0.3-1.0 m; base 90-105 % of (0.10 + 0.35 x height) across (0.18-0.48 m),
    20-40 mm thick; cone radius 38-45 % of the base at the bottom, 15-40 mm at the top.
    0-3 white or silver collars 40-150 mm deep, standing 2 mm proud of the cone. Orange,
    red, yellow or lime. Overall: 0.3-1.0 m high, 0.18-0.48 m (x and y).
    """
    h = dim(rng, 0.3, 1.0)
    s = round((0.10 + 0.35 * h) * dim(rng, 0.9, 1.05), 3)
    body, collar = pick(rng, CONE), pick(rng, RETRO)
    base_look = body if rng.random() < 0.4 else RUBBER
    tb = dim(rng, 0.02, 0.04)
    if rng.random() < 0.6:
        parts: list[Part] = [Box((s, s, tb), (0.0, 0.0, tb / 2), 0.0, base_look)]
    else:  # octagon with corners on the axes, exactly s across
        parts = [frustum(s / 2, s / 2 * 0.96, 0.0, tb, base_look, sides=8)]
    r0, r1 = s * dim(rng, 0.38, 0.45), dim(rng, 0.015, 0.04)
    z0 = tb - EMBED
    parts.append(frustum(r0, r1, z0, h, body))

    def radius(z: float) -> float:
        return r0 + (r1 - r0) * (z - z0) / (h - z0)

    bands = int(rng.integers(0, 4)) if h >= 0.45 else int(rng.integers(0, 2))
    slot = (h - z0) * 0.8 / max(bands, 1)
    for i in range(bands):
        deep = min(dim(rng, 0.04, 0.15), slot * 0.7)
        top = h - 0.08 * (h - z0) - i * slot
        parts.append(frustum(radius(top - deep) + 0.002, radius(top) + 0.002, top - deep, top, collar))
    return parts


# ----------------------------------------------------------------------------- parked scooter


def _kick_scooter(rng: np.random.Generator) -> list[Part]:
    """A kick e-scooter built upright along y (front +y), then leaned onto its kickstand."""
    r, ww, wb = dim(rng, 0.10, 0.14), dim(rng, 0.04, 0.065), dim(rng, 0.78, 0.95)
    db, dt, dw = dim(rng, 0.06, 0.10), dim(rng, 0.04, 0.07), dim(rng, 0.14, 0.20)
    paint, dark = pick(rng, BRAND), pick(rng, (RUBBER, PAINT[1], PAINT[2]))
    yr, yf = -wb / 2, wb / 2
    y_dr, y_df = yr + r + dim(rng, 0.01, 0.03), yf - r - dim(rng, 0.02, 0.06)
    deck_z = db + dt / 2
    parts: list[Part] = [rod(r, (-ww / 2, y, r), (ww / 2, y, r), RUBBER) for y in (yr, yf)]
    parts.append(Box((dw, y_df - y_dr, dt), (0.0, (y_dr + y_df) / 2, deck_z), 0.0, paint))
    low, high = min(r, deck_z) - 0.015, max(r, deck_z) + 0.015
    parts.append(_block(-ww / 2 - 0.01, ww / 2 + 0.01, yr, y_dr + 0.02, low, high, dark))  # wheel to deck
    fender_z = 2 * r + 0.012
    half_w = ww / 2 + 0.015
    parts.append(_block(-half_w, half_w, yr - 0.6 * r, y_dr + 0.02, fender_z - 0.004, fender_z + 0.004, dark))
    riser = fender_z + 0.004 - (db + dt) + EMBED
    parts.append(Box((dw * 0.6, 0.02, riser), (0.0, y_dr + 0.01, db + dt - EMBED + riser / 2), 0.0, dark))
    rake, bar_z, stem_r = math.radians(dim(rng, 8.0, 16.0)), dim(rng, 0.95, 1.2), dim(rng, 0.02, 0.03)

    def stem_y(z: float) -> float:
        return yf - (z - r) * math.tan(rake)

    parts.append(rod(stem_r, (0.0, yf, r), (0.0, stem_y(bar_z), bar_z), paint))
    neck_z = dim(rng, 0.25, 0.4)
    parts.append(rod(dim(rng, 0.02, 0.03), (0.0, y_df - 0.02, deck_z), (0.0, stem_y(neck_z), neck_z), paint))
    bar, bar_r, grip = dim(rng, 0.40, 0.60), dim(rng, 0.011, 0.015), dim(rng, 0.09, 0.13)
    yb = stem_y(bar_z)
    parts.append(rod(bar_r, (-bar / 2, yb, bar_z), (bar / 2, yb, bar_z), dark))
    parts += [
        rod(bar_r + 0.008, (s * (bar / 2 - grip), yb, bar_z), (s * bar / 2, yb, bar_z), RUBBER)
        for s in (-1, 1)
    ]
    light_z = dim(rng, 0.45, 0.9)
    parts.append(Box((0.06, 0.05, 0.04), (0.0, stem_y(light_z) + stem_r + 0.02, light_z), 0.0, RETRO[0]))
    if rng.random() < 0.5:  # display / phone holder above the bar
        parts.append(Box((0.08, 0.05, 0.03), (0.0, yb, bar_z + bar_r + 0.012), 0.0, dark))
    # Lean everything onto the -x side by turning it about the y axis ...
    lean = math.radians(dim(rng, 4.0, 9.0))
    c, s = math.cos(lean), math.sin(lean)
    turn = np.array([[c, 0.0, -s], [0.0, 1.0, 0.0], [s, 0.0, c]])
    points = [p.hull_points() @ turn.T for p in parts]
    floor = min(float(p[:, 2].min()) for p in points[:2])  # the wheels' lowest point
    # ... and put the kickstand down: from under the deck's -x edge to the ground.
    ks_r, out, back = dim(rng, 0.008, 0.012), dim(rng, 0.10, 0.16), dim(rng, 0.03, 0.08)
    y_k = dim(rng, y_dr + 0.05, (y_dr + y_df) / 2)
    start = turn @ np.array([-dw / 2 + 0.02, y_k, db + 0.01])
    end = np.array([start[0] - out, y_k - back, floor])
    for _ in range(3):  # the tilted rod's rim must just reach the wheels' lowest point
        stand = rod(ks_r, start, end, dark).hull_points()
        end[2] += floor - stand[:, 2].min()
    points.append(rod(ks_r, start, end, dark).hull_points())
    looks = [p.material for p in parts] + [dark]
    lift = -min(float(p[:, 2].min()) for p in points)
    return [_mesh(p + np.array([0.0, 0.0, lift]), look) for p, look in zip(points, looks, strict=True)]


def _moped(rng: np.random.Generator) -> list[Part]:
    """A moped / Vespa-like scooter on its centre stand, built along y (front +y)."""
    r, ww, wb = dim(rng, 0.20, 0.27), dim(rng, 0.09, 0.13), dim(rng, 1.15, 1.35)
    paint, trim, seat_look = pick(rng, PASTEL), pick(rng, (STEEL, PAINT[1])), pick(rng, LEATHER)
    yr, yf = -wb / 2, wb / 2
    parts: list[Part] = [rod(r, (-ww / 2, y, r), (ww / 2, y, r), RUBBER) for y in (yr, yf)]
    fb_z, fw = dim(rng, 0.22, 0.30), dim(rng, 0.28, 0.36)
    body_front, body_rear = yr + r + dim(rng, 0.1, 0.25), yr - r * dim(rng, 0.7, 1.0)
    seat_z, bw = dim(rng, 0.62, 0.72), dim(rng, 0.15, 0.20)
    body = [(x * bw, body_front, z) for x in (-1, 1) for z in (fb_z - 0.05, seat_z)]
    body += [(x * bw * 0.7, body_rear, z) for x in (-1, 1) for z in (1.2 * r, seat_z)]
    body += [(x * bw, (body_front + body_rear) / 2, r * 1.1) for x in (-1, 1)]
    parts.append(_mesh(np.array(body), paint))
    y_ff = yf - r - dim(rng, 0.05, 0.12)
    parts.append(_block(-fw / 2, fw / 2, body_front - 0.05, y_ff, fb_z - 0.06, fb_z, paint))  # floorboard
    stand_y = body_front + dim(rng, 0.0, 0.1)
    parts.append(
        Box((fw * 0.8, 0.04, fb_z - 0.06 + EMBED), (0.0, stand_y, (fb_z - 0.06 + EMBED) / 2), 0.0, trim)
    )
    rake, bar_z = math.radians(dim(rng, 18.0, 25.0)), dim(rng, 0.95, 1.1)
    shield_z = bar_z - dim(rng, 0.08, 0.15)
    shield_top = (0.0, y_ff - (shield_z - fb_z) * math.tan(rake), shield_z)
    parts.append(
        _plank((0.0, y_ff - 0.02, fb_z - 0.06), shield_top, dim(rng, 0.34, 0.42), dim(rng, 0.04, 0.06), paint)
    )
    top = (0.0, yf - (bar_z - r) * math.tan(rake), bar_z)
    parts.append(rod(dim(rng, 0.025, 0.035), (0.0, yf, r), top, trim))
    parts.append(_plank(shield_top, top, 0.2, 0.12, paint))
    fender_y = yf - r * math.tan(rake)
    parts.append(Box((ww + 0.05, 1.2 * r, 0.05), (0.0, fender_y, 2 * r + 0.04), 0.0, paint))
    bar = dim(rng, 0.62, 0.74)
    parts.append(rod(0.013, (-bar / 2, top[1], bar_z), (bar / 2, top[1], bar_z), trim))
    parts += [
        rod(0.02, (s * (bar / 2 - 0.12), top[1], bar_z), (s * bar / 2, top[1], bar_z), RUBBER)
        for s in (-1, 1)
    ]
    parts.append(Box((0.30, 0.16, 0.12), (0.0, top[1], bar_z), 0.0, paint))
    parts.append(
        rod(dim(rng, 0.06, 0.08), (0.0, top[1], bar_z), (0.0, top[1] + dim(rng, 0.1, 0.14), bar_z), RETRO[0])
    )
    if rng.random() < 0.8:  # mirrors on stalks
        stalk = dim(rng, 0.2, 0.3)
        for s in (-1, 1):
            foot = (s * (bar / 2 - 0.15), top[1], bar_z)
            head = (s * (bar / 2 - 0.06), top[1] - 0.03, bar_z + stalk)
            parts.append(rod(0.008, foot, head, trim))
            parts.append(Box((0.12, 0.03, 0.08), (head[0], head[1], head[2] + 0.03), 0.0, trim))
    seat_l, seat_w, seat_t = dim(rng, 0.55, 0.72), dim(rng, 0.26, 0.32), dim(rng, 0.08, 0.12)
    seat_y = (body_front + body_rear) / 2 + dim(rng, 0.0, 0.08)
    parts.append(Box((seat_w, seat_l, seat_t), (0.0, seat_y, seat_z + seat_t / 2 - EMBED), 0.0, seat_look))
    if rng.random() < 0.3:  # top case on a rear rack
        case = (dim(rng, 0.32, 0.4), dim(rng, 0.26, 0.34), dim(rng, 0.26, 0.32))
        parts.append(
            Box(
                case,
                (0.0, body_rear + case[1] / 2 - 0.05, seat_z + case[2] / 2 - EMBED),
                0.0,
                pick(rng, (paint, PAINT[1], RETRO[0])),
            )
        )
    return parts


def parked_scooter(rng: np.random.Generator) -> list[Part]:
    """A parked scooter, its length along y (lined up with the curb), either way round.

    Kick e-scooter (60 %): wheels 100-140 mm in radius, 0.78-0.95 m apart; deck 0.14-0.20 m
    wide at 60-100 mm; stem raked 8-16 degrees to a handlebar 0.40-0.60 m wide at
    0.95-1.2 m; leaning 4-9 degrees onto a kickstand on one side. Moped (40 %): wheels
    200-270 mm, 1.15-1.35 m apart; floorboard at 0.22-0.30 m, leg shield, rear body and seat
    at 0.62-0.72 m, handlebar 0.62-0.74 m wide at 0.95-1.1 m, mirrors (80 %), top case
    (30 %); on its centre stand. Overall: 0.93-1.47 m high, 0.35-0.76 m (x), 0.98-1.95 m (y).
    """
    parts = _kick_scooter(rng) if rng.random() < 0.6 else _moped(rng)
    flip = np.array([1.0 if rng.random() < 0.5 else -1.0, 1.0 if rng.random() < 0.5 else -1.0, 1.0])
    if flip[0] == flip[1] == 1.0:
        return parts
    return [_mesh(p.hull_points() * flip, p.material) for p in parts]


# --------------------------------------------------------------------------------- cafe table


def _chair(
    rng: np.random.Generator, front: float, size: tuple[float, float, float], look: Look
) -> list[Part]:
    """A chair facing -x, its front legs' inner faces at x = ``front`` (m); ``size`` is the
    seat's depth, width and height (m)."""
    depth, width, seat = size
    leg, seat_t = dim(rng, 0.02, 0.035), dim(rng, 0.02, 0.05)
    legs = seat - seat_t + EMBED
    parts: list[Part] = [
        Box((leg, leg, legs), (front + leg / 2 + dx, sy * (width / 2 - leg / 2), legs / 2), 0.0, look)
        for dx in (0.0, depth - leg)
        for sy in (-1, 1)
    ]
    parts.append(Box((depth, width, seat_t), (front + depth / 2, 0.0, seat - seat_t / 2), 0.0, look))
    rise, lean, back_t = dim(rng, 0.32, 0.45), math.radians(dim(rng, 4.0, 12.0)), dim(rng, 0.015, 0.03)
    x_back = front + depth - back_t / 2
    z0 = seat - EMBED

    def board(high: float, wide: float, z_bottom: float, y: float = 0.0) -> ConvexMesh:
        z = z_bottom + high / 2 * math.cos(lean)  # the board's centre, on the line leaning back from x_back
        centre = (x_back + (z - z0) * math.tan(lean), y, z)
        return tilted((back_t, wide, high), centre, lean, look)

    if rng.random() < 0.5:  # one solid back panel
        parts.append(board(rise, width, z0))
    else:  # two posts and one or two rails
        parts += [board(rise, leg, z0, sy * (width / 2 - leg / 2)) for sy in (-1, 1)]
        rail = dim(rng, 0.05, 0.12)
        for k in range(int(rng.integers(1, 3))):
            parts.append(board(rail, width, z0 + rise - rail - k * (rail + 0.06)))
    return parts


def cafe_table(rng: np.random.Generator) -> list[Part]:
    """A cafe table on a base plate with 2-4 chairs pushed in around it, optionally under a
    parasol.

    Round top 0.6-0.9 m across or square top 0.6-0.8 m a side, 20-40 mm thick, 0.72-0.76 m
    high, on a column 25-50 mm in radius and a round or square base plate, domed or flat.
    Chairs: seat 0.40-0.46 m deep and wide at 0.44-0.47 m, back 0.32-0.45 m above it
    leaning 4-12 degrees, solid or railed; pushed in until their front legs meet the base
    plate, their seats under the top but their backs clear of it and of each other.
    Parasol (35 %): canopy 2.0-3.0 m across (round, octagonal or square), rim at
    2.0-2.3 m, rising 0.3-0.5 m. Overall: 0.75-2.8 m high, 0.6-3.0 m (x and y).
    """
    square = rng.random() < 0.4
    top_h, top_t = dim(rng, 0.72, 0.76), dim(rng, 0.02, 0.04)
    half = dim(rng, 0.3, 0.4) if square else dim(rng, 0.3, 0.45)  # half the top's width (m)
    n = int(rng.choice([2, 4])) if square else int(rng.integers(2, 5))
    col = dim(rng, 0.025, 0.05)
    size = (dim(rng, 0.40, 0.46), dim(rng, 0.40, 0.46), dim(rng, 0.44, 0.47))
    depth, width = size[0], size[1]
    spread = 2 * math.pi / n
    clear = 0.0 if n == 2 else (width / 2) / math.tan(spread / 2) + 0.02  # chairs miss each other
    square_plate = square and rng.random() < 0.6  # else round; both reach the chairs' front legs
    # a square plate's edge meets the front legs only where it is as wide as the chair
    front_min = max(col + 0.04, half - depth + 0.05, clear, width / 2 if square_plate else 0.0)
    front = dim(rng, front_min, max(front_min, half - 0.05))
    chair_look, wood = pick(rng, SEATING), pick(rng, TABLETOP)
    frame = pick(rng, (*PAINT[:3], STEEL))
    parts: list[Part] = []
    plate_t = dim(rng, 0.01, 0.03)
    if square_plate:
        plate = front + EMBED
        parts.append(Box((2 * plate, 2 * plate, plate_t), (0.0, 0.0, plate_t / 2), 0.0, frame))
    else:  # round plate whose 24-gon reaches past the front legs' inner corners
        thinnest = 0.02  # the front legs' inner corner is at least this far in from the seat's side
        plate = math.hypot(front, width / 2 - thinnest) / math.cos(math.pi / 24) + 2 * EMBED
        if rng.random() < 0.5:
            parts.append(Cylinder(plate, plate_t, (0.0, 0.0, plate_t / 2), frame))
        else:
            parts.append(frustum(plate, plate * 0.5, 0.0, plate_t + dim(rng, 0.02, 0.04), frame))
    parasol = rng.random() < 0.35
    rim, rise = dim(rng, 2.0, 2.3), dim(rng, 0.3, 0.5)
    column_top = rim + rise - 0.05 if parasol else top_h - top_t + EMBED
    parts.append(Cylinder(col, column_top, (0.0, 0.0, column_top / 2), frame))
    if square:
        parts.append(Box((2 * half, 2 * half, top_t), (0.0, 0.0, top_h - top_t / 2), 0.0, wood))
    else:
        parts.append(Cylinder(half, top_t, (0.0, 0.0, top_h - top_t / 2), wood))
    start = (0.0 if rng.random() < 0.5 else spread / 2) if not square else 0.0
    if n == 2 and rng.random() < 0.5 and not square:
        start = math.pi / 2  # the two chairs side to side
    chair = _chair(rng, front, size, chair_look)
    for k in range(n):
        parts += [_moved(p, start + k * spread) for p in chair]
    if parasol:
        canopy, cloth = dim(rng, 1.0, 1.5), pick(rng, CANVAS)
        shape = int(rng.integers(3))
        if shape == 2:  # square, its edges along x and y
            pts = [(x * canopy, y * canopy, rim) for x in (-1, 1) for y in (-1, 1)]
            pts += [(x * 0.03, y * 0.03, rim + rise) for x in (-1, 1) for y in (-1, 1)]
            parts.append(_mesh(np.array(pts), cloth))
        else:
            parts.append(frustum(canopy, 0.03, rim, rim + rise, cloth, sides=(24, 8)[shape]))
    return parts


# ----------------------------------------------------------------------------------- building


def _parapet(
    x0: float, x1: float, y0: float, y1: float, z: float, high: float, wall: float, look: Look
) -> list[Part]:
    """A low wall (``high`` m, ``wall`` m thick) round the roof edge of the box x0..x1, y0..y1 at z."""
    zc = z - EMBED + high / 2
    return [
        *(
            Box((x1 - x0, wall, high), ((x0 + x1) / 2, y, zc), 0.0, look)
            for y in (y0 + wall / 2, y1 - wall / 2)
        ),
        *(
            Box((wall, y1 - y0, high), (x, (y0 + y1) / 2, zc), 0.0, look)
            for x in (x0 + wall / 2, x1 - wall / 2)
        ),
    ]


def building(rng: np.random.Generator) -> list[Part]:
    """Building massing: one box, an L of two wings or a stepped tower of 2-4 boxes.

    Footprint 8-40 m a side (x and y), centred on the origin: the box (or the L's bounding
    rectangle, or the tower's podium) is exactly that size, so placement can scale and turn
    it to fill a lot; an L's wings are each 30-65 % of the side (at least 6 m) and 14-40 m
    long. Ground floor 4-5 m, upper floors 2.9-3.6 m. Roof: flat with a membrane, parapet
    0.4-1.2 m high (60 %) and 1-3 plant rooms 2-5 m wide, 1.5-4.5 m high (40 %), or (low boxes up to
    16 m deep, 45 %) a gable or hip roof rising 25-60 % of half the depth, its eaves
    overhanging the walls by 0-0.6 m. Overall: 4-60 m high, 8-40 m (x and y).
    """
    style = int(rng.choice(3, p=[0.45, 0.25, 0.3]))  # box, L, stepped tower
    facade, top_look = pick(rng, FACADE), pick(rng, FACADE)
    ground, storey = dim(rng, 4.0, 5.0), dim(rng, 2.9, 3.6)
    low = 14.0 if style == 1 else 8.0
    sx, sy = dim(rng, low, 40.0), dim(rng, low, 40.0)
    x0, x1, y0, y1 = -sx / 2, sx / 2, -sy / 2, sy / 2
    pitched = style == 0 and min(sx, sy) <= 16.0 and rng.random() < 0.45
    parapet = dim(rng, 0.4, 1.2) if not pitched and rng.random() < 0.6 else 0.0
    plant = dim(rng, 1.5, 4.5) if not pitched and rng.random() < 0.4 else 0.0
    roof_rise = round(dim(rng, 0.25, 0.6) * min(sx, sy) / 2, 3) if pitched else 0.0
    membrane = 0.05
    room = 60.0 - max(parapet, plant, roof_rise, membrane) - ground  # what the upper floors may take
    most = int(room // storey) + 1
    floors = 1 + int((min(most, 5 if pitched else 16) - 1) * rng.random() ** 1.5)
    if style == 2:
        floors = max(floors, 3)

    def height(k: int) -> float:
        return ground + (k - 1) * storey

    parts: list[Part] = []
    if style == 0:
        top = height(floors)
        if pitched:
            eave = dim(rng, 0.0, 0.6)
            parts.append(_block(x0 + eave, x1 - eave, y0 + eave, y1 - eave, 0.0, top, facade))
            ridge_x = sx >= sy  # the ridge runs along the longer side
            hip = rng.random() < 0.4
            pts = [(x, y, top - EMBED) for x in (x0, x1) for y in (y0, y1)]
            inset = min(sx, sy) / 2 if hip else 0.0
            if ridge_x:
                pts += [(x, 0.0, top - EMBED + roof_rise) for x in (x0 + inset, x1 - inset)]
            else:
                pts += [(0.0, y, top - EMBED + roof_rise) for y in (y0 + inset, y1 - inset)]
            parts.append(_mesh(np.array(pts), pick(rng, ROOFING)))
            return parts
        parts.append(_block(x0, x1, y0, y1, 0.0, top, facade))
        roofs = [(x0, x1, y0, y1, top)]
    elif style == 1:
        wx = dim(rng, max(6.0, 0.3 * sx), 0.65 * sx)
        wy = dim(rng, max(6.0, 0.3 * sy), 0.65 * sy)
        other = int(np.clip(floors + rng.choice([-2, -1, 1, 2]), 1, most))
        if other == floors:
            other = floors + 1 if floors < most else floors - 1
        fx, fy = (1 if rng.random() < 0.5 else -1), (1 if rng.random() < 0.5 else -1)
        # wing A along x at the -y side, wing B along y at the -x side (then mirrored)
        wing_a = (x0, x1, y0, y0 + wy)
        wing_b = (x0, x0 + wx, y0, y1)
        roofs = []
        for (a0, a1, b0, b1), k in ((wing_a, floors), (wing_b, other)):
            a0, a1 = sorted((fx * a0, fx * a1))
            b0, b1 = sorted((fy * b0, fy * b1))
            parts.append(_block(a0, a1, b0, b1, 0.0, height(k), facade))
            roofs.append((a0, a1, b0, b1, height(k)))
        if parapet or plant:  # keep the roof fittings on the taller wing only
            roofs = [max(roofs, key=lambda roof: roof[4])]
    else:
        tiers = int(rng.integers(2, min(4, floors) + 1))
        cuts = sorted(rng.choice(np.arange(1, floors), size=tiers - 1, replace=False).tolist())
        tops = [*cuts, floors]
        sides = int(rng.integers(4))  # 0: set back all round, 1-3: on 1-3 sides only
        box = [x0, x1, y0, y1]
        z0 = 0.0
        look = facade
        for i, k in enumerate(tops):
            if i:
                setback = dim(rng, 1.5, 5.0)
                order = (0, 1, 2, 3) if sides == 0 else tuple(int(j) for j in rng.permutation(4)[:sides])
                for j in order:
                    span = box[1] - box[0] if j < 2 else box[3] - box[2]
                    step = min(setback, (span - 6.0) / 2)
                    if step > 0:
                        box[j] += step if j in (0, 2) else -step
                look = top_look if rng.random() < 0.5 else look
            parts.append(_block(*box, z0 - (EMBED if i else 0.0), height(k), look))
            z0 = height(k)
        roofs = [(*box, height(tops[-1]))]
    for a0, a1, b0, b1, z in roofs:
        parts.append(_block(a0 + 0.3, a1 - 0.3, b0 + 0.3, b1 - 0.3, z - EMBED, z + membrane, MEMBRANE))
        if parapet:
            parts += _parapet(a0, a1, b0, b1, z, parapet, dim(rng, 0.2, 0.35), facade)
        if plant:
            for _ in range(int(rng.integers(1, 4))):
                wx, wy = min(dim(rng, 2.0, 5.0), (a1 - a0) / 2), min(dim(rng, 2.0, 5.0), (b1 - b0) / 2)
                cx = dim(rng, a0 + 1.0 + wx / 2, a1 - 1.0 - wx / 2) if a1 - a0 > wx + 2 else (a0 + a1) / 2
                cy = dim(rng, b0 + 1.0 + wy / 2, b1 - 1.0 - wy / 2) if b1 - b0 > wy + 2 else (b0 + b1) / 2
                hz = dim(rng, 1.5, plant)
                parts.append(Box((wx, wy, hz), (cx, cy, z - EMBED + hz / 2), 0.0, pick(rng, CONCRETE)))
    return parts


#: The categories built here, registered by :mod:`citygen.assets.catalog`.
CATEGORIES: dict[str, Category] = {
    "bus_stop_shelter": Category(
        bus_stop_shelter, "bus_stop_shelter", zones("sidewalk", "curb"), 0.8,
        height=(2.38, 3.15), size_x=(1.30, 2.10), size_y=(2.60, 6.20), anchor="curb",
    ),
    "tree": Category(
        tree, "tree", zones("vegetation", "sidewalk", "plaza"), 0.5,
        height=(3.0, 14.0), size_x=(1.5, 7.0), size_y=(1.5, 7.0), anchor="free",
    ),
    "bush": Category(
        bush, "bush", zones("vegetation", "plaza"), 0.2,
        height=(0.4, 2.0), size_x=(0.4, 2.0), size_y=(0.4, 2.0),
    ),
    "bike_rack": Category(
        bike_rack, "bike_rack", zones("sidewalk", "plaza"), 0.8,
        height=(0.30, 0.95), size_x=(0.30, 1.01), size_y=(0.95, 4.50), anchor="curb",
    ),
    "traffic_cone": Category(
        traffic_cone, "traffic_cone", zones("sidewalk", "curb", "plaza"), 0.3,
        height=(0.30, 1.00), size_x=(0.18, 0.48), size_y=(0.18, 0.48),
    ),
    "parked_scooter": Category(
        parked_scooter, "scooter", zones("sidewalk", "plaza"), 0.3,
        height=(0.93, 1.47), size_x=(0.35, 0.76), size_y=(0.98, 1.95), anchor="curb",
    ),
    "cafe_table": Category(
        cafe_table, "cafe_table", zones("sidewalk", "plaza"), 0.5,
        height=(0.75, 2.80), size_x=(0.60, 3.00), size_y=(0.60, 3.00), anchor="frontage",
    ),
    "building": Category(
        building, "building", zones("building"), 0.0,
        height=(4.0, 60.0), size_x=(8.0, 40.0), size_y=(8.0, 40.0), anchor="lot",
    ),
}  # fmt: skip
