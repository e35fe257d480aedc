"""Stage 5: pedestrians, cyclists and scooter riders on walkable ground, vehicles on lanes.

People start and end in one connected piece of walkable ground wide enough for them
(the walkable zones shrunk by the largest radius of their kind, minus the objects
grown by it: :mod:`citygen.generate.space`), so a path between them exists; their
discs do not overlap each other or the robot's at the start. Radius and preferred
speed follow a normal distribution centred in the config's range (sd a quarter of
the range), truncated to it: walking speeds cluster around 1.3 m/s in field studies.

Vehicles drive on the right: each starts in the rightmost lane of a random block's
road end, heading in, and follows a random route through the road graph (no block
twice) to a road end of its last block. Cars, vans and buses in 75 : 15 : 10.
"""

from __future__ import annotations

import bisect
import math
from collections.abc import Sequence

import numpy as np
import shapely
from shapely.geometry import Point, Polygon
from shapely.geometry.base import BaseGeometry

from citygen.errors import GenerationError
from citygen.generate.placement import base_of
from citygen.generate.space import GRID, Sampler, free_space, pieces, walkable_ground, zone_polygon
from citygen.generate.task import Endpoints
from citygen.geometry.roads import block_geometry, road_graph
from citygen.seeding import child
from citygen.spec.agents import Person, Vehicle
from citygen.spec.blocks import Block
from citygen.spec.config import AgentsConfig, Range
from citygen.spec.placements import Placement
from citygen.spec.scene import Bounds
from citygen.spec.zones import Zone

#: Vehicle types: (weight, length range m, width range m).
VEHICLE_TYPES = (
    (0.75, (4.2, 4.9), (1.75, 1.95)),  # car
    (0.15, (5.0, 6.2), (1.95, 2.1)),  # van
    (0.10, (10.5, 12.0), (2.5, 2.55)),  # bus
)
GAP = 0.1
"""Space (m) kept between agents' discs, and between them and the robot's, at the start."""
TRIP = 30.0
"""Longest straight-line distance (m) a person's trip is asked to span (less in small scenes)."""


def truncated_normal(rng: np.random.Generator, span: Range) -> float:
    """A draw from a normal centred in ``span`` with sd a quarter of it, truncated to it."""
    lo, hi = span
    if hi <= lo:
        return float(lo)
    for _ in range(16):
        v = float(rng.normal((lo + hi) / 2, (hi - lo) / 4))
        if lo <= v <= hi:
            return v
    return float(np.clip(v, lo, hi))


def place_agents(
    bounds: Bounds,
    zones: Sequence[Zone],
    blocks: Sequence[Block],
    placements: Sequence[Placement],
    cfg: AgentsConfig,
    rng: np.random.Generator,
    *,
    level: float = 1.0,
    ends: Endpoints | None = None,
    robot_radius: float = 0.0,
    seed: int = 0,
    walkable: BaseGeometry | None = None,
    straight: bool = False,
) -> tuple[Person | Vehicle, ...]:
    """People and vehicles of one scene; ``level`` scales the config's counts; ``walkable`` is
    the walkable ground when the caller has it. ``straight`` (a city) keeps each person's
    straight line from start to goal on walkable ground: people walk along a sidewalk, over a
    crosswalk or across a plaza, never over a lawn or through a building."""
    people = _people(
        bounds, zones, placements, cfg, child(rng, 0), level, ends, robot_radius, seed, walkable, straight
    )
    vehicles = math.floor(cfg.vehicles * level + 0.5)
    if vehicles and not blocks:
        raise GenerationError(
            "agents",
            seed,
            f"{vehicles} vehicles need road blocks to drive on (layout 'blocks'); set vehicles = 0",
        )
    cars = _vehicles(zones, blocks, cfg, child(rng, 1), vehicles, seed) if vehicles else []
    return (*people, *cars)


