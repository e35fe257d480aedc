"""MJCF: a scene as a MuJoCo model (``<name>.xml`` plus shared mesh files).

What the model holds (metres, radians, Z up; ``<compiler angle="radian"/>``):

- **Ground.** Flat ground is thin convex *slabs* (boxes where a piece is a rectangle,
  convex meshes otherwise) from ``floor`` up to the ground's height, one set per zone:
  each zone's polygon, cut to the flat ground and split into convex pieces (rectangles
  for axis-aligned shapes, else a constrained Delaunay triangulation merged back into
  convex polygons, Hertel-Mehlhorn), carries the zone's friction and colour. So friction
  is exact per zone on flat ground, and the slabs are at once the collision and the
  visual geometry. Flat ground is everything outside the terrain grid (z = 0) and every
  level tile (flat, a slope of angle 0, a rough tile of amplitude 0) at its height.
  Ground no zone covers gets :data:`DEFAULT_FRICTION`. Beyond the scene (the bounds and
  the grid) an *apron* of four boxes ``apron`` metres wide keeps the ground at z = 0;
  there is no infinite plane, since a plane would also collide under the slabs and pits.
- **Terrain.** Stair tiles are boxes (:func:`~citygen.geometry.terrain.tile_boxes`);
  slope and rough tiles are one heightfield each, sampled from
  :func:`~citygen.geometry.terrain.tile_height` every ``resolution`` metres or finer
  (rough tiles every ``scale / 8``, at most four times finer than ``resolution``), so
  every tile edge is exact and meets its neighbour. A non-level tile has one friction: its
  own (``friction`` or ``material``),
  else that of the zone covering most of it, else :data:`DEFAULT_FRICTION`; where zones
  of different friction share such a tile an :class:`ExportWarning` says so.
- **Objects.** One static body per placement (``object:<id>``) whose geoms are the
  asset's convex parts: MuJoCo boxes, cylinders, capsules and spheres where the part is
  one, convex meshes (``assets/<digest>.stl``, written once per dataset folder)
  otherwise. A placement's mesh file (relative to the scene file) is split into its
  connected parts, each a mesh geom; MuJoCo collides a mesh as its convex hull, so an
  :class:`ExportWarning` names every placement with a non-convex part.
- **Agents.** One mocap body per agent (``agent:<id>``) at its start, on the ground,
  facing its goal: people are capsules of their radius, :data:`PERSON_HEIGHT` tall;
  vehicles boxes of their length and width, :data:`VEHICLE_HEIGHT` tall. The body's
  origin is the ground point under the agent's centre, so a runner drives it by writing
  ``data.mocap_pos[model.body(name).mocapid]`` = ``(x, y, height_at(x, y))``.
  Each agent's goal is a site ``agent:<id>:goal`` (group 4, hidden), its preferred speed
  (m/s) ``<custom><numeric name="agent:<id>:speed">`` and a vehicle's route of block ids
  ``<custom><text name="agent:<id>:route">``.
- **Signals.** Sites ``signal:<id>:head:<k>`` where each light hangs, ``signal:<id>:<phase>``
  (group 4) per phase, custom entries of each phase's times, lanes and crosswalks.
- **Task.** Sites ``task:start`` (its frame turned by the start yaw), ``task:goal`` (a
  disc of the goal tolerance) and for a traverse ``task:waypoint:<k>``; custom entries
  ``task:kind``, ``task:robot`` (text), ``task:time_limit`` (s) and for locomotion
  ``task:command`` (vx, vy in m/s, yaw rate in rad/s).
- **Cameras.** ``top`` (orthographic, straight down, covering the scene) and
  ``perspective`` (from the south-west, above, looking at the scene's centre).
- **Limits.** ``<size memory>`` is sized from the number of geoms (:func:`arena_mb`), so
  the first step of a city works; heightfields stay within ``lod.BUDGETS["mjcf"]``
  samples unless a ``resolution`` is given (:mod:`citygen.exporters.lod`).

Contact filtering (MuJoCo collides two geoms when ``contype1 & conaffinity2`` or
``contype2 & conaffinity1``): every static geom has ``contype`` :data:`STATIC_BIT` and
``conaffinity`` 0, agents ``contype`` :data:`AGENT_BIT` and ``conaffinity`` 0, so the
world never collides with itself or with agents. A robot's geoms should use
``contype=ROBOT_BIT`` and ``conaffinity=ROBOT_CONAFFINITY`` (static world and agents;
add ``ROBOT_BIT`` for self-collision). Static geoms have ``priority="1"``, so a contact
between a robot (priority 0) and the ground uses the ground's friction, not a mix.
Geom groups: 0 ground and terrain, 1 objects, 2 agents (so a ray or a rendering can
select them: ``mj_ray(..., geomgroup=[1, 0, 0, 0, 0, 0], ...)`` sees only the ground).

Names (the runner may rely on them; they are a public contract, the README's naming table):
the parts of every name are joined by ``:`` (:data:`SEP`), never ``/``, which dm_control's
``mjcf`` reserves for the scopes of attached models. Every geom is
``<layer>:<class>:<id>:<k>`` (an id may itself hold a ``:``; layer, class and k never do):
``zone:<zone kind>:<zone id>:<k>`` (``zone:none:ground:<k>`` for ground no zone covers,
``zone:none:outside:<k>`` for the apron), ``terrain:<tile kind>:<row>_<col>:<k>``,
``object:<semantic class>:<placement id>:<k>`` (``object:mesh:...`` for mesh files),
``agent:<agent kind>:<agent id>:0``. Ground and terrain geoms use the material
``zone:<kind>`` (or ``ground``) of the ground they stand for; heightfields are
``terrain:<n>``. Bodies are ``object:<id>`` and ``agent:<id>``; sites ``agent:<id>:goal``,
``task:start``, ``task:goal``, ``task:waypoint:<k>``; custom entries ``agent:<id>:speed``,
``agent:<id>:route``, ``task:kind``, ``task:robot``, ``task:time_limit``, ``task:command``.

The same scene and options give the same XML and asset bytes; numbers are written with
at most 6 decimals.

>>> from citygen.exporters import mjcf
>>> xml = mjcf.to_xml("examples/nav_static_10m.json")
>>> xml.startswith('<mujoco model="nav_static_10m">')
True
"""

from __future__ import annotations

import functools
import hashlib
import math
import os
import struct
import sys
import warnings
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from ctypes.util import find_library
from dataclasses import dataclass, field
from itertools import pairwise
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING, Any

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry import box as rect

