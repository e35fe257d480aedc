"""ORCA, *Optimal Reciprocal Collision Avoidance* (van den Berg, Guy, Lin and Manocha, 2011),
as the reference RVO2 library computes it, for every agent at once.

Neighbours and their lines' inputs are arrays over all agents (numpy); each agent's half-planes
and linear programs run in the numba kernel of :mod:`citygen.runner.agents.orca_kernel` (RVO2's
own incremental algorithm, line by line). What follows is the plain-numpy form of that solver,
kept as the reference (``orca_velocities(..., reference=True)``; ``tests/test_orca_kernel.py``
holds the two together):

RVO2 builds one half-plane of allowed velocities per neighbour (``computeNewVelocity``) and
solves a small 2-D linear program per agent by an incremental algorithm (``linearProgram2``,
and ``linearProgram3`` where the half-planes leave no feasible velocity). Run line by line
for all agents, that algorithm costs a sequence of numpy calls per line; here every step of
it is an array operation over all agents, lines and line pairs at once, with the same result:

- each of RVO2's updates puts the velocity on one line (``linearProgram1``), at a point that
  depends only on that line, the lines before it and the preferred velocity, never on the
  velocity so far. So all the points it could produce (*candidates*) are computed at once,
  and its answer is the candidate that keeps every half-plane and is nearest to the
  preferred velocity (the optimum of a strictly convex problem is unique, and it is RVO2's).
- where no candidate keeps every half-plane, RVO2 fails at the first line whose prefix of
  lines leaves nothing feasible, and ``linearProgram3`` returns the velocity that violates
  the worst agent half-plane least (static ones stay hard). Its step for line ``i`` is again
  a small linear program independent of the velocity so far; all of them are solved at once
  by the same candidate rule (one problem per sub-problem), and the answer is the solution
  of the worst violation.

Neighbours come from a KD-tree (:class:`scipy.spatial.cKDTree`) for large crowds and from
the dense distance matrix for small ones; lines no agent has (far static discs, missing
neighbours) are dropped first, and a line only some agents lack becomes one no velocity
violates (no masks). At a hundred agents numpy's cost per call and per row of an array
dominates, not the arithmetic, so the solver keeps few, long rows: one problem per column
(``[line, agent]``), pair arrays with one row per line (``[j, k * V + v]``) or per line
pair (only ``j < i``, grouped for ``ufunc.reduceat``), gathers by :func:`numpy.take`
(C-ordered results). Results agree with
RVO2 to float precision (``tests/test_crowd.py`` compares with RVO2 through ``pyrvo``, also
in a dense crowd where most agents need ``linearProgram3``). One exception, with static
discs: the line of a standing obstacle passes through zero velocity, and where several such
lines leave zero alone RVO2's rounding decides whether that is feasible; here it is (the
person stands), where RVO2 may fall back to ``linearProgram3``.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.spatial import cKDTree

from citygen.runner.agents import orca_kernel

RVO_EPSILON = 1e-5
"""RVO2's tolerance for parallel lines (its ``RVO_EPSILON``)."""
FEASIBLE_TOL = 1e-9
"""How far (m/s) a candidate velocity may lie on the wrong side of a half-plane and still keep
it: rounding of the points computed on the line itself."""
FAR = 1e6
"""How far (m/s) from zero the line lies that stands in for a missing one (no velocity the
solver meets violates it, and it bounds no other line within the speed disc)."""
KDTREE_AGENTS = 48
"""From this many agents per environment on, neighbours come from a KD-tree (cheaper than
the dense distance matrix)."""


