"""Builders of street furniture: benches, bins, bollards, planters, lamp posts, hydrants.

Each builder follows :class:`citygen.assets.catalog.AssetBuilder`: it draws every
dimension from the generator it is given (real-world sizes, metres, drawn to the
millimetre) and returns convex parts in the asset frame: origin at the centre of
the base on the ground, z up, front facing +x. Parts that belong together overlap
by a few millimetres so their union is one solid.
"""

from __future__ import annotations

import math

import numpy as np

from citygen.assets.category import Category, zones
from citygen.assets.parts import Box, Capsule, Cylinder, Look, Part, convex_mesh, frustum, rod
from citygen.assets.parts import tilted_box as tilted

PAINT = tuple(
    Look("metal", rgba)
    for rgba in (
        (0.13, 0.27, 0.18, 1.0),  # fir green
        (0.08, 0.08, 0.09, 1.0),  # black
        (0.22, 0.23, 0.25, 1.0),  # anthracite
        (0.12, 0.21, 0.40, 1.0),  # gentian blue
        (0.45, 0.11, 0.09, 1.0),  # oxide red
        (0.55, 0.56, 0.57, 1.0),  # silver grey
    )
)
STEEL = Look("metal", (0.72, 0.73, 0.75, 1.0))
WOOD = tuple(
    Look("wood", rgba)
    for rgba in ((0.55, 0.38, 0.22, 1.0), (0.66, 0.50, 0.33, 1.0), (0.50, 0.46, 0.40, 1.0),
                 (0.35, 0.22, 0.13, 1.0), (0.60, 0.31, 0.20, 1.0))
)  # fmt: skip
CONCRETE = tuple(
    Look("concrete", rgba)
    for rgba in ((0.70, 0.69, 0.66, 1.0), (0.58, 0.57, 0.55, 1.0), (0.78, 0.74, 0.66, 1.0),
                 (0.45, 0.45, 0.46, 1.0))
)  # fmt: skip
PLASTIC = tuple(
    Look("plastic", rgba)
    for rgba in ((0.15, 0.35, 0.20, 1.0), (0.20, 0.20, 0.22, 1.0), (0.10, 0.30, 0.55, 1.0),
                 (0.85, 0.60, 0.10, 1.0), (0.60, 0.62, 0.64, 1.0))
)  # fmt: skip
FOLIAGE = tuple(
    Look("foliage", rgba)
    for rgba in ((0.16, 0.36, 0.13, 1.0), (0.25, 0.45, 0.18, 1.0), (0.12, 0.28, 0.15, 1.0))
)
HYDRANT = tuple(
    Look("metal", rgba)
    for rgba in ((0.75, 0.10, 0.08, 1.0), (0.90, 0.72, 0.10, 1.0), (0.72, 0.73, 0.75, 1.0),
                 (0.10, 0.45, 0.25, 1.0))
)  # fmt: skip
SOIL = Look("soil", (0.30, 0.22, 0.15, 1.0))
REFLECTOR = Look("plastic", (0.95, 0.95, 0.92, 1.0))
GLASS = Look("glass", (0.95, 0.93, 0.80, 0.85))
EMBED = 0.003
"""Overlap (m) between parts that touch, so their union is one solid."""


def dim(rng: np.random.Generator, low: float, high: float) -> float:
    """A length (m) uniform in [low, high], to the millimetre."""
    return round(float(rng.uniform(low, high)), 3)


def pick(rng: np.random.Generator, options: tuple[Look, ...]) -> Look:
    return options[int(rng.integers(len(options)))]


