"""Stage 1 for ``layout = "osm"``: the streets an extract maps, as a street graph and road blocks.

Every ``highway=*`` way a vehicle drives on (motorway to service road; not footways, paths,
cycleways or steps, which :mod:`.ground` lays as walkways) is a :class:`Street` with its width:
the ``width`` tag, else its lanes (``lanes``, else the class's, one for a one-way minor street)
times the class's lane width (:data:`CLASSES`); and its sidewalks: ``sidewalk`` /
``sidewalk:both|left|right`` (``separate`` and ``no`` mean none beside the road), else the
class's default. Tunnels are left out.

The street graph's nodes are the ways' ends and the nodes several ways share; a *junction* is a
node where three or more street edges meet. Written in road blocks (:mod:`citygen.spec.blocks`):

- a junction of four streets meeting within :data:`FIT_DEG` of right angles is an
  ``intersection``, of three (two roughly opposite, one across) a ``t_intersection``, centred
  on the mapped node and turned to its streets; any other junction (five ways, a sharp Y,
  arms off right angles, two close junctions of a dual carriageway) is a general ``junction``
  on the node, an arm along each street, as far as the street needs to leave its neighbours
  behind (:func:`_general`); so every junction node of the graph has a block (``j-n12``:
  node 12);
- every edge is cut where it leaves the box and at its junctions' arms, and each straight piece
  of its polyline is a ``straight`` (``s-w45-3``: way 45, piece 3), joined to the next, to the
  junction at its end, and to the edge it continues at a node of two edges; an edge too short
  for a piece between two junctions joins their blocks to each other.

A street gives way to the furniture and trees the map puts beside it (:func:`give_way`): an
edge whose drawn roadway or curb would reach a mapped object's point (and the room its slimmest
variant needs) is drawn narrower, down to :data:`MIN_LANE` a lane, so the object stands on the
sidewalk on its point; an object the floor cannot clear (mapped in the middle of the road)
does not narrow it.

A block's ``lanes`` are per direction and its ``lane_width`` what makes the mapped width. A
one-way street (:func:`one_way`: ``oneway=yes/true/1/-1/reverse``, a roundabout's ring) is
written as ``one_way`` straights laid in its driving direction (``in`` where traffic comes
from), each as wide as the mapped street.
"""

from __future__ import annotations

import itertools
import math
import re
from collections import defaultdict
from dataclasses import dataclass, replace

import numpy as np
import shapely
from shapely.geometry import LineString, box
from shapely.ops import substring

from citygen.geometry.roads import block_geometry, block_sockets, general_junction, with_connections
from citygen.spec import limits
from citygen.spec.blocks import Intersection, Pose2, Straight, TIntersection
from citygen.spec.blocks import Junction as JunctionBlock

#: Street classes: (lanes both ways together, lane width m, sidewalks by default).
CLASSES = {
    "motorway": (4, 3.5, False),
    "trunk": (4, 3.5, False),
    "primary": (2, 3.5, True),
    "secondary": (2, 3.25, True),
    "tertiary": (2, 3.25, True),
    "unclassified": (2, 3.0, True),
    "residential": (2, 3.0, True),
    "living_street": (2, 2.75, True),
    "service": (1, 3.5, False),
    "road": (2, 3.0, True),
    "busway": (2, 3.5, False),
}
for _name in ("motorway", "trunk", "primary", "secondary", "tertiary"):
    CLASSES[f"{_name}_link"] = (1, 3.5, False)
#: Sidewalk width beside a street (m) when no ``sidewalk:width`` says: major and minor streets.
SIDEWALK_WIDTH = {"primary": 3.5, "secondary": 3.0, "trunk": 3.0}
DEFAULT_SIDEWALK = 2.5
#: Curb width (m) between the roadway and the sidewalk.
CURB = 0.15
#: Streets meeting within this angle (degrees) of a block's arms make an intersection or a T.
FIT_DEG = 20.0
#: Curb radius at a junction block's corners, in metres.
CORNER = 3.0
#: Narrowest lane (m) a street is drawn with where it gives way to a mapped object.
MIN_LANE = 2.5
#: Room (m) kept between a mapped object's slimmest base and the curb.
GAP = 0.05
#: A street is narrowed for an object it can bring this near (m) to clearing: the object's
#: own nudge (:data:`~.objects.NUDGE`) does the rest.
REACH = 0.4
#: A junction block's arms reach this far past the widest street's edge and corner, in metres
#: (room for a crosswalk), unless a neighbouring junction is nearer.
ARM_ROOM = 6.0


