"""The asset catalog: category registry, seeded variants and :func:`resolve`.

An asset id is ``category/NNNN`` (``bench/0012``): the category's builder, run
with a generator seeded by ``SeedSequence([sha256(category), NNNN])``, gives the
same parts in every process and on every machine. Adding a category is one
builder function (see :class:`AssetBuilder`) plus one :data:`CATEGORIES` entry.

Asset frame: origin at the centre of the asset's base at ground level, z up, the
asset's front (where one sits, the outlet, the lamp's arm) facing +x, so a
placement's yaw is the heading the asset faces.
"""

from __future__ import annotations

import functools
import hashlib
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Protocol

import manifold3d
import numpy as np
import shapely
import trimesh
from shapely.geometry import Polygon

from citygen.assets import furniture
from citygen.assets.parts import Box, Capsule, ConvexMesh, Cylinder, Part
from citygen.spec.placements import CATALOG_ID
from citygen.spec.surfaces import ZONE_KINDS

_ID = re.compile(f"^{CATALOG_ID}$")
_PART_TYPES = (Box, Cylinder, Capsule, ConvexMesh)
Range = tuple[float, float]


class AssetBuilder(Protocol):
    """Builds one variant of a category from ``rng``, the only source of randomness.

    Returns the asset's convex parts in the asset frame (metres), resting on z = 0.
    """

    def __call__(self, rng: np.random.Generator) -> list[Part]: ...


@dataclass(frozen=True)
class Category:
    """A kind of asset: its builder and what placement and export need to know about it.

    ``height``, ``size_x`` and ``size_y`` are the ranges (m) the builder promises for
    every variant: its height and its footprint's extent along x (front to back)
    and y (side to side). The tests hold the builder to them.
    """

    build: AssetBuilder
    semantic_class: str
    zones: frozenset[str]
    """Zone kinds (:data:`citygen.spec.surfaces.ZONE_KINDS`) the asset belongs in."""
    clearance: float
    """Free space (m) the asset wants around its footprint."""
    height: Range
    size_x: Range
    size_y: Range

    def __post_init__(self) -> None:
        unknown = sorted(set(self.zones) - set(ZONE_KINDS))
        if not self.zones or unknown:
            raise ValueError(
                f"Category.zones: expected a non-empty set of {', '.join(ZONE_KINDS)}, got unknown {unknown}"
            )
        if not self.clearance >= 0:
            raise ValueError(f"Category.clearance: expected >= 0 m, got {self.clearance!r}")
        for name in ("height", "size_x", "size_y"):
            low, high = getattr(self, name)
            if not 0 < low <= high:
                raise ValueError(f"Category.{name}: expected 0 < low <= high (m), got {(low, high)}")


def _zones(*kinds: str) -> frozenset[str]:
    return frozenset(kinds)


#: Every category, by name. One entry per builder; the tests cover each one.
CATEGORIES: Mapping[str, Category] = MappingProxyType(
    {
        "bench": Category(
            furniture.bench, "bench", _zones("sidewalk", "plaza", "trail"), 0.6,
            height=(0.40, 1.00), size_x=(0.38, 0.72), size_y=(1.20, 2.40),
        ),
        "trash_bin": Category(
            furniture.trash_bin, "trash_bin", _zones("sidewalk", "plaza", "trail"), 0.4,
            height=(0.74, 1.20), size_x=(0.43, 0.74), size_y=(0.37, 0.74),
        ),
        "bollard": Category(
            furniture.bollard, "bollard", _zones("sidewalk", "plaza", "curb"), 0.4,
            height=(0.80, 1.10), size_x=(0.10, 0.35), size_y=(0.10, 0.35),
        ),
        "planter": Category(
            furniture.planter, "planter", _zones("sidewalk", "plaza"), 0.4,
            height=(0.35, 1.90), size_x=(0.50, 1.20), size_y=(0.50, 1.80),
        ),
        "lamp_post": Category(
            furniture.lamp_post, "lamp_post", _zones("sidewalk", "curb", "plaza", "trail"), 0.4,
            height=(3.80, 8.40), size_x=(0.35, 3.00), size_y=(0.20, 0.61),
        ),
        "fire_hydrant": Category(
            furniture.fire_hydrant, "fire_hydrant", _zones("sidewalk", "curb"), 0.9,
            height=(0.54, 0.90), size_x=(0.20, 0.45), size_y=(0.28, 0.50),
        ),
    }
)  # fmt: skip


def categories() -> tuple[str, ...]:
    """The names of every catalog category, sorted.

    >>> "bench" in categories()
    True
    """
    return tuple(sorted(CATEGORIES))


