"""URDF: the scene as one fixed-base model for PyBullet, Gazebo and ROS tools.

The file holds a root link, ``scene/world``, and one link per thing in the scene, each
fixed to the root by a joint named ``joint/<link>`` whose origin places it:

- ``<id>``: each placement, at its position and yaw. Its collision geometry is the asset's
  convex parts as URDF primitives (``box``, ``cylinder``) and convex meshes (convex-mesh
  parts; capsules too, unless ``capsules="pybullet"`` writes PyBullet's ``<capsule>``); its
  visual is the asset's watertight visual mesh, one mesh per material colour. A mesh file
  placement is its mesh, for collision flagged ``concave="yes"``. The placement's scale
  multiplies every size and offset (meshes through their ``scale`` attribute).
- ``zone/<id>``: each zone's draped ground surface as its visual (coloured by kind), and
  where the zone lies outside the terrain grid a slab from ``-zone_thickness`` up to
  ``z = 0`` as its collision, with the zone's friction.
- ``solid/<id>``: each zone's solid (a building's footprint, holes cut out, extruded to its
  ``height``: :mod:`citygen.exporters.solids`), its closed mesh as the visual and its convex
  pieces as the collision, with the zone's friction.
- ``ground/plane``: the rest of the scene's bounds outside the grid, a slab like the zones';
  ``ground/apron``: four boxes ``apron`` metres wide around the scene and its grid at
  ``z = 0`` (the MJCF's apron), so a body that rolls off the scene stays on the ground.
- ``ground/terrain/<k>``: the terrain's tiles, one link per friction coefficient (a tile's
  own friction, else its material's, else the zones' frictions averaged by area, rounded
  to :data:`FRICTION_STEP`, with one :class:`ExportWarning` saying how far that is from the
  zones' on how much of the terrain). Flat tiles are cut where the zone changes, each piece
  keeping its zone's friction.

All ground collision is **convex pieces** (:mod:`citygen.exporters.pieces`), so that loaders
which take each collision mesh's convex hull (SAPIEN, Genesis, Isaac Sim's importer) get the
ground PyBullet gets: flat ground is boxes, or prisms where a piece is not a rectangle;
stairs are their treads' boxes; a slope is one prism (a pyramid or a pit five); a rough tile
is tilted boxes within ``tolerance`` of ``height_at`` (:mod:`citygen.geometry.pieces`). The
terrain's visual is its boxes, or its tiles' meshes where it is not made of boxes. Only a
placement's mesh file stays one concave mesh (``concave="yes"``, PyBullet's extension).

Friction is written as PyBullet reads it (``<contact><lateral_friction>``) and as Gazebo
does (``<gazebo reference="<link>"><mu1>``, ``<mu2>``); SAPIEN's and Genesis' URDF readers
read neither, so their recipes set it by hand (docs/simulators/). ``visual=False`` leaves
every ``<visual>`` out (and its meshes): a loader on a machine without a rendering device
(SAPIEN) loads the collision geometry alone; :func:`frictions` reads the frictions back.

Meshes are Wavefront OBJ files (:func:`obj_bytes`) under ``<out_dir>/assets/``, named by their content
(:func:`~citygen.exporters.shared_file`), so scenes exported to one folder share them.
Agents and the task cannot be expressed: each raises an :class:`ExportWarning`. Units are
metres and radians, Z up. The same scene always gives the same bytes.

>>> import warnings, tempfile
>>> from citygen.exporters import urdf
>>> with tempfile.TemporaryDirectory() as out, warnings.catch_warnings(record=True) as caught:
...     warnings.simplefilter("always")
...     files = urdf.export("examples/street_corner.json", out)
...     print(files[0].name, [str(w.message).split(":")[0] for w in caught])
street_corner.urdf ['$.agents', '$.task']
"""

from __future__ import annotations

import math
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import shapely
import trimesh

from citygen.assets import Box, Capsule, Cylinder, Part
from citygen.errors import ExportError
from citygen.exporters import ExportWarning, lod, shared_file, tiles
from citygen.exporters.ground import (
    ZONE_LIFT,
    drape,
    fit_terrain,
    grid_box,
    rough_cells,
    zone_polygons,
)
from citygen.exporters.meshes import (
    GROUND_RGBA,
    RGBA,
    TERRAIN_RGBA,
    catalog_asset,
    colour_groups,
    file_mesh,
    submesh,
    zone_rgba,
)
from citygen.exporters.options import AUTO, check_options, output_name, resolution_option, scene_dir_of
from citygen.exporters.pieces import (
    APRON,
    PIECE_BUDGETS,
    TILED_PIECE_BUDGET,
    apron_boxes,
    flat_pieces,
    terrain_pieces,
    tolerance_option,
)
from citygen.exporters.solids import extrude, solids
from citygen.geometry.features import feature_boxes
from citygen.geometry.pieces import Pieces, axis_boxes, prism_mesh
from citygen.geometry.terrain import MIN_THICKNESS, tile_boxes, tile_mesh
from citygen.geometry.tiles import tile_kind
from citygen.io import write_atomic
from citygen.spec.placements import Placement
from citygen.spec.scene import Scene
from citygen.spec.surfaces import FRICTION
from citygen.spec.terrain import FlatTile, RoughTile, Terrain