@dataclass(frozen=True)
class Street:
    """One street way in scene metres: its OSM id, tags, polyline and node ids, and its cross-section."""

    id: str
    tags: dict
    points: np.ndarray
    nodes: tuple[int, ...]
    width: float
    """Carriageway width, in metres."""
    lanes: int
    """Lanes per direction as a block holds them (1-4)."""
    sidewalks: tuple[bool, bool]
    """Sidewalk on the (left, right) of the way's direction."""
    sidewalk_width: float
    oneway: int = 0
    """1: a one-way street driven along the way's direction (``oneway=yes/true/1``,
    ``junction=roundabout``); -1: against it (``oneway=-1/reverse``); 0: both ways."""

    @property
    def half(self) -> float:
        return self.width / 2

    @property
    def lane_width(self) -> float:
        return float(np.clip(self.width / (2 * self.lanes), 2.0, 5.0))


def _metres(text: str | None) -> float | None:
    """A length tag in metres (``7``, ``7.5 m``), or None when it says something else."""
    if not text:
        return None
    match = re.fullmatch(r"\s*([0-9]+(?:\.[0-9]+)?)\s*(m)?\s*", text)
    return float(match.group(1)) if match else None


def _sidewalks(tags: dict, default: bool) -> tuple[bool, bool]:
    both = tags.get("sidewalk:both", tags.get("sidewalk"))
    left = right = default
    if both is not None:
        left = both in ("both", "left", "yes")
        right = both in ("both", "right", "yes")
    for side in ("left", "right"):
        value = tags.get(f"sidewalk:{side}")
        if value is not None:
            if side == "left":
                left = value == "yes"
            else:
                right = value == "yes"
    return left, right


def is_street(tags: dict) -> bool:
    """Whether a highway way is a street vehicles drive on (its class in :data:`CLASSES`)."""
    return tags.get("highway") in CLASSES and tags.get("tunnel", "no") == "no" and tags.get("area") != "yes"


def street(fid: str, tags: dict, points: np.ndarray, nodes: tuple[int, ...]) -> Street:
    """A street way's cross-section from its tags (see the module docstring)."""
    cls = tags["highway"]
    lanes_all, lane_width, walks = CLASSES[cls]
    oneway = one_way(tags)
    tagged = _metres(tags.get("lanes"))
    lanes = int(tagged) if tagged and tagged >= 1 else (1 if oneway and lanes_all <= 2 else lanes_all)
    width = _metres(tags.get("width")) or lanes * lane_width
    width = float(np.clip(width, 3.0, 40.0))
    per_direction = int(np.clip(math.ceil(lanes / 2), 1, 4))
    walk_width = _metres(tags.get("sidewalk:width")) or SIDEWALK_WIDTH.get(
        cls.removesuffix("_link"), DEFAULT_SIDEWALK
    )
    return Street(
        fid, tags, points, nodes, width, per_direction, _sidewalks(tags, walks), float(walk_width), oneway
    )


def one_way(tags: dict) -> int:
    """A way's driving direction: 1 along it (``oneway=yes/true/1``, or a roundabout's ring
    without ``oneway=no``), -1 against it (``oneway=-1/reverse``), 0 both ways.

    >>> one_way({"oneway": "yes"}), one_way({"oneway": "-1"}), one_way({"junction": "roundabout"})
    (1, -1, 1)
    """
    value = tags.get("oneway", "").strip().lower()
    if value in ("yes", "true", "1"):
        return 1
    if value in ("-1", "reverse"):
        return -1
    if value == "" and tags.get("junction") in ("roundabout", "circular"):
        return 1
    return 0


@dataclass(frozen=True)
class Edge:
    """A piece of a street between two graph nodes."""

    street: Street
    nodes: tuple[int, int]
    points: np.ndarray


@dataclass(frozen=True)
class Arm:
    """A street edge leaving a junction: the edge, its heading out (rad), and whether it starts there."""

    edge: Edge
    yaw: float
    outward: bool