def _people(
    bounds, zones, placements, cfg, rng, level, ends, robot_radius, seed, walkable, straight=False
) -> list[Person]:
    count = math.floor(cfg.people * level + 0.5)
    if count == 0:
        return []
    kinds = ("pedestrian", "cyclist", "scooter")
    weights = np.array([cfg.mix.pedestrian, cfg.mix.cyclist, cfg.mix.scooter], dtype=float)
    radius = {
        "pedestrian": cfg.pedestrian_radius,
        "cyclist": cfg.cyclist_radius,
        "scooter": cfg.scooter_radius,
    }
    speed = {"pedestrian": cfg.pedestrian_speed, "cyclist": cfg.cyclist_speed, "scooter": cfg.scooter_speed}
    ground = walkable if walkable is not None else walkable_ground(zones, (*bounds.min, *bounds.max))
    bases = [base_of(p) for p in placements if not p.is_mesh]
    spaces: dict[str, list] = {}
    taken: list[tuple[float, float, float]] = []
    if ends is not None:
        taken.append((*ends.start, robot_radius))
    trip = min(TRIP, 0.5 * min(bounds.size))
    out = []
    live = [k for k, w in zip(kinds, weights, strict=True) if w > 0]
    mix = _Choice(weights / weights.sum())
    for i in range(count):
        drawn = kinds[mix.draw(rng)]
        # Where the drawn kind finds no room (a cyclist's disc in a narrow lane), the
        # others in the mix are tried, the slimmest first.
        for kind in [drawn, *sorted((k for k in live if k != drawn), key=lambda k: radius[k][1])]:
            if kind not in spaces:
                free = free_space(ground, bases, radius[kind][1])
                if straight:
                    # A city's walkable ground is one network: cut into squares, each piece of
                    # which is quick to triangulate (a straight trip stays in one anyway).
                    spaces[kind] = _Pieces(pieces(_squares(free, bounds, SQUARE))[:MAX_PIECES])
                else:
                    spaces[kind] = _Pieces(pieces(free)[:64])
            r = round(truncated_normal(rng, radius[kind]), 3)
            find = _line_trip if straight else _trip
            pair = find(spaces[kind], rng, trip, r, taken) if spaces[kind] else None
            if pair is not None:
                break
        else:
            raise GenerationError(
                "agents", seed, f"no room on walkable ground for person {i + 1} of {count} (of any kind)"
            )
        v = round(truncated_normal(rng, speed[kind]), 3)
        start, goal = pair
        taken.append((*start, r))
        out.append(Person(id=f"{kind}-{i + 1}", kind=kind, start=start, goal=goal, radius=r, speed=v))
    return out


class _Choice:
    """``rng.choice(len(p), p=p)`` without its per-call checks: the same cumulative weights,
    one uniform draw and the same search, so the same index from the same generator state."""

    def __init__(self, p: np.ndarray):
        cdf = np.asarray(p, dtype=float).cumsum()
        if len(cdf):
            cdf /= cdf[-1]
        self._cdf = cdf.tolist()

    def draw(self, rng: np.random.Generator) -> int:
        return bisect.bisect_right(self._cdf, rng.random())


class _Pieces:
    """The connected pieces of one kind's free space, their areas, and a sampler of each,
    triangulated when the piece is first drawn (a city's largest pieces draw most people)."""

    def __init__(self, polygons: list[Polygon]):
        self.polygons = polygons
        areas = np.array([p.area for p in polygons])
        self.p = areas / areas.sum() if polygons else areas
        self.choice = _Choice(self.p)
        self.samplers: dict[int, Sampler] = {}

    def __len__(self) -> int:
        return len(self.polygons)

    def __getitem__(self, k: int) -> tuple[Polygon, Sampler]:
        if k not in self.samplers:
            shapely.prepare(self.polygons[k])  # many points are tested against it
            self.samplers[k] = Sampler(self.polygons[k])
        return self.polygons[k], self.samplers[k]


def _start(spaces: _Pieces, rng, r, taken):
    """One draw of a start: ``(piece, sampler, point)``, the point None when the piece does
    not cover it or it comes within ``r`` + a taken disc's radius + :data:`GAP` of one."""
    # A point is in a piece where the piece covers it: for a point, ``intersects_xy``.
    piece, sampler = spaces[spaces.choice.draw(rng)]
    start = sampler.point(rng)
    if not shapely.intersects_xy(piece, *start):
        return piece, sampler, None
    if any(math.dist(start, (x, y)) < r + q + GAP for x, y, q in taken):
        return piece, sampler, None
    return piece, sampler, start


