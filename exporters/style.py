"""How citygen's pictures (the PNG map, the occupancy map's picture) look and are laid out:
matplotlib's default style with citygen's fixed settings (:func:`style`), the figure's size
and the map's place in it (:func:`figure_layout`), the accepted sizes in pixels
(:func:`check_size`) and the scale bar's length (:func:`scale_bar_length`).

matplotlib is imported only while a picture is drawn: the runner builds occupancy maps and
never draws them."""

from __future__ import annotations

import math
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np

from citygen.errors import ExportError

#: Smallest and largest ``size_px`` accepted (the larger side of the picture, in pixels).
MIN_SIZE_PX, MAX_SIZE_PX = 64, 8192
#: Size (pt) of the pictures' text.
FONT_PT = 7.5
# Layout of the figure in inches; the dpi follows from size_px.
_MARGINS = {"left": 0.62, "right": 0.15, "bottom": 0.45, "top": 0.32}
_LEGEND_IN = 1.75
# Everything that decides how the picture looks, fixed so the user's rcParams do not.
_RC = {
    "font.family": "DejaVu Sans",
    "font.size": FONT_PT,
    "hatch.linewidth": 1.2,
    "path.simplify": True,
    "agg.path.chunksize": 20_000,
    "savefig.facecolor": "white",
    "image.resample": False,
}


def scale_bar_length(width_m: float) -> float:
    """A round length (1, 2 or 5 times a power of ten) close to a fifth of ``width_m``, in metres.

    >>> scale_bar_length(24.0), scale_bar_length(1200.0), scale_bar_length(10.0), scale_bar_length(3.0)
    (5.0, 200.0, 2.0, 0.5)
    """
    if not width_m > 0:
        raise ValueError(f"width_m: expected a positive length in metres, got {width_m!r}")
    target = width_m / 5
    decade = 10.0 ** math.floor(math.log10(target))
    # The candidate nearest the target on a log scale.
    candidates = [m * decade for m in (1, 2, 5, 10)]
    best = min(candidates, key=lambda c: abs(math.log(c / target)))
    return float(f"{best:.6g}")


# --- layout -------------------------------------------------------------------------


@dataclass(frozen=True)
class Layout:
    """Where a picture's parts go: its size in pixels and dpi, the map's axes, the legend's corner."""

    width_px: int
    height_px: int
    dpi: float
    axes: tuple[float, float, float, float]
    """The map's axes in figure fractions: left, bottom, width, height."""
    legend_anchor: tuple[float, float]
    """The legend's upper left corner in figure fractions."""

    @property
    def px_per_m(self) -> float:
        return self.axes[2] * self.width_px


def figure_layout(width_m: float, height_m: float, size_px: int, legend_entries: int, legend: bool) -> Layout:
    """Figure size and the map's place in it, so the map shows the bounds at equal aspect."""
    long_in = min(max(size_px / 130, 5.0), 11.0)
    dpi = size_px / long_in
    m = _MARGINS
    legend_in = _LEGEND_IN if legend else 0.0
    extra_w = m["left"] + m["right"] + legend_in
    extra_h = m["bottom"] + m["top"]
    ratio = height_m / width_m
    map_w = long_in - extra_w
    map_h = map_w * ratio
    if map_h + extra_h > long_in:  # a tall scene: the height is the long side
        map_h = long_in - extra_h
        map_w = map_h / ratio
    fig_w, fig_h = map_w + extra_w, map_h + extra_h
    if legend:  # room for every legend entry
        fig_h = max(fig_h, min(long_in, (legend_entries * 1.55 + 1.2) * FONT_PT / 72 + m["top"]))
    fig_h, fig_w = max(fig_h, 1.6), max(fig_w, 1.6)
    width_px = size_px if fig_w >= fig_h else max(1, round(fig_w * dpi))
    height_px = size_px if fig_h > fig_w else max(1, round(fig_h * dpi))
    fig_w, fig_h = width_px / dpi, height_px / dpi
    # The map box at exact aspect, centred in the room left by the margins.
    room_w, room_h = fig_w - extra_w, fig_h - extra_h
    map_w = min(room_w, room_h / ratio)
    map_h = map_w * ratio
    left = m["left"] + (room_w - map_w) / 2
    bottom = m["bottom"] + (room_h - map_h) / 2
    axes = (left / fig_w, bottom / fig_h, map_w / fig_w, map_h / fig_h)
    anchor = ((fig_w - legend_in - m["right"] + 0.1) / fig_w, 1 - m["top"] / fig_h)
    return Layout(width_px, height_px, dpi, axes, anchor)


@contextmanager
def style() -> Iterator[None]:
    """matplotlib's default style plus citygen's settings, restored on leaving."""
    import matplotlib.style

    with matplotlib.style.context("default"), matplotlib.rc_context(_RC):
        yield


def check_size(size_px: object) -> int:
    """``size_px`` as an int, or an :class:`ExportError` unless it is a whole number of pixels
    from :data:`MIN_SIZE_PX` to :data:`MAX_SIZE_PX`."""
    if isinstance(size_px, bool) or not isinstance(size_px, int | np.integer):
        raise ExportError(f"size_px: expected a whole number of pixels, got {size_px!r}")
    if not MIN_SIZE_PX <= size_px <= MAX_SIZE_PX:
        raise ExportError(f"size_px: expected {MIN_SIZE_PX} to {MAX_SIZE_PX} pixels, got {size_px}")
    return int(size_px)