def bench(rng: np.random.Generator) -> list[Part]:
    """A park bench: seat slats on 2-3 supports, optional backrest and armrests.

    Seat 1.2-2.4 m long (y), 0.38-0.55 m deep (x), top 0.40-0.48 m high, 3-7 slats
    25-45 mm thick; supports are leg frames or solid panels. Backrest (70 %)
    0.35-0.50 m above the seat, leaning back 5-15 degrees with 2-4 slats; armrests
    (35 %) 0.18-0.25 m above the seat. Overall: 0.40-1.00 m high, 0.38-0.72 m deep
    (x), 1.2-2.4 m long (y).
    """
    length, depth, seat = dim(rng, 1.2, 2.4), dim(rng, 0.38, 0.55), dim(rng, 0.40, 0.48)
    slats, thick, gap = int(rng.integers(3, 8)), dim(rng, 0.025, 0.045), dim(rng, 0.005, 0.02)
    top = pick(rng, WOOD) if rng.random() < 0.75 else pick(rng, PAINT)
    frame_look = pick(rng, PAINT)
    width = (depth - (slats - 1) * gap) / slats
    parts: list[Part] = [
        Box(
            (width, length, thick),
            (-depth / 2 + width / 2 + i * (width + gap), 0.0, seat - thick / 2),
            0.0,
            top,
        )
        for i in range(slats)
    ]
    supports = 2 if length < 1.6 else int(rng.integers(2, 4))
    inset = dim(rng, 0.08, 0.25)
    ys = np.linspace(-length / 2 + inset, length / 2 - inset, supports).tolist()
    under = seat - thick + EMBED  # top of the supports
    if rng.random() < 0.5:  # leg frames: two legs and a rail under the seat
        leg = dim(rng, 0.04, 0.07)
        for y in ys:
            parts += [
                Box(
                    (leg, leg, under),
                    (sx * (depth / 2 - leg / 2 - 0.02), y, under / 2),
                    0.0,
                    frame_look,
                )
                for sx in (-1, 1)
            ]
            parts.append(Box((depth - 0.04, leg, 0.04), (0.0, y, under - 0.02), 0.0, frame_look))
    else:  # solid side panels
        panel, look = dim(rng, 0.06, 0.15), pick(rng, CONCRETE + PAINT[:3])
        parts += [
            Box((depth - dim(rng, 0.0, 0.03), panel, under), (0.0, y, under / 2), 0.0, look) for y in ys
        ]
    if rng.random() < 0.7:
        parts += _backrest(rng, length, depth, seat, thick, ys, top, frame_look)
    if rng.random() < 0.35:
        arm_z = seat + dim(rng, 0.18, 0.25)
        for y in (ys[0], ys[-1]):
            parts.append(
                Box(
                    (0.04, 0.05, arm_z - seat + EMBED),
                    (depth / 2 - 0.06, y, (seat + arm_z) / 2),
                    0.0,
                    frame_look,
                )
            )
            parts.append(Box((depth * 0.8, 0.06, 0.03), (0.1 * depth, y, arm_z), 0.0, frame_look))
    return parts


def _backrest(
    rng: np.random.Generator,
    length: float,
    depth: float,
    seat: float,
    thick: float,
    ys: list[float],
    look: Look,
    frame_look: Look,
) -> list[Part]:
    """Posts leaning back from the seat's rear edge (one per support at ``ys``) and slats
    across them; ``length``, ``depth``, ``seat`` (top height) and ``thick`` are the seat's (m).
    """
    rise, lean = dim(rng, 0.35, 0.50), math.radians(dim(rng, 5.0, 15.0))
    post = dim(rng, 0.035, 0.05)  # post depth (x) and width (y)
    z0, z1 = seat - thick, seat + rise
    x0 = -depth / 2 + post / 2
    span = (z1 - z0) / math.cos(lean)
    centre_x = x0 - (z1 - z0) / 2 * math.tan(lean)
    parts: list[Part] = [
        tilted((post, post, span), (centre_x, y, (z0 + z1) / 2), -lean, frame_look) for y in ys
    ]
    n, high = int(rng.integers(2, 5)), dim(rng, 0.06, 0.12)
    for z in np.linspace(seat + 0.08 + high / 2, z1 - high / 2, n).tolist():
        x = x0 - (z - z0) * math.tan(lean) + post / 2 + thick / 2 - EMBED
        parts.append(tilted((thick, length, high), (x, 0.0, z), -lean, look))
    return parts


