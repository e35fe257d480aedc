"""Authoring USD at the Sdf level (fast: no composition while writing): layers with the
stage metadata, prims, API schemas, attributes, transforms, semantic labels, colliders,
triangle meshes, and layers written atomically or read back as bytes.

pxr is imported here, once, for the whole USD exporter; without usd-core its names are
None and :func:`need_pxr` raises :class:`~citygen.errors.DependencyMissing`."""

from __future__ import annotations

import itertools
import math
import os
import re
from collections.abc import Iterable, Sequence
from pathlib import Path

import numpy as np

from citygen.errors import DependencyMissing, ExportError

try:
    from pxr import Gf, Sdf, Usd, Vt
except ImportError:  # pragma: no cover - usd-core is a dependency of citygen
    Gf = Sdf = Usd = Vt = None

_INVALID = re.compile(r"[^A-Za-z0-9_]")
_temp_counter = itertools.count()


def need_pxr() -> None:
    if Usd is None:  # pragma: no cover
        raise DependencyMissing("usd-core", "USD export")


def prim_names(ids: Iterable[str]) -> list[str]:
    """Valid, unique USD prim names for ``ids`` in order: characters other than letters,
    digits and ``_`` become ``_``, a leading digit gets a ``_`` before it, and a name
    already taken gets ``_1``, ``_2`` ... after it.

    >>> prim_names(["bench/0012", "road-0", "road_0", "7"])
    ['bench_0012', 'road_0', 'road_0_1', '_7']
    """
    used: set[str] = set()
    out = []
    for raw in ids:
        base = _INVALID.sub("_", raw) or "_"
        if base[0].isdigit():
            base = "_" + base
        name, n = base, 1
        while name in used:
            name, n = f"{base}_{n}", n + 1
        used.add(name)
        out.append(name)
    return out


def new_layer(default_prim: str) -> Sdf.Layer:
    """An empty in-memory layer with the stage metadata: Z up, metres, kilograms."""
    layer = Sdf.Layer.CreateAnonymous(".usda")
    layer.defaultPrim = default_prim
    layer.pseudoRoot.SetInfo("upAxis", "Z")
    layer.pseudoRoot.SetInfo("metersPerUnit", 1.0)
    layer.pseudoRoot.SetInfo("kilogramsPerUnit", 1.0)
    return layer


def define(parent: Sdf.Layer | Sdf.PrimSpec, name: str, type_name: str = "", kind: str = "") -> Sdf.PrimSpec:
    spec = Sdf.PrimSpec(parent, name, Sdf.SpecifierDef, type_name)
    if kind:
        spec.kind = kind
    return spec


def apply_schemas(spec: Sdf.PrimSpec, *schemas: str) -> None:
    """Apply API schemas by name (prepended, each once, in order)."""
    items = list(spec.GetInfo("apiSchemas").prependedItems)
    items += [name for name in schemas if name not in items]
    op = Sdf.TokenListOp()
    op.prependedItems = items
    spec.SetInfo("apiSchemas", op)


def attr(
    spec: Sdf.PrimSpec, name: str, type_name, value=None, *, custom: bool = False, uniform: bool = False
) -> Sdf.AttributeSpec:
    """An attribute of ``spec`` (custom or uniform if asked), ``value`` its default if given."""
    variability = Sdf.VariabilityUniform if uniform else Sdf.VariabilityVarying
    out = Sdf.AttributeSpec(spec, name, type_name, variability, declaresCustom=custom)
    if value is not None:
        out.default = value
    return out


def xform(spec: Sdf.PrimSpec, translate: Sequence[float], yaw: float = 0.0, scale=None) -> None:
    """xformOps translate (m), rotateZ (``yaw`` in radians, written in degrees), scale."""
    t = Sdf.ValueTypeNames
    order = ["xformOp:translate"]
    attr(spec, "xformOp:translate", t.Double3, Gf.Vec3d(*map(float, translate)))
    if yaw:
        order.append("xformOp:rotateZ")
        attr(spec, "xformOp:rotateZ", t.Double, math.degrees(yaw))
    if scale is not None:
        order.append("xformOp:scale")
        attr(spec, "xformOp:scale", t.Double3, Gf.Vec3d(*map(float, scale)))
    attr(spec, "xformOpOrder", t.TokenArray, order, uniform=True)


