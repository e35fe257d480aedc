"""Stage 2 for ``layout = "city"``: the ground of a city, planned city block by city block.

The streets' ground is that of any road network (:func:`~citygen.generate.ground.street_bands`:
crosswalks at every junction arm, roadway, curbs, sidewalks with their furnishing, clear and
frontage strips). The land is cut into lots along the plan's lines
(:attr:`~citygen.generate.layouts.city.streets.CityPlan.cuts`: street centre lines, the back of the frontage
lots, lot widths along the street), and each lot is divided as its city block is built:

- **downtown**: every frontage lot is a building up to the sidewalk (a continuous street
  wall, now and then a small plaza); the lots behind are one courtyard (a garden, a plaza or
  parking, ``city.parking_share`` of them);
- **residential**: a front yard (``city.residential_setback``) along the sidewalk, then
  a building in each frontage lot with side yards; back yards behind (half
  ``city.parking_share`` of those lots parking);
- **park**: lawn crossed by trails through the middle of the city block;
- **plaza**: paved, with lawn beds in the lots behind the frontage.

Lots are divided as in :func:`~citygen.generate.ground.plan_ground` (one noding per lot), so
the zones tile the scene exactly.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import shapely
from shapely.geometry import Polygon, box

from citygen.generate.ground import street_bands, street_layers
from citygen.generate.layouts.city.streets import CityPlan
from citygen.generate.zoning import QUAD_SEGS, Piece, arrange, clip_to_lots, polygons, snap, to_zones
from citygen.seeding import uniform
from citygen.spec.config import CityConfig, GroundConfig
from citygen.spec.scene import Bounds
from citygen.spec.zones import Zone

#: A lot this close to a sidewalk (beyond the front yard) fronts the street, in metres.
FACING = 3.0
#: Chance that a downtown frontage lot is a small plaza instead of a building.
POCKET_PLAZA = 0.06
#: Chance that a residential frontage lot is built on.
HOUSE = 0.85


def plan_city_ground(
    bounds: Bounds,
    plan: CityPlan,
    cfg: GroundConfig,
    city: CityConfig,
    rng: np.random.Generator,
    *,
    seed: int | None = None,
) -> tuple[Zone, ...]:
    """Zones tiling ``bounds`` around a city's streets (see the module docstring)."""
    crosswalks, roads, curbs, islands, sidewalks = street_bands(plan.blocks, cfg, rng)
    street = sidewalks["frontage"]
    setback = uniform(rng, city.residential_setback)
    yard = street.buffer(setback, quad_segs=QUAD_SEGS)
    shapely.prepare(street)
    xs, ys = plan.cuts
    layers = [crosswalks, roads, curbs, islands, *sidewalks.values(), yard]
    for g in layers:
        shapely.prepare(g)
    clipped: dict[tuple[int, int], list] = {}
    clip_to_lots(layers, list(xs), list(ys), 0, len(xs) - 1, 0, len(ys) - 1, clipped)
    lot_seed = int(rng.integers(2**63))
    # The middle lot row and column of each city block, where a park's trails run.
    middle = (_middles(xs, plan.lines[0]), _middles(ys, plan.lines[1]))

    pieces: list[Piece] = []
    for (j, i), parts in sorted(clipped.items()):
        *street_parts, yard_band = parts
        lot = box(xs[i], ys[j], xs[i + 1], ys[j + 1])
        cell = plan.cell((xs[i] + xs[i + 1]) / 2, (ys[j] + ys[j + 1]) / 2)
        district, courtyard = plan.districts[cell], plan.courtyards[cell]
        layers = street_layers(street_parts)
        if district == "residential":
            layers.append(("vegetation", None, yard_band))
        r = np.random.default_rng([lot_seed, j, i])
        if district == "park" and (i in middle[0] or j in middle[1]):
            # Trails through the middle lot row and column: a layer, noded with the rest.
            layers.append(("trail", None, _trail(lot, i in middle[0], j in middle[1], r)))

        def fill(part, r=r, district=district, courtyard=courtyard):
            reach = setback + FACING if district == "residential" else FACING
            faces = bool(shapely.dwithin(street, part, reach))
            return _lot(part, district, courtyard, faces, city, r)

        pieces += arrange(lot, layers, fill)
    return to_zones(pieces)


def _middles(cuts, lines) -> set[int]:
    """Index of the lot nearest the middle of each interval between street lines."""
    centres = np.array([(a + b) / 2 for a, b in itertools.pairwise(cuts)])
    bounds = [0.0, *lines, cuts[-1]]
    out = set()
    for a, b in itertools.pairwise(bounds):
        out.add(int(np.argmin(np.abs(centres - (a + b) / 2))))
    return out


def _lot(part: Polygon, district: str, courtyard: str, faces: bool, city: CityConfig, r) -> list[Piece]:
    """What one lot's land (``part``, what the streets leave of it) is built as."""
    if district == "park":
        return [("vegetation", None, part)]
    if district == "plaza":
        return [("plaza" if faces or r.random() < 0.6 else "vegetation", None, part)]
    if faces and part.area >= 60.0 and _compact(part):
        if district == "downtown":
            if r.random() >= POCKET_PLAZA:
                return [("building", None, part)]
            return [("plaza", None, part)]
        if r.random() < HOUSE:
            inset = part.buffer(-uniform(r, (1.5, 3.0)), join_style="mitre")
            footprints = [f for f in polygons(inset) if f.area >= 40.0]
            if footprints:
                yard = Polygon(part.exterior, [*part.interiors, *(f.exterior for f in footprints)])
                return [*(("building", None, f) for f in footprints), ("vegetation", None, yard)]
    if faces:
        return [("plaza" if district == "downtown" else "vegetation", None, part)]
    # Courtyards (one kind per downtown city block) and back yards (lawn, some parking).
    if district == "downtown":
        return [(courtyard, None, part)]
    return [("parking" if r.random() < city.parking_share / 2 else "vegetation", None, part)]


def _compact(part: Polygon) -> bool:
    """Whether a lot's land is close to a rectangle at least 8 m across."""
    rect = part.minimum_rotated_rectangle
    corners = list(rect.exterior.coords)
    short = min(math.dist(corners[k], corners[k + 1]) for k in range(4))
    return part.area >= 0.6 * rect.area and short >= 8.0


def _trail(lot: Polygon, vertical: bool, horizontal: bool, r) -> Polygon:
    """A park's trails across ``lot``: through its middle, along y and/or along x."""
    x0, y0, x1, y1 = lot.bounds
    x, y = snap((x0 + x1) / 2), snap((y0 + y1) / 2)
    half = snap(uniform(r, (1.5, 2.5)) / 2)
    return shapely.union_all(
        ([box(x0, y - half, x1, y + half)] if horizontal else [])
        + ([box(x - half, y0, x + half, y1)] if vertical else [])
    )
