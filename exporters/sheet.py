"""Contact sheets of the asset catalog: a grid of small shaded 3-D views of one category's
variants, and a table of every category, for people choosing and checking assets.

Each cell shows ``resolve(id).visual_mesh()`` seen from the front-left (from +x, +y,
25 degrees above the ground), faces in their material colours with Lambert shading,
on its footprint in light grey, labelled with the id and the overall size as
height x width (y) x depth (x) in metres. Every cell has its own scale, so the size
label is what compares variants.

The same arguments always give the same PNG bytes: no timestamp or version is written
and the picture is drawn with matplotlib's default style whatever the user's
``matplotlibrc`` says. pyplot is never imported and the global backend is never
changed. While drawing, matplotlib's global ``rcParams`` are switched to that style and
back (:func:`matplotlib.rc_context`), so do not draw from two threads at once.

>>> rows = list_categories(samples=3)
>>> row = next(r for r in rows if r["name"] == "bench")
>>> row["semantic_class"], row["anchor"], row["variants"]
('bench', 'free', 10000)
"""

from __future__ import annotations

import io
import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import matplotlib
import matplotlib.style
import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from mpl_toolkits.mplot3d.axes3d import Axes3D

from citygen.assets import CATEGORIES, categories, resolve
from citygen.errors import ExportError
from citygen.io import write_atomic

#: Variant numbers of every category: ids ``category/0000`` to ``category/9999``.
VARIANTS = 10_000
#: Most variants on one sheet.
MAX_COUNT = 100
#: Smallest and largest ``size_px`` accepted (the sheet's width, in pixels).
MIN_SIZE_PX, MAX_SIZE_PX = 64, 8192
#: Where the light comes from (unit vector, asset frame): above, front-left of the viewer.
LIGHT = tuple((np.array([0.45, 0.25, 0.86]) / np.linalg.norm([0.45, 0.25, 0.86])).tolist())
#: Fraction of a face's colour it keeps when facing away from the light.
AMBIENT = 0.38
#: The camera: elevation and azimuth (degrees) of mplot3d's view.
ELEVATION, AZIMUTH = 25.0, 30.0

_DPI = 100.0
_LABEL_FRACTION = 0.16  # of a cell's height, under the view, for the two label lines
_GROUND = (0.86, 0.86, 0.84, 1.0)
_RC = {"font.family": "DejaVu Sans", "savefig.facecolor": "white", "path.simplify": False}


class SheetError(ExportError, ValueError):
    """Bad arguments for a contact sheet (unknown category, count, start or size).

    An :class:`~citygen.errors.ExportError`, so the CLI prints it as one line, and a
    ``ValueError``, as the arguments are bad input.
    """


def list_categories(samples: int = 100) -> list[dict[str, object]]:
    """Every catalog category with what placement needs and its measured sizes, sorted by name.

    Each row: ``name``, ``semantic_class``, ``zones`` (sorted), ``anchor``, ``clearance``
    (m), ``variants`` (10,000: ids 0000-9999), and ``height``, ``size_x``, ``size_y`` as
    ``(min, max)`` in metres (to the millimetre), measured over variants 0 to
    ``samples - 1``; the category's promised ranges hold them.
    """
    if isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= VARIANTS:
        raise SheetError(
            f"samples: expected a whole number of variants from 1 to {VARIANTS}, got {samples!r}"
        )
    rows: list[dict[str, object]] = []
    for name in categories():
        entry = CATEGORIES[name]
        sizes = np.array([_size(f"{name}/{v:04d}") for v in range(samples)])
        low, high = sizes.min(axis=0), sizes.max(axis=0)
        rows.append(
            {
                "name": name,
                "semantic_class": entry.semantic_class,
                "zones": sorted(entry.zones),
                "anchor": entry.anchor,
                "clearance": entry.clearance,
                "variants": VARIANTS,
                **{
                    key: (round(float(low[i]), 3), round(float(high[i]), 3))
                    for i, key in enumerate(("height", "size_x", "size_y"))
                },
            }
        )
    return rows


def _size(asset_id: str) -> tuple[float, float, float]:
    """Height, extent along x and extent along y (m) of an asset."""
    asset = resolve(asset_id)
    x0, y0, x1, y1 = asset.footprint.bounds
    return asset.height, x1 - x0, y1 - y0


def sheet_figure(category: str, *, count: int = 16, start: int = 0, size_px: int = 1600) -> Figure:
    """The contact sheet of variants ``start`` to ``start + count - 1`` of ``category`` as a
    matplotlib :class:`~matplotlib.figure.Figure` (Agg canvas, no pyplot).

    The grid has ``ceil(sqrt(count))`` columns of square cells; the sheet is ``size_px``
    pixels wide and as high as its rows need. Raises :class:`SheetError` for an unknown
    category or out-of-range arguments.
    """
    ids, cols, rows = _check(category, count, start, size_px)
    with _style():
        return _figure(ids, cols, rows, size_px)