@dataclass(frozen=True)
class Junction:
    """A node where three or more street edges meet."""

    node: int
    position: tuple[float, float]
    arms: tuple[Arm, ...]
    block: Intersection | TIntersection | JunctionBlock | None
    """The junction's block: of the vocabulary where one fits, else a general junction; None
    only for a node of more than eight streets."""
    sockets: tuple[str | None, ...]
    """Each arm's socket on the block."""
    reaches: tuple[float, ...] = ()
    """How far from the node each arm's block reaches along its street, in metres."""

    @property
    def half(self) -> float:
        """Half the width of the widest street meeting here, in metres."""
        return max(a.edge.street.half for a in self.arms)

    def reach(self, edge: Edge, outward: bool) -> float:
        """How far from the node the junction's block reaches along the arm of ``edge`` (that
        starts here when ``outward``): where the street's own blocks begin."""
        for arm, r in zip(self.arms, self.reaches, strict=True):
            if arm.edge is edge and arm.outward == outward:
                return r
        return 0.0


def edges_of(streets: list[Street]) -> tuple[list[Edge], dict[int, int]]:
    """The streets cut at shared nodes into edges, and each graph node's degree."""
    uses: dict[int, int] = defaultdict(int)
    for s in streets:
        for k, n in enumerate(s.nodes):
            uses[n] += 1 if k in (0, len(s.nodes) - 1) else 2
    shared = defaultdict(int)
    for s in streets:
        for n in set(s.nodes):
            shared[n] += 1
    edges = []
    for s in streets:
        cut = [0] + [k for k in range(1, len(s.nodes) - 1) if uses[s.nodes[k]] >= 3 or shared[s.nodes[k]] > 1]
        cut.append(len(s.nodes) - 1)
        for a, b in itertools.pairwise(cut):
            if b > a:
                edges.append(Edge(s, (s.nodes[a], s.nodes[b]), s.points[a : b + 1]))
    return edges, dict(uses)


def give_way(edges: list[Edge], objects: list[tuple[tuple[float, float], float]]) -> list[Edge]:
    """``edges`` with each street drawn narrower where a mapped object stands beside it.

    ``objects`` are ``(position, room)``: a mapped object's point (m) and the radius its
    slimmest variant needs. An edge's half width becomes at most the object's distance from
    its centre line less the room, the curb and :data:`GAP`, at least :data:`MIN_LANE` a lane;
    an edge that even at that floor would keep the object more than :data:`REACH` off clear
    ground is left as it is. Edges not narrowed are the same objects.

    >>> street_ = street("w1", {"highway": "residential"}, np.array([[0.0, 0.0], [50.0, 0.0]]), (1, 2))
    >>> (e,) = give_way(edges_of([street_])[0], [((20.0, 2.9), 0.14)])
    >>> e.street.width, street_.width
    (5.12, 6.0)
    """
    if not objects:
        return edges
    points = shapely.points([p for p, _ in objects])
    rooms = np.array([r for _, r in objects])
    tree = shapely.STRtree(points)
    out = []
    for e in edges:
        s = e.street
        line = LineString(e.points)
        near = tree.query(line, predicate="dwithin", distance=s.half + CURB + float(rooms.max()))
        half = s.half
        floor = min(s.half, s.lanes * MIN_LANE)
        for i in sorted(near.tolist()):
            d = float(line.distance(points[i]))
            want = d - rooms[i] - CURB - GAP
            if want >= half or want < floor - REACH:
                continue
            half = max(floor, want)
        if half < s.half:
            s = replace(s, width=round(float(2 * half), 3))
            e = Edge(s, e.nodes, e.points)
        out.append(e)
    return out


def _heading(points: np.ndarray, reach: float = 5.0) -> float:
    """Heading (rad) of a polyline from its first point, towards its point ``reach`` metres on."""
    line = LineString(points)
    p = line.interpolate(min(reach, line.length))
    return math.atan2(p.y - points[0][1], p.x - points[0][0])


def _room(arms) -> float:
    """Most a junction's arms may reach: under half its shortest edge."""
    return 0.45 * min(LineString(a.edge.points).length for a in arms)


def junctions(edges: list[Edge], degree: dict[int, int], position: dict[int, np.ndarray]) -> list[Junction]:
    """Every node where three or more edges meet, with its block where one fits."""
    arms: dict[int, list[Arm]] = defaultdict(list)
    for e in edges:
        arms[e.nodes[0]].append(Arm(e, _heading(e.points), True))
        arms[e.nodes[1]].append(Arm(e, _heading(e.points[::-1]), False))
    out = []
    for node in sorted(n for n, d in degree.items() if d >= 3 and n in arms):
        here = tuple(arms[node])
        if len(here) < 3:
            continue
        p = position[node]
        centre = (float(p[0]), float(p[1]))
        block, sockets, reaches = _fit(node, centre, here)
        if block is None:
            block, sockets, reaches = _general(node, centre, here)
        out.append(Junction(node, centre, here, block, sockets, reaches))
    return out