def _trip(spaces: _Pieces, rng, trip, r, taken):
    """A start clear of every disc in ``taken`` and a goal in the same piece, as far as
    ``trip`` when the piece allows, else the farthest of a few draws."""
    for _ in range(64):
        piece, sampler, start = _start(spaces, rng, r, taken)
        if start is None:
            continue
        best = None
        for _ in range(16):
            goal = sampler.point(rng)
            if not shapely.intersects_xy(piece, *goal):
                continue
            d = math.dist(start, goal)
            if d >= trip:
                return start, goal
            if best is None or d > best[0]:
                best = (d, goal)
        if best is not None:
            return start, best[1]
    return None


#: Side (m) of the squares a city's free space is cut into, and how many of the pieces people
#: are drawn in.
SQUARE, MAX_PIECES = 100.0, 20_000


def _squares(free: BaseGeometry, bounds: Bounds, side: float):
    """``free`` cut into squares of ``side`` metres from the bounds' minimum corner."""
    (x0, y0), (x1, y1) = bounds.min, bounds.max
    nx_, ny_ = max(1, math.ceil((x1 - x0) / side)), max(1, math.ceil((y1 - y0) / side))
    cells = [
        (x0 + i * side, y0 + j * side, min(x1, x0 + (i + 1) * side), min(y1, y0 + (j + 1) * side))
        for j in range(ny_)
        for i in range(nx_)
    ]
    parts = [shapely.clip_by_rect(free, *c) for c in cells]
    return shapely.GeometryCollection([g for p in parts for g in shapely.get_parts(p)])


#: Shortest trip (m) :func:`_line_trip` takes.
SHORTEST = 5.0


def _line_trip(spaces: _Pieces, rng, trip, r, taken):
    """As :func:`_trip`, with the goal in a straight line of free space from the start: the
    longest of some draws of heading and distance (up to ``trip``) whose line the piece
    covers, at least :data:`SHORTEST` metres."""
    for _ in range(64):
        piece, _, start = _start(spaces, rng, r, taken)
        if start is None:
            continue
        headings = rng.uniform(-math.pi, math.pi, 48)
        reach = trip * rng.uniform(0.3, 1.0, 48)
        ends = np.round(
            np.asarray(start) + reach[:, None] * np.stack([np.cos(headings), np.sin(headings)], 1), 3
        )
        lines = shapely.linestrings(np.stack([np.broadcast_to(start, ends.shape), ends], 1))
        ok = np.flatnonzero(shapely.covers(piece, lines) & (reach >= SHORTEST))
        if len(ok):
            best = ok[int(np.argmax(reach[ok]))]
            return start, (float(ends[best, 0]) + 0.0, float(ends[best, 1]) + 0.0)
    return None


def _vehicles(zones, blocks, cfg, rng, count, seed) -> list[Vehicle]:
    graph = road_graph(blocks)
    by_id = {b.id: b for b in blocks}
    roads = [zone_polygon(z) for z in zones if z.kind in ("roadway", "parking")]
    road = shapely.union_all(roads, grid_size=GRID) if roads else None
    if road is not None:
        shapely.prepare(road)
    order = [b.id for b in blocks]
    out: list[Vehicle] = []
    starts: list[tuple[float, float, float]] = []
    weights = np.array([w for w, _, _ in VEHICLE_TYPES])
    for i in range(count):
        _, length_range, width_range = VEHICLE_TYPES[int(rng.choice(len(weights), p=weights / weights.sum()))]
        length = round(float(rng.uniform(*length_range)), 3)
        width = round(float(rng.uniform(*width_range)), 3)
        for _ in range(64):
            route = _route(graph, order, by_id, rng)
            first, last = by_id[route[0][0]], by_id[route[-1][0]]
            start = _lane_point(first, route[0][1], length, road, inward=True)
            goal = _lane_point(last, route[-1][2], length, road, inward=False)
            if start is None or goal is None:
                continue
            if any(math.dist(start, (x, y)) < (length + q) / 2 + 2.0 for x, y, q in starts):
                continue
            starts.append((*start, length))
            speed = round(float(rng.uniform(*cfg.vehicle_speed)), 3)
            out.append(
                Vehicle(
                    id=f"vehicle-{i + 1}",
                    kind="vehicle",
                    start=start,
                    goal=goal,
                    length=length,
                    width=width,
                    speed=speed,
                    route=tuple(b for b, _, _ in route),
                )
            )
            break
        else:
            raise GenerationError("agents", seed, f"no free lane start for vehicle {i + 1} of {count}")
    return out


