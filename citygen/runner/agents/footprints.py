"""Vehicles' footprints as people see them: oriented rectangles, the discs that cover them
(moving obstacles for ORCA) and how deep a disc reaches into one.

A vehicle of length ``L`` and width ``W`` is covered by ``n = ceil(L / W)`` discs on its axis,
``L / n`` apart, of radius ``hypot(W / 2, L / 2n)``: each covers its ``L / n`` slice of the
rectangle corner to corner, so a person kept out of the discs is kept out of the vehicle.

>>> import numpy as np
>>> car = Footprints(np.zeros((1, 2)), np.zeros(1), np.array([4.0]), np.array([2.0]), np.array([5.0]))
>>> centres, radii, vel = covering_discs(car)
>>> centres.tolist(), radii.round(3).tolist(), vel.tolist()
([[-1.0, 0.0], [1.0, 0.0]], [1.414, 1.414], [[5.0, 0.0], [5.0, 0.0]])
>>> depth(np.array([[0.0, 1.5], [2.5, 0.0]]), np.array([0.3, 0.3]), car).round(2).tolist()
[-0.2, -0.2]
>>> depth(np.array([[2.5, 0.0]]), np.array([0.3]), car, ahead=0.1).round(2).tolist()  # 0.5 m ahead
[0.3]
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class Footprints(NamedTuple):
    """Vehicles' footprints: centres ``pos`` ``(M, 2)`` (m), headings ``yaw`` ``(M,)`` (rad),
    ``length`` and ``width`` ``(M,)`` (m), and ``speed`` ``(M,)`` (m/s along the heading)."""

    pos: np.ndarray
    yaw: np.ndarray
    length: np.ndarray
    width: np.ndarray
    speed: np.ndarray


def rectangles(pos: np.ndarray, yaw: np.ndarray, length: np.ndarray, width: np.ndarray) -> np.ndarray:
    """Corners ``(M, 4, 2)`` of vehicles' footprints."""
    c, s = np.cos(yaw), np.sin(yaw)
    fwd = np.stack([c, s], axis=-1) * (length / 2)[:, None]
    side = np.stack([-s, c], axis=-1) * (width / 2)[:, None]
    return np.stack([pos + fwd + side, pos - fwd + side, pos - fwd - side, pos + fwd - side], axis=1)


def covering_discs(fp: Footprints) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Centres ``(D, 2)`` (m), radii ``(D,)`` (m) and velocities ``(D, 2)`` (m/s) of discs that
    cover every footprint (see the module docstring), vehicle by vehicle."""
    width = np.maximum(np.asarray(fp.width, dtype=np.float64), 1e-3)
    length = np.asarray(fp.length, dtype=np.float64)
    n = np.maximum(np.ceil(length / width - 1e-9), 1).astype(np.int64)
    owner = np.repeat(np.arange(len(n)), n)
    k = np.arange(len(owner)) - np.repeat(np.cumsum(n) - n, n)  # index of the disc on its vehicle
    slice_ = (length / n)[owner]
    along = (k + 0.5) * slice_ - length[owner] / 2
    fwd = np.stack([np.cos(fp.yaw), np.sin(fp.yaw)], axis=-1).reshape(-1, 2)[owner]
    centres = np.asarray(fp.pos, dtype=np.float64).reshape(-1, 2)[owner] + fwd * along[:, None]
    radii = np.hypot(width[owner] / 2, slice_ / 2)
    return centres, radii, fwd * np.asarray(fp.speed, dtype=np.float64)[owner, None]


def depth(xy: np.ndarray, radius: np.ndarray, fp: Footprints, *, ahead: float = 0.0) -> np.ndarray:
    """Per disc (centres ``xy`` ``(N, 2)``, radii ``(N,)``, m) how far (m) it reaches into the
    footprint it reaches deepest into (negative: its gap to the nearest); each footprint
    lengthened forwards by ``ahead`` seconds of its speed (the ground its next step covers)."""
    xy = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    radius = np.asarray(radius, dtype=np.float64).reshape(-1)
    if not len(fp.pos) or not len(xy):
        return np.full(len(xy), -np.inf)
    fwd = np.stack([np.cos(fp.yaw), np.sin(fp.yaw)], axis=-1)
    grow = np.maximum(np.asarray(fp.speed, dtype=np.float64), 0.0) * ahead
    centre = fp.pos + fwd * (grow / 2)[:, None]
    rel = xy[:, None] - centre[None]  # (N, M, 2)
    u = np.abs(rel[..., 0] * fwd[:, 0] + rel[..., 1] * fwd[:, 1]) - (fp.length + grow) / 2
    w = np.abs(rel[..., 1] * fwd[:, 0] - rel[..., 0] * fwd[:, 1]) - fp.width / 2
    outside = np.hypot(np.maximum(u, 0.0), np.maximum(w, 0.0)) + np.minimum(np.maximum(u, w), 0.0)
    return np.max(radius[:, None] - outside, axis=1)