def _near(a: float, b: float) -> bool:
    return abs(math.remainder(a - b, 2 * math.pi)) < math.radians(FIT_DEG)


def _fit(node: int, centre: tuple[float, float], arms: tuple[Arm, ...]):
    """The intersection or T block of a junction's arms, each arm's socket and reach; (None,
    Nones, zeros) where neither fits."""
    none = (None, (None,) * len(arms), (0.0,) * len(arms))
    half = max(a.edge.street.half for a in arms)
    lanes = max(a.edge.street.lanes for a in arms)
    common = {
        "id": f"j-n{node}",
        "lanes": lanes,
        "lane_width": float(np.clip(half / lanes, 2.0, 5.0)),
        "corner_radius": CORNER,
    }
    w = lanes * common["lane_width"]
    a = round(min(w + CORNER + ARM_ROOM, _room(arms)), 4)
    if a < 1.0:
        return none
    yaws = [arm.yaw for arm in arms]
    if len(arms) == 4:
        base = yaws[0]
        names = {"out": 0.0, "left": math.pi / 2, "in": math.pi, "right": -math.pi / 2}
        sockets = []
        for y in yaws:
            hit = [n for n, off in names.items() if _near(y, base + off)]
            sockets.append(hit[0] if hit else None)
        if None in sockets or len(set(sockets)) < 4:
            return none
        block = Intersection(**common, kind="intersection", pose=_pose(centre, base, a), arm_length=a)
        return block, tuple(sockets), (a,) * 4
    if len(arms) == 3:
        for i in range(3):
            for j in range(3):
                k = 3 - i - j
                if i == j or k in (i, j) or not _near(yaws[i], yaws[j] + math.pi):
                    continue
                side = "left" if _near(yaws[k], yaws[j] + math.pi / 2) else None
                side = side or ("right" if _near(yaws[k], yaws[j] - math.pi / 2) else None)
                if side is None:
                    continue
                block = TIntersection(
                    **common, kind="t_intersection", pose=_pose(centre, yaws[j], a), arm_length=a, side=side
                )
                sockets = [None] * 3
                sockets[i], sockets[j], sockets[k] = "in", "out", "side"
                return block, tuple(sockets), (a,) * 3
    return none


def _general(node: int, centre: tuple[float, float], arms: tuple[Arm, ...]):
    """The general junction block of a junction no block of the vocabulary fits, each arm's
    socket and reach: an arm reaches :data:`CORNER` and :data:`ARM_ROOM` past where its street
    leaves its neighbours' (or past its own half width), at most 0.45 of its edge (the street's
    blocks begin there; a close junction takes the rest), at least half a metre."""
    if len(arms) > limits.MAX_SOCKETS:
        return None, (None,) * len(arms), (0.0,) * len(arms)
    spec = [
        {
            "yaw": arm.yaw,
            "length": 100.0,
            "lanes": arm.edge.street.lanes,
            "lane_width": arm.edge.street.lane_width,
        }
        for arm in arms
    ]
    sites = block_geometry(general_junction("probe", centre, spec, CORNER)).crossings
    reaches = []
    for arm, site, a in zip(arms, sites, spec, strict=True):
        leaves = max(site.offset - 0.5, a["lanes"] * a["lane_width"])
        room = 0.45 * LineString(arm.edge.points).length
        reaches.append(max(0.5, min(leaves + CORNER + ARM_ROOM, room)))
    for a, r in zip(spec, reaches, strict=True):
        a["length"] = r
    block = general_junction(f"j-n{node}", centre, spec, CORNER)
    sockets = block_sockets(block)
    # the reach written: the block's arm length, as the spec rounds it
    return block, tuple(s.id for s in sockets), tuple(a.length for a in block.arms)


def _pose(centre, yaw: float, a: float) -> Pose2:
    """The entry pose of a junction block centred on ``centre`` whose ``out`` arm heads ``yaw``."""
    x, y = centre[0] - a * math.cos(yaw), centre[1] - a * math.sin(yaw)
    return Pose2(position=(x, y), yaw=math.remainder(yaw, 2 * math.pi))


