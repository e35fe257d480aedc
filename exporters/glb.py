"""GLB: the whole scene as one glTF 2.0 binary, for Blender, three.js and any glTF viewer.

One scene graph holds

- ``ground/terrain``: the terrain's tiles as one closed solid (:func:`terrain_mesh`, rough
  tiles meshed every :data:`RESOLUTION` metres by default), each face in the colour of the
  zone over it;
- ``ground/plane``: the flat ground at ``z = 0`` over the scene's bounds outside the
  terrain grid;
- ``zone/<id>``: each zone's ground surface, draped on the terrain and coloured by kind
  (:data:`~citygen.exporters.ZONE_COLORS`), lifted :data:`ZONE_LIFT` above it;
- ``<id>``: each placement, the asset's visual mesh (one mesh per asset, reused by every
  node that places it: glTF instancing) moved, turned and scaled by the node;
- ``agent/<id>`` and ``agent/<id>/goal``: people as cylinders of their radius, vehicles as
  boxes along their way, coloured by kind, and a disc at each goal;
- ``task/start`` (an arrow along the start yaw), ``task/goal`` (a disc of the goal
  tolerance) and ``task/route/<k>`` (a traverse's waypoints).

Only placement nodes are named by bare ids; every other name holds a ``/``, which ids
cannot, so names never clash. Everything hangs under one node, ``scene/root``, which turns
citygen's Z-up frame into glTF's Y-up (``y_up=False`` leaves it Z-up). Colours are vertex
colours, exact per face. Units are metres. The scene's ``extras`` keep what geometry cannot
say (agents' speeds, the task's kind, time limit and command) as the spec's own JSON, so
nothing is lost. The same scene always gives the same bytes.

>>> from citygen.exporters import glb
>>> graph = glb.build("examples/street_corner.json")
>>> "zone/crosswalk" in graph.graph.nodes and "lamp-1" in graph.graph.nodes
True
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any

from citygen.exporters.ground import (
    MAX_TERRAIN_TRIANGLES,
    RESOLUTION,
    ZONE_LIFT,
    auto_terrain,
    drape,
    fit_terrain,
    grid_box,
    ground_plane,
    polygon_parts,
    rough_cells,
    terrain_solid,
    tile_owners,
    triangulate,
    zone_polygons,
)
from citygen.exporters.meshes import (
    GROUND_RGBA,
    MESH_RGBA,
    RGBA,
    TERRAIN_RGBA,
    catalog_asset,
    colour_groups,
    file_mesh,
    flat_coloured,
    load_mesh_file,
    mesh_file,
    placement_matrix,
    rgba,
    submesh,
    vertex_coloured,
    zone_rgba,
)
from citygen.exporters.options import AUTO, check_options, output_name, resolution_option, scene_dir_of
from citygen.exporters.scene_graph import (
    AGENT_COLORS,
    AGENT_HEIGHT,
    GOAL_COLOR,
    MARKER_THICKNESS,
    ROOT,
    START_COLOR,
    Z_UP_TO_Y_UP,
    build,
)
from citygen.io import write_atomic
from citygen.spec.scene import Scene

_OPTIONS = ("name", "scene_dir", "resolution", "y_up")


#: glTF ``bufferView.target`` values: vertex attributes and indices.
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


def with_targets(glb: bytes) -> bytes:
    """A GLB with ``target`` set on every buffer view its meshes read (``ARRAY_BUFFER`` for
    vertex attributes, ``ELEMENT_ARRAY_BUFFER`` for indices), which trimesh leaves out and
    the Khronos validator hints at; the binary chunk is unchanged."""
    magic, version, _ = struct.unpack_from("<4sII", glb, 0)
    length, kind = struct.unpack_from("<I4s", glb, 12)
    if magic != b"glTF" or kind != b"JSON":
        return glb
    doc = json.loads(glb[20 : 20 + length])
    views, accessors = doc.get("bufferViews", []), doc.get("accessors", [])
    for mesh in doc.get("meshes", []):
        for prim in mesh.get("primitives", []):
            uses = [(a, ARRAY_BUFFER) for a in prim.get("attributes", {}).values()]
            if "indices" in prim:
                uses.append((prim["indices"], ELEMENT_ARRAY_BUFFER))
            for accessor, target in uses:
                view = accessors[accessor].get("bufferView")
                if view is not None:
                    views[view]["target"] = target
    text = json.dumps(doc, separators=(",", ":")).encode("utf-8")
    text += b" " * (-len(text) % 4)
    rest = glb[20 + length :]
    header = struct.pack("<4sII", magic, version, 12 + 8 + len(text) + len(rest))
    return header + struct.pack("<I4s", len(text), b"JSON") + text + rest


def to_bytes(scene: Scene | str | Path, **options: Any) -> bytes:
    """The GLB file's bytes (options as :func:`build`), every buffer view's ``target`` set."""
    return with_targets(build(scene, **options).export(file_type="glb"))


def export(scene: Scene | str | Path, out_dir: str | Path, **options: Any) -> list[Path]:
    """Write ``<out_dir>/<name>.glb``; returns ``[that path]``.

    Options: ``name`` (default: the scene file's stem, ``<split>-<index>`` or ``scene``),
    ``scene_dir``, ``resolution`` (m, default :data:`AUTO`) and ``y_up`` (see :func:`build`).
    """
    check_options(options, _OPTIONS, "glb")
    name = output_name(scene, options, "glb")
    data = to_bytes(scene, **{k: v for k, v in options.items() if k != "name"})
    path = Path(out_dir) / f"{name}.glb"
    write_atomic(path, data)
    return [path]


# The scene-to-mesh kernel this module was written around now lives in options, meshes, ground
# and scene_graph; its names stay importable from here.
__all__ = [
    "AGENT_COLORS",
    "AGENT_HEIGHT",
    "ARRAY_BUFFER",
    "AUTO",
    "ELEMENT_ARRAY_BUFFER",
    "GOAL_COLOR",
    "GROUND_RGBA",
    "MARKER_THICKNESS",
    "MAX_TERRAIN_TRIANGLES",
    "MESH_RGBA",
    "RESOLUTION",
    "RGBA",
    "ROOT",
    "START_COLOR",
    "TERRAIN_RGBA",
    "ZONE_LIFT",
    "Z_UP_TO_Y_UP",
    "auto_terrain",
    "build",
    "catalog_asset",
    "check_options",
    "colour_groups",
    "drape",
    "export",
    "file_mesh",
    "fit_terrain",
    "flat_coloured",
    "grid_box",
    "ground_plane",
    "load_mesh_file",
    "mesh_file",
    "output_name",
    "placement_matrix",
    "polygon_parts",
    "resolution_option",
    "rgba",
    "rough_cells",
    "scene_dir_of",
    "submesh",
    "terrain_solid",
    "tile_owners",
    "to_bytes",
    "triangulate",
    "vertex_coloured",
    "with_targets",
    "zone_polygons",
    "zone_rgba",
]
