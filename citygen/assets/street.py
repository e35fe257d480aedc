"""Builders of street equipment: recycling bins, mailboxes, newspaper boxes, parking meters,
telephone booths, advertising boards, street signs and traffic lights.

Same conventions as :mod:`citygen.assets.furniture`: every dimension is drawn from the
generator given (real-world sizes, metres, to the millimetre), parts are convex, in the
asset frame (origin at the centre of the base on the ground, z up) and overlap by
:data:`~citygen.assets.furniture.EMBED` where they touch, so their union is one solid.

Which way things face. Placement turns +x towards the roadway (anchors ``curb`` and
``crossing``) or towards the street with the back to the building (``frontage``), see
:data:`citygen.assets.category.Anchor`. So:

- what people use from the sidewalk while it stands at the curb faces -x, the sidewalk:
  a recycling station's openings, a newspaper box's window, a parking meter's display;
- a mailbox's chute faces +x, the street (drive-up), as curbside collection boxes do;
- a telephone booth's door, a billboard's poster face +x (frontage: towards passers-by);
- traffic faces +y: with right-hand traffic, vehicles pass a curbside asset travelling
  towards -y, so sign plates and vehicle signal heads face +y; a mast arm reaches out
  over the roadway along +x; pedestrian signal heads face +x, across the crosswalk.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from citygen.assets.category import Category, zones
from citygen.assets.furniture import CONCRETE, EMBED, PAINT, STEEL, dim, pick
from citygen.assets.parts import Box, Capsule, ConvexMesh, Cylinder, Look, Part, frustum, rod
from citygen.assets.parts import tilted_box as tilted

#: Colour code of waste streams (European conventions; lids and labels of recycling bins).
STREAMS = tuple(
    Look("plastic", rgba)
    for rgba in (
        (0.09, 0.33, 0.68, 1.0),  # paper: blue
        (0.13, 0.50, 0.24, 1.0),  # glass: green
        (0.95, 0.77, 0.08, 1.0),  # packaging: yellow
        (0.45, 0.29, 0.15, 1.0),  # organics: brown
        (0.62, 0.63, 0.65, 1.0),  # metal, cans: grey
        (0.16, 0.16, 0.17, 1.0),  # residual waste: black
    )
)
#: Post boxes: USPS blue, Royal Mail red, Deutsche Post yellow, An Post green, old US olive.
MAIL = tuple(
    Look("metal", rgba)
    for rgba in ((0.09, 0.20, 0.45, 1.0), (0.75, 0.07, 0.07, 1.0), (0.98, 0.78, 0.05, 1.0),
                 (0.00, 0.42, 0.24, 1.0), (0.33, 0.37, 0.22, 1.0))
)  # fmt: skip
#: Loud vending-box and poster colours.
BRIGHT = tuple(
    Look("plastic", rgba)
    for rgba in ((0.80, 0.10, 0.10, 1.0), (0.10, 0.30, 0.70, 1.0), (0.95, 0.80, 0.10, 1.0),
                 (0.10, 0.55, 0.30, 1.0), (0.93, 0.93, 0.90, 1.0), (0.95, 0.50, 0.10, 1.0),
                 (0.55, 0.20, 0.55, 1.0), (0.10, 0.10, 0.11, 1.0))
)  # fmt: skip
DARK = Look("plastic", (0.06, 0.06, 0.07, 1.0))
#: Window glass (opaque in the catalog: the colour stands for it).
GLASS = Look("glass", (0.56, 0.70, 0.76, 1.0))
SCREEN = Look("glass", (0.10, 0.16, 0.22, 1.0))
WHITE = Look("metal", (0.95, 0.95, 0.94, 1.0))
SIGN_RED = Look("metal", (0.78, 0.07, 0.09, 1.0))
#: Guide and information sign faces: street-name green, blue, brown, black.
SIGN = tuple(
    Look("metal", rgba)
    for rgba in ((0.00, 0.40, 0.24, 1.0), (0.05, 0.25, 0.60, 1.0), (0.40, 0.24, 0.12, 1.0),
                 (0.10, 0.10, 0.10, 1.0))
)  # fmt: skip
AMBER = Look("plastic", (0.98, 0.62, 0.05, 1.0))
#: Signal lenses from top to bottom: red, amber, green.
LENSES = (Look("glass", (0.85, 0.08, 0.06, 1.0)), AMBER, Look("glass", (0.10, 0.75, 0.40, 1.0)))
#: Pedestrian lenses: the orange hand, the white walking person.
WALK = (Look("glass", (0.97, 0.45, 0.10, 1.0)), Look("glass", (0.95, 0.93, 0.88, 1.0)))
SIGNAL = (PAINT[1], PAINT[0], Look("metal", (0.95, 0.78, 0.10, 1.0)), PAINT[2])

_OCTAGON = [math.radians(22.5 + 45 * k) for k in range(8)]


def _prism_y(outline: Sequence[tuple[float, float]], y0: float, y1: float, look: Look) -> ConvexMesh:
    """A plate facing +-y: the convex ``outline`` of (x, z) points (m) from ``y0`` to ``y1``."""
    return ConvexMesh(tuple((x, y, z) for y in (y0, y1) for x, z in outline), look)


def _arch(depth: float, width: float, rise: float, z0: float, look: Look, y0: float = 0.0) -> ConvexMesh:
    """A barrel roof along x: a circular segment ``width`` (y) wide rising ``rise`` above
    ``z0``, ``depth`` (x) long, centred on x = 0, y = ``y0`` (all m).
    """
    if not 0 < rise <= width / 2:
        raise ValueError(f"_arch: expected 0 < rise <= width / 2 (m), got rise {rise}, width {width}")
    radius = (width**2 / 4 + rise**2) / (2 * rise)
    half = math.asin(min(1.0, width / 2 / radius))
    ring = [
        (radius * math.sin(t), z0 + rise - radius + radius * math.cos(t))
        for t in np.linspace(-half, half, 13)
    ]
    return ConvexMesh(tuple((sx * depth / 2, y0 + y, z) for sx in (-1, 1) for y, z in ring), look)


def _hip(
    bottom: tuple[float, float], top: tuple[float, float], z0: float, z1: float, look: Look
) -> ConvexMesh:
    """A hipped roof: a rectangle ``bottom`` (x, y; m) at ``z0`` narrowing to ``top`` at ``z1``."""
    corners = [(sx, sy) for sx in (-1, 1) for sy in (-1, 1)]
    return ConvexMesh(
        tuple((sx * w[0] / 2, sy * w[1] / 2, z) for w, z in ((bottom, z0), (top, z1)) for sx, sy in corners),
        look,
    )


# --- recycling bins -------------------------------------------------------------------


def recycling_bin(rng: np.random.Generator) -> list[Part]:
    """A recycling bin: a single square or round bin, or a multi-stream station of 2-4.

    Lids and labels carry the colour of their waste stream (:data:`STREAMS`); the
    openings (dark inserts 60-100 mm high) face -x, the sidewalk. Square: 0.45-0.62 m
    a side, 0.85-1.10 m high. Round: radius 0.22-0.31 m, 0.85-1.05 m, optional dome
    50-120 mm. Station: 2-4 compartments 0.40-0.55 m wide (y), 0.42-0.60 m deep (x),
    0.88-1.08 m high, each a different stream, optional roof panel 40-80 mm. Lids
    30-70 mm, overhanging 10-25 mm. Overall: 0.85-1.17 m high, 0.44-0.68 m (x),
    0.44-2.24 m (y).
    """
    style = int(rng.integers(3))  # 0 square, 1 round, 2 station
    body = pick(rng, (*PAINT[:3], STEEL, Look("plastic", (0.85, 0.85, 0.83, 1.0))))
    lid_t, lip = dim(rng, 0.03, 0.07), dim(rng, 0.01, 0.025)
    if style == 1:
        stream, r, h = pick(rng, STREAMS), dim(rng, 0.22, 0.31), dim(rng, 0.85, 1.05)
        label = dim(rng, 0.12, 0.25)
        parts: list[Part] = [
            Cylinder(r, h - lid_t + EMBED, (0.0, 0.0, (h - lid_t + EMBED) / 2), body),
            Cylinder(r + lip, lid_t, (0.0, 0.0, h - lid_t / 2), stream),
            Cylinder(r + 0.004, label, (0.0, 0.0, dim(rng, 0.3, h - lid_t - 0.25) + label / 2), stream),
            Box((0.048, r * 0.9, dim(rng, 0.06, 0.10)), (-r + 0.016, 0.0, h - lid_t - 0.09), 0.0, DARK),
        ]
        if rng.random() < 0.4:
            parts.append(frustum(r + lip, r * 0.5, h - EMBED, h + dim(rng, 0.05, 0.12), stream))
        return parts
    if style == 0:
        streams = [pick(rng, STREAMS)]
        depth, width, h = dim(rng, 0.45, 0.62), dim(rng, 0.45, 0.62), dim(rng, 0.85, 1.10)
        lid_y = width + 2 * lip
    else:
        n = int(rng.integers(2, 5))
        streams = [STREAMS[i] for i in rng.permutation(len(STREAMS))[:n].tolist()]
        depth, width, h = dim(rng, 0.42, 0.60), dim(rng, 0.40, 0.55), dim(rng, 0.88, 1.08)
        lid_y = width - 0.006
    label_h, slot = dim(rng, 0.15, 0.30), dim(rng, 0.06, 0.10)
    step = width - EMBED
    parts = []
    for i, stream in enumerate(streams):
        y = (i - (len(streams) - 1) / 2) * step
        front = -depth / 2 - 0.005 + EMBED  # centre of a 10 mm insert on the -x face
        parts += [
            Box((depth, width, h - lid_t + EMBED), (0.0, y, (h - lid_t + EMBED) / 2), 0.0, body),
            Box((depth + 2 * lip, lid_y, lid_t), (0.0, y, h - lid_t / 2), 0.0, stream),
            Box((0.01, width * 0.7, slot), (front, y, h - lid_t - 0.03 - slot / 2), 0.0, DARK),
            Box((0.01, width * 0.7, label_h), (front, y, h - lid_t - 0.06 - slot - label_h / 2), 0.0, stream),
        ]
    if len(streams) > 1 and rng.random() < 0.5:
        roof = dim(rng, 0.04, 0.08)
        span = len(streams) * step + EMBED + 0.04
        parts.append(
            Box((depth * dim(rng, 0.6, 1.0), span, roof), (0.0, 0.0, h + roof / 2 - EMBED), 0.0, body)
        )
    return parts


# --- mailboxes -------------------------------------------------------------------------


def mailbox(rng: np.random.Generator) -> list[Part]:
    """A street collection box: a US-style box on legs, a pillar box or a box on a post.

    US collection box: 0.46-0.56 m deep (x), 0.45-0.54 m wide (y), body 0.88-0.98 m on
    legs 80-140 mm, barrel roof rising 0.16-0.22 m (about 0.5 x 0.5 x 1.27 m, like the
    USPS box), pull-down chute towards +x. Pillar box: radius 0.22-0.30 m, 1.25-1.45 m
    high on a plinth, cap and low dome, slot towards +x. Post box: a box 0.22-0.35 m
    deep, 0.34-0.52 m wide, 0.40-0.60 m high on a post 0.80-1.00 m, slot towards +x.
    Colours: :data:`MAIL`. Overall: 1.12-1.68 m high, 0.24-0.71 m (x), 0.36-0.71 m (y).
    """
    style, look = int(rng.integers(3)), pick(rng, MAIL)
    if style == 0:  # US collection box
        depth, width = dim(rng, 0.46, 0.56), dim(rng, 0.45, 0.54)
        legs, body, rise = dim(rng, 0.08, 0.14), dim(rng, 0.88, 0.98), dim(rng, 0.16, 0.22)
        leg, top = dim(rng, 0.035, 0.06), legs + body
        parts: list[Part] = [
            Box(
                (leg, leg, legs + EMBED),
                (sx * (depth / 2 - leg), sy * (width / 2 - leg), (legs + EMBED) / 2),
                0.0,
                look,
            )
            for sx in (-1, 1)
            for sy in (-1, 1)
        ]
        chute_w, chute_h = width * dim(rng, 0.6, 0.75), dim(rng, 0.10, 0.14)
        chute_d = dim(rng, 0.03, 0.06)
        parts += [
            Box((depth, width, body), (0.0, 0.0, legs + body / 2), 0.0, look),
            _arch(depth, width, rise, top - EMBED, look),
            Box((chute_d, chute_w, chute_h), (depth / 2 + chute_d / 2 - EMBED, 0.0, top - 0.12), 0.0, look),
            Box((0.008, chute_w * 0.8, 0.02), (depth / 2 + chute_d - EMBED, 0.0, top - 0.12), 0.0, DARK),
            Box((0.006, width * 0.5, dim(rng, 0.12, 0.2)), (depth / 2, 0.0, legs + body * 0.45), 0.0, WHITE),
        ]
        return parts
    if style == 1:  # pillar box
        r, body = dim(rng, 0.22, 0.30), dim(rng, 1.25, 1.45)
        plinth, cap, cap_t = dim(rng, 0.06, 0.12), r + dim(rng, 0.015, 0.04), dim(rng, 0.05, 0.08)
        slot_z = body - dim(rng, 0.15, 0.30)
        parts = [
            Cylinder(r + dim(rng, 0.015, 0.05), plinth, (0.0, 0.0, plinth / 2), look),
            Cylinder(r, body - plinth + EMBED, (0.0, 0.0, (body + plinth + EMBED) / 2 - EMBED), look),
            Cylinder(cap, cap_t, (0.0, 0.0, body + cap_t / 2 - EMBED), look),
            frustum(cap - 0.01, r * 0.3, body + cap_t - 2 * EMBED, body + cap_t + dim(rng, 0.08, 0.15), look),
            Box((0.07, r * 0.8, 0.035), (r - 0.02, 0.0, slot_z), 0.0, DARK),
            Box((0.09, r * 0.95, 0.025), (r - 0.02, 0.0, slot_z + 0.03), 0.0, look),
            Box((0.04, r * 0.7, dim(rng, 0.10, 0.16)), (r - 0.015, 0.0, slot_z - 0.18), 0.0, WHITE),
        ]
        return parts
    # post box
    post, post_h = dim(rng, 0.06, 0.10), dim(rng, 0.80, 1.00)
    depth, width, high = dim(rng, 0.22, 0.35), dim(rng, 0.34, 0.52), dim(rng, 0.40, 0.60)
    bottom = post_h - 0.05
    roof_t = dim(rng, 0.03, 0.08)
    parts = [
        Box((post, post, post_h), (0.0, 0.0, post_h / 2), 0.0, pick(rng, (STEEL, *PAINT[1:3], look))),
        Box((depth, width, high), (0.0, 0.0, bottom + high / 2), 0.0, look),
        _hip(
            (depth + 0.02, width + 0.02),
            (depth * 0.4, width + 0.02),
            bottom + high - EMBED,
            bottom + high + roof_t,
            look,
        ),
        Box((0.012, width * 0.6, 0.03), (depth / 2 + 0.006 - EMBED, 0.0, bottom + high - 0.08), 0.0, DARK),
    ]
    if rng.random() < 0.6:  # a post-horn or logo disc
        z = bottom + high * 0.45
        parts.append(rod(dim(rng, 0.05, 0.09), (depth / 2 - 0.01, 0.0, z), (depth / 2 + 0.006, 0.0, z), DARK))
    if rng.random() < 0.5:
        parts.append(Box((0.25, 0.25, 0.015), (0.0, 0.0, 0.0075), 0.0, STEEL))
    return parts


# --- newspaper boxes ------------------------------------------------------------------


def newspaper_box(rng: np.random.Generator) -> list[Part]:
    """A newspaper vending box on legs or a pedestal, or a bank of 2-3 side by side (y).

    Each box: 0.40-0.53 m wide (y), 0.36-0.46 m deep (x), body 0.55-0.75 m high on a
    stand 0.25-0.45 m, lid 20-40 mm overhanging 10-20 mm; its window (0.40-0.55 of the
    body's height), coin mechanism and handle face -x, the sidewalk. Legs 30-45 mm
    square; a pedestal is a post 60-100 mm on a foot plate. Overall: 0.81-1.24 m high,
    0.41-0.52 m (x), 0.41-1.62 m (y).
    """
    count = 1 if rng.random() < 0.5 else int(rng.integers(2, 4))
    widths = [dim(rng, 0.40, 0.53) for _ in range(count)]
    total = sum(widths) - (count - 1) * EMBED
    parts: list[Part] = []
    left = -total / 2
    for width in widths:
        y = left + width / 2
        left += width - EMBED
        parts += _vending_box(rng, y, width)
    return parts


def _vending_box(rng: np.random.Generator, y: float, width: float) -> list[Part]:
    """One vending box ``width`` (m) wide centred at ``y`` (m), front (window) at -x."""
    look, trim = pick(rng, BRIGHT), pick(rng, (DARK, STEEL, *PAINT[1:3]))
    depth, body, stand = dim(rng, 0.36, 0.46), dim(rng, 0.55, 0.75), dim(rng, 0.25, 0.45)
    lid_t, lip = dim(rng, 0.02, 0.04), dim(rng, 0.01, 0.02)
    top = stand + body
    window = body * dim(rng, 0.40, 0.55)
    front = -depth / 2 - 0.006 + EMBED
    parts: list[Part] = [
        Box((depth, width, body), (0.0, y, stand + body / 2), 0.0, look),
        Box((depth + 2 * lip, width + 2 * lip - 0.006, lid_t), (0.0, y, top + lid_t / 2 - EMBED), 0.0, look),
        Box((0.012, width * 0.78, window), (front, y, top - 0.06 - window / 2), 0.0, GLASS),
        Box((0.05, 0.12, 0.14), (-depth / 2 - 0.015, y + width * 0.3, top - 0.04 - 0.07), 0.0, trim),
        Box((0.02, width * 0.4, 0.03), (front - 0.004, y, top - 0.10 - window), 0.0, trim),
    ]
    if rng.random() < 0.5:  # four legs
        leg = dim(rng, 0.03, 0.045)
        parts += [
            Box(
                (leg, leg, stand + EMBED),
                (sx * (depth / 2 - leg), y + sy * (width / 2 - leg), (stand + EMBED) / 2),
                0.0,
                trim,
            )
            for sx in (-1, 1)
            for sy in (-1, 1)
        ]
    else:  # pedestal on a foot plate
        post, foot = dim(rng, 0.06, 0.10), dim(rng, 0.01, 0.02)
        parts += [
            Box((post, post, stand + EMBED), (0.0, y, (stand + EMBED) / 2), 0.0, trim),
            Box((depth * 0.8, width * 0.8, foot), (0.0, y, foot / 2), 0.0, trim),
        ]
    return parts


# --- parking meters ---------------------------------------------------------------------


def parking_meter(rng: np.random.Generator) -> list[Part]:
    """A parking meter: one or two heads on a post, or a pay-and-display station.

    Post radius 30-45 mm (or square 60-90 mm), 0.95-1.15 m high; a head is 0.15-0.22 m
    deep (x), 0.18-0.26 m wide (y), 0.30-0.42 m high with a dome of half its width or a
    flat cap; a double head's yoke sets them 0.02-0.10 m apart. Pay station: cabinet
    0.25-0.40 m deep, 0.35-0.55 m wide, 1.45-1.85 m high, optional solar panel on top.
    Displays, slots and keypads face -x, the sidewalk. Overall: 1.24-2.32 m high,
    0.15-0.45 m (x), 0.18-0.65 m (y).
    """
    style, look = int(rng.integers(3)), pick(rng, (*PAINT, STEEL))
    if style == 2:
        return _pay_station(rng, look)
    post_h = dim(rng, 0.95, 1.15)
    if rng.random() < 0.6:
        r = dim(rng, 0.03, 0.045)
        parts: list[Part] = [Cylinder(r, post_h, (0.0, 0.0, post_h / 2), look)]
        flange = dim(rng, 0.01, 0.02)
        parts.append(Cylinder(r + dim(rng, 0.02, 0.04), flange, (0.0, 0.0, flange / 2), look))
    else:
        side = dim(rng, 0.06, 0.09)
        parts = [Box((side, side, post_h), (0.0, 0.0, post_h / 2), 0.0, look)]
    depth, width, high = dim(rng, 0.15, 0.22), dim(rng, 0.18, 0.26), dim(rng, 0.30, 0.42)
    head = pick(rng, (*PAINT, STEEL, *BRIGHT[:3]))
    dome = pick(rng, (GLASS, head)) if rng.random() < 0.5 else None
    if style == 0:
        return parts + _meter_head(0.0, post_h - 0.03, depth, width, high, head, dome)
    gap, yoke = dim(rng, 0.02, 0.10), dim(rng, 0.04, 0.07)
    offset = (width + gap) / 2
    parts.append(
        Box((depth * 0.6, 2 * offset + width * 0.5, yoke), (0.0, 0.0, post_h + yoke / 2 - EMBED), 0.0, look)
    )
    for sy in (-1, 1):
        parts += _meter_head(sy * offset, post_h + yoke - 2 * EMBED, depth, width, high, head, dome)
    return parts


def _meter_head(
    y: float, z: float, depth: float, width: float, high: float, look: Look, dome: Look | None
) -> list[Part]:
    """A meter head ``depth`` x ``width`` x ``high`` (m) with its bottom at (0, ``y``, ``z``),
    under a half-round ``dome`` of that look, or a flat cap when ``dome`` is None."""
    face = -depth / 2 - 0.006 + EMBED
    parts: list[Part] = [
        Box((depth, width, high), (0.0, y, z + high / 2), 0.0, look),
        Box((0.012, width * 0.7, high * 0.3), (face, y, z + high * 0.7), 0.0, SCREEN),
        Box((0.012, 0.03, 0.06), (face, y, z + high * 0.35), 0.0, DARK),
    ]
    if dome is not None:
        parts.append(_arch(depth, width, width / 2, z + high - EMBED, dome, y))
    else:
        parts.append(Box((depth + 0.02, width + 0.02, 0.03), (0.0, y, z + high + 0.015 - EMBED), 0.0, look))
    return parts


def _pay_station(rng: np.random.Generator, look: Look) -> list[Part]:
    """A pay-and-display machine: cabinet on a plinth, screen and keypad on -x, optional solar panel."""
    depth, width, high = dim(rng, 0.25, 0.40), dim(rng, 0.35, 0.55), dim(rng, 1.45, 1.85)
    plinth, cap = dim(rng, 0.04, 0.10), dim(rng, 0.03, 0.06)
    face = -depth / 2 - 0.008 + EMBED
    parts: list[Part] = [
        Box((depth - 0.03, width - 0.03, plinth + EMBED), (0.0, 0.0, (plinth + EMBED) / 2), 0.0, DARK),
        Box(
            (depth, width, high - plinth - cap + 2 * EMBED), (0.0, 0.0, (high + plinth - cap) / 2), 0.0, look
        ),
        Box((depth + 0.03, width + 0.03, cap), (0.0, 0.0, high - cap / 2), 0.0, look),
        Box((0.016, width * 0.6, dim(rng, 0.12, 0.22)), (face, 0.0, high - 0.35), 0.0, SCREEN),
        Box((0.016, width * 0.35, 0.14), (face, -width * 0.15, high - 0.62), 0.0, DARK),
        Box((0.016, 0.09, 0.03), (face, width * 0.25, high - 0.6), 0.0, DARK),
        Box((0.03, width * 0.5, 0.05), (face - 0.006, 0.0, 0.55), 0.0, DARK),
    ]
    if rng.random() < 0.5:  # solar panel on a short stem, tilted towards -x
        stem, lean = dim(rng, 0.08, 0.2), math.radians(dim(rng, 15.0, 35.0))
        panel = (dim(rng, 0.30, 0.42), dim(rng, 0.28, width), 0.025)
        # its centre this far above its lowest edge (at +x), which rests at the stem's height
        centre = high + stem + panel[0] / 2 * math.sin(lean) + panel[2] / 2 * math.cos(lean)
        parts.append(
            Box((0.05, 0.05, centre - high + EMBED), (0.0, 0.0, (high - EMBED + centre) / 2), 0.0, look)
        )
        parts.append(tilted(panel, (0.0, 0.0, centre), -lean, SCREEN))
    return parts


# --- telephone booths ------------------------------------------------------------------


def telephone_booth(rng: np.random.Generator) -> list[Part]:
    """A telephone booth: a classic kiosk with its door ajar, a glass booth, or a phone on a post.

    Classic (like the British K6): 0.88-1.00 m square, walls 2.15-2.40 m on a plinth
    80-120 mm, glazed on four sides, a sign band and a hipped roof 0.10-0.20 m; the
    door (+x) stands open 10-25 degrees. Glass booth: 0.85-1.10 m by 0.85-1.10 m,
    2.20-2.50 m high, glass panels 10-25 cm above the ground between four posts, roof
    80-150 mm. Pedestal phone: a post 1.00-1.25 m carrying a phone 0.35-0.50 m high,
    with a hood 0.55-0.80 m wide (60 %). The phone hangs on the back wall, facing +x.
    Overall: 1.30-2.92 m high, 0.30-1.40 m (x), 0.30-1.22 m (y).
    """
    style = int(rng.integers(3))
    if style == 0:
        return _kiosk(rng)
    if style == 1:
        return _glass_booth(rng)
    post, post_h = dim(rng, 0.08, 0.14), dim(rng, 1.00, 1.25)
    look = pick(rng, (*PAINT, STEEL, *BRIGHT[:2]))
    depth, width, high = dim(rng, 0.15, 0.25), dim(rng, 0.22, 0.32), dim(rng, 0.35, 0.50)
    bottom = post_h - 0.04
    parts: list[Part] = [
        Box((post, post, post_h), (0.0, 0.0, post_h / 2), 0.0, look),
        Box((0.30, 0.30, 0.015), (0.0, 0.0, 0.0075), 0.0, look),
        Box((depth, width, high), (0.0, 0.0, bottom + high / 2), 0.0, STEEL),
        Box(
            (0.012, width * 0.5, high * 0.2),
            (depth / 2 + 0.006 - EMBED, 0.0, bottom + high * 0.75),
            0.0,
            SCREEN,
        ),
        Box(
            (0.012, width * 0.4, high * 0.25),
            (depth / 2 + 0.006 - EMBED, 0.0, bottom + high * 0.4),
            0.0,
            DARK,
        ),
        Capsule(0.025, 0.14, (depth / 2 + 0.02, width / 2 - 0.04, bottom + high * 0.55), DARK),
    ]
    if rng.random() < 0.6:  # hood: a back wall, a roof and two side wings, open to +x
        hood_w, hood_d, hood_h = dim(rng, 0.55, 0.80), dim(rng, 0.35, 0.50), dim(rng, 0.60, 0.90)
        wall, z0 = 0.02, bottom - 0.1
        back = -depth / 2 - wall / 2 + EMBED
        x_mid = back - wall / 2 + hood_d / 2
        parts += [
            Box((wall, hood_w, hood_h), (back, 0.0, z0 + hood_h / 2), 0.0, look),
            Box((hood_d, hood_w, 0.03), (x_mid, 0.0, z0 + hood_h + 0.015 - EMBED), 0.0, look),
        ]
        parts += [
            Box((hood_d, wall, hood_h), (x_mid, sy * (hood_w / 2 - wall / 2), z0 + hood_h / 2), 0.0, look)
            for sy in (-1, 1)
        ]
    return parts


def _kiosk(rng: np.random.Generator) -> list[Part]:
    """A classic square kiosk, its door (+x) ajar so the inside opens to the street."""
    side, walls, plinth = dim(rng, 0.88, 1.00), dim(rng, 2.15, 2.40), dim(rng, 0.08, 0.12)
    post, wall = dim(rng, 0.08, 0.12), 0.04
    look = pick(rng, (MAIL[1], MAIL[1], MAIL[3], PAINT[3], PAINT[2]))
    top = plinth + walls
    span = side - 2 * post + 2 * EMBED
    mid = plinth + walls / 2
    pane_h, pane_z = walls * 0.55, plinth + walls * 0.55
    edge = side / 2 - wall / 2
    off = wall / 2 + 0.005 - EMBED  # a 10 mm pane's centre from its wall's centre
    parts: list[Part] = [
        Box((side + 0.04, side + 0.04, plinth), (0.0, 0.0, plinth / 2), 0.0, pick(rng, CONCRETE)),
        Box((side + 0.02, side + 0.02, 0.2), (0.0, 0.0, top + 0.1 - EMBED), 0.0, look),
        Box((side + 0.028, side * 0.6, 0.1), (0.0, 0.0, top + 0.1), 0.0, WHITE),
        _hip(
            (side + 0.06, side + 0.06),
            (side * 0.5, side * 0.5),
            top + 0.2 - EMBED,
            top + 0.2 + dim(rng, 0.10, 0.20),
            look,
        ),
        Box((wall, span, walls), (-edge, 0.0, mid), 0.0, look),
        Box((0.01, span * 0.8, pane_h), (-edge - off, 0.0, pane_z), 0.0, GLASS),
        Box((0.06, 0.18, 0.25), (-edge + wall / 2 + 0.03 - EMBED, 0.0, plinth + 1.35), 0.0, DARK),
    ]
    parts += [
        Box((post, post, walls + 2 * EMBED), (sx * (side - post) / 2, sy * (side - post) / 2, mid), 0.0, look)
        for sx in (-1, 1)
        for sy in (-1, 1)
    ]
    for sy in (-1, 1):
        parts.append(Box((span, wall, walls), (0.0, sy * edge, mid), 0.0, look))
        parts.append(Box((span * 0.8, 0.01, pane_h), (0.0, sy * (edge + off), pane_z), 0.0, GLASS))
    # the door, hinged in the front post at -y, swung out by `ajar`
    ajar = math.radians(dim(rng, 10.0, 25.0))
    hinge = (side / 2 - post / 2, -side / 2 + post - 0.01)
    length = side - 2 * post + 0.012
    along = (math.sin(ajar), math.cos(ajar))  # from the hinge to the door's free edge
    centre = (hinge[0] + length / 2 * along[0], hinge[1] + length / 2 * along[1])
    normal = (along[1], -along[0])  # the door's outer face
    parts.append(Box((wall, length, walls - 0.02), (*centre, mid), -ajar, look))
    parts.append(
        Box(
            (0.01, length * 0.8, pane_h),
            (centre[0] + off * normal[0], centre[1] + off * normal[1], pane_z),
            -ajar,
            GLASS,
        )
    )
    return parts


def _glass_booth(rng: np.random.Generator) -> list[Part]:
    """A modern booth: glass panels between four posts, clear of the ground, under a roof."""
    sx, sy, high = dim(rng, 0.85, 1.10), dim(rng, 0.85, 1.10), dim(rng, 2.20, 2.50)
    post, roof, gap = dim(rng, 0.05, 0.08), dim(rng, 0.08, 0.15), dim(rng, 0.10, 0.25)
    frame, band = pick(rng, (STEEL, *PAINT[1:4])), pick(rng, (*BRIGHT[:5], WHITE))
    over = dim(rng, 0.02, 0.06)
    under = high - roof  # the roof's underside
    pane, pz, ph = 0.012, (gap + under) / 2, under - gap + EMBED
    parts: list[Part] = [
        Box((sx + 2 * over, sy + 2 * over, roof), (0.0, 0.0, high - roof / 2), 0.0, frame),
        Box((sx + 2 * over + 0.01, sy * 0.7, roof * 0.6), (0.0, 0.0, high - roof / 2), 0.0, band),
        Box((pane, sy - post, ph), (-(sx - post) / 2, 0.0, pz), 0.0, GLASS),
        # a shelf from the back panel to the side panel at -y
        Box((0.3, 0.25, 0.02), (-(sx - post) / 2 + 0.15, -(sy - post) / 2 + 0.125, 1.0), 0.0, frame),
        Box((0.08, 0.2, 0.3), (-(sx - post) / 2 + pane / 2 + 0.04 - EMBED, 0.0, 1.4), 0.0, DARK),
    ]
    parts += [
        Box(
            (post, post, under + EMBED),
            (px * (sx - post) / 2, py * (sy - post) / 2, (under + EMBED) / 2),
            0.0,
            frame,
        )
        for px in (-1, 1)
        for py in (-1, 1)
    ]
    parts += [Box((sx - post, pane, ph), (0.0, py * (sy - post) / 2, pz), 0.0, GLASS) for py in (-1, 1)]
    door = sy * dim(rng, 0.55, 0.75)
    parts.append(Box((pane, door, ph), ((sx - post) / 2, -(sy - post) / 2 + door / 2, pz), 0.0, GLASS))
    return parts


# --- advertising boards ----------------------------------------------------------------


def advertising_board(rng: np.random.Generator) -> list[Part]:
    """An advertising board: a sandwich board, a poster column (Litfass) or a poster panel on legs.

    Sandwich board: two boards 0.50-0.70 m wide and 0.80-1.10 m long leaning together
    from a spread of 0.40-0.70 m; faces +-y, to passers-by along the sidewalk. Poster
    column: drum radius 0.55-0.70 m, 2.0-2.8 m on a plinth 0.15-0.35 m, cornice and a
    domed roof 0.25-0.60 m with a finial, 2-3 poster bands. Poster panel: 1.20-3.00 m
    wide (y), 1.70-2.30 m high, 0.12-0.30 m thick, on one or two legs 0.30-1.20 m,
    posters on +x (both sides 60 %). Overall: 0.72-4.16 m high, 0.12-1.66 m (x),
    0.40-3.00 m (y).
    """
    style = int(rng.integers(3))
    if style == 0:
        return _sandwich_board(rng)
    if style == 1:
        return _poster_column(rng)
    width, high, thick = dim(rng, 1.20, 3.00), dim(rng, 1.70, 2.30), dim(rng, 0.12, 0.30)
    legs, frame = dim(rng, 0.30, 1.20), pick(rng, (*PAINT[:4], STEEL))
    border = dim(rng, 0.04, 0.10)
    parts: list[Part] = [Box((thick, width, high), (0.0, 0.0, legs + high / 2), 0.0, frame)]
    poster = (0.01, width - 2 * border, high - 2 * border)
    for sx in (1, -1) if rng.random() < 0.6 else (1,):
        at = (sx * (thick / 2 + 0.005 - EMBED), 0.0, legs + high / 2)
        parts.append(Box(poster, at, 0.0, pick(rng, BRIGHT[:7])))
    leg_x, leg_y = dim(rng, 0.08, thick), dim(rng, 0.08, 0.20)
    ys = [0.0] if width < 1.6 else [-(width / 2 - 0.3), width / 2 - 0.3]
    for y in ys:
        parts.append(Box((leg_x, leg_y, legs + 0.05), (0.0, y, (legs + 0.05) / 2), 0.0, frame))
        if rng.random() < 0.5:
            foot = dim(rng, max(thick, 0.25), 0.45)
            parts.append(Box((foot, leg_y + 0.1, 0.02), (0.0, y, 0.01), 0.0, frame))
    return parts


def _sandwich_board(rng: np.random.Generator) -> list[Part]:
    """Two boards leaning together (an A-frame), their faces towards +-y."""
    width, length, thick = dim(rng, 0.50, 0.70), dim(rng, 0.80, 1.10), dim(rng, 0.018, 0.03)
    spread = dim(rng, 0.40, 0.70) / 2  # from the centre to each board's foot (m)
    lean = math.asin(spread / length)
    frame, poster = pick(rng, (*PAINT[:3], *CONCRETE[:1], WHITE)), pick(rng, (*BRIGHT, DARK))
    z = (length * math.cos(lean) + thick * math.sin(lean)) / 2
    parts: list[Part] = []
    for sy in (-1, 1):
        phi = sy * lean  # tilt about +x: the board's top towards y = 0
        centre = (0.0, sy * length / 2 * math.sin(lean), z)
        parts.append(_board(width, thick, length, centre, phi, frame))
        out = thick / 2 + 0.004 - EMBED
        normal = (0.0, math.cos(phi) * sy, math.sin(phi) * sy)
        face = tuple(c + out * n for c, n in zip(centre, normal, strict=True))
        parts.append(_board(width * 0.84, 0.008, length * 0.72, face, phi, poster))
    return parts


def _board(
    width: float, thick: float, length: float, centre: Sequence[float], phi: float, look: Look
) -> ConvexMesh:
    """A board ``width`` (x) by ``thick`` (y) by ``length`` (z), turned by ``phi`` (rad) about +x."""
    c, s = math.cos(phi), math.sin(phi)
    points = []
    for x in (-width / 2, width / 2):
        for y in (-thick / 2, thick / 2):
            for z in (-length / 2, length / 2):
                points.append((centre[0] + x, centre[1] + y * c - z * s, centre[2] + y * s + z * c))
    return ConvexMesh(tuple(points), look)


def _poster_column(rng: np.random.Generator) -> list[Part]:
    """A Litfass column: plinth, poster drum, cornice, domed roof and finial."""
    r, drum, plinth = dim(rng, 0.55, 0.70), dim(rng, 2.0, 2.8), dim(rng, 0.15, 0.35)
    look = pick(rng, (PAINT[0], PAINT[2], PAINT[3], *CONCRETE[:2]))
    cornice, lip = dim(rng, 0.10, 0.20), dim(rng, 0.06, 0.12)
    top = plinth + drum
    roof = dim(rng, 0.25, 0.60)
    parts: list[Part] = [
        Cylinder(r + dim(rng, 0.05, 0.10), plinth, (0.0, 0.0, plinth / 2), look),
        Cylinder(r, drum + 2 * EMBED, (0.0, 0.0, plinth + drum / 2), pick(rng, (WHITE, *CONCRETE[:2]))),
        Cylinder(r + lip, cornice, (0.0, 0.0, top + cornice / 2), look),
        frustum(r + lip * 0.6, 0.12, top + cornice - EMBED, top + cornice + roof, look),
    ]
    finial = dim(rng, 0.06, 0.12)
    parts.append(Capsule(finial, 0.0, (0.0, 0.0, top + cornice + roof + finial - 0.03), look))
    bands = int(rng.integers(2, 4))
    band = (drum - 0.2) / bands
    for i in range(bands):
        parts.append(
            Cylinder(r + 0.004, band - 0.04, (0.0, 0.0, plinth + 0.1 + (i + 0.5) * band), pick(rng, BRIGHT))
        )
    return parts


# --- street signs ------------------------------------------------------------------------


def street_sign(rng: np.random.Generator) -> list[Part]:
    """A sign post with 1-3 plates facing +y and optional street-name blades on top.

    Post: round (radius 25-40 mm) or square (50-75 mm), galvanised or painted, 2.1-3.4
    m to its top, optional footing. Main plate: a stop octagon 0.60-0.90 m across (a
    convex prism with a white border), a yield triangle 0.60-0.90 m, a round sign
    0.42-0.75 m (prohibition, mandatory or speed limit), or a rectangle 0.30-0.75 m by
    0.30-0.90 m, its top 2.1-2.9 m above the ground; 0-2 supplementary plates 0.30-0.60
    m wide below it. Street-name blades (40 %): one or two (crossed) 0.60-1.20 m long,
    0.15-0.23 m high, on the post top. Overall: 2.10-3.40 m high, 0.30-1.20 m (x),
    0.05-1.20 m (y).
    """
    look = pick(rng, (STEEL, STEEL, PAINT[1], PAINT[0], PAINT[2]))
    top = dim(rng, 2.1, 2.9)  # top of the main plate
    round_post = rng.random() < 0.6
    half = dim(rng, 0.025, 0.04) if round_post else dim(rng, 0.025, 0.0375)
    thick = dim(rng, 0.006, 0.012)
    y0 = half - 0.008  # plates start inside the post's front
    parts: list[Part] = []
    kind = int(rng.integers(4))
    if kind == 0:  # stop
        across = dim(rng, 0.60, 0.90)
        radius = across / 2 / math.cos(math.pi / 8)
        zc = top - across / 2
        outline = [(radius * math.cos(a), zc + radius * math.sin(a)) for a in _OCTAGON]
        inner = [(0.88 * x, zc + 0.88 * (z - zc)) for x, z in outline]
        parts += [
            _prism_y(outline, y0, y0 + thick, WHITE),
            _prism_y(inner, y0 + thick - EMBED, y0 + thick + 0.003, SIGN_RED),
        ]
        bottom = top - across
    elif kind == 1:  # yield: apex down
        side = dim(rng, 0.60, 0.90)
        tall = side * math.sqrt(3) / 2
        outline = [(-side / 2, top), (side / 2, top), (0.0, top - tall)]
        zc = top - tall / 3  # the incentre, about which the inner white triangle shrinks
        inner = [(0.62 * x, zc + 0.62 * (z - zc)) for x, z in outline]
        parts += [
            _prism_y(outline, y0, y0 + thick, SIGN_RED),
            _prism_y(inner, y0 + thick - EMBED, y0 + thick + 0.003, WHITE),
        ]
        bottom = top - tall
    elif kind == 2:  # round
        radius = dim(rng, 0.21, 0.375)
        zc = top - radius
        face, rim = [(WHITE, SIGN_RED), (SIGN[1], WHITE), (SIGN_RED, SIGN_RED)][int(rng.integers(3))]
        parts.append(rod(radius, (0.0, y0, zc), (0.0, y0 + thick, zc), rim))
        if face is SIGN_RED:  # no entry: a white bar
            parts.append(Box((radius * 1.5, 0.006, radius * 0.36), (0.0, y0 + thick + 0.002, zc), 0.0, WHITE))
        else:
            parts.append(
                rod(radius * 0.8, (0.0, y0 + thick - EMBED, zc), (0.0, y0 + thick + 0.003, zc), face)
            )
        bottom = top - 2 * radius
    else:  # rectangle
        w, h = dim(rng, 0.30, 0.75), dim(rng, 0.30, 0.90)
        bg, fg = [(WHITE, SIGN[3]), (SIGN[1], WHITE), (SIGN[0], WHITE), (AMBER, SIGN[3])][
            int(rng.integers(4))
        ]
        parts.append(Box((w, thick, h), (0.0, y0 + thick / 2, top - h / 2), 0.0, bg))
        parts.append(Box((w * 0.7, 0.004, h * 0.25), (0.0, y0 + thick + 0.001, top - h * 0.45), 0.0, fg))
        bottom = top - h
    for _ in range(int(rng.integers(0, 3))):
        w, h, gap = dim(rng, 0.30, 0.60), dim(rng, 0.15, 0.40), dim(rng, 0.03, 0.10)
        if bottom - gap - h < 1.2:
            break
        parts.append(
            Box(
                (w, thick, h),
                (0.0, y0 + thick / 2, bottom - gap - h / 2),
                0.0,
                pick(rng, (WHITE, *SIGN[:2])),
            )
        )
        bottom -= gap + h
    post_top = top + dim(rng, 0.0, 0.1)
    if rng.random() < 0.4:  # street-name blades, the first along x, the second along y
        height, lift = dim(rng, 0.15, 0.23), dim(rng, 0.05, 0.25)
        z = min(post_top + lift, 3.4 - 2 * height)
        blade = pick(rng, SIGN[:3])
        for along in range(int(rng.integers(1, 3))):
            length = dim(rng, 0.60, 1.20)
            size = (length, 0.012, height) if along == 0 else (0.012, length, height)
            parts.append(Box(size, (0.0, 0.0, z + height / 2), 0.0, blade))
            z += height - EMBED
        post_top = z - 0.01
    if round_post:
        parts.append(Cylinder(half, post_top, (0.0, 0.0, post_top / 2), look))
        parts.append(Cylinder(half + 0.004, 0.02, (0.0, 0.0, post_top - 0.01), look))
    else:
        parts.append(Box((2 * half, 2 * half, post_top), (0.0, 0.0, post_top / 2), 0.0, look))
    if rng.random() < 0.3:
        footing = dim(rng, 0.03, 0.08)
        parts.append(Cylinder(dim(rng, 0.10, 0.15), footing, (0.0, 0.0, footing / 2), pick(rng, CONCRETE)))
    return parts


# --- traffic lights -------------------------------------------------------------------------


def traffic_light(rng: np.random.Generator) -> list[Part]:
    """A traffic signal: heads on a post, or on a mast arm reaching out over the roadway (+x).

    A vehicle head is three lenses (red, amber, green; radius 0.10-0.15 m) in a housing
    0.18-0.28 m deep with visors 0.10-0.18 m and a backplate (35 %); all heads of one
    signal are alike. Pedestrian heads (70 %): 0.30-0.40 m wide with two aspects, bottom
    2.1-2.5 m up, facing +x (and +y, 50 %), with a push button on -x. Post: 2.8-4.2 m
    (raised to clear the pedestrian heads), radius 70-120 mm at the base tapering to
    75-90 %, a vehicle head facing +y at the top and one facing -y (50 %). Mast arm:
    pole 5.5-7.5 m, radius 0.12-0.18 m; arm 2.5-5.2 m towards +x starting 0.2-0.4 m
    below the pole top and rising 0-0.4 m, with 1-2 heads hanging from it; a head on
    the pole (50 %). Overall: 2.80-7.80 m high, 0.26-5.55 m (x), 0.30-1.15 m (y).
    """
    mast = rng.random() < 0.5
    look, head_look = pick(rng, (*PAINT[:4], STEEL)), pick(rng, SIGNAL)
    lens = dim(rng, 0.10, 0.15)
    head = _Head(
        lens,
        dim(rng, 0.18, 0.28),
        2 * lens + dim(rng, 0.06, 0.10),
        2 * lens + dim(rng, 0.04, 0.08),
        head_look,
    )
    walk = None
    if rng.random() < 0.7:
        walk = (dim(rng, 2.1, 2.5), dim(rng, 0.30, 0.40), dim(rng, 0.18, 0.25), rng.random() < 0.5)
    if mast:
        r0, pole_h = dim(rng, 0.12, 0.18), dim(rng, 5.5, 7.5)
    else:
        r0, pole_h = dim(rng, 0.07, 0.12), dim(rng, 2.8, 4.2)
        if walk:  # the vehicle heads above the pedestrian heads
            pole_h = max(pole_h, round(walk[0] + 2 * walk[1] + 0.1 + head.high, 3))
    r1 = round(r0 * dim(rng, 0.75, 0.90), 3)
    parts: list[Part] = [frustum(r0, r1, 0.0, pole_h, look)]
    parts.append(Cylinder(r1 + 0.01, 0.03, (0.0, 0.0, pole_h - 0.015), look))  # cap
    if rng.random() < 0.5:
        base = dim(rng, 0.3, 0.6)
        parts.append(Cylinder(r0 + dim(rng, 0.03, 0.06), base, (0.0, 0.0, base / 2), look))
    back = r1 * math.cos(math.pi / 24) - 0.01  # a head's back this far from the axis is inside the pole
    if mast:
        arm_z, rise = pole_h - dim(rng, 0.2, 0.4), dim(rng, 0.0, 0.4)
        reach, arm_r = dim(rng, 2.5, 5.2), dim(rng, 0.05, 0.08)
        parts.append(rod(arm_r, (0.0, 0.0, arm_z), (reach, 0.0, arm_z + rise), look))
        xs = [reach - 0.45] if reach < 4.0 or rng.random() < 0.5 else [reach - 0.45, reach - 3.2]
        for x in xs:  # hanging from the arm, the housing's top 10 mm above the arm's axis
            parts += head.parts(rng, (x, -head.depth / 2), arm_z + rise * x / reach + 0.01, 1)
        if rng.random() < 0.5:
            parts += head.parts(rng, (0.0, back), pole_h - 1.0, 1)
    else:
        parts += head.parts(rng, (0.0, back), pole_h, 1)
        if rng.random() < 0.5:
            parts += head.parts(rng, (0.0, -back), pole_h, -1)
    if walk:
        z, side, depth, second = walk
        parts += _walk_head(back, z, side, depth, (1, 0), head_look)
        if second:
            parts += _walk_head(back, z, side, depth, (0, 1), head_look)
        parts.append(Box((0.06, 0.10, 0.16), (-back - 0.03 + EMBED, 0.0, dim(rng, 1.0, 1.1)), 0.0, AMBER))
    return parts


@dataclass(frozen=True)
class _Head:
    """A three-aspect vehicle signal head: lens radius, housing depth and width, the
    spacing of the lenses (m) and the housing's look."""

    lens: float
    depth: float
    width: float
    pitch: float
    look: Look

    @property
    def high(self) -> float:
        """The housing's height (m)."""
        return round(3 * self.pitch + 0.04, 6)

    def parts(
        self, rng: np.random.Generator, back: tuple[float, float], top: float, facing: int
    ) -> list[Part]:
        """The head with the middle of its back at ``back`` (x, y; m), its top at ``top`` (m),
        facing ``facing`` * +y; visors 0.10-0.18 m and the backplate (35 %) are drawn from ``rng``.
        """
        x, y = back[0], back[1] + facing * self.depth / 2
        face = back[1] + facing * self.depth
        parts: list[Part] = [
            Box((self.width, self.depth, self.high), (x, y, top - self.high / 2), 0.0, self.look)
        ]
        for k, colour in enumerate(LENSES):
            zc = top - 0.02 - (k + 0.5) * self.pitch
            parts.append(
                rod(self.lens, (x, face - facing * 0.01, zc), (x, face + facing * 0.012, zc), colour)
            )
            visor = dim(rng, 0.10, 0.18)
            parts.append(
                Box(
                    (2 * self.lens + 0.02, visor, 0.012),
                    (x, face + facing * (visor / 2 - EMBED), zc + self.lens + 0.006),
                    0.0,
                    self.look,
                )
            )
        if rng.random() < 0.35:  # a backplate, black or with a bright border
            plate = (self.width + 0.16, 0.015, self.high + 0.12)
            at = (x, back[1] + facing * 0.004, top - self.high / 2)
            parts.append(Box(plate, at, 0.0, pick(rng, (PAINT[1], SIGNAL[2], WHITE))))
        return parts


def _walk_head(
    back: float, z: float, side: float, depth: float, facing: tuple[int, int], look: Look
) -> list[Part]:
    """A two-aspect pedestrian head ``side`` wide, ``2 * side`` high and ``depth`` deep (m)
    on the pole, its back ``back`` (m) from the axis, bottom at ``z`` (m), facing (x, y)."""
    fx, fy = facing
    cx, cy = fx * (back + depth / 2), fy * (back + depth / 2)
    size = (depth, side, 2 * side) if fx else (side, depth, 2 * side)
    parts: list[Part] = [Box(size, (cx, cy, z + side), 0.0, look)]
    for k, colour in enumerate(WALK):
        zc = z + (1.5 - k) * side
        face = (cx + fx * (depth / 2 - 0.005), cy + fy * (depth / 2 - 0.005), zc)
        out = (face[0] + fx * 0.015, face[1] + fy * 0.015, zc)
        parts.append(rod(side * 0.38, face, out, colour))
    return parts


#: The categories built here, registered by :mod:`citygen.assets.catalog`.
CATEGORIES: dict[str, Category] = {
    "recycling_bin": Category(
        recycling_bin, "recycling_bin", zones("sidewalk", "plaza", "trail"), 0.5,
        height=(0.85, 1.17), size_x=(0.44, 0.68), size_y=(0.44, 2.24), anchor="curb",
    ),
    "mailbox": Category(
        mailbox, "mailbox", zones("sidewalk", "curb", "plaza"), 0.6,
        height=(1.12, 1.68), size_x=(0.24, 0.71), size_y=(0.36, 0.71), anchor="curb",
    ),
    "newspaper_box": Category(
        newspaper_box, "newspaper_box", zones("sidewalk", "plaza"), 0.6,
        height=(0.81, 1.24), size_x=(0.41, 0.52), size_y=(0.41, 1.62), anchor="curb",
    ),
    "parking_meter": Category(
        parking_meter, "parking_meter", zones("sidewalk", "curb"), 0.5,
        height=(1.24, 2.32), size_x=(0.15, 0.45), size_y=(0.18, 0.65), anchor="curb",
    ),
    "telephone_booth": Category(
        telephone_booth, "telephone_booth", zones("sidewalk", "plaza"), 0.8,
        height=(1.30, 2.92), size_x=(0.30, 1.40), size_y=(0.30, 1.22), anchor="frontage",
    ),
    "advertising_board": Category(
        advertising_board, "advertising_board", zones("sidewalk", "plaza"), 0.6,
        height=(0.72, 4.16), size_x=(0.12, 1.66), size_y=(0.40, 3.00), anchor="frontage",
    ),
    "street_sign": Category(
        street_sign, "street_sign", zones("sidewalk", "curb"), 0.3,
        height=(2.10, 3.40), size_x=(0.30, 1.20), size_y=(0.05, 1.20), anchor="curb",
    ),
    "traffic_light": Category(
        traffic_light, "traffic_light", zones("sidewalk", "curb"), 0.4,
        height=(2.80, 7.80), size_x=(0.26, 5.55), size_y=(0.30, 1.15), anchor="crossing",
    ),
}  # fmt: skip
