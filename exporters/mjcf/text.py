"""Numbers as MJCF attribute text: at most 6 decimals, trailing zeros dropped, never ``-0``;
a heightfield's integers written fast."""

from __future__ import annotations

from typing import Any

import numpy as np


def num(x: float) -> str:
    """A number in at most 6 decimals, trailing zeros dropped, never ``-0``."""
    s = f"{x:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def nums(values: Any) -> str:
    """Numbers separated by single spaces, each as :func:`num` writes it."""
    return " ".join(map(num, np.asarray(values, dtype=float).ravel().tolist()))


def ints(values: Any) -> str:
    """Integers separated by single spaces, the characters ``" ".join(map(str, values))``
    writes, two to four times faster for a heightfield's elevation: non-negative values'
    digits are laid out in columns by numpy and the leading zeros dropped."""
    v = np.asarray(values, dtype=np.int64).ravel()
    if not v.size:
        return ""
    if v.min() < 0:
        return ("%d " * v.size % tuple(v.tolist()))[:-1]
    width = len(str(int(v.max())))
    chars = np.empty((v.size, width + 1), dtype=np.uint8)
    chars[:, width] = ord(" ")
    rest = v.copy()
    for d in range(width - 1, -1, -1):
        chars[:, d] = ord("0") + rest % 10
        rest //= 10
    keep = np.ones(chars.shape, dtype=bool)  # from each number's first non-zero digit on
    keep[:, : width - 1] = v[:, None] >= 10 ** np.arange(width - 1, 0, -1, dtype=np.int64)
    return chars[keep].tobytes()[:-1].decode("ascii")
