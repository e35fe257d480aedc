"""Stage 1 for ``layout = "city"``: a city's street plan, written in road blocks.

Streets run along two families of straight lines, at jittered spacings
(``city.street_spacing``) from an outer ring ``city.edge_inset`` inside the scene's edge:
a perturbed grid. Each line is an arterial (``city.arterial_lanes`` lanes each way) with
probability ``city.arterial_share``, else a local street. Where lines cross is a junction;
between neighbouring junctions a street segment. ``city.grid_irregularity`` of the interior
local segments are left out, each joining two city blocks into one (never more than two,
so city blocks stay 80-250 m), and never leaving a dead end or a disconnected network.

The plan is then written in the vocabulary of road blocks (:mod:`citygen.geometry.roads`):

- a junction of four streets is an ``intersection``, or a ``roundabout``
  (``city.roundabout_share``, never two side by side);
- a junction of three (the outer ring, a left-out segment) is a ``t_intersection``;
- a corner of the outer ring is a 90-degree ``curve`` of radius ``city.corner_radius``;
- a segment is a ``straight`` between the two junctions' arms.

A junction's lanes are those of its widest street. Blocks are numbered junctions first (row
by row), then segments; every socket that meets another is connected both ways.
:func:`plan_city` also returns the lines where the ground stage cuts lots (street centre
lines, the back of the frontage lots, lot widths along the street) and what each city block
is: ``downtown`` (continuous street walls), ``residential`` (front yards, detached
buildings), ``park`` or ``plaza``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from citygen.errors import GenerationError
from citygen.geometry.roads import block_geometry, with_connections
from citygen.seeding import uniform
from citygen.spec.blocks import Curve, Intersection, Pose2, Roundabout, Straight, TIntersection
from citygen.spec.config import BlocksConfig, CityConfig, GroundConfig
from citygen.spec.scene import Bounds

#: Directions of a junction's arms: east, north, west, south.
DIRECTIONS = ((1, 0), (0, 1), (-1, 0), (0, -1))
#: Shortest straight segment between two junctions, in metres.
MIN_SEGMENT = 6.0


@dataclass(frozen=True)
class CityPlan:
    """A city's road blocks and how its ground is divided into lots."""

    blocks: tuple
    lines: tuple[tuple[float, ...], tuple[float, ...]]
    """Street centre lines: the x of the streets along y, the y of the streets along x."""
    cuts: tuple[tuple[float, ...], tuple[float, ...]]
    """Lot boundaries along x and along y, from the scene's edge to the other (street centre
    lines among them)."""
    districts: dict[tuple[int, int], str]
    """What city block ``(i, j)`` is (``i`` from -1 west of the first line to ``len(xs) - 1``)."""

    courtyards: dict[tuple[int, int], str]
    """What the lots behind a downtown city block's frontage are: ``plaza``, ``vegetation``
    (a garden) or ``parking``."""

    def cell(self, x: float, y: float) -> tuple[int, int]:
        """The city block ``(i, j)`` the point is in."""
        return int(np.searchsorted(self.lines[0], x)) - 1, int(np.searchsorted(self.lines[1], y)) - 1


def _lines(lo: float, hi: float, cfg: CityConfig, rng: np.random.Generator) -> list[float]:
    """Street centre lines from the inset at ``lo`` to the inset before ``hi``."""
    a, b = lo + uniform(rng, cfg.edge_inset), hi - uniform(rng, cfg.edge_inset)
    mean = (cfg.street_spacing[0] + cfg.street_spacing[1]) / 2
    n = max(1, round((b - a) / mean))
    gaps = np.array([uniform(rng, cfg.street_spacing) for _ in range(n)])
    gaps *= (b - a) / gaps.sum()
    return [round(v, 3) for v in (a + np.concatenate([[0.0], np.cumsum(gaps)])).tolist()]


