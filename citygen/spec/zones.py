"""Functional zones (stage 2): the ground of the scene divided by use.

A zone is a polygon (with optional holes) of one kind of public space (a building
zone with a ``height`` is the building itself, its footprint extruded). Its
walkability follows from its kind (:data:`~citygen.spec.surfaces.WALKABLE_ZONES`);
its surface material and friction default to the kind's and the material's.
Zones never overlap. Ground that no zone covers is non-walkable.
"""

from __future__ import annotations

from pydantic import Field

from citygen.spec import limits
from citygen.spec.base import Identifier, SpecModel, Vec2, bounded_float
from citygen.spec.surfaces import (
    FRICTION,
    WALKABLE_ZONES,
    ZONE_MATERIAL,
    Material,
    SidewalkStrip,
    ZoneKind,
)

Ring = tuple[Vec2, ...]


class Zone(SpecModel):
    """One functional zone: a polygon of a single kind of ground."""

    id: Identifier
    kind: ZoneKind
    """What the ground is used for; decides walkability and the default material."""
    polygon: Ring = Field(min_length=3, max_length=limits.MAX_POLYGON_VERTICES)
    """Exterior ring ``[[x, y], ...]`` in metres, not repeating the first vertex."""
    holes: tuple[Ring, ...] = Field(default=(), max_length=limits.MAX_HOLES)
    """Interior rings cut out of the polygon (a tree pit in a plaza, a kiosk ...)."""
    material: Material | None = None
    """Surface material; when left out, the kind's default (concrete for sidewalks ...)."""
    friction: bounded_float(0.0, 2.0) | None = None
    """Sliding friction coefficient; when left out, the material's default."""
    strip: SidewalkStrip | None = None
    """For sidewalks only: frontage, clear (pedestrian through zone) or furnishing strip."""
    height: bounded_float(0.5, 500.0) | None = None
    """For buildings only: the building's height in metres. A building zone with a height is a
    solid, its polygon (holes cut out) extruded from the lowest ground under it up to that
    height; without one the zone is the building's lot (the synthetic city stands a catalog
    massing on it)."""

    @property
    def walkable(self) -> bool:
        """Whether pedestrians and micromobility robots are meant to move here."""
        return self.kind in WALKABLE_ZONES

    @property
    def surface(self) -> Material:
        """The material, resolved from the kind when the spec leaves it out."""
        return self.material or ZONE_MATERIAL[self.kind]  # type: ignore[return-value]

    @property
    def mu(self) -> float:
        """The friction coefficient, resolved from the material when the spec leaves it out."""
        return self.friction if self.friction is not None else FRICTION[self.surface]
