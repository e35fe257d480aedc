"""Semantic checks of a scene: everything its JSON Schema cannot say.

:func:`validate` returns a list of :class:`~citygen.errors.Problem` (empty when the
scene is sound) and never raises for bad content. Checks, in order: bounds;
unique ids; block connections; zone polygons (valid, inside the bounds, not
overlapping); the terrain grid (size, inside the bounds, neighbours agreeing on
shared edges); placements (assets resolvable, mesh paths inside the scene's
folder, their meshes with volume, inside the bounds, not overlapping each other or
buildings, standing on the ground under them); agents and the task (inside the bounds, on
walkable ground, not inside an object).

Geometry work is vectorised with shapely's STRtree, so the cost grows with the
number of items and their actual neighbours, not with their pairs.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from functools import lru_cache
from pathlib import Path, PurePosixPath

import numpy as np
import shapely
from shapely.geometry import Point, Polygon, box
from shapely.validation import explain_validity

from citygen.errors import Problem
from citygen.geometry.features import feature_polygon
from citygen.spec import limits
from citygen.spec.agents import Person
from citygen.spec.blocks import Junction
from citygen.spec.placements import Placement
from citygen.spec.scene import Scene
from citygen.spec.surfaces import WALKABLE_ZONES
from citygen.spec.task import NavTask, TraverseTask
from citygen.spec.terrain import edge_profile, profiles_match

#: Overlap area (m^2) below which two shapes are taken to merely touch.
AREA_TOL = 1e-6
#: Distance (m) by which a point may lie outside a region and still count as inside.
DIST_TOL = 1e-4


def validate(scene: Scene, base_dir: str | Path | None = None) -> list[Problem]:
    """All semantic problems of ``scene``; ``base_dir`` is the scene file's folder, used
    to check that mesh files exist (without it, only that their paths stay inside it).

    >>> from citygen.io import load_scene
    >>> validate(load_scene("examples/nav_static_10m.json"), "examples")
    []
    """
    problems = _check_bounds(scene)
    if problems:
        return problems  # everything else is measured against the bounds
    # Built once and shared: the bounds (with tolerance) and every zone's shape.
    area = box(*scene.bounds.min, *scene.bounds.max).buffer(DIST_TOL, join_style="mitre")
    zones = [Polygon(z.polygon, z.holes) for z in scene.zones]
    problems += _check_unique_ids(scene)
    problems += _check_blocks(scene)
    problems += _check_signals(scene)
    problems += _check_zones(scene, zones, area)
    # Later checks use the zones as shapes; an invalid ring (already reported) is
    # repaired so that unions and overlap tests never fail on it.
    zones = [z if z.is_valid else shapely.make_valid(z) for z in zones]
    problems += _check_terrain(scene, area)
    footprints, more = _placement_footprints(scene, base_dir)
    problems += more
    problems += _check_placements(scene, footprints, zones, area)
    problems += _check_agents_and_task(scene, footprints, zones, area)
    return problems


def _fmt(x: float) -> str:
    return f"{x:.4g}"


def _pt(p: Sequence[float]) -> str:
    return "[" + ", ".join(_fmt(v) for v in p) + "]"


# --- bounds and ids -------------------------------------------------------------------


def _check_bounds(scene: Scene) -> list[Problem]:
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    if x1 <= x0 or y1 <= y0:
        return [
            Problem(
                "$.bounds", "max greater than min on both axes", f"min {_pt((x0, y0))}, max {_pt((x1, y1))}"
            )
        ]
    if max(x1 - x0, y1 - y0) > limits.MAX_EXTENT_M:
        return [
            Problem(
                "$.bounds",
                f"sides of at most {limits.MAX_EXTENT_M:g} m",
                f"{_fmt(x1 - x0)} m x {_fmt(y1 - y0)} m",
            )
        ]
    return []


def _check_unique_ids(scene: Scene) -> list[Problem]:
    problems = []
    for name in ("blocks", "zones", "placements", "agents"):
        first: dict[str, int] = {}
        for i, item in enumerate(getattr(scene, name)):
            if item.id in first:
                problems.append(
                    Problem(
                        f"$.{name}[{i}].id",
                        f"an id not used before in {name}",
                        f"{item.id!r}, also $.{name}[{first[item.id]}]",
                    )
                )
            else:
                first[item.id] = i
    return problems


# --- blocks ----------------------------------------------------------------------


def _check_blocks(scene: Scene) -> list[Problem]:
    problems = []
    sockets = {b.id: {s.id for s in b.sockets} for b in scene.blocks}
    links = {(b.id, c.socket): (c.block, c.to_socket) for b in scene.blocks for c in b.connections}
    for i, block in enumerate(scene.blocks):
        for j, conn in enumerate(block.connections):
            where = f"$.blocks[{i}].connections[{j}]"
            if conn.socket not in sockets[block.id]:
                problems.append(
                    Problem(
                        f"{where}.socket",
                        f"one of this block's sockets {sorted(sockets[block.id])}",
                        repr(conn.socket),
                    )
                )
            elif conn.block not in sockets:
                problems.append(Problem(f"{where}.block", "the id of a block in $.blocks", repr(conn.block)))
            elif conn.to_socket not in sockets[conn.block]:
                problems.append(
                    Problem(f"{where}.to_socket", f"a socket of block {conn.block!r}", repr(conn.to_socket))
                )
            elif links.get((conn.block, conn.to_socket)) != (block.id, conn.socket):
                problems.append(
                    Problem(
                        where,
                        f"block {conn.block!r} to connect its socket {conn.to_socket!r} back to this one",
                        "a one-way connection",
                    )
                )
        if isinstance(block, Junction):
            problems += _check_junction(block, f"$.blocks[{i}]")
    return problems


def _check_junction(block: Junction, where: str) -> list[Problem]:
    """A general junction's polygon is a valid polygon round its centre, and its pose is its
    first arm's road end, heading in."""
    problems = []
    poly = Polygon(block.polygon)
    if not poly.is_valid or poly.area <= 0:
        why = explain_validity(poly) if not poly.is_valid else "no area"
        problems.append(Problem(f"{where}.polygon", "a valid polygon (a simple ring with area)", why))
    elif not poly.buffer(1e-3).covers(Point(block.centre)):
        problems.append(
            Problem(f"{where}.centre", "a point inside the junction's polygon", repr(list(block.centre)))
        )
    first = block.arms[0]
    end = (
        block.centre[0] + first.length * math.cos(first.yaw),
        block.centre[1] + first.length * math.sin(first.yaw),
    )
    turn = abs(math.remainder(block.pose.yaw - first.yaw - math.pi, 2 * math.pi))
    if math.dist(end, block.pose.position) > 0.01 or turn > 0.01:
        problems.append(
            Problem(
                f"{where}.pose",
                f"the first arm's road end [{end[0]:.4f}, {end[1]:.4f}] heading in "
                f"(yaw {math.remainder(first.yaw + math.pi, 2 * math.pi):.4f})",
                f"[{block.pose.position[0]:.4f}, {block.pose.position[1]:.4f}] yaw {block.pose.yaw:.4f}",
            )
        )
    return problems