def _unit(x: np.ndarray, y: np.ndarray, n=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(x, y) / |(x, y)|`` and the length ``n`` (computed unless given); a zero vector gives
    ``(1, 0)``."""
    if n is None:
        n = np.sqrt(x * x + y * y)
    safe = n > 1e-12
    inv = 1.0 / np.where(safe, n, 1.0)
    return np.where(safe, x * inv, 1.0), np.where(safe, y * inv, 0.0), n


def half_planes(rx, ry, vx, vy, combined, inv_tau, inv_dt):
    """RVO2's ORCA line for a neighbour at relative position ``(rx, ry)`` (neighbour minus
    agent) with relative velocity ``(vx, vy)`` (agent minus neighbour): ``(dx, dy, ux, uy)``,
    the line's direction and the smallest change of relative velocity out of the velocity
    obstacle (arrays of any one shape; ``inv_tau``, ``inv_dt`` are ``1 / tau`` and ``1 / dt``)."""
    dist2 = rx * rx + ry * ry
    r2 = combined * combined
    wx, wy = vx - rx * inv_tau, vy - ry * inv_tau
    w_len2 = wx * wx + wy * wy
    dotp = wx * rx + wy * ry
    on_cutoff = (dotp < 0.0) & (dotp * dotp > r2 * w_len2)
    # Projection on the legs of the cone (left or right as w lies).
    inv = 1.0 / np.where(dist2 > 0, dist2, 1.0)
    leg = np.sqrt(np.maximum(dist2 - r2, 0.0))
    leg *= np.where(rx * wy - ry * wx > 0.0, 1.0, -1.0)
    dx = (rx * leg - ry * combined) * inv
    dy = (rx * combined + ry * leg) * inv
    proj = vx * dx + vy * dy
    ux, uy = proj * dx - vx, proj * dy - vy
    if on_cutoff.any():  # projection on the cut-off circle
        cx, cy, w_len = _unit(wx, wy, np.sqrt(w_len2))
        k = combined * inv_tau - w_len
        dx, dy = np.where(on_cutoff, cy, dx), np.where(on_cutoff, -cx, dy)
        ux, uy = np.where(on_cutoff, k * cx, ux), np.where(on_cutoff, k * cy, uy)
    colliding = dist2 <= r2
    if colliding.any():  # already overlapping: leave the velocity obstacle of one time step
        cx, cy, c_len = _unit(vx - rx * inv_dt, vy - ry * inv_dt)
        k = combined * inv_dt - c_len
        dx, dy = np.where(colliding, cy, dx), np.where(colliding, -cx, dy)
        ux, uy = np.where(colliding, k * cx, ux), np.where(colliding, k * cy, uy)
    return dx, dy, ux, uy


@functools.lru_cache(maxsize=64)
def _earlier(n_j: int, first: int, n_i: int, n_problems: int) -> np.ndarray:
    """``[j, (i - first) * n_problems + v]``: ``j < i``, for ``j < n_j``, ``first <= i < n_i``."""
    return np.repeat(np.arange(n_j)[:, None] < np.arange(first, n_i), n_problems, axis=1)


@functools.lru_cache(maxsize=64)
def _pairs(n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The pairs ``(i, j)``, ``j < i < n``, grouped by ``i`` (``i = 1 .. n - 1``): ``(i, j,
    starts)``, ``starts`` the first pair of each group."""
    i, j = np.tril_indices(n, -1)
    return i, j, np.searchsorted(i, np.arange(1, n))


def _tiled(lines, times: int) -> np.ndarray:
    """Quantities ``(Q, L, V)`` of lines repeated ``times`` along the last axis:
    ``[q, j, k * V + v] = lines[q, j, v]``. Pair arrays are laid out ``[j, k * V + v]``, one
    row per line ``j``: few long rows keep numpy's per-row overhead low."""
    return np.tile(lines, (1, 1, times))


def _clip(ox, oy, radius) -> tuple[np.ndarray, np.ndarray]:
    """``(ox, oy)`` clipped to the disc of ``radius`` (RVO2's start of ``linearProgram2``)."""
    n2 = ox * ox + oy * oy
    over = n2 > radius * radius
    scale = np.where(over, radius / np.sqrt(np.where(over, n2, 1.0)), 1.0)
    return ox * scale, oy * scale