def _cuts(
    lines: list[float], hi: float, reach: list[float], depth: float, cfg: CityConfig, rng
) -> list[float]:
    """Lot boundaries along one axis: the scene's edges, every street's centre line, the back
    of the frontage lots ``depth`` behind each street's sidewalk (``reach`` from its centre
    line), and lot widths in between."""
    cuts = [0.0]
    for k, x in enumerate(lines):
        cuts.append(x)
        if k + 1 == len(lines):
            break
        a, b = x + reach[k] + depth, lines[k + 1] - reach[k + 1] - depth
        if b - a < cfg.lot_width[0]:
            cuts.append(round((x + lines[k + 1]) / 2, 3))
            continue
        cuts.append(a)
        n = max(1, round((b - a) / ((cfg.lot_width[0] + cfg.lot_width[1]) / 2)))
        cuts += [a + (b - a) * m / n for m in range(1, n)]
        cuts.append(b)
    cuts.append(hi)
    return sorted({round(v, 3) for v in cuts})


def plan_city(
    bounds: Bounds,
    cfg: CityConfig,
    blocks_cfg: BlocksConfig,
    ground: GroundConfig,
    rng: np.random.Generator,
    *,
    seed: int | None = None,
) -> CityPlan:
    """The street plan of a city filling ``bounds`` (see the module docstring).

    >>> from collections import Counter
    >>> from citygen.seeding import stage_rng
    >>> from citygen.spec.config import GeneratorConfig
    >>> cfg = GeneratorConfig(size=(600.0, 600.0), layout="city")
    >>> bounds = Bounds(min=(0, 0), max=cfg.size)
    >>> plan = plan_city(bounds, cfg.city, cfg.blocks, cfg.ground, stage_rng(1, "blocks"))
    >>> sorted(Counter(b.kind for b in plan.blocks).items())
    [('curve', 4), ('intersection', 6), ('roundabout', 1), ('straight', 39), ('t_intersection', 14)]
    >>> len(plan.lines[0]), plan.districts[plan.cell(300.0, 300.0)]
    (5, 'downtown')
    """
    (x0, y0), (x1, y1) = bounds.min, bounds.max
    if min(x1 - x0, y1 - y0) < 2 * cfg.edge_inset[1] + cfg.street_spacing[0]:
        raise GenerationError(
            "blocks", seed, f"a {x1 - x0:g} m x {y1 - y0:g} m scene is too small for a city's streets"
        )
    xs, ys = _lines(x0, x1, cfg, rng), _lines(y0, y1, cfg, rng)
    lane_width = round(uniform(rng, blocks_cfg.lane_width), 4)
    arterial = [[bool(rng.random() < cfg.arterial_share) for _ in line] for line in (xs, ys)]
    lanes = [[cfg.arterial_lanes if a else cfg.local_lanes for a in axis] for axis in arterial]
    nx_, ny_ = len(xs), len(ys)

    # The grid: nodes (i, j), edges along x on line y_j and along y on line x_i.
    import networkx as nx  # 0.17 s to import: only where a city's street grid is made

    graph = nx.Graph()
    graph.add_nodes_from((i, j) for j in range(ny_) for i in range(nx_))
    for j in range(ny_):
        for i in range(nx_):
            if i + 1 < nx_:
                graph.add_edge((i, j), (i + 1, j), lanes=lanes[1][j], arterial=arterial[1][j])
            if j + 1 < ny_:
                graph.add_edge((i, j), (i, j + 1), lanes=lanes[0][i], arterial=arterial[0][i])
    # Leave out some interior local segments: two city blocks become one.
    merged = {(i, j): (i, j) for i in range(-1, nx_) for j in range(-1, ny_)}

    def root(c):
        while merged[c] != c:
            c = merged[c]
        return c

    sizes: dict[tuple[int, int], int] = {}
    interior = [
        (a, b)
        for a, b in sorted(graph.edges)
        if not graph.edges[a, b]["arterial"]
        and min(a[0], b[0]) > 0
        and max(a[0], b[0]) < nx_ - 1
        and min(a[1], b[1]) > 0
        and max(a[1], b[1]) < ny_ - 1
    ]
    target = round(cfg.grid_irregularity * len(interior))
    dropped = 0
    for k in rng.permutation(len(interior)).tolist():
        if dropped >= target:
            break
        a, b = interior[k]
        if graph.degree(a) < 4 or graph.degree(b) < 4:
            continue
        # The two city blocks on either side of the segment.
        if a[1] == b[1]:  # along x: blocks below and above
            i = min(a[0], b[0])
            left, right = (i, a[1] - 1), (i, a[1])
        else:
            j = min(a[1], b[1])
            left, right = (a[0] - 1, j), (a[0], j)
        ra, rb = root(left), root(right)
        if sizes.get(ra, 1) + sizes.get(rb, 1) > 2:
            continue
        graph.remove_edge(a, b)
        if not nx.is_connected(graph):
            graph.add_edge(a, b, lanes=lanes[0][a[0]] if a[0] == b[0] else lanes[1][a[1]], arterial=False)
            continue
        merged[rb] = ra
        sizes[ra] = sizes.get(ra, 1) + sizes.get(rb, 1)
        dropped += 1

    # Junction kinds and their reach (centre to socket) along their arms.
    kinds: dict[tuple[int, int], str] = {}
    for node in sorted(graph.nodes):
        kinds[node] = {4: "intersection", 3: "t_intersection", 2: "curve"}[graph.degree(node)]
    fours = [n for n in sorted(graph.nodes) if kinds[n] == "intersection"]
    for k in rng.permutation(len(fours)).tolist():
        node = fours[k]
        if rng.random() < cfg.roundabout_share and all(kinds[m] != "roundabout" for m in graph[node]):
            kinds[node] = "roundabout"

    def arms(node) -> list[tuple[int, int]]:
        i, j = node
        return [d for d in DIRECTIONS if graph.has_edge(node, (i + d[0], j + d[1]))]

    junctions: dict[tuple[int, int], object] = {}
    reach: dict[tuple[int, int], float] = {}
    for node in sorted(graph.nodes, key=lambda n: (n[1], n[0])):
        i, j = node
        centre = np.array([xs[i], ys[j]])
        n_lanes = max(graph.edges[node, m]["lanes"] for m in graph[node])
        w = n_lanes * lane_width
        common = {"id": f"b{len(junctions)}", "lanes": n_lanes, "lane_width": lane_width}
        kind = kinds[node]
        here = arms(node)
        if kind == "curve":
            r = max(uniform(rng, cfg.corner_radius), w + 3.0)
            d1, d2 = here
            start = centre + r * np.array(d1)
            yaw = math.atan2(-d1[1], -d1[0])
            turn = math.remainder(math.atan2(d2[1], d2[0]) - yaw, 2 * math.pi)
            block = Curve(**common, kind="curve", pose=_pose(start, yaw), radius=r, angle=turn)
            reach[node] = r
        elif kind == "roundabout":
            radius = max(uniform(rng, blocks_cfg.roundabout_radius), w + 4.0)
            reach[node] = radius + w + 8.0  # roads.ROUNDABOUT_APPROACH
            block = Roundabout(
                **common,
                kind="roundabout",
                pose=_pose(centre - [reach[node], 0.0], 0.0),
                radius=radius,
                arms=4,
            )
        else:
            corner = uniform(rng, (4.0, 8.0))
            a = w + corner + uniform(rng, (7.0, 10.0))
            reach[node] = a
            if kind == "intersection":
                block = Intersection(
                    **common,
                    kind="intersection",
                    pose=_pose(centre - [a, 0.0], 0.0),
                    arm_length=a,
                    corner_radius=corner,
                )
            else:
                (missing,) = [d for d in DIRECTIONS if d not in here]
                yaw = math.atan2(missing[1], missing[0]) + math.pi / 2
                start = centre - a * np.array([math.cos(yaw), math.sin(yaw)])
                block = TIntersection(
                    **common,
                    kind="t_intersection",
                    pose=_pose(start, yaw),
                    arm_length=a,
                    corner_radius=corner,
                    side="left",
                )
        junctions[node] = block

    # Segments between junctions.
    links: dict[str, dict[str, tuple[str, str]]] = {b.id: {} for b in junctions.values()}
    segments = []
    for a, b in sorted(graph.edges, key=lambda e: (e[0][1], e[0][0], e[1][1], e[1][0])):
        d = (b[0] - a[0], b[1] - a[1])
        pa, pb = np.array([xs[a[0]], ys[a[1]]]), np.array([xs[b[0]], ys[b[1]]])
        start = pa + reach[a] * np.array(d)
        length = float(np.linalg.norm(pb - reach[b] * np.array(d) - start))
        if length < MIN_SEGMENT:
            raise GenerationError(
                "blocks",
                seed,
                f"streets at {tuple(pa)} and {tuple(pb)} are too close; widen city.street_spacing",
            )
        block = Straight(
            id=f"b{len(junctions) + len(segments)}",
            kind="straight",
            pose=_pose(start, math.atan2(d[1], d[0])),
            lanes=graph.edges[a, b]["lanes"],
            lane_width=lane_width,
            length=length,
        )
        segments.append(block)
        links[block.id] = {
            "in": (junctions[a].id, _socket(junctions[a], d)),
            "out": (junctions[b].id, _socket(junctions[b], (-d[0], -d[1]))),
        }
        links[junctions[a].id][_socket(junctions[a], d)] = (block.id, "in")
        links[junctions[b].id][_socket(junctions[b], (-d[0], -d[1]))] = (block.id, "out")

    blocks = [with_connections(block, links[block.id]) for block in [*junctions.values(), *segments]]

    # Lot cuts: each street's reach is its half width, a curb and the widest sidewalk.
    side = ground.curb_width[1] + ground.sidewalk_width[1] + cfg.residential_setback[1]
    depth = uniform(rng, cfg.lot_depth)
    cuts = tuple(
        tuple(_cuts(line, hi, [n * lane_width + side for n in axis_lanes], depth, cfg, rng))
        for line, hi, axis_lanes in ((xs, x1, lanes[0]), (ys, y1, lanes[1]))
    )
    districts, courtyards = _districts(bounds, xs, ys, merged, root, cfg, rng)
    return CityPlan(tuple(blocks), (tuple(xs), tuple(ys)), cuts, districts, courtyards)


