"""Occupancy map: a scene as a labelled grid for planners, ROS and the runner.

:func:`occupancy` rasterises a scene on a regular grid of square cells (default
:data:`DEFAULT_RESOLUTION` = 0.05 m) covering its bounds, from ``bounds.min``; row ``r``
and column ``c`` is the cell whose centre is ``(x0 + (c + 0.5) * res, y0 + (r + 0.5) * res)``,
so rows grow with +y. A cell takes a zone's class when its *centre* lies in the zone,
boundary included (:mod:`citygen.geometry.raster`), and an object's when it overlaps the
object's base at all. Three layers, each ``(rows, cols)``:

- ``labels`` (uint8): what stands on the cell, an index into :data:`CLASSES`. Precedence,
  highest first: ``out_of_bounds`` (centre outside ``$.bounds``: only in the last row or
  column when the bounds are not a whole number of cells), then placement *bases*
  (:attr:`~citygen.assets.Asset.base`, the parts below 2 m a robot can walk into, moved
  by the placement's scale, yaw and position; ``building`` for the building massing
  category, ``obstacle`` for every other object; a mesh file's base is the convex hull of
  its vertices seen from above, as :func:`citygen.validate` measures it), then zones by
  kind (a later zone wins where zones overlap, which a valid scene never has), then
  ``ground``: ground inside the bounds that no zone covers (non-walkable, as the spec says,
  except in a scene without any zone, an Urban-Loc grid, where all ground is open and
  walkable: the npz's ``walkable`` flags say so). Objects are rasterised
  *conservatively*: every cell their base overlaps at all is theirs
  (:func:`conservative`), so a thin post or sign always occupies a cell; zones take the
  cells whose centres they hold.
- ``terrain`` (uint8): the kind of the terrain tile under the cell centre (of a terrain
  feature where one covers it: ``stair`` for steps, ``slope`` for a ramp), an index into
  :data:`TERRAIN_CLASSES` (``flat`` outside the tile grid and without terrain; pyramids and
  pits are ``slope`` or ``stair``). It is a separate layer because a stair on a sidewalk is
  still a sidewalk: a legged robot may walk it, a wheeled one may not.
- ``heights`` (float32, m): the ground's height at the cell centre,
  :func:`~citygen.geometry.terrain.height_at` (objects are not in it).

Classes (:data:`CLASSES`, stable ids: new zone kinds are appended)::

    0 out_of_bounds   1 ground    2 obstacle   3 roadway   4 bike_lane   5 parking
    6 curb            7 sidewalk  8 crosswalk  9 plaza    10 trail      11 building
    12 vegetation    13 water

Walkable classes are the spec's walkable zone kinds
(:data:`~citygen.spec.surfaces.WALKABLE_ZONES`: sidewalk, crosswalk, plaza, trail);
``obstacle`` and ``building`` stand up from the ground (:meth:`OccupancyMap.obstacle_mask`).

Files (:func:`export`, named ``<name>`` like the other exporters):

- ``<name>.npz``: keys ``labels``, ``heights``, ``terrain``, ``origin`` (float64
  ``[x0, y0]``, m: the grid's minimum corner), ``resolution`` (float64, m), ``classes`` and
  ``terrain_classes`` (unicode arrays of names indexed by value), ``walkable`` (bool per
  class) and ``format`` (``citygen.occupancy/1``). Every array is plain numeric or unicode,
  so ``np.load(path, allow_pickle=False)`` reads it; :func:`load` gives an
  :class:`OccupancyMap` back.
- ``<name>.pgm`` and ``<name>.yaml``: a ROS ``map_server`` pair. The PGM (binary P5, 8 bit)
  is :data:`PGM_FREE` (254) where the cell is walkable and :data:`PGM_OCCUPIED` (0)
  everywhere else (objects, buildings, roadway, vegetation, out of bounds ...); its first
  row is the grid's last (max y), as map_server expects. The YAML says ``image``,
  ``resolution``, ``origin: [x0, y0, 0.0]``, ``negate: 0``, ``occupied_thresh: 0.65``,
  ``free_thresh: 0.196`` and ``mode: trinary``.
- ``<name>-occupancy.png``: the labels in colour (:data:`CLASS_COLORS`: zone kinds in the
  PNG map's palette, :data:`~citygen.exporters.ZONE_COLORS`) with stair, slope and
  rough tiles tinted, a legend marking the walkable classes, and a scale bar.

Size: a grid has at most :data:`MAX_CELLS` cells (about 290 m x 290 m at 0.05 m, 1.2 km x
1.2 km at 0.21 m); a larger one is an :class:`~citygen.errors.ExportError` that names the
finest resolution that fits, never a silent change of resolution. Zones and objects cost
the cells under their bounding boxes; heights the cells over the terrain grid.

The same scene and options give the same bytes in every file (the npz is written with
fixed zip timestamps; :func:`numpy.savez` would stamp the current time).

>>> from citygen.exporters import occupancy
>>> m = occupancy.occupancy("examples/nav_static_10m.json", resolution=0.25)
>>> m.shape, m.classes[m.label_at(5.0, 5.0)], m.terrain_classes[m.terrain[m.cell(3.0, 5.0)]]
((40, 40), 'sidewalk', 'stair')
>>> round(float(m.walkable_mask().mean()), 3)
0.23
"""

