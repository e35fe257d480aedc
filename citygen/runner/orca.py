"""ORCA, *Optimal Reciprocal Collision Avoidance* (van den Berg, Guy, Lin and Manocha, 2011),
as the reference RVO2 library computes it, for every agent at once with numpy.

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
  by the same candidate rule, and the answer is the solution of the worst violation.

Neighbours come from a KD-tree (:class:`scipy.spatial.cKDTree`) for large crowds and from
the dense distance matrix for small ones; lines no agent has (far static discs, missing
neighbours) are dropped first. Results agree with RVO2 to float precision
(``tests/test_crowd.py`` compares with RVO2 through ``pyrvo``). One exception, with static
discs: the line of a standing obstacle passes through zero velocity, and where several such
lines leave zero alone RVO2's rounding decides whether that is feasible; here it is (the
person stands), where RVO2 may fall back to ``linearProgram3``.
"""

from __future__ import annotations

import functools

import numpy as np
from scipy.spatial import cKDTree

RVO_EPSILON = 1e-5
"""RVO2's tolerance for parallel lines (its ``RVO_EPSILON``)."""
FEASIBLE_TOL = 1e-9
"""How far (m/s) a candidate velocity may lie on the wrong side of a half-plane and still keep
it: rounding of the points computed on the line itself."""
KDTREE_AGENTS = 48
"""From this many agents per environment on, neighbours come from a KD-tree (cheaper than
the dense distance matrix)."""