def _route(graph, order, by_id, rng) -> list[tuple[str, str, str]]:
    """A random drive: ``(block id, entry socket, exit socket)`` per block, no block twice,
    1 to 8 blocks; a one-way road (``one_way``) only from its ``in`` to its ``out``, and no
    road end of a junction that leads against one."""
    here = order[int(rng.integers(len(order)))]
    arms = [a.socket for a in block_geometry(by_id[here]).arms]
    if getattr(by_id[here], "one_way", None):
        entry = "in"
    else:
        arms = [a for a in arms if _may(graph, by_id, here, a, "in")] or arms
        entry = arms[int(rng.integers(len(arms)))]
    route, seen = [], {here}
    for _ in range(int(rng.integers(1, 9))):
        exits = _exits(graph, by_id, here, entry)
        if not exits:
            break
        onward = []
        for e in exits:
            for nb in sorted(graph.neighbors(here)):
                if graph.edges[here, nb]["sockets"][here] == e and nb not in seen:
                    onward.append((e, nb))
        if not onward:
            route.append((here, entry, exits[int(rng.integers(len(exits)))]))
            return route
        e, nb = onward[int(rng.integers(len(onward)))]
        route.append((here, entry, e))
        entry, here = graph.edges[here, nb]["sockets"][nb], nb
        seen.add(nb)
    exits = _exits(graph, by_id, here, entry) or [entry]
    route.append((here, entry, exits[int(rng.integers(len(exits)))]))
    return route


def _exits(graph, by_id, here: str, entry: str) -> list[str]:
    """The sockets a vehicle that came into block ``here`` by ``entry`` may leave it by: not
    the one it came by, a one-way road's ``out``, none into a one-way road's ``out``."""
    block = by_id[here]
    arms = [a.socket for a in block_geometry(block).arms if a.socket != entry]
    if getattr(block, "one_way", None):
        return [a for a in arms if a == "out"]
    return [a for a in arms if _may(graph, by_id, here, a, "out")]


def _may(graph, by_id, here: str, socket: str, way: str) -> bool:
    """Whether traffic may go ``way`` (``"out"`` of block ``here``, or ``"in"`` to it) at its
    ``socket``: not where a one-way road joined there runs the other way."""
    for nb in graph.neighbors(here):
        sockets = graph.edges[here, nb]["sockets"]
        if sockets[here] == socket and getattr(by_id[nb], "one_way", None):
            return sockets[nb] == ("in" if way == "out" else "out")
    return True


def _lane_point(block, socket, length, road, *, inward: bool):
    """A point in the rightmost lane at the block's ``socket`` end: heading into the block
    when ``inward`` (a start), out of it otherwise (a goal), on roadway (not a crosswalk)."""
    arm = next(a for a in block_geometry(block).arms if a.socket == socket)
    heading = arm.yaw + math.pi if inward else arm.yaw
    fwd = np.array([math.cos(arm.yaw + math.pi), math.sin(arm.yaw + math.pi)])  # into the block
    right = np.array([math.sin(heading), -math.cos(heading)])
    lane = min(block.lane_width, arm.half_width) / 2
    for depth in (length / 2 + 0.5, length / 2 + 3.0, length / 2 + 6.0, length / 2 + 10.0):
        p = np.asarray(arm.position) + fwd * depth + right * lane
        pt = (round(float(p[0]), 3) + 0.0, round(float(p[1]), 3) + 0.0)
        if road is None or road.covers(Point(pt)):
            return pt
    return None
