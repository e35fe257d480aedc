"""Road geometry of the blocks of a scene: a pure function of each block's spec.

A block is laid out from its entry socket (``block.pose``: the centre of the road end,
``yaw`` heading into the block). Roads are two-way: ``lanes`` lanes in each direction
of ``lane_width`` metres, so a road is ``2 * lanes * lane_width`` wide. Every road end
is a *socket*: its pose is the centre of the end, its yaw points out of the block.

Shapes, with ``w`` the half width of the road:

- **straight**: a rectangle ``length`` long.
- **curve**: an annular sector about a centre ``radius`` to the left (``angle > 0``) or
  right of the entry.
- **roundabout**: a ring road of centre-line ``radius`` with ``arms`` straight arms at
  even angles, each reaching :data:`ROUNDABOUT_APPROACH` ``+ w`` beyond the ring's
  outer edge; the central island is a hole of the outline.
- **diverge** / **merge**: a straight main road with a branch leaving (joining) it at
  ``branch_angle``, ``0.35`` (``0.65``) of the way along.
- **intersection** / **t_intersection**: four (three) arms of ``arm_length`` from the
  centre, the corners rounded to ``corner_radius``.
- **junction**: the general junction, its stored ``polygon``, with its ``arms`` (any number
  from three to eight, at any angles) reaching from ``centre``; each arm's crosswalk site
  starts where the arm's road leaves its neighbours' behind.

Socket ids: ``in`` (the entry) and ``out`` for through roads; ``branch`` for diverge
and merge; ``left`` and ``right`` for an intersection; ``side`` for a T; ``arm1`` ...
for a roundabout and a general junction.

>>> from citygen.spec.blocks import Straight, Pose2
>>> road = Straight(id="b0", kind="straight", pose=Pose2(position=(0, 0)), length=20, lanes=1,
...                 lane_width=3.5)
>>> [round(v, 6) + 0.0 for v in block_outline(road).bounds]
[0.0, -3.5, 20.0, 3.5]
>>> [(s.id, s.pose.position) for s in block_sockets(road)]
[('in', (0.0, 0.0)), ('out', (20.0, 0.0))]
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from functools import lru_cache
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from shapely.geometry import Point, Polygon
from shapely.geometry.polygon import orient

from citygen.spec.blocks import (
    Connection,
    Curve,
    Diverge,
    Intersection,
    Junction,
    Merge,
    Pose2,
    Roundabout,
    Socket,
    Straight,
    TIntersection,
)

if TYPE_CHECKING:  # networkx takes 0.17 s to import: only where a road graph is made
    import networkx as nx

#: Length of a roundabout's arms beyond the ring's outer edge, plus the road's half width, in metres.
ROUNDABOUT_APPROACH = 8.0
#: Where a diverging branch leaves, and a merging branch joins, as a fraction of the length.
DIVERGE_AT, MERGE_AT = 0.35, 0.65
#: Radius of the fillets where a branch meets the main road, in metres.
BRANCH_FILLET = 2.0
#: Segments per quarter circle of arcs.
QUAD_SEGS = 8


def wrap(yaw: float) -> float:
    """An angle in ``(-pi, pi]``."""
    return math.pi - (math.pi - yaw) % (2 * math.pi)


@dataclass(frozen=True)
class Arm:
    """A road end of a block."""

    socket: str
    position: tuple[float, float]
    yaw: float
    """Pointing out of the block, radians."""
    half_width: float
    """Half the road's width at this end, in metres."""
    lane_width: float = 0.0
    """Width of one lane at this end, in metres, where it is not the block's (a general
    junction's arm); 0: the block's."""


@dataclass(frozen=True)
class CrossingSite:
    """Where a crosswalk may cross a road: at ``offset`` metres from ``origin`` along ``yaw``."""

    origin: tuple[float, float]
    yaw: float
    half_width: float
    offset: float
    room: float
    """Length of road available for the crosswalk beyond ``offset``, in metres."""


@dataclass(frozen=True)
class BlockGeometry:
    outline: Polygon
    """The road surface: the roadway of this block."""
    arms: tuple[Arm, ...]
    crossings: tuple[CrossingSite, ...]
    island: Polygon | None = None
    """A roundabout's central island."""
    centre: tuple[float, float] | None = None
    """Where a junction's arms meet (intersections, T's and general junctions)."""


def _dir(yaw: float) -> np.ndarray:
    return np.array([math.cos(yaw), math.sin(yaw)])


def _rect(start: np.ndarray, yaw: float, length: float, half_width: float) -> Polygon:
    d, n = _dir(yaw), _dir(yaw + math.pi / 2)
    end = start + length * d
    return Polygon(
        [start - half_width * n, end - half_width * n, end + half_width * n, start + half_width * n]
    )