from __future__ import annotations

import io
import math
import warnings
import zipfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, get_args

import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.errors import ExportError, Problem, SpecError
from citygen.exporters import OBJECT_COLOR, ZONE_COLORS, ExportWarning
from citygen.exporters.ground import zone_polygons
from citygen.exporters.meshes import catalog_asset, load_mesh_file
from citygen.exporters.options import check_options, output_name, resolution_option, scene_dir_of
from citygen.exporters.style import FONT_PT, check_size, figure_layout, scale_bar_length, style
from citygen.geometry.features import feature_mask
from citygen.geometry.raster import Grid, erode, paint
from citygen.geometry.terrain import height_at
from citygen.io import write_atomic
from citygen.outputs import staged
from citygen.spec.scene import Scene
from citygen.spec.surfaces import WALKABLE_ZONES, ZONE_KINDS
from citygen.spec.terrain import TILE_TYPES

if TYPE_CHECKING:  # matplotlib only where a picture is drawn: the runner builds maps
    from matplotlib.figure import Figure  # and never draws them

FORMAT = "citygen.occupancy/1"
"""The ``format`` entry of the npz; a reader checks it before trusting the keys."""

#: Class names indexed by label value (see the module docstring for precedence).
CLASSES: tuple[str, ...] = ("out_of_bounds", "ground", "obstacle", *ZONE_KINDS)
OUT_OF_BOUNDS, GROUND, OBSTACLE = 0, 1, 2
BUILDING = CLASSES.index("building")
#: Label value of each zone kind.
ZONE_CLASS = {kind: CLASSES.index(kind) for kind in ZONE_KINDS}
#: Classes a pedestrian or micromobility robot is meant to move on.
WALKABLE_CLASSES: tuple[int, ...] = tuple(i for i, name in enumerate(CLASSES) if name in WALKABLE_ZONES)
#: Classes that stand up from the ground: objects and buildings.
OBSTACLE_CLASSES: tuple[int, ...] = (OBSTACLE, BUILDING)
#: Terrain tile kinds indexed by ``terrain`` value; ``flat`` also where no tile is.
TERRAIN_CLASSES: tuple[str, ...] = tuple(get_args(t.model_fields["kind"].annotation)[0] for t in TILE_TYPES)

#: Default cell size (m).
DEFAULT_RESOLUTION = 0.05
#: Most cells in one map: an export peaks at about 11 bytes a cell (labels, terrain, heights,
#: the files being written), so about 370 MB at this limit.
MAX_CELLS = 1 << 25
#: PGM values: walkable and everything else (map_server reads 254 as free, 0 as occupied).
PGM_FREE, PGM_OCCUPIED = 254, 0
#: The ROS map_server thresholds written into the YAML.
OCCUPIED_THRESH, FREE_THRESH = 0.65, 0.196

#: Colour of each class in the PNG (hex RGB): zone kinds as in the PNG map.
#: Uncovered ground gets its own colour here: in the map's palette it is close to sidewalk's.
CLASS_COLORS = {"out_of_bounds": "#ffffff", "ground": "#e9c9c9", "obstacle": OBJECT_COLOR, **ZONE_COLORS}
#: Tint (hex RGB, alpha) of non-flat terrain kinds laid over the classes in the PNG.
TERRAIN_TINTS = {"slope": ("#1f5fd1", 0.35), "stair": ("#6a1b9a", 0.45), "rough": ("#b8860b", 0.4)}

_OPTIONS = ("name", "resolution", "scene_dir", "size_px", "legend")
_CHUNK_CELLS = 1 << 18  # cells per height_at call: its temporaries take about 200 bytes a cell
_ZIP_TIME = (1980, 1, 1, 0, 0, 0)
_NPZ_KEYS = (
    "format",
    "labels",
    "heights",
    "terrain",
    "origin",
    "resolution",
    "classes",
    "terrain_classes",
    "walkable",
)


# --- the map ---------------------------------------------------------------------------


