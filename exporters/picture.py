"""Top-down pictures of a scene: a PNG map for people to look at.

The map shows the zones filled by kind (a fixed palette, :data:`ZONE_COLORS`), the
road blocks' outlines with their sockets as arrows, static objects as their
footprints, agents (people as discs of their radius, vehicles as rectangles along
their way) with a dotted line to their goal, the task's start and goal, the
terrain as a hillshade with marks for stairs, slopes and rough ground, a scale bar
and axes in metres. The legend lists only what the scene holds.

Units: world coordinates in metres (x to the right, y up, equal aspect); picture
sizes in pixels.

The same scene always gives the same PNG bytes: no timestamp or version is written,
and the picture is drawn with matplotlib's default style whatever the user's
``matplotlibrc`` says. pyplot is never imported and the global backend is never
changed, so calling this from a notebook or a GUI program leaves it as it was.

A scene is drawn as it is, even one that :func:`citygen.validate` rejects
(overlapping zones are drawn overlapping), so a picture can show what is wrong.
While drawing, matplotlib's global ``rcParams`` are switched to that style and back
(:func:`matplotlib.rc_context`), so do not draw from two threads at once.

>>> from citygen.exporters import picture
>>> fig = picture.figure("examples/street_corner.json", size_px=800)
>>> fig.canvas.get_width_height()
(800, 572)
>>> [t.get_text() for t in fig.legends[0].get_texts()][:4]
['roadway', 'curb', 'sidewalk', 'crosswalk']
"""

from __future__ import annotations

import io
import math
from collections.abc import Sequence
from dataclasses import dataclass
from itertools import chain, pairwise
from pathlib import Path
from types import MappingProxyType
from typing import Any

import matplotlib.colors
import numpy as np
from matplotlib.artist import Artist
from matplotlib.axes import Axes
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.collections import EllipseCollection, LineCollection, PathCollection, PolyCollection
from matplotlib.figure import Figure
from matplotlib.font_manager import FontProperties
from matplotlib.lines import Line2D
from matplotlib.patches import Circle, Patch
from matplotlib.path import Path as MplPath
from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

from citygen.assets import UnknownAsset, resolve
from citygen.errors import ExportError, Problem, SpecError
from citygen.exporters import OBJECT_COLOR, ZONE_COLORS, as_scene, output_name
from citygen.exporters.style import FONT_PT, check_size, figure_layout, scale_bar_length, style
from citygen.exporters.style import MAX_SIZE_PX as MAX_SIZE_PX
from citygen.exporters.style import MIN_SIZE_PX as MIN_SIZE_PX
from citygen.geometry.features import feature_polygon
from citygen.geometry.roads import block_outline
from citygen.geometry.terrain import height_at
from citygen.io import write_atomic
from citygen.spec.agents import Person, Vehicle
from citygen.spec.scene import Scene
from citygen.spec.surfaces import ZONE_KINDS
from citygen.spec.task import NavTask, TraverseTask
from citygen.spec.terrain import RoughTile, SlopeTile, StairTile

#: Hatching of a zone kind (matplotlib hatch pattern, drawn in white): crosswalk stripes.
ZONE_HATCH = MappingProxyType({"crosswalk": "///"})

#: Tiles narrower than this many pixels get no stair, slope or rough marks.
GLYPH_MIN_PX = 14.0
#: Most terrain height samples along one side of the grid (one per pixel up to this).
MAX_HEIGHT_SAMPLES = 1024
#: Width of zone outlines in points, drawn when zones are typically at least
#: ``ZONE_EDGE_MIN_PX`` pixels across (on a city map outlines would hide the fills).
ZONE_EDGE_PT, ZONE_EDGE_MIN_PX = 0.3, 24.0
#: Socket arrows shorter than this (points) are not drawn at all: the map is too small.
SOCKET_MIN_PT = 4.0
#: Blocks beyond this count are drawn without their id labels.
MAX_BLOCK_LABELS = 60

_BACKGROUND = "#f4f1ea"  # ground inside the bounds that no zone covers
_OUTSIDE = "#ffffff"
_MESH_OBJECT = "#7a3e9d"
_ROAD_EDGE = "#f2b600"
_JOINED = "#b8b8b8"
_GLYPH = "#1b1b1b"
_START, _GOAL = "#0b8f3a", "#d11f4a"
_AGENT_COLORS = {"pedestrian": "#e6194b", "cyclist": "#f58231", "scooter": "#911eb4", "vehicle": "#1f5fd1"}

# --- shapes as matplotlib paths -------------------------------------------------------