# --- signals ---------------------------------------------------------------------


def _check_signals(scene: Scene) -> list[Problem]:
    """Each signal's junction is a block, its phases name that block's approach lanes and
    crosswalk zones (or a crosswalk zone its phases serve, and no lanes), and its cycle is the
    sum of the phases' times."""
    problems: list[Problem] = []
    blocks = {b.id: b for b in scene.blocks}
    crosswalks = {z.id for z in scene.zones if z.kind == "crosswalk"}
    seen: dict[str, int] = {}
    for i, signal in enumerate(scene.signals or ()):
        where = f"$.signals[{i}]"
        if signal.id in seen:
            problems.append(
                Problem(
                    f"{where}.id",
                    "an id not used before in signals",
                    f"{signal.id!r}, also $.signals[{seen[signal.id]}]",
                )
            )
        seen.setdefault(signal.id, i)
        block = blocks.get(signal.junction)
        served = {c for p in signal.phases for c in p.crosswalks}
        if block is None and signal.junction in crosswalks and signal.junction in served:
            # a pedestrian signal on no street (a crossing of tram tracks): no lanes to name
            for j, phase in enumerate(signal.phases):
                for k, lane in enumerate(phase.lanes):
                    problems.append(
                        Problem(
                            f"{where}.phases[{j}].lanes[{k}]",
                            f"no lanes on the signal of crosswalk {signal.junction!r} (on no street)",
                            repr(lane),
                        )
                    )
        elif block is None:
            problems.append(
                Problem(
                    f"{where}.junction",
                    "the id of a block in $.blocks (or of a crosswalk zone its phases serve)",
                    repr(signal.junction),
                )
            )
        else:
            sockets = [s.id for s in block.sockets]
            for j, phase in enumerate(signal.phases):
                for k, lane in enumerate(phase.lanes):
                    socket, n = lane.rsplit(":", 1)
                    if socket not in sockets or int(n) >= block.lanes:
                        problems.append(
                            Problem(
                                f"{where}.phases[{j}].lanes[{k}]",
                                f"an approach lane '<socket>:<k>' of block {block.id!r} (sockets "
                                f"{', '.join(sockets) or 'none'}; lanes 0-{block.lanes - 1})",
                                repr(lane),
                            )
                        )
        for j, phase in enumerate(signal.phases):
            for k, walk in enumerate(phase.crosswalks):
                if walk not in crosswalks:
                    problems.append(
                        Problem(
                            f"{where}.phases[{j}].crosswalks[{k}]", "the id of a crosswalk zone", repr(walk)
                        )
                    )
        total = sum(p.green + p.amber + p.red for p in signal.phases)
        if abs(total - signal.cycle) > 1e-3:
            problems.append(
                Problem(
                    f"{where}.cycle",
                    f"the sum of the phases' green, amber and red times ({_fmt(total)} s)",
                    _fmt(signal.cycle),
                )
            )
    return problems


