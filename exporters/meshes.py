"""Meshes of a scene's things for the mesh exporters (GLB, HTML, URDF, the occupancy map):
colours, a placement's catalog asset or mesh file, triangle meshes with exact face or vertex
colours, and a placement's transform.

trimesh is imported only where a mesh is made: the occupancy map and the runner use the
helpers here that need none."""

from __future__ import annotations

import math
import warnings
from collections.abc import Sequence
from pathlib import Path, PurePosixPath
from typing import TYPE_CHECKING

import numpy as np

from citygen.assets import Asset, UnknownAsset, resolve
from citygen.errors import ExportError
from citygen.exporters import ZONE_COLORS, ExportWarning
from citygen.spec.placements import Placement

if TYPE_CHECKING:
    import trimesh

RGBA = tuple[float, float, float, float]

#: Colour of the terrain solid and of the flat ground outside it (RGBA in [0, 1]).
TERRAIN_RGBA: RGBA = (0.66, 0.62, 0.57, 1.0)
GROUND_RGBA: RGBA = (0.957, 0.945, 0.918, 1.0)
#: Colour of objects read from mesh files that carry no colours of their own.
MESH_RGBA: RGBA = (0.478, 0.243, 0.616, 1.0)


def rgba(colour: str | Sequence[float]) -> RGBA:
    """A ``#rrggbb`` colour (or RGBA numbers) as an RGBA tuple in [0, 1]."""
    if isinstance(colour, str):
        h = colour.lstrip("#")
        return (int(h[0:2], 16) / 255, int(h[2:4], 16) / 255, int(h[4:6], 16) / 255, 1.0)
    return tuple(float(c) for c in colour)  # type: ignore[return-value]


def zone_rgba(kind: str) -> RGBA:
    """The colour of a zone kind, the PNG map's palette."""

    return rgba(ZONE_COLORS[kind])


def mesh_file(placement: Placement, index: int, scene_dir: Path | None) -> Path:
    """The file of a mesh placement, checked to lie inside the scene's folder."""
    where = f"$.placements[{index}].asset"
    if scene_dir is None:
        raise ExportError(
            f"{where}: the mesh {placement.asset!r} is relative to the scene file's folder; export the "
            "scene from its file or pass the option scene_dir"
        )
    rel = PurePosixPath(placement.asset)
    base = Path(scene_dir).resolve()
    path = (base / rel).resolve()
    if rel.is_absolute() or placement.asset.startswith("~") or not path.is_relative_to(base):
        raise ExportError(f"{where}: expected a path inside the scene's folder, got {placement.asset!r}")
    if not path.is_file():
        raise ExportError(f"{where}: expected an existing mesh file, got no file {placement.asset!r}")
    return path


def load_mesh_file(placement: Placement, index: int, scene_dir: Path | None) -> trimesh.Trimesh:
    """A mesh placement's geometry in its own frame (m), before the placement's transform."""
    import trimesh

    path = mesh_file(placement, index, scene_dir)
    try:
        mesh = trimesh.load(path, force="mesh", process=False)
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise ExportError(f"$.placements[{index}].asset: cannot read {placement.asset!r}: {exc}") from None
    if not isinstance(mesh, trimesh.Trimesh) or len(mesh.faces) == 0:
        raise ExportError(f"$.placements[{index}].asset: expected a mesh with faces in {placement.asset!r}")
    return mesh


def flat_coloured(vertices: np.ndarray, faces: np.ndarray, colour: RGBA) -> trimesh.Trimesh:
    """A mesh of one colour (vertex colours, 8 bits per channel)."""
    import trimesh

    mesh = trimesh.Trimesh(np.asarray(vertices, dtype=np.float64), np.asarray(faces, np.int64), process=False)
    c = np.round(np.asarray(colour) * 255).astype(np.uint8)
    mesh.visual = trimesh.visual.ColorVisuals(mesh, vertex_colors=np.tile(c, (len(mesh.vertices), 1)))
    return mesh


def colour_groups(mesh: trimesh.Trimesh) -> list[tuple[tuple[int, ...], np.ndarray]]:
    """The mesh's faces grouped by face colour: ``[(rgba bytes, face indices), ...]`` in
    the order each colour first appears."""
    colours = np.asarray(mesh.visual.face_colors, dtype=np.uint8)
    _, first, inverse = np.unique(colours, axis=0, return_index=True, return_inverse=True)
    inverse = inverse.ravel()
    by_colour = np.argsort(inverse, kind="stable")
    groups = np.split(by_colour, np.flatnonzero(np.diff(inverse[by_colour])) + 1)
    order = np.argsort(first, kind="stable")
    return [(tuple(int(c) for c in colours[first[g]]), groups[g]) for g in order.tolist()]


def submesh(mesh: trimesh.Trimesh, faces: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Vertices and faces of the given faces of ``mesh``, keeping only the vertices they use."""
    used, inverse = np.unique(mesh.faces[faces].ravel(), return_inverse=True)
    return np.asarray(mesh.vertices)[used], inverse.reshape(-1, 3)


def vertex_coloured(mesh: trimesh.Trimesh) -> trimesh.Trimesh:
    """The mesh with its face colours as exact vertex colours: vertices are split where
    faces of different colours meet (glTF and WebGL colour vertices, not faces)."""
    import trimesh

    parts_v, parts_f, parts_c, count = [], [], [], 0
    for colour, faces in colour_groups(mesh):
        v, f = submesh(mesh, faces)
        parts_v.append(v)
        parts_f.append(f + count)
        parts_c.append(np.tile(np.array(colour, dtype=np.uint8), (len(v), 1)))
        count += len(v)
    out = trimesh.Trimesh(np.concatenate(parts_v), np.concatenate(parts_f), process=False)
    out.visual = trimesh.visual.ColorVisuals(out, vertex_colors=np.concatenate(parts_c))
    return out


def placement_matrix(placement: Placement) -> np.ndarray:
    """The 4x4 transform of a placement: scale, then yaw about +Z, then move to its position."""
    c, s = math.cos(placement.yaw), math.sin(placement.yaw)
    k = placement.scale
    m = np.eye(4)
    m[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) * k
    m[:3, 3] = placement.position
    return m


def catalog_asset(pl: Placement, index: int) -> Asset:
    """The catalog asset of a placement, or an :class:`ExportError` naming it."""
    try:
        return resolve(pl.asset)
    except UnknownAsset as exc:
        raise ExportError(f"$.placements[{index}].asset: expected {exc.expected}, got {pl.asset!r}") from None


def file_mesh(pl: Placement, index: int, folder: Path | None) -> trimesh.Trimesh:
    """A mesh placement's geometry with face colours: its own where the file has colours,
    else :data:`MESH_RGBA`. A texture cannot be kept: an :class:`ExportWarning` says so."""
    import trimesh

    mesh = load_mesh_file(pl, index, folder)
    visual = mesh.visual
    out = trimesh.Trimesh(mesh.vertices, mesh.faces, process=False)
    if isinstance(visual, trimesh.visual.ColorVisuals) and visual.kind in ("face", "vertex"):
        out.visual.face_colors = visual.face_colors
        return out
    if (
        isinstance(visual, trimesh.visual.TextureVisuals)
        and getattr(visual.material, "image", None) is not None
    ):
        warnings.warn(
            ExportWarning(
                f"$.placements[{index}].asset: the texture of {pl.asset!r} is not kept; one colour"
            ),
            stacklevel=3,
        )
    out.visual.face_colors = np.round(np.asarray(MESH_RGBA) * 255).astype(np.uint8)
    return out
