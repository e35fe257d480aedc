"""ORCA's per-agent work compiled with numba: each agent's half-planes and RVO2's incremental
linear programs (``linearProgram1``, ``2`` and ``3`` of RVO2's ``Agent.cpp``), one agent after
another, as RVO2 runs them.

At a hundred agents the array form of :mod:`citygen.runner.agents.orca` pays numpy's cost per
call and per row more than the arithmetic; here the same work is a loop over lines compiled
once (``cache=True``: later processes load it from ``__pycache__``). The numpy form stays the
reference: ``tests/test_orca_kernel.py`` holds the two to float precision, and both to RVO2
through ``pyrvo``. Lines are per agent in order, the first ``n_static`` static (hard in
``linearProgram3``, as RVO2's obstacle lines); an absent line (``present == 0``) is skipped,
which is what the reference's never-violated stand-in line amounts to.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

RVO_EPSILON = 1e-5
"""RVO2's tolerance for parallel lines (its ``RVO_EPSILON``; the same as the reference's)."""


@njit(cache=True)
def _half_plane(rx, ry, vx, vy, combined, inv_tau, inv_dt):
    """RVO2's ORCA line of one neighbour (``half_planes`` of the reference, same arithmetic):
    ``(dx, dy, ux, uy)``."""
    dist2 = rx * rx + ry * ry
    r2 = combined * combined
    if dist2 <= r2:  # already overlapping: leave the velocity obstacle of one time step
        wx, wy = vx - rx * inv_dt, vy - ry * inv_dt
        n = math.sqrt(wx * wx + wy * wy)
        cx, cy = (wx / n, wy / n) if n > 1e-12 else (1.0, 0.0)
        k = combined * inv_dt - n
        return cy, -cx, k * cx, k * cy
    wx, wy = vx - rx * inv_tau, vy - ry * inv_tau
    w_len2 = wx * wx + wy * wy
    dotp = wx * rx + wy * ry
    if dotp < 0.0 and dotp * dotp > r2 * w_len2:  # projection on the cut-off circle
        n = math.sqrt(w_len2)
        cx, cy = (wx / n, wy / n) if n > 1e-12 else (1.0, 0.0)
        k = combined * inv_tau - n
        return cy, -cx, k * cx, k * cy
    # Projection on the legs of the cone (left or right as w lies).
    inv = 1.0 / dist2
    leg = math.sqrt(dist2 - r2)
    if not rx * wy - ry * wx > 0.0:
        leg = -leg
    dx = (rx * leg - ry * combined) * inv
    dy = (rx * combined + ry * leg) * inv
    proj = vx * dx + vy * dy
    return dx, dy, proj * dx - vx, proj * dy - vy


@njit(cache=True)
def _program1(px, py, dx, dy, no, radius, ox, oy, direction_opt):
    """RVO2's ``linearProgram1``: the velocity on line ``no`` within the disc and lines
    ``< no`` nearest to ``opt`` (or farthest along it): ``(ok, x, y)``."""
    dot = px[no] * dx[no] + py[no] * dy[no]
    disc = dot * dot + radius * radius - (px[no] * px[no] + py[no] * py[no])
    if disc < 0.0:
        return False, 0.0, 0.0
    root = math.sqrt(disc)
    t_left, t_right = -dot - root, root - dot
    for i in range(no):
        den = dx[no] * dy[i] - dy[no] * dx[i]
        num = dx[i] * (py[no] - py[i]) - dy[i] * (px[no] - px[i])
        if abs(den) <= RVO_EPSILON:
            if num < 0.0:
                return False, 0.0, 0.0
            continue
        t = num / den
        if den >= 0.0:
            t_right = min(t_right, t)
        else:
            t_left = max(t_left, t)
        if t_left > t_right:
            return False, 0.0, 0.0
    if direction_opt:
        t = t_right if ox * dx[no] + oy * dy[no] > 0.0 else t_left
    else:
        t = min(max(dx[no] * (ox - px[no]) + dy[no] * (oy - py[no]), t_left), t_right)
    return True, px[no] + t * dx[no], py[no] + t * dy[no]


@njit(cache=True)
def _program2(px, py, dx, dy, n, radius, ox, oy, direction_opt):
    """RVO2's ``linearProgram2`` over lines ``< n``: ``(fail, x, y)``, ``fail`` the line it
    stopped at (``n`` when it did not), ``(x, y)`` the velocity it holds."""
    if direction_opt:
        x, y = ox * radius, oy * radius
    else:
        n2 = ox * ox + oy * oy
        if n2 > radius * radius:
            s = radius / math.sqrt(n2)
            x, y = ox * s, oy * s
        else:
            x, y = ox, oy
    for i in range(n):
        if dx[i] * (py[i] - y) - dy[i] * (px[i] - x) > 0.0:
            ok, nx, ny = _program1(px, py, dx, dy, i, radius, ox, oy, direction_opt)
            if not ok:
                return i, x, y
            x, y = nx, ny
    return n, x, y


@njit(cache=True)
def _program3(px, py, dx, dy, n, n_static, begin, radius, x, y, qx, qy, ex, ey):
    """RVO2's ``linearProgram3``: from line ``begin`` on, the velocity whose worst violation
    of an agent line is least, the static lines kept (``qx .. ey`` scratch of length ``n``)."""
    distance = 0.0
    for i in range(begin, n):
        if dx[i] * (py[i] - y) - dy[i] * (px[i] - x) > distance:
            m = 0
            for j in range(n_static):
                qx[m], qy[m], ex[m], ey[m] = px[j], py[j], dx[j], dy[j]
                m += 1
            for j in range(n_static, i):
                det = dx[i] * dy[j] - dy[i] * dx[j]
                if abs(det) <= RVO_EPSILON:
                    if dx[i] * dx[j] + dy[i] * dy[j] > 0.0:
                        continue
                    qx[m], qy[m] = 0.5 * (px[i] + px[j]), 0.5 * (py[i] + py[j])
                else:
                    t = (dx[j] * (py[i] - py[j]) - dy[j] * (px[i] - px[j])) / det
                    qx[m], qy[m] = px[i] + t * dx[i], py[i] + t * dy[i]
                wx, wy = dx[j] - dx[i], dy[j] - dy[i]
                w = math.sqrt(wx * wx + wy * wy)
                ex[m], ey[m] = (wx / w, wy / w) if w > 1e-12 else (1.0, 0.0)
                m += 1
            fail, nx, ny = _program2(qx, qy, ex, ey, m, radius, -dy[i], dx[i], True)
            if fail == m:
                x, y = nx, ny
            distance = dx[i] * (py[i] - y) - dy[i] * (px[i] - x)
    return x, y


@njit(cache=True)
def solve(line, n_static, inv_tau, inv_tau_static, inv_dt, vel, pref, vmax):
    """New velocities ``(A, 2)`` of agents with lines ``line`` ``(7, A, L)`` (per line: relative
    position ``rx, ry`` (m), relative velocity ``vx, vy`` (m/s), combined radius (m), share of
    the avoidance, present (1 or 0); the first ``n_static`` static discs, seen ``inv_tau_static``
    ahead), own velocities ``vel`` and preferred ones ``pref`` ``(A, 2)``, top speeds ``vmax``
    ``(A,)``: RVO2's ``computeNewVelocity`` per agent."""
    n_agents, n_lines = line.shape[1], line.shape[2]
    out = np.empty((n_agents, 2))
    px, py, dx, dy = np.empty(n_lines), np.empty(n_lines), np.empty(n_lines), np.empty(n_lines)
    qx, qy, ex, ey = np.empty(n_lines), np.empty(n_lines), np.empty(n_lines), np.empty(n_lines)
    for a in range(n_agents):
        vx, vy = vel[a, 0], vel[a, 1]
        m = 0
        statics = 0
        for j in range(n_lines):
            if line[6, a, j] <= 0.5:
                continue
            tau = inv_tau_static if j < n_static else inv_tau
            hx, hy, ux, uy = _half_plane(
                line[0, a, j], line[1, a, j], line[2, a, j], line[3, a, j], line[4, a, j], tau, inv_dt
            )
            share = line[5, a, j]
            px[m], py[m], dx[m], dy[m] = vx + share * ux, vy + share * uy, hx, hy
            m += 1
            if j < n_static:
                statics += 1
        radius, ox, oy = vmax[a], pref[a, 0], pref[a, 1]
        fail, x, y = _program2(px, py, dx, dy, m, radius, ox, oy, False)
        if fail < m:
            x, y = _program3(px, py, dx, dy, m, statics, fail, radius, x, y, qx, qy, ex, ey)
        out[a, 0], out[a, 1] = x, y
    return out
