"""The terrain's non-level tiles in MJCF: a heightfield per slope and rough tile (one
asset per distinct geometry and sampling, planned within the model's sample budget),
boxes for stairs; each such tile has one friction, from the zones under it."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from typing import Any

import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.errors import ExportError
from citygen.exporters import lod
from citygen.exporters.mjcf.builder import DEFAULT_FRICTION, GROUND_RGBA, ZONE_RGBA, Builder, friction
from citygen.exporters.mjcf.text import ints, nums
from citygen.geometry.convex import AREA_EPS
from citygen.geometry.pieces import Pieces, prism_mesh, rpy_quat, tile_pieces
from citygen.geometry.terrain import tile_boxes, tile_grid
from citygen.geometry.tiles import tile_kind
from citygen.spec.surfaces import FRICTION
from citygen.spec.terrain import RoughTile, SlopeTile, StairTile

#: Thickness (m) of every heightfield below its lowest sample.
HFIELD_BASE = 1.0
#: Contact time constant (s) of a heightfield under ``terrain="hybrid"`` (the runner's under
#: feet), against MuJoCo's 0.02 elsewhere: a trotting foot sinks about a millimetre into it
#: rather than 1.4 cm, short of the depth at which a heightfield's contacts turn sideways and
#: hold the foot (see :mod:`citygen.exporters.mjcf`, "Terrain"). Twice a 5 ms physics step,
#: the stiffest MuJoCo keeps stable.
HYBRID_HFIELD_TIMECONST = 0.01
#: Default of the ``resolution`` option: heightfield sample spacing (m).
DEFAULT_RESOLUTION = 0.1
#: Height step (m) of heightfield samples (they are written as whole numbers of it).
HFIELD_UNIT = 1e-5
#: Most heightfield samples in one model (bounds the XML's size: about 6 bytes a sample).
MAX_HFIELD_SAMPLES = 1 << 24
#: Most samples along one side of a tile's heightfield.
MAX_HFIELD_SIDE = 257


def level(tile: Any) -> bool:
    """Whether a tile is flat ground at its height (slabs rather than boxes or a heightfield)."""
    return tile_kind(tile).level(tile)


def own_friction(tile: Any) -> float | None:
    if tile.friction is not None:
        return tile.friction
    if tile.material is not None:
        return FRICTION[tile.material]
    return None


def _zone_areas(
    squares: np.ndarray, zones: list[Polygon], tree: Any
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """For tile squares (an array of boxes): the pairs ``(square, zone)`` that intersect,
    sorted by square then zone index, and each pair's area of overlap (m^2), all at once."""
    pairs = tree.query(squares, predicate="intersects")
    order = np.lexsort((pairs[1], pairs[0]))
    tiles, zis = pairs[0][order], pairs[1][order]
    areas = shapely.area(shapely.intersection(np.asarray(zones, dtype=object)[zis], squares[tiles]))
    return tiles, zis, areas


def _tile_ground(b: Builder, k: int, square_area: float, zis: list[int], areas: list[float]):
    """The friction and material of a non-level tile (``square_area`` m^2), given the zones
    ``zis`` meeting it in ascending order and their areas of overlap, and whether zones of
    different friction share it."""
    tile = b.scene.terrain.tiles[k]
    best, best_area, mus = None, 0.0, []
    for zi, area in zip(zis, areas, strict=True):
        if area > AREA_EPS:
            mus.append(b.scene.zones[zi].mu)
            if area > best_area:
                best, best_area = b.scene.zones[zi], area
    if best is None:
        mat = b.material("ground", GROUND_RGBA)
    else:
        mat = b.material(f"zone:{best.kind}", ZONE_RGBA[best.kind])
    own = own_friction(tile)
    if own is not None:
        return own, mat, False
    if best is None:
        return DEFAULT_FRICTION, mat, False
    covered = best_area >= square_area * (1 - 1e-9)
    mixed = len(set(mus)) > 1 or (not covered and best.mu != DEFAULT_FRICTION)
    return best.mu, mat, mixed


def _hfield_cells(tile: SlopeTile | RoughTile, s: float, resolution: float) -> int:
    if isinstance(tile, RoughTile):  # finer, to resolve the bumps, but at most 4 times
        resolution = min(resolution, max(tile.scale / 8.0, resolution / 4.0))
    cells = math.ceil(s / resolution - 1e-9)
    if isinstance(tile, SlopeTile) and tile.shape is not None:
        cells = 3 * math.ceil(cells / 3)  # samples on the platform's edges at s/3 and 2s/3
    return int(min(max(cells, 1), MAX_HFIELD_SIDE - 1))


#: The tile kinds each ``terrain`` option draws as heightfields; the other slope and rough
#: tiles are convex pieces, stairs always boxes.
HFIELD_KINDS: dict[str, tuple[type, ...]] = {
    "heightfield": (SlopeTile, RoughTile), "hybrid": (RoughTile,), "convex": (),
}  # fmt: skip


