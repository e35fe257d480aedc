"""Placed objects in MJCF: one static body per placement whose geoms are its asset's convex
parts (MuJoCo primitives where a part is one, convex meshes otherwise), or a placement's
mesh file split into its connected parts; and the zones' solids (a building from its
footprint, :mod:`citygen.exporters.solids`) as their convex pieces."""

from __future__ import annotations

import functools
import struct
import xml.etree.ElementTree as ET
from typing import Any

import numpy as np

from citygen.assets import Box, Capsule, ConvexMesh, Cylinder, UnknownAsset, resolve
from citygen.errors import ExportError, Problem, SpecError
from citygen.exporters.mjcf.builder import DEFAULT_FRICTION, ZONE_RGBA, Builder, friction
from citygen.exporters.mjcf.text import num, nums
from citygen.exporters.solids import solids
from citygen.geometry.pieces import prism_mesh, rpy_quat
from citygen.spec.surfaces import FRICTION

#: A mesh file with more connected parts than this is one mesh geom (one convex hull).
MAX_MESH_PARTS = 64


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


def _look_material(b: Builder, look: Any) -> str:
    r, g, bl, a = (round(c * 255) for c in look.rgba)
    return b.material(f"look:{look.name}:{r:02x}{g:02x}{bl:02x}{a:02x}", look.rgba)


def add_objects(b: Builder) -> None:
    for i, pl in enumerate(b.scene.placements):
        x, y, z = pl.position
        attrs = {"name": f"object:{pl.id}", "childclass": "object", "pos": nums((x, y, z))}
        if pl.yaw:
            attrs["euler"] = nums((0, 0, pl.yaw))
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


def add_solids(b: Builder) -> None:
    """Each zone's solid as its convex pieces (MuJoCo collides a mesh as its convex hull, so an
    L-shaped or courtyard building is cut into convex prisms and boxes): static geoms
    ``solid:<zone kind>:<zone id>:<k>`` of the object class (group 1), meshes
    ``solid:<zone id>:<k>``, with the zone's colour and friction."""
    for solid in solids(b.scene):
        zone = solid.zone
        pieces = solid.pieces()
        common = {
            "class": "object",
            "material": b.material(f"zone:{zone.kind}", ZONE_RGBA[zone.kind]),
            "friction": friction(zone.mu),
        }
        prefix = f"solid:{zone.kind}:{zone.id}"
        quats = rpy_quat(pieces.boxes[:, 2])
        for k, ((centre, half, _), quat) in enumerate(zip(pieces.boxes, quats, strict=True)):
            ET.SubElement(
                b.world, "geom", name=f"{prefix}:{k}", type="box", pos=nums(centre), size=nums(half),
                quat=nums(quat), **common,
            )  # fmt: skip
        for k, top in enumerate(pieces.prisms, start=len(pieces.boxes)):
            mesh = f"solid:{zone.id}:{k}"
            ET.SubElement(b.asset, "mesh", name=mesh, vertex=nums(prism_mesh(top, pieces.bottom)[0]))
            ET.SubElement(b.world, "geom", name=f"{prefix}:{k}", type="mesh", mesh=mesh, **common)
        b.top = max(b.top, solid.top)
        b.bottom = min(b.bottom, solid.bottom)


def _part(b: Builder, body: ET.Element, name: str, part: Any, scale: float) -> None:
    look = part.material
    mu = FRICTION.get(look.name, DEFAULT_FRICTION)
    attrs = {"name": name, "material": _look_material(b, look), "friction": friction(mu)}
    if isinstance(part, ConvexMesh):
        attrs |= {"type": "mesh", "mesh": b.mesh_file(_part_stl(part), scale)}
    else:
        attrs["pos"] = nums(np.asarray(part.pos) * scale)
        if isinstance(part, Box):
            attrs |= {"type": "box", "size": nums(np.asarray(part.size) * scale / 2)}
            if part.yaw:
                attrs["euler"] = nums((0, 0, part.yaw))
        elif isinstance(part, Cylinder):
            attrs |= {"type": "cylinder", "size": nums((part.radius * scale, part.height * scale / 2))}
        elif isinstance(part, Capsule) and part.length > 0:
            attrs |= {"type": "capsule", "size": nums((part.radius * scale, part.length * scale / 2))}
        else:
            attrs |= {"type": "sphere", "size": num(part.radius * scale)}
    ET.SubElement(body, "geom", **attrs)


def _mesh_placement(b: Builder, i: int, body: ET.Element) -> float:
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
            friction=friction(DEFAULT_FRICTION),
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
