"""2-D vectors along the last axis of numpy arrays (``(..., 2)``), as people and vehicles move."""

from __future__ import annotations

import numpy as np


def det(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 1] - a[..., 1] * b[..., 0]


def dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return a[..., 0] * b[..., 0] + a[..., 1] * b[..., 1]
