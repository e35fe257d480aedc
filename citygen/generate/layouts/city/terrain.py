"""Stage 3 for ``layout = "city"``: the level changes a city has, as terrain features.

A city's tile grid is at street level (hard ground pins nearly every tile flat); what a
city adds to that are local features
(:class:`~citygen.spec.terrain.StepsFeature`, :class:`~citygen.spec.terrain.RampFeature`,
:class:`~citygen.spec.terrain.LandingFeature`), placed from the zones:

- **front steps** (``front-steps-<k>``) at the entrance of most buildings: one to three
  risers of 12-17 cm rising to the facade that faces the nearest sidewalk, treads of 30 cm
  and a top tread deep enough to stand at the door;
- **raised terraces** on plazas large enough (``terrace-<k>``): a landing two or three
  risers up, reached by a flight of steps on one side (``terrace-steps-<k>``) and a ramp of
  at most 1:12 on another (``terrace-ramp-<k>``), as accessibility codes ask.

Under them, the curbs (:mod:`citygen.generate.layouts.city.curbs`): every sidewalk a curb's height
above the street on slabs, and a 1:12 curb ramp at each end of every crosswalk. The front
steps and terraces stand on the ground under their low edge (a sidewalk's slab, a lawn).

Rough paving stays with the tile grid (rough tiles of cracked concrete, cobbles or setts),
except under a crosswalk or a feature other than a sidewalk's slab, where the tile is made
flat so no bump pokes through a tread or a ramp (under the slabs the bumps, lower than the
curb, stay hidden). A front step or a terrace never reaches into hard ground (roadway,
curb, crosswalk, parking, another building), never overlaps another feature but a
sidewalk's slab, and keeps clear of the traverse route's corridor; the route runs on the
sidewalks' slabs and crosses the streets down and up the curb ramps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import LineString, Polygon
from shapely.geometry.base import BaseGeometry

from citygen.generate.layouts.city.curbs import curb_features
from citygen.geometry.features import feature_polygon
from citygen.geometry.terrain import height_at
from citygen.seeding import uniform
from citygen.spec.base import quantize
from citygen.spec.terrain import FlatTile, LandingFeature, RampFeature, StepsFeature, Terrain
from citygen.spec.zones import Zone

#: Share of buildings with front steps.
FRONT_STEPS = 0.8
#: Farthest (m) a building's front may be from a sidewalk to get front steps.
FRONT_REACH = 12.0
#: Riser heights (m) and tread depth (m) of front steps and terrace steps.
RISER = (0.12, 0.17)
TREAD = 0.3
#: Smallest plaza (m^2) that gets a raised terrace, and the share of those that do.
TERRACE_AREA = 250.0
TERRACE_SHARE = 0.7
#: Steepest terrace ramp: 1:12 (accessibility codes).
RAMP_GRADE = 1.0 / 12.0
#: Zone kinds a feature may stand on.
SOFT = frozenset({"sidewalk", "plaza", "vegetation", "trail"})


def city_features(
    zones: Sequence[Zone],
    terrain: Terrain,
    rng: np.random.Generator,
    *,
    keep_clear: BaseGeometry | None = None,
    avoid: Sequence[tuple[float, float, float]] = (),
) -> Terrain:
    """``terrain`` with the city's features (see the module docstring) added; ``keep_clear``
    (an area, m) is ground no feature may reach (the traverse route's corridor); ``avoid``
    discs ``(x, y, radius)`` (m) the curb ramps narrow to keep clear of (a real place's
    mapped trees, :func:`~.curbs.curb_features`)."""
    polys = [Polygon(z.polygon, z.holes) for z in zones]
    hard = [p for p, z in zip(polys, zones, strict=True) if z.kind not in SOFT]
    hard_tree = shapely.STRtree(hard)
    sidewalk_tree = shapely.STRtree([p for p, z in zip(polys, zones, strict=True) if z.kind == "sidewalk"])
    buildings = [p for p, z in zip(polys, zones, strict=True) if z.kind == "building"]
    plazas = [p for p, z in zip(polys, zones, strict=True) if z.kind == "plaza"]
    if keep_clear is not None:
        shapely.prepare(keep_clear)
    taken: list[Polygon] = []
    taken_tree: dict[tuple[int, int], list[Polygon]] = {}

    def fits(shapes: list[Polygon], inside: Polygon | None = None, allow: Polygon | None = None) -> bool:
        for shape in shapes:
            probe = shape.buffer(-0.02, join_style="mitre")
            if inside is not None and not inside.contains(probe):
                return False
            if len(hard_tree.query(probe, predicate="intersects")):
                return False
            if keep_clear is not None and keep_clear.intersects(shape):
                return False
            x0, y0, x1, y1 = shape.bounds
            for key in _keys(x0, y0, x1, y1):
                if any(other.intersects(probe) for other in taken_tree.get(key, ())):
                    return False
        return True

    def take(shapes: list[Polygon]) -> None:
        for shape in shapes:
            taken.append(shape)
            for key in _keys(*shape.bounds):
                taken_tree.setdefault(key, []).append(shape)

    features: list = []
    r = np.random.default_rng(rng.integers(2**63))
    curbs, ramps = curb_features(zones, np.random.default_rng(rng.integers(2**63)), avoid)
    take(ramps)
    for building in buildings:
        if r.random() >= FRONT_STEPS:
            continue
        stoop = _front_steps(building, sidewalk_tree, r, len(features) + 1)
        if stoop is None:
            continue
        shape = feature_polygon(stoop)
        if fits([shape]):
            take([shape])
            features.append(stoop)
    t = 0
    for plaza in plazas:
        if plaza.area < TERRACE_AREA or r.random() >= TERRACE_SHARE:
            continue
        parts = _terrace(plaza, r, t + 1)
        if parts is None:
            continue
        shapes = [feature_polygon(f) for f in parts]
        if fits(shapes, inside=plaza):
            take(shapes)
            features += parts
            t += 1
    if not features and not curbs:
        return terrain
    # Crosswalks are smooth too: a step down the curb lands on level ground.
    walks = [p for p, z in zip(polys, zones, strict=True) if z.kind == "crosswalk"]
    terrain = _flatten_under(terrain, taken + walks)
    # The curbs stand at street level; every other feature on the ground under its low edge
    # (a sidewalk, a curb's height up, or a plaza or a lawn at street level).
    curbed = terrain.model_copy(update={"features": tuple(curbs) or None})
    if features:
        feet = np.array([_foot(f) for f in features])
        ground = height_at(curbed, feet[:, 0], feet[:, 1])
        features = [
            f.model_copy(update={"height": quantize(float(z))}) for f, z in zip(features, ground, strict=True)
        ]
    features = [*curbs, *(type(f).model_validate(f.model_dump()) for f in features)]
    # A feature lies on the tile grid: where streets run past the scene's edge (a real place's
    # box cuts them), the curb or ramp that would stick out of it is left out.
    (ox, oy), s = terrain.origin, terrain.tile_size
    grid = shapely.box(ox, oy, ox + terrain.cols * s, oy + terrain.rows * s).buffer(1e-4)
    features = [f for f in features if grid.covers(feature_polygon(f))]
    return terrain.model_copy(update={"features": tuple(features)})


def _flatten_under(terrain: Terrain, shapes: list[Polygon]) -> Terrain:
    """``terrain`` with every rough tile a feature stands on made flat at its height (its
    edges are level at that height, so its neighbours still agree): bumps never poke
    through a landing or a tread."""
    s, (ox, oy) = terrain.tile_size, terrain.origin
    tiles = list(terrain.tiles)
    for shape in shapes:
        x0, y0, x1, y1 = shape.bounds
        for row in range(max(0, math.floor((y0 - oy) / s)), min(terrain.rows, math.floor((y1 - oy) / s) + 1)):
            for col in range(
                max(0, math.floor((x0 - ox) / s)), min(terrain.cols, math.floor((x1 - ox) / s) + 1)
            ):
                k = row * terrain.cols + col
                if tiles[k].kind == "rough":
                    tiles[k] = FlatTile(kind="flat", height=tiles[k].height, material=tiles[k].material)
    return terrain.model_copy(update={"tiles": tuple(tiles)})


def _keys(x0: float, y0: float, x1: float, y1: float) -> list[tuple[int, int]]:
    s = 20.0
    return [
        (i, j)
        for i in range(math.floor(x0 / s), math.floor(x1 / s) + 1)
        for j in range(math.floor(y0 / s), math.floor(y1 / s) + 1)
    ]


def _foot(f) -> tuple[float, float]:
    return (f.center[0] - math.cos(f.yaw) * f.length / 2, f.center[1] - math.sin(f.yaw) * f.length / 2)


def _front_steps(building: Polygon, sidewalks: shapely.STRtree, r, k: int) -> StepsFeature | None:
    """Front steps against the facade of ``building`` that faces the nearest sidewalk."""
    ring = building.exterior
    if not ring.is_ccw:
        ring = LineString(ring.coords[::-1])
    pts = np.asarray(ring.coords)
    a, b = pts[:-1], pts[1:]
    d = b - a
    length = np.hypot(d[:, 0], d[:, 1])
    ok = np.flatnonzero(length >= 4.0)
    if not ok.size:
        return None
    mid = (a[ok] + b[ok]) / 2
    normal = np.c_[d[ok, 1], -d[ok, 0]] / length[ok, None]  # outward of a counter-clockwise ring
    probes = shapely.points(mid + normal * 0.5)
    near, dist = sidewalks.query_nearest(probes, return_distance=True, all_matches=False)
    best = np.full(len(ok), np.inf)
    best[near[0]] = dist
    e = int(np.argmin(best))
    if not best[e] <= FRONT_REACH:
        return None
    n = int(r.integers(1, 4))
    riser = quantize(uniform(r, RISER))
    landing = quantize(uniform(r, (0.3, 0.8)))
    depth = n * TREAD + landing
    span = float(length[ok[e]])
    width = quantize(min(uniform(r, (1.6, 3.0)), span - 1.0))
    along = uniform(r, (width / 2 + 0.5, span - width / 2 - 0.5)) if span - width > 1.0 else span / 2
    u = d[ok[e]] / span
    foot = a[ok[e]] + u * along
    centre = foot + normal[e] * depth / 2
    yaw = math.atan2(-normal[e][1], -normal[e][0])  # rising towards the facade
    return StepsFeature(
        id=f"front-steps-{k}",
        kind="steps",
        center=(quantize(float(centre[0])), quantize(float(centre[1]))),
        yaw=quantize(yaw),
        length=quantize(depth),
        width=width,
        step_height=riser,
        step_count=n,
        landing=landing,
        material="concrete",
    )


def _terrace(plaza: Polygon, r, k: int) -> list | None:
    """A raised landing inside ``plaza``, its steps on one side and a ramp on another."""
    rect = plaza.minimum_rotated_rectangle
    c = np.asarray(rect.exterior.coords)[:4]
    sides = [c[1] - c[0], c[2] - c[1]]
    lengths = [float(np.hypot(*s)) for s in sides]
    long_side = int(np.argmax(lengths))
    yaw = math.atan2(sides[long_side][1], sides[long_side][0])
    n = int(r.integers(2, 4))
    riser = quantize(uniform(r, RISER))
    rise = n * riser
    ramp_len = quantize(rise / RAMP_GRADE)
    flight = n * TREAD
    along = lengths[long_side] * uniform(r, (0.35, 0.5))
    across = lengths[1 - long_side] * uniform(r, (0.35, 0.5))
    if along < 4.0 or across < 3.0:
        return None
    centre = plaza.representative_point() if not plaza.contains(rect.centroid) else rect.centroid
    cx, cy = centre.x, centre.y
    cu, su = math.cos(yaw), math.sin(yaw)
    terrace = LandingFeature(
        id=f"terrace-{k}", kind="landing", center=(quantize(cx), quantize(cy)), yaw=quantize(yaw),
        length=quantize(along), width=quantize(across), rise=quantize(rise), material="paving_stone",
    )  # fmt: skip
    # The steps rise along +yaw to the terrace's low-x side; the ramp rises across to its side.
    sx, sy = cx - cu * (along / 2 + flight / 2), cy - su * (along / 2 + flight / 2)
    steps = StepsFeature(
        id=f"terrace-steps-{k}", kind="steps", center=(quantize(sx), quantize(sy)), yaw=quantize(yaw),
        length=quantize(flight), width=quantize(min(across, uniform(r, (2.5, 5.0)))), step_height=riser,
        step_count=n, material="paving_stone",
    )  # fmt: skip
    ramp_w = 1.5
    if ramp_len > along - 0.2:
        return [terrace, steps]
    # The ramp runs along the terrace's side (across offset), rising along +yaw to a strip
    # of the landing's side: placed beside the landing, it climbs to the landing's level at
    # its far end, where a short landing strip joins it to the terrace.
    off = across / 2 + ramp_w / 2
    nx, ny = -su, cu
    rx = cx + nx * off - cu * (along / 2 - ramp_len / 2)
    ry = cy + ny * off - su * (along / 2 - ramp_len / 2)
    ramp = RampFeature(
        id=f"terrace-ramp-{k}", kind="ramp", center=(quantize(rx), quantize(ry)), yaw=quantize(yaw),
        length=ramp_len, width=ramp_w, rise=quantize(rise), material="paving_stone",
    )  # fmt: skip
    top_len = along - ramp_len
    tx = cx + nx * off + cu * (along / 2 - top_len / 2)
    ty = cy + ny * off + su * (along / 2 - top_len / 2)
    top = LandingFeature(
        id=f"terrace-top-{k}", kind="landing", center=(quantize(tx), quantize(ty)), yaw=quantize(yaw),
        length=quantize(top_len), width=ramp_w, rise=quantize(rise), material="paving_stone",
    )  # fmt: skip
    return [terrace, steps, ramp, top]