#: Vertices per matplotlib path when many polygons are drawn as one compound path.
_CHUNK_VERTICES = 50_000


def _polygon_paths(polygons: Sequence[tuple[Any, Sequence[Any]]]) -> list[MplPath]:
    """Polygons with holes as a few compound paths, each exterior counter-clockwise and
    each hole clockwise, so they fill right under matplotlib's non-zero rule.

    ``polygons`` are ``(exterior, holes)`` pairs of rings of ``(x, y)`` in metres; a ring
    may repeat its first vertex or not. The work is vectorised over all rings, and a
    polygon's rings always go into the same path (a hole alone would fill).
    """
    rings: list[Any] = []
    ccw: list[bool] = []
    owner: list[int] = []
    for i, (exterior, holes) in enumerate(polygons):
        for j, ring in enumerate((exterior, *holes)):
            if len(ring) >= 3:
                rings.append(ring)
                ccw.append(j == 0)
                owner.append(i)
    if not rings:
        return []
    lens = np.fromiter(map(len, rings), dtype=np.int64, count=len(rings))
    xy = np.array(list(chain.from_iterable(rings)), dtype=float).reshape(-1, 2)
    starts = np.concatenate([[0], np.cumsum(lens)[:-1]])
    # Drop a repeated first vertex: the closing vertex is added below.
    closed = np.all(xy[starts] == xy[starts + lens - 1], axis=1)
    if closed.any():
        keep = np.ones(len(xy), dtype=bool)
        keep[(starts + lens - 1)[closed]] = False
        xy, lens = xy[keep], lens - closed
        starts = np.concatenate([[0], np.cumsum(lens)[:-1]])
    n, r = len(xy), len(lens)
    ring_of = np.repeat(np.arange(r), lens)
    local = np.arange(n) - starts[ring_of]
    nxt = np.arange(1, n + 1)
    nxt[starts + lens - 1] = starts
    x, y = xy[:, 0], xy[:, 1]
    area2 = np.add.reduceat(x * y[nxt] - x[nxt] * y, starts)
    flip = (area2 > 0) != np.asarray(ccw)
    src = np.where(flip[ring_of], (starts + lens - 1)[ring_of] - local, np.arange(n))
    verts = np.empty((n + r, 2))
    codes = np.full(n + r, MplPath.LINETO, dtype=MplPath.code_type)
    verts[np.arange(n) + ring_of] = xy[src]
    first = starts + np.arange(r)
    end = first + lens
    codes[first] = MplPath.MOVETO
    codes[end] = MplPath.CLOSEPOLY
    verts[end] = verts[first]
    # Cut into paths at polygon boundaries, about _CHUNK_VERTICES vertices each.
    out_starts = np.concatenate([first, [n + r]])
    owners = np.asarray(owner)
    new_polygon = np.concatenate([[True], owners[1:] != owners[:-1]])
    cuts, last = [0], 0
    for k in np.flatnonzero(new_polygon)[1:]:
        if out_starts[k] - out_starts[last] >= _CHUNK_VERTICES:
            cuts.append(int(out_starts[k]))
            last = k
    cuts.append(n + r)
    return [MplPath(verts[a:b], codes[a:b]) for a, b in pairwise(cuts)]


# --- the layers ---------------------------------------------------------------------


@dataclass
class _Legend:
    handles: list[Artist]

    def add(self, handle: Artist) -> None:
        self.handles.append(handle)


def _draw_zones(ax: Axes, scene: Scene, px_per_m: float, legend: _Legend) -> None:
    """One collection per kind present. Zones get a thin darker outline (neighbouring
    zones of one kind stay apart) unless they are too small for it to leave any fill."""
    width, height = scene.bounds.size
    typical_px = math.sqrt(width * height / max(len(scene.zones), 1)) * px_per_m
    edge_pt = ZONE_EDGE_PT if typical_px >= ZONE_EDGE_MIN_PX else 0.0
    by_kind: dict[str, list[tuple[Any, Sequence[Any]]]] = {}
    for zone in scene.zones:
        by_kind.setdefault(zone.kind, []).append((zone.polygon, zone.holes))
    for kind in ZONE_KINDS:  # a fixed order: the legend's and the drawing's
        if kind not in by_kind:
            continue
        colour = ZONE_COLORS[kind]
        coll = PathCollection(
            _polygon_paths(by_kind[kind]),
            facecolors=colour,
            edgecolors=_darker(colour) if edge_pt else "none",
            linewidths=edge_pt,
            transform=ax.transData,
            zorder=1,
        )
        hatch = ZONE_HATCH.get(kind)
        if hatch:
            coll.set_hatch(hatch)
            coll.set_hatchcolor("white")
        ax.add_collection(coll, autolim=False)
        legend.add(Patch(facecolor=colour, edgecolor=_darker(colour), hatch=hatch, label=kind))


