"""The asset catalog: category registry, seeded variants and :func:`resolve`.

An asset id is ``category/NNNN`` (``bench/0012``): the category's builder, run
with a generator seeded by ``SeedSequence([sha256(category), NNNN])``, gives the
same parts in every process and on every machine. Adding a category is one
builder function (see :class:`~citygen.assets.category.AssetBuilder`) plus one entry in its
module's ``CATEGORIES``.

Asset frame: origin at the centre of the asset's base at ground level, z up, the
asset's front (where one sits, the outlet, the lamp's arm) facing +x, so a
placement's yaw is the heading the asset faces.
"""

from __future__ import annotations

import functools
import hashlib
import re
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import TYPE_CHECKING

import manifold3d
import numpy as np
import shapely
from shapely.geometry import Polygon

from citygen.assets import furniture, outdoor, street
from citygen.assets.category import Category
from citygen.assets.parts import Box, Capsule, ConvexMesh, Cylinder, Part, footprints, release
from citygen.spec.placements import CATALOG_ID

if TYPE_CHECKING:  # imported where used: generation never needs trimesh
    import trimesh

_ID = re.compile(f"^{CATALOG_ID}$")
BASE_HEIGHT = 2.0
"""Parts whose bottom is below this height (m) stand in the way at ground level."""
_PART_TYPES = (Box, Cylinder, Capsule, ConvexMesh)


def _merge(*registries: Mapping[str, Category]) -> dict[str, Category]:
    merged: dict[str, Category] = {}
    for registry in registries:
        twice = sorted(set(merged) & set(registry))
        if twice:
            raise ValueError(f"asset categories defined twice: {twice}")
        merged.update(registry)
    return dict(sorted(merged.items()))


#: Every category, by name, merged from the builder modules; sorted. The tests cover each one.
CATEGORIES: Mapping[str, Category] = MappingProxyType(
    _merge(furniture.CATEGORIES, street.CATEGORIES, outdoor.CATEGORIES)
)


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
    base: Polygon = field(compare=False)
    """The footprint of the parts reaching below :data:`BASE_HEIGHT`: what a pedestrian or a
    robot can walk into. A lamp's arm or a tree's crown overhead is in ``footprint`` only.
    Placement keeps bases apart and on suitable ground; the occupancy map marks bases."""
    height: float
    """Top of the highest part above the ground (m)."""
    zones: frozenset[str]
    clearance: float
    """Free space (m) the asset wants around its footprint."""

    @functools.cached_property
    def footprint(self) -> Polygon:
        """Union of the parts' ground projections (m), holes filled; derived from ``parts``.

        Placement needs only :attr:`base`, so an asset with parts above :data:`BASE_HEIGHT`
        outlines all its parts on first use (the same polygon as when it was resolved);
        for any other asset it is the base itself.
        """
        return _outline(footprints([p.extent()[2] for p in self.parts]))

    def visual_mesh(self) -> trimesh.Trimesh:
        """The watertight union of the parts (manifold3d), faces coloured by part material.

        Built once per asset and cached; each call returns a copy the caller may change.
        """
        import trimesh

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
    # Each part's height range once, and only the footprints the base is the outline of, in
    # one vectorised pass; the footprint of all parts is the base unless some are high.
    extents = [p.extent() for p in parts]
    release(parts)
    low = [xy for z_low, _, xy in extents if z_low < BASE_HEIGHT]
    if not low:
        raise TypeError(f"the {name!r} builder must return a part reaching below {BASE_HEIGHT} m, got none")
    asset = Asset(
        id=asset_id,
        category=name,
        semantic_class=category.semantic_class,
        parts=parts,
        base=_outline(footprints(low)),
        height=max(z_high for _, z_high, _ in extents),
        zones=category.zones,
        clearance=category.clearance,
    )
    if len(low) == len(parts):
        asset.__dict__["footprint"] = asset.base  # what the cached property would give
    return asset


def _outline(prints: Sequence[Polygon]) -> Polygon:
    """The union of part footprints as one polygon without holes (its hull if disjoint)."""
    union = shapely.union_all(prints)
    if not isinstance(union, Polygon):
        union = union.convex_hull
    return shapely.normalize(Polygon(union.exterior))


@functools.lru_cache(maxsize=256)
def _union_mesh(parts: tuple[Part, ...]) -> trimesh.Trimesh:
    import trimesh

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
