"""Following a path and avoiding moving agents, for a unicycle (forward speed and yaw rate):
the point a given distance ahead on a path, pure pursuit along it, and the command nearest a
desired one whose predicted arc keeps clear of agents. Lengths in metres, angles in
radians, speeds in m/s and rad/s.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence

import numpy as np


def _wrap(a: float) -> float:
    return (a + math.pi) % (2.0 * math.pi) - math.pi


def _closest_on_path(path: np.ndarray, xy: np.ndarray) -> tuple[float, np.ndarray]:
    """Arc length (m) of the point of ``path`` nearest ``xy``, and the cumulative arc length
    at each vertex."""
    seg = np.diff(path, axis=0)
    lengths = np.hypot(seg[:, 0], seg[:, 1])
    cum = np.concatenate(([0.0], np.cumsum(lengths)))
    if len(seg) == 0:
        return 0.0, cum
    sq = np.maximum(lengths**2, 1e-18)
    t = np.clip(((xy - path[:-1]) * seg).sum(axis=1) / sq, 0.0, 1.0)
    foot = path[:-1] + t[:, None] * seg
    k = int(np.argmin(np.hypot(*(foot - xy).T)))
    return float(cum[k] + t[k] * lengths[k]), cum


def _point_at(path: np.ndarray, cum: np.ndarray, s: float) -> np.ndarray:
    s = min(max(s, 0.0), float(cum[-1]))
    k = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(path) - 2)) if len(path) > 1 else 0
    if len(path) == 1:
        return path[0].copy()
    length = cum[k + 1] - cum[k]
    t = 0.0 if length <= 0 else (s - cum[k]) / length
    return path[k] + t * (path[k + 1] - path[k])


def point_ahead(path: np.ndarray, xy: Sequence[float], ahead: float) -> np.ndarray:
    """The point ``ahead`` m along ``path`` (``(K, 2)``, m) past the point of it nearest
    ``xy``, at most its end."""
    path = np.asarray(path, dtype=np.float64)
    s, cum = _closest_on_path(path, np.asarray(xy, dtype=np.float64)[:2])
    return _point_at(path, cum, s + ahead)


def pure_pursuit(
    pose: Sequence[float],
    path_xy: np.ndarray,
    lookahead: float,
    max_speed: float,
    max_yaw_rate: float,
    *,
    slow_radius: float = 1.0,
    turn_in_place: float = math.pi / 4,
    sharp_turn: float = math.pi / 6,
    corner_radius: float = 0.1,
    yaw_gain: float = 2.5,
) -> tuple[float, float]:
    """Forward speed ``v`` (m/s) and yaw rate ``w`` (rad/s) that steer a unicycle at
    ``pose = (x, y, yaw)`` (m, m, rad) along ``path_xy`` (``(K, 2)``, m).

    The target is the point ``lookahead`` metres of path beyond the path point nearest the
    robot, but never past a vertex that turns by more than ``sharp_turn`` unless the robot
    is within ``corner_radius`` of it, so the robot does not cut sharp corners. The command
    follows the pure-pursuit arc through the target (curvature ``2 sin(alpha) / d``), at
    ``max_speed`` scaled by ``cos(alpha)`` on turns, linearly down to zero within
    ``slow_radius`` of the path's end, and slower still when the arc would need more than
    ``max_yaw_rate``; when the target lies more than ``turn_in_place`` off the heading the
    robot turns on the spot. The yaw rate never exceeds ``yaw_gain`` (1/s) times the heading
    error, so a robot whose turning lags one control step does not overshoot and weave.
    Returns ``(0, 0)`` at the end of the path.
    """
    x, y, yaw = (float(v) for v in pose)
    path = np.asarray(path_xy, dtype=np.float64).reshape(-1, 2)
    if len(path) == 0:
        raise ValueError("path_xy: expected at least one (x, y) point")
    if not (lookahead > 0 and max_speed > 0 and max_yaw_rate > 0):
        raise ValueError(
            "pure_pursuit: lookahead (m), max_speed (m/s) and max_yaw_rate (rad/s) must be positive, got "
            f"{lookahead!r}, {max_speed!r}, {max_yaw_rate!r}"
        )
    xy = np.array([x, y])
    s0, cum = _closest_on_path(path, xy)
    total = float(cum[-1])
    s_target = s0 + lookahead
    # Stop at the first sharp vertex ahead (beyond corner_radius), so the chord hugs the path.
    for k in range(1, len(path) - 1):
        if cum[k] <= s0 + corner_radius:
            continue
        if cum[k] >= s_target:
            break
        a, b = path[k] - path[k - 1], path[k + 1] - path[k]
        if abs(_wrap(math.atan2(b[1], b[0]) - math.atan2(a[1], a[0]))) > sharp_turn:
            s_target = float(cum[k])
            break
    target = _point_at(path, cum, s_target)
    to_goal = float(np.hypot(*(path[-1] - xy)))
    if s_target >= total - 1e-9:
        target = path[-1]
    d = float(np.hypot(*(target - xy)))
    if d < 1e-6 or to_goal < 1e-3:
        return 0.0, 0.0
    alpha = _wrap(math.atan2(target[1] - y, target[0] - x) - yaw)
    turn_cap = min(max_yaw_rate, yaw_gain * abs(alpha))
    if abs(alpha) > turn_in_place:
        return 0.0, math.copysign(turn_cap, alpha)
    remaining = total - s0 + float(np.hypot(*(path[0] - xy))) * (len(path) == 1)
    v = max_speed * math.cos(alpha) * min(1.0, max(remaining, to_goal) / slow_radius)
    v = min(v, to_goal / 0.1 * max_speed) if to_goal < 0.1 else v
    curvature = 2.0 * math.sin(alpha) / d
    w = v * curvature
    if abs(w) > turn_cap:
        v, w = turn_cap / abs(curvature), math.copysign(turn_cap, w)
    return float(v), float(w)


def _unicycle(
    pose: np.ndarray, v: np.ndarray, w: np.ndarray, times: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Positions ``(C, T)`` x and y of a unicycle at ``pose`` after each time in ``times``
    under each constant command ``(v[c], w[c])`` (exact arcs)."""
    x, y, yaw = pose
    t = times[None, :]
    w_ = w[:, None]
    v_ = v[:, None]
    straight = np.abs(w_) < 1e-9
    safe_w = np.where(straight, 1.0, w_)
    heading = yaw + w_ * t
    xs = np.where(straight, x + v_ * t * math.cos(yaw), x + v_ / safe_w * (np.sin(heading) - math.sin(yaw)))
    ys = np.where(straight, y + v_ * t * math.sin(yaw), y - v_ / safe_w * (np.cos(heading) - math.cos(yaw)))
    return xs, ys