@dataclass(frozen=True, eq=False)
class OccupancyMap:
    """A scene rasterised: ``labels``, ``terrain`` and ``heights`` on ``grid`` (see the module
    docstring). Arrays are ``grid.shape`` = ``(rows, cols)``, row 0 at the minimum y."""

    labels: np.ndarray
    """uint8 class per cell, an index into ``classes``."""
    heights: np.ndarray
    """float32 ground height (m) at each cell centre."""
    terrain: np.ndarray
    """uint8 terrain tile kind per cell, an index into ``terrain_classes``."""
    grid: Grid
    classes: tuple[str, ...] = CLASSES
    terrain_classes: tuple[str, ...] = TERRAIN_CLASSES
    walkable: tuple[bool, ...] = tuple(c in WALKABLE_ZONES for c in CLASSES)
    """Whether each class is walkable: the walkable zone kinds, and ``ground`` in a scene
    without zones (an Urban-Loc grid, all open ground)."""

    @property
    def shape(self) -> tuple[int, int]:
        """``(rows, cols)``."""
        return self.grid.shape

    @property
    def resolution(self) -> float:
        """Side of a cell (m)."""
        return self.grid.resolution

    @property
    def origin(self) -> tuple[float, float]:
        """The grid's minimum corner ``(x0, y0)`` (m): the outer corner of cell (0, 0)."""
        return (self.grid.x0, self.grid.y0)

    def class_id(self, name: str) -> int:
        """The label value of a class name."""
        try:
            return self.classes.index(name)
        except ValueError:
            raise ValueError(f"class: expected one of {', '.join(self.classes)}, got {name!r}") from None

    def _in(self, names: Sequence[str] | frozenset[str]) -> np.ndarray:
        lut = np.zeros(256, dtype=bool)
        lut[[i for i, n in enumerate(self.classes) if n in names]] = True
        return lut[self.labels]

    def walkable_mask(self) -> np.ndarray:
        """Cells a pedestrian or micromobility robot may stand on (bool): walkable zone
        kinds with no object on them (and open ground in a scene without zones). The ROS
        map's free cells."""
        return self._in(frozenset(c for c, ok in zip(self.classes, self.walkable, strict=True) if ok))

    def obstacle_mask(self) -> np.ndarray:
        """Cells under an object's base or a building (bool)."""
        return self._in(("obstacle", "building"))

    def occupied_mask(self) -> np.ndarray:
        """Cells that are not walkable (bool): the ROS map's occupied cells."""
        return ~self.walkable_mask()

    def inflated(self, radius: float) -> np.ndarray:
        """Occupied cells grown by ``radius`` (m): True where a disc of that radius centred
        on the cell centre would reach a non-walkable cell's centre or the map's edge
        (:func:`~citygen.geometry.raster.erode`), so a robot of that radius keeps its
        centre on False cells."""
        if isinstance(radius, bool) or not isinstance(radius, int | float) or not radius >= 0:
            raise ValueError(f"radius: expected a length >= 0 in metres, got {radius!r}")
        return ~erode(self.walkable_mask(), radius / self.resolution)

    def cell(self, x: float, y: float) -> tuple[int, int]:
        """The ``(row, col)`` of the cell containing ``(x, y)`` (m), clamped to the grid."""
        return self.grid.cell(x, y)

    def label_at(self, xs: Any, ys: Any) -> np.ndarray:
        """The label of the cells containing points ``(xs, ys)`` (m, broadcastable);
        ``out_of_bounds`` (0) for points outside the grid."""
        x, y = np.broadcast_arrays(np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64))
        g = self.grid
        col = np.floor((x - g.x0) / g.resolution)
        row = np.floor((y - g.y0) / g.resolution)
        inside = (col >= 0) & (col < g.cols) & (row >= 0) & (row < g.rows)
        out = np.zeros(x.shape, dtype=np.uint8)
        out[inside] = self.labels[row[inside].astype(np.int64), col[inside].astype(np.int64)]
        return out


def _grid(scene: Scene, resolution: float) -> Grid:
    """The grid over the scene's bounds, or an ExportError when it has too many cells."""
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    if not (x1 > x0 and y1 > y0):
        found = f"min [{x0:g}, {y0:g}], max [{x1:g}, {y1:g}]"
        raise SpecError([Problem("$.bounds", "max greater than min in x and y", found)])
    grid = Grid.covering((x0, y0, x1, y1), resolution)
    if grid.rows * grid.cols > MAX_CELLS:
        finest = finest_resolution(scene)
        raise ExportError(
            f"occupancy export: a {x1 - x0:g} m x {y1 - y0:g} m scene at resolution={resolution:g} m needs "
            f"{grid.cols:,} x {grid.rows:,} cells, more than {MAX_CELLS:,}; pass resolution={finest:g} "
            "(m) or coarser"
        )
    return grid


def finest_resolution(scene: Scene) -> float:
    """The finest cell size (m, in whole centimetres) at which the scene's map stays within
    :data:`MAX_CELLS` cells."""
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    finest = math.ceil(math.sqrt((x1 - x0) * (y1 - y0) / MAX_CELLS) * 100) / 100
    while (g := Grid.covering((x0, y0, x1, y1), finest)).rows * g.cols > MAX_CELLS:
        finest = round(finest + 0.01, 2)
    return finest


