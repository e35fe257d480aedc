"""Stage 1: block connection, a road network grown block by block as in MetaDrive.

The network starts with one block at the centre of the scene. Each step picks an open
socket (a road end nothing is attached to yet), samples a block type by the config's
weights (or takes the next of an explicit ``sequence``), samples its parameters, lays
it out from the socket (:mod:`citygen.geometry.roads`) and keeps it when it

- stays inside the scene with ``margin`` metres to spare (room for curbs and sidewalks),
- keeps ``clearance`` metres from every road but the one it attaches to,
- attaches without overlapping that one.

A socket that rejects several candidates in a row is a dead end and is closed. When
``max_tries`` candidates in a row fail, or no socket is left open, the last block is
removed and its socket reopened (backtracking); when backtracking runs out the stage
raises :class:`~citygen.errors.GenerationError` naming the seed and how far it got.

Overlap tests look up nearby roads in a uniform grid hash, so the cost of each test
depends on the roads around the candidate, not on the size of the network.
"""

from __future__ import annotations

import math
from collections import defaultdict
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np
import shapely
from shapely.geometry import Polygon, box

from citygen.errors import GenerationError
from citygen.geometry.roads import BLOCK_KINDS, block_geometry, block_sockets, wrap
from citygen.seeding import uniform
from citygen.spec.blocks import (
    Connection,
    Curve,
    Diverge,
    Intersection,
    Merge,
    Pose2,
    Roundabout,
    Straight,
    TIntersection,
)
from citygen.spec.config import BlocksConfig
from citygen.spec.scene import Bounds

#: The sampled block kinds' names, in the registry's order (that of ``BlockWeights``).
KINDS = tuple(kind.name for kind in BLOCK_KINDS.values() if kind.sampled)
#: Candidates a socket may reject in a row before it is closed as a dead end.
SOCKET_TRIES = 6
#: Side of a cell of the grid hash of road outlines, in metres.
CELL = 64.0
#: Overlap area (m^2) below which a block and the one it attaches to merely touch.
TOUCH_AREA = 0.05


@dataclass
class _Placed:
    block: object
    outline: Polygon
    parent: tuple[int, str] | None
    """(index of the block attached to, its socket)."""
    cells: list[tuple[int, int]]
    children: dict[str, tuple[int, str]] = field(default_factory=dict)
    """This block's socket -> (index of the attached block, its socket)."""


def _sample_block(kind: str, index: int, pose: Pose2, lanes: int, lane_width: float, cfg, rng):
    """A block of ``kind`` with its parameters drawn from the config's ranges (:data:`SAMPLERS`)."""
    common = {"id": f"b{index}", "kind": kind, "pose": pose, "lanes": lanes, "lane_width": lane_width}
    sign = 1.0 if rng.random() < 0.5 else -1.0
    model = _MODELS[kind]
    return model(**common, **SAMPLERS[model](cfg, rng, lanes, lane_width, sign))


def _straight(
    cfg: BlocksConfig, rng: np.random.Generator, lanes: int, lane_width: float, sign: float
) -> dict:
    return {"length": uniform(rng, cfg.straight_length)}


def _curve(cfg: BlocksConfig, rng: np.random.Generator, lanes: int, lane_width: float, sign: float) -> dict:
    angle = math.radians(uniform(rng, cfg.curve_angle_deg))
    return {"radius": uniform(rng, cfg.curve_radius), "angle": sign * angle}


def _roundabout(
    cfg: BlocksConfig, rng: np.random.Generator, lanes: int, lane_width: float, sign: float
) -> dict:
    radius = max(uniform(rng, cfg.roundabout_radius), lanes * lane_width + 2.0)
    return {"radius": radius, "arms": int(rng.integers(3, 6))}


def _branching(
    cfg: BlocksConfig, rng: np.random.Generator, lanes: int, lane_width: float, sign: float
) -> dict:
    """A diverge's or a merge's: the branch at 20-45 degrees, with no more lanes than the road."""
    return {
        "length": uniform(rng, cfg.straight_length),
        "branch_angle": sign * math.radians(float(rng.uniform(20.0, 45.0))),
        "branch_lanes": int(rng.integers(min(cfg.lanes[0], lanes), lanes + 1)),
    }


def _junction(
    cfg: BlocksConfig, rng: np.random.Generator, lanes: int, lane_width: float, sign: float
) -> dict:
    """An intersection's or a T's: arms, and corners rounded no further than the arms allow."""
    arm = uniform(rng, cfg.arm_length)
    width = lanes * lane_width
    corner = float(np.clip(rng.uniform(3.0, 8.0), 0.0, max(arm - width - 6.0, 0.0)))
    return {"arm_length": arm, "corner_radius": corner}