def _unit(x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(x, y) / |(x, y)|`` and the length; a zero vector gives ``(1, 0)``."""
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
    leg = np.sqrt(np.maximum(dist2 - r2, 0.0))
    inv = 1.0 / np.where(dist2 > 0, dist2, 1.0)
    side = np.where(rx * wy - ry * wx > 0.0, 1.0, -1.0)
    dx = (side * rx * leg - ry * combined) * inv
    dy = (rx * combined + side * ry * leg) * inv
    proj = vx * dx + vy * dy
    ux, uy = proj * dx - vx, proj * dy - vy
    if on_cutoff.any():  # projection on the cut-off circle
        cx, cy, w_len = _unit(wx, wy)
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
def _strictly_lower(n: int) -> np.ndarray:
    """``[i, j]``: ``j < i``."""
    return np.tri(n, k=-1, dtype=bool)


def _candidates(px, py, dx, dy, valid, radius, ox, oy, direction_opt: bool):
    """Every velocity RVO2's ``linearProgram2`` may hold, for lines ``(..., L)`` in order:
    the start (``opt`` clipped to the disc of ``radius``, or ``opt * radius`` when
    ``direction_opt``) and, per line, ``linearProgram1``'s point on it bounded by the disc and
    the valid lines before it. Returns ``(cx, cy, usable)`` of shape ``(..., L + 1)``."""
    n_lines = px.shape[-1]
    r = radius[..., None]
    pd = px * dx + py * dy
    disc = pd * pd + r * r - (px * px + py * py)
    ok = valid & (disc >= 0.0)
    root = np.sqrt(np.maximum(disc, 0.0))
    t_left, t_right = -pd - root, -pd + root
    if n_lines > 1:
        # [..., i, j]: line i against an earlier line j.
        dxi, dyi, pxi, pyi = dx[..., :, None], dy[..., :, None], px[..., :, None], py[..., :, None]
        dxj, dyj, pxj, pyj = dx[..., None, :], dy[..., None, :], px[..., None, :], py[..., None, :]
        den = dxi * dyj - dyi * dxj
        num = dxj * (pyi - pyj) - dyj * (pxi - pxj)
        earlier = _strictly_lower(n_lines) & valid[..., None, :]
        parallel = np.abs(den) <= RVO_EPSILON
        ok &= ~np.any(earlier & parallel & (num < 0.0), axis=-1)
        use = earlier & ~parallel
        t = num / np.where(parallel, 1.0, den)
        t_right = np.minimum(t_right, np.min(np.where(use & (den >= 0.0), t, np.inf), axis=-1))
        t_left = np.maximum(t_left, np.max(np.where(use & (den < 0.0), t, -np.inf), axis=-1))
        ok &= t_left <= t_right
    ox_, oy_ = ox[..., None], oy[..., None]
    if direction_opt:
        t = np.where(ox_ * dx + oy_ * dy > 0.0, t_right, t_left)
        sx, sy = ox * radius, oy * radius
    else:
        t = np.minimum(np.maximum(dx * (ox_ - px) + dy * (oy_ - py), t_left), t_right)
        n2 = ox * ox + oy * oy
        over = n2 > radius * radius
        scale = np.where(over, radius / np.sqrt(np.where(over, n2, 1.0)), 1.0)
        sx, sy = ox * scale, oy * scale
    cx = np.concatenate([sx[..., None], px + t * dx], axis=-1)
    cy = np.concatenate([sy[..., None], py + t * dy], axis=-1)
    usable = np.concatenate([np.ones((*ok.shape[:-1], 1), bool), ok], axis=-1)
    return cx, cy, usable


def _keeps(cx, cy, px, py, dx, dy, valid) -> np.ndarray:
    """``[..., c, j]``: candidate ``c`` keeps (valid) line ``j``."""
    off = (
        (dx * py - dy * px)[..., None, :]
        - dx[..., None, :] * cy[..., :, None]
        + dy[..., None, :] * cx[..., :, None]
    )
    return (off <= FEASIBLE_TOL) | ~valid[..., None, :]


def _pick(cx, cy, fit, score) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The fitting candidate of least ``score`` of each row ``(A, C)``: ``(x, y, any_fit)``."""
    best = np.argmin(np.where(fit, score, np.inf), axis=-1)
    rows = np.arange(len(cx))
    return cx[rows, best], cy[rows, best], fit.any(axis=-1)


def _scan(cx, cy, usable, px, py, dx, dy, valid):
    """RVO2's ``linearProgram2`` run line by line over precomputed candidates (exact also where
    its tolerances for nearly parallel lines matter): ``(x, y, fail)``, ``fail`` the line it
    stopped at (``L`` when it did not)."""
    n_lines = px.shape[-1]
    x, y = cx[..., 0], cy[..., 0]
    fail = np.full(x.shape, n_lines)
    for k in range(n_lines):
        hit = (
            (fail == n_lines)
            & valid[..., k]
            & (dx[..., k] * (py[..., k] - y) - dy[..., k] * (px[..., k] - x) > 0)
        )
        take = hit & usable[..., k + 1]
        x, y = np.where(take, cx[..., k + 1], x), np.where(take, cy[..., k + 1], y)
        fail = np.where(hit & ~usable[..., k + 1], k, fail)
    return x, y, fail


def _linear_program(px, py, dx, dy, valid, n_static: int, radius, ox, oy):
    """RVO2's ``linearProgram2`` and, where it fails, ``linearProgram3`` for lines ``(A, L)``
    (the first ``n_static`` static): the velocities ``(x, y)`` ``(A,)``."""
    n2 = ox * ox + oy * oy
    over = n2 > radius * radius
    scale = np.where(over, radius / np.sqrt(np.where(over, n2, 1.0)), 1.0)
    x, y = ox * scale, oy * scale
    # Most agents' preferred velocity (clipped to the disc) keeps every line: RVO2 stops there.
    busy = np.flatnonzero(np.any(valid & (dx * (py - y[:, None]) - dy * (px - x[:, None]) > 0.0), axis=1))
    if not len(busy):
        return x, y
    px, py, dx, dy, valid, radius, ox, oy = (v[busy] for v in (px, py, dx, dy, valid, radius, ox, oy))
    cx, cy, usable = _candidates(px, py, dx, dy, valid, radius, ox, oy, False)
    keeps = _keeps(cx, cy, px, py, dx, dy, valid)
    score = (cx - ox[:, None]) ** 2 + (cy - oy[:, None]) ** 2
    bx, by, feasible = _pick(cx, cy, usable & np.all(keeps, axis=-1), score)
    stuck = np.flatnonzero(~feasible)
    if len(stuck):
        # RVO2 fails at the first line whose prefix leaves nothing feasible, holding the
        # optimum of the lines before it.
        usable, keeps = usable[stuck], keeps[stuck]
        prefix = np.logical_and.accumulate(keeps, axis=-1) & usable[..., None]
        begin = np.argmin(np.any(prefix, axis=-2), axis=-1)
        before = np.concatenate([usable[..., None], prefix], axis=-1)
        fit = np.take_along_axis(before, begin[:, None, None], -1)[..., 0]
        sx, sy, _ = _pick(cx[stuck], cy[stuck], fit, score[stuck])
        bx[stuck], by[stuck] = _least_violation(
            px[stuck], py[stuck], dx[stuck], dy[stuck], valid[stuck], n_static, radius[stuck], sx, sy, begin
        )
    x[busy], y[busy] = bx, by
    return x, y


@functools.lru_cache(maxsize=64)
def _triangle(n_lines: int, first: int) -> dict[str, np.ndarray]:
    """Index layout of the sub-problems ``i`` in ``[first, n_lines)`` of ``linearProgram3``,
    each over its lines ``j < i``: *slots* ``(i, k)`` (line ``k``'s point of sub-problem
    ``i``), *triples* ``(i, k, j)``, ``j < k`` (line ``j`` bounding slot ``(i, k)``), the
    candidates ``(i, c)`` (``c = 0`` the start, ``c = k + 1`` slot ``(i, k)``) and *checks*
    ``(i, c, j)``; each group of triples and checks leads with a dummy entry, so that
    ``ufunc.reduceat`` sees no empty group. Flat ``i * n_lines + j`` index the dense arrays."""
    slot_i, slot_k, tri_slot, tri_j, tri_real, tri_start = [], [], [], [], [], []
    cand_i, cand_slot, chk_cand, chk_j, chk_real, chk_start = [], [], [], [], [], []
    for i in range(first, n_lines):
        base = len(slot_i)
        for k in range(i):
            tri_start.append(len(tri_slot))
            tri_slot += [len(slot_i)] * (k + 1)
            tri_j += [0, *range(k)]
            tri_real += [False] + [True] * k
            slot_i.append(i)
            slot_k.append(k)
        for c in range(i + 1):
            chk_start.append(len(chk_cand))
            chk_cand += [len(cand_i)] * (i + 1)
            chk_j += [0, *range(i)]
            chk_real += [False] + [True] * i
            cand_i.append(i)
            cand_slot.append(base + c - 1 if c else -1)
    a = np.asarray
    cand_c = np.concatenate([np.zeros(0, int), *(np.arange(i + 1) for i in range(first, n_lines))])
    cand_of = np.zeros((n_lines, n_lines + 1), int)  # [i, c]: the candidate's flat index
    cand_of[a(cand_i, int), cand_c] = np.arange(len(cand_i))
    slot_i, slot_k, tri_slot, tri_j = a(slot_i, int), a(slot_k, int), a(tri_slot, int), a(tri_j, int)
    cand_i, chk_cand, chk_j = a(cand_i, int), a(chk_cand, int), a(chk_j, int)
    return {
        "slot": slot_i * n_lines + slot_k,
        "slot_i": slot_i,
        "tri_slot": tri_slot,
        "tri_k": (slot_i * n_lines + slot_k)[tri_slot],
        "tri_j": slot_i[tri_slot] * n_lines + tri_j,
        "tri_real": a(tri_real, bool),
        "tri_start": a(tri_start, int),
        "cand_i": cand_i,
        "cand_slot": a(cand_slot, int),
        "chk_cand": chk_cand,
        "chk_j": cand_i[chk_cand] * n_lines + chk_j,
        "chk_real": a(chk_real, bool),
        "chk_start": a(chk_start, int),
        "cand_c": cand_c,
        "cand_of": cand_of,
    }


def _solve_projected(qx, qy, ex, ey, sub_valid, radius, opt_x, opt_y, first: int):
    """``linearProgram2`` (direction-optimal) of ``linearProgram3``'s sub-problems ``i >= first``
    (dense ``[a, i, j]`` lines, sub-problem ``i`` over lines ``j < i``), by the candidate rule
    over only the line pairs and triples a sub-problem has: ``(x, y, ok)`` of shape ``(A, L)``."""
    n_agents, n_lines = opt_x.shape
    if first >= n_lines:
        return np.zeros(opt_x.shape), np.zeros(opt_x.shape), np.zeros(opt_x.shape, bool)
    lay = _triangle(n_lines, first)
    qx, qy, ex, ey = (v.reshape(n_agents, -1) for v in (qx, qy, ex, ey))
    sv = sub_valid.reshape(n_agents, -1)
    r = radius[:, None]
    slot = lay["slot"]
    px, py, dx, dy = qx[:, slot], qy[:, slot], ex[:, slot], ey[:, slot]
    pd = px * dx + py * dy
    disc = pd * pd + r * r - (px * px + py * py)
    ok = sv[:, slot] & (disc >= 0.0)
    root = np.sqrt(np.maximum(disc, 0.0))
    t_left, t_right = -pd - root, -pd + root
    if len(lay["tri_slot"]):
        k, j, starts = lay["tri_k"], lay["tri_j"], lay["tri_start"]
        dxk, dyk, pxk, pyk = ex[:, k], ey[:, k], qx[:, k], qy[:, k]
        dxj, dyj = ex[:, j], ey[:, j]
        den = dxk * dyj - dyk * dxj
        num = dxj * (pyk - qy[:, j]) - dyj * (pxk - qx[:, j])
        use = lay["tri_real"] & sv[:, j]
        parallel = np.abs(den) <= RVO_EPSILON
        ok &= ~np.logical_or.reduceat(use & parallel & (num < 0.0), starts, axis=1)
        use &= ~parallel
        t = num / np.where(parallel, 1.0, den)
        t_right = np.minimum(
            t_right, np.minimum.reduceat(np.where(use & (den >= 0.0), t, np.inf), starts, axis=1)
        )
        t_left = np.maximum(
            t_left, np.maximum.reduceat(np.where(use & (den < 0.0), t, -np.inf), starts, axis=1)
        )
        ok &= t_left <= t_right
    ox, oy = opt_x[:, lay["slot_i"]], opt_y[:, lay["slot_i"]]
    t = np.where(ox * dx + oy * dy > 0.0, t_right, t_left)
    sx, sy = px + t * dx, py + t * dy
    # Candidates: the start of each sub-problem, then its slots.
    ci, cs = lay["cand_i"], lay["cand_slot"]
    start = cs < 0
    cx = np.where(start, opt_x[:, ci] * r, sx[:, cs])
    cy = np.where(start, opt_y[:, ci] * r, sy[:, cs])
    usable = start | ok[:, cs]
    cc, cj = lay["chk_cand"], lay["chk_j"]
    off = ex[:, cj] * qy[:, cj] - ey[:, cj] * qx[:, cj] - ex[:, cj] * cy[:, cc] + ey[:, cj] * cx[:, cc]
    keeps = (off <= FEASIBLE_TOL) | ~sv[:, cj] | ~lay["chk_real"]
    fit = usable & np.logical_and.reduceat(keeps, lay["chk_start"], axis=1)
    score = -(cx * opt_x[:, ci] + cy * opt_y[:, ci])
    # Dense [a, i, c] for the choice per sub-problem.
    dense = np.full((n_agents, n_lines, n_lines + 1), np.inf)
    dense[:, ci, lay["cand_c"]] = np.where(fit, score, np.inf)
    best = np.argmin(dense, axis=-1)
    rows, subs = np.arange(n_agents)[:, None], np.arange(n_lines)[None, :]
    pick = lay["cand_of"][subs, best]
    return cx[rows, pick], cy[rows, pick], np.isfinite(dense[rows, subs, best])


def _least_violation(px, py, dx, dy, valid, n_static: int, radius, sx, sy, begin):
    """RVO2's ``linearProgram3`` for agents whose lines leave nothing feasible (first failing
    at line ``begin``, holding ``(sx, sy)`` then): the velocity whose worst violation of an
    agent line is least, static lines kept. Line ``i``'s step maximises the distance into
    line ``i`` keeping the static lines and 'no agent line ``j < i`` worse than ``i``'."""
    n_lines = px.shape[-1]
    # [a, i, j]: the sub-problem of line i, its line j.
    dxi, dyi, pxi, pyi = dx[:, :, None], dy[:, :, None], px[:, :, None], py[:, :, None]
    dxj, dyj, pxj, pyj = dx[:, None, :], dy[:, None, :], px[:, None, :], py[:, None, :]
    det = dxi * dyj - dyi * dxj
    parallel = np.abs(det) <= RVO_EPSILON
    same = parallel & (dxi * dxj + dyi * dyj > 0.0)
    t = (dxj * (pyi - pyj) - dyj * (pxi - pxj)) / np.where(parallel, 1.0, det)
    qx = np.where(parallel, 0.5 * (pxi + pxj), pxi + t * dxi)
    qy = np.where(parallel, 0.5 * (pyi + pyj), pyi + t * dyi)
    ex, ey, _ = _unit(dxj - dxi, dyj - dyi)
    static = np.arange(n_lines) < n_static
    stat_b = np.broadcast_to(static, det.shape)
    qx = np.where(stat_b, pxj, qx)
    qy = np.where(stat_b, pyj, qy)
    ex = np.where(stat_b, dxj, ex)
    ey = np.where(stat_b, dyj, ey)
    projected = _strictly_lower(n_lines) & ~static[None, :] & ~same
    sub_valid = valid[:, None, :] & (stat_b | projected)
    opt_x, opt_y = -dy, dx
    rad = np.broadcast_to(radius[:, None], opt_x.shape)
    rx, ry = sx.copy(), sy.copy()
    reg = np.flatnonzero(begin >= n_static)
    if len(reg):
        first = int(begin[reg].min())  # sub-problems before any begin are never taken
        sub = (qx[reg], qy[reg], ex[reg], ey[reg], sub_valid[reg])
        x, y, ok = _solve_projected(*sub, radius[reg], opt_x[reg], opt_y[reg], first)
        # The worst violation of an agent line by each sub-problem's answer.
        lx, ly, lpx, lpy, lv = dx[reg], dy[reg], px[reg], py[reg], valid[reg]
        off = (
            (lx * lpy - ly * lpx)[:, None, :]
            - lx[:, None, :] * y[:, :, None]
            + ly[:, None, :] * x[:, :, None]
        )
        worst = np.max(np.where(lv[:, None, :] & ~static, off, -np.inf), axis=-1)
        take = ok & lv & ~static & (np.arange(n_lines) >= begin[reg][:, None])
        bx, by, found = _pick(x, y, take, worst)
        rx[reg], ry[reg] = np.where(found, bx, sx[reg]), np.where(found, by, sy[reg])
    odd = np.flatnonzero(begin < n_static)
    if len(odd):
        # The static lines themselves conflict: RVO2's steps depend on its tolerances; take them.
        sub = (qx[odd], qy[odd], ex[odd], ey[odd], sub_valid[odd])
        cx, cy, usable = _candidates(*sub, rad[odd], opt_x[odd], opt_y[odd], True)
        x, y, fail = _scan(cx, cy, usable, *sub)
        ok = fail == n_lines
        valid, begin = valid[odd], begin[odd]
        dx, dy, px, py = dx[odd], dy[odd], px[odd], py[odd]
        ux, uy, dist = sx[odd], sy[odd], np.zeros(len(odd))
        for i in range(int(begin.min()), n_lines):
            hit = (
                (begin <= i) & valid[:, i] & (dx[:, i] * (py[:, i] - uy) - dy[:, i] * (px[:, i] - ux) > dist)
            )
            ux, uy = np.where(hit & ok[:, i], x[:, i], ux), np.where(hit & ok[:, i], y[:, i], uy)
            dist = np.where(hit, dx[:, i] * (py[:, i] - uy) - dy[:, i] * (px[:, i] - ux), dist)
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
        if np.array_equal(nb[:, 0], me):
            dist, nb = dist[:, 1:], nb[:, 1:]
        else:
            order = np.argsort(nb == me[:, None], axis=1, kind="stable")[:, :k]
            dist, nb = np.take_along_axis(dist, order, 1), np.take_along_axis(nb, order, 1)
        idx[e] = np.minimum(nb, n - 1)
        d = dist
        present[e] = d * d < r2
    return idx, present


def _present_columns(valid: np.ndarray, n_static: int) -> tuple[np.ndarray | None, int]:
    """Per agent the columns of its lines to keep, ``(A, L')``, present static lines first
    (in order), then the neighbours (present ones come first already), ``L'`` the most any
    agent has; and the new count of static columns. None where nothing can be dropped."""
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
    try:
        return np.broadcast_to(np.asarray(x, dtype=np.float64), shape)
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
    radius or a non-finite point is no obstacle.

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
    vx, vy = vel[..., 0], vel[..., 1]
    # Per line: relative position, relative velocity, combined radius, 1/tau, share, present.
    parts = []
    n_static = 0
    if static is not None:
        sp, sr = static
        sp = np.asarray(sp, dtype=np.float64)
        if sp.ndim < 3 or sp.shape[:-2] != (*batch, n) or sp.shape[-1] != 2:
            raise ValueError(f"static points: expected shape {(*batch, n, 'S', 2)}, got {sp.shape}")
        n_static = sp.shape[-2]
        sr = _as_agents(sr, sp.shape[:-1], "static radii").reshape(b, n, n_static)
        sp = sp.reshape(b, n, n_static, 2)
        present = (sr >= 0) & np.all(np.isfinite(sp), axis=-1)
        rel = np.where(present[..., None], sp - p[:, :, None], 1e6)
        shape = present.shape
        parts.append(
            (rel[..., 0], rel[..., 1], np.broadcast_to(vx[..., None], shape),
             np.broadcast_to(vy[..., None], shape), rad[..., None] + sr, np.full(shape, 1.0 / tau_static),
             np.ones(shape), present)
        )  # fmt: skip
    k = min(max_neighbors, n - 1)
    if k > 0:
        near, present = _neighbours(p, k, neighbor_dist)
        bi = np.arange(b)[:, None, None]
        rel = p[bi, near] - p[:, :, None]
        rv = vel[:, :, None] - vel[bi, near]
        parts.append(
            (rel[..., 0], rel[..., 1], rv[..., 0], rv[..., 1], rad[:, :, None] + rad[bi, near],
             np.full(present.shape, 1.0 / tau), np.where(coop[bi, near], 0.5, 1.0), present)
        )  # fmt: skip
    if not parts:
        px_, py_ = pref[..., 0], pref[..., 1]
        n2 = px_ * px_ + py_ * py_
        over = n2 > vmax**2
        scale = np.where(over, vmax / np.sqrt(np.where(over, n2, 1.0)), 1.0)[..., None]
        return np.where(coop[..., None], pref * scale, vel).reshape(pos.shape)
    rx, ry, rvx, rvy, comb, inv_tau, share, valid = (
        (c[0] if len(c) == 1 else np.concatenate(c, axis=-1)).reshape(b * n, -1)
        for c in zip(*parts, strict=True)
    )
    # Lines no agent has are dropped (absent static discs moved last first): the answer of
    # each agent depends only on its present lines, in order.
    cols, n_static = _present_columns(valid, n_static)
    if cols is not None:
        rows = np.arange(len(cols))[:, None]
        rx, ry, rvx, rvy, comb, inv_tau, share, valid = (
            v[rows, cols] for v in (rx, ry, rvx, rvy, comb, inv_tau, share, valid)
        )
    dx, dy, ux, uy = half_planes(rx, ry, rvx, rvy, comb, inv_tau, 1.0 / dt)
    px = vx.reshape(-1, 1) + share * ux
    py = vy.reshape(-1, 1) + share * uy
    r_max = vmax.reshape(-1)
    ox, oy = pref[..., 0].reshape(-1), pref[..., 1].reshape(-1)
    x, y = _linear_program(px, py, dx, dy, valid, n_static, r_max, ox, oy)
    out = np.where(coop.reshape(-1)[:, None], np.stack([x, y], axis=-1), vel.reshape(-1, 2))
    return out.reshape(pos.shape)