def _darker(colour: str, factor: float = 0.75) -> tuple[float, float, float]:
    r, g, b = matplotlib.colors.to_rgb(colour)
    return (r * factor, g * factor, b * factor)


def _draw_terrain(ax: Axes, scene: Scene, px_per_m: float, legend: _Legend) -> None:
    t = scene.terrain
    if t is None:
        return
    x0, y0 = t.origin
    x1, y1 = x0 + t.cols * t.tile_size, y0 + t.rows * t.tile_size
    nx = int(min(max(round((x1 - x0) * px_per_m), 2), MAX_HEIGHT_SAMPLES))
    ny = int(min(max(round((y1 - y0) * px_per_m), 2), MAX_HEIGHT_SAMPLES))
    dx, dy = (x1 - x0) / nx, (y1 - y0) / ny
    xs = x0 + (np.arange(nx) + 0.5) * dx
    ys = y0 + (np.arange(ny) + 0.5) * dy
    z = height_at(scene, xs[None, :], ys[:, None])
    ax.imshow(
        _hillshade(z, dx, dy),
        extent=(x0, x1, y0, y1),
        origin="lower",
        interpolation="nearest",
        zorder=2,
    )
    legend.add(
        Patch(
            facecolor="#8a8a8a",
            edgecolor="none",
            label=f"terrain {float(z.min()):.2f} to {float(z.max()):.2f} m",
        )
    )
    tile_px = t.tile_size * px_per_m
    if tile_px >= GLYPH_MIN_PX:
        _draw_tile_marks(ax, t, tile_px, legend)
    _draw_features(ax, t, legend)


#: Fill of each kind of terrain feature, and its legend label.
FEATURE_STYLE = {
    "steps": ("#00b8d9", "steps"),
    "ramp": ("#3aa84a", "ramp"),
    "landing": ("#9b5d2e", "raised landing (terrace)"),
}


def _draw_features(ax: Axes, t: Any, legend: _Legend) -> None:
    """Terrain features as filled rectangles, grown to at least a few pixels' outline so
    front steps stay visible on a city-wide map."""
    features = t.features or ()
    for kind, (colour, label) in FEATURE_STYLE.items():
        # A landing no higher than a curb is a raised sidewalk: its zone's colour shows it.
        shown = [f for f in features if f.kind == kind and (kind != "landing" or f.rise > 0.2)]
        rects = [np.asarray(feature_polygon(f).exterior.coords) for f in shown]
        if not rects:
            continue
        ax.add_collection(
            PolyCollection(rects, facecolors=colour, edgecolors=colour, linewidths=0.6, zorder=3.5)
        )
        legend.add(Patch(facecolor=colour, edgecolor="none", label=label))