ROOT = "scene/world"
#: Thickness (m) of the slabs that carry the flat ground's collision outside the terrain grid.
ZONE_THICKNESS = 0.1
#: Bottom (m) of terrain tiles, lowered below a tile's lowest point when needed.
FLOOR = -1.0
CAPSULES = ("mesh", "pybullet")

_OPTIONS = (
    "name", "scene_dir", "resolution", "floor", "zone_thickness", "capsules", "tile", "visual", "apron",
    "tolerance",
)  # fmt: skip
#: Most links (about one a zone and one an object) a scene's URDF holds in one file; a
#: larger scene is cut into tiles of about :data:`TILE_LINKS` links each. PyBullet 3.2.7
#: loads the 15,000 links of urban-tra-city's one-file URDF in about 95 s and crashes
#: freeing that body.
MAX_LINKS, TILE_LINKS = 2_000, 1_000


def _f(x: float) -> str:
    """A number as URDF text: at most 6 decimals (1 micrometre), no trailing zeros, no -0."""
    text = f"{round(float(x), 6) + 0.0:.6f}".rstrip("0").rstrip(".")
    return "0" if text in ("", "-0") else text


def _v(xs: Sequence[float]) -> str:
    return " ".join(_f(x) for x in xs)


def obj_bytes(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """A Wavefront OBJ of a triangle mesh (m, to 0.1 mm), each vertex written once: about
    two thirds of a binary STL's size for a terrain mesh (whose vertices six triangles
    share), and read by PyBullet, yourdfpy (trimesh), Gazebo and RViz alike."""
    v = np.asarray(vertices, dtype=np.float64) + 0.0  # -0.0 + 0.0 is 0.0
    f = np.asarray(faces, dtype=np.int64) + 1
    # One %-format of the whole mesh runs in C: three times faster than a line at a time.
    text = ("v %.4f %.4f %.4f\n" * len(v)) % tuple(v.ravel().tolist())
    text += ("f %d %d %d\n" * len(f)) % tuple(f.ravel().tolist())
    return ("# citygen, metres\n" + text).encode("ascii")


class _Writer:
    """Builds the URDF tree and writes its meshes, each once, under ``out_dir/assets``."""

    def __init__(self, out_dir: Path, name: str, assets: dict | None = None, visual: bool = True) -> None:
        self.out_dir = out_dir
        #: Each catalog asset's meshes as already written (shared by the tiles of one export).
        self.assets: dict[str, tuple] = {} if assets is None else assets
        #: Whether links get ``<visual>`` elements (and their meshes and materials).
        self.visual = visual
        self.robot = ET.Element("robot", name=name)
        self.materials: dict[str, RGBA] = {}
        self.files: dict[Path, None] = {}
        _static(ET.SubElement(self.robot, "link", name=ROOT))

    def mesh(self, vertices: np.ndarray, faces: np.ndarray) -> str:
        return self.uses(shared_file(self.out_dir, obj_bytes(vertices, faces), ".obj"))

    def uses(self, path: Path) -> str:
        """Note that the file references ``path`` (a mesh under ``out_dir``); its reference."""
        self.files[path] = None
        return path.relative_to(self.out_dir).as_posix()

    def material(self, name: str, colour: RGBA) -> str:
        self.materials.setdefault(name, tuple(colour))  # type: ignore[arg-type]
        return name

    def link(
        self, name: str, xyz=(0.0, 0.0, 0.0), yaw: float = 0.0, friction: float | None = None
    ) -> ET.Element:
        link = ET.SubElement(self.robot, "link", name=name)
        _static(link)
        joint = ET.SubElement(self.robot, "joint", name=f"joint/{name}", type="fixed")
        ET.SubElement(joint, "parent", link=ROOT)
        ET.SubElement(joint, "child", link=name)
        ET.SubElement(joint, "origin", xyz=_v(xyz), rpy=_v((0.0, 0.0, yaw)))
        if friction is not None:  # PyBullet's extension, and Gazebo's (SDFormat's URDF reader)
            contact = ET.SubElement(link, "contact")
            ET.SubElement(contact, "lateral_friction", value=_f(friction))
            gazebo = ET.SubElement(self.robot, "gazebo", reference=name)
            ET.SubElement(gazebo, "mu1").text = _f(friction)
            ET.SubElement(gazebo, "mu2").text = _f(friction)
        return link

    def pieces(self, link: ET.Element, pieces: Pieces, offset=(0.0, 0.0, 0.0)) -> None:
        """Convex pieces as ``link``'s collision elements, moved by ``offset``: boxes as
        ``<box>``, prisms as meshes (written in the pieces' frame, so tiles alike share them)."""
        for centre, half, (roll, pitch, yaw) in pieces.boxes:
            box = ("box", {"size": _v(2.0 * half)})
            _element(link, "collision", box, centre + offset, yaw, pitch=-pitch, roll=roll)
        for top in pieces.prisms:
            _element(link, "collision", _mesh_geometry(self.mesh(*prism_mesh(top, pieces.bottom))), offset)

    def text(self) -> str:
        for i, (name, colour) in enumerate(sorted(self.materials.items())):
            material = ET.Element("material", name=name)
            ET.SubElement(material, "color", rgba=_v(colour))
            self.robot.insert(i, material)
        ET.indent(self.robot, "  ")
        return '<?xml version="1.0"?>\n' + ET.tostring(self.robot, encoding="unicode") + "\n"


def _static(link: ET.Element) -> None:
    """Mass 0: a static body (PyBullet's convention; without it PyBullet assumes 1 kg and warns)."""
    inertial = ET.SubElement(link, "inertial")
    ET.SubElement(inertial, "mass", value="0")
    ET.SubElement(inertial, "inertia", ixx="0", ixy="0", ixz="0", iyy="0", iyz="0", izz="0")


def _element(
    link: ET.Element,
    kind: str,
    geometry: tuple[str, dict[str, str]],
    xyz=(0.0, 0.0, 0.0),
    yaw: float = 0.0,
    material: str | None = None,
    concave: bool = False,
    pitch: float = 0.0,
    roll: float = 0.0,
) -> None:
    """A ``<visual>`` or ``<collision>`` element of ``link`` (``pitch`` raises its +x end)."""
    el = ET.SubElement(link, kind, {"concave": "yes"} if concave else {})
    ET.SubElement(el, "origin", xyz=_v(xyz), rpy=_v((roll, -pitch, yaw)))
    geo = ET.SubElement(el, "geometry")
    ET.SubElement(geo, geometry[0], geometry[1])
    if material is not None:
        ET.SubElement(el, "material", name=material)


def _mesh_geometry(filename: str, scale: float = 1.0) -> tuple[str, dict[str, str]]:
    return ("mesh", {"filename": filename, "scale": _v((scale, scale, scale))})


# --- placements ---------------------------------------------------------------------------


def _colour_name(look_name: str, colour: Sequence[int]) -> str:
    return f"{look_name}-{''.join(f'{c:02x}' for c in colour)}"


def _add_placement(w: _Writer, pl: Placement, index: int, folder: Path | None, capsules: str) -> None:
    link = w.link(pl.id, pl.position, pl.yaw)
    k = pl.scale
    if pl.is_mesh:
        mesh = file_mesh(pl, index, folder)
        for colour, faces in colour_groups(mesh) if w.visual else ():
            material = w.material(_colour_name("mesh", colour), tuple(c / 255 for c in colour))
            _element(link, "visual", _mesh_geometry(w.mesh(*submesh(mesh, faces)), k), material=material)
        _element(link, "collision", _mesh_geometry(w.mesh(mesh.vertices, mesh.faces), k), concave=True)
        return
    if pl.asset not in w.assets:  # an asset's meshes are the same wherever it stands: made once
        asset = catalog_asset(pl, index)
        names = {tuple(round(c * 255) for c in p.material.rgba): p.material.name for p in asset.parts}
        looks = []
        for colour, faces in colour_groups(visual := asset.visual_mesh()) if w.visual else ():
            path = shared_file(w.out_dir, obj_bytes(*submesh(visual, faces)), ".obj")
            look = _colour_name(names.get(colour, "part"), colour)
            looks.append((look, tuple(c / 255 for c in colour), path))
        hulls = [
            None if _primitive(part, capsules) else shared_file(w.out_dir, obj_bytes(*_hull(part)), ".obj")
            for part in asset.parts
        ]
        w.assets[pl.asset] = (asset, looks, hulls)
    asset, looks, hulls = w.assets[pl.asset]
    for name, colour, path in looks:
        _element(link, "visual", _mesh_geometry(w.uses(path), k), material=w.material(name, colour))
    for part, hull in zip(asset.parts, hulls, strict=True):
        _add_part(w, link, part, k, capsules, hull)


def _primitive(part: Part, capsules: str) -> bool:
    """Whether a part is written as a URDF primitive (else as its convex mesh)."""
    return isinstance(part, Box | Cylinder) or (isinstance(part, Capsule) and capsules == "pybullet")


def _hull(part: Part) -> tuple[np.ndarray, np.ndarray]:
    hull = part.to_trimesh()
    return hull.vertices, hull.faces


def _add_part(
    w: _Writer, link: ET.Element, part: Part, k: float, capsules: str, hull: Path | None = None
) -> None:
    """A part's collision element; ``hull`` is its convex mesh's file if already written."""
    if isinstance(part, Box):
        size = {"size": _v(np.asarray(part.size) * k)}
        _element(link, "collision", ("box", size), np.asarray(part.pos) * k, part.yaw)
    elif isinstance(part, Cylinder):
        size = {"radius": _f(part.radius * k), "length": _f(part.height * k)}
        _element(link, "collision", ("cylinder", size), np.asarray(part.pos) * k)
    elif isinstance(part, Capsule) and capsules == "pybullet":
        size = {"radius": _f(part.radius * k), "length": _f(part.length * k)}
        _element(link, "collision", ("capsule", size), np.asarray(part.pos) * k)
    else:  # a convex mesh, or a capsule as its convex mesh
        filename = w.mesh(*_hull(part)) if hull is None else w.uses(hull)
        _element(link, "collision", _mesh_geometry(filename, k))


# --- the ground ---------------------------------------------------------------------------


def _add_ground(
    w: _Writer, scene: Scene, polys: list, resolution: float | None, thickness: float, apron: np.ndarray
) -> None:
    """Each zone's link (its draped surface as the visual, its flat ground outside the
    terrain grid as convex pieces), the rest of the bounds (``ground/plane``) and the apron's
    boxes (``ground/apron``)."""
    grid = grid_box(scene)
    surfaces = drape(scene, polys, resolution=resolution) if w.visual else [((), ())] * len(polys)
    for zone, poly, (verts, faces) in zip(scene.zones, polys, surfaces, strict=True):
        link = w.link(f"zone/{zone.id}", friction=zone.mu)
        if len(faces):
            material = w.material(f"zone-{zone.kind}", zone_rgba(zone.kind))
            filename = w.mesh(verts + np.array([0.0, 0.0, ZONE_LIFT]), faces)
            _element(link, "visual", _mesh_geometry(filename), material=material)
        w.pieces(link, flat_pieces(poly if grid is None else poly.difference(grid), -thickness, 0.0))
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    rest = shapely.box(x0, y0, x1, y1)
    if grid is not None:
        rest = rest.difference(grid)
    if polys:
        rest = rest.difference(shapely.union_all(polys))
    if not rest.is_empty and rest.area > 1e-9:
        link = w.link("ground/plane", friction=FRICTION["concrete"])
        sv, sf = extrude(rest, -thickness, 0.0)
        if w.visual and len(sf):
            _element(
                link, "visual", _mesh_geometry(w.mesh(sv, sf)), material=w.material("ground", GROUND_RGBA)
            )
        w.pieces(link, flat_pieces(rest, -thickness, 0.0))
    if len(apron):
        link = w.link("ground/apron", friction=FRICTION["concrete"])
        for centre, half, _ in apron:
            if w.visual:
                box = ("box", {"size": _v(2.0 * half)})
                _element(link, "visual", box, centre, material=w.material("ground", GROUND_RGBA))
        w.pieces(link, Pieces(apron, (), -thickness))


def _add_solids(w: _Writer, scene: Scene, polys: list) -> None:
    """Each zone's solid (:mod:`citygen.exporters.solids`: a building extruded from its
    footprint) as a link ``solid/<zone id>``: its closed mesh as the visual, its convex pieces
    as the collision (a hull would fill a courtyard), with the zone's friction."""
    for solid in solids(scene, polys):
        zone = solid.zone
        link = w.link(f"solid/{zone.id}", friction=zone.mu)
        if w.visual:
            material = w.material(f"zone-{zone.kind}", zone_rgba(zone.kind))
            _element(link, "visual", _mesh_geometry(w.mesh(*solid.mesh())), material=material)
        w.pieces(link, solid.pieces())


#: Step (m) tile frictions are rounded to, so tiles share links.
FRICTION_STEP = 0.01


def tile_friction(
    scene: Scene, zones: Sequence[shapely.Geometry] | None = None, *, split_flat: bool = False
) -> tuple[np.ndarray, str | None]:
    """Each terrain tile's friction coefficient: its own, else its material's, else the
    mean of the zones' frictions over the tile weighted by area (ground no zone covers
    counts as concrete's, :data:`~citygen.spec.surfaces.FRICTION`), rounded to
    :data:`FRICTION_STEP`; and a one-line report of how far that is from the ground under
    the tiles that lie on zones of different friction (None when none does).
    ``zones`` are the zones' shapes if already made (:func:`~citygen.exporters.ground.zone_polygons`).
    With ``split_flat``, flat tiles without a friction of their own are left out of the
    report: the URDF exporter cuts them where the zone changes, so they keep it exactly."""
    t = scene.terrain
    if t is None:
        return np.zeros(0), None
    s = t.tile_size
    ids = np.arange(t.rows * t.cols)
    x0 = t.origin[0] + (ids % t.cols) * s
    y0 = t.origin[1] + (ids // t.cols) * s
    concrete = FRICTION["concrete"]
    out = np.full(len(ids), concrete)
    worst, mixed_area, mixed = 0.0, 0.0, 0
    if scene.zones:
        polys = np.asarray(zone_polygons(scene) if zones is None else zones, dtype=object)
        squares = shapely.box(x0, y0, x0 + s, y0 + s)
        ti, zi = shapely.STRtree(polys).query(squares, predicate="intersects")
        areas = shapely.area(shapely.intersection(polys[zi], squares[ti]))
        mus = np.array([z.mu for z in scene.zones])[zi]
        covered = np.bincount(ti, weights=areas, minlength=len(ids))
        weighted = np.bincount(ti, weights=areas * mus, minlength=len(ids))
        rest = np.clip(s * s - covered, 0.0, None)
        out = np.round((weighted + rest * concrete) / (s * s) / FRICTION_STEP) * FRICTION_STEP
        own = np.array([tile.friction is not None or tile.material is not None for tile in t.tiles])
        if split_flat:  # exact, so never off: counted as having their own friction
            own |= np.array([isinstance(tile, FlatTile) for tile in t.tiles])
        keep = areas > 1e-6 * s * s
        off = np.abs(mus - out[ti]) * keep * ~own[ti]
        rest_off = np.abs(concrete - out) * (rest > 1e-6 * s * s) * ~own
        differs = np.bincount(ti, weights=areas * (off > FRICTION_STEP / 2), minlength=len(ids))
        differs += rest * (rest_off > FRICTION_STEP / 2)
        worst = float(max(off.max(initial=0.0), rest_off.max(initial=0.0)))
        mixed_area = float(differs.sum())
        mixed = int(np.count_nonzero(differs))
    for k, tile in enumerate(t.tiles):
        if tile.friction is not None:
            out[k] = tile.friction
        elif tile.material is not None:
            out[k] = FRICTION[tile.material]
    report = None
    if mixed:
        report = (
            f"$.terrain: {mixed} {'sloped, stepped or rough ' if split_flat else ''}tile(s) lie on zones "
            "of different friction; each gets the zones' "
            f"friction averaged by area, up to {worst:.2f} off the zone's on "
            f"{100 * mixed_area / (len(ids) * s * s):.1f} % of the terrain's area (MJCF keeps flat "
            "ground's zone friction exactly)"
        )
    return out, report


def _flat_rectangles(t: Terrain, members: np.ndarray) -> list[tuple[int, int, int, int, float]]:
    """Flat tiles among ``members`` merged into rectangles of equal height:
    ``(row0, col0, row1, col1, height)`` with exclusive ends, in row-major order."""
    height = {int(k): t.tiles[k].height for k in members if isinstance(t.tiles[k], FlatTile)}
    runs: dict[tuple[int, int, float], list[int]] = {}  # (col0, col1, h) -> rows
    for r in range(t.rows):
        c = 0
        while c < t.cols:
            k = r * t.cols + c
            if k not in height:
                c += 1
                continue
            c1 = c + 1
            while c1 < t.cols and height.get(r * t.cols + c1) == height[k]:
                c1 += 1
            runs.setdefault((c, c1, height[k]), []).append(r)
            c = c1
    rects = []
    for (c0, c1, h), rows in runs.items():
        r0 = rows[0]
        for a, b in zip(rows, [*rows[1:], None], strict=True):
            if b != a + 1:
                rects.append((r0, c0, a + 1, c1, h))
                r0 = b if b is not None else 0
    return sorted(rects)


def _split_flat(
    t: Terrain, members: np.ndarray, polys: Sequence, mus: Sequence[float]
) -> dict[float, list[tuple[shapely.Geometry, float]]]:
    """The flat tiles ``members`` cut where the zone, and so the friction, changes: for each
    friction coefficient, the pieces ``(area, height)`` of flat ground it holds (ground no
    zone covers: concrete's)."""
    s, (ox, oy) = t.tile_size, t.origin
    out: dict[float, list[tuple[shapely.Geometry, float]]] = {}
    shapes = np.asarray(polys, dtype=object)
    tree = shapely.STRtree(shapes) if len(shapes) else None
    for r0, c0, r1, c1, h in _flat_rectangles(t, members):
        rect = shapely.box(ox + c0 * s, oy + r0 * s, ox + c1 * s, oy + r1 * s)
        hit = tree.query(rect, predicate="intersects") if tree is not None else np.zeros(0, dtype=int)
        covered = []
        for i in hit.tolist():
            part = shapely.intersection(shapes[i], rect)
            if part.area > 1e-9:
                out.setdefault(round(float(mus[i]), 6), []).append((part, h))
                covered.append(part)
        rest = rect.difference(shapely.union_all(covered)) if covered else rect
        if rest.area > 1e-9:
            out.setdefault(FRICTION["concrete"], []).append((rest, h))
    return out


def _add_terrain(
    w: _Writer, scene: Scene, polys: list, friction: np.ndarray, resolution: float | None, floor: float,
    tolerance: float,
) -> None:  # fmt: skip
    """The terrain's links, one per friction coefficient. ``friction`` is each tile's
    (:func:`tile_friction`); flat tiles without a friction of their own are instead cut
    where the zone changes (:func:`_split_flat`), each piece a slab with its zone's. The
    collision is convex pieces (:mod:`citygen.exporters.pieces`, rough tiles within
    ``tolerance`` m); the visual is boxes where the ground is boxes, else the tiles' meshes."""
    t = scene.terrain
    if t is None:
        return
    s, (ox, oy) = t.tile_size, t.origin
    own = np.array([tile.friction is not None or tile.material is not None for tile in t.tiles])
    flat = np.array([isinstance(tile, FlatTile) for tile in t.tiles])
    friction = np.round(friction, 6)
    split = _split_flat(t, np.flatnonzero(flat & ~own), polys, [z.mu for z in scene.zones])
    values = list(dict.fromkeys([*friction[~(flat & ~own)].tolist(), *split]))  # deterministic order
    terrain_material = w.material("terrain", TERRAIN_RGBA) if w.visual else None
    shaped = np.flatnonzero(~flat)
    pieces = terrain_pieces(scene, shaped[np.isin(friction[shaped], values)], floor, tolerance)
    for g, mu in enumerate(values):
        members = np.flatnonzero((friction == mu) & ~(flat & ~own))
        link = w.link(f"ground/terrain/{g}", friction=mu)
        boxes = [
            np.array(
                [(ox + c0 * s, oy + r0 * s, min(floor, h - MIN_THICKNESS)), (ox + c1 * s, oy + r1 * s, h)]
            )
            for r0, c0, r1, c1, h in _flat_rectangles(t, members)
        ]
        w.pieces(link, Pieces(axis_boxes(np.array(boxes)), (), floor))
        for area, h in split.get(mu, []):
            w.pieces(link, flat_pieces(area, min(floor, h - MIN_THICKNESS), h))
        for k in members.tolist():
            if not flat[k]:
                w.pieces(link, pieces[k], (ox + (k % t.cols) * s, oy + (k // t.cols) * s, 0.0))
        if not w.visual:
            continue
        # The visual: boxes where the ground is made of boxes, else the tiles' meshes (the
        # zones' surfaces colour it).
        for k in members.tolist():
            if not flat[k] and tile_kind(t.tiles[k]).boxes is not None:
                corner = np.array([ox + (k % t.cols) * s, oy + (k // t.cols) * s, 0.0])
                boxes += list(tile_boxes(t.tiles[k], s, floor=floor) + corner)
        for lo, hi in boxes:
            _element(link, "visual", ("box", {"size": _v(hi - lo)}), (lo + hi) / 2, material=terrain_material)
        slabs = [extrude(area, min(floor, h - MIN_THICKNESS), h) for area, h in split.get(mu, [])]
        meshes = [k for k in members.tolist() if tile_kind(t.tiles[k]).boxes is None]
        if meshes:
            slabs.append(_tiles(t, np.asarray(meshes), floor, resolution))
        slabs = [(v, f) for v, f in slabs if len(f)]
        if slabs:
            offsets = np.cumsum([0] + [len(v) for v, _ in slabs[:-1]])
            verts = np.concatenate([v for v, _ in slabs])
            faces = np.concatenate([f + o for (_, f), o in zip(slabs, offsets, strict=True)])
            _element(link, "visual", _mesh_geometry(w.mesh(verts, faces)), material=terrain_material)
    # Terrain features: oriented boxes, one link per friction.
    groups: dict[float, list] = {}
    for f in t.features or ():
        groups.setdefault(FRICTION[f.material or "concrete"], []).append(f)
    for g, (mu, group) in enumerate(groups.items()):
        link = w.link(f"ground/features/{g}", friction=mu)
        for f in group:
            for centre, half, yaw, pitch in feature_boxes(f):
                for kind, material in (("visual", terrain_material), ("collision", None)):
                    if kind == "collision" or w.visual:
                        size = ("box", {"size": _v(2.0 * np.asarray(half))})
                        _element(link, kind, size, centre, yaw, material=material, pitch=pitch)


def _tiles(t: Terrain, members: np.ndarray, floor: float, resolution: float | np.ndarray | None):
    """The solids of the tiles ``members`` in world coordinates, each distinct tile built once;
    ``resolution`` is one cell size (m) for all or an array of each tile's."""
    cache: dict[tuple[str, float | None], trimesh.Trimesh] = {}
    verts, faces, count = [], [], 0
    for k in members.tolist():
        tile = t.tiles[k]
        res = float(resolution[k]) if isinstance(resolution, np.ndarray) else resolution
        key = (tile.model_dump_json(exclude={"material", "friction"}), res)
        if key not in cache:
            cache[key] = tile_mesh(tile, t.tile_size, floor=floor, resolution=res)
        mesh = cache[key]
        shift = (t.origin[0] + (k % t.cols) * t.tile_size, t.origin[1] + (k // t.cols) * t.tile_size, 0.0)
        verts.append(mesh.vertices + np.array(shift))
        faces.append(mesh.faces + count)
        count += len(mesh.vertices)
    return np.concatenate(verts), np.concatenate(faces)


# --- export -------------------------------------------------------------------------------


def _write(
    out: Path, name: str, piece: tiles.Piece, folder: Path | None, friction: np.ndarray, options: dict,
    lod_choice: tuple[float | None, np.ndarray | None] | None,
) -> tuple[Path, list[Path], float | None, int]:  # fmt: skip
    """One URDF file of ``piece``: its path, its meshes, its rough tiles' coarsest cell size
    and its links. ``lod_choice`` is :func:`_auto_lod`'s, None for an explicit ``resolution``."""
    view, placements = piece.scene, piece.scene.placements
    if not options["visual"]:
        visual = terrain = None  # no visual meshes: no level of detail to choose
    elif lod_choice is None:
        visual = terrain = fit_terrain(view, options["resolution"], "urdf", None)
    else:
        visual, cells = lod_choice
        terrain = (
            None if cells is None else view.terrain.tile_size / np.maximum(cells[piece.terrain_tiles], 1)
        )
    w = _Writer(out, name, options.get("assets"), options["visual"])
    apron = apron_boxes(options["model"], options["apron"], -options["thickness"], piece.box)
    _add_ground(w, view, piece.zones, visual, options["thickness"], apron)
    _add_solids(w, view, piece.zones)
    _add_terrain(
        w, view, piece.zones, friction[piece.terrain_tiles], terrain, options["floor"], options["tolerance"]
    )
    for i in piece.placements:
        _add_placement(w, placements[i], i, folder, options["capsules"])
    path = out / f"{name}.urdf"
    write_atomic(path, w.text().encode("utf-8"))
    coarsest = terrain if not isinstance(terrain, np.ndarray) else None
    if isinstance(terrain, np.ndarray):
        rough = [isinstance(tile, RoughTile) for tile in view.terrain.tiles]
        coarsest = float(terrain[rough].max()) if any(rough) else None
    return path, sorted(w.files), coarsest, len(w.robot.findall("link"))


def _auto_lod(model: Scene, pieces: list[tiles.Piece]) -> tuple[float | None, np.ndarray | None]:
    """The terrain's level of detail when none is asked for: the zones' draped surfaces'
    cell size (m; None: the default), and each terrain tile's cells along its side (None: the
    default for every tile). Where the default rough meshes exceed ``lod.BUDGETS["urdf"]``
    triangles in a file or ``lod.TILED_BUDGETS["urdf"]`` in all, rougher tiles get finer
    cells (:func:`~citygen.exporters.lod.fit`), said in one warning."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportWarning)
        visual = fit_terrain(model, AUTO, "urdf", None)
    t = model.terrain
    if t is None:
        return visual, None
    default = np.array(
        [rough_cells(x, t.tile_size, None) if isinstance(x, RoughTile) else 0 for x in t.tiles]
    )
    per_file = lod.BUDGETS["urdf"]
    total = per_file if len(pieces) == 1 else lod.TILED_BUDGETS["urdf"]
    groups = [p.terrain_tiles for p in pieces]
    cells = lod.fit(model, default, total, groups=groups, group_budget=per_file)
    if cells is None:
        return visual, None
    budget = f"{total:,} triangles" + (f" ({per_file:,} a tile)" if len(pieces) > 1 else "")
    option = "resolution= (citygen export --terrain-resolution)"
    warnings.warn(ExportWarning(lod.warning("URDF", model, cells, budget, option)), stacklevel=3)
    return visual, cells


def frictions(path: str | Path) -> dict[str, float]:
    """Each link's friction coefficient as a URDF file of this exporter gives it, for loaders
    that read none from the file (SAPIEN: ``loader.set_link_material(link, mu, mu, 0.0)``).

    >>> import tempfile, warnings
    >>> with tempfile.TemporaryDirectory() as out, warnings.catch_warnings():
    ...     warnings.simplefilter("ignore")
    ...     mu = frictions(export("examples/nav_static_10m.json", out, visual=False)[0])
    >>> mu["ground/apron"]  # concrete's
    0.75
    """
    root = ET.parse(path).getroot()
    found = ((link.get("name"), link.find("contact/lateral_friction")) for link in root.iter("link"))
    return {name: float(el.get("value")) for name, el in found if el is not None}


def links(scene: Scene) -> int:
    """About how many links the scene's URDF has in one file."""
    solid = sum(z.height is not None for z in scene.zones)
    return 2 + len(scene.zones) + solid + len(scene.placements) + (8 if scene.terrain is not None else 0)


def tile_side(scene: Scene) -> float:
    """The side (m) of the square URDF tiles the scene is cut into by default: 0 (one file)
    up to :data:`MAX_LINKS` links, else about :data:`TILE_LINKS` links a tile."""
    n = links(scene)
    if n <= MAX_LINKS:
        return 0.0
    w, h = scene.bounds.size
    return max(w, h) / math.ceil(math.sqrt(n / TILE_LINKS))


def export(scene: Scene | str | Path, out_dir: str | Path, **options: Any) -> list[Path]:
    """Write ``<out_dir>/<name>.urdf`` and its meshes under ``<out_dir>/assets/``; returns
    the URDF's path followed by every mesh file it references, sorted. A scene of more
    than :data:`MAX_LINKS` links (a city) is cut into square tiles instead
    (:mod:`citygen.exporters.tiles`): ``<name>-tile-<row>-<col>.urdf`` each, listed with
    their bounds in ``<name>-urdf-tiles.json``; returns the index, the tiles, then the meshes.

    Options: ``name`` (default: the scene file's stem, ``<split>-<index>`` or ``scene``),
    ``scene_dir`` (the folder mesh placements are relative to, for a scene given as a
    model), ``resolution`` (m, cell size of rough tiles' meshes; default
    :func:`~citygen.geometry.terrain.tile_mesh`'s, uniformly coarser with one warning where
    a file's terrain would exceed ``lod.BUDGETS["urdf"]`` triangles), ``floor`` (m, bottom of the terrain,
    default -1), ``zone_thickness`` (m, default 0.1), ``capsules`` (``"mesh"``, the
    default, writes capsules as convex meshes every reader loads; ``"pybullet"`` writes
    PyBullet's ``<capsule>``), ``tile`` (m, side of the URDF tiles; 0 writes one file
    whatever the size; default :func:`tile_side`), ``visual`` (default True; False writes
    collision geometry only), ``apron`` (m, width of the ground around the scene, default
    :data:`~citygen.exporters.pieces.APRON`; 0 for none), ``tolerance`` (m, how far rough
    tiles' convex pieces may lie from ``height_at``; default 0.01, coarser with one warning
    where they would exceed :data:`~citygen.exporters.pieces.PIECE_BUDGETS`).
    """
    check_options(options, _OPTIONS, "urdf")
    name = output_name(scene, options, "urdf")
    model, folder = scene_dir_of(scene, options)
    capsules = options.get("capsules", "mesh")
    if capsules not in CAPSULES:
        raise ExportError(f"urdf export: expected capsules one of {', '.join(CAPSULES)}, got {capsules!r}")
    thickness = float(options.get("zone_thickness", ZONE_THICKNESS))
    floor = float(options.get("floor", FLOOR))
    if not (math.isfinite(thickness) and thickness > 0) or not math.isfinite(floor):
        raise ExportError(
            f"urdf export: expected zone_thickness > 0 and a finite floor (m), got {thickness!r}, {floor!r}"
        )
    side = options.get("tile", AUTO)
    side = tile_side(model) if side == AUTO else side
    if isinstance(side, bool) or not isinstance(side, int | float) or not math.isfinite(side) or side < 0:
        raise ExportError(f"urdf export: expected tile >= 0 (m; 0 for one file), got {side!r}")
    resolution = resolution_option(options.get("resolution", AUTO), "urdf")
    visual, apron = options.get("visual", True), options.get("apron", APRON)
    if not isinstance(visual, bool):
        raise ExportError(f"urdf export: expected visual True or False, got {visual!r}")
    if (
        isinstance(apron, bool)
        or not isinstance(apron, int | float)
        or not (math.isfinite(apron) and apron >= 0)
    ):
        raise ExportError(f"urdf export: expected apron >= 0 (m; 0 for none), got {apron!r}")
    budget = PIECE_BUDGETS["urdf"] if side == 0 else TILED_PIECE_BUDGET
    settings = {
        "resolution": AUTO if resolution is None else resolution,
        "thickness": thickness, "floor": floor, "capsules": capsules, "assets": {}, "visual": visual,
        "apron": float(apron), "model": model,
        "tolerance": tolerance_option(options.get("tolerance", AUTO), model, "urdf", budget),
    }  # fmt: skip
    out = Path(out_dir)
    polys = zone_polygons(model)
    friction, report = tile_friction(model, polys, split_flat=True)
    if report is not None:
        warnings.warn(ExportWarning(report), stacklevel=2)
    if side == 0:
        whole = tiles.Piece(
            0, 0, (*model.bounds.min, *model.bounds.max), model, polys, list(range(len(model.zones))),
            list(range(len(model.placements))), np.arange(len(model.terrain.tiles) if model.terrain else 0),
        )  # fmt: skip
        choice = _auto_lod(model, [whole]) if settings["resolution"] == AUTO and visual else None
        path, files, _, _ = _write(out, name, whole, folder, friction, settings, choice)
        written = [path]
    else:
        written, files = _write_tiles(model, out, name, float(side), polys, folder, friction, settings)
    if model.agents:
        warnings.warn(
            ExportWarning(
                f"$.agents: URDF has no moving agents; {len(model.agents)} left out (GLB and MJCF keep them)"
            ),
            stacklevel=2,
        )
    if model.task is not None:
        warnings.warn(
            ExportWarning(f"$.task: URDF has no task; the {model.task.kind} task is left out"), stacklevel=2
        )
    return [*written, *sorted(set(files))]


def _write_tiles(
    model: Scene, out: Path, name: str, side: float, polys: list, folder: Path | None,
    friction: np.ndarray, settings: dict,
) -> tuple[list[Path], list[Path]]:  # fmt: skip
    """Every tile's URDF and the index."""
    pieces = tiles.plan(model, side, polys)
    choice = _auto_lod(model, pieces) if settings["resolution"] == AUTO and settings["visual"] else None
    digits = tiles.width(pieces)
    paths, files, entries = [], [], []
    for piece in pieces:
        path, meshes, resolution, link_count = _write(
            out, piece.name(name, digits), piece, folder, friction, settings, choice
        )
        paths.append(path)
        files += meshes
        entries.append(tiles.entry(
            piece, path.name, links=link_count,
            objects=len(piece.placements), terrain_resolution=resolution,
        ))  # fmt: skip
    index = tiles.write_index(out / f"{name}-urdf-tiles.json", name, "urdf", entries)
    return [index, *paths], files