def _pt(p: np.ndarray) -> tuple[float, float]:
    return (float(p[0]), float(p[1]))


def _close(shape, radius: float):
    """Morphological closing: concave corners rounded to ``radius``, convex ones kept."""
    if radius <= 0:
        return shape
    return shape.buffer(radius, quad_segs=QUAD_SEGS).buffer(-radius, quad_segs=QUAD_SEGS)


def _clean(shape) -> Polygon:
    if not shape.is_valid:
        shape = shapely.make_valid(shape)
    if shape.geom_type != "Polygon":
        parts = [g for g in getattr(shape, "geoms", [shape]) if g.geom_type == "Polygon" and g.area > 0]
        shape = max(parts, key=lambda g: g.area) if parts else Polygon()
    return shape


def half_width(block) -> float:
    """Half the width of the block's main road, in metres."""
    return block.lanes * block.lane_width


def branch_length(block: Diverge | Merge) -> float:
    """Length of a diverge's or merge's branch road, in metres: long enough to leave the
    main road behind before its socket."""
    w, wb = half_width(block), block.branch_lanes * block.lane_width
    return max(0.5 * block.length, (w + wb + 4.0) / max(abs(math.sin(block.branch_angle)), 0.2) + 4.0)


@lru_cache(maxsize=65_536)
def block_geometry(block) -> BlockGeometry:
    """The outline, road ends and crosswalk sites of one block (cached: blocks are frozen),
    laid out by its kind's builder (:data:`BLOCK_KINDS`)."""
    return block_kind(block).lay_out(block)


def _entry(block) -> tuple[np.ndarray, float, float, float, Arm]:
    """The block's entry point, heading, half width, the heading back out, and its entry arm."""
    p0 = np.array(block.pose.position, dtype=float)
    yaw = block.pose.yaw
    w = half_width(block)
    back = wrap(yaw + math.pi)
    return p0, yaw, w, back, Arm("in", _pt(p0), back, w)


def _straight(block: Straight) -> BlockGeometry:
    p0, yaw, w, _, entry = _entry(block)
    end = p0 + block.length * _dir(yaw)
    arms = (entry, Arm("out", _pt(end), wrap(yaw), w))
    crossings = (CrossingSite(_pt(p0), yaw, w, 0.0, block.length),)
    return BlockGeometry(_rect(p0, yaw, block.length, w), arms, crossings)


def _curve(block: Curve) -> BlockGeometry:
    p0, yaw, w, _, entry = _entry(block)
    side = 1.0 if block.angle >= 0 else -1.0
    centre = p0 + side * block.radius * _dir(yaw + math.pi / 2)
    n = max(2, math.ceil(abs(block.angle) / (math.pi / (2 * QUAD_SEGS))) + 1)
    headings = yaw + np.linspace(0.0, block.angle, n)
    # Points on the centre line, and the road's left and right edges.
    normals = np.stack([-np.sin(headings), np.cos(headings)], axis=1)
    centre_line = centre - side * block.radius * normals
    left, right = centre_line + w * normals, centre_line - w * normals
    outline = _clean(Polygon(np.concatenate([right, left[::-1]])))
    arms = (entry, Arm("out", _pt(centre_line[-1]), wrap(yaw + block.angle), w))
    return BlockGeometry(outline, arms, ())


def _roundabout(block: Roundabout) -> BlockGeometry:
    p0, yaw, w, back, entry = _entry(block)
    reach = block.radius + w + ROUNDABOUT_APPROACH
    centre = p0 + reach * _dir(yaw)
    ring = Point(*centre).buffer(block.radius + w, quad_segs=4 * QUAD_SEGS)
    island = None
    if block.radius - w > 0.5:
        island = Point(*centre).buffer(block.radius - w, quad_segs=4 * QUAD_SEGS)
        ring = ring.difference(island)
    parts, arms, crossings = [ring], [], []
    for i in range(block.arms):
        out = wrap(back + i * 2 * math.pi / block.arms)
        start = centre + block.radius * _dir(out)
        parts.append(_rect(start, out, reach - block.radius, w))
        end = centre + reach * _dir(out)
        arms.append(entry if i == 0 else Arm(f"arm{i}", _pt(end), out, w))
        edge = block.radius + w
        crossings.append(CrossingSite(_pt(centre), out, w, edge + 1.0, reach - edge - 1.0))
    outline = _clean(shapely.union_all(parts))
    return BlockGeometry(outline, tuple(arms), tuple(crossings), island)