def _hillshade(z: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """An RGBA overlay: black where the ground faces away from a light in the north-west
    (45 degrees up), white where it faces it, clear where it is level."""
    if z.shape[0] > 1 and z.shape[1] > 1:
        dzdy, dzdx = np.gradient(z, dy, dx)
    else:
        dzdy = dzdx = np.zeros_like(z)
    azimuth, altitude = math.radians(315.0), math.radians(45.0)
    lx, ly = math.cos(altitude) * math.sin(azimuth), math.cos(altitude) * math.cos(azimuth)
    lz = math.sin(altitude)
    lit = (lz - dzdx * lx - dzdy * ly) / np.sqrt(1.0 + dzdx**2 + dzdy**2)
    delta = lit - lz  # zero on level ground
    rgba = np.zeros((*z.shape, 4))
    rgba[..., :3] = (delta > 0)[..., None]
    rgba[..., 3] = np.clip(np.abs(delta) * 2.5, 0.0, 0.6)
    return rgba


def _direction(ascent: str) -> tuple[float, float]:
    return {"+x": (1.0, 0.0), "-x": (-1.0, 0.0), "+y": (0.0, 1.0), "-y": (0.0, -1.0)}[ascent]


def _square(ox: float, oy: float, s: float, e: float) -> list[tuple[tuple[float, float], ...]]:
    """The four sides of the square ``e`` metres inside the tile at ``(ox, oy)`` of side ``s``."""
    a, b = (ox + e, oy + e), (ox + s - e, oy + s - e)
    return [(a, (b[0], a[1])), ((b[0], a[1]), b), (b, (a[0], b[1])), ((a[0], b[1]), a)]


def _ramp_marks(
    tile: StairTile | SlopeTile,
    ox: float,
    oy: float,
    s: float,
    tile_px: float,
    shaped: bool,
    lines: list,
    arrows: list,
) -> None:
    """A flight: risers across the ascent (stairs) and an arrow up it. A pyramid or pit
    (a ``shape``): risers as nested squares (stairs), or the platform and the four hip
    lines of a roof seen from above (slopes)."""
    if shaped:
        if isinstance(tile, StairTile):
            d = s / (2 * tile.step_count + 2)
            if d / s * tile_px >= 3.0:
                for k in range(1, tile.step_count + 1):
                    lines.extend(_square(ox, oy, s, k * d))
        else:
            e = s / 3
            lines.extend(_square(ox, oy, s, e))
            for (cx, cy), (ix, iy) in zip(
                ((ox, oy), (ox + s, oy), (ox + s, oy + s), (ox, oy + s)),
                ((ox + e, oy + e), (ox + s - e, oy + e), (ox + s - e, oy + s - e), (ox + e, oy + s - e)),
                strict=True,
            ):
                lines.append(((cx, cy), (ix, iy)))
        return
    ux, uy = _direction(tile.ascent)
    cx, cy = ox + s / 2, oy + s / 2
    arrows.append((cx - 0.3 * s * ux, cy - 0.3 * s * uy, 0.6 * s * ux, 0.6 * s * uy))
    if isinstance(tile, StairTile) and tile_px / (tile.step_count + 1) >= 3.0:
        hx, hy = -uy * 0.45 * s, ux * 0.45 * s
        for k in range(1, tile.step_count + 1):
            f = k / (tile.step_count + 1) - 0.5
            px, py = cx + f * s * ux, cy + f * s * uy
            lines.append(((px - hx, py - hy), (px + hx, py + hy)))


def _draw_tile_marks(ax: Axes, t: Any, tile_px: float, legend: _Legend) -> None:
    """Stair risers and ascent arrows, slope arrows, pyramid outlines and rough stipple, one
    collection each (tiles are looped over here; only grids of visible tiles get here)."""
    s = t.tile_size
    lines: list[tuple[tuple[float, float], tuple[float, float]]] = []
    arrows: list[tuple[float, float, float, float]] = []
    dots: list[np.ndarray] = []
    n_dots = int(min(max(tile_px // 12, 2), 6))
    # A fixed quincunx of dots, the same in every rough tile.
    g = (np.arange(n_dots) + 0.5) / n_dots
    lattice = np.stack(np.meshgrid(g, g), axis=-1).reshape(-1, 2)
    lattice[:, 0] += np.where(np.repeat(np.arange(n_dots), n_dots) % 2 == 1, 0.25 / n_dots, -0.25 / n_dots)
    kinds: set[str] = set()
    for row in range(t.rows):
        for col in range(t.cols):
            tile = t.tiles[row * t.cols + col]
            ox, oy = t.origin[0] + col * s, t.origin[1] + row * s
            if isinstance(tile, RoughTile):
                dots.append(lattice * s + (ox, oy))
                kinds.add("rough")
            elif isinstance(tile, StairTile | SlopeTile):
                shaped = getattr(tile, "shape", None) is not None
                kinds.add("pyramid" if shaped else tile.kind)
                _ramp_marks(tile, ox, oy, s, tile_px, shaped, lines, arrows)
    if lines:
        ax.add_collection(
            LineCollection(lines, colors=_GLYPH, linewidths=0.8, alpha=0.8, zorder=3), autolim=False
        )
    if arrows:
        a = np.asarray(arrows)
        ax.quiver(
            a[:, 0], a[:, 1], a[:, 2], a[:, 3],
            angles="xy", scale_units="xy", scale=1.0, color=_GLYPH, alpha=0.8,
            units="inches", width=0.9 / 72, headwidth=4, headlength=5, zorder=3,
        )  # fmt: skip
    if dots:
        d = np.concatenate(dots)
        ax.scatter(d[:, 0], d[:, 1], s=1.5, c=_GLYPH, marker="o", linewidths=0, alpha=0.8, zorder=3)
    marks = {
        "stair": Line2D([], [], color=_GLYPH, marker=">", linestyle="-", label="stair (risers, up)"),
        "slope": Line2D([], [], color=_GLYPH, marker=">", linestyle="none", label="slope (up)"),
        "pyramid": Patch(facecolor="none", edgecolor=_GLYPH, label="pyramid or pit"),
        "rough": Line2D([], [], color=_GLYPH, marker=".", linestyle="none", label="rough ground"),
    }
    for kind in ("stair", "slope", "pyramid", "rough"):
        if kind in kinds:
            legend.add(marks[kind])


def _draw_blocks(ax: Axes, scene: Scene, m_per_pt: float, legend: _Legend) -> None:
    if not scene.blocks:
        return
    outlines = [block_outline(block) for block in scene.blocks]
    paths = _polygon_paths(
        [(o.exterior.coords, [r.coords for r in o.interiors]) for o in outlines if not o.is_empty]
    )
    if paths:
        ax.add_collection(
            PathCollection(
                paths,
                facecolors="none",
                edgecolors=_ROAD_EDGE,
                linewidths=0.9,
                linestyles="--",
                transform=ax.transData,
                zorder=4,
            ),
            autolim=False,
        )
        legend.add(Line2D([], [], color=_ROAD_EDGE, linestyle="--", label="road block"))
    _draw_sockets(ax, scene, m_per_pt, legend)
    _draw_one_way(ax, scene, m_per_pt, legend)
    if len(scene.blocks) <= MAX_BLOCK_LABELS:
        for block in scene.blocks:
            ax.annotate(
                block.id,
                block.pose.position,
                fontsize=FONT_PT - 1,
                ha="left",
                va="bottom",
                xytext=(3, 3),
                textcoords="offset points",
                color="black",
                bbox={"boxstyle": "round,pad=0.15", "fc": _ROAD_EDGE, "ec": "none", "alpha": 0.85},
                zorder=8,
                annotation_clip=True,
            )


def _draw_sockets(ax: Axes, scene: Scene, m_per_pt: float, legend: _Legend) -> None:
    """Each socket as an arrow ending at the road end, pointing out of its block: open ones
    (where another block could attach) bright, joined ones grey. An arrow is at most 11 pt
    and at most 0.8 of its road's width long; on a map too small for that, none is drawn."""
    joined = {(b.id, c.socket) for b in scene.blocks for c in b.connections}
    joined |= {(c.block, c.to_socket) for b in scene.blocks for c in b.connections}
    rows = [
        (*s.pose.position, s.pose.yaw, 2 * b.lanes * b.lane_width, (b.id, s.id) in joined)
        for b in scene.blocks
        for s in b.sockets
    ]
    if not rows:
        return
    x, y, yaw, road, is_joined = np.array(rows, dtype=float).T
    length = np.minimum(11 * m_per_pt, 0.8 * road)
    typical = float(np.median(length))
    if typical < SOCKET_MIN_PT * m_per_pt:
        return
    for mask, colour in ((is_joined == 1, _JOINED), (is_joined == 0, _ROAD_EDGE)):
        if mask.any():
            ax.quiver(
                x[mask], y[mask], (length * np.cos(yaw))[mask], (length * np.sin(yaw))[mask],
                angles="xy", scale_units="xy", scale=1.0, pivot="tip", color=colour, edgecolor="black",
                linewidth=0.4, units="xy", width=0.16 * typical, headwidth=3, headlength=3.5, zorder=7,
            )  # fmt: skip
    if (is_joined == 0).any():
        legend.add(Line2D([], [], color=_ROAD_EDGE, marker=">", linestyle="-", label="open socket"))
    if (is_joined == 1).any():
        legend.add(Line2D([], [], color=_JOINED, marker=">", linestyle="-", label="joined socket"))


def _draw_one_way(ax: Axes, scene: Scene, m_per_pt: float, legend: _Legend) -> None:
    """A white arrowhead at the middle of each one-way road block, pointing the way its
    traffic drives (from ``in`` to ``out``); as small as a socket's arrow."""
    rows = [
        (*b.pose.position, b.pose.yaw, b.length, 2 * b.lanes * b.lane_width)
        for b in scene.blocks
        if getattr(b, "one_way", None)
    ]
    if not rows:
        return
    x, y, yaw, length, road = np.array(rows, dtype=float).T
    size = np.minimum(np.minimum(9 * m_per_pt, 0.6 * road), 0.8 * length)
    if float(np.median(size)) < SOCKET_MIN_PT * m_per_pt:
        return
    d = np.stack([np.cos(yaw), np.sin(yaw)])
    mid = np.stack([x, y]) + d * (length + size) / 2
    ax.quiver(
        mid[0], mid[1], size * d[0], size * d[1],
        angles="xy", scale_units="xy", scale=1.0, pivot="tip", color="white", edgecolor="black",
        linewidth=0.4, units="xy", width=0.12 * float(np.median(size)), headwidth=3, headlength=3.5,
        zorder=6,
    )  # fmt: skip
    legend.add(Line2D([], [], color="white", marker=">", markeredgecolor="black", linestyle="-",
                      label="one-way road"))  # fmt: skip


def _draw_placements(ax: Axes, scene: Scene, file: str | None, legend: _Legend) -> None:
    groups: dict[str, list[int]] = {}
    meshes: list[int] = []
    for i, pl in enumerate(scene.placements):
        if pl.is_mesh:
            meshes.append(i)
        else:
            groups.setdefault(pl.asset, []).append(i)
    shapes: list[np.ndarray] = []
    for asset_id, members in groups.items():
        try:
            footprint = resolve(asset_id).footprint
        except UnknownAsset as exc:
            where = f"$.placements[{members[0]}].asset"
            raise SpecError([Problem(where, exc.expected, repr(asset_id))], file=file) from None
        if footprint.geom_type != "Polygon":
            footprint = footprint.convex_hull
        ring = np.asarray(footprint.exterior.coords, dtype=float)[:-1]
        pls = [scene.placements[i] for i in members]
        yaw = np.array([p.yaw for p in pls])
        scale = np.array([p.scale for p in pls])
        pos = np.array([p.position[:2] for p in pls])
        c, s = np.cos(yaw)[:, None], np.sin(yaw)[:, None]
        x, y = ring[None, :, 0] * scale[:, None], ring[None, :, 1] * scale[:, None]
        shapes.extend(np.stack([c * x - s * y, s * x + c * y], axis=-1) + pos[:, None, :])
    if shapes:
        ax.add_collection(
            PolyCollection(shapes, facecolors=OBJECT_COLOR, edgecolors="black", linewidths=0.4, zorder=5),
            autolim=False,
        )
        legend.add(Patch(facecolor=OBJECT_COLOR, edgecolor="black", label="object"))
    if meshes:
        xy = np.array([scene.placements[i].position[:2] for i in meshes])
        ax.scatter(xy[:, 0], xy[:, 1], s=28, marker="s", c=_MESH_OBJECT, edgecolors="black", zorder=5)
        legend.add(
            Line2D(
                [], [], color=_MESH_OBJECT, marker="s", markeredgecolor="black",
                linestyle="none", label="mesh object",
            )
        )  # fmt: skip


def _draw_agents(ax: Axes, scene: Scene, legend: _Legend) -> None:
    if not scene.agents:
        return
    starts = np.array([a.start for a in scene.agents])
    goals = np.array([a.goal for a in scene.agents])
    colours = [_AGENT_COLORS[a.kind] for a in scene.agents]
    ax.add_collection(
        LineCollection(
            np.stack([starts, goals], axis=1),
            colors=colours,
            linewidths=0.8,
            linestyles=":",
            alpha=0.8,
            zorder=6,
        ),
        autolim=False,
    )
    people = [i for i, a in enumerate(scene.agents) if isinstance(a, Person)]
    if people:
        d = np.array([2 * scene.agents[i].radius for i in people])
        ax.add_collection(
            EllipseCollection(
                d,
                d,
                np.zeros(len(people)),
                units="xy",
                offsets=starts[people],
                offset_transform=ax.transData,
                facecolors=[colours[i] for i in people],
                edgecolors="black",
                linewidths=0.4,
                zorder=6,
            ),
            autolim=False,
        )
    cars = [i for i, a in enumerate(scene.agents) if isinstance(a, Vehicle)]
    if cars:
        boxes = []
        for i in cars:
            v = scene.agents[i]
            heading = goals[i] - starts[i]
            yaw = math.atan2(heading[1], heading[0]) if np.any(heading) else 0.0
            u = np.array([math.cos(yaw), math.sin(yaw)])
            n = np.array([-u[1], u[0]])
            hl, hw = v.length / 2, v.width / 2
            boxes.append(
                [starts[i] + sx * hl * u + sy * hw * n for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]
            )
        ax.add_collection(
            PolyCollection(
                boxes, facecolors=_AGENT_COLORS["vehicle"], edgecolors="black", linewidths=0.4, zorder=6
            ),
            autolim=False,
        )
    present = {a.kind for a in scene.agents}
    for kind, colour in _AGENT_COLORS.items():
        if kind in present:
            marker = "s" if kind == "vehicle" else "o"
            legend.add(
                Line2D(
                    [], [], color=colour, marker=marker, markeredgecolor="black",
                    linestyle=":", label=kind,
                )
            )  # fmt: skip


def _draw_task(ax: Axes, scene: Scene, m_per_pt: float, legend: _Legend) -> None:
    task = scene.task
    if task is None:
        return
    (sx, sy), yaw = task.start.position, task.start.yaw
    length = 13 * m_per_pt
    ax.quiver(
        [sx], [sy], [length * math.cos(yaw)], [length * math.sin(yaw)],
        angles="xy", scale_units="xy", scale=1.0, color=_START, units="inches", width=2.0 / 72, zorder=8,
    )  # fmt: skip
    ax.scatter([sx], [sy], s=60, marker="o", c=_START, edgecolors="white", linewidths=1.0, zorder=9)
    legend.add(
        Line2D(
            [], [], color=_START, marker="o", markeredgecolor="white", linestyle="none",
            label=f"start ({task.robot})",
        )
    )  # fmt: skip
    goal = None
    if isinstance(task, NavTask):
        goal, tolerance = task.goal, task.goal_tolerance
    elif isinstance(task, TraverseTask):
        route = np.array([task.start.position, *task.route])
        ax.plot(route[:, 0], route[:, 1], color=_GOAL, linewidth=1.2, linestyle="-", alpha=0.8, zorder=8)
        goal, tolerance = task.route[-1], task.goal_tolerance
        legend.add(Line2D([], [], color=_GOAL, linewidth=1.2, label="route"))
    if goal is not None:
        ring = Circle(goal, tolerance, facecolor="none", edgecolor=_GOAL, linewidth=1.0, linestyle="--")
        ring.set_zorder(9)
        ax.add_patch(ring)
        ax.scatter(
            [goal[0]], [goal[1]], s=120, marker="*", c=_GOAL, edgecolors="white", linewidths=0.8, zorder=9
        )
        legend.add(
            Line2D(
                [], [], color=_GOAL, marker="*", markersize=9, markeredgecolor="white",
                linestyle="none", label="goal",
            )
        )  # fmt: skip


def _title(scene: Scene) -> str:
    w, h = scene.bounds.size
    parts = []
    if scene.meta.split is not None:
        parts.append(scene.meta.split + (f" #{scene.meta.index}" if scene.meta.index is not None else ""))
    parts.append(f"{w:g} m x {h:g} m")
    if scene.task is not None:
        parts.append(scene.task.kind)
    return "  |  ".join(parts)


def _legend_size(scene: Scene, terrain: bool) -> int:
    """How many entries the legend will have at most, to make room for them."""
    n = len({z.kind for z in scene.zones})
    n += 3 if scene.blocks else 0  # road block, open and joined sockets
    n += any(not p.is_mesh for p in scene.placements) + any(p.is_mesh for p in scene.placements)
    n += len({a.kind for a in scene.agents})
    if scene.task is not None:
        n += 1 + isinstance(scene.task, NavTask) + 2 * isinstance(scene.task, TraverseTask)
    if terrain and scene.terrain is not None:
        marked = {t.kind for t in scene.terrain.tiles} - {"flat"}
        n += 1 + len(marked) + ("stair" in marked or "slope" in marked)  # pyramids and pits too
        n += len({f.kind for f in scene.terrain.features or ()})
    return n


def _bar_place(fig: Figure, layout: Any, shown: Any) -> tuple[str, tuple[float, float]] | None:
    """Where the scale bar goes beside the map, in figure fractions, so it never covers the legend:
    at the foot of the legend's column when the legend ends above the map's foot, else just
    under the legend when there is room there; None: in the map's lower left corner (a wide,
    low scene whose legend fills the column)."""
    foot = ("lower left", (layout.legend_anchor[0], layout.axes[1]))
    if shown is None:
        return foot
    box = shown.get_window_extent(fig.canvas.get_renderer()).transformed(fig.transFigure.inverted())
    tall = (FONT_PT * 1.4 + 8) / 72 / fig.get_figheight()  # the bar and its label
    if box.y0 - tall >= layout.axes[1]:
        return foot
    if box.y0 - tall >= 0.01:
        return ("upper left", (layout.legend_anchor[0], box.y0 - 0.2 * tall))
    return None


# --- public API -------------------------------------------------------------------


def _figure(scene: Scene, file: str | None, size_px: int, terrain: bool, legend: bool) -> Figure:
    width_m, height_m = scene.bounds.size
    if not (width_m > 0 and height_m > 0):
        found = f"a size of {width_m:g} x {height_m:g} m"
        raise SpecError([Problem("$.bounds", "max greater than min in x and y", found)], file=file)
    layout = figure_layout(width_m, height_m, size_px, _legend_size(scene, terrain), legend)
    fig = Figure(figsize=(layout.width_px / layout.dpi, layout.height_px / layout.dpi), dpi=layout.dpi)
    FigureCanvasAgg(fig)
    fig.set_facecolor(_OUTSIDE)
    ax = fig.add_axes(layout.axes)
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal", adjustable="box", anchor="C")
    ax.set_facecolor(_BACKGROUND)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(_title(scene), loc="left", fontsize=FONT_PT)
    ax.tick_params(labelsize=FONT_PT - 0.5)
    px_per_m = layout.px_per_m / width_m
    m_per_pt = layout.dpi / 72 / px_per_m

    entries = _Legend([])
    shade = terrain and scene.terrain is not None
    _draw_zones(ax, scene, px_per_m, entries)
    if shade:
        _draw_terrain(ax, scene, px_per_m, entries)
    _draw_blocks(ax, scene, m_per_pt, entries)
    _draw_placements(ax, scene, file, entries)
    _draw_agents(ax, scene, entries)
    _draw_task(ax, scene, m_per_pt, entries)

    shown = None
    if legend and entries.handles:
        shown = fig.legend(
            handles=entries.handles,
            loc="upper left",
            bbox_to_anchor=layout.legend_anchor,
            frameon=False,
            fontsize=FONT_PT,
            handlelength=1.8,
            borderaxespad=0.0,
        )
    bar = scale_bar_length(width_m)
    place = _bar_place(fig, layout, shown) if legend else None
    ax.add_artist(
        AnchoredSizeBar(
            ax.transData,
            bar,
            f"{bar:g} m",
            place[0] if place else "lower left",
            pad=0.3,
            borderpad=0.0 if place else 0.6,
            sep=3,
            color="black",
            frameon=place is None,
            size_vertical=1.8 * m_per_pt,
            fontproperties=FontProperties(size=FONT_PT),
            zorder=10,
            **({"bbox_to_anchor": place[1], "bbox_transform": fig.transFigure} if place else {}),
        )
    )
    ax.apply_aspect()
    return fig


def figure(
    scene: Scene | str | Path, *, size_px: int = 1600, terrain: bool = True, legend: bool = True
) -> Figure:
    """The top-down map of a scene as a matplotlib :class:`~matplotlib.figure.Figure`
    (Agg canvas, no pyplot), for adding overlays before saving or showing it in a notebook.

    ``size_px`` is the picture's larger side in pixels; the other follows the scene's
    bounds. The map axes are ``fig.axes[0]``, in metres; the legend is ``fig.legends[0]``.
    """
    size_px = check_size(size_px)
    model, _ = as_scene(scene)
    file = None if isinstance(scene, Scene) else str(scene)
    with style():
        return _figure(model, file, size_px, terrain, legend)


def render(
    scene: Scene | str | Path,
    path: str | Path,
    *,
    size_px: int = 1600,
    terrain: bool = True,
    legend: bool = True,
) -> Path:
    """Draw the scene top-down and write it as a PNG to ``path`` (atomically); returns ``path``.

    ``size_px`` is the picture's larger side in pixels (64 to 8192); the other side
    follows the scene's bounds. ``terrain=False`` leaves out the hillshade and the tile
    marks; ``legend=False`` leaves out the legend (the map gets wider). The same scene
    and options always give the same bytes.
    """
    size_px = check_size(size_px)
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ExportError(f"{path}: expected a path ending in .png, got {path.suffix or 'no suffix'!r}")
    model, _ = as_scene(scene)
    file = None if isinstance(scene, Scene) else str(scene)
    buf = io.BytesIO()
    with style():
        fig = _figure(model, file, size_px, terrain, legend)
        # No "Software" (matplotlib's version) and no time: the bytes depend on the scene only.
        fig.savefig(buf, format="png", dpi=fig.dpi, metadata={"Software": None})
    try:
        write_atomic(path, buf.getvalue())
    except OSError as exc:
        raise ExportError(f"{path}: cannot write the picture: {exc.strerror or type(exc).__name__}") from None
    return path


_OPTIONS = ("name", "size_px", "terrain", "legend")


def export(scene: Scene | str | Path, out_dir: str | Path, **options: object) -> list[Path]:
    """Write ``<out_dir>/<name>.png`` (see :func:`render`); returns ``[that path]``.

    Options: ``name`` (default: the scene file's stem, or ``<split>-<index>`` from the
    scene's meta, or ``scene``), ``size_px``, ``terrain``, ``legend``.
    """
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        allowed = ", ".join(_OPTIONS)
        raise ExportError(f"picture export: unknown option {unknown[0]!r}; expected one of {allowed}")
    name = output_name(scene, options.get("name"), "picture")
    kwargs: dict[str, Any] = {k: options[k] for k in ("size_px", "terrain", "legend") if k in options}
    return [render(scene, Path(out_dir) / f"{name}.png", **kwargs)]
