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
  every tile edge is exact and meets its neighbour; with ``terrain="convex"`` (for readers
  without heightfields) they are convex pieces instead, exact for slopes, within
  ``tolerance`` of ``height_at`` for rough tiles (:mod:`citygen.geometry.pieces`: geoms
  ``terrain:<kind>:<row>_<col>:<k>``, prisms' meshes ``terrain:mesh:<n>``); with
  ``terrain="hybrid"`` (the runner's) slopes are convex prisms and rough tiles heightfields
  with stiffer contacts (``solref`` time constant
  :data:`~citygen.exporters.mjcf.heightfield.HYBRID_HFIELD_TIMECONST`). MuJoCo's collisions of
  small spheres and capsules (a robot's feet and shins) with a heightfield's prisms give
  contact normals that lie flat once a foot sinks a centimetre, which holds a walking foot
  in place: on a heightfield a quadruped's walk goes nowhere where on boxes or prisms it
  walks, and on the stiffer heightfield it walks. A non-level
  tile has one friction: its own (``friction`` or ``material``),
  else that of the zone covering most of it, else :data:`DEFAULT_FRICTION`; where zones
  of different friction share such a tile an :class:`ExportWarning` says so.
- **Objects.** One static body per placement (``object:<id>``) whose geoms are the
  asset's convex parts: MuJoCo boxes, cylinders, capsules and spheres where the part is
  one, convex meshes (``assets/<digest>.stl``, written once per dataset folder)
  otherwise. A placement's mesh file (relative to the scene file) is split into its
  connected parts, each a mesh geom; MuJoCo collides a mesh as its convex hull, so an
  :class:`ExportWarning` names every placement with a non-convex part.
- **Solids.** A zone with a ``height`` (a building from its mapped footprint) is a solid
  (:mod:`citygen.exporters.solids`): its polygon, holes cut out, from the lowest ground under
  it up that height, cut into convex pieces (boxes where a piece is a rectangle, convex mesh
  prisms otherwise), so a courtyard or an L's inner corner stays open ground; static geoms
  ``solid:<zone kind>:<zone id>:<k>`` of the object class (group 1), with the zone's friction.
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
Geom groups: 0 ground and terrain, 1 objects and solids, 2 agents (so a ray or a rendering can
select them: ``mj_ray(..., geomgroup=[1, 0, 0, 0, 0, 0], ...)`` sees only the ground).

Names (the runner may rely on them; they are a public contract, the naming table of docs/exporting.md):
the parts of every name are joined by ``:`` (:data:`SEP`), never ``/``, which dm_control's
``mjcf`` reserves for the scopes of attached models. Every geom is
``<layer>:<class>:<id>:<k>`` (an id may itself hold a ``:``; layer, class and k never do):
``zone:<zone kind>:<zone id>:<k>`` (``zone:none:ground:<k>`` for ground no zone covers,
``zone:none:outside:<k>`` for the apron), ``terrain:<tile kind>:<row>_<col>:<k>``,
``object:<semantic class>:<placement id>:<k>`` (``object:mesh:...`` for mesh files),
``solid:<zone kind>:<zone id>:<k>`` (meshes ``solid:<zone id>:<k>``),
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

import math
import warnings
from collections.abc import Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from citygen.errors import ExportError
from citygen.exporters import ExportWarning, as_scene, output_name, shared_file
from citygen.exporters.mjcf.assemble import (
    MAX_ORTHOGRAPHIC,
    OFFSCREEN,
    PERSON_HEIGHT,
    SIGNAL_HEIGHT,
    VEHICLE_HEIGHT,
    assemble,
    assemble_tree,
)
from citygen.exporters.mjcf.builder import DEFAULT_FRICTION, FLOOR, ZONE_RGBA, Builder, asset_name
from citygen.exporters.mjcf.contract import (
    AGENT_BIT,
    ARENA_BASE_MB,
    ARENA_PER_GEOM,
    LAYERS,
    MJCF,
    ROBOT_BIT,
    ROBOT_CONAFFINITY,
    SEP,
    STATIC_BIT,
    MJCFTree,
    arena_mb,
    geom_labels,
    import_mujoco,
)
from citygen.exporters.mjcf.ground import DEFAULT_APRON
from citygen.exporters.mjcf.heightfield import (
    DEFAULT_RESOLUTION,
    HFIELD_BASE,
    HFIELD_UNIT,
    MAX_HFIELD_SAMPLES,
    MAX_HFIELD_SIDE,
)
from citygen.exporters.mjcf.objects import MAX_MESH_PARTS
from citygen.exporters.pieces import PIECE_BUDGETS, tolerance_option
from citygen.geometry.convex import convex_pieces
from citygen.io import write_atomic
from citygen.spec.scene import Scene

if TYPE_CHECKING:
    import mujoco

_OPTIONS = ("name", "resolution", "apron", "mesh_dir", "terrain", "tolerance")
#: The ``terrain`` option's values: slope and rough tiles as heightfields (MuJoCo), as
#: convex pieces (readers without heightfields, such as Genesis), or slopes as convex pieces
#: (exact, five prisms a tile) and rough tiles as heightfields (the runner's: see the module
#: docstring, "Terrain").
TERRAINS = ("heightfield", "convex", "hybrid")


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
    out["terrain"] = options.get("terrain", "heightfield")
    if out["terrain"] not in TERRAINS:
        raise ExportError(
            f"mjcf export: terrain: expected one of {', '.join(TERRAINS)}, got {out['terrain']!r}"
        )
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
    ``mesh_dir`` (the folder mesh paths are relative to, for a scene given as a model),
    ``terrain`` (``"heightfield"``, the default: slope and rough tiles as heightfields;
    ``"convex"``: as convex pieces, :mod:`citygen.geometry.pieces`, for readers without
    heightfields such as Genesis; ``"hybrid"``: slopes as convex pieces, rough tiles as
    heightfields, what the runner simulates), ``tolerance`` (m, how far a convex rough tile's pieces may
    lie from ``height_at``; default 0.01, coarser with one warning where the pieces would
    exceed ``pieces.PIECE_BUDGETS["mjcf"]``).
    Anything the format cannot express is reported as an :class:`~citygen.exporters.ExportWarning`.
    """
    return _build(scene, options, assemble)


def to_tree(scene: Scene | str | Path, **options: object) -> MJCFTree:
    """:func:`to_mjcf`'s model (the same options) for a reader in this process, such as the
    runner: the XML as an element tree and its heightfields as binary files
    (:class:`~citygen.exporters.mjcf.contract.MJCFTree`), the same model once compiled,
    without the text a file needs (on a 1.2 km city 100 MB, 70 of them heightfields)."""
    return _build(scene, options, assemble_tree)


def _build(scene: Scene | str | Path, options: Mapping[str, object], assembler: Any) -> Any:
    opts = _check_options(options)
    model, base = as_scene(scene)
    file = None if isinstance(scene, Scene) else str(scene)
    b = Builder(model, file, opts["mesh_dir"] or base, opts["resolution"], opts["apron"], opts["terrain"])
    if b.terrain == "convex" and model.terrain is not None:
        b.tolerance = tolerance_option(options.get("tolerance"), model, "mjcf", PIECE_BUDGETS["mjcf"])
    out = assembler(b, scene_name(scene, options.get("name")))
    for message in b.warnings:
        warnings.warn(ExportWarning(message), stacklevel=3)
    return out


def to_xml(scene: Scene | str | Path, **options: object) -> str:
    """The scene as MJCF text (see :func:`to_mjcf` for the options); mesh files it names
    are in ``to_mjcf(...).assets``."""
    return to_mjcf(scene, **options).xml


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


__all__ = [
    "AGENT_BIT",
    "ARENA_BASE_MB",
    "ARENA_PER_GEOM",
    "DEFAULT_APRON",
    "DEFAULT_FRICTION",
    "DEFAULT_RESOLUTION",
    "FLOOR",
    "HFIELD_BASE",
    "HFIELD_UNIT",
    "LAYERS",
    "MAX_HFIELD_SAMPLES",
    "MAX_HFIELD_SIDE",
    "MAX_MESH_PARTS",
    "MAX_ORTHOGRAPHIC",
    "MJCF",
    "OFFSCREEN",
    "PERSON_HEIGHT",
    "ROBOT_BIT",
    "ROBOT_CONAFFINITY",
    "SEP",
    "SIGNAL_HEIGHT",
    "STATIC_BIT",
    "TERRAINS",
    "VEHICLE_HEIGHT",
    "ZONE_RGBA",
    "MJCFTree",
    "arena_mb",
    "asset_name",
    "build",
    "convex_pieces",
    "export",
    "geom_labels",
    "import_mujoco",
    "scene_name",
    "to_mjcf",
    "to_tree",
    "to_xml",
]
