"""Wave Function Collapse: the simple tiled model over a rectangular grid.

Written for citygen (no maintained Python WFC library exists) and generic over a
tileset: the terrain stage (:mod:`citygen.generate.terrain`) is one user, but nothing
here knows about terrain.

**Tiles.** A :class:`Prototype` has one *socket* per side (north, east, south, west),
each a tuple of labels read *clockwise* around the tile. Two tiles may touch along a
side when one's socket there equals the other's read backwards (reversed), which is
how the shared edge looks from the other tile. A prototype's symmetry class says how
many distinct quarter turns it has (``X``: 1, ``I`` and ``\\``: 2, ``L`` and ``T``: 4);
:meth:`Tileset.from_prototypes` expands every prototype into its rotations
(*variants*) and derives the adjacency from the sockets. Rotating a tile a quarter
turn clockwise moves each socket to the next side clockwise and keeps its reading
order, so no socket is ever rewritten.

**Weights.** Each variant belongs to a *group* (by default its prototype) with a
group weight; a cell whose domain holds several groups first draws a group in
proportion to the group weights of those present, then a variant of that group in
proportion to the variant weights. So a kind's share does not grow with its number
of rotations or levels, and a cell's choice follows the configured mix whatever
subset of kinds its neighbours still allow.

**Solver.** Variants that allow exactly the same neighbours on every side (flat and
rough ground at one level, say) are interchangeable, so the search runs over such
*classes* and each cell's variant is drawn from its class at the end, in proportion to
the variants' probabilities in a draw over that class. Domains are bitsets (Python
integers, one bit per class) on a grid padded with empty border cells. The cell of
lowest Shannon entropy comes from a heap of integer keys (ties broken by a seeded
random key; cells never restricted wait in one shuffled list instead), is collapsed by a
weighted draw, and the choice is propagated to a fixed point (arc consistency: each
neighbour keeps the classes some class of this cell allows, through cached support
masks). A contradiction (an empty domain) is undone from a trail of changes and the
offending choice banned, newest first (chronological backtracking), which is complete:
an instance with no solution is proved so. Only the latest :data:`MAX_DEPTH` to
``2 * MAX_DEPTH`` decisions stay undoable, which bounds the trail's memory on large
grids and keeps backtracking local to where the search is. A search that backtracks
more than its budget restarts with fresh random keys, at most ``max_restarts`` times;
what still cannot be resolved raises :class:`Unsatisfiable`, a
:class:`~citygen.errors.GenerationError` naming the cell.

All randomness comes from the ``numpy.random.Generator`` passed in, so the same
tileset, domains and generator state give the same grid.

>>> ts = Tileset.from_prototypes([
...     Prototype("land", (("g", "g"),) * 4),
...     Prototype("sea", (("w", "w"),) * 4),
...     Prototype("coast", (("g", "g"), ("g", "w"), ("w", "w"), ("w", "g")), symmetry="T"),
... ])
>>> len(ts), ts.names[2:]
(6, ('coast', 'coast@1', 'coast@2', 'coast@3'))
>>> grid = solve(ts, 4, 5, np.random.default_rng(1))
>>> grid.shape, check(ts, grid)
((4, 5), [])
"""

from __future__ import annotations

import heapq
import math
from bisect import bisect_right
from collections import deque
from collections.abc import Hashable, Iterable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from citygen.errors import GenerationError

Socket = tuple[Hashable, ...]
"""The labels along one side of a tile, read clockwise around it."""
Symmetry = Literal["X", "I", "\\", "L", "T"]

#: Sides in the order sockets are given: north (+y, row + 1), east (+x, col + 1), south, west.
SIDES = ("north", "east", "south", "west")
#: Row and column offset of the neighbour across each side.
OFFSETS = ((1, 0), (0, 1), (-1, 0), (0, -1))
#: Distinct quarter turns of each symmetry class (reflections are not used).
ROTATIONS: dict[str, int] = {"X": 1, "I": 2, "\\": 2, "L": 4, "T": 4}

_MASK_CACHE_LIMIT = 1 << 16


@dataclass(frozen=True)
class Prototype:
    """One tile of a tileset before rotation."""

    name: str
    sockets: tuple[Socket, Socket, Socket, Socket]
    """North, east, south and west sockets, each read clockwise around the tile."""
    weight: float = 1.0
    """Relative frequency of each of this prototype's variants within its group."""
    symmetry: Symmetry = "X"
    """Symmetry class: how many distinct quarter turns the tile has."""
    group: str | None = None
    """Weight group (a tile kind); ``None`` makes the prototype its own group."""