# --- zones -----------------------------------------------------------------------


def _check_zones(scene: Scene, polys: list[Polygon], area: Polygon) -> list[Problem]:
    problems = []
    good = []
    for i, (zone, poly) in enumerate(zip(scene.zones, polys, strict=True)):
        where = f"$.zones[{i}]"
        if zone.strip is not None and zone.kind != "sidewalk":
            problems.append(
                Problem(f"{where}.strip", "no strip on a zone that is not a sidewalk", repr(zone.strip))
            )
        if zone.height is not None and zone.kind != "building":
            problems.append(
                Problem(f"{where}.height", "no height on a zone that is not a building", _fmt(zone.height))
            )
        if not poly.is_valid:
            problems.append(
                Problem(f"{where}.polygon", "a valid simple polygon", explain_validity(poly).lower())
            )
            continue
        if poly.area <= AREA_TOL:
            problems.append(
                Problem(f"{where}.polygon", "a polygon with positive area", f"area {poly.area:.3g} m^2")
            )
            continue
        if not area.covers(poly):
            outside = poly.difference(area).area
            problems.append(
                Problem(f"{where}.polygon", "a polygon inside $.bounds", f"{outside:.4g} m^2 outside")
            )
        good.append(i)
    problems += _overlaps(
        [polys[i] for i in good],
        [f"$.zones[{i}]" for i in good],
        "no overlap with other zones",
    )
    return problems