def _branching(block: Diverge | Merge) -> BlockGeometry:
    """A diverge's branch leaves at :data:`DIVERGE_AT` of the length, a merge's joins at
    :data:`MERGE_AT`."""
    p0, yaw, w, _, entry = _entry(block)
    main = _rect(p0, yaw, block.length, w)
    wb = block.branch_lanes * block.lane_width
    lb = branch_length(block)
    end = p0 + block.length * _dir(yaw)
    if isinstance(block, Diverge):
        joint = p0 + DIVERGE_AT * block.length * _dir(yaw)
        out = wrap(yaw + block.branch_angle)
    else:
        joint = p0 + MERGE_AT * block.length * _dir(yaw)
        out = wrap(yaw - block.branch_angle + math.pi)
    branch = _rect(joint, out, lb, wb)
    tip = joint + lb * _dir(out)
    outline = _clean(_close(main.union(branch), BRANCH_FILLET))
    arms = (entry, Arm("out", _pt(end), wrap(yaw), w), Arm("branch", _pt(tip), out, wb))
    return BlockGeometry(outline, arms, ())


def _junction(block: Intersection | TIntersection) -> BlockGeometry:
    """Arms of ``arm_length`` from the centre: four for an intersection, three for a T."""
    p0, yaw, w, back, entry = _entry(block)
    a = block.arm_length
    centre = p0 + a * _dir(yaw)
    names = [("in", back), ("out", wrap(yaw))]
    if isinstance(block, Intersection):
        names += [("left", wrap(yaw + math.pi / 2)), ("right", wrap(yaw - math.pi / 2))]
    else:
        names.append(("side", wrap(yaw + (1 if block.side == "left" else -1) * math.pi / 2)))
    parts, arms, crossings = [], [], []
    for name, out in names:
        parts.append(_rect(centre - w * _dir(out), out, a + w, w))
        arms.append(entry if name == "in" else Arm(name, _pt(centre + a * _dir(out)), out, w))
        offset = w + block.corner_radius + 0.5
        crossings.append(CrossingSite(_pt(centre), out, w, offset, a - offset))
    outline = _clean(_close(shapely.union_all(parts), block.corner_radius))
    return BlockGeometry(outline, tuple(arms), tuple(crossings), centre=_pt(centre))


def junction_sockets(count: int) -> tuple[str, ...]:
    """The socket ids of a general junction of ``count`` arms: ``in``, ``arm1``, ``arm2`` ..."""
    return ("in", *(f"arm{i}" for i in range(1, count)))


def general_junction(bid: str, centre, arms, corner_radius: float = 3.0) -> Junction:
    """A general junction block ``bid`` whose ``arms`` (:class:`~citygen.spec.blocks.JunctionArm`
    or their fields as dicts) meet at ``centre``: its pose on the first arm's road end heading
    in, its ``lanes`` and ``lane_width`` its widest arm's, its polygon the arms' roads (each as
    wide as its lanes, from behind the centre to its end) with the corners between them
    rounded to ``corner_radius``; its sockets laid out.

    >>> j = general_junction("j", (0.0, 0.0), [{"yaw": 0.0, "length": 10.0},
    ...     {"yaw": 2.6, "length": 10.0}, {"yaw": -2.6, "length": 10.0}])
    >>> j.kind, [s.id for s in j.sockets], j.pose.position, round(j.pose.yaw, 4)
    ('junction', ['in', 'arm1', 'arm2'], (10.0, 0.0), 3.1416)
    """
    block = Junction.model_validate(
        {
            "id": bid,
            "kind": "junction",
            "pose": {"position": (0.0, 0.0)},
            "centre": tuple(float(v) for v in centre),
            "arms": [a if isinstance(a, dict) else a.model_dump() for a in arms],
            "polygon": ((0.0, 0.0), (1.0, 0.0), (0.0, 1.0)),
        }
    )
    c = np.array(block.centre, dtype=float)
    parts = []
    for arm in block.arms:
        w = arm.lanes * arm.lane_width
        parts.append(_rect(c - w * _dir(arm.yaw), arm.yaw, arm.length + w, w))
    shape = _clean(_close(shapely.union_all(parts), corner_radius)).simplify(0.01)
    ring = orient(Polygon(shape.exterior), 1.0).exterior.coords[:-1]
    widest = max(block.arms, key=lambda a: a.lanes * a.lane_width)
    first = block.arms[0]
    entry = c + first.length * _dir(first.yaw)
    block = block.model_copy(
        update={
            "pose": Pose2(position=_pt(entry), yaw=wrap(first.yaw + math.pi)),
            "lanes": widest.lanes,
            "lane_width": widest.lane_width,
        }
    )
    block = Junction.model_validate({**block.model_dump(), "polygon": [_pt(p) for p in ring]})
    return block.model_copy(update={"sockets": block_sockets(block)})


