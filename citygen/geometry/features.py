"""Terrain features (front steps, ramps, landings) as heights and as convex solids.

A feature raises the ground inside its oriented rectangle to its surface (see
:mod:`citygen.spec.terrain`); :func:`raise_heights` applies every feature of a terrain to
heights already computed from its tiles, so :func:`citygen.geometry.terrain.height_at` and
everything built on it see them. Exporters build each feature from :func:`feature_boxes`:
oriented boxes that tile its rectangle (a ramp is one box pitched to its incline), each a
convex part every physics engine accepts.

>>> from citygen.spec.terrain import StepsFeature
>>> f = StepsFeature(id="s", kind="steps", center=(1.0, 0.0), length=2.0, width=1.0,
...     step_height=0.15, step_count=2, landing=1.0)
>>> raise_heights((f,), np.array([-0.5, 0.2, 0.6, 1.9]), np.zeros(4), np.zeros(4)).tolist()
[0.0, 0.15, 0.3, 0.3]
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from citygen.spec.terrain import LandingFeature, RampFeature, StepsFeature

AnyFeature = LandingFeature | StepsFeature | RampFeature

#: Side (m) of the buckets features are indexed by.
BUCKET = 8.0
#: Depth (m) a feature's solids reach below the ground it stands on.
FOOTING = 0.05

_LANDING, _STEPS, _RAMP = 0, 1, 2
_CODE = {LandingFeature: _LANDING, StepsFeature: _STEPS, RampFeature: _RAMP}


@dataclass(frozen=True)
class _Index:
    cx: np.ndarray
    cy: np.ndarray
    cos: np.ndarray
    sin: np.ndarray
    length: np.ndarray
    half_width: np.ndarray
    h: np.ndarray
    kind: np.ndarray
    a: np.ndarray  # steps: riser height; ramp: rise
    n: np.ndarray  # steps: count
    tread: np.ndarray  # steps: tread depth
    origin: tuple[float, float]
    shape: tuple[int, int]  # buckets along y, x
    starts: np.ndarray  # CSR over bucket ids
    members: np.ndarray


def _index(features: Sequence[AnyFeature]) -> _Index:
    m = len(features)
    cx = np.array([f.center[0] for f in features], dtype=np.float64)
    cy = np.array([f.center[1] for f in features], dtype=np.float64)
    yaw = np.array([f.yaw for f in features], dtype=np.float64)
    length = np.array([f.length for f in features], dtype=np.float64)
    width = np.array([f.width for f in features], dtype=np.float64)
    kind = np.array([_CODE[type(f)] for f in features], dtype=np.int8)
    a, n, tread = np.zeros(m), np.ones(m), np.ones(m)
    for k, f in enumerate(features):
        if isinstance(f, StepsFeature):
            a[k], n[k] = f.step_height, f.step_count
            tread[k] = max(f.length - f.landing, 1e-9) / f.step_count
        else:
            a[k] = f.rise
    cos, sin = np.cos(yaw), np.sin(yaw)
    # Bounding boxes of the rotated rectangles, bucketed.
    ex = np.abs(cos) * length / 2 + np.abs(sin) * width / 2
    ey = np.abs(sin) * length / 2 + np.abs(cos) * width / 2
    ox, oy = float((cx - ex).min()), float((cy - ey).min())
    i0 = np.floor((cx - ex - ox) / BUCKET).astype(np.int64)
    i1 = np.floor((cx + ex - ox) / BUCKET).astype(np.int64)
    j0 = np.floor((cy - ey - oy) / BUCKET).astype(np.int64)
    j1 = np.floor((cy + ey - oy) / BUCKET).astype(np.int64)
    nx, ny = int(i1.max()) + 1, int(j1.max()) + 1
    ids_a, owners_a = _buckets(i0, i1, j0, j1, nx)
    order = np.argsort(ids_a, kind="stable")
    starts = np.searchsorted(ids_a[order], np.arange(nx * ny + 1))
    return _Index(
        cx, cy, cos, sin, length, width / 2, np.array([f.height for f in features]), kind,
        a, n, tread, (ox, oy), (ny, nx), starts, owners_a[order],
    )  # fmt: skip


def _buckets(i0, i1, j0, j1, nx: int) -> tuple[np.ndarray, np.ndarray]:
    """The bucket ids ``j * nx + i`` each feature ``k`` covers (its ``[j0, j1] x [i0, i1]``,
    ``j`` major) one feature after another, and their owners ``k``: what one ``np.mgrid``
    per feature gave (a city's 13,800 features: 0.26 s of its first ``height_at``)."""
    w = i1 - i0 + 1
    count = w * (j1 - j0 + 1)
    owners = np.repeat(np.arange(len(w)), count)
    local = np.arange(int(count.sum())) - np.repeat(np.cumsum(count) - count, count)
    rows, cols = np.divmod(local, w[owners])
    return (j0[owners] + rows) * nx + i0[owners] + cols, owners


_CACHE: dict[int, tuple[tuple, _Index]] = {}


def _cached(features: tuple) -> _Index:
    hit = _CACHE.get(id(features))
    if hit is not None and hit[0] is features:
        return hit[1]
    index = _index(features)
    _CACHE[id(features)] = (features, index)
    for key in list(_CACHE)[:-8]:
        _CACHE.pop(key, None)
    return index


def raise_heights(
    features: Sequence[AnyFeature] | None, x: np.ndarray, y: np.ndarray, z: np.ndarray
) -> np.ndarray:
    """``z`` (heights at the 1-d points ``x, y``, m) raised to every feature's surface
    where a feature covers a point: ``max(z, surface)``. Returns ``z`` (changed in place)."""
    if not features or not x.size:
        return z
    ix = _cached(features if isinstance(features, tuple) else tuple(features))
    ny, nx = ix.shape
    with np.errstate(invalid="ignore"):
        bi = np.floor((x - ix.origin[0]) / BUCKET)
        bj = np.floor((y - ix.origin[1]) / BUCKET)
    ok = np.flatnonzero((bi >= 0) & (bi < nx) & (bj >= 0) & (bj < ny))
    if not ok.size:
        return z
    bucket = (bj[ok] * nx + bi[ok]).astype(np.int64)
    lo, hi = ix.starts[bucket], ix.starts[bucket + 1]
    counts = hi - lo
    if not counts.any():
        return z
    point = np.repeat(ok, counts)
    offset = np.arange(int(counts.sum())) - np.repeat(np.cumsum(counts) - counts, counts)
    f = ix.members[np.repeat(lo, counts) + offset]
    dx, dy = x[point] - ix.cx[f], y[point] - ix.cy[f]
    along = dx * ix.cos[f] + dy * ix.sin[f] + ix.length[f] / 2
    across = -dx * ix.sin[f] + dy * ix.cos[f]
    inside = (along >= -1e-9) & (along <= ix.length[f] + 1e-9) & (np.abs(across) <= ix.half_width[f] + 1e-9)
    point, f, along = point[inside], f[inside], np.clip(along[inside], 0.0, ix.length[f[inside]])
    kind = ix.kind[f]
    steps = np.minimum(np.floor(along / ix.tread[f] + 1e-9) + 1, ix.n[f])
    surface = ix.h[f] + np.where(
        kind == _STEPS, ix.a[f] * steps, np.where(kind == _RAMP, ix.a[f] * along / ix.length[f], ix.a[f])
    )
    np.maximum.at(z, point, surface)
    return z


def feature_boxes(
    feature: AnyFeature,
) -> list[tuple[tuple[float, float, float], tuple[float, float, float], float, float]]:
    """The feature as oriented boxes ``(centre xyz, half sizes xyz, yaw, pitch)`` (m, rad):
    a box's local x runs along the feature's ``yaw``; ``pitch`` tilts it up about its local
    y (only a ramp's box is pitched, its top face lying on the ramp). Each box reaches
    :data:`FOOTING` below the feature's ``height``; together their tops are the surface.

    >>> from citygen.spec.terrain import LandingFeature
    >>> feature_boxes(LandingFeature(id="l", kind="landing", center=(0, 0), length=2, width=1, rise=0.3))
    [((0.0, 0.0, 0.125), (1.0, 0.5, 0.175), 0.0, 0.0)]
    """
    c, s = math.cos(feature.yaw), math.sin(feature.yaw)
    x0, y0 = feature.center[0] - c * feature.length / 2, feature.center[1] - s * feature.length / 2
    bottom, hw = feature.height - FOOTING, feature.width / 2

    def box(a0: float, a1: float, top: float):
        mid = (a0 + a1) / 2
        return (
            (x0 + c * mid, y0 + s * mid, (bottom + top) / 2),
            ((a1 - a0) / 2, hw, (top - bottom) / 2),
            feature.yaw,
            0.0,
        )

    if isinstance(feature, LandingFeature):
        return [box(0.0, feature.length, feature.height + feature.rise)]
    if isinstance(feature, StepsFeature):
        d = (feature.length - feature.landing) / feature.step_count
        n = feature.step_count
        return [
            box(
                k * d,
                feature.length if k == n - 1 else (k + 1) * d,
                feature.height + (k + 1) * feature.step_height,
            )
            for k in range(n)
        ]
    # A ramp: one box whose top face is the incline, FOOTING thick at its low edge.
    pitch = math.atan2(feature.rise, feature.length)
    slant = math.hypot(feature.length, feature.rise)
    half_t = FOOTING * math.cos(pitch) / 2
    # The top face's midpoint, then half the thickness along the face's downward normal.
    mx, mz = feature.length / 2, feature.height + feature.rise / 2
    nx, nz = math.sin(pitch), -math.cos(pitch)
    ax, az = mx + nx * half_t, mz + nz * half_t
    return [((x0 + c * ax, y0 + s * ax, az), (slant / 2, hw, half_t), feature.yaw, pitch)]


def box_corners(box) -> np.ndarray:
    """The 8 corners (m) of a box of :func:`feature_boxes`, shape ``(8, 3)``."""
    (cx, cy, cz), (hx, hy, hz), yaw, pitch = box
    u = np.array([[sx * hx, sy * hy, sz * hz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)])
    cp, sp = math.cos(pitch), math.sin(pitch)
    # Pitch up about local y (the box's +x end rises), then yaw about z.
    px, pz = u[:, 0] * cp - u[:, 2] * sp, u[:, 0] * sp + u[:, 2] * cp
    cyaw, syaw = math.cos(yaw), math.sin(yaw)
    return np.c_[cx + px * cyaw - u[:, 1] * syaw, cy + px * syaw + u[:, 1] * cyaw, cz + pz]


def feature_polygon(feature: AnyFeature):
    """The feature's rectangle as a shapely polygon (m)."""
    from shapely.geometry import Polygon

    c, s = math.cos(feature.yaw), math.sin(feature.yaw)
    hl, hw = feature.length / 2, feature.width / 2
    x, y = feature.center
    return Polygon(
        [(x + c * a - s * b, y + s * a + c * b) for a, b in ((-hl, -hw), (hl, -hw), (hl, hw), (-hl, hw))]
    )


def feature_mask(features: Sequence[AnyFeature], xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
    """bool ``(len(ys), len(xs))``: whether the point ``(xs[j], ys[i])`` (m) lies in one of
    ``features``' rectangles (``xs``, ``ys`` increasing)."""
    out = np.zeros((len(ys), len(xs)), dtype=bool)
    for f in features:
        x0, y0, x1, y1 = feature_polygon(f).bounds
        j0, j1 = np.searchsorted(xs, x0), np.searchsorted(xs, x1, side="right")
        i0, i1 = np.searchsorted(ys, y0), np.searchsorted(ys, y1, side="right")
        if i0 >= i1 or j0 >= j1:
            continue
        c, s = math.cos(f.yaw), math.sin(f.yaw)
        dx, dy = xs[None, j0:j1] - f.center[0], ys[i0:i1, None] - f.center[1]
        along, across = dx * c + dy * s, -dx * s + dy * c
        out[i0:i1, j0:j1] |= (np.abs(along) <= f.length / 2) & (np.abs(across) <= f.width / 2)
    return out