def _overlaps(geoms: list[Polygon], paths: list[str], expected: str) -> list[Problem]:
    """Pairs of shapes whose intersection has area, found with an STRtree."""
    if len(geoms) < 2:
        return []
    arr = np.asarray(geoms, dtype=object)
    tree = shapely.STRtree(arr)
    left, right = tree.query(arr, predicate="intersects")
    keep = left < right
    left, right = left[keep], right[keep]
    areas = shapely.area(shapely.intersection(arr[left], arr[right]))
    return [
        Problem(paths[a], expected, f"{areas[k]:.4g} m^2 shared with {paths[b]}")
        for k, (a, b) in enumerate(zip(left.tolist(), right.tolist(), strict=True))
        if areas[k] > AREA_TOL
    ]


# --- terrain ---------------------------------------------------------------------


def _describe_profile(p: tuple) -> str:
    if p[0] == "level":
        return f"level at {_fmt(p[1])} m"
    if p[0] == "ramp":
        return f"a ramp {_fmt(p[1])} -> {_fmt(p[2])} m"
    return f"{p[3]} steps {_fmt(p[1])} -> {_fmt(p[2])} m"


def _check_terrain(scene: Scene, area: Polygon) -> list[Problem]:
    t = scene.terrain
    if t is None:
        return []
    if len(t.tiles) != t.rows * t.cols:
        return [Problem("$.terrain.tiles", f"rows x cols = {t.rows * t.cols} tiles", f"{len(t.tiles)} tiles")]
    if t.rows * t.cols > limits.MAX_TILES:
        return [Problem("$.terrain", f"at most {limits.MAX_TILES} tiles", f"{t.rows} x {t.cols}")]
    problems = []
    grid = box(
        t.origin[0], t.origin[1], t.origin[0] + t.cols * t.tile_size, t.origin[1] + t.rows * t.tile_size
    )
    if not area.covers(grid):
        problems.append(
            Problem("$.terrain", "a tile grid inside $.bounds", f"a grid spanning {_pt(grid.bounds)}")
        )
    problems += _check_features(t, grid)
    s = t.tile_size
    for r in range(t.rows):
        for c in range(t.cols):
            tile = t.tile(r, c)
            here = f"$.terrain.tiles[{r * t.cols + c}]"
            for side, dr, dc, their in (("east", 0, 1, "west"), ("north", 1, 0, "south")):
                rr, cc = r + dr, c + dc
                if rr >= t.rows or cc >= t.cols:
                    continue
                mine, other = edge_profile(tile, side, s), edge_profile(t.tile(rr, cc), their, s)
                if not profiles_match(mine, other):
                    problems.append(
                        Problem(
                            here,
                            f"its {side} edge to match the {their} edge of tiles[{rr * t.cols + cc}] "
                            f"(row {rr}, col {cc}), with no cliff between them",
                            f"{_describe_profile(mine)} against {_describe_profile(other)}",
                        )
                    )
    return problems


def _check_features(t, grid: Polygon) -> list[Problem]:
    """Terrain features lie on the tile grid, with unique ids."""
    problems, seen = [], set()
    for i, f in enumerate(t.features or ()):
        if f.id in seen:
            problems.append(
                Problem(f"$.terrain.features[{i}].id", "an id unique among the features", repr(f.id))
            )
        seen.add(f.id)
        shape = feature_polygon(f)
        if not grid.buffer(1e-3).covers(shape):
            problems.append(
                Problem(
                    f"$.terrain.features[{i}]",
                    "a feature on the tile grid",
                    f"one spanning {_pt(shape.bounds)}",
                )
            )
    return problems


# --- placements ------------------------------------------------------------------


def _safe_mesh_path(asset: str) -> str | None:
    """Why a mesh path could leave the scene's folder, or None when it cannot."""
    p = PurePosixPath(asset)
    if p.is_absolute() or asset.startswith("~") or (len(asset) > 1 and asset[1] == ":"):
        return "an absolute path"
    depth = 0
    for part in p.parts:
        depth += -1 if part == ".." else (0 if part == "." else 1)
        if depth < 0:
            return "a path leading out of the scene's folder"
    return None