def blocks(edges: list[Edge], joints: list[Junction], size: tuple[float, float]) -> tuple:
    """The road blocks of the street graph (see the module docstring), connected."""
    by_node = {j.node: j for j in joints}
    frame = box(0.0, 0.0, *size)
    out: list = [j.block for j in joints if j.block is not None]
    links: dict[str, dict[str, tuple[str, str]]] = {b.id: {} for b in out}
    ends: dict[int, list[tuple[str, str, Edge]]] = defaultdict(list)
    counter: dict[str, int] = defaultdict(int)

    def link(a: str, sa: str, b: str, sb: str) -> None:
        links[a][sa] = (b, sb)
        links[b][sb] = (a, sa)

    def reach(node: int, e: Edge, outward: bool) -> float:
        joint = by_node.get(node)
        return joint.reach(e, outward) if joint is not None else 0.0

    for e in edges:
        line = LineString(e.points)
        start, stop = reach(e.nodes[0], e, True), line.length - reach(e.nodes[1], e, False)
        if stop - start < 0.5:
            _touch(e, by_node, links, link)
            continue
        trimmed = substring(line, start, stop)
        inside = trimmed.intersection(frame)
        parts = [
            g for g in getattr(inside, "geoms", [inside]) if g.geom_type == "LineString" and g.length >= 0.5
        ]
        # A one-way street's blocks run the way its traffic drives: against the way's
        # direction (oneway=-1) each piece is laid from its far end, its "in" there.
        back = e.street.oneway < 0
        first, last = ("out", "in") if back else ("in", "out")
        for part in parts:
            pts = _thin(np.asarray(part.coords))
            ids = []
            for p, q in itertools.pairwise(pts):
                counter[e.street.id] += 1
                bid = f"s-{e.street.id}-{counter[e.street.id]}"
                a, b = (q, p) if back else (p, q)
                block = Straight(
                    id=bid,
                    kind="straight",
                    pose=Pose2(position=(float(a[0]), float(a[1])), yaw=math.atan2(b[1] - a[1], b[0] - a[0])),
                    lanes=e.street.lanes,
                    lane_width=e.street.lane_width,
                    length=float(np.hypot(*(q - p))),
                    one_way=True if e.street.oneway else None,
                )
                out.append(block)
                links[bid] = {}
                if ids:
                    link(ids[-1], last, bid, first)
                ids.append(bid)
            if not ids:
                continue
            if part.coords[0] == trimmed.coords[0]:
                ends[e.nodes[0]].append((ids[0], first, e))
            if part.coords[-1] == trimmed.coords[-1]:
                ends[e.nodes[1]].append((ids[-1], last, e))
    for node, here in sorted(ends.items()):
        joint = by_node.get(node)
        if joint is None:
            if len(here) == 2:  # one street going on as another
                (a, sa, _), (b, sb, _) = here
                link(a, sa, b, sb)
            continue
        if joint.block is None:
            continue
        for bid, socket, e in here:
            arm = next((s for arm, s in zip(joint.arms, joint.sockets, strict=True) if arm.edge is e), None)
            if arm is not None and arm not in links[joint.block.id]:
                link(joint.block.id, arm, bid, socket)
    return tuple(with_connections(block, links[block.id]) for block in out)


def _touch(e: Edge, by_node: dict, links: dict, link) -> None:
    """Join the two junction blocks at the ends of an edge too short for a block of its own
    (two close junctions of a dual carriageway), socket to socket."""
    a, b = by_node.get(e.nodes[0]), by_node.get(e.nodes[1])
    if a is None or b is None or a is b or a.block is None or b.block is None:
        return
    sa = next((s for arm, s in zip(a.arms, a.sockets, strict=True) if arm.edge is e and arm.outward), None)
    sb = next(
        (s for arm, s in zip(b.arms, b.sockets, strict=True) if arm.edge is e and not arm.outward), None
    )
    if sa is None or sb is None or sa in links[a.block.id] or sb in links[b.block.id]:
        return
    link(a.block.id, sa, b.block.id, sb)


def _thin(points: np.ndarray, least: float = 0.5) -> np.ndarray:
    """A polyline without vertices closer than ``least`` metres to the one before (its end kept)."""
    kept = [points[0]]
    for p in points[1:-1]:
        if np.hypot(*(p - kept[-1])) >= least:
            kept.append(p)
    if np.hypot(*(points[-1] - kept[-1])) < least and len(kept) > 1:
        kept.pop()
    kept.append(points[-1])
    return np.asarray(kept)