def _offset(c, dx, dy, x, y) -> np.ndarray:
    """How far velocities ``(x, y)`` ``(C, V)`` lie on the wrong side of lines ``(L, V)``
    (``c = dx * py - dy * px``), ``[j, k * V + v]`` for velocity ``k``: RVO2's
    ``det(direction, point - v)``."""
    cj, dxj, dyj = _tiled(np.stack([c, dx, dy]), x.shape[0])
    return cj - dxj * y.reshape(1, -1) + dyj * x.reshape(1, -1)


def _candidates(px, py, dx, dy, radius, ox, oy, direction_opt: bool):
    """Every velocity RVO2's ``linearProgram2`` may hold, for lines ``(L, V)`` in order (one
    problem per column): the start (``opt`` clipped to the disc of ``radius``, or
    ``opt * radius`` when ``direction_opt``) and, per line, ``linearProgram1``'s point on it
    bounded by the disc and the lines before it. Returns ``(cx, cy, usable)``, ``(L + 1, V)``."""
    n_lines = px.shape[0]
    pd = px * dx + py * dy
    disc = pd * pd + radius * radius - (px * px + py * py)
    ok = disc >= 0.0
    root = np.sqrt(np.maximum(disc, 0.0))
    t_left, t_right = -pd - root, root - pd
    if n_lines > 1:
        # [pair, v]: line i of problem v against an earlier line j, the pairs grouped by i.
        i, j, starts = _pairs(n_lines)
        lines = np.stack([px, py, dx, dy])
        pxi, pyi, dxi, dyi = lines.take(i, axis=1)
        pxj, pyj, dxj, dyj = lines.take(j, axis=1)
        den = dxi * dyj - dyi * dxj
        num = dxj * (pyi - pyj) - dyj * (pxi - pxj)
        parallel = np.abs(den) <= RVO_EPSILON
        ok[1:] &= ~np.logical_or.reduceat(parallel & (num < 0.0), starts, axis=0)
        t = num / np.where(parallel, 1.0, den)
        upper = np.minimum.reduceat(np.where(den > RVO_EPSILON, t, np.inf), starts)
        lower = np.maximum.reduceat(np.where(den < -RVO_EPSILON, t, -np.inf), starts)
        t_right[1:] = np.minimum(t_right[1:], upper)
        t_left[1:] = np.maximum(t_left[1:], lower)
        ok &= t_left <= t_right
    if direction_opt:
        t = np.where(ox * dx + oy * dy > 0.0, t_right, t_left)
        sx, sy = ox * radius, oy * radius
    else:
        t = np.minimum(np.maximum(dx * (ox - px) + dy * (oy - py), t_left), t_right)
        sx, sy = _clip(ox, oy, radius)
    cx = np.concatenate([sx[None], px + t * dx])
    cy = np.concatenate([sy[None], py + t * dy])
    usable = np.concatenate([np.ones((1, ok.shape[1]), bool), ok])
    return cx, cy, usable


