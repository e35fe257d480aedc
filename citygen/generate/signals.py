"""Traffic signals for a city's junctions (part of stage 2 for ``layout = "city"``), and the
traffic lights that stand where they are (after stage 4).

Every ``intersection`` and ``t_intersection`` block gets a two-phase plan: the arms along one
axis (``in`` and ``out``; ``left`` and ``right`` or a T's ``side``) share a phase, so opposing
traffic goes together. A general ``junction`` gets a phase per axis too, two arms within
:data:`GENERAL_AXIS` of opposite sharing one, and a phase of its own for every other arm (a
five-way junction's fifth street, a Y's branches). A phase serves all lanes of its arms and
the crosswalks over the *other* arms (people walk beside the traffic that has green). Green is
:data:`BASE_GREEN` plus :data:`GREEN_PER_LANE` per lane of the street an arm leads to (arterials
get longer greens), then :data:`AMBER` and :data:`ALL_RED`. Offsets make a green wave for
traffic going east at :data:`WAVE_SPEED`. Roundabouts are left unsignalised (vehicles yield),
as are curves. A mid-block crossing is signalised only where a real place maps it so
(:func:`signalise_crossing`: a straight block's plan of a traffic phase and a walk phase),
and a crossing of no street where it maps signals over tram tracks (:func:`signalise_walk`).

Nothing is drawn from a generator: the plan is a function of the blocks and zones, so it is
the same for the same streets and costs no seeds.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.generate.placement import base_of
from citygen.geometry.roads import block_geometry, block_kind
from citygen.geometry.terrain import height_at
from citygen.spec.blocks import Junction, Straight
from citygen.spec.placements import Placement
from citygen.spec.signals import Head, Phase, Signal
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

BASE_GREEN, GREEN_PER_LANE = 14.0, 8.0
"""Green time (s) of a phase: this base plus this much per lane of its widest street."""
AMBER, ALL_RED = 3.0, 2.0
"""Amber and all-red clearance times (s) after each green."""
WAVE_SPEED = 12.0
"""Speed (m/s) of the green wave the offsets make for eastbound traffic."""
HEAD_SIDE = (1.0, 0.6, 1.5, 0.3)
"""Distances (m) beyond the road's edge tried for a light's pole, on the sidewalk or curb."""
LIGHT_ASSET = "traffic_light/0000"
"""The catalog variant of the lights that stand at signalised junctions."""
BESIDE_PATHS = ("sidewalk", "curb", "bike_lane", "trail", "plaza", "vegetation")
"""Ground a pedestrian signal's light (of a plan with no lanes) may stand on."""
GENERAL_AXIS = math.radians(25.0)
"""Two arms of a general junction this near (rad) one axis share a phase: a street going on
across it, however the map bends it."""


def _axis_groups(arms, tolerance: float = 0.1) -> list[list]:
    """Arms grouped by their road's axis (opposite arms within ``tolerance`` rad together), in
    arm order."""
    groups: list[list] = []
    for arm in arms:
        for g in groups:
            if len(g) < 2 and abs(math.remainder(arm.yaw - g[0].yaw, math.pi)) < tolerance:
                g.append(arm)
                break
        else:
            groups.append([arm])
    return groups


def _arm_length(block, arm, centre: np.ndarray) -> float:
    """How far an arm of a junction block reaches from its centre (m)."""
    if not isinstance(block, Junction):
        return block.arm_length
    return float(np.hypot(*(np.asarray(arm.position) - centre)))