from citygen.assets import Box, Capsule, ConvexMesh, Cylinder, UnknownAsset, resolve
from citygen.errors import DependencyMissing, ExportError, Problem, SpecError
from citygen.exporters import ZONE_COLORS, ExportWarning, as_scene, lod, output_name, shared_file
from citygen.geometry.features import feature_boxes
from citygen.geometry.terrain import MIN_THICKNESS, height_at, tile_boxes, tile_grid
from citygen.io import write_atomic
from citygen.spec.agents import Person
from citygen.spec.scene import Scene
from citygen.spec.surfaces import FRICTION
from citygen.spec.task import LocoTask, NavTask, TraverseTask
from citygen.spec.terrain import FlatTile, RoughTile, SlopeTile, StairTile, peak, rise

if TYPE_CHECKING:
    import mujoco

#: ``contype`` of every static geom (ground, terrain, objects); their ``conaffinity`` is 0.
STATIC_BIT = 1
#: The separator of the parts of every name this exporter gives (``object:bench:bench-1:0``).
#: Not ``/``: dm_control's ``mjcf`` reserves that for the scopes of attached models.
SEP = ":"
#: The first part of every geom name: what the geom stands for.
LAYERS = ("zone", "terrain", "object", "agent")

#: The bit a robot's geoms should set in ``contype``.
ROBOT_BIT = 2
#: ``contype`` of agents' geoms (mocap bodies); their ``conaffinity`` is 0.
AGENT_BIT = 4
#: The ``conaffinity`` a robot's geoms should have: touch the static world and agents.
ROBOT_CONAFFINITY = STATIC_BIT | AGENT_BIT

#: Sliding friction of ground no zone covers and of object parts of a material without
#: a friction in :data:`citygen.spec.surfaces.FRICTION` (concrete's).
DEFAULT_FRICTION = FRICTION["concrete"]
#: MuJoCo's default torsional and rolling friction, written after the sliding one.
_SPIN_ROLL = (0.005, 0.0001)

#: Zone colours (RGBA in [0, 1]) from the exporters' shared palette
#: (:data:`citygen.exporters.ZONE_COLORS`).
ZONE_RGBA = MappingProxyType(
    {kind: (*(int(h[i : i + 2], 16) / 255 for i in (1, 3, 5)), 1.0) for kind, h in ZONE_COLORS.items()}
)
_GROUND_RGBA = (0.957, 0.945, 0.918, 1.0)  # ground inside the scene no zone covers
_OUTSIDE_RGBA = (0.8, 0.8, 0.78, 1.0)
_AGENT_RGBA = {
    "pedestrian": (0.9, 0.1, 0.29, 1.0),
    "cyclist": (0.96, 0.51, 0.19, 1.0),
    "scooter": (0.57, 0.12, 0.71, 1.0),
    "vehicle": (0.12, 0.37, 0.82, 1.0),
}
_START_RGBA, _GOAL_RGBA = (0.04, 0.56, 0.23, 0.8), (0.82, 0.12, 0.29, 0.45)

#: Height (m) of the capsule standing for each kind of person.
SIGNAL_HEIGHT = 3.0
"""Height (m) of a signal head's site above the ground."""
PERSON_HEIGHT = MappingProxyType({"pedestrian": 1.75, "cyclist": 1.8, "scooter": 1.8})
#: Height (m) of the box standing for a vehicle.
VEHICLE_HEIGHT = 1.5
#: Default bottom (m) of slabs and stair boxes, lowered to ``MIN_THICKNESS`` below the lowest tread.
FLOOR = -1.0
#: Thickness (m) of every heightfield below its lowest sample.
HFIELD_BASE = 1.0
#: Defaults of the options: heightfield sample spacing (m) and apron width (m).
DEFAULT_RESOLUTION, DEFAULT_APRON = 0.1, 20.0
#: Height step (m) of heightfield samples (they are written as whole numbers of it).
HFIELD_UNIT = 1e-5
#: Most heightfield samples in one model (bounds the XML's size: about 6 bytes a sample).
MAX_HFIELD_SAMPLES = 1 << 24
#: Most samples along one side of a tile's heightfield.
MAX_HFIELD_SIDE = 257
#: A mesh file with more connected parts than this is one mesh geom (one convex hull).
MAX_MESH_PARTS = 64
#: Widest view (m) of the orthographic top camera; wider scenes get a perspective one.
MAX_ORTHOGRAPHIC = 170.0
#: Size (px) of the offscreen buffer written into ``<visual><global>``.
OFFSCREEN = (1280, 960)

#: ``<size memory>``: MiB for contacts and constraints, plus bytes a geom (broadphase).
ARENA_BASE_MB, ARENA_PER_GEOM = 32, 4096

_AREA_EPS = 1e-6  # m^2: pieces smaller than this are numerical slivers
_OPTIONS = ("name", "resolution", "apron", "mesh_dir")


# --- numbers --------------------------------------------------------------------------


def _n(x: float) -> str:
    """A number in at most 6 decimals, trailing zeros dropped, never ``-0``."""
    s = f"{x:.6f}".rstrip("0").rstrip(".")
    return "0" if s in ("-0", "") else s


def _v(values: Any) -> str:
    return " ".join(map(_n, np.asarray(values, dtype=float).ravel().tolist()))


def _ints(values: Any) -> str:
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


# --- convex pieces of polygons --------------------------------------------------------


def _polygons(geom: Any) -> list[Polygon]:
    """The polygons of a shapely result (dropping lines, points and slivers), in order."""
    parts = shapely.get_parts(geom).tolist() if not geom.is_empty else []
    out: list[Polygon] = []
    for p in parts:
        if isinstance(p, Polygon):
            if p.area > _AREA_EPS:
                out.append(p)
        elif hasattr(p, "geoms"):
            out.extend(_polygons(p))
    return out