def _pick(cx, cy, fit, score) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fitting candidate of least ``score`` of each column ``(C, V)``: ``(x, y, any_fit)``."""
    best = np.where(fit, score, np.inf).argmin(axis=0)
    best = best * cx.shape[1] + np.arange(cx.shape[1])
    return cx.ravel()[best], cy.ravel()[best], fit.any(axis=0)


def _best_in_direction(qx, qy, ex, ey, radius, opt_x, opt_y):
    """RVO2's ``linearProgram2`` with ``directionOpt`` (the velocity in the disc of ``radius``
    farthest along the unit ``opt``) for lines ``(L, V)``: ``(x, y, ok)`` ``(V,)``, by the
    candidate rule."""
    cx, cy, usable = _candidates(qx, qy, ex, ey, radius, opt_x, opt_y, True)
    fit = usable & (_offset(ex * qy - ey * qx, ex, ey, cx, cy) <= FEASIBLE_TOL).all(axis=0).reshape(cx.shape)
    return _pick(cx, cy, fit, -(cx * opt_x + cy * opt_y))


def _scan(cx, cy, usable, px, py, dx, dy):
    """RVO2's ``linearProgram2`` run line by line over precomputed candidates (exact also where
    its tolerances for nearly parallel lines matter): ``(x, y, fail)``, ``fail`` the line it
    stopped at (``L`` when it did not)."""
    n_lines = px.shape[0]
    x, y = cx[0], cy[0]
    fail = np.full(x.shape, n_lines)
    for k in range(n_lines):
        hit = (fail == n_lines) & (dx[k] * (py[k] - y) - dy[k] * (px[k] - x) > 0)
        take = hit & usable[k + 1]
        x, y = np.where(take, cx[k + 1], x), np.where(take, cy[k + 1], y)
        fail = np.where(hit & ~usable[k + 1], k, fail)
    return x, y, fail


def _linear_program(px, py, dx, dy, agent_line, n_static: int, radius, ox, oy):
    """RVO2's ``linearProgram2`` and, where it fails, ``linearProgram3`` for lines ``(A, L)``
    (the first ``n_static`` static; ``agent_line`` marks the present neighbour lines, any
    other line is one no velocity violates): the velocities ``(x, y)`` ``(A,)``."""
    x, y = _clip(ox, oy, radius)
    c = dx * py - dy * px
    # Most agents' preferred velocity (clipped to the disc) keeps every line: RVO2 stops there.
    busy = np.flatnonzero((c - dx * y[:, None] + dy * x[:, None] > 0.0).any(axis=1))
    if not len(busy):
        return x, y
    # From here on one agent per column: [quantity, line, agent].
    # (np.take keeps the result C-ordered, where indexing an axis with an array would not.)
    lines = np.stack([px, py, dx, dy, c]).take(busy, axis=1).transpose(0, 2, 1).copy()
    x[busy], y[busy] = _solve(
        lines, agent_line.take(busy, axis=0).T.copy(), n_static, radius[busy], ox[busy], oy[busy]
    )
    return x, y


def _solve(lines, agent_line, n_static: int, radius, ox, oy):
    """``linearProgram2`` and, where it fails, ``linearProgram3`` for the agents of ``lines``
    ``(5, L, B)`` (``px, py, dx, dy, c``): ``(x, y)`` ``(B,)``."""
    px, py, dx, dy, c = lines
    cx, cy, usable = _candidates(px, py, dx, dy, radius, ox, oy, False)
    keeps = _offset(c, dx, dy, cx, cy) <= FEASIBLE_TOL
    score = (cx - ox) ** 2 + (cy - oy) ** 2
    x, y, feasible = _pick(cx, cy, usable & keeps.all(axis=0).reshape(cx.shape), score)
    stuck = np.flatnonzero(~feasible)
    if len(stuck):
        # RVO2 fails at the first line no candidate keeps together with all lines before it,
        # holding the optimum of the lines before it (a candidate keeping them all).
        first_broken = np.where(usable, keeps.argmin(axis=0).reshape(cx.shape), -1).take(stuck, axis=1)
        begin = first_broken.max(axis=0)
        fit = first_broken == begin
        sx, sy, _ = _pick(cx.take(stuck, axis=1), cy.take(stuck, axis=1), fit, score.take(stuck, axis=1))
        x[stuck], y[stuck] = _least_violation(
            lines.take(stuck, axis=2), agent_line.take(stuck, axis=1), n_static, radius[stuck], sx, sy, begin
        )
    return x, y


def _projected_lines(lines, n_static: int, first: int, width: int):
    """``linearProgram3``'s lines of the sub-problems ``i >= first`` of agents with ``lines``
    ``(5, L, S)`` (``px, py, dx, dy, c``), the first ``width`` of each (a sub-problem ``i``
    has ``i`` lines): ``(4, width, (L - first) * S)``, ``[:, j, (i - first) * S + s]`` the
    static line ``j`` as it is, for an agent line ``j < i`` the line where ``j`` and ``i``
    are violated alike (none where they run the same way), and one no velocity violates for
    the others."""
    n_lines, n = lines.shape[1:]
    # [j, (i - first) * S + s]: sub-problem i of agent s, its line j.
    j_lines = _tiled(lines[:4, :width], n_lines - first)
    pxj, pyj, dxj, dyj = j_lines
    pxi, pyi, dxi, dyi = (q.reshape(1, -1) for q in lines[:4, first:])
    det = dxi * dyj - dyi * dxj
    parallel = np.abs(det) <= RVO_EPSILON
    t = (dxj * (pyi - pyj) - dyj * (pxi - pxj)) / np.where(parallel, 1.0, det)
    qx = np.where(parallel, 0.5 * (pxi + pxj), pxi + t * dxi)
    qy = np.where(parallel, 0.5 * (pyi + pyj), pyi + t * dyi)
    ex, ey, _ = _unit(dxj - dxi, dyj - dyi)
    keep = _earlier(width, first, n_lines, n) & ~(parallel & (dxi * dxj + dyi * dyj > 0.0))
    proj = np.stack([qx, qy, ex, ey])
    if n_static:
        static = (np.arange(width) < n_static)[:, None]
        proj, keep = np.where(static, j_lines, proj), keep | static
    return np.where(keep, proj, _NO_LINE)


_NO_LINE = np.array([0.0, -FAR, 1.0, 0.0])[:, None, None]
"""A line ``(px, py, dx, dy)`` no velocity within ``FAR`` m/s of zero violates."""


def _least_violation(lines, agent_line, n_static: int, radius, sx, sy, begin):
    """RVO2's ``linearProgram3`` for agents whose lines ``(5, L, S)`` (``px, py, dx, dy, c``)
    leave nothing feasible (first failing at line ``begin``, holding ``(sx, sy)`` then): the
    velocity whose worst violation of an agent line is least, static lines kept. Line ``i``'s
    step maximises the distance into line ``i`` keeping the static lines and 'no agent line
    ``j < i`` worse than ``i``'; the steps are independent, solved all at once."""
    n_lines = lines.shape[1]
    rx, ry = sx.copy(), sy.copy()
    reg = np.flatnonzero(begin >= n_static)
    if len(reg):
        first = int(begin[reg].min())  # sub-problems before any begin are never taken
        n_sub = n_lines - first
        every = len(reg) == len(begin)
        lr = lines if every else lines.take(reg, axis=2)
        mine = agent_line if every else agent_line.take(reg, axis=1)
        # Sub-problem i has lines j < i: the last line is none's. Columns (i, s), i-major.
        qx, qy, ex, ey = _projected_lines(lr, n_static, first, n_lines - 1)
        opt_x, opt_y = -lr[3, first:].ravel(), lr[2, first:].ravel()
        x, y, ok = _best_in_direction(qx, qy, ex, ey, np.tile(radius[reg], n_sub), opt_x, opt_y)
        x, y, ok = x.reshape(n_sub, -1), y.reshape(n_sub, -1), ok.reshape(n_sub, -1)
        # The worst violation of an agent line by each sub-problem's answer.
        off = _offset(lr[4], lr[2], lr[3], x, y)
        worst = np.where(np.tile(mine, (1, n_sub)), off, -np.inf).max(axis=0).reshape(n_sub, -1)
        take = ok & mine[first:] & (np.arange(first, n_lines)[:, None] >= begin[reg])
        bx, by, found = _pick(x, y, take, worst)
        rx[reg], ry[reg] = np.where(found, bx, sx[reg]), np.where(found, by, sy[reg])
    odd = np.flatnonzero(begin < n_static)
    if len(odd):
        # The static lines themselves conflict: RVO2's steps depend on its tolerances; take them.
        n_odd = len(odd)
        lo = lines.take(odd, axis=2)
        qx, qy, ex, ey = _projected_lines(lo, n_static, 0, n_lines)
        opt_x, opt_y = -lo[3].ravel(), lo[2].ravel()
        cx, cy, usable = _candidates(qx, qy, ex, ey, np.tile(radius[odd], n_lines), opt_x, opt_y, True)
        x, y, fail = _scan(cx, cy, usable, qx, qy, ex, ey)
        x, y, ok = (v.reshape(n_lines, n_odd) for v in (x, y, fail == n_lines))
        begin = begin[odd]
        px, py, dx, dy, _ = lo
        ux, uy, dist = sx[odd], sy[odd], np.zeros(n_odd)
        for i in range(int(begin.min()), n_lines):
            hit = (begin <= i) & (dx[i] * (py[i] - uy) - dy[i] * (px[i] - ux) > dist)
            ux, uy = np.where(hit & ok[i], x[i], ux), np.where(hit & ok[i], y[i], uy)
            dist = np.where(hit, dx[i] * (py[i] - uy) - dy[i] * (px[i] - ux), dist)
        rx[odd], ry[odd] = ux, uy
    return rx, ry