def trash_bin(rng: np.random.Generator) -> list[Part]:
    """A litter bin: round or square on the ground, or a round bin on a post.

    Round: radius 0.21-0.34 m, body 0.72-1.0 m, lid 30-80 mm with a 5-25 mm lip and an
    optional dome 50-120 mm. Square: 0.42-0.62 m a side, 0.75-1.05 m. On a post: bin
    radius 0.18-0.25 m, 0.40-0.55 m tall, bottom 0.35-0.45 m above ground. Overall:
    0.74-1.20 m high, 0.43-0.74 m (x), 0.37-0.74 m (y).
    """
    style, body, trim = int(rng.integers(3)), pick(rng, PAINT + PLASTIC), pick(rng, PAINT)
    lid_t, lip = dim(rng, 0.03, 0.08), dim(rng, 0.005, 0.025)
    if style == 1:  # square
        sx, sy, h = dim(rng, 0.42, 0.62), dim(rng, 0.42, 0.62), dim(rng, 0.75, 1.05)
        return [
            Box((sx, sy, h - lid_t + EMBED), (0.0, 0.0, (h - lid_t + EMBED) / 2), 0.0, body),
            Box((sx + 2 * lip, sy + 2 * lip, lid_t), (0.0, 0.0, h - lid_t / 2), 0.0, trim),
        ]
    if style == 0:  # round, on the ground
        r, bottom, top = dim(rng, 0.21, 0.34), 0.0, dim(rng, 0.72, 1.0)
        parts: list[Part] = []
    else:  # round, on a post
        r, bottom = dim(rng, 0.18, 0.25), dim(rng, 0.35, 0.45)
        top = bottom + dim(rng, 0.40, 0.55)
        pole = dim(rng, 0.03, 0.05)
        parts = [Cylinder(pole, top, (-(r + pole) + 2 * EMBED, 0.0, top / 2), trim)]
        parts.append(Cylinder(pole + 0.05, 0.01, (-(r + pole) + 2 * EMBED, 0.0, 0.005), trim))
    parts += [
        Cylinder(r, top - bottom, (0.0, 0.0, (top + bottom) / 2), body),
        Cylinder(r + lip, lid_t, (0.0, 0.0, top + lid_t / 2 - EMBED), trim),
    ]
    for _ in range(int(rng.integers(0, 3))):  # decorative bands
        band = dim(rng, 0.02, 0.05)
        parts.append(Cylinder(r + 0.004, band, (0.0, 0.0, dim(rng, bottom + 0.1, top - 0.1)), trim))
    if rng.random() < 0.4:
        parts.append(
            frustum(r + lip, r * 0.6, top + lid_t - 2 * EMBED, top + lid_t + dim(rng, 0.05, 0.12), trim)
        )
    return parts


def bollard(rng: np.random.Generator) -> list[Part]:
    """A bollard: a round or square post 0.80-1.10 m high with a cap.

    Round: radius 0.05-0.13 m, domed, flat-capped or chamfered top, 0-2 reflective
    bands 30-80 mm. Square: 0.10-0.22 m a side with a flat cap. Optional base collar
    20-40 mm wider. Overall: 0.80-1.10 m high, 0.10-0.35 m across.
    """
    h, look = dim(rng, 0.80, 1.10), pick(rng, (*PAINT, STEEL, *CONCRETE[:2]))
    collar = dim(rng, 0.02, 0.04) if rng.random() < 0.5 else 0.0
    collar_h = dim(rng, 0.03, 0.08)
    if rng.random() < 0.3:  # square
        s, cap = dim(rng, 0.10, 0.22), dim(rng, 0.02, 0.04)
        parts: list[Part] = [
            Box((s, s, h - cap + EMBED), (0.0, 0.0, (h - cap + EMBED) / 2), 0.0, look),
            Box((s + 0.01, s + 0.01, cap), (0.0, 0.0, h - cap / 2), 0.0, look),
        ]
        if collar:
            parts.append(Box((s + 2 * collar, s + 2 * collar, collar_h), (0.0, 0.0, collar_h / 2), 0.0, look))
        return parts
    r, top = dim(rng, 0.05, 0.13), int(rng.integers(3))
    cap = (r, dim(rng, 0.02, 0.05), dim(rng, 0.03, 0.08))[top]  # dome, flat, chamfer
    parts = [Cylinder(r, h - cap + EMBED, (0.0, 0.0, (h - cap + EMBED) / 2), look)]
    if top == 0:
        parts.append(Capsule(r, 0.0, (0.0, 0.0, h - r), look))
    elif top == 1:
        parts.append(Cylinder(r + 0.008, cap, (0.0, 0.0, h - cap / 2), look))
    else:
        parts.append(frustum(r, r * 0.6, h - cap, h, look))
    for i in range(int(rng.integers(0, 3))):
        band = dim(rng, 0.03, 0.08)
        parts.append(Cylinder(r + 0.003, band, (0.0, 0.0, h - cap - 0.06 - i * 0.12 - band / 2), REFLECTOR))
    if collar:
        parts.append(Cylinder(r + collar, collar_h, (0.0, 0.0, collar_h / 2), look))
    return parts