def signalise(blocks: Sequence, zones: Sequence[Zone]) -> tuple[Signal, ...]:
    """One :class:`~citygen.spec.signals.Signal` per intersection, T-intersection and general
    junction of ``blocks``, its phases naming the crosswalk zones of ``zones`` at each arm.

    >>> from citygen.generate.pipeline import layout
    >>> from citygen.spec.config import GeneratorConfig
    >>> scene = layout(GeneratorConfig(size=(400.0, 400.0), layout="city"), 1)
    >>> s = scene.signals[0]
    >>> [p.id for p in s.phases], s.phases[0].lanes[:2], s.cycle
    (['in-out', 'side'], ('in:0', 'in:1'), 70.0)
    """
    walks = [z for z in zones if z.kind == "crosswalk"]
    polys = [Polygon(z.polygon, z.holes) for z in walks]
    tree = shapely.STRtree(polys)
    lanes_of = {b.id: b.lanes for b in blocks}
    out = []
    for block in blocks:
        if not block_kind(block).signalised:
            continue
        g = block_geometry(block)
        centre = np.asarray(g.centre)
        neighbour = {c.socket: c.block for c in block.connections}
        crossing: dict[str, list[str]] = {}
        far: dict[str, float] = {}
        for arm, site in zip(g.arms, g.crossings, strict=True):
            d = np.array([math.cos(arm.yaw), math.sin(arm.yaw)])
            n = np.array([-d[1], d[0]])
            a, b = (
                centre + d * site.offset,
                centre + d * min(site.offset + 6.0, _arm_length(block, arm, centre)),
            )
            span = site.half_width + 0.5
            band = Polygon([a - n * span, b - n * span, b + n * span, a + n * span])
            hits = sorted(int(k) for k in tree.query(band, predicate="intersects"))
            hits = [k for k in hits if polys[k].intersection(band).area > 0.5]
            crossing[arm.socket] = [walks[k].id for k in hits]
            reach = [float(np.max(np.asarray(polys[k].exterior.coords) @ d - centre @ d)) for k in hits]
            far[arm.socket] = max(reach, default=site.offset + 3.0)
        phases = []
        for group in _axis_groups(g.arms, GENERAL_AXIS if isinstance(block, Junction) else 0.1):
            names = [a.socket for a in group]
            widest = max(lanes_of.get(neighbour.get(s, ""), block.lanes) for s in names)
            phases.append(
                Phase(
                    id="-".join(names),
                    lanes=tuple(f"{s}:{k}" for s in names for k in range(block.lanes)),
                    crosswalks=tuple(c for a in g.arms if a.socket not in names for c in crossing[a.socket]),
                    green=BASE_GREEN + GREEN_PER_LANE * widest,
                    amber=AMBER,
                    red=ALL_RED,
                )
            )
        heads = []
        for arm in g.arms:
            d = np.array([math.cos(arm.yaw), math.sin(arm.yaw)])
            n = np.array([-d[1], d[0]])  # the right of traffic coming in along this arm
            p = centre + d * (far[arm.socket] + 1.0) + n * arm.half_width
            heads.append(Head(position=(float(p[0]), float(p[1])), yaw=math.remainder(arm.yaw, 2 * math.pi)))
        out.append(_plan(f"signal-{block.id}", block.id, phases, centre[0], heads))
    return tuple(out)


def _plan(name: str, junction: str, phases, x, heads) -> Signal:
    """A signal plan of ``phases`` in order, its cycle their sum and its offset the green
    wave's at ``x`` (m, the plan's centre along the wave)."""
    cycle = sum(p.green + p.amber + p.red for p in phases)
    return Signal(
        id=name,
        junction=junction,
        phases=tuple(phases),
        cycle=cycle,
        offset=round((x / WAVE_SPEED) % cycle, 1),
        heads=tuple(heads),
    )


WALK_GREEN, WALK_SPEED = 6.0, 1.2
"""Walk time (s) of a mid-block crossing's walk phase: this base plus the crossing at this
speed (m/s)."""