def _neighbours(p: np.ndarray, k: int, neighbor_dist: float) -> tuple[np.ndarray, np.ndarray]:
    """The ``k`` nearest other agents within ``neighbor_dist`` of each, nearest first, as RVO2
    picks them: ``(index (b, n, k), present (b, n, k))``."""
    b, n = p.shape[:2]
    r2 = neighbor_dist * neighbor_dist
    if n < KDTREE_AGENTS:
        dx = p[:, None, :, 0] - p[:, :, None, 0]
        dy = p[:, None, :, 1] - p[:, :, None, 1]
        d2 = dx * dx + dy * dy
        d2[:, np.arange(n), np.arange(n)] = np.inf
        d2[d2 >= r2] = np.inf
        near = (
            np.argpartition(d2, k - 1, axis=-1)[..., :k]
            if k < n - 1
            else np.broadcast_to(np.arange(n), d2.shape)
        )
        dn = np.take_along_axis(d2, near, -1)
        order = np.argsort(dn, axis=-1, kind="stable")[..., :k]
        return np.take_along_axis(near, order, -1), np.isfinite(np.take_along_axis(dn, order, -1))
    idx = np.empty((b, n, k), dtype=np.int64)
    present = np.empty((b, n, k), dtype=bool)
    me = np.arange(n)
    for e in range(b):
        # Sorted by distance; each agent first, unless another stands exactly on it.
        dist, nb = cKDTree(p[e]).query(p[e], k=k + 1, distance_upper_bound=neighbor_dist * (1 + 1e-9))
        if (nb[:, 0] == me).all():
            dist, nb = dist[:, 1:], nb[:, 1:]
        else:
            order = np.argsort(nb == me[:, None], axis=1, kind="stable")[:, :k]
            dist, nb = np.take_along_axis(dist, order, 1), np.take_along_axis(nb, order, 1)
        idx[e] = np.minimum(nb, n - 1)
        present[e] = dist * dist < r2
    return idx, present