def _t_junction(
    cfg: BlocksConfig, rng: np.random.Generator, lanes: int, lane_width: float, sign: float
) -> dict:
    return {**_junction(cfg, rng, lanes, lane_width, sign), "side": "left" if sign > 0 else "right"}


Sampler = Callable[[BlocksConfig, np.random.Generator, int, float, float], dict]
"""``(cfg, rng, lanes, lane_width, sign) -> fields``: a block's parameters drawn from the
config's ranges; ``sign`` (+1 or -1, drawn for every block) turns curves and branches left
or right and puts a T's side road on the left or right."""

#: How each block kind of :data:`citygen.geometry.roads.BLOCK_KINDS` is sampled, by its class.
SAMPLERS: dict[type, Sampler] = {
    Straight: _straight,
    Curve: _curve,
    Roundabout: _roundabout,
    Diverge: _branching,
    Merge: _branching,
    Intersection: _junction,
    TIntersection: _t_junction,
}
_MODELS = {kind.name: model for model, kind in BLOCK_KINDS.items() if kind.sampled}


class _Network:
    """The blocks placed so far, with a grid hash of their outlines."""

    def __init__(self, clearance: float) -> None:
        self.placed: list[_Placed] = []
        self.grid: dict[tuple[int, int], list[int]] = defaultdict(list)
        self.clearance = clearance

    @staticmethod
    def cells(shape, pad: float) -> list[tuple[int, int]]:
        x0, y0, x1, y1 = shape.bounds
        i0, j0 = math.floor((x0 - pad) / CELL), math.floor((y0 - pad) / CELL)
        i1, j1 = math.floor((x1 + pad) / CELL), math.floor((y1 + pad) / CELL)
        return [(i, j) for i in range(i0, i1 + 1) for j in range(j0, j1 + 1)]

    def fits(self, outline: Polygon, parent: int | None, socket_pose) -> bool:
        near = sorted({k for c in self.cells(outline, self.clearance) for k in self.grid.get(c, ())})
        others = [self.placed[k].outline for k in near if k != parent]
        if others and shapely.dwithin(np.asarray(others, dtype=object), outline, self.clearance).any():
            return False
        if parent is None:
            return True
        mine = self.placed[parent].outline
        if mine.intersection(outline).area > TOUCH_AREA:
            return False
        # Away from the joint, the new block keeps its clearance from its parent too.
        (x, y), yaw = socket_pose
        reach = self.clearance + 0.05
        collar = Polygon(
            [
                (x + s * math.cos(yaw) - t * math.sin(yaw), y + s * math.sin(yaw) + t * math.cos(yaw))
                for s, t in ((-reach, -1e4), (reach, -1e4), (reach, 1e4), (-reach, 1e4))
            ]
        )
        collar = collar.intersection(box(x - 60, y - 60, x + 60, y + 60))
        return not shapely.dwithin(outline.difference(collar), mine.difference(collar), self.clearance)

    def add(self, placed: _Placed) -> None:
        self.placed.append(placed)
        for c in placed.cells:
            self.grid[c].append(len(self.placed) - 1)

    def pop(self) -> _Placed:
        placed = self.placed.pop()
        for c in placed.cells:
            self.grid[c].pop()
        return placed