def planter(rng: np.random.Generator) -> list[Part]:
    """A planter: a square, oblong or round tub, usually with a shrub or topiary in it.

    Square 0.5-1.2 m a side; oblong 0.5-1.0 m (x) by 1.0-1.8 m (y); round (tapered)
    0.5-1.2 m across. Rim 0.35-0.90 m high, walls 40-120 mm, soil 30-100 mm below the
    rim, optional feet 30-80 mm. Plant (80 %): a shrub or cone 0.3-1.0 m tall or a
    ball 0.2-0.35 m in radius on a trunk. Overall: 0.35-1.90 m high, 0.5-1.2 m (x),
    0.5-1.8 m (y).
    """
    shape, h = int(rng.integers(3)), dim(rng, 0.35, 0.90)
    look = pick(rng, CONCRETE + WOOD + PAINT[:3])
    soil_top = h - dim(rng, 0.03, 0.10)
    if shape == 2:  # round, tapered
        r = dim(rng, 0.25, 0.60)
        parts: list[Part] = [frustum(r * dim(rng, 0.75, 1.0), r, 0.0, h, look)]
        room = r - 0.05
    else:
        sx = dim(rng, 0.5, 1.2) if shape == 0 else dim(rng, 0.5, 1.0)
        sy = sx if shape == 0 else dim(rng, 1.0, 1.8)
        wall = dim(rng, 0.04, 0.12)
        feet = dim(rng, 0.03, 0.08) if rng.random() < 0.4 else 0.0
        wall_h, z = h - feet, feet + (h - feet) / 2
        parts = [Box((wall, sy, wall_h), (sgn * (sx - wall) / 2, 0.0, z), 0.0, look) for sgn in (-1, 1)] + [
            Box(
                (sx - 2 * wall + 2 * EMBED, wall, wall_h),
                (0.0, sgn * (sy - wall) / 2, z),
                0.0,
                look,
            )
            for sgn in (-1, 1)
        ]
        parts.append(
            Box(
                (sx - 2 * wall + 2 * EMBED, sy - 2 * wall + 2 * EMBED, soil_top - feet),
                (0.0, 0.0, (soil_top + feet) / 2),
                0.0,
                SOIL,
            )
        )
        if feet:
            corners = [(fx * (sx / 2 - 0.07), fy * (sy / 2 - 0.07)) for fx in (-1, 1) for fy in (-1, 1)]
            parts += [
                Box((0.1, 0.1, feet + EMBED), (x, y, (feet + EMBED) / 2), 0.0, look) for x, y in corners
            ]
        room = min(sx, sy) / 2 - wall
    if rng.random() < 0.8:
        parts += _plant(rng, soil_top, room)
    return parts