def signalise_crossing(block: Straight, crosswalks: Sequence[Zone], lights: Sequence = ()) -> Signal:
    """The plan of a signalised mid-block crossing of ``crosswalks`` (zones) on a straight
    ``block``: a traffic phase (every lane of the ``in`` socket and, both ways, of ``out``)
    then a walk phase (the crosswalks), a light at the right of each approach, 1 m before the
    crosswalks or beside the farthest of ``lights`` (points, m: where a map puts the signals)
    on that side. Named after the first crosswalk (``signal-crosswalk-n12``).

    >>> from citygen.spec.blocks import Straight
    >>> from citygen.spec.zones import Zone
    >>> road = Straight(id="s1", kind="straight", pose={"position": [0, 0], "yaw": 0}, lanes=1,
    ...                 lane_width=3.0, length=40.0)
    >>> walk = Zone(id="crosswalk-n7", kind="crosswalk",
    ...             polygon=[[18, -3.2], [21, -3.2], [21, 3.2], [18, 3.2]])
    >>> s = signalise_crossing(road, [walk])
    >>> s.junction, [(p.id, p.lanes, p.crosswalks) for p in s.phases], [h.position for h in s.heads]
    ('s1', [('traffic', ('in:0', 'out:0'), ()), ('walk', (), ('crosswalk-n7',))], [(17.0, -3.0), (22.0, 3.0)])
    """
    g = block_geometry(block)
    p0 = np.asarray(block.pose.position, dtype=float)
    d = np.array([math.cos(block.pose.yaw), math.sin(block.pose.yaw)])
    n = np.array([-d[1], d[0]])
    along = np.concatenate([np.asarray(Polygon(z.polygon, z.holes).exterior.coords) for z in crosswalks])
    u = (along - p0) @ d
    near, far = float(u.min()), float(u.max())
    stop_in, stop_out = near - 1.0, far + 1.0
    for q in lights:
        v = float((np.asarray(q, dtype=float) - p0) @ d)
        stop_in, stop_out = (min(stop_in, v), stop_out) if v < near else (stop_in, max(stop_out, v))
    half = g.arms[0].half_width
    lanes = [f"in:{k}" for k in range(block.lanes)]
    heads = [
        Head(
            position=_xy(p0 + d * stop_in - n * half),
            yaw=math.remainder(block.pose.yaw + math.pi, 2 * math.pi),
        )
    ]
    if not block.one_way:
        lanes += [f"out:{k}" for k in range(block.lanes)]
        heads.append(
            Head(position=_xy(p0 + d * stop_out + n * half), yaw=math.remainder(block.pose.yaw, 2 * math.pi))
        )
    walk = round(WALK_GREEN + 2 * half / WALK_SPEED, 1)
    phases = (
        Phase(
            id="traffic",
            lanes=tuple(lanes),
            green=BASE_GREEN + GREEN_PER_LANE * block.lanes,
            amber=AMBER,
            red=ALL_RED,
        ),
        Phase(id="walk", crosswalks=tuple(z.id for z in crosswalks), green=walk, amber=AMBER, red=ALL_RED),
    )
    centre = p0 + d * (near + far) / 2
    return _plan(f"signal-{crosswalks[0].id}", block.id, phases, centre[0], heads)


def signalise_walk(crosswalks: Sequence[Zone], ends: Sequence) -> Signal:
    """The plan of a pedestrian signal on no street (a real place's footway crossing tram
    tracks, which the scene does not draw): a ``tracks`` phase serving nothing (the trams'
    turn; no vehicle the scene drives waits for it), then a walk phase (the ``crosswalks``,
    zones). It belongs to its first crosswalk (``junction`` names that zone), its lights stand
    at ``ends`` (``((x, y), yaw)``: each end of the crossing, facing out along it).

    >>> from citygen.spec.zones import Zone
    >>> walk = Zone(id="crosswalk-w9", kind="crosswalk", polygon=[[0, 0], [4, 0], [4, 2], [0, 2]])
    >>> s = signalise_walk([walk], [((0.0, 0.0), math.pi), ((4.0, 2.0), 0.0)])
    >>> s.id, s.junction, [(p.id, p.lanes, p.crosswalks) for p in s.phases], s.cycle
    ('signal-crosswalk-w9', 'crosswalk-w9', [('tracks', (), ()), ('walk', (), ('crosswalk-w9',))], 41.7)
    """
    (p, _), (q, _) = ends[0], ends[-1]
    phases = (
        Phase(id="tracks", green=BASE_GREEN + GREEN_PER_LANE, amber=AMBER, red=ALL_RED),
        Phase(
            id="walk",
            crosswalks=tuple(z.id for z in crosswalks),
            green=round(WALK_GREEN + math.dist(p, q) / WALK_SPEED, 1),
            amber=AMBER,
            red=ALL_RED,
        ),
    )
    heads = [Head(position=_xy(np.asarray(xy)), yaw=math.remainder(yaw, 2 * math.pi)) for xy, yaw in ends]
    return _plan(f"signal-{crosswalks[0].id}", crosswalks[0].id, phases, (p[0] + q[0]) / 2, heads)