def _districts(bounds: Bounds, xs, ys, merged, root, cfg: CityConfig, rng):
    """What each city block is, and its courtyards; joined city blocks are one thing."""
    (x0, y0), (x1, y1) = bounds.min, bounds.max
    cx, cy, half = (x0 + x1) / 2, (y0 + y1) / 2, min(x1 - x0, y1 - y0) / 2
    ex, ey = [x0, *xs, x1], [y0, *ys, y1]
    out: dict[tuple[int, int], str] = {}
    yards: dict[tuple[int, int], str] = {}
    for cell in sorted(merged, key=lambda c: (c[1], c[0])):
        i, j = cell
        home = root(cell)
        if home != cell:
            continue
        mx, my = (ex[i + 1] + ex[i + 2]) / 2, (ey[j + 1] + ey[j + 2]) / 2
        edge = i in (-1, len(xs) - 1) or j in (-1, len(ys) - 1)
        draw = rng.random()
        if not edge and draw < cfg.park_share:
            kind = "park"
        elif not edge and draw < cfg.park_share + cfg.plaza_share:
            kind = "plaza"
        elif math.hypot(mx - cx, my - cy) <= cfg.downtown_radius * half:
            kind = "downtown"
        else:
            kind = "residential"
        out[cell] = kind
        yard = rng.random()
        yards[cell] = "parking" if yard < cfg.parking_share else ("plaza" if yard < 0.5 else "vegetation")
    for cell in merged:
        out[cell], yards[cell] = out[root(cell)], yards[root(cell)]
    return out, yards


def _pose(position, yaw: float) -> Pose2:
    return Pose2(position=(float(position[0]), float(position[1])), yaw=math.remainder(yaw, 2 * math.pi))


def _socket(block, direction: tuple[int, int]) -> str:
    """The id of ``block``'s socket whose road leaves towards ``direction``."""
    want = math.atan2(direction[1], direction[0])
    for arm in block_geometry(block).arms:
        if abs(math.remainder(arm.yaw - want, 2 * math.pi)) < 1e-3:
            return arm.socket
    raise ValueError(f"{block.id} has no arm towards {direction}")