def connect_blocks(
    bounds: Bounds,
    cfg: BlocksConfig,
    rng: np.random.Generator,
    *,
    seed: int | None = None,
    margin: float = 0.0,
) -> tuple:
    """A connected road network of ``cfg.count`` blocks (or ``cfg.sequence``) inside ``bounds``,
    each block ``margin`` metres from the edge. Blocks are ids ``b0``, ``b1`` ... in the
    order they were placed; their ``sockets`` and two-way ``connections`` are filled in."""
    (x0, y0), (x1, y1) = bounds.min, bounds.max
    area = box(x0 + margin, y0 + margin, x1 - margin, y1 - margin)
    if area.is_empty or area.area <= 0:
        raise GenerationError("blocks", seed, f"the scene is too small for roads with a {margin:g} m margin")
    lanes = int(rng.integers(cfg.lanes[0], cfg.lanes[1] + 1))
    lane_width = round(uniform(rng, cfg.lane_width), 4)
    kinds = np.array(KINDS)
    weights = np.array([getattr(cfg.weights, k) for k in KINDS], dtype=float)
    cumulative = np.cumsum(weights)
    count = len(cfg.sequence) or cfg.count

    def next_kind(index: int) -> str:
        if cfg.sequence:
            return cfg.sequence[index]
        pick = int(np.searchsorted(cumulative, rng.random() * cumulative[-1], side="right"))
        return str(kinds[min(pick, len(KINDS) - 1)])

    net = _Network(cfg.clearance)
    # Open sockets in the order they appeared: (block index, socket id).
    open_sockets: list[tuple[int, str]] = []
    dead: set[tuple[int, str]] = set()
    backtracks, budget = 0, 4 * count + 8

    def socket_lanes(k: int, socket: str) -> int:
        block = net.placed[k].block
        return block.branch_lanes if socket == "branch" else block.lanes

    def place(block, parent: tuple[int, str] | None) -> bool:
        geometry = block_geometry(block)
        outline = geometry.outline
        if outline.is_empty or not area.contains(outline):
            return False
        joint = None
        if parent is not None:
            arm = _arm(net.placed[parent[0]].block, parent[1])
            joint = (arm.position, arm.yaw)
        if not net.fits(outline, None if parent is None else parent[0], joint):
            return False
        net.add(_Placed(block, outline, parent, net.cells(outline, 0.0)))
        k = len(net.placed) - 1
        if parent is not None:
            net.placed[parent[0]].children[parent[1]] = (k, "in")
            open_sockets.remove(parent)
        open_sockets.extend((k, a.socket) for a in geometry.arms if a.socket != "in" or parent is None)
        return True

    def place_first() -> None:
        for _ in range(cfg.max_tries):
            cx = float(rng.uniform(0.4, 0.6)) * (x1 - x0) + x0
            cy = float(rng.uniform(0.4, 0.6)) * (y1 - y0) + y0
            yaw = float(rng.choice([0.0, math.pi / 2, math.pi, -math.pi / 2]))
            block = _sample_block(
                next_kind(0), 0, Pose2(position=(cx, cy), yaw=yaw), lanes, lane_width, cfg, rng
            )
            # The first block is centred on the chosen point rather than starting at it.
            far = block_geometry(block).arms[1].position
            centred = Pose2(position=((3 * cx - far[0]) / 2, (3 * cy - far[1]) / 2), yaw=yaw)
            if place(type(block).model_validate({**block.model_dump(), "pose": centred}), None):
                return
        raise GenerationError("blocks", seed, f"no room for a first block in {x1 - x0:g} x {y1 - y0:g} m")

    failures = 0
    while len(net.placed) < count:
        if not net.placed:
            place_first()
            continue
        candidates = [s for s in open_sockets if s not in dead]
        if candidates and failures < cfg.max_tries:
            parent = candidates[int(rng.integers(len(candidates)))]
            lanes_here = socket_lanes(*parent)
            arm = _arm(net.placed[parent[0]].block, parent[1])
            pose = Pose2(position=arm.position, yaw=wrap(arm.yaw))
            index = len(net.placed)
            ok = False
            for _ in range(SOCKET_TRIES):
                block = _sample_block(next_kind(index), index, pose, lanes_here, lane_width, cfg, rng)
                failures += 1
                if place(block, parent):
                    ok, failures = True, 0
                    break
            if not ok:
                dead.add(parent)
            continue
        # Stuck: take the last block back and try again from its parent.
        if backtracks >= budget:
            raise GenerationError(
                "blocks",
                seed,
                f"placed {len(net.placed)} of {count} blocks: no open road end has room for another "
                f"block after {cfg.max_tries} tries; enlarge the scene, lower blocks.count or "
                "blocks.clearance",
            )
        backtracks += 1
        failures = 0
        gone = net.pop()
        k = len(net.placed)
        open_sockets[:] = [s for s in open_sockets if s[0] != k]
        dead.difference_update({s for s in dead if s[0] == k})
        if gone.parent is None:  # the first block goes: start afresh
            open_sockets.clear()
            dead.clear()
        else:
            del net.placed[gone.parent[0]].children[gone.parent[1]]
            open_sockets.append(gone.parent)
            dead.add(gone.parent)  # that socket already failed once with this block

    return _finish(net)


def _arm(block, socket: str):
    """The road end of ``block`` at ``socket``."""
    return next(a for a in block_geometry(block).arms if a.socket == socket)


def _finish(net: _Network) -> tuple:
    """Frozen blocks with their sockets and two-way connections."""
    blocks = []
    for k, placed in enumerate(net.placed):
        sockets = block_sockets(placed.block)
        links = dict(placed.children)
        if placed.parent is not None:
            links["in"] = placed.parent
        connections = tuple(
            Connection(socket=a.id, block=f"b{links[a.id][0]}", to_socket=links[a.id][1])
            for a in sockets
            if a.id in links
        )
        assert placed.block.id == f"b{k}"
        blocks.append(placed.block.model_copy(update={"sockets": sockets, "connections": connections}))
    return tuple(blocks)