def avoid(
    pose: Sequence[float],
    v: float,
    w: float,
    others_xy: np.ndarray,
    others_vel: np.ndarray,
    others_radius: np.ndarray | float,
    robot_radius: float,
    horizon: float,
    *,
    max_speed: float | None = None,
    max_yaw_rate: float = 1.5,
    min_speed: float = 0.0,
    dt: float = 0.1,
    margin: float = 0.05,
    samples: tuple[int, int] = (7, 15),
    free_at: Callable[[np.ndarray, np.ndarray], np.ndarray] | None = None,
    clearance: float = 1.0,
    clearance_weight: float = 0.5,
) -> tuple[float, float]:
    """The command ``(v, w)`` (m/s, rad/s) nearest the desired one whose predicted arc keeps
    clear of moving agents for ``horizon`` seconds.

    Agents are discs at ``others_xy`` (``(N, 2)``, m) moving at constant ``others_vel``
    (``(N, 2)``, m/s) with ``others_radius`` (m, scalar or ``(N,)``); the robot is a disc of
    ``robot_radius`` following the exact arc of each constant command, checked every ``dt``
    seconds. A command is safe when the robot's distance to every agent stays above the sum
    of radii plus ``margin`` (for an agent already closer, when it does not shrink). The
    desired command is returned unchanged when it is safe; otherwise the safe one among a
    ``samples = (n_v, n_w)`` lattice over ``[min_speed, max_speed] x [-max_yaw_rate,
    max_yaw_rate]`` of least cost: the squared distance to the desired command (speeds
    relative to ``max_speed``, default the larger of ``|v|`` and 1 m/s; yaw rates to
    ``max_yaw_rate``) plus ``clearance_weight`` times how far the closest approach falls
    short of ``clearance`` metres of slack (0..1), which keeps it from merely slowing down to
    push a conflict past the horizon and from swapping sides step by step. Arcs must also keep
    ``free_at(xs, ys)`` (a callable giving True where a position is free of static obstacles)
    True when given. When no command is safe, the one with the widest closest approach,
    slowest first.
    """
    others = np.asarray(others_xy, dtype=np.float64).reshape(-1, 2)
    vel = np.asarray(others_vel, dtype=np.float64).reshape(-1, 2)
    if vel.shape != others.shape:
        raise ValueError(f"others_vel: expected shape {others.shape} like others_xy, got {vel.shape}")
    if len(others) == 0:
        return float(v), float(w)
    if not (horizon > 0 and dt > 0):
        raise ValueError(f"avoid: horizon and dt must be positive seconds, got {horizon!r}, {dt!r}")
    radii = np.broadcast_to(np.asarray(others_radius, dtype=np.float64), (len(others),))
    vmax = float(max_speed) if max_speed is not None else max(abs(float(v)), 1.0)
    nv, nw = samples
    vs, ws = np.meshgrid(np.linspace(min_speed, vmax, nv), np.linspace(-max_yaw_rate, max_yaw_rate, nw))
    cand_v = np.concatenate(([float(v)], vs.ravel()))
    cand_w = np.concatenate(([float(w)], ws.ravel()))
    times = np.arange(1, math.ceil(horizon / dt - 1e-9) + 1) * dt
    xs, ys = _unicycle(np.asarray(pose, dtype=np.float64), cand_v, cand_w, times)  # (C, T)
    ox = others[:, 0, None] + vel[:, 0, None] * times[None, :]  # (N, T)
    oy = others[:, 1, None] + vel[:, 1, None] * times[None, :]
    dist = np.hypot(xs[:, None, :] - ox[None], ys[:, None, :] - oy[None])  # (C, N, T)
    d0 = np.hypot(others[:, 0] - pose[0], others[:, 1] - pose[1])
    clear = radii + robot_radius + margin
    limit = np.minimum(clear, d0 - 1e-9)  # an agent already too close must not get closer
    gap = (dist - limit[None, :, None]).min(axis=(1, 2))  # (C,) m: the closest approach's slack
    conflict = (dist < limit[None, :, None]).any(axis=1)  # (C, T)
    if free_at is not None:
        conflict |= ~np.asarray(free_at(xs, ys), dtype=bool)
    safe = ~conflict.any(axis=1)
    if safe[0]:
        return float(v), float(w)
    if safe.any():
        cost = ((cand_v - v) / vmax) ** 2 + ((cand_w - w) / max_yaw_rate) ** 2
        cost += clearance_weight * (1.0 - np.clip(gap, 0.0, clearance) / clearance)
        k = int(np.argmin(np.where(safe, cost, np.inf)))
    else:  # the widest berth, slowest first
        k = int(np.lexsort((np.abs(cand_v), -np.round(gap, 6)))[0])
    return float(cand_v[k]), float(cand_w[k])