def _plant(rng: np.random.Generator, soil: float, room: float) -> list[Part]:
    """A shrub, a cone or a ball on a trunk rooted in soil at height ``soil`` (m).

    The plant stays within ``room`` (m) of the vertical axis.
    """
    leaves, kind = pick(rng, FOLIAGE), int(rng.integers(3))
    if kind == 0:  # shrub: hull of random points on an ellipsoid
        rx, ry, hz = dim(rng, 0.5, 1.0) * room, dim(rng, 0.5, 1.0) * room, dim(rng, 0.3, 1.0)
        d = rng.normal(size=(26, 3))
        d = np.vstack([np.eye(3), -np.eye(3), d / np.linalg.norm(d, axis=1, keepdims=True)])
        pts = d * [rx, ry, hz / 2] + [0.0, 0.0, soil + hz / 2 - 0.02]
        return [convex_mesh(pts, leaves)]
    if kind == 1:  # cone
        return [frustum(dim(rng, 0.5, 1.0) * room, 0.0, soil - 0.02, soil + dim(rng, 0.3, 1.0), leaves)]
    ball = min(dim(rng, 0.2, 0.35), room)
    trunk = dim(rng, 0.15, 0.35)
    return [
        Cylinder(0.03, trunk + 0.05, (0.0, 0.0, soil + (trunk - 0.05) / 2), WOOD[3]),
        Capsule(ball, 0.0, (0.0, 0.0, soil + trunk + ball - 0.05), leaves),
    ]


def lamp_post(rng: np.random.Generator) -> list[Part]:
    """A street lamp: a tapered pole with one or two arms, or a post-top lantern.

    Pole radius 0.06-0.12 m at the base tapering to 50-90 %, optional plinth
    0.3-0.8 m high. Arms: pole 4.5-8.0 m, arm 0.5-1.8 m (single, towards +x) or
    0.3-0.9 m (double, +x and -x) rising 0-0.4 m, luminaire 0.4-0.7 m long. Post-top:
    pole 3.5-5.0 m with a globe 0.18-0.30 m in radius or a lantern. Overall: 3.8-8.4 m
    high, 0.35-3.0 m (x), 0.20-0.61 m (y).
    """
    style, paint = int(rng.integers(3)), pick(rng, (*PAINT, STEEL))
    pole_h = dim(rng, 3.5, 5.0) if style == 2 else dim(rng, 4.5, 8.0)
    r0 = dim(rng, 0.06, 0.12)
    r1 = round(r0 * dim(rng, 0.5, 0.9), 3)
    parts: list[Part] = [frustum(r0, r1, 0.0, pole_h, paint)]
    if rng.random() < 0.6:
        plinth = dim(rng, 0.3, 0.8)
        parts.append(Cylinder(r0 + dim(rng, 0.04, 0.13), plinth, (0.0, 0.0, plinth / 2), paint))
    if style == 2:
        if rng.random() < 0.5:
            globe = dim(rng, 0.18, 0.30)
            parts.append(Capsule(globe, 0.0, (0.0, 0.0, pole_h + globe - 0.03), GLASS))
        else:
            body = dim(rng, 0.25, 0.45)
            parts.append(frustum(0.12, 0.2, pole_h - EMBED, pole_h + body, GLASS, sides=6))
            parts.append(frustum(0.24, 0.04, pole_h + body - EMBED, pole_h + body + 0.12, paint, sides=6))
        return parts
    rise, arm_r = dim(rng, 0.0, 0.4), dim(rng, 0.03, 0.05)
    lum = (dim(rng, 0.4, 0.7), dim(rng, 0.2, 0.35), dim(rng, 0.08, 0.15))
    for side in (1, -1) if style == 1 else (1,):
        reach = dim(rng, 0.3, 0.9) if style == 1 else dim(rng, 0.5, 1.8)
        z_end = pole_h - 0.1 + rise
        parts.append(rod(arm_r, (0.0, 0.0, pole_h - 0.1), (side * reach, 0.0, z_end), paint))
        centre = (side * (reach + lum[0] / 2 - 0.1), 0.0, z_end - lum[2] / 2 + arm_r)
        parts.append(Box(lum, centre, 0.0, paint))
    return parts