def contact_sheet(
    category: str, path: str | Path, *, count: int = 16, start: int = 0, size_px: int = 1600
) -> Path:
    """Draw a contact sheet (see :func:`sheet_figure`) and write it as a PNG to ``path``,
    atomically; returns ``path``. The same arguments always give the same bytes.
    """
    ids, cols, rows = _check(category, count, start, size_px)
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise SheetError(f"{path}: expected a path ending in .png, got {path.suffix or 'no suffix'!r}")
    buf = io.BytesIO()
    with _style():
        fig = _figure(ids, cols, rows, size_px)
        # No "Software" (matplotlib's version) and no time: the bytes depend on the arguments only.
        fig.savefig(buf, format="png", dpi=_DPI, metadata={"Software": None})
    try:
        write_atomic(path, buf.getvalue())
    except OSError as exc:
        raise ExportError(f"{path}: cannot write the sheet: {exc.strerror or type(exc).__name__}") from None
    return path


def _check(category: object, count: object, start: object, size_px: object) -> tuple[list[str], int, int]:
    """The ids to draw and the grid's columns and rows, or a :class:`SheetError`."""
    if not isinstance(category, str) or category not in CATEGORIES:
        raise SheetError(f"unknown asset category {category!r}: expected one of {', '.join(categories())}")
    for name, value, low, high in (
        ("count", count, 1, MAX_COUNT),
        ("start", start, 0, VARIANTS - 1),
        ("size_px", size_px, MIN_SIZE_PX, MAX_SIZE_PX),
    ):
        if isinstance(value, bool) or not isinstance(value, int | np.integer) or not low <= value <= high:
            raise SheetError(f"{name}: expected a whole number from {low} to {high}, got {value!r}")
    count, start = int(count), int(start)  # type: ignore[call-overload]
    if start + count > VARIANTS:
        raise SheetError(
            f"start + count: expected at most {VARIANTS} (variants 0000-{VARIANTS - 1}), got {start + count}"
        )
    cols = math.ceil(math.sqrt(count))
    return [f"{category}/{v:04d}" for v in range(start, start + count)], cols, math.ceil(count / cols)


@contextmanager
def _style() -> Iterator[None]:
    """matplotlib's default style plus citygen's settings, restored on leaving."""
    with matplotlib.style.context("default"), matplotlib.rc_context(_RC):
        yield


def _figure(ids: list[str], cols: int, rows: int, size_px: int) -> Figure:
    cell = size_px / cols  # px
    height_px = round(rows * cell)
    # A quarter pixel more, so that the canvas, which truncates, is exactly this size.
    fig = Figure(figsize=((size_px + 0.25) / _DPI, (height_px + 0.25) / _DPI), dpi=_DPI)
    FigureCanvasAgg(fig)
    fig.set_facecolor("white")
    font_pt = max(4.0, cell * 0.045) * 72 / _DPI
    w, h = cell / size_px, cell / height_px  # one cell in figure fractions
    for k, asset_id in enumerate(ids):
        row, col = divmod(k, cols)
        left, bottom = col * w, 1.0 - (row + 1) * h
        ax = fig.add_axes((left, bottom + h * _LABEL_FRACTION, w, h * (1 - _LABEL_FRACTION)), projection="3d")
        height, size_x, size_y = _draw_asset(ax, asset_id)
        fig.text(
            left + w / 2,
            bottom + h * _LABEL_FRACTION * 0.5,
            f"{asset_id}\n{height:.2f} x {size_y:.2f} x {size_x:.2f} m",
            ha="center",
            va="center",
            fontsize=font_pt,
            linespacing=1.25,
        )
    return fig


def _draw_asset(ax: Axes3D, asset_id: str) -> tuple[float, float, float]:
    """Draw one asset's visual mesh, shaded, on its footprint; returns its height, size_x, size_y (m)."""
    asset = resolve(asset_id)
    mesh = asset.visual_mesh()
    triangles = mesh.triangles
    normals = mesh.face_normals
    rgb = mesh.visual.face_colors[:, :3] / 255.0
    # Back faces hidden: the painter's algorithm of mplot3d then has far fewer faces to misorder.
    el, az = math.radians(ELEVATION), math.radians(AZIMUTH)
    front = normals @ np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)]) > 0
    triangles, normals, rgb = triangles[front], normals[front], rgb[front]
    light = np.clip(normals @ np.asarray(LIGHT), 0.0, 1.0)
    shade = AMBIENT + (1.0 - AMBIENT) * light
    colours = np.column_stack([rgb * shade[:, None], np.ones(len(rgb))])

    ax.computed_zorder = False  # the ground first, then the mesh sorted face by face
    ground = np.asarray(asset.footprint.exterior.coords)[:-1]
    ax.add_collection3d(
        Poly3DCollection(
            [np.column_stack([ground, np.zeros(len(ground))])], facecolors=[_GROUND], linewidths=0
        )
    )
    ax.add_collection3d(Poly3DCollection(triangles, facecolors=colours, edgecolors=colours, linewidths=0.5))

    lo, hi = mesh.bounds
    centre = (lo + hi) / 2
    half = float(np.max(hi - lo)) / 2 * 1.02
    ax.set_xlim(centre[0] - half, centre[0] + half)
    ax.set_ylim(centre[1] - half, centre[1] + half)
    ax.set_zlim(centre[2] - half, centre[2] + half)
    ax.set_box_aspect((1.0, 1.0, 1.0), zoom=1.25)
    ax.view_init(elev=ELEVATION, azim=AZIMUTH)
    ax.set_axis_off()
    x0, y0, x1, y1 = asset.footprint.bounds
    return asset.height, x1 - x0, y1 - y0