def _present_columns(valid: np.ndarray, n_static: int) -> tuple[np.ndarray | None, int]:
    """Per agent the columns of its lines to keep, ``(A, L')``, present static lines first
    (in order), then the neighbours (present ones come first already), ``L'`` the most any
    agent has; and the new count of static columns. None where nothing can be dropped."""
    if valid.all():
        return None, n_static
    n_lines = valid.shape[1]
    statics = valid[:, :n_static]
    keep_s = int(statics.sum(axis=1).max(initial=0))
    keep_n = int(valid[:, n_static:].sum(axis=1).max(initial=0))
    if keep_s == n_static and keep_n == n_lines - n_static:
        return None, n_static
    order = np.argsort(~statics, axis=1, kind="stable")[:, :keep_s]
    rest = np.broadcast_to(np.arange(n_static, n_static + keep_n), (len(valid), keep_n))
    return np.concatenate([order, rest], axis=1), keep_s


def _as_agents(x, shape: tuple[int, ...], name: str) -> np.ndarray:
    x = np.asarray(x, dtype=np.float64)
    if x.shape == shape:
        return x
    try:
        return np.broadcast_to(x, shape)
    except ValueError:
        raise ValueError(
            f"{name}: expected a scalar or an array of shape {shape}, got {np.shape(x)}"
        ) from None


