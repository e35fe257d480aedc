"""The MJCF model being built (:class:`Builder`): its XML elements, the asset files it
names, its materials and custom entries; and what the ground, terrain and objects share:
their friction text, the zone palette, the floor."""

from __future__ import annotations

import hashlib
import xml.etree.ElementTree as ET
from dataclasses import dataclass, field
from pathlib import Path
from types import MappingProxyType

import numpy as np

from citygen.exporters import ZONE_COLORS
from citygen.exporters.mjcf.text import num, nums
from citygen.geometry.pieces import ROUGH_TOLERANCE
from citygen.spec.scene import Scene
from citygen.spec.surfaces import FRICTION

#: Sliding friction of ground no zone covers and of object parts of a material without
#: a friction in :data:`citygen.spec.surfaces.FRICTION` (concrete's).
DEFAULT_FRICTION = FRICTION["concrete"]
#: MuJoCo's default torsional and rolling friction, written after the sliding one.
_SPIN_ROLL = (0.005, 0.0001)

#: Zone colours (RGBA in [0, 1]) from the exporters' shared palette
#: (:data:`citygen.exporters.ZONE_COLORS`).
ZONE_RGBA = MappingProxyType(
    {kind: (*(int(h[i : i + 2], 16) / 255 for i in (1, 3, 5)), 1.0) for kind, h in ZONE_COLORS.items()}
)
#: Colour of the ground inside the scene that no zone covers.
GROUND_RGBA = (0.957, 0.945, 0.918, 1.0)
#: Default bottom (m) of slabs and stair boxes, lowered to ``MIN_THICKNESS`` below the lowest tread.
FLOOR = -1.0


def asset_name(data: bytes, suffix: str) -> str:
    """The path, relative to the XML file, of an asset file: ``assets/<digest><suffix>``,
    the name :func:`citygen.exporters.shared_file` gives it."""
    return f"assets/{hashlib.sha256(data).hexdigest()[:20]}{suffix}"


@dataclass
class Builder:
    """One model while it is built: the scene, the options, the XML elements written so far
    and what they name (asset files, materials, meshes), warnings to give at the end."""

    scene: Scene
    file: str | None
    base_dir: Path | None
    resolution: float | None
    apron: float
    #: ``heightfield`` (slope and rough tiles as heightfields) or ``convex`` (as convex pieces
    #: within ``tolerance`` m of height_at).
    terrain: str = "heightfield"
    tolerance: float = ROUGH_TOLERANCE
    root: ET.Element = field(init=False)
    asset: ET.Element = field(init=False)
    world: ET.Element = field(init=False)
    files: dict[str, bytes] = field(default_factory=dict)
    materials: dict[str, tuple[float, ...]] = field(default_factory=dict)
    meshes: set[str] = field(default_factory=set)
    floor: float = FLOOR
    samples: int = 0
    warnings: list[str] = field(default_factory=list)
    customs: ET.Element | None = None
    top: float = 0.0
    bottom: float = 0.0
    #: Heightfields' samples as arrays in :attr:`hfields` (:class:`~citygen.exporters.mjcf.contract.MJCFTree`)
    #: rather than ``elevation`` text.
    binary_hfields: bool = False
    hfields: dict[str, np.ndarray] = field(default_factory=dict)

    def material(self, name: str, rgba: tuple[float, ...]) -> str:
        if name not in self.materials:
            self.materials[name] = rgba
            ET.SubElement(self.asset, "material", name=name, rgba=nums(rgba))
        return name

    def custom(self, kind: str, name: str, data: str) -> None:
        """A ``<custom>`` entry (``numeric`` or ``text``): scene data no geom carries."""
        if self.customs is None:
            self.customs = ET.Element("custom")
        ET.SubElement(self.customs, kind, name=name, data=data)

    def mesh_file(self, data: bytes, scale: float, **extra: str) -> str:
        """A mesh asset for a file's bytes at a scale; its name."""
        path = asset_name(data, ".stl")
        self.files[path] = data
        name = f"{path[7:19]}@{num(scale)}"
        if name not in self.meshes:
            self.meshes.add(name)
            attrs = {"name": name, "file": path, **extra}
            if scale != 1.0:
                attrs["scale"] = nums([scale] * 3)
            ET.SubElement(self.asset, "mesh", **attrs)
        return name


def friction(mu: float) -> str:
    """A geom's ``friction`` text: sliding friction ``mu``, then MuJoCo's default torsional
    and rolling ones."""
    return nums((mu, *_SPIN_ROLL))