class UnknownAsset(LookupError, ValueError):
    """An asset id that is malformed or names no catalog category.

    A ``ValueError`` (the id is bad input) and a ``LookupError`` (a failed catalog
    look-up), never a ``KeyError``. ``expected`` says what would have been accepted,
    ready for a :class:`citygen.errors.Problem`.
    """

    def __init__(self, asset_id: object, expected: str) -> None:
        self.asset_id, self.expected = asset_id, expected
        super().__init__(f"unknown asset {asset_id!r}: expected {expected}")


@dataclass(frozen=True)
class Asset:
    """One catalog variant, in the asset frame (m), before a placement's scale, yaw and position."""

    id: str
    category: str
    semantic_class: str
    parts: tuple[Part, ...]
    """Convex parts: the collision geometry."""
    footprint: Polygon = field(compare=False)
    """Union of the parts' ground projections (m), holes filled; derived from ``parts``."""
    height: float
    """Top of the highest part above the ground (m)."""
    zones: frozenset[str]
    clearance: float
    """Free space (m) the asset wants around its footprint."""

    def visual_mesh(self) -> trimesh.Trimesh:
        """The watertight union of the parts (manifold3d), faces coloured by part material.

        Built once per asset and cached; each call returns a copy the caller may change.
        """
        mesh = _union_mesh(self.parts)
        # Not mesh.copy(): trimesh would derive vertex colours, which needs scipy.
        return trimesh.Trimesh(
            mesh.vertices.copy(),
            mesh.faces.copy(),
            face_colors=mesh.visual.face_colors.copy(),
            process=False,
        )


def _name_key(name: str) -> int:
    """A stable 64-bit integer for a category name (never ``hash()``, which is salted)."""
    return int.from_bytes(hashlib.sha256(name.encode("utf-8")).digest()[:8], "little")


def _expected() -> str:
    known = ", ".join(categories())
    return f"a catalog id 'category/NNNN' (NNNN in 0000-9999), category one of: {known}"


@functools.lru_cache(maxsize=4096)
def resolve(asset_id: str) -> Asset:
    """The asset with this id; the same id gives the same geometry in any process.

    Raises :class:`UnknownAsset` for a malformed id or an unknown category.

    >>> bench = resolve("bench/0012")
    >>> bench.category, bench.semantic_class, bench.height > 0.4
    ('bench', 'bench', True)
    >>> resolve("bench/0012") == bench
    True
    """
    if not isinstance(asset_id, str) or not _ID.match(asset_id):
        raise UnknownAsset(asset_id, _expected())
    name, variant = asset_id.split("/")
    if name not in CATEGORIES:
        raise UnknownAsset(asset_id, _expected())
    category = CATEGORIES[name]
    rng = np.random.default_rng(np.random.SeedSequence([_name_key(name), int(variant)]))
    parts = tuple(category.build(rng))
    if not parts or not all(isinstance(p, _PART_TYPES) for p in parts):
        raise TypeError(f"the {name!r} builder must return a non-empty list of parts, got {parts!r}")
    return Asset(
        id=asset_id,
        category=name,
        semantic_class=category.semantic_class,
        parts=parts,
        footprint=_footprint(parts),
        height=max(float(p.hull_points()[:, 2].max()) for p in parts),
        zones=category.zones,
        clearance=category.clearance,
    )


def _footprint(parts: tuple[Part, ...]) -> Polygon:
    """The union of the parts' footprints as one polygon without holes (its hull if disjoint)."""
    union = shapely.union_all([p.footprint() for p in parts])
    if not isinstance(union, Polygon):
        union = union.convex_hull
    return shapely.normalize(Polygon(union.exterior))


@functools.lru_cache(maxsize=256)
def _union_mesh(parts: tuple[Part, ...]) -> trimesh.Trimesh:
    solids = [p.to_manifold().as_original() for p in parts]
    colour = {s.original_id(): p.material.rgba for s, p in zip(solids, parts, strict=True)}
    union = manifold3d.Manifold.batch_boolean(solids, manifold3d.OpType.Add).to_mesh64()
    vertices = np.asarray(union.vert_properties, dtype=np.float64)[:, :3]
    mesh = trimesh.Trimesh(vertices, np.asarray(union.tri_verts, dtype=np.int64), process=False)
    bounds = np.asarray(union.run_index, dtype=np.int64) // 3  # face range of each input solid
    rgba = np.zeros((len(mesh.faces), 4))
    for start, stop, original in zip(bounds[:-1], bounds[1:], union.run_original_id, strict=True):
        rgba[start:stop] = colour[int(original)]
    mesh.visual.face_colors = np.round(rgba * 255).astype(np.uint8)
    return mesh