def _general(block: Junction) -> BlockGeometry:
    """A general junction: its polygon, and its arms from the centre. An arm's crosswalk site
    begins half a metre past the last point where its road (as wide as its lanes) meets
    another arm's."""
    c = np.array(block.centre, dtype=float)
    roads = [_rect(c, arm.yaw, arm.length, arm.lanes * arm.lane_width) for arm in block.arms]
    arms, crossings = [], []
    for k, (name, arm) in enumerate(zip(junction_sockets(len(block.arms)), block.arms, strict=True)):
        w = arm.lanes * arm.lane_width
        d = _dir(arm.yaw)
        others = shapely.union_all([r for j, r in enumerate(roads) if j != k])
        shared = roads[k].intersection(others)
        reach = float(np.max(shapely.get_coordinates(shared) @ d - c @ d)) if not shared.is_empty else w
        offset = min(max(reach, 0.0) + 0.5, arm.length)
        arms.append(Arm(name, _pt(c + arm.length * d), wrap(arm.yaw), w, arm.lane_width))
        crossings.append(CrossingSite(_pt(c), wrap(arm.yaw), w, offset, arm.length - offset))
    outline = _clean(Polygon(block.polygon))
    return BlockGeometry(outline, tuple(arms), tuple(crossings), centre=_pt(c))


@dataclass(frozen=True)
class BlockKind:
    """One road block class and what the readers of a road network need of it."""

    model: type
    """The spec's block class."""
    lay_out: Callable[[Any], BlockGeometry]
    """Its outline, road ends and crosswalk sites, from its entry socket."""
    signalised: bool = False
    """A junction that gets traffic signals (:mod:`citygen.generate.signals`)."""
    midblock: bool = False
    """A road between junctions: its crosswalk site is a mid-block crossing, placed by chance
    and centred in the site's room (:func:`citygen.generate.ground.street_bands`)."""
    sampled: bool = True
    """Drawn by the blocks layout (a weight of ``BlockWeights``); a general junction is only
    written from a map."""

    @property
    def name(self) -> str:
        """The kind's name in the spec (its ``kind`` field)."""
        return self.model.model_fields["kind"].annotation.__args__[0]


#: Every block kind, by its spec class, in the spec's order (:data:`~citygen.spec.blocks.BLOCK_TYPES`).
BLOCK_KINDS: dict[type, BlockKind] = {
    Straight: BlockKind(Straight, _straight, midblock=True),
    Curve: BlockKind(Curve, _curve),
    Roundabout: BlockKind(Roundabout, _roundabout),
    Diverge: BlockKind(Diverge, _branching),
    Merge: BlockKind(Merge, _branching),
    Intersection: BlockKind(Intersection, _junction, signalised=True),
    TIntersection: BlockKind(TIntersection, _junction, signalised=True),
    Junction: BlockKind(Junction, _general, signalised=True, sampled=False),
}


def block_kind(block) -> BlockKind:
    """The registry's entry for ``block``'s class.

    >>> block_kind(Straight(id="b0", kind="straight", pose=Pose2(position=(0, 0)), length=5)).name
    'straight'
    """
    try:
        return BLOCK_KINDS[type(block)]
    except KeyError:
        raise TypeError(f"not a block: {block!r}") from None


def block_outline(block) -> Polygon:
    """The road surface of one block, a shapely polygon in metres."""
    return block_geometry(block).outline


def block_sockets(block) -> tuple[Socket, ...]:
    """The sockets of a block as its builder lays them out (what ``block.sockets`` stores)."""
    return tuple(
        Socket(id=a.socket, pose=Pose2(position=a.position, yaw=a.yaw)) for a in block_geometry(block).arms
    )


def with_connections(block, links: dict[str, tuple[str, str]]):
    """``block`` with its sockets (:func:`block_sockets`) and a connection for each socket
    ``links`` joins (``socket id -> (block id, socket id)``), in the sockets' order."""
    sockets = block_sockets(block)
    connections = tuple(
        Connection(socket=s.id, block=links[s.id][0], to_socket=links[s.id][1])
        for s in sockets
        if s.id in links
    )
    return block.model_copy(update={"sockets": sockets, "connections": connections})


def road_graph(blocks) -> nx.Graph:
    """The road network: blocks as nodes (with their ``kind``), connections as edges (with
    the two sockets they join). Nodes and edges are added in the blocks' order."""
    import networkx as nx

    graph = nx.Graph()
    for block in blocks:
        graph.add_node(block.id, kind=block.kind)
    for block in blocks:
        for c in block.connections:
            if c.block in graph and not graph.has_edge(block.id, c.block):
                graph.add_edge(block.id, c.block, sockets={block.id: c.socket, c.block: c.to_socket})
    return graph