def add_label(spec: Sdf.PrimSpec, semantic_class: str) -> None:
    """The semantic class as both Isaac Sim schemas have it."""
    t = Sdf.ValueTypeNames
    apply_schemas(spec, "SemanticsLabelsAPI:class", "SemanticsAPI:Semantics")
    attr(spec, "semantics:labels:class", t.TokenArray, [semantic_class])
    attr(spec, "semantic:Semantics:params:semanticType", t.String, "class")
    attr(spec, "semantic:Semantics:params:semanticData", t.String, semantic_class)


def semantic_class(prim: Usd.Prim) -> str | None:
    """The class label of a prim as this exporter writes it (``semantics:labels:class``),
    else ``semantic:Semantics:params:semanticData``; None without either."""
    labels = prim.GetAttribute("semantics:labels:class")
    if labels and labels.Get():
        return str(labels.Get()[0])
    data = prim.GetAttribute("semantic:Semantics:params:semanticData")
    return str(data.Get()) if data and data.Get() is not None else None


def collider(spec: Sdf.PrimSpec, approximation: str | None = None) -> None:
    apply_schemas(spec, "PhysicsCollisionAPI")
    if approximation is not None:
        apply_schemas(spec, "PhysicsMeshCollisionAPI")
        attr(spec, "physics:approximation", Sdf.ValueTypeNames.Token, approximation, uniform=True)


def extent(spec: Sdf.PrimSpec, lo: Sequence[float], hi: Sequence[float]) -> None:
    value = Vt.Vec3fArray([Gf.Vec3f(*map(float, lo)), Gf.Vec3f(*map(float, hi))])
    attr(spec, "extent", Sdf.ValueTypeNames.Float3Array, value)


def define_mesh(parent: Sdf.PrimSpec, name: str, verts: np.ndarray, faces: np.ndarray) -> Sdf.PrimSpec:
    """A triangle Mesh prim (points in metres, float32)."""
    t = Sdf.ValueTypeNames
    spec = define(parent, name, "Mesh")
    pts = np.ascontiguousarray(verts, dtype=np.float32)
    attr(spec, "points", t.Point3fArray, Vt.Vec3fArray.FromNumpy(pts))
    attr(spec, "faceVertexCounts", t.IntArray, Vt.IntArray.FromNumpy(np.full(len(faces), 3, dtype=np.int32)))
    indices = np.ascontiguousarray(faces, dtype=np.int32).ravel()
    attr(spec, "faceVertexIndices", t.IntArray, Vt.IntArray.FromNumpy(indices))
    attr(spec, "subdivisionScheme", t.Token, "none", uniform=True)
    extent(spec, pts.min(axis=0), pts.max(axis=0))
    return spec


def write_layer(layer: Sdf.Layer, path: Path) -> None:
    """Export ``layer`` to ``path`` through a temporary file in the same folder (atomic)."""
    tmp = path.with_name(f".{path.stem}.{os.getpid()}.{next(_temp_counter)}.tmp{path.suffix}")
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        if not layer.Export(str(tmp)):
            raise ExportError(f"{path}: usd-core could not write the layer")
        os.replace(tmp, path)
    except OSError as exc:
        raise ExportError(f"{path}: cannot write: {exc.strerror or type(exc).__name__}") from None
    finally:
        tmp.unlink(missing_ok=True)


def layer_bytes(layer: Sdf.Layer, fmt: str, scratch: Path) -> bytes:
    """The bytes of ``layer`` as a ``fmt`` file (usdc needs a trip through a file)."""
    if fmt == "usda":
        return layer.ExportToString().encode("utf-8")
    tmp = scratch / f".layer.{os.getpid()}.{next(_temp_counter)}.tmp.usdc"
    try:
        scratch.mkdir(parents=True, exist_ok=True)
        if not layer.Export(str(tmp)):
            raise ExportError(f"{tmp}: usd-core could not write the layer")
        return tmp.read_bytes()
    except OSError as exc:
        raise ExportError(f"{scratch}: cannot write: {exc.strerror or type(exc).__name__}") from None
    finally:
        tmp.unlink(missing_ok=True)