def _cross(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    """The z of ``(a - o) x (b - a)``: positive where the path o, a, b turns left."""
    return (a[0] - o[0]) * (b[1] - a[1]) - (a[1] - o[1]) * (b[0] - a[0])


def _turns_left(o: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> bool:
    """Whether o, a, b turns left or goes straight on (within a relative 1e-9)."""
    scale = math.hypot(a[0] - o[0], a[1] - o[1]) * math.hypot(b[0] - a[0], b[1] - a[1])
    return _cross(o, a, b) >= -1e-9 * scale


def _clean_ring(ring: Any) -> np.ndarray:
    """A counter-clockwise ring ``(n, 2)`` without its repeated first vertex or collinear vertices."""
    pts = [(float(x), float(y)) for x, y in np.asarray(ring, dtype=float)[:, :2]]
    if len(pts) > 1 and pts[0] == pts[-1]:
        pts.pop()
    area2 = sum(x0 * y1 - x1 * y0 for (x0, y0), (x1, y1) in zip(pts, pts[1:] + pts[:1], strict=True))
    if area2 < 0:
        pts.reverse()
    changed = True
    while changed and len(pts) > 3:
        changed = False
        for i in range(len(pts)):
            o, a, b = pts[i - 1], pts[i], pts[(i + 1) % len(pts)]
            scale = math.hypot(a[0] - o[0], a[1] - o[1]) * math.hypot(b[0] - a[0], b[1] - a[1])
            if abs(_cross(o, a, b)) <= 1e-9 * scale:
                del pts[i]
                changed = True
                break
    return np.array(pts, dtype=float).reshape(-1, 2)


def _is_convex(ring: np.ndarray) -> bool:
    pts = [tuple(p) for p in np.asarray(ring, dtype=float).tolist()]
    return all(_turns_left(pts[i - 2], pts[i - 1], pts[i]) for i in range(len(pts)))


def _rectilinear(poly: Polygon) -> bool:
    for ring in (poly.exterior, *poly.interiors):
        d = np.diff(np.asarray(ring.coords), axis=0)
        if not np.all((np.abs(d[:, 0]) <= 1e-9) | (np.abs(d[:, 1]) <= 1e-9)):
            return False
    return True


def _rectangles(poly: Polygon) -> list[np.ndarray]:
    """A rectilinear polygon as axis-aligned rectangles: horizontal bands between its
    vertices' y values, equal intervals of neighbouring bands merged."""
    coords = np.concatenate([np.asarray(r.coords) for r in (poly.exterior, *poly.interiors)])
    ys = np.unique(coords[:, 1])
    x0, _, x1, _ = poly.bounds
    out: list[tuple[float, float, float, float]] = []
    open_: dict[tuple[float, float], float] = {}
    for y0, y1 in pairwise(ys.tolist()):
        band = _polygons(poly.intersection(rect(x0, y0, x1, y1)))
        spans = sorted((p.bounds[0], p.bounds[2]) for p in band)
        now = {span: open_.pop(span, y0) for span in spans}
        out += [(a, start, b, y0) for (a, b), start in open_.items()]
        open_ = now
    out += [(a, start, b, float(ys[-1])) for (a, b), start in open_.items()]
    return [np.array([[a, b], [c, b], [c, d], [a, d]]) for a, b, c, d in out]


def _hertel_mehlhorn(poly: Polygon) -> list[np.ndarray]:
    """Convex pieces of a polygon with holes: its constrained Delaunay triangles, merged
    across diagonals (longest first) while the union stays convex."""
    index: dict[tuple[float, float], int] = {}
    pieces: list[list[int] | None] = []
    for t in shapely.get_parts(shapely.constrained_delaunay_triangles(poly)).tolist():
        ring = [(float(x), float(y)) for x, y in t.exterior.coords[:3]]
        if _cross(*ring) == 0:
            continue
        if _cross(*ring) < 0:
            ring.reverse()
        pieces.append([index.setdefault(p, len(index)) for p in ring])
    pts = list(index)
    owner: dict[tuple[int, int], int] = {}
    for k, piece in enumerate(pieces):
        for a, b in zip(piece, piece[1:] + piece[:1], strict=True):
            owner[(a, b)] = k
    diagonals = sorted(
        ((a, b) for a, b in owner if a < b and (b, a) in owner),
        key=lambda e: (-math.dist(pts[e[0]], pts[e[1]]), e),
    )
    for a, b in diagonals:
        p, q = owner[(a, b)], owner[(b, a)]
        if p == q:
            continue
        pp, qq = pieces[p], pieces[q]
        i, j = pp.index(a), qq.index(b)  # pp: ... a, b ...; qq: ... b, a ...
        path_p = pp[i + 1 :] + pp[: i + 1]  # b ... a
        path_q = qq[j + 1 :] + qq[: j + 1]  # a ... b
        # Only the corners at a and b change; every other corner is one of a convex piece.
        if not (
            _turns_left(pts[path_p[-2]], pts[a], pts[path_q[1]])
            and _turns_left(pts[path_q[-2]], pts[b], pts[path_p[1]])
        ):
            continue
        merged = path_p + path_q[1:-1]
        pieces[p], pieces[q] = merged, None
        for u, w in zip(merged, merged[1:] + merged[:1], strict=True):
            owner[(u, w)] = p
    return [_clean_ring([pts[k] for k in piece]) for piece in pieces if piece is not None]


def convex_pieces(poly: Polygon) -> list[np.ndarray]:
    """A polygon (with holes) as convex counter-clockwise rings ``(n, 2)`` in metres that
    tile it: itself when convex, rectangles when its edges are axis-aligned, else merged
    triangles (Hertel-Mehlhorn, at most four times the fewest convex pieces).

    >>> from shapely.geometry import Polygon
    >>> len(convex_pieces(Polygon([(0, 0), (2, 0), (2, 1), (1, 1), (1, 2), (0, 2)])))
    2
    """
    ring = _clean_ring(np.asarray(poly.exterior.coords))
    if not poly.interiors and _is_convex(ring):
        return [ring]
    if _rectilinear(poly):
        return _rectangles(poly)
    return _hertel_mehlhorn(poly)


def _as_rectangle(ring: np.ndarray) -> tuple[np.ndarray, float, float, float] | None:
    """``(centre, length, width, yaw)`` when a convex ring is a rectangle, else None."""
    if len(ring) != 4:
        return None
    e = np.roll(ring, -1, axis=0) - ring
    lengths = np.linalg.norm(e, axis=1)
    cos = np.abs(np.sum(e * np.roll(e, -1, axis=0), axis=1)) / (lengths * np.roll(lengths, -1))
    if np.any(cos > 1e-9):
        return None
    # The edge nearest the +x axis gives the yaw, in (-pi/4, pi/4]: axis-aligned boxes get none.
    quarter = math.atan2(e[0, 1], e[0, 0]) / (math.pi / 2)
    turns = math.ceil(quarter - 0.5)
    length, width = (lengths[0], lengths[1]) if turns % 2 == 0 else (lengths[1], lengths[0])
    yaw = (quarter - turns) * (math.pi / 2)
    return ring.mean(axis=0), float(length), float(width), yaw


# --- mesh files --------------------------------------------------------------------


def _stl(vertices: np.ndarray, faces: np.ndarray) -> bytes:
    """Binary STL of a triangle mesh (float32), with a fixed header: the same mesh, the same bytes."""
    tri = np.asarray(vertices, dtype=np.float64)[np.asarray(faces, dtype=np.int64)]
    normal = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    length = np.linalg.norm(normal, axis=1, keepdims=True)
    normal = np.divide(normal, length, out=np.zeros_like(normal), where=length > 0)
    rec = np.zeros(len(tri), dtype=[("n", "<f4", 3), ("v", "<f4", (3, 3)), ("a", "<u2")])
    rec["n"], rec["v"] = normal, tri
    return b"citygen binary STL".ljust(80, b" ") + struct.pack("<I", len(tri)) + rec.tobytes()


@functools.lru_cache(maxsize=4096)
def _part_stl(part: ConvexMesh) -> bytes:
    mesh = part.to_manifold().to_mesh64()
    return _stl(np.asarray(mesh.vert_properties)[:, :3], np.asarray(mesh.tri_verts))


def asset_name(data: bytes, suffix: str) -> str:
    """The path, relative to the XML file, of an asset file: ``assets/<digest><suffix>``,
    the name :func:`citygen.exporters.shared_file` gives it."""
    return f"assets/{hashlib.sha256(data).hexdigest()[:20]}{suffix}"


# --- the model --------------------------------------------------------------------------


@dataclass(frozen=True)
class MJCF:
    """A compiled scene: the XML text and the asset files it names (path relative to the
    XML file -> bytes), ready for ``mujoco.MjModel.from_xml_string(xml, dict(assets))``."""

    xml: str
    assets: Mapping[str, bytes]


@dataclass
class _Builder:
    scene: Scene
    file: str | None
    base_dir: Path | None
    resolution: float | None
    apron: float
    root: ET.Element = field(init=False)
    asset: ET.Element = field(init=False)
    world: ET.Element = field(init=False)
    files: dict[str, bytes] = field(default_factory=dict)
    materials: dict[str, tuple[float, ...]] = field(default_factory=dict)
    meshes: set[str] = field(default_factory=set)
    floor: float = FLOOR
    samples: int = 0
    warnings: list[str] = field(default_factory=list)
    customs: ET.Element | None = None
    top: float = 0.0
    bottom: float = 0.0

    def material(self, name: str, rgba: tuple[float, ...]) -> str:
        if name not in self.materials:
            self.materials[name] = rgba
            ET.SubElement(self.asset, "material", name=name, rgba=_v(rgba))
        return name

    def custom(self, kind: str, name: str, data: str) -> None:
        """A ``<custom>`` entry (``numeric`` or ``text``): scene data no geom carries."""
        if self.customs is None:
            self.customs = ET.Element("custom")
        ET.SubElement(self.customs, kind, name=name, data=data)

    def mesh_file(self, data: bytes, scale: float, **extra: str) -> str:
        """A mesh asset for a file's bytes at a scale; its name."""
        path = asset_name(data, ".stl")
        self.files[path] = data
        name = f"{path[7:19]}@{_n(scale)}"
        if name not in self.meshes:
            self.meshes.add(name)
            attrs = {"name": name, "file": path, **extra}
            if scale != 1.0:
                attrs["scale"] = _v([scale] * 3)
            ET.SubElement(self.asset, "mesh", **attrs)
        return name


def _friction(mu: float) -> str:
    return _v((mu, *_SPIN_ROLL))


def _slab(b: _Builder, parent: ET.Element, name: str, ring: np.ndarray, top: float, mu: float, mat: str):
    """One convex piece of flat ground from the floor up to ``top``: a box or a mesh prism."""
    bottom = b.floor
    box = _as_rectangle(ring)
    attrs = {"name": name, "class": "static", "material": mat, "friction": _friction(mu)}
    if box is not None:
        (cx, cy), length, width, yaw = box
        attrs |= {"type": "box", "pos": _v((cx, cy, (top + bottom) / 2))}
        attrs["size"] = _v((length / 2, width / 2, (top - bottom) / 2))
        if abs(yaw) > 1e-12:
            attrs["euler"] = _v((0, 0, yaw))
        ET.SubElement(parent, "geom", **attrs)
        return
    n = len(ring)
    verts = np.concatenate([np.c_[ring, np.full(n, bottom)], np.c_[ring, np.full(n, top)]])
    ET.SubElement(b.asset, "mesh", name=name, vertex=_v(verts))
    ET.SubElement(parent, "geom", type="mesh", mesh=name, **attrs)


def _level(tile: Any) -> bool:
    """Whether a tile is flat ground at its height (slabs rather than boxes or a heightfield)."""
    return (
        isinstance(tile, FlatTile)
        or (isinstance(tile, SlopeTile) and tile.angle == 0.0)
        or (isinstance(tile, RoughTile) and tile.amplitude == 0.0)
    )


def _own_friction(tile: Any) -> float | None:
    if tile.friction is not None:
        return tile.friction
    if tile.material is not None:
        return FRICTION[tile.material]
    return None


def _zone_shapes(b: _Builder) -> list[Polygon]:
    out = []
    for zone in b.scene.zones:
        poly = Polygon(zone.polygon, zone.holes)
        out.append(poly if poly.is_valid else shapely.make_valid(poly))
    return out


def _ground(b: _Builder) -> None:
    """Zone slabs on all flat ground, the apron, stair boxes and heightfields."""
    scene, terrain = b.scene, b.scene.terrain
    (bx0, by0), (bx1, by1) = scene.bounds.min, scene.bounds.max
    grid = None
    shaped: list[int] = []
    plan: dict[int, int] = {}
    if terrain is not None:
        # The heightfields' plan first: a resolution too fine for the sample limit fails here,
        # before the city's slabs are built (the runner retries coarser on that error).
        shaped = [k for k, tile in enumerate(terrain.tiles) if not _level(tile)]
        plan = _hfield_plan(b, shaped)
        s = terrain.tile_size
        ox, oy = terrain.origin
        grid = rect(ox, oy, ox + terrain.cols * s, oy + terrain.rows * s)
        gx0, gy0, gx1, gy1 = grid.bounds
        bx0, by0, bx1, by1 = min(bx0, gx0), min(by0, gy0), max(bx1, gx1), max(by1, gy1)
        lows = [
            t.height + min(0.0, peak(t, s)) for t in terrain.tiles if _level(t) or isinstance(t, StairTile)
        ]
        b.floor = min(FLOOR, min(lows, default=0.0) - MIN_THICKNESS)
    scene_rect = rect(bx0, by0, bx1, by1)
    # Flat areas by (height, own friction), in a fixed order: outside the grid first.
    areas: dict[tuple[float, float | None], list[Polygon]] = {
        (0.0, None): [scene_rect.difference(grid) if grid is not None else scene_rect]
    }
    if terrain is not None:
        s = terrain.tile_size
        for k, tile in enumerate(terrain.tiles):
            if _level(tile):
                r, c = divmod(k, terrain.cols)
                x, y = terrain.origin[0] + c * s, terrain.origin[1] + r * s
                areas.setdefault((tile.height, _own_friction(tile)), []).append(rect(x, y, x + s, y + s))
    zones = _zone_shapes(b)
    tree = shapely.STRtree(zones)
    counters: dict[str, int] = {}

    def name_of(prefix: str) -> str:
        k = counters.get(prefix, 0)
        counters[prefix] = k + 1
        return f"{prefix}:{k}"

    for (height, own), squares in areas.items():
        area = shapely.union_all(squares) if len(squares) > 1 else squares[0]
        if area.is_empty:
            continue
        covered = []
        for zi in sorted(tree.query(area, predicate="intersects").tolist()):
            zone = scene.zones[zi]
            piece = zones[zi].intersection(area)
            covered.append(piece)
            mat = b.material(f"zone:{zone.kind}", ZONE_RGBA[zone.kind])
            mu = own if own is not None else zone.mu
            for poly in _polygons(piece):
                for ring in convex_pieces(poly):
                    _slab(b, b.world, name_of(f"zone:{zone.kind}:{zone.id}"), ring, height, mu, mat)
        rest = area.difference(shapely.union_all(covered)) if covered else area
        mat = b.material("ground", _GROUND_RGBA)
        for poly in _polygons(rest):
            for ring in convex_pieces(poly):
                mu = own if own is not None else DEFAULT_FRICTION
                _slab(b, b.world, name_of("zone:none:ground"), ring, height, mu, mat)
    if b.apron > 0:
        m = b.apron
        mat = b.material("outside", _OUTSIDE_RGBA)
        for x0, y0, x1, y1 in (
            (bx0 - m, by0 - m, bx1 + m, by0),
            (bx0 - m, by1, bx1 + m, by1 + m),
            (bx0 - m, by0, bx0, by1),
            (bx1, by0, bx1 + m, by1),
        ):
            ring = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
            _slab(b, b.world, name_of("zone:none:outside"), ring, 0.0, DEFAULT_FRICTION, mat)
    if terrain is not None:
        _shaped_tiles(b, zones, tree, shaped, plan)
        _features(b)


def _features(b: _Builder) -> None:
    """Each terrain feature as oriented boxes (:func:`~citygen.geometry.features.feature_boxes`):
    ``terrain:<feature kind>:<feature id>:<k>``, with its material's friction."""
    for f in b.scene.terrain.features or ():
        material = f.material or "concrete"
        mat = b.material(f"terrain:{material}", ZONE_RGBA["plaza" if material == "paving_stone" else "curb"])
        for k, (centre, half, yaw, pitch) in enumerate(feature_boxes(f)):
            # Yaw about z, then the pitch that raises the box's +x end (about its -y).
            cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
            quat = (cy * cp, sy * sp, -cy * sp, sy * cp)
            ET.SubElement(
                b.world, "geom", name=f"terrain:{f.kind}:{f.id}:{k}", type="box", pos=_v(centre),
                size=_v(half), quat=_v(quat), **{"class": "static"}, material=mat,
                friction=_friction(FRICTION[material]),
            )  # fmt: skip


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


def _tile_ground(b: _Builder, k: int, square_area: float, zis: list[int], areas: list[float]):
    """The friction and material of a non-level tile (``square_area`` m^2), given the zones
    ``zis`` meeting it in ascending order and their areas of overlap, and whether zones of
    different friction share it."""
    tile = b.scene.terrain.tiles[k]
    best, best_area, mus = None, 0.0, []
    for zi, area in zip(zis, areas, strict=True):
        if area > _AREA_EPS:
            mus.append(b.scene.zones[zi].mu)
            if area > best_area:
                best, best_area = b.scene.zones[zi], area
    if best is None:
        mat = b.material("ground", _GROUND_RGBA)
    else:
        mat = b.material(f"zone:{best.kind}", ZONE_RGBA[best.kind])
    own = _own_friction(tile)
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


def _geometry_key(tile: SlopeTile | RoughTile) -> tuple:
    return tuple(sorted(tile.model_dump(exclude={"height", "material", "friction"}).items()))


def _hfield_plan(b: _Builder, shaped: list[int]) -> dict[int, int]:
    """Cells along a side of each slope and rough tile's heightfield (tile index -> cells):
    by ``resolution``, or when none was given, :data:`DEFAULT_RESOLUTION`, where the scene's
    heightfields would exceed :data:`~citygen.exporters.lod.BUDGETS` samples made coarser
    (rough tiles by :func:`~citygen.exporters.lod.fit`, rougher tiles finer; slopes uniformly
    if they alone would take more than half), with one warning; an explicit resolution
    beyond :data:`MAX_HFIELD_SAMPLES` is an ExportError."""
    terrain = b.scene.terrain
    s = terrain.tile_size
    tiles = {k: terrain.tiles[k] for k in shaped if not isinstance(terrain.tiles[k], StairTile)}
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


def _shaped_tiles(
    b: _Builder, zones: list[Polygon], tree: Any, shaped: list[int], plan: dict[int, int]
) -> None:
    """The non-level tiles (indices ``shaped``): a heightfield of ``plan[k]`` cells a side for
    each slope and rough tile (:func:`_hfield_plan`), boxes for stairs."""
    terrain = b.scene.terrain
    s = terrain.tile_size
    hfields: dict[tuple, tuple[str, float]] = {}
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
        common = {"class": "static", "material": mat, "friction": _friction(mu)}
        if isinstance(tile, StairTile):
            for j, (lo, hi) in enumerate(tile_boxes(tile, s, floor=b.floor)):
                centre = (lo + hi) / 2 + (x, y, 0.0)
                ET.SubElement(
                    b.world, "geom", name=f"{prefix}:{j}", type="box", pos=_v(centre), size=_v((hi - lo) / 2),
                    **common,
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
            ET.SubElement(
                b.asset, "hfield", name=name, nrow=str(cells + 1), ncol=str(cells + 1),
                size=_v((s / 2, s / 2, span, HFIELD_BASE)),
                elevation=_ints(steps[::-1]),
            )  # fmt: skip
            hfields[key] = (name, lo)
        name, lo = hfields[key]
        ET.SubElement(
            b.world, "geom", name=f"{prefix}:0", type="hfield", hfield=name,
            pos=_v((x + s / 2, y + s / 2, tile.height + lo)), **common,
        )  # fmt: skip
    if mixed:
        b.warnings.append(
            f"$.terrain.tiles[{mixed[0]}]: {len(mixed)} stair, slope or rough tile(s) lie on zones of "
            "different friction; MJCF gives each tile one friction, that of the zone covering most of it"
        )


def _look_material(b: _Builder, look: Any) -> str:
    r, g, bl, a = (round(c * 255) for c in look.rgba)
    return b.material(f"look:{look.name}:{r:02x}{g:02x}{bl:02x}{a:02x}", look.rgba)


def _objects(b: _Builder) -> None:
    for i, pl in enumerate(b.scene.placements):
        x, y, z = pl.position
        attrs = {"name": f"object:{pl.id}", "childclass": "object", "pos": _v((x, y, z))}
        if pl.yaw:
            attrs["euler"] = _v((0, 0, pl.yaw))
        body = ET.SubElement(b.world, "body", **attrs)
        if pl.is_mesh:
            top = _mesh_placement(b, i, body)
        else:
            try:
                asset = resolve(pl.asset)
            except UnknownAsset as exc:
                where = f"$.placements[{i}].asset"
                raise SpecError([Problem(where, exc.expected, repr(pl.asset))], file=b.file) from None
            for k, part in enumerate(asset.parts):
                _part(b, body, f"object:{asset.semantic_class}:{pl.id}:{k}", part, pl.scale)
            top = asset.height * pl.scale
        b.top = max(b.top, z + top)
        b.bottom = min(b.bottom, z)


def _part(b: _Builder, body: ET.Element, name: str, part: Any, scale: float) -> None:
    look = part.material
    mu = FRICTION.get(look.name, DEFAULT_FRICTION)
    attrs = {"name": name, "material": _look_material(b, look), "friction": _friction(mu)}
    if isinstance(part, ConvexMesh):
        attrs |= {"type": "mesh", "mesh": b.mesh_file(_part_stl(part), scale)}
    else:
        attrs["pos"] = _v(np.asarray(part.pos) * scale)
        if isinstance(part, Box):
            attrs |= {"type": "box", "size": _v(np.asarray(part.size) * scale / 2)}
            if part.yaw:
                attrs["euler"] = _v((0, 0, part.yaw))
        elif isinstance(part, Cylinder):
            attrs |= {"type": "cylinder", "size": _v((part.radius * scale, part.height * scale / 2))}
        elif isinstance(part, Capsule) and part.length > 0:
            attrs |= {"type": "capsule", "size": _v((part.radius * scale, part.length * scale / 2))}
        else:
            attrs |= {"type": "sphere", "size": _n(part.radius * scale)}
    ET.SubElement(body, "geom", **attrs)


def _mesh_placement(b: _Builder, i: int, body: ET.Element) -> float:
    """The geoms of a placement's mesh file (one per connected part); the mesh's top (m)."""
    import trimesh

    pl = b.scene.placements[i]
    where = f"$.placements[{i}].asset"
    if b.base_dir is None:
        raise ExportError(
            f"{where}: {pl.asset!r} is a mesh file beside the scene, but the scene was given as a "
            "model: pass the scene's file, or mesh_dir= (its folder)"
        )
    base = b.base_dir.resolve()
    path = (base / pl.asset).resolve()
    if not path.is_relative_to(base) or not path.is_file():
        found = "a path leading outside it" if not path.is_relative_to(base) else "no such file"
        raise SpecError(
            [Problem(where, "a mesh file inside the scene's folder", f"{found}: {pl.asset!r}")], file=b.file
        )
    try:
        mesh = trimesh.load(path, force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise SpecError(
            [Problem(where, "a readable mesh file", f"{type(exc).__name__}: {pl.asset!r}")], file=b.file
        ) from None
    if len(mesh.faces) == 0:
        raise SpecError([Problem(where, "a mesh with triangles", f"none in {pl.asset!r}")], file=b.file)
    parts = mesh.split(only_watertight=False) if mesh.body_count > 1 else [mesh]
    if len(parts) > MAX_MESH_PARTS:
        parts = [mesh]
    concave = 0
    for k, part in enumerate(parts):
        data = _stl(part.vertices, part.faces)
        name = b.mesh_file(data, pl.scale, inertia="convex")
        mat = b.material("mesh", (0.48, 0.24, 0.62, 1.0))
        ET.SubElement(
            body, "geom", name=f"object:mesh:{pl.id}:{k}", type="mesh", mesh=name, material=mat,
            friction=_friction(DEFAULT_FRICTION),
        )  # fmt: skip
        hull = part.convex_hull
        if not (part.is_watertight and abs(part.volume) >= 0.98 * hull.volume):
            concave += 1
    if concave:
        b.warnings.append(
            f"{where}: {concave} of the {len(parts)} connected part(s) of {pl.asset!r} are not convex; "
            "MuJoCo collides each part as its convex hull (no convex decomposition)"
        )
    return float(mesh.bounds[1, 2]) * pl.scale


def _agents(b: _Builder) -> None:
    for a in b.scene.agents:
        (x, y), (gx, gy) = a.start, a.goal
        z = float(height_at(b.scene, x, y))
        yaw = math.atan2(gy - y, gx - x) if (gx, gy) != (x, y) else 0.0
        body = ET.SubElement(
            b.world, "body", name=f"agent:{a.id}", mocap="true", pos=_v((x, y, z)), euler=_v((0, 0, yaw))
        )
        attrs = {"name": f"agent:{a.kind}:{a.id}:0", "class": "agent", "rgba": _v(_AGENT_RGBA[a.kind])}
        if isinstance(a, Person):
            height = PERSON_HEIGHT[a.kind]
            half = height / 2 - a.radius
            if half > 0:
                attrs |= {"type": "capsule", "size": _v((a.radius, half)), "pos": _v((0, 0, height / 2))}
            else:
                height = 2 * a.radius
                attrs |= {"type": "sphere", "size": _n(a.radius), "pos": _v((0, 0, a.radius))}
        else:
            height = VEHICLE_HEIGHT
            attrs |= {"type": "box", "size": _v((a.length / 2, a.width / 2, height / 2))}
            attrs["pos"] = _v((0, 0, height / 2))
        ET.SubElement(body, "geom", **attrs)
        b.top = max(b.top, z + height)
        gz = float(height_at(b.scene, gx, gy))
        ET.SubElement(b.world, "site", name=f"agent:{a.id}:goal", pos=_v((gx, gy, gz)), size="0.1", group="4")
        b.custom("numeric", f"agent:{a.id}:speed", _n(a.speed))
        if getattr(a, "route", ()):
            b.custom("text", f"agent:{a.id}:route", " ".join(a.route))


def _signals(b: _Builder) -> None:
    """Per signal head a site ``signal:<id>:head:<k>`` where the light hangs (facing the
    traffic it signals); per phase a hidden site ``signal:<id>:<phase>`` over the junction
    and custom entries ``signal:<id>:<phase>:times`` (green, amber, red: s),
    ``signal:<id>:<phase>:lanes`` and ``:crosswalks`` (text), ``signal:<id>:plan`` (cycle,
    offset: s)."""
    for s in b.scene.signals or ():
        heads = [h.position for h in s.heads]
        for k, h in enumerate(s.heads):
            z = float(height_at(b.scene, *h.position))
            ET.SubElement(
                b.world, "site", name=f"signal:{s.id}:head:{k}", type="box", size="0.15 0.15 0.4",
                pos=_v((*h.position, z + SIGNAL_HEIGHT)), euler=_v((0, 0, h.yaw)), rgba="0.1 0.1 0.1 1",
            )  # fmt: skip
        cx, cy = np.mean(heads, axis=0) if heads else (0.0, 0.0)
        for phase in s.phases:
            name = f"signal:{s.id}:{phase.id}"
            ET.SubElement(b.world, "site", name=name, pos=_v((cx, cy, SIGNAL_HEIGHT)), size="0.1", group="4")
            b.custom("numeric", f"{name}:times", _v((phase.green, phase.amber, phase.red)))
            if phase.lanes:
                b.custom("text", f"{name}:lanes", " ".join(phase.lanes))
            if phase.crosswalks:
                b.custom("text", f"{name}:crosswalks", " ".join(phase.crosswalks))
        b.custom("numeric", f"signal:{s.id}:plan", _v((s.cycle, s.offset)))


def _task(b: _Builder) -> None:
    task = b.scene.task
    if task is None:
        return
    (x, y), yaw = task.start.position, task.start.yaw
    z = float(height_at(b.scene, x, y))
    b.custom("text", "task:kind", task.kind)
    b.custom("text", "task:robot", task.robot)
    b.custom("numeric", "task:time_limit", _n(task.time_limit))
    if isinstance(task, LocoTask):
        b.custom("numeric", "task:command", _v(task.command))
    ET.SubElement(
        b.world, "site", name="task:start", type="sphere", size="0.15", pos=_v((x, y, z + 0.15)),
        euler=_v((0, 0, yaw)), rgba=_v(_START_RGBA),
    )  # fmt: skip
    points: list[tuple[str, tuple[float, float], float]] = []
    if isinstance(task, NavTask):
        points.append(("task:goal", task.goal, task.goal_tolerance))
    elif isinstance(task, TraverseTask):
        points += [(f"task:waypoint:{k}", p, task.goal_tolerance) for k, p in enumerate(task.route)]
        points.append(("task:goal", task.route[-1], task.goal_tolerance))
    for name, (px, py), tol in points:
        pz = float(height_at(b.scene, px, py))
        ET.SubElement(
            b.world, "site", name=name, type="cylinder", size=_v((tol, 0.01)), pos=_v((px, py, pz + 0.01)),
            rgba=_v(_GOAL_RGBA),
        )  # fmt: skip


def _extent(b: _Builder) -> tuple[np.ndarray, float, float]:
    """The scene's centre (m), the larger side of its rectangle (m) and its height span (m)."""
    scene, terrain = b.scene, b.scene.terrain
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    top, bottom = b.top, b.bottom
    if terrain is not None:
        s = terrain.tile_size
        ox, oy = terrain.origin
        x0, y0 = min(x0, ox), min(y0, oy)
        x1, y1 = max(x1, ox + terrain.cols * s), max(y1, oy + terrain.rows * s)
        for t in terrain.tiles:
            amp = t.amplitude if isinstance(t, RoughTile) else 0.0
            top = max(top, t.height + rise(t, s) + max(0.0, peak(t, s)) + amp)
            bottom = min(bottom, t.height + min(0.0, peak(t, s)) - amp)
    centre = np.array([(x0 + x1) / 2, (y0 + y1) / 2, (top + bottom) / 2])
    return centre, max(x1 - x0, y1 - y0), top - bottom


def _cameras(b: _Builder, visual: ET.Element) -> None:
    centre, side, span = _extent(b)
    cx, cy, cz = centre
    fovy = 45.0
    if 1.05 * side < MAX_ORTHOGRAPHIC:
        top = {
            "projection": "orthographic",
            "fovy": _n(1.05 * side),
            "pos": _v((cx, cy, cz + span / 2 + side)),
        }
    else:  # MuJoCo caps fovy, also an orthographic one's (in metres), below 180
        height = 1.05 * side / 2 / math.tan(math.radians(fovy) / 2)
        top = {"fovy": _n(fovy), "pos": _v((cx, cy, cz + span / 2 + height))}
    ET.SubElement(b.world, "camera", name="top", **top)
    diag = math.hypot(side, span)
    dist = 0.6 * diag / math.tan(math.radians(fovy) / 2)
    az, el = math.radians(-125.0), math.radians(38.0)
    forward = -np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])
    right = np.cross(forward, (0.0, 0.0, 1.0))
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    ET.SubElement(
        b.world, "camera", name="perspective", fovy=_n(fovy), pos=_v(centre - dist * forward),
        xyaxes=_v(np.concatenate([right, up])),
    )  # fmt: skip
    ET.SubElement(visual, "map", znear="0.01", zfar="50")
    ET.SubElement(b.root, "statistic", center=_v(centre), extent=_n(max(diag / 2, 1.0)))


def _build(b: _Builder, name: str) -> MJCF:
    b.root = root = ET.Element("mujoco", model=name)
    ET.SubElement(root, "compiler", angle="radian", autolimits="true")
    size = ET.SubElement(root, "size")
    visual = ET.SubElement(root, "visual")
    ET.SubElement(visual, "global", offwidth=str(OFFSCREEN[0]), offheight=str(OFFSCREEN[1]))
    ET.SubElement(visual, "headlight", ambient="0.3 0.3 0.3", diffuse="0.3 0.3 0.3", specular="0 0 0")
    default = ET.SubElement(root, "default")
    ET.SubElement(default, "material", specular="0.05", shininess="0.1")
    static = ET.SubElement(default, "default", **{"class": "static"})
    ET.SubElement(static, "geom", contype=str(STATIC_BIT), conaffinity="0", priority="1", group="0")
    agent = ET.SubElement(default, "default", **{"class": "agent"})
    ET.SubElement(agent, "geom", contype=str(AGENT_BIT), conaffinity="0", group="2")
    obj = ET.SubElement(default, "default", **{"class": "object"})
    ET.SubElement(obj, "geom", contype=str(STATIC_BIT), conaffinity="0", priority="1", group="1")
    b.asset = ET.SubElement(root, "asset")
    ET.SubElement(
        b.asset, "texture", name="sky", type="skybox", builtin="gradient", rgb1="0.55 0.7 0.88",
        rgb2="0.95 0.97 1", width="64", height="64",
    )  # fmt: skip
    b.world = ET.SubElement(root, "worldbody")
    _ground(b)
    _objects(b)
    _agents(b)
    _signals(b)
    _task(b)
    centre, side, span = _extent(b)
    ET.SubElement(
        b.world, "light", name="sun", type="directional", castshadow="false", dir="0.35 0.45 -1",
        pos=_v(centre + np.array([0.0, 0.0, span + side])), diffuse="0.45 0.45 0.45", specular="0 0 0",
    )  # fmt: skip
    _cameras(b, visual)
    size.set("memory", f"{arena_mb(sum(1 for _ in b.world.iter('geom')))}M")
    if b.customs is not None:
        root.append(b.customs)
    # The statistic element belongs before the worldbody for people reading the file.
    stat = root.find("statistic")
    root.remove(stat)
    root.insert(list(root).index(b.asset), stat)
    ET.indent(root, space="  ")
    xml = ET.tostring(root, encoding="unicode") + "\n"
    return MJCF(xml, MappingProxyType(dict(sorted(b.files.items()))))


# --- public API ----------------------------------------------------------------------


def arena_mb(ngeom: int) -> int:
    """The ``<size memory>`` (MiB) of a model with ``ngeom`` geoms: MuJoCo's broadphase
    takes about 700 bytes a geom of the arena at every step on a 62,000-geom city, and
    one ~148 MB block on the 0.3.0 city (115,000 geoms) on top of ~150 MB in use, contacts
    and constraints a few MiB; :data:`ARENA_PER_GEOM` a geom and
    :data:`ARENA_BASE_MB` leave room for a robot's contacts with heightfields."""
    return ARENA_BASE_MB + math.ceil(ngeom * ARENA_PER_GEOM / (1 << 20))


def _check_options(options: Mapping[str, object]) -> dict[str, Any]:
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise ExportError(
            f"mjcf export: unknown option {unknown[0]!r}; expected one of {', '.join(_OPTIONS)}"
        )
    out: dict[str, Any] = {}
    for key, default, low in (("resolution", None, 0.005), ("apron", DEFAULT_APRON, 0.0)):
        value = options.get(key, default)
        if value is None and key == "resolution":
            out[key] = None
            continue
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise ExportError(f"mjcf export: {key}: expected a number of metres, got {value!r}")
        if value < low or (key == "resolution" and value == 0):
            raise ExportError(f"mjcf export: {key}: expected at least {low:g} m, got {value!r}")
        out[key] = float(value)
    mesh_dir = options.get("mesh_dir")
    if mesh_dir is not None and not isinstance(mesh_dir, str | Path):
        raise ExportError(f"mjcf export: mesh_dir: expected a folder path, got {mesh_dir!r}")
    out["mesh_dir"] = None if mesh_dir is None else Path(mesh_dir)
    return out


def scene_name(scene: Scene | str | Path, name: object = None) -> str:
    """The file name stem for a scene (:func:`citygen.exporters.output_name`)."""
    return output_name(scene, name, "mjcf")


def to_mjcf(scene: Scene | str | Path, **options: object) -> MJCF:
    """The scene as MJCF text and the mesh files it names, in memory.

    Options: ``name`` (the model's name, see :func:`scene_name`), ``resolution``
    (largest heightfield sample spacing in m; default None: 0.1, or coarser with one
    warning where the scene's heightfields would exceed ``lod.BUDGETS["mjcf"]`` samples),
    ``apron`` (width in m of the flat ground around the scene, default 20; 0 for none),
    ``mesh_dir`` (the folder mesh paths are relative to, for a scene given as a model).
    Anything the format cannot express is reported as an :class:`~citygen.exporters.ExportWarning`.
    """
    opts = _check_options(options)
    model, base = as_scene(scene)
    file = None if isinstance(scene, Scene) else str(scene)
    b = _Builder(model, file, opts["mesh_dir"] or base, opts["resolution"], opts["apron"])
    out = _build(b, scene_name(scene, options.get("name")))
    for message in b.warnings:
        warnings.warn(ExportWarning(message), stacklevel=2)
    return out


def to_xml(scene: Scene | str | Path, **options: object) -> str:
    """The scene as MJCF text (see :func:`to_mjcf` for the options); mesh files it names
    are in ``to_mjcf(...).assets``."""
    return to_mjcf(scene, **options).xml


def import_mujoco() -> Any:
    """``import mujoco``, first choosing a headless OpenGL backend for its renderer when
    nobody did: on Linux with ``MUJOCO_GL`` unset and mujoco not yet imported, it is set
    to ``egl`` when libEGL is installed, else to ``osmesa`` when libOSMesa is."""
    if "mujoco" not in sys.modules and not os.environ.get("MUJOCO_GL") and sys.platform.startswith("linux"):
        backend = "egl" if find_library("EGL") else "osmesa" if find_library("OSMesa") else None
        if backend is not None:
            os.environ["MUJOCO_GL"] = backend
    try:
        import mujoco
    except ImportError:
        raise DependencyMissing("mujoco", "compiling MJCF") from None
    return mujoco


def build(scene: Scene | str | Path, **options: object) -> mujoco.MjModel:
    """The scene compiled into a ``mujoco.MjModel`` without writing files (options as
    :func:`to_mjcf`). Raises :class:`~citygen.errors.ExportError` if MuJoCo rejects it."""
    mujoco = import_mujoco()
    mj = to_mjcf(scene, **options)
    try:
        return mujoco.MjModel.from_xml_string(mj.xml, dict(mj.assets))
    except ValueError as exc:
        raise ExportError(f"MuJoCo rejected the exported model: {exc}") from None


def export(scene: Scene | str | Path, out_dir: str | Path, **options: object) -> list[Path]:
    """Write ``<out_dir>/<name>.xml`` and its mesh files under ``<out_dir>/assets/`` (each
    named by its content digest, written once per folder, shared between scenes);
    returns the XML path then the asset paths. Options as :func:`to_mjcf`.

    The XML loads with ``mujoco.MjModel.from_xml_path``.
    """
    mj = to_mjcf(scene, **options)
    out = Path(out_dir)
    written = []
    try:
        for rel, data in mj.assets.items():
            path = shared_file(out, data, ".stl")
            if path != out / rel:
                raise ExportError(f"mjcf export: asset {rel} was written as {path}")
            written.append(path)
        xml_path = out / f"{scene_name(scene, options.get('name'))}.xml"
        write_atomic(xml_path, mj.xml.encode("utf-8"))
    except OSError as exc:
        raise ExportError(
            f"{out}: cannot write the MJCF files: {exc.strerror or type(exc).__name__}"
        ) from None
    return [xml_path, *written]


def geom_labels(model: mujoco.MjModel) -> list[tuple[str, str, str] | None]:
    """``(layer, class, id)`` of every geom by geom id (``("object", "bench", "bench-1")``),
    parsed from the names this exporter gives; None for a geom it did not name (a robot's).
    A runner maps a contact's ``geom1``/``geom2`` to a semantic class with it."""
    out: list[tuple[str, str, str] | None] = []
    for gid in range(model.ngeom):
        parts = model.geom(gid).name.split(SEP, 2)  # layer, class, "<id>:<k>" (an id may hold a ':')
        if len(parts) == 3 and parts[0] in LAYERS and SEP in parts[2]:
            out.append((parts[0], parts[1], parts[2].rsplit(SEP, 1)[0]))
        else:
            out.append(None)
    return out