def _geometry_key(tile: SlopeTile | RoughTile) -> tuple:
    return tuple(sorted(tile.model_dump(exclude={"height", "material", "friction"}).items()))


def hfield_plan(b: Builder, shaped: list[int]) -> dict[int, int]:
    """Cells along a side of each slope and rough tile's heightfield (tile index -> cells):
    by ``resolution``, or when none was given, :data:`DEFAULT_RESOLUTION`, where the scene's
    heightfields would exceed :data:`~citygen.exporters.lod.BUDGETS` samples made coarser
    (rough tiles by :func:`~citygen.exporters.lod.fit`, rougher tiles finer; slopes uniformly
    if they alone would take more than half), with one warning; an explicit resolution
    beyond :data:`MAX_HFIELD_SAMPLES` is an ExportError."""
    terrain = b.scene.terrain
    s = terrain.tile_size
    tiles = {k: terrain.tiles[k] for k in shaped if isinstance(terrain.tiles[k], HFIELD_KINDS[b.terrain])}
    res = b.resolution if b.resolution is not None else DEFAULT_RESOLUTION
    cells = {k: _hfield_cells(t, s, res) for k, t in tiles.items()}

    def samples(plan: dict[int, int]) -> int:
        unique = {(_geometry_key(tiles[k]), c) for k, c in plan.items()}
        return sum((c + 1) ** 2 for _, c in unique)

    limit = MAX_HFIELD_SAMPLES if b.resolution is not None else lod.BUDGETS["mjcf"]
    if samples(cells) <= limit:
        return cells
    if b.resolution is not None:
        unique = len({_geometry_key(t) for t in tiles.values()})
        cap = lod.cells_within(limit, unique, lambda c: (c + 1) ** 2)
        raise ExportError(
            f"mjcf export: the terrain's heightfields need {samples(cells):,} samples at resolution="
            f"{b.resolution:g} m, more than {MAX_HFIELD_SAMPLES:,}; pass a coarser resolution, e.g. "
            f"resolution={4 * s / cap:.3g} (m)"
        )
    plan = dict(cells)
    slopes = {k: c for k, c in cells.items() if isinstance(tiles[k], SlopeTile)}
    if samples(slopes) > limit // 2:
        unique = len({_geometry_key(tiles[k]) for k in slopes})
        cap = lod.cells_within(limit // 2, unique, lambda c: (c + 1) ** 2)
        cap = max(cap - cap % 3, 3)  # a multiple of 3: shaped slopes keep their platform's edges
        plan.update({k: min(c, cap) for k, c in slopes.items()})
    default = np.zeros(len(terrain.tiles), dtype=np.int64)
    share = np.arange(len(terrain.tiles))
    keys: dict[tuple, int] = {}
    for k, t in tiles.items():
        if isinstance(t, RoughTile):
            default[k] = cells[k]
            share[k] = keys.setdefault(_geometry_key(t), k)
    most = np.zeros_like(default)
    most[default > 0] = MAX_HFIELD_SIDE - 1
    fixed = samples({k: c for k, c in plan.items() if isinstance(tiles[k], SlopeTile)})
    chosen = lod.fit(
        b.scene, default, limit, most=most, fixed=fixed, cost=lambda c: (c + 1) ** 2, share=share
    )
    if chosen is None:  # the slopes' coarsening was enough
        chosen = default
    plan.update({k: int(chosen[k]) for k in tiles if isinstance(tiles[k], RoughTile)})
    table = np.zeros(len(terrain.tiles), dtype=np.int64)
    table[list(plan)] = list(plan.values())
    b.warnings.append(
        lod.warning(
            "MJCF", b.scene, table, f"{limit:,} heightfield samples",
            "resolution= (citygen export --terrain-resolution)", what="heightfields",
        )
    )  # fmt: skip
    return plan


def shaped_tiles(
    b: Builder, zones: list[Polygon], tree: Any, shaped: list[int], plan: dict[int, int]
) -> None:
    """The non-level tiles (indices ``shaped``): a heightfield of ``plan[k]`` cells a side for
    each slope and rough tile (:func:`hfield_plan`), boxes for stairs."""
    terrain = b.scene.terrain
    s = terrain.tile_size
    hfields: dict[tuple, tuple[str, float]] = {}
    pieces: dict[Any, tuple[Pieces, list[str]]] = {}
    mixed: list[int] = []
    if not shaped:
        return
    ids = np.asarray(shaped)
    xs = terrain.origin[0] + (ids % terrain.cols) * s
    ys = terrain.origin[1] + (ids // terrain.cols) * s
    squares = shapely.box(xs, ys, xs + s, ys + s)  # as rect(x, y, x + s, y + s) makes them
    square_areas = shapely.area(squares).tolist()
    tiles, zis, areas = _zone_areas(squares, zones, tree)
    runs = np.searchsorted(tiles, np.arange(len(shaped) + 1)).tolist()
    zis, areas = zis.tolist(), areas.tolist()
    for n, k in enumerate(shaped):
        tile = terrain.tiles[k]
        row, col = divmod(k, terrain.cols)
        x, y = terrain.origin[0] + col * s, terrain.origin[1] + row * s
        run = slice(runs[n], runs[n + 1])
        mu, mat, mix = _tile_ground(b, k, square_areas[n], zis[run], areas[run])
        if mix:
            mixed.append(k)
        prefix = f"terrain:{tile.kind}:{row}_{col}"
        common = {"class": "static", "material": mat, "friction": friction(mu)}
        if not isinstance(tile, (StairTile, *HFIELD_KINDS[b.terrain])):
            _convex_tile(b, tile, prefix, (x, y), common, pieces)
            continue
        if isinstance(tile, StairTile):
            for j, (lo, hi) in enumerate(tile_boxes(tile, s, floor=b.floor)):
                centre = (lo + hi) / 2 + (x, y, 0.0)
                ET.SubElement(
                    b.world, "geom", name=f"{prefix}:{j}", type="box", pos=nums(centre),
                    size=nums((hi - lo) / 2), **common,
                )  # fmt: skip
            continue
        cells = plan[k]
        key = (_geometry_key(tile), cells)
        if key not in hfields:
            g = np.linspace(0.0, s, cells + 1)
            rel = tile_grid(tile, s, g, g) - tile.height  # rows along +y
            lo = float(rel.min())
            # MuJoCo rescales elevation to [0, 1], so it is written in whole units of
            # HFIELD_UNIT above the lowest sample, rows from +y down (as an image's).
            steps = np.rint((rel - lo) / HFIELD_UNIT).astype(np.int64)
            span = max(int(steps.max()), 1) * HFIELD_UNIT
            b.samples += steps.size
            name = f"terrain:{len(hfields)}"
            size = nums((s / 2, s / 2, span, HFIELD_BASE))
            shape = {"nrow": str(cells + 1), "ncol": str(cells + 1), "size": size}
            if b.binary_hfields and int(steps.max()) < 1 << 24:  # whole numbers float32 holds
                # The samples as MuJoCo's parser reads the text into the heightfield's
                # userdata (the text's rows reversed), to the bit: the same model.
                b.hfields[name] = steps.astype(np.float32).ravel()
                ET.SubElement(b.asset, "hfield", name=name, **shape)
            else:
                ET.SubElement(b.asset, "hfield", name=name, **shape, elevation=ints(steps[::-1]))
            hfields[key] = (name, lo)
        name, lo = hfields[key]
        stiff = {"solref": nums((HYBRID_HFIELD_TIMECONST, 1.0))} if b.terrain == "hybrid" else {}
        ET.SubElement(
            b.world, "geom", name=f"{prefix}:0", type="hfield", hfield=name,
            pos=nums((x + s / 2, y + s / 2, tile.height + lo)), **common, **stiff,
        )  # fmt: skip
    if mixed:
        b.warnings.append(
            f"$.terrain.tiles[{mixed[0]}]: {len(mixed)} stair, slope or rough tile(s) lie on zones of "
            "different friction; MJCF gives each tile one friction, that of the zone covering most of it"
        )


def _convex_tile(
    b: Builder, tile: Any, prefix: str, corner: tuple[float, float], common: dict, built: dict
) -> None:
    """A slope or rough tile as convex pieces (``terrain="convex"``,
    :func:`~citygen.geometry.pieces.tile_pieces`): tilted boxes, and prisms as meshes
    (``terrain:mesh:<n>``) that tiles alike share."""
    key = tile.model_copy(update={"material": None, "friction": None})
    if key not in built:
        pieces = tile_pieces(tile, b.scene.terrain.tile_size, floor=b.floor, tolerance=b.tolerance)
        names = []
        for top in pieces.prisms:
            names.append(f"terrain:mesh:{sum(len(n) for _, n in built.values()) + len(names)}")
            ET.SubElement(b.asset, "mesh", name=names[-1], vertex=nums(prism_mesh(top, pieces.bottom)[0]))
        built[key] = (pieces, names)
    pieces, names = built[key]
    shift = np.array([corner[0], corner[1], 0.0])
    quats = rpy_quat(pieces.boxes[:, 2])
    for j, ((centre, half, _), quat) in enumerate(zip(pieces.boxes, quats, strict=True)):
        ET.SubElement(
            b.world, "geom", name=f"{prefix}:{j}", type="box", pos=nums(centre + shift), size=nums(half),
            quat=nums(quat), **common,
        )  # fmt: skip
    for j, name in enumerate(names, start=len(pieces.boxes)):
        ET.SubElement(
            b.world, "geom", name=f"{prefix}:{j}", type="mesh", mesh=name, pos=nums(shift), **common
        )