def rotate(sockets: Sequence[Socket], quarter_turns: int) -> tuple[Socket, ...]:
    """The sockets of a tile turned ``quarter_turns`` times clockwise: north's socket moves east.

    >>> rotate(("n", "e", "s", "w"), 1)
    ('w', 'n', 'e', 's')
    """
    k = quarter_turns % 4
    return tuple(sockets[(i - k) % 4] for i in range(4))


@dataclass(frozen=True, eq=False)
class Tileset:
    """Variants (rotated prototypes), their adjacency and their weights."""

    names: tuple[str, ...]
    """Variant names: the prototype's name, then ``@k`` for ``k`` clockwise quarter turns."""
    prototype: tuple[int, ...]
    """Index of each variant's prototype in the list it was built from."""
    rotation: tuple[int, ...]
    """Clockwise quarter turns of each variant relative to its prototype."""
    sockets: tuple[tuple[Socket, ...], ...]
    """Each variant's north, east, south and west sockets (empty when built from adjacency)."""
    weights: np.ndarray
    """Weight of each variant within its group, shape ``(n,)``."""
    groups: tuple[str, ...]
    """Group names, in order of first appearance."""
    group_of: np.ndarray
    """Group index of each variant, shape ``(n,)``."""
    group_weights: np.ndarray
    """Weight of each group, shape ``(len(groups),)``."""
    allowed: np.ndarray
    """``allowed[d, a, b]``: variant ``b`` may be the neighbour of variant ``a`` across side ``d``."""
    _cache: dict = field(default_factory=dict, repr=False, compare=False)

    def __len__(self) -> int:
        return len(self.names)

    @classmethod
    def from_prototypes(
        cls, prototypes: Sequence[Prototype], group_weights: Mapping[str, float] | None = None
    ) -> Tileset:
        """Expand every prototype into its rotations and derive the adjacency from the sockets.

        ``group_weights`` gives each group's weight (a missing group weighs 1; groups left
        implicit weigh their prototype's weight). Raises ``ValueError`` on a prototype whose
        sockets contradict its symmetry class, on duplicate names or negative weights.
        """
        if not prototypes:
            raise ValueError("a tileset needs at least one prototype")
        names, proto, rot, socks, weights, gnames = [], [], [], [], [], []
        explicit: dict[str, float] = {}
        for p_index, p in enumerate(prototypes):
            if len(p.sockets) != 4:
                raise ValueError(
                    f"prototype {p.name!r}: expected 4 sockets (N, E, S, W), got {len(p.sockets)}"
                )
            if p.symmetry not in ROTATIONS:
                raise ValueError(
                    f"prototype {p.name!r}: symmetry {p.symmetry!r} is not one of {', '.join(ROTATIONS)}"
                )
            if not (p.weight >= 0 and math.isfinite(p.weight)):
                raise ValueError(f"prototype {p.name!r}: weight must be finite and >= 0, got {p.weight!r}")
            turns = ROTATIONS[p.symmetry]
            if rotate(p.sockets, turns) != tuple(p.sockets):
                raise ValueError(
                    f"prototype {p.name!r} has symmetry {p.symmetry!r} but its sockets change "
                    f"after {turns} quarter turn(s): {p.sockets!r}"
                )
            group = p.group if p.group is not None else p.name
            if p.group is None:
                explicit[group] = p.weight
            for k in range(turns):
                names.append(p.name if k == 0 else f"{p.name}@{k}")
                proto.append(p_index)
                rot.append(k)
                socks.append(rotate(p.sockets, k))
                weights.append(p.weight if p.group is not None else 1.0)
                gnames.append(group)
        if len(set(names)) != len(names):
            raise ValueError("prototype names must be unique")
        groups = tuple(dict.fromkeys(gnames))
        gw = {**explicit, **(group_weights or {})}
        gweights = np.array([float(gw.get(g, 1.0)) for g in groups])
        if (gweights < 0).any() or not np.isfinite(gweights).all():
            found = dict(zip(groups, gweights.tolist(), strict=True))
            raise ValueError(f"group weights must be finite and >= 0, got {found}")
        n = len(names)
        # A tile's socket on side d meets its neighbour's socket on the opposite side
        # (d + 2) % 4, which that neighbour reads in the opposite direction.
        allowed = np.zeros((4, n, n), dtype=bool)
        for d in range(4):
            ids: dict[Hashable, int] = {}
            mine = np.array([ids.setdefault(s[d], len(ids)) for s in socks])
            theirs = np.array([ids.setdefault(tuple(reversed(s[(d + 2) % 4])), len(ids)) for s in socks])
            allowed[d] = mine[:, None] == theirs[None, :]
        return cls(
            names=tuple(names),
            prototype=tuple(proto),
            rotation=tuple(rot),
            sockets=tuple(socks),
            weights=np.asarray(weights, dtype=np.float64),
            groups=groups,
            group_of=np.array([groups.index(g) for g in gnames], dtype=np.int64),
            group_weights=gweights,
            allowed=allowed,
        )

    @classmethod
    def from_adjacency(
        cls,
        names: Sequence[str],
        allowed: np.ndarray,
        weights: Sequence[float] | None = None,
        groups: Sequence[str] | None = None,
        group_weights: Mapping[str, float] | None = None,
    ) -> Tileset:
        """A tileset given directly as variants and adjacency: ``allowed[d, a, b]`` says that
        ``b`` may be ``a``'s neighbour across side ``d`` (north, east, south, west), and must
        equal ``allowed[(d + 2) % 4, b, a]``. Every variant is its own group unless ``groups``
        names one per variant (then ``weights`` act within groups, ``group_weights`` between).
        """
        n = len(names)
        allowed = np.asarray(allowed, dtype=bool)
        if allowed.shape != (4, n, n):
            raise ValueError(f"allowed must have shape (4, {n}, {n}), got {allowed.shape}")
        for d in range(2):
            if not np.array_equal(allowed[d], allowed[d + 2].T):
                raise ValueError(
                    f"allowed[{d}] must be the transpose of allowed[{d + 2}]: adjacency is mutual"
                )
        w = np.ones(n) if weights is None else np.asarray(weights, dtype=np.float64)
        if w.shape != (n,) or (w < 0).any() or not np.isfinite(w).all():
            raise ValueError(f"weights must be {n} finite numbers >= 0")
        if len(set(names)) != n:
            raise ValueError("variant names must be unique")
        if groups is None:
            gnames, gw = list(names), dict(zip(names, w.tolist(), strict=True))
            w = np.ones(n)
        else:
            gnames, gw = list(groups), {}
        order = tuple(dict.fromkeys(gnames))
        gw = {**gw, **(group_weights or {})}
        gweights = np.array([float(gw.get(g, 1.0)) for g in order])
        if (gweights < 0).any() or not np.isfinite(gweights).all():
            raise ValueError("group weights must be finite and >= 0")
        return cls(
            names=tuple(names),
            prototype=tuple(range(n)),
            rotation=(0,) * n,
            sockets=(),
            weights=w,
            groups=order,
            group_of=np.array([order.index(g) for g in gnames], dtype=np.int64),
            group_weights=gweights,
            allowed=allowed.copy(),
        )

    # --- bitset tables (built once per tileset, cached) ---------------------------------

    def _reduced(self) -> _Classes:
        """The tileset with interchangeable variants (same neighbours on every side) merged."""
        hit = self._cache.get("classes")
        if hit is None:
            hit = self._cache["classes"] = _Classes(self)
        return hit

    def _info(self) -> dict[int, tuple[float, list[int], list[float]]]:
        """Cache: domain bitset -> (entropy, variants, cumulative probabilities)."""
        return self._cache.setdefault("info", {})

    def distribution(self, mask: int) -> tuple[float, list[int], list[float]]:
        """The draw over a domain: ``(entropy, variants, cumulative probabilities)``."""
        info = self._info()
        hit = info.get(mask)
        if hit is not None:
            return hit
        variants = [b for b in range(len(self)) if mask >> b & 1]
        w = self.weights[variants]
        g = self.group_of[variants]
        gsum = np.bincount(g, weights=w, minlength=len(self.groups))
        present = np.bincount(g, minlength=len(self.groups)) > 0
        gw = np.where(present & (gsum > 0), self.group_weights, 0.0)
        if gw.sum() > 0:
            p = gw[g] / gw.sum() * np.divide(w, gsum[g], out=np.zeros_like(w), where=gsum[g] > 0)
        else:
            p = np.zeros_like(w)
        if not p.sum() > 0:  # only weightless variants remain: any of them
            p = np.full(len(variants), 1.0)
        p = p / p.sum()
        nz = p[p > 0]
        entropy = float(-(nz * np.log(nz)).sum())
        cum = np.cumsum(p).tolist()
        cum[-1] = 1.0
        if len(info) >= _MASK_CACHE_LIMIT:
            info.clear()
        hit = info[mask] = (entropy, variants, cum)
        return hit