def _xy(p: np.ndarray) -> tuple[float, float]:
    return (round(float(p[0]), 4) + 0.0, round(float(p[1]), 4) + 0.0)


def place_lights(
    signals: Sequence[Signal],
    zones: Sequence[Zone],
    placements: Sequence[Placement],
    terrain: Terrain | None,
    keep: frozenset[str] = frozenset(),
) -> tuple[Placement, ...]:
    """``placements`` with a traffic light at each signal head: its pole moved out from the
    road's edge (:data:`HEAD_SIDE`) to the first spot on sidewalk or curb (a pedestrian
    signal's, with no lanes, on any ground of :data:`BESIDE_PATHS`: beside a footway in a
    park); objects its base would touch (not buildings) make way, but for those named in
    ``keep`` (a real place's mapped objects), which no light's spot may touch (no spot: no
    light there)."""

    def base_at(x: float, y: float, yaw: float) -> Polygon:
        return base_of(Placement(id="light", asset=LIGHT_ASSET, position=(x, y, 0.0), yaw=yaw))

    def ground_of(kinds) -> tuple[list[Polygon], shapely.STRtree]:
        polys = [Polygon(z.polygon, z.holes) for z in zones if z.kind in kinds]
        return polys, shapely.STRtree(polys)

    by_road = ground_of(("sidewalk", "curb"))
    by_path = ground_of(BESIDE_PATHS) if any(not _has_lanes(s) for s in signals) else by_road
    kept = [base_of(p) for p in placements if p.id in keep]
    fixed = shapely.STRtree(kept) if kept else None
    lights: list[Placement] = []
    bases: list[Polygon] = []
    for s in signals:
        ground, tree = by_road if _has_lanes(s) else by_path
        for k, head in enumerate(s.heads):
            yaw = head.yaw
            d = np.array([math.cos(yaw), math.sin(yaw)])
            n = np.array([-d[1], d[0]])
            for side in HEAD_SIDE:
                x, y = np.asarray(head.position) + n * side
                base = base_at(float(x), float(y), yaw)
                hits = tree.query(base, predicate="intersects")
                on_ground = len(hits) and shapely.union_all([ground[i] for i in hits]).covers(base)
                clear = fixed is None or not len(fixed.query(base.buffer(0.1), predicate="intersects"))
                if on_ground and clear and not any(base.intersects(b) for b in bases):
                    break
            else:
                continue
            z = round(float(height_at(terrain, x, y)), 3) + 0.0
            lights.append(
                Placement(
                    id=f"{s.id}-light-{k + 1}",
                    asset=LIGHT_ASSET,
                    position=(round(float(x), 3) + 0.0, round(float(y), 3) + 0.0, z),
                    yaw=round(yaw, 6) + 0.0,
                )
            )
            bases.append(base)
    if not lights:
        return tuple(placements)
    tree_l = shapely.STRtree(bases)
    kept = []
    for p in placements:
        if p.asset.startswith("building/") or p.is_mesh:
            kept.append(p)
            continue
        if len(tree_l.query(base_of(p).buffer(0.1), predicate="intersects")) == 0:
            kept.append(p)
    return (*kept, *lights)


def _has_lanes(signal: Signal) -> bool:
    return any(p.lanes for p in signal.phases)