def auto_resolution(scene: Scene) -> tuple[float, str | None]:
    """:data:`DEFAULT_RESOLUTION`, or where the scene needs more than :data:`MAX_CELLS`
    cells at it, the finest that fits and a one-line note saying so."""
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    g = Grid.covering((x0, y0, x1, y1), DEFAULT_RESOLUTION)
    if g.rows * g.cols <= MAX_CELLS:
        return DEFAULT_RESOLUTION, None
    res = finest_resolution(scene)
    return res, (
        f"$.bounds: occupancy cells of {res:g} m, not {DEFAULT_RESOLUTION:g} m, to stay within "
        f"{MAX_CELLS:,} cells; pass resolution= (citygen export --occupancy-resolution) to choose"
    )


def _bases(scene: Scene, scene_dir: Path | None) -> list[tuple[shapely.Geometry, int]]:
    """Every placement's base in the world frame and its class, in spec order."""
    out: list[tuple[shapely.Geometry, int]] = []
    hulls: dict[str, np.ndarray | None] = {}
    for i, pl in enumerate(scene.placements):
        if pl.is_mesh:
            if pl.asset not in hulls:
                mesh = load_mesh_file(pl, i, scene_dir)
                hull = shapely.MultiPoint(np.asarray(mesh.vertices)[:, :2]).convex_hull
                hulls[pl.asset] = np.asarray(hull.exterior.coords) if isinstance(hull, Polygon) else None
            ring, cls = hulls[pl.asset], OBSTACLE
            if ring is None:
                warnings.warn(
                    ExportWarning(
                        f"$.placements[{i}].asset: {pl.asset!r} has no area seen from above; "
                        "left out of the occupancy map"
                    ),
                    stacklevel=3,
                )
                continue
        else:
            asset = catalog_asset(pl, i)
            ring = np.asarray(asset.base.exterior.coords)
            cls = BUILDING if asset.category == "building" else OBSTACLE
        c, s = math.cos(pl.yaw), math.sin(pl.yaw)
        xy = ring * pl.scale @ np.array([[c, s], [-s, c]]) + np.asarray(pl.position[:2])
        out.append((Polygon(xy), cls))
    return out


def conservative(shape: shapely.Geometry, resolution: float) -> shapely.Geometry:
    """The points whose cell (a square of side ``resolution`` centred on them) overlaps
    ``shape``: its Minkowski sum with that square, a hair smaller so that a cell merely
    touching the shape's edge is left out. Painting this by cell centres marks every cell
    the shape overlaps, however thin the shape."""
    h = resolution / 2 * (1 - 1e-6)
    rings = [np.asarray(shape.exterior.coords)] + [np.asarray(r.coords) for r in shape.interiors]
    corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
    hulls = []
    for ring in rings:
        ends = np.stack([ring[:-1], ring[1:]], axis=1)  # (edges, 2, 2)
        pts = (ends[:, :, None, :] + corners[None, None]).reshape(len(ends), 8, 2)
        hulls.append(shapely.convex_hull(shapely.multipoints(pts)))
    return shapely.union_all([shape, *np.concatenate(hulls).tolist()])


def _convex_ring(shape: shapely.Geometry) -> np.ndarray | None:
    """The exterior ring ``(n, 2)`` of a polygon without holes whose every corner turns the
    same way or goes straight on (a convex polygon), else None."""
    if not isinstance(shape, Polygon) or shape.interiors:
        return None
    ring = np.asarray(shape.exterior.coords)[:-1, :2]
    e = np.roll(ring, -1, axis=0) - ring
    turn = e[:, 0] * np.roll(e[:, 1], -1) - e[:, 1] * np.roll(e[:, 0], -1)
    return ring if len(ring) >= 3 and (np.all(turn >= 0) or np.all(turn <= 0)) else None


def conservative_all(shapes: list[shapely.Geometry], resolution: float) -> list[shapely.Geometry]:
    """:func:`conservative` of each shape, the convex ones at once: a convex polygon's sum
    with the cell's square is the convex hull of its corners moved to the square's four
    corners (one vectorised hull for all of them, where the edge by edge union took a
    city's 7,900 bases 3.8 s); the others by :func:`conservative`. Each paints the cells
    :func:`conservative`'s does (``tests/test_export_occupancy.py``)."""
    h = resolution / 2 * (1 - 1e-6)
    corners = np.array([[-h, -h], [h, -h], [h, h], [-h, h]])
    out: list[shapely.Geometry | None] = [None] * len(shapes)
    points, owner = [], []
    for k, shape in enumerate(shapes):
        ring = _convex_ring(shape)
        if ring is None:
            out[k] = conservative(shape, resolution)
            continue
        points.append((ring[:, None, :] + corners[None]).reshape(-1, 2))
        owner.append(np.full(4 * len(ring), len(owner)))
    if points:
        hulls = shapely.convex_hull(
            shapely.multipoints(np.concatenate(points), indices=np.concatenate(owner))
        )
        it = iter(hulls.tolist())
        out = [next(it) if g is None else g for g in out]
    return out