@lru_cache(maxsize=4096)
def _catalog_footprint(asset_id: str) -> np.ndarray | str:
    from citygen import assets

    try:
        fp = assets.resolve(asset_id).base
    except assets.UnknownAsset as exc:
        return str(exc)
    return np.asarray(fp.exterior.coords)


def _lot_assets(scene: Scene) -> set[int]:
    """Placements of catalog assets that belong in building lots (building massing)."""
    from citygen import assets

    out = set()
    for i, pl in enumerate(scene.placements):
        if not pl.is_mesh:
            try:
                if "building" in assets.resolve(pl.asset).zones:
                    out.add(i)
            except assets.UnknownAsset:
                pass
    return out


def _mesh_footprint(path: Path) -> np.ndarray | str:
    import trimesh

    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        return f"an unreadable mesh ({type(exc).__name__})"
    if len(mesh.vertices) < 3:
        return "a mesh with no vertices"
    flat = _flat_part(mesh)
    if flat is not None:
        return flat
    hull = shapely.MultiPoint(mesh.vertices[:, :2]).convex_hull
    return np.asarray(hull.exterior.coords) if isinstance(hull, Polygon) else "a mesh with no footprint"


#: Connected parts of a mesh asset checked one by one (the MJCF exporter collides each part as
#: its convex hull, up to 64 parts; beyond, the whole mesh).
MAX_MESH_PARTS = 64


def _flat_part(mesh) -> str | None:
    """What stops the engines from colliding a mesh asset: a connected part (after trimesh drops
    degenerate faces) without four points off one plane has no convex hull (Qhull fails)."""
    parts = mesh.split(only_watertight=False) if mesh.body_count > 1 else [mesh]
    if len(parts) > MAX_MESH_PARTS:
        parts = [mesh]
    for k, part in enumerate(parts):
        points = np.unique(np.asarray(part.vertices), axis=0)
        spread = np.linalg.svd(points - points.mean(axis=0), compute_uv=False) if len(points) >= 4 else ()
        if len(points) < 4 or spread[2] <= 1e-9 * max(spread[0], 1e-12):
            what = f"part {k + 1} of {len(parts)}" if len(parts) > 1 else "the mesh"
            return (
                f"a mesh without volume: {what} has {len(points)} distinct vertices"
                f"{' in one plane' if len(points) >= 4 else ''} after its degenerate faces are dropped "
                "(no convex hull for the engines to collide)"
            )
    return None


def _placement_footprints(
    scene: Scene, base_dir: str | Path | None
) -> tuple[list[Polygon | None], list[Problem]]:
    """World-frame footprint of every placement (None where its asset is unusable)."""
    problems: list[Problem] = []
    out: list[Polygon | None] = []
    base = Path(base_dir).resolve() if base_dir is not None else None
    for i, pl in enumerate(scene.placements):
        where = f"$.placements[{i}].asset"
        if pl.is_mesh:
            why = _safe_mesh_path(pl.asset)
            if why:
                problems.append(
                    Problem(
                        where, "a mesh path relative to the scene's folder, inside it", f"{why}: {pl.asset!r}"
                    )
                )
                out.append(None)
                continue
            if base is None:
                out.append(None)  # nothing to measure; the path itself is fine
                continue
            file = (base / pl.asset).resolve()
            if not file.is_relative_to(base):
                problems.append(
                    Problem(where, "a mesh file inside the scene's folder", f"a link leading to {file}")
                )
                out.append(None)
                continue
            if not file.is_file():
                problems.append(
                    Problem(where, "an existing mesh file", f"no file {pl.asset!r} beside the scene")
                )
                out.append(None)
                continue
            coords = _mesh_footprint(file)
        else:
            coords = _catalog_footprint(pl.asset)
        if isinstance(coords, str):
            problems.append(Problem(where, "an asset citygen can resolve", coords))
            out.append(None)
            continue
        c, s = math.cos(pl.yaw), math.sin(pl.yaw)
        xy = coords * pl.scale @ np.array([[c, s], [-s, c]]) + np.asarray(pl.position[:2])
        out.append(Polygon(xy))
    return out, problems


