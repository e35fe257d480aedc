"""The asset catalog: seeded variants of urban objects made of convex parts.

An asset id ``category/NNNN`` names one variant; :func:`resolve` builds it (the
same parts in every process), :func:`categories` lists what exists. An asset's
parts are its collision geometry, their union its watertight visual mesh.

>>> from citygen.assets import categories, resolve
>>> {'bench', 'fire_hydrant'} <= set(categories())
True
>>> hydrant = resolve("fire_hydrant/0007")
>>> sorted(hydrant.zones), hydrant.clearance
(['curb', 'sidewalk'], 0.9)
>>> hydrant.visual_mesh().is_watertight
True
"""

from citygen.assets.catalog import (
    CATEGORIES,
    Asset,
    UnknownAsset,
    categories,
    resolve,
)
from citygen.assets.category import AssetBuilder, Category
from citygen.assets.parts import Box, Capsule, ConvexMesh, Cylinder, Look, Part

__all__ = [
    "CATEGORIES",
    "Asset",
    "AssetBuilder",
    "Box",
    "Capsule",
    "Category",
    "ConvexMesh",
    "Cylinder",
    "Look",
    "Part",
    "UnknownAsset",
    "categories",
    "resolve",
]
