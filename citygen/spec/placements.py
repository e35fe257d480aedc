"""Static objects (stage 4): instances of catalog assets or of meshes beside the scene."""

from __future__ import annotations

from typing import Annotated

from pydantic import Field, Strict

from citygen.spec.base import Identifier, SpecModel, Vec3, Yaw, bounded_float

CATALOG_ID = r"[a-z][a-z0-9_]*/[0-9]{4}"
"""A catalog asset id: ``category/variant``, for example ``bench/0012``."""
MESH_PATH = r'[^\\:*?"<>|]+\.(obj|stl|ply|glb|gltf|off)'
"""A mesh file beside the scene, as a relative POSIX path (``meshes/kiosk.obj``)."""

AssetRef = Annotated[
    str,
    Strict(),
    Field(
        max_length=256,
        pattern=f"^(({CATALOG_ID})|({MESH_PATH}))$",
        description=(
            "A catalog asset id 'category/NNNN' (for example 'bench/0012'), or the path of a "
            "mesh file relative to the scene file's folder (for example 'meshes/kiosk.obj')."
        ),
    ),
]


class Placement(SpecModel):
    """One static object standing in the scene."""

    id: Identifier
    asset: AssetRef
    position: Vec3
    """``[x, y, z]`` of the asset's origin (centre of its base) in metres."""
    yaw: Yaw = 0.0
    """Rotation about +Z in radians."""
    scale: bounded_float(0.05, 20.0) = 1.0
    """Uniform scale factor applied to the asset."""

    @property
    def is_mesh(self) -> bool:
        """Whether the asset is a mesh file rather than a catalog id."""
        return "." in self.asset