def _check_placements(
    scene: Scene, footprints: list[Polygon | None], zones: list[Polygon], area: Polygon
) -> list[Problem]:
    problems = []
    present = [i for i, fp in enumerate(footprints) if fp is not None]
    for i in present:
        if not area.covers(footprints[i]):
            problems.append(
                Problem(
                    f"$.placements[{i}].position",
                    "an object standing inside $.bounds",
                    f"{_pt(scene.placements[i].position)}, partly outside",
                )
            )
    problems += _overlaps(
        [footprints[i] for i in present],
        [f"$.placements[{i}]" for i in present],
        "no overlap with other objects",
    )
    lots = _lot_assets(scene)
    problems += _inside_zones(scene, footprints, zones, present, lots)
    problems += _on_the_ground(scene, footprints)
    return problems


#: How far (m) an object's base may sit above the highest ground under it, or below the lowest.
REST_TOL = 0.01


def ground_under(scene: Scene, footprints: Sequence[Polygon | None]) -> list[tuple[float, float] | None]:
    """The lowest and highest ground (m) under each footprint (its corners and its centre, as
    the placement stage measures them); None where there is no footprint or no sound terrain."""
    from citygen.geometry.terrain import height_at

    rings = [
        None if fp is None else np.vstack([np.asarray(fp.exterior.coords), pl.position[:2]])
        for fp, pl in zip(footprints, scene.placements, strict=True)
    ]
    points = [r for r in rings if r is not None]
    if not points:
        return [None] * len(rings)
    try:
        z = height_at(scene, *np.vstack(points).T) if scene.terrain is not None else None
    except ValueError:  # a malformed terrain grid (its own problem): no ground to measure
        return [None] * len(rings)
    out: list[tuple[float, float] | None] = []
    k = 0
    for ring in rings:
        if ring is None:
            out.append(None)
            continue
        part = z[k : k + len(ring)] if z is not None else np.zeros(1)
        k += len(ring)
        out.append((float(part.min()), float(part.max())))
    return out


def reseated(scene: Scene, base_dir: str | Path | None = None) -> tuple[Placement, ...]:
    """The scene's objects, each that floats above the ground under it or is buried in it
    (after a hand edit) moved to stand on it, at the lowest ground under its base as the
    placement stage puts it; every other object as it is. Mesh assets are measured only
    with ``base_dir`` (the scene's folder)."""
    footprints, _ = _placement_footprints(scene, base_dir)
    out = []
    for pl, ground in zip(scene.placements, ground_under(scene, footprints), strict=True):
        if ground is not None and not ground[0] - REST_TOL <= pl.position[2] <= ground[1] + REST_TOL:
            pl = pl.model_copy(update={"position": (*pl.position[:2], round(ground[0], 3) + 0.0)})
        out.append(pl)
    return tuple(out)


def _on_the_ground(scene: Scene, footprints: Sequence[Polygon | None]) -> list[Problem]:
    """Every object stands on the ground under it: its base neither floats above the highest
    ground under it nor is buried below the lowest (after a hand edit of the terrain or of z)."""
    problems = []
    for i, (pl, ground) in enumerate(zip(scene.placements, ground_under(scene, footprints), strict=True)):
        if ground is None:
            continue
        low, high = ground
        z = pl.position[2]
        if low - REST_TOL <= z <= high + REST_TOL:
            continue
        off = f"{z - high:.2f} m above it" if z > high else f"buried {low - z:.2f} m in it"
        problems.append(Problem(
            f"$.placements[{i}].position",
            f"z on the ground under the object ({low:.3f} to {high:.3f} m; "
            "'citygen rebuild SCENE --from placement' re-seats it)",
            f"z = {_fmt(z)}, {off}",
        ))  # fmt: skip
    return problems