def orca_velocities(
    pos,
    vel,
    pref_vel,
    radius,
    max_speed,
    *,
    dt: float,
    tau: float = 2.0,
    neighbor_dist: float = 5.0,
    max_neighbors: int = 10,
    cooperative=None,
    static=None,
    tau_static: float = 1.0,
    reference: bool = False,
) -> np.ndarray:
    """New velocities (m/s) of agents by ORCA, as RVO2's ``computeNewVelocity``, for all at once.

    ``pos``, ``vel``, ``pref_vel``: ``(..., N, 2)`` positions (m), current and preferred
    velocities (m/s); any leading dimensions are a batch of independent environments (each
    environment's agents only see each other). ``radius`` (m) and ``max_speed`` (m/s): scalars
    or ``(..., N)``. ``dt`` (s) is the step (ORCA's horizon for agents that already overlap),
    ``tau`` (s) the time horizon for agents, ``neighbor_dist`` (m) and ``max_neighbors`` pick
    the nearest neighbours as RVO2 does. ``cooperative`` (bool ``(..., N)``, default all): a
    non-cooperative agent (the robot) keeps its ``vel`` and others take full responsibility
    for avoiding it. ``static``: ``(points (..., N, S, 2), radii (..., N, S))``, per agent
    ``S`` discs standing still (m) it must not run into within ``tau_static`` (s); a negative
    radius or a non-finite point is no obstacle. ``reference``: solve with the plain-numpy
    form of this module instead of the compiled kernel (:mod:`~citygen.runner.agents.orca_kernel`,
    the default); the two agree to float precision.

    >>> import numpy as np
    >>> pos = np.array([[-2.0, 0.05], [2.0, 0.0]])  # walking at each other, 5 cm off the line
    >>> pref = np.array([[1.0, 0.0], [-1.0, 0.0]])
    >>> orca_velocities(pos, pref, pref, 0.3, 1.5, dt=0.1).round(2).tolist()  # each dodges half
    [[0.98, 0.14], [-0.98, -0.14]]
    """
    pos = np.asarray(pos, dtype=np.float64)
    if pos.ndim < 2 or pos.shape[-1] != 2:
        raise ValueError(f"pos: expected an array of shape (..., N, 2), got {pos.shape}")
    if not (dt > 0 and tau > 0 and tau_static > 0 and neighbor_dist >= 0 and max_neighbors >= 0):
        raise ValueError(
            f"orca_velocities: expected dt > 0, tau > 0, tau_static > 0 (s), neighbor_dist >= 0 (m) and "
            f"max_neighbors >= 0, got {dt!r}, {tau!r}, {tau_static!r}, {neighbor_dist!r}, {max_neighbors!r}"
        )
    batch, n = pos.shape[:-2], pos.shape[-2]
    vel = _as_agents(vel, pos.shape, "vel").reshape(-1, n, 2)
    pref = _as_agents(pref_vel, pos.shape, "pref_vel").reshape(-1, n, 2)
    rad = _as_agents(radius, (*batch, n), "radius").reshape(-1, n)
    vmax = _as_agents(max_speed, (*batch, n), "max_speed").reshape(-1, n)
    coop = np.ones((*batch, n), bool) if cooperative is None else np.asarray(cooperative, bool)
    coop = np.broadcast_to(coop, (*batch, n)).reshape(-1, n)
    p = pos.reshape(-1, n, 2)
    b = p.shape[0]
    n_static = 0
    if static is not None:
        sp, sr = static
        sp = np.asarray(sp, dtype=np.float64)
        if sp.ndim < 3 or sp.shape[:-2] != (*batch, n) or sp.shape[-1] != 2:
            raise ValueError(f"static points: expected shape {(*batch, n, 'S', 2)}, got {sp.shape}")
        n_static = sp.shape[-2]
        sr = _as_agents(sr, sp.shape[:-1], "static radii").reshape(b, n, n_static)
        sp = sp.reshape(b, n, n_static, 2)
    k = max(min(max_neighbors, n - 1), 0)
    if not n_static + k:
        px_, py_ = pref[..., 0], pref[..., 1]
        n2 = px_ * px_ + py_ * py_
        over = n2 > vmax**2
        scale = np.where(over, vmax / np.sqrt(np.where(over, n2, 1.0)), 1.0)[..., None]
        return np.where(coop[..., None], pref * scale, vel).reshape(pos.shape)
    # Per line (the static discs, then the neighbours): relative position, relative velocity,
    # combined radius, share of the avoidance, present.
    line = np.empty((7, b, n, n_static + k))
    if n_static:
        present = (sr >= 0) & np.all(np.isfinite(sp), axis=-1)
        rel = np.where(present[..., None], sp - p[:, :, None], 1e6)
        ls = line[..., :n_static]
        ls[0], ls[1] = rel[..., 0], rel[..., 1]
        ls[2], ls[3] = vel[..., 0, None], vel[..., 1, None]
        ls[4] = rad[..., None] + sr
        ls[5], ls[6] = 1.0, present
    if k:
        near, present = _neighbours(p, k, neighbor_dist)
        # Per agent (b, n): position, velocity, radius, cooperative; of each neighbour (b, n, k).
        own = np.stack([p[..., 0], p[..., 1], vel[..., 0], vel[..., 1], rad, coop])
        other = own.reshape(6, -1).take(near + np.arange(0, b * n, n)[:, None, None], axis=1)
        own = own[..., None]
        ln = line[..., n_static:]
        np.subtract(other[:2], own[:2], out=ln[:2])
        np.subtract(own[2:4], other[2:4], out=ln[2:4])
        np.add(own[4], other[4], out=ln[4])
        np.subtract(1.0, 0.5 * other[5], out=ln[5])  # half for a cooperative neighbour
        ln[6] = present
    solver = _solve_reference if reference else orca_kernel.solve
    out = solver(
        line.reshape(7, b * n, -1), n_static, 1.0 / tau, 1.0 / tau_static, 1.0 / dt,
        np.ascontiguousarray(vel.reshape(-1, 2)), np.ascontiguousarray(pref.reshape(-1, 2)),
        np.ascontiguousarray(vmax.reshape(-1)),
    )  # fmt: skip
    if cooperative is not None:
        out = np.where(coop.reshape(-1)[:, None], out, vel.reshape(-1, 2))
    return out.reshape(pos.shape)


