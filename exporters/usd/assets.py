"""Materials (a UsdPreviewSurface with friction, bound for every purpose and physics) and
the asset layers: one small layer per distinct asset, its convex parts as gprims (or a mesh
file's triangles), which every object placing it references as an instanceable prim."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from types import MappingProxyType

from citygen.assets import Asset, Box, Capsule, ConvexMesh, Cylinder, Look, UnknownAsset, resolve
from citygen.errors import ExportError, Problem, SpecError
from citygen.exporters import shared_file
from citygen.exporters.usd.sdf import (
    Gf,
    Sdf,
    add_label,
    apply_schemas,
    attr,
    collider,
    define,
    define_mesh,
    extent,
    layer_bytes,
    new_layer,
    prim_names,
    xform,
)
from citygen.spec.scene import Scene
from citygen.spec.surfaces import FRICTION

#: Friction of asset part materials that are not ground materials (rubber sole on them).
OBJECT_FRICTION = MappingProxyType({"plastic": 0.5, "glass": 0.4, "foliage": 0.6})
#: Friction of a part material found in neither table.
DEFAULT_OBJECT_FRICTION = 0.5
#: Semantic class of mesh-file objects (the spec gives none).
MESH_CLASS = "object"


def define_material(parent: Sdf.PrimSpec, name: str, rgba: Sequence[float], mu: float) -> Sdf.Path:
    """A UsdPreviewSurface material of colour ``rgba`` with friction ``mu`` (static and dynamic)."""
    t = Sdf.ValueTypeNames
    mat = define(parent, name, "Material")
    apply_schemas(mat, "PhysicsMaterialAPI")
    attr(mat, "physics:staticFriction", t.Float, float(mu))
    attr(mat, "physics:dynamicFriction", t.Float, float(mu))
    attr(mat, "physics:restitution", t.Float, 0.0)
    shader = define(mat, "Surface", "Shader")
    attr(shader, "info:id", t.Token, "UsdPreviewSurface", uniform=True)
    attr(shader, "inputs:diffuseColor", t.Color3f, Gf.Vec3f(*map(float, rgba[:3])))
    attr(shader, "inputs:roughness", t.Float, 0.8)
    if len(rgba) > 3 and rgba[3] < 1.0:
        attr(shader, "inputs:opacity", t.Float, float(rgba[3]))
    attr(shader, "outputs:surface", t.Token)
    out = attr(mat, "outputs:surface", t.Token)
    out.connectionPathList.explicitItems = [shader.path.AppendProperty("outputs:surface")]
    return mat.path


def bind(spec: Sdf.PrimSpec, material: Sdf.Path) -> None:
    """Bind ``material`` for every purpose and, explicitly, for physics."""
    apply_schemas(spec, "MaterialBindingAPI")
    for name in ("material:binding", "material:binding:physics"):
        rel = Sdf.RelationshipSpec(spec, name, custom=False)
        rel.targetPathList.explicitItems = [material]
    rel.SetInfo("bindMaterialAs", "weakerThanDescendants")


def _part_friction(look: Look) -> float:
    return FRICTION.get(look.name, OBJECT_FRICTION.get(look.name, DEFAULT_OBJECT_FRICTION))


def _author_part(parent: Sdf.PrimSpec, name: str, part) -> Sdf.PrimSpec:
    """One convex part as a gprim in the asset frame, with its collision API."""
    t = Sdf.ValueTypeNames
    if isinstance(part, Box):
        spec = define(parent, name, "Cube")
        attr(spec, "size", t.Double, 1.0)
        extent(spec, (-0.5,) * 3, (0.5,) * 3)
        xform(spec, part.pos, part.yaw, part.size)
    elif isinstance(part, ConvexMesh):
        hull = part.to_trimesh()
        spec = define_mesh(parent, name, hull.vertices, hull.faces)
        collider(spec, "convexHull")
        return spec
    elif isinstance(part, Capsule) and part.length == 0:
        spec = define(parent, name, "Sphere")
        r = part.radius
        attr(spec, "radius", t.Double, r)
        extent(spec, (-r,) * 3, (r,) * 3)
        xform(spec, part.pos)
    elif isinstance(part, Cylinder | Capsule):
        capsule = isinstance(part, Capsule)
        spec = define(parent, name, "Capsule" if capsule else "Cylinder")
        r = part.radius
        h = part.length if capsule else part.height
        attr(spec, "radius", t.Double, r)
        attr(spec, "height", t.Double, h)
        attr(spec, "axis", t.Token, "Z", uniform=True)
        top = h / 2 + (r if capsule else 0.0)
        extent(spec, (-r, -r, -top), (r, r, top))
        xform(spec, part.pos)
    else:  # pragma: no cover - the catalog checks part types
        raise TypeError(f"unknown part type {type(part).__name__}")
    collider(spec)
    return spec


def _asset_root(layer: Sdf.Layer, name: str, asset: str, semantic: str) -> Sdf.PrimSpec:
    root = define(layer, name, "Xform", kind="component")
    attr(root, "citygen:asset", Sdf.ValueTypeNames.String, asset, custom=True)
    add_label(root, semantic)
    return root


def _asset_layer(asset: Asset) -> Sdf.Layer:
    """The asset as a layer of its own: parts, materials, semantics (see the module doc)."""
    (name,) = prim_names([asset.id])
    layer = new_layer(name)
    with Sdf.ChangeBlock():
        root = _asset_root(layer, name, asset.id, asset.semantic_class)
        looks: list[Look] = []
        for part in asset.parts:
            if part.material not in looks:
                looks.append(part.material)
        scope = define(root, "Looks", "Scope")
        names = prim_names(f"m{k}_{look.name}" for k, look in enumerate(looks))
        materials = [
            define_material(scope, n, look.rgba, _part_friction(look))
            for n, look in zip(names, looks, strict=True)
        ]
        for k, part in enumerate(asset.parts):
            bind(_author_part(root, f"part_{k:02d}", part), materials[looks.index(part.material)])
    return layer


def _mesh_asset_layer(asset: str, file: Path) -> Sdf.Layer:
    """A mesh file beside the scene as an asset layer: its triangles (metres, Z up)."""
    import trimesh

    try:
        mesh = trimesh.load(file, force="mesh")
    except Exception as exc:  # trimesh raises many types for unreadable files
        raise ExportError(f"{file}: cannot read the mesh ({type(exc).__name__})") from None
    if len(mesh.faces) == 0:
        raise ExportError(f"{file}: expected a mesh with triangles, found none")
    (name,) = prim_names([Path(asset).stem])
    layer = new_layer(name)
    with Sdf.ChangeBlock():
        root = _asset_root(layer, name, asset, MESH_CLASS)
        material = define_material(
            define(root, "Looks", "Scope"), "m0", (0.6, 0.6, 0.6), FRICTION["concrete"]
        )
        spec = define_mesh(root, "mesh", mesh.vertices, mesh.faces)
        collider(spec, "none")
        bind(spec, material)
    return layer


def _mesh_file(scene_file: str | None, mesh_dir: Path | None, index: int, asset: str) -> Path:
    where = f"$.placements[{index}].asset"

    def fail(expected: str, found: str) -> SpecError:
        return SpecError([Problem(where, expected, found)], file=scene_file)

    if mesh_dir is None:
        raise fail("a catalog asset id when the scene is not a file (or pass mesh_dir=)", repr(asset))
    base = mesh_dir.resolve()
    file = (base / asset).resolve()
    if not file.is_relative_to(base):
        raise fail("a mesh file inside the scene's folder", repr(asset))
    if not file.is_file():
        raise fail("an existing mesh file", f"no file {asset!r} in {base}")
    return file


def asset_files(
    scene: Scene, scene_file: str | None, mesh_dir: Path | None, out_dir: Path, fmt: str
) -> dict[str, Path]:
    """Each distinct asset's shared layer file, by asset reference (first use order)."""
    files: dict[str, Path] = {}
    for i, pl in enumerate(scene.placements):
        if pl.asset in files:
            continue
        if pl.is_mesh:
            layer = _mesh_asset_layer(pl.asset, _mesh_file(scene_file, mesh_dir, i, pl.asset))
        else:
            try:
                layer = _asset_layer(resolve(pl.asset))
            except UnknownAsset as exc:
                where = f"$.placements[{i}].asset"
                raise SpecError([Problem(where, exc.expected, repr(pl.asset))], file=scene_file) from None
        data = layer_bytes(layer, fmt, out_dir / "assets")
        try:
            files[pl.asset] = shared_file(out_dir, data, f".{fmt}")
        except OSError as exc:
            why = exc.strerror or type(exc).__name__
            raise ExportError(f"{out_dir / 'assets'}: cannot write: {why}") from None
    return files