def _labels(scene: Scene, grid: Grid, bases: list[tuple[shapely.Geometry, int]]) -> np.ndarray:
    labels = np.full(grid.shape, GROUND, dtype=np.uint8)
    for zone, shape in zip(scene.zones, zone_polygons(scene), strict=True):
        paint(grid, labels, shape, ZONE_CLASS[zone.kind])
    grown = conservative_all([shape for shape, _ in bases], grid.resolution)
    for shape, (_, cls) in zip(grown, bases, strict=True):
        paint(grid, labels, shape, cls)
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    xs, ys = grid.xs(), grid.ys()
    labels[:, (xs < x0) | (xs > x1)] = OUT_OF_BOUNDS
    labels[(ys < y0) | (ys > y1), :] = OUT_OF_BOUNDS
    return labels


def _terrain_window(scene: Scene, grid: Grid) -> tuple[slice, slice]:
    """Rows and columns of the cells whose centres may lie on the tile grid (one cell of
    margin: :func:`height_at` itself decides the cells on its border)."""
    t, e = scene.terrain, grid.resolution
    ox, oy = t.origin
    return grid.window((ox - e, oy - e, ox + t.cols * t.tile_size + e, oy + t.rows * t.tile_size + e))


def _heights(scene: Scene, grid: Grid) -> np.ndarray:
    heights = np.zeros(grid.shape, dtype=np.float32)
    if scene.terrain is None:
        return heights
    rows, cols = _terrain_window(scene, grid)
    xs, ys = grid.xs()[cols], grid.ys()
    step = max(1, _CHUNK_CELLS // max(xs.size, 1))
    for r in range(rows.start, rows.stop, step):
        r1 = min(r + step, rows.stop)
        heights[r:r1, cols] = height_at(scene.terrain, xs[None, :], ys[r:r1, None])
    return heights


def _tile_index(coords: np.ndarray, origin: float, size: float, count: int) -> tuple[np.ndarray, np.ndarray]:
    """Tile index along one axis of each coordinate and whether it lies on the grid, by
    :func:`height_at`'s rule: the grid includes its border, and a coordinate on the border
    between two tiles belongs to the one with the larger index."""
    g = (coords - origin) / size
    return np.clip(np.floor(g), 0, count - 1).astype(np.int64), (g >= 0) & (g <= count)


def _terrain(scene: Scene, grid: Grid) -> np.ndarray:
    """The kind of the tile under each cell centre; ``flat`` (0) off the tile grid."""
    out = np.zeros(grid.shape, dtype=np.uint8)
    t = scene.terrain
    if t is None:
        return out
    rows, cols = _terrain_window(scene, grid)
    col, on_x = _tile_index(grid.xs()[cols], t.origin[0], t.tile_size, t.cols)
    row, on_y = _tile_index(grid.ys()[rows], t.origin[1], t.tile_size, t.rows)
    kinds = np.array([TERRAIN_CLASSES.index(tile.kind) for tile in t.tiles], dtype=np.uint8)
    window = kinds.reshape(t.rows, t.cols)[row][:, col]  # uint8 throughout: no index grid
    window[~on_y, :] = 0
    window[:, ~on_x] = 0
    out[rows, cols] = window
    # A terrain feature's cells: steps are stairs, a ramp a slope, a landing flat ground.
    for kind, tile_kind in (("landing", "flat"), ("ramp", "slope"), ("steps", "stair")):
        features = [f for f in t.features or () if f.kind == kind]
        if features:
            out[feature_mask(features, grid.xs(), grid.ys())] = TERRAIN_CLASSES.index(tile_kind)
    return out


def occupancy(
    scene: Scene | str | Path, resolution: float = DEFAULT_RESOLUTION, *, scene_dir: str | Path | None = None
) -> OccupancyMap:
    """The scene's occupancy map in memory, cells of ``resolution`` metres.

    ``scene_dir`` is the folder mesh placements are relative to, for a scene given as a
    model (a scene file's own folder otherwise). Raises :class:`~citygen.errors.ExportError`
    when the grid would exceed :data:`MAX_CELLS` cells.
    """
    res = resolution_option(resolution, "occupancy") or DEFAULT_RESOLUTION
    model, folder = scene_dir_of(scene, {"scene_dir": scene_dir})
    grid = _grid(model, res)
    labels = _labels(model, grid, _bases(model, folder))
    walkable = tuple(c in WALKABLE_ZONES or (c == "ground" and not model.zones) for c in CLASSES)
    return OccupancyMap(labels, _heights(model, grid), _terrain(model, grid), grid, walkable=walkable)


# --- files -----------------------------------------------------------------------------


def npz_bytes(m: OccupancyMap) -> bytes:
    """The map as an ``.npz`` (deflated zip of ``.npy`` files, see the module docstring);
    the same map always gives the same bytes (fixed zip timestamps and attributes)."""
    arrays = {
        "format": np.array(FORMAT),
        "labels": m.labels.astype(np.uint8, copy=False),
        "heights": m.heights.astype(np.float32, copy=False),
        "terrain": m.terrain.astype(np.uint8, copy=False),
        "origin": np.array(m.origin, dtype=np.float64),
        "resolution": np.array(m.resolution, dtype=np.float64),
        "classes": np.array(m.classes, dtype=np.str_),
        "terrain_classes": np.array(m.terrain_classes, dtype=np.str_),
        "walkable": np.array(m.walkable, dtype=bool),
    }
    buf = io.BytesIO()
    with zipfile.ZipFile(buf, "w", compression=zipfile.ZIP_DEFLATED, compresslevel=6) as zf:
        for key in _NPZ_KEYS:
            info = zipfile.ZipInfo(f"{key}.npy", date_time=_ZIP_TIME)
            info.compress_type = zipfile.ZIP_DEFLATED
            info.create_system = 3  # Unix, whatever the platform
            info.external_attr = 0o644 << 16
            with zf.open(info, "w", force_zip64=True) as f:
                np.lib.format.write_array(f, arrays[key], allow_pickle=False)
    return buf.getvalue()


def load(path: str | Path) -> OccupancyMap:
    """An occupancy map read back from an ``.npz`` written by :func:`export`.

    Raises :class:`~citygen.errors.SpecError` naming the key when the file is not one.
    """
    file = str(path)

    def fail(key: str, expected: str, found: str) -> SpecError:
        return SpecError([Problem(key, expected, found)], file=file)

    try:
        with np.load(path, allow_pickle=False) as npz:
            data = {k: npz[k] for k in npz.files if k in _NPZ_KEYS}
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as exc:
        raise fail("$", "an occupancy map (.npz)", f"{type(exc).__name__}: {exc}") from None
    missing = [k for k in _NPZ_KEYS if k not in data]
    if missing:
        raise fail(missing[0], "an array of that name in the .npz", "none")
    if data["format"].shape != () or str(data["format"]) != FORMAT:
        raise fail("format", repr(FORMAT), repr(data["format"].tolist()))
    labels, heights, terrain = data["labels"], data["heights"], data["terrain"]
    if labels.ndim != 2 or labels.dtype != np.uint8:
        raise fail("labels", "a 2-D uint8 array", f"{labels.ndim}-D {labels.dtype}")
    for key, arr in (("heights", heights), ("terrain", terrain)):
        if arr.shape != labels.shape:
            raise fail(key, f"an array of the labels' shape {labels.shape}", str(arr.shape))
    origin, res = data["origin"], data["resolution"]
    if origin.shape != (2,) or res.shape != () or not (np.all(np.isfinite(origin)) and float(res) > 0):
        raise fail(
            "origin", "[x0, y0] (m) and a positive resolution (m)", f"{origin.tolist()}, {res.tolist()}"
        )
    classes = tuple(str(c) for c in data["classes"].tolist())
    terrain_classes = tuple(str(c) for c in data["terrain_classes"].tolist())
    if labels.size and int(labels.max()) >= len(classes):
        raise fail("labels", f"values below {len(classes)} (the classes)", str(int(labels.max())))
    walkable = tuple(bool(w) for w in data["walkable"].tolist())
    if len(walkable) != len(classes):
        raise fail("walkable", f"one flag per class ({len(classes)})", str(len(walkable)))
    grid = Grid(float(origin[0]), float(origin[1]), float(res), labels.shape[0], labels.shape[1])
    return OccupancyMap(
        labels, heights.astype(np.float32, copy=False), terrain, grid, classes, terrain_classes, walkable
    )


def pgm_bytes(m: OccupancyMap) -> bytes:
    """The binary occupancy as a P5 PGM: :data:`PGM_FREE` where walkable, :data:`PGM_OCCUPIED`
    elsewhere; the first image row is the grid's last row (max y)."""
    image = np.where(m.walkable_mask(), np.uint8(PGM_FREE), np.uint8(PGM_OCCUPIED))[::-1]
    header = f"P5\n{m.grid.cols} {m.grid.rows}\n255\n".encode("ascii")
    return header + np.ascontiguousarray(image).tobytes()


def _num(x: float) -> str:
    """A float as YAML reads it back exactly (Python's shortest round-trip repr)."""
    return repr(float(x))


def ros_yaml(m: OccupancyMap, image: str) -> str:
    """The map_server YAML for the PGM file named ``image`` (relative to the YAML)."""
    x0, y0 = m.origin
    return (
        f"image: {image}\n"
        f"resolution: {_num(m.resolution)}\n"
        f"origin: [{_num(x0)}, {_num(y0)}, 0.0]\n"
        "negate: 0\n"
        f"occupied_thresh: {OCCUPIED_THRESH}\n"
        f"free_thresh: {FREE_THRESH}\n"
        "mode: trinary\n"
    )


def _rgba(colour: str, alpha: float = 1.0) -> np.ndarray:
    """``#rrggbb`` and an alpha in [0, 1] as 8-bit RGBA (images of bytes keep matplotlib's
    copies of them small)."""
    h = colour.lstrip("#")
    return np.array([int(h[i : i + 2], 16) for i in (0, 2, 4)] + [round(alpha * 255)], dtype=np.uint8)


def _blend(base: str, tint: str, alpha: float) -> str:
    """The colour ``tint`` at ``alpha`` over ``base`` shows as (8-bit alpha, as drawn)."""
    a = _rgba(tint, alpha)[3] / 255
    mixed = a * _rgba(tint)[:3].astype(float) + (1 - a) * _rgba(base)[:3].astype(float)
    return "#" + "".join(f"{round(v):02x}" for v in mixed)


def figure(m: OccupancyMap, *, size_px: int = 1600, legend: bool = True, title: str = "") -> Figure:
    """The map as a matplotlib :class:`~matplotlib.figure.Figure` (Agg canvas, no pyplot):
    classes in colour, non-flat terrain tinted, a legend of what the map holds, a scale bar;
    axes in metres. ``size_px`` is the larger side of the picture in pixels."""
    size_px = check_size(size_px)
    with style():
        return _figure(m, size_px, legend, title)


def _values(a: np.ndarray) -> np.ndarray:
    """The distinct values of a uint8 array, ascending (counted a band of rows at a time:
    ``bincount`` of the whole would copy it as 64-bit integers)."""
    seen = np.zeros(256, dtype=bool)
    step = max(1, _CHUNK_CELLS // max(a.shape[1], 1))
    for r in range(0, a.shape[0], step):
        seen |= np.bincount(a[r : r + step].ravel(), minlength=256) > 0
    return np.flatnonzero(seen)


def _figure(m: OccupancyMap, size_px: int, legend: bool, title: str) -> Figure:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.font_manager import FontProperties
    from matplotlib.patches import Patch
    from mpl_toolkits.axes_grid1.anchored_artists import AnchoredSizeBar

    g = m.grid
    width_m, height_m = g.cols * g.resolution, g.rows * g.resolution
    # At most about one cell per pixel: sample every k-th cell at the middle of its block.
    k = max(1, math.ceil(max(g.rows, g.cols) / size_px))
    labels, terrain = m.labels[k // 2 :: k, k // 2 :: k], m.terrain[k // 2 :: k, k // 2 :: k]
    present, kinds = _values(m.labels), _values(m.terrain)
    handles = [
        Patch(
            facecolor=CLASS_COLORS.get(m.classes[i], "#000000"),
            edgecolor="#555555",
            label=f"{m.classes[i]} (walkable)" if m.walkable[i] else m.classes[i],
        )
        for i in present.tolist()
    ]
    tints = {m.terrain_classes[i]: TERRAIN_TINTS[m.terrain_classes[i]] for i in kinds.tolist()
             if m.terrain_classes[i] in TERRAIN_TINTS}  # fmt: skip
    # A tinted tile shows as its class's colour under the tint: one entry per pair drawn.
    pairs = np.flatnonzero(np.bincount((labels.astype(np.uint16) << 8 | terrain).ravel(), minlength=1 << 16))
    for kind, (colour, alpha) in tints.items():
        t = m.terrain_classes.index(kind)
        for i in (int(c) >> 8 for c in pairs if int(c) & 0xFF == t):
            name = m.classes[i]
            handles.append(Patch(
                facecolor=_blend(CLASS_COLORS.get(name, "#000000"), colour, alpha), edgecolor="#555555",
                label=f"{name} on a {kind} tile",
            ))  # fmt: skip
    layout = figure_layout(width_m, height_m, size_px, len(handles), legend)
    fig = Figure(figsize=(layout.width_px / layout.dpi, layout.height_px / layout.dpi), dpi=layout.dpi)
    FigureCanvasAgg(fig)
    fig.set_facecolor("white")
    ax = fig.add_axes(layout.axes)
    x0, y0 = m.origin
    ax.set_xlim(x0, x0 + width_m)
    ax.set_ylim(y0, y0 + height_m)
    ax.set_aspect("equal", adjustable="box", anchor="C")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.tick_params(labelsize=FONT_PT - 0.5)
    ax.set_title(title or f"occupancy {g.cols} x {g.rows} cells of {g.resolution:g} m", loc="left",
                 fontsize=FONT_PT)  # fmt: skip
    lut = np.array([_rgba(CLASS_COLORS.get(c, "#000000")) for c in m.classes])
    extent = (x0, x0 + labels.shape[1] * k * g.resolution, y0, y0 + labels.shape[0] * k * g.resolution)
    common = {"extent": extent, "origin": "lower", "interpolation": "nearest", "resample": False}
    ax.imshow(lut[labels], zorder=1, **common)
    if tints:
        tlut = np.zeros((len(m.terrain_classes), 4), dtype=np.uint8)
        for kind, (colour, alpha) in tints.items():
            tlut[m.terrain_classes.index(kind)] = _rgba(colour, alpha)
        ax.imshow(tlut[terrain], zorder=2, **common)
    bar = scale_bar_length(width_m)
    px_per_m = layout.px_per_m / width_m
    ax.add_artist(
        AnchoredSizeBar(
            ax.transData, bar, f"{bar:g} m", "lower left", pad=0.3, borderpad=0.6, sep=3, color="black",
            frameon=True, size_vertical=1.8 * layout.dpi / 72 / px_per_m,
            fontproperties=FontProperties(size=FONT_PT), zorder=10,
        )
    )  # fmt: skip
    if legend and handles:
        fig.legend(
            handles=handles, loc="upper left", bbox_to_anchor=layout.legend_anchor, frameon=False,
            fontsize=FONT_PT, handlelength=1.8, borderaxespad=0.0,
        )  # fmt: skip
    return fig


def png_bytes(m: OccupancyMap, *, size_px: int = 1600, legend: bool = True, title: str = "") -> bytes:
    """The picture of :func:`figure` as PNG bytes, the same for the same map and options."""
    size_px = check_size(size_px)
    buf = io.BytesIO()
    with style():
        fig = _figure(m, size_px, legend, title)
        # No "Software" (matplotlib's version) and no time: the bytes depend on the map only.
        fig.savefig(buf, format="png", dpi=fig.dpi, metadata={"Software": None})
    return buf.getvalue()


def export(scene: Scene | str | Path, out_dir: str | Path, **options: object) -> list[Path]:
    """Write ``<name>.npz``, ``<name>.yaml``, ``<name>.pgm`` and ``<name>-occupancy.png``
    into ``out_dir`` (atomically); returns their paths in that order.

    Options: ``name`` (default: the scene file's stem, else ``<split>-<index>``, else
    ``scene``), ``resolution`` (cell side in m; default 0.05, or the finest that keeps the
    map within :data:`MAX_CELLS` cells, with a warning), ``scene_dir`` (the folder mesh
    placements are relative to, for a scene given as a model), ``size_px`` (the PNG's
    larger side, default 1600) and ``legend`` (default True). Agents and the task are not
    part of a static map: an :class:`~citygen.exporters.ExportWarning` says so.
    """
    check_options(dict(options), _OPTIONS, "occupancy")
    name = output_name(scene, dict(options), "occupancy")
    size_px = check_size(options.get("size_px", 1600))
    legend = options.get("legend", True)
    if not isinstance(legend, bool):
        raise ExportError(f"occupancy export: expected True or False for 'legend', got {legend!r}")
    model, folder = scene_dir_of(scene, dict(options))
    resolution = options.get("resolution")
    if resolution is None:
        resolution, note = auto_resolution(model)
        if note is not None:
            warnings.warn(ExportWarning(note), stacklevel=2)
    m = occupancy(model, resolution, scene_dir=folder)  # type: ignore[arg-type]
    if model.agents:
        warnings.warn(
            ExportWarning(
                f"$.agents: an occupancy map is static; {len(model.agents)} agent(s) left out "
                "(MJCF and GLB keep them)"
            ),
            stacklevel=2,
        )
    if model.task is not None:
        warnings.warn(
            ExportWarning(f"$.task: an occupancy map has no task; the {model.task.kind} task is left out"),
            stacklevel=2,
        )
    out = Path(out_dir)
    paths = [out / f"{name}.npz", out / f"{name}.yaml", out / f"{name}.pgm", out / f"{name}-occupancy.png"]
    title = f"{name}: {m.grid.cols} x {m.grid.rows} cells of {m.resolution:g} m"
    contents = (
        lambda: npz_bytes(m),
        lambda: ros_yaml(m, paths[2].name).encode("utf-8"),
        lambda: pgm_bytes(m),
        lambda: png_bytes(m, size_px=size_px, legend=legend, title=title),
    )
    try:
        with staged(out) as stage:  # the yaml never names a pgm that is not there
            for path, content in zip(paths, contents, strict=True):
                write_atomic(stage / path.name, content())
    except OSError as exc:
        raise ExportError(
            f"{out}: cannot write the occupancy map: {exc.strerror or type(exc).__name__}"
        ) from None
    return paths