def _solve_reference(
    line, n_static: int, inv_tau: float, inv_tau_static: float, inv_dt: float, vel, pref, vmax
):
    """The plain-numpy form of :func:`citygen.runner.agents.orca_kernel.solve` (same arguments:
    lines ``(7, A, L)``, the first ``n_static`` static; ``(A, 2)`` velocities out)."""
    valid = line[6] > 0.5
    # Lines no agent has are dropped (absent static discs moved last first): the answer of
    # each agent depends only on its present lines, in order.
    cols, n_static = _present_columns(valid, n_static)
    if cols is not None:
        line, valid = line[:, np.arange(len(cols))[:, None], cols], valid[np.arange(len(cols))[:, None], cols]
    rx, ry, rvx, rvy, comb, share, _ = line
    if n_static:
        inv_tau = np.where(np.arange(line.shape[2]) < n_static, inv_tau_static, inv_tau)
    vx, vy = vel.T
    dx, dy, ux, uy = half_planes(rx, ry, rvx, rvy, comb, inv_tau, inv_dt)
    px = vx[:, None] + share * ux
    py = vy[:, None] + share * uy
    if not valid.all():
        px, py, dx, dy = np.where(valid, np.stack([px, py, dx, dy]), _NO_LINE)
    agent_line = valid & (np.arange(valid.shape[1]) >= n_static) if n_static else valid
    x, y = _linear_program(px, py, dx, dy, agent_line, n_static, vmax, pref[:, 0].copy(), pref[:, 1].copy())
    return np.stack([x, y], axis=-1)