def fire_hydrant(rng: np.random.Generator) -> list[Part]:
    """A pillar fire hydrant: barrel, base flange, bonnet, operating nut and hose outlets.

    Barrel radius 0.08-0.13 m, 0.45-0.70 m high; dome or conical bonnet; a pentagonal
    operating nut 30-50 mm; two side outlets (+-y) 30-45 mm in radius reaching 40-90 mm
    out, and a pumper outlet (60 %) towards +x. Overall: 0.54-0.90 m high, 0.20-0.45 m
    (x), 0.28-0.50 m (y).
    """
    look, caps = pick(rng, HYDRANT), pick(rng, (*HYDRANT, STEEL))
    r, barrel = dim(rng, 0.08, 0.13), dim(rng, 0.45, 0.70)
    flange, flange_h = r + dim(rng, 0.02, 0.05), dim(rng, 0.04, 0.08)
    parts: list[Part] = [
        Cylinder(r, barrel, (0.0, 0.0, barrel / 2), look),
        Cylinder(flange, flange_h, (0.0, 0.0, flange_h / 2), look),
    ]
    if rng.random() < 0.6:
        ring = dim(rng, 0.025, 0.04)
        parts.append(Cylinder(r + dim(rng, 0.015, 0.03), ring, (0.0, 0.0, barrel - ring / 2), look))
    if rng.random() < 0.5:
        bonnet = r * dim(rng, 0.85, 1.0)
        parts.append(Capsule(bonnet, 0.0, (0.0, 0.0, barrel - EMBED), caps))
        top = barrel - EMBED + bonnet
    else:
        top = barrel + dim(rng, 0.06, 0.12)
        parts.append(frustum(r, r * 0.5, barrel - EMBED, top, caps))
    parts.append(frustum(0.025, 0.02, top - 0.01, top + dim(rng, 0.03, 0.05), caps, sides=5))
    z_out, out_r, reach = barrel * dim(rng, 0.6, 0.75), dim(rng, 0.03, 0.045), r + dim(rng, 0.04, 0.09)
    for side in (1, -1):
        parts.append(rod(out_r, (0.0, 0.0, z_out), (0.0, side * reach, z_out), look))
        parts.append(
            rod(
                out_r + 0.008,
                (0.0, side * (reach - 0.01), z_out),
                (0.0, side * (reach + 0.025), z_out),
                caps,
            )
        )
    if rng.random() < 0.6:
        pump_r, pump = dim(rng, 0.05, 0.065), r + dim(rng, 0.05, 0.1)
        parts.append(rod(pump_r, (0.0, 0.0, z_out), (pump, 0.0, z_out), look))
        parts.append(rod(pump_r + 0.008, (pump - 0.01, 0.0, z_out), (pump + 0.03, 0.0, z_out), caps))
    return parts


#: The categories built here, registered by :mod:`citygen.assets.catalog`.
CATEGORIES: dict[str, Category] = {
    "bench": Category(
        bench, "bench", zones("sidewalk", "plaza", "trail"), 0.6,
        height=(0.40, 1.00), size_x=(0.38, 0.72), size_y=(1.20, 2.40),
    ),
    "trash_bin": Category(
        trash_bin, "trash_bin", zones("sidewalk", "plaza", "trail"), 0.4,
        height=(0.74, 1.20), size_x=(0.43, 0.74), size_y=(0.37, 0.74), anchor="curb",
    ),
    "bollard": Category(
        bollard, "bollard", zones("sidewalk", "plaza", "curb"), 0.4,
        height=(0.80, 1.10), size_x=(0.10, 0.35), size_y=(0.10, 0.35), anchor="crossing",
    ),
    "planter": Category(
        planter, "planter", zones("sidewalk", "plaza"), 0.4,
        height=(0.35, 1.90), size_x=(0.50, 1.20), size_y=(0.50, 1.80),
    ),
    "lamp_post": Category(
        lamp_post, "lamp_post", zones("sidewalk", "curb", "plaza", "trail"), 0.4,
        height=(3.80, 8.40), size_x=(0.35, 3.00), size_y=(0.20, 0.61), anchor="curb",
    ),
    "fire_hydrant": Category(
        fire_hydrant, "fire_hydrant", zones("sidewalk", "curb"), 0.9,
        height=(0.54, 0.90), size_x=(0.20, 0.45), size_y=(0.28, 0.50), anchor="crossing",
    ),
}  # fmt: skip