class _Classes:
    """Variants that allow exactly the same neighbours on every side are interchangeable:
    the search runs over such classes (fewer, smaller domains), and each cell's variant is
    drawn from its class at the end, in proportion to its probability in a draw over the
    class alone (the draw over variants gives the same odds whenever each group has as
    many variants in every class of a domain, as with terrain levels)."""

    def __init__(self, ts: Tileset) -> None:
        self.ts = ts
        keys = [ts.allowed[:, v, :].tobytes() for v in range(len(ts))]
        index: dict[bytes, int] = {}
        self.of = np.array([index.setdefault(k, len(index)) for k in keys], dtype=np.int64)
        self.n = len(index)
        self.members = [np.flatnonzero(self.of == c) for c in range(self.n)]
        reps = [int(m[0]) for m in self.members]
        self.vmask = [sum(1 << int(v) for v in m) for m in self.members]
        self.compat = [
            [sum(1 << b for b in range(self.n) if ts.allowed[d, reps[a], reps[b]]) for a in range(self.n)]
            for d in range(4)
        ]
        self.share = []
        for m in self.members:
            _, variants, cum = ts.distribution(sum(1 << int(v) for v in m))
            p = np.diff(np.concatenate([[0.0], cum]))
            self.share.append(p[np.searchsorted(variants, m)])
        self.info: dict[int, tuple[float, list[int], list[float]]] = {}
        self.support: dict[int, tuple[int, int, int, int]] = {}
        self.keys: dict[int, int] = {}

    def distribution(self, cmask: int) -> tuple[float, list[int], list[float]]:
        """The draw over a domain of classes: ``(entropy, classes, cumulative probabilities)``."""
        hit = self.info.get(cmask)
        if hit is not None:
            return hit
        classes = [c for c in range(self.n) if cmask >> c & 1]
        vmask = 0
        for c in classes:
            vmask |= self.vmask[c]
        _, variants, cum = self.ts.distribution(vmask)
        pv = np.diff(np.concatenate([[0.0], cum]))
        p = np.bincount(self.of[variants], weights=pv, minlength=self.n)[classes]
        nz = p[p > 0]
        entropy = float(-(nz * np.log(nz)).sum()) + 0.0
        cum_c = np.cumsum(p).tolist()
        cum_c[-1] = 1.0
        if len(self.info) >= _MASK_CACHE_LIMIT:
            self.info.clear()
        hit = self.info[cmask] = (entropy, classes, cum_c)
        return hit

    def variants(self, classes: np.ndarray, domains: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """A variant for each cell from its class, among those its domain allows, by weight."""
        flat = domains.reshape(-1, domains.shape[-1])
        out = np.empty(classes.size, dtype=np.int64)
        u = rng.random(classes.size)
        for c in range(self.n):
            cells = np.flatnonzero(classes == c)
            m = self.members[c]
            if cells.size == 0:
                continue
            if m.size == 1:
                out[cells] = m[0]
                continue
            ok = flat[np.ix_(cells, m)]
            w = np.where(ok, self.share[c][None, :], 0.0)
            w = np.where((w.sum(axis=1) > 0)[:, None], w, ok.astype(np.float64))
            cum = np.cumsum(w, axis=1)
            pick = (cum < u[cells, None] * cum[:, -1:]).sum(axis=1)
            out[cells] = m[np.minimum(pick, m.size - 1)]
        return out


class Unsatisfiable(GenerationError):
    """No assignment of variants satisfies the adjacency and the cells' domains."""

    def __init__(self, stage: str, seed: int | None, cell: tuple[int, int], message: str) -> None:
        self.cell = cell
        super().__init__(stage, seed, message)


def full_domains(tileset: Tileset, rows: int, cols: int) -> np.ndarray:
    """Every variant allowed in every cell: a ``(rows, cols, n)`` boolean array to restrict."""
    return np.ones((rows, cols, len(tileset)), dtype=bool)


def _to_masks(domains: np.ndarray) -> list[int]:
    flat = domains.reshape(-1, domains.shape[-1])
    n = flat.shape[1]
    if n <= 63:
        return (flat.astype(np.uint64) << np.arange(n, dtype=np.uint64)).sum(axis=1).tolist()
    packed = np.packbits(flat, axis=1, bitorder="little")
    return [int.from_bytes(row.tobytes(), "little") for row in packed]


def solve(
    tileset: Tileset,
    rows: int,
    cols: int,
    rng: np.random.Generator,
    *,
    domains: np.ndarray | None = None,
    max_restarts: int = 20,
    max_backtracks: int | None = None,
    seed: int | None = None,
    stage: str = "terrain",
) -> np.ndarray:
    """A ``(rows, cols)`` array of variant indices in which every pair of neighbours fits.

    ``domains`` (``(rows, cols, n)`` booleans, default all true) restricts what each cell
    may hold: pinned cells are cells with a restricted domain. ``max_backtracks`` bounds
    the undone choices of one attempt (default ``64 + cells // 4``) before a restart with
    fresh random keys; after ``max_restarts`` restarts, or at once when the domains admit
    no solution at all, :class:`Unsatisfiable` is raised naming the cell where the search
    failed (``seed`` and ``stage`` only label that error).
    """
    n = len(tileset)
    if rows < 1 or cols < 1:
        raise ValueError(f"a grid needs at least one row and one column, got {rows} x {cols}")
    if domains is None:
        domains = full_domains(tileset, rows, cols)
    if domains.shape != (rows, cols, n):
        raise ValueError(f"domains must have shape {(rows, cols, n)}, got {domains.shape}")
    domains = np.asarray(domains, dtype=bool)
    classes = tileset._reduced()
    start = _to_masks(np.stack([domains[..., m].any(axis=-1) for m in classes.members], axis=-1))
    budget = 64 + rows * cols // 4 if max_backtracks is None else max_backtracks
    failures: dict[int, int] = {}
    for _attempt in range(max_restarts + 1):
        run = _Run(classes, rows, cols, start, rng, failures)
        status = run.search(budget)
        if status == "solved":
            return classes.variants(run.result().ravel(), domains, rng).reshape(rows, cols)
        if status == "unsatisfiable":
            break
    cell = max(failures, key=lambda i: (failures[i], -i)) if failures else 0
    r, c = divmod(cell, cols)
    if status == "unsatisfiable":
        msg = f"no tiling fits the adjacency and the pinned cells: nothing fits cell (row {r}, col {c})"
    else:
        msg = (
            f"contradictions persisted through {max_restarts} restart(s), most often at cell "
            f"(row {r}, col {c})"
        )
    raise Unsatisfiable(stage, seed, (r, c), msg)


_CELL_BITS = 23  # padded cell index (a 2048 x 2048 grid pads to 2050 x 2050 < 2**23)
_NOISE_BITS = 16  # random tie-break between cells of equal entropy
_ENTROPY_SHIFT = _CELL_BITS + _NOISE_BITS
_CELL_MASK = (1 << _CELL_BITS) - 1
#: Undoable decisions kept at most; older ones are committed, bounding the trail's memory.
MAX_DEPTH = 64


class _Run:
    """One attempt: domains, heap, trail and decisions.

    Cells live on a grid padded by one border cell on every side whose domain is empty:
    intersecting an empty domain changes nothing, so the hot loop needs no bounds checks,
    and border cells are never propagated from. Cell ``(r, c)`` is ``(r + 1) * (cols + 2) + c + 1``.

    The heap holds integers ``entropy * 1e6 << 39 | noise << 23 | cell`` (one comparison
    each); a popped key that no longer matches its cell's domain is stale and skipped.
    Cells whose domain was never restricted all share the largest key prefix, so instead of
    sitting on the heap they wait in one list in random order (by the same noise) and are
    taken when the heap holds nothing lower.
    """

    def __init__(
        self,
        ts: _Classes,
        rows: int,
        cols: int,
        start: list[int],
        rng: np.random.Generator,
        failures: dict[int, int],
    ) -> None:
        self.ts, self.rows, self.cols = ts, rows, cols
        w = self.width = cols + 2
        masks = [0] * ((rows + 2) * w)
        for r in range(rows):
            masks[(r + 1) * w + 1 : (r + 1) * w + 1 + cols] = start[r * cols : (r + 1) * cols]
        self.masks = masks
        idx = ((np.arange(rows)[:, None] + 1) * w + np.arange(cols)[None, :] + 1).ravel()
        self.cells = idx.tolist()
        self.rng = rng
        self.failures = failures
        noise = rng.integers(0, 1 << _NOISE_BITS, size=len(masks), dtype=np.int64)
        self.tie = ((noise << _CELL_BITS) | np.arange(len(masks))).tolist()
        self.pool = idx[np.argsort(noise[idx], kind="stable")].tolist()[::-1]
        self.support, self.keys = ts.support, ts.keys
        self.trail: list[tuple[int, int]] = []
        self.base = 0  # absolute trail position of trail[0]
        self.heap: list[int] = []

    def cell(self, i: int) -> int:
        """The unpadded row-major index of padded cell ``i``."""
        r, c = divmod(i, self.width)
        return (r - 1) * self.cols + c - 1

    def result(self) -> np.ndarray:
        """Each cell's class (the lowest of its domain; the domain is one class when solved)."""
        masks = self.masks
        return np.array([masks[i].bit_length() - 1 for i in self.cells], dtype=np.int64)

    def _fail(self, i: int) -> bool:
        k = self.cell(i)
        self.failures[k] = self.failures.get(k, 0) + 1
        return False

    def _support(self, mask: int) -> tuple[int, int, int, int]:
        """Per side, the classes some class of ``mask`` allows across it."""
        out = []
        for d in range(4):
            s, comp, m, b = 0, self.ts.compat[d], mask, 0
            while m:
                if m & 1:
                    s |= comp[b]
                m >>= 1
                b += 1
            out.append(s)
        if len(self.support) >= _MASK_CACHE_LIMIT:
            self.support.clear()
        hit = self.support[mask] = tuple(out)
        return hit  # type: ignore[return-value]

    def _key(self, mask: int) -> int:
        """The heap-key prefix of a domain: its entropy in millionths, shifted."""
        if len(self.keys) >= _MASK_CACHE_LIMIT:
            self.keys.clear()
        k = self.keys[mask] = round(self.ts.distribution(mask)[0] * 1e6) << _ENTROPY_SHIFT
        return k

    def _queue(self, cells: Iterable[int]) -> None:
        """Put cells with more than one option on the heap, keyed by their current entropy."""
        masks, heap, tie, keys, push = self.masks, self.heap, self.tie, self.keys, heapq.heappush
        for j in cells:
            m = masks[j]
            if m & (m - 1):
                k = keys.get(m)
                push(heap, (self._key(m) if k is None else k) | tie[j])

    def _propagate(self, stack: list[int]) -> bool:
        """Arc consistency from the cells on ``stack``; False on a contradiction. Cells whose
        domain shrank are queued once, at the end, with their final entropy."""
        masks, trail, support, w = self.masks, self.trail, self.support, self.width
        log, push = trail.append, stack.append
        mark = len(trail)
        while stack:
            i = stack.pop()
            m = masks[i]
            sup = support.get(m)
            if sup is None:
                sup = self._support(m)
            # The four sides, unrolled: north (+w), east (+1), south (-w), west (-1).
            j = i + w
            mj = masks[j]
            nm = mj & sup[0]
            if nm != mj:
                if not nm:
                    return self._fail(j)
                log((j, mj))
                masks[j] = nm
                push(j)
            j = i + 1
            mj = masks[j]
            nm = mj & sup[1]
            if nm != mj:
                if not nm:
                    return self._fail(j)
                log((j, mj))
                masks[j] = nm
                push(j)
            j = i - w
            mj = masks[j]
            nm = mj & sup[2]
            if nm != mj:
                if not nm:
                    return self._fail(j)
                log((j, mj))
                masks[j] = nm
                push(j)
            j = i - 1
            mj = masks[j]
            nm = mj & sup[3]
            if nm != mj:
                if not nm:
                    return self._fail(j)
                log((j, mj))
                masks[j] = nm
                push(j)
        if len(trail) > mark:
            self._queue(dict.fromkeys(j for j, _ in trail[mark:]))
        return True

    def _undo(self, to: int) -> None:
        """Restore every domain changed since absolute trail position ``to``."""
        masks, trail = self.masks, self.trail
        keep = to - self.base
        restored = []
        while len(trail) > keep:
            j, old = trail.pop()
            masks[j] = old
            restored.append(j)
        self._queue(dict.fromkeys(restored))

    def _next(self) -> int:
        """The undecided cell of lowest entropy (random among equals), or -1 when none is left."""
        heap, masks, keys, tie, pool = self.heap, self.masks, self.keys, self.tie, self.pool
        full = self.full
        top = self.full_key
        while True:
            while pool and masks[pool[-1]] != full:
                pool.pop()  # restricted since: on the heap, or decided
            if heap and (not pool or heap[0] < top | tie[pool[-1]]):
                k = heapq.heappop(heap)
                i = k & _CELL_MASK
                m = masks[i]
                if m & (m - 1):
                    km = keys.get(m)
                    if (self._key(m) if km is None else km) | tie[i] == k:
                        return i
                continue  # decided, or stale: the domain changed since it was queued
            if pool:
                return pool.pop()
            return -1

    def search(self, budget: int) -> str:
        """``"solved"``, ``"unsatisfiable"`` (proved) or ``"budget"`` (gave up this attempt)."""
        masks = self.masks
        for i in self.cells:
            if not masks[i]:
                return self._fail(i) or "unsatisfiable"
        self.full = full = (1 << self.ts.n) - 1
        self.full_key = self.keys.get(full) or self._key(full)
        if not self._propagate([i for i in self.cells if masks[i] != full]):
            return "unsatisfiable"
        self.trail.clear()  # the initial propagation is never undone
        self.heap = []
        self._queue(i for i in self.cells if masks[i] != full)
        dist, trail = self.ts.distribution, self.trail
        uniforms, u = self.rng.random(256).tolist(), 0
        decisions: deque[tuple[int, int, int]] = deque()
        backtracks = 0
        committed = False  # whether decisions were dropped, so that failing is no proof
        while (i := self._next()) >= 0:
            m = masks[i]
            _, classes, cum = dist(m)
            if u == len(uniforms):
                uniforms, u = self.rng.random(256).tolist(), 0
            k = bisect_right(cum, uniforms[u])
            u += 1
            bit = 1 << classes[min(k, len(classes) - 1)]
            if len(decisions) >= 2 * MAX_DEPTH:
                # Commit the oldest half: its changes can no longer be undone.
                for _ in range(MAX_DEPTH):
                    decisions.popleft()
                cut = decisions[0][2] - self.base
                del trail[:cut]
                self.base += cut
                committed = True
            decisions.append((i, bit, self.base + len(trail)))
            trail.append((i, m))
            masks[i] = bit
            if self._propagate([i]):
                continue
            # Contradiction: undo choices, newest first, banning each undone one.
            while True:
                if not decisions:
                    return "budget" if committed else "unsatisfiable"
                backtracks += 1
                if backtracks > budget:
                    return "budget"
                j, bad, mark = decisions.pop()
                self._undo(mark)
                left = masks[j] & ~bad
                if not left:
                    continue
                trail.append((j, masks[j]))
                masks[j] = left
                self._queue((j,))
                if self._propagate([j]):
                    break
        return "solved"


def check(tileset: Tileset, grid: np.ndarray) -> list[tuple[int, int, str]]:
    """``(row, col, side)`` of every pair of neighbours in ``grid`` that does not fit (east and
    north sides only, so each pair is reported once); empty when the grid is a valid tiling."""
    grid = np.asarray(grid)
    bad = []
    for d, (side, (dr, dc)) in enumerate(zip(SIDES[:2], OFFSETS[:2], strict=True)):
        a = grid[: grid.shape[0] - dr, : grid.shape[1] - dc]
        b = grid[dr:, dc:]
        ok = tileset.allowed[d][a, b]
        bad += [(int(r), int(c), side) for r, c in zip(*np.nonzero(~ok), strict=True)]
    return sorted(bad)


def counts(tileset: Tileset, grids: Iterable[np.ndarray]) -> dict[str, int]:
    """How many cells of ``grids`` hold a variant of each group."""
    total = np.zeros(len(tileset.groups), dtype=np.int64)
    for g in grids:
        total += np.bincount(tileset.group_of[np.asarray(g).ravel()], minlength=len(tileset.groups))
    return dict(zip(tileset.groups, total.tolist(), strict=True))