def _inside_zones(
    scene: Scene, footprints: list[Polygon | None], zones: list[Polygon], present: list[int], lots: set[int]
) -> list[Problem]:
    """No object on the roadway; none in a building lot, except building massing, which
    stands inside one lot."""
    problems: list[Problem] = []
    kinds = [z.kind for z in scene.zones]
    if not present or not zones:
        return problems
    tree = shapely.STRtree(zones)
    objs = np.asarray([footprints[i] for i in present], dtype=object)
    left, right = tree.query(objs, predicate="intersects")
    inside_lot = set()
    for a, b in zip(left.tolist(), right.tolist(), strict=True):
        i, kind = present[a], kinds[b]
        if kind not in ("roadway", "building"):
            continue
        if kind == "building" and i in lots:
            if zones[b].buffer(DIST_TOL).covers(objs[a]):
                inside_lot.add(i)
            continue
        shared = objs[a].intersection(zones[b]).area
        if shared > AREA_TOL:
            expected = f"no overlap with {'the roadway' if kind == 'roadway' else 'building zones'}"
            problems.append(Problem(f"$.placements[{i}]", expected, f"{shared:.4g} m^2 inside $.zones[{b}]"))
    for i in sorted(lots & set(present) - inside_lot):
        problems.append(
            Problem(f"$.placements[{i}]", "a building standing inside one building zone", "it is not")
        )
    return problems


# --- agents and task -----------------------------------------------------------------


class _Ground:
    """Point queries against the scene's bounds, walkable zones, roadway and objects."""

    def __init__(
        self, scene: Scene, footprints: Iterable[Polygon | None], zones: list[Polygon], area: Polygon
    ):
        self.area = area
        walk = [g for g, z in zip(zones, scene.zones, strict=True) if z.kind in WALKABLE_ZONES]
        road = [g for g, z in zip(zones, scene.zones, strict=True) if z.kind in ("roadway", "parking")]
        # A scene without zones (a locomotion grid) is walkable everywhere.
        self.walkable = shapely.union_all(walk).buffer(DIST_TOL) if scene.zones else self.area
        self.road = shapely.union_all(road).buffer(DIST_TOL) if road else None
        objs = [f for f in footprints if f is not None]
        self.objects = shapely.union_all(objs) if objs else None
        shapely.prepare(self.walkable)

    def check(self, where: str, p: Sequence[float], need: str) -> Problem | None:
        pt = Point(p[0], p[1])
        if not self.area.covers(pt):
            return Problem(where, "a point inside $.bounds", _pt(p))
        if need == "walkable" and not self.walkable.covers(pt):
            return Problem(where, "a point on walkable ground (sidewalk, crosswalk, plaza or trail)", _pt(p))
        if need == "road" and self.road is not None and not self.road.covers(pt):
            return Problem(where, "a point on the roadway", _pt(p))
        if self.objects is not None and self.objects.contains(pt):
            return Problem(where, "a point not inside a static object", _pt(p))
        return None


def _check_agents_and_task(
    scene: Scene, footprints: list[Polygon | None], zones: list[Polygon], area: Polygon
) -> list[Problem]:
    if not scene.agents and scene.task is None:
        return []
    ground = _Ground(scene, footprints, zones, area)
    found = []
    for i, agent in enumerate(scene.agents):
        need = "walkable" if isinstance(agent, Person) else "road"
        for end in ("start", "goal"):
            found.append(ground.check(f"$.agents[{i}].{end}", getattr(agent, end), need))
    task = scene.task
    if task is not None:
        found.append(ground.check("$.task.start.position", task.start.position, "walkable"))
        if isinstance(task, NavTask):
            found.append(ground.check("$.task.goal", task.goal, "walkable"))
        elif isinstance(task, TraverseTask):
            found += [ground.check(f"$.task.route[{k}]", p, "walkable") for k, p in enumerate(task.route)]
    return [p for p in found if p is not None]
