"""What a catalog category is: a seeded builder and what placement and export need to know.

Builder modules (:mod:`~citygen.assets.furniture`, :mod:`~citygen.assets.street`,
:mod:`~citygen.assets.outdoor`) each define a ``CATEGORIES`` dict of
:class:`Category`; :mod:`citygen.assets.catalog` merges them into the registry.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Literal, Protocol, get_args

import numpy as np

from citygen.assets.parts import Part
from citygen.spec.surfaces import ZONE_KINDS

Range = tuple[float, float]

Anchor = Literal["free", "curb", "crossing", "frontage", "lot"]
"""Where placement puts an asset within its zones, and how it turns it:

- ``free``: anywhere in a suitable zone, turned to one of the zone's principal axes
  (benches, planters on a plaza; everything in small region scenes without roads);
- ``curb``: in the sidewalk's furnishing strip (or on the curb), lined up with the
  curb, its front (+x) facing the roadway (the lamp's arm, the hydrant's outlet,
  the shelter's open side; bins, parking meters, parked scooters);
- ``crossing``: like ``curb``, but near the ends of a crosswalk (hydrants, traffic
  lights, bollards);
- ``frontage``: in the sidewalk's frontage strip along the building line, back to
  the building, front (+x) facing the street (cafe tables, advertising boards);
- ``lot``: fills a building zone, scaled and turned to fit it (building massing).

Scenes without sidewalk strips (the small region layouts) treat every anchor but
``lot`` as ``free``.
"""
ANCHORS: tuple[str, ...] = get_args(Anchor)


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
    anchor: Anchor = "free"
    """Where in its zones placement puts the asset (see :data:`Anchor`)."""

    def __post_init__(self) -> None:
        unknown = sorted(set(self.zones) - set(ZONE_KINDS))
        if not self.zones or unknown:
            raise ValueError(
                f"Category.zones: expected a non-empty set of {', '.join(ZONE_KINDS)}, got unknown {unknown}"
            )
        if self.anchor not in ANCHORS:
            raise ValueError(f"Category.anchor: expected one of {', '.join(ANCHORS)}, got {self.anchor!r}")
        if not self.clearance >= 0:
            raise ValueError(f"Category.clearance: expected >= 0 m, got {self.clearance!r}")
        for name in ("height", "size_x", "size_y"):
            low, high = getattr(self, name)
            if not 0 < low <= high:
                raise ValueError(f"Category.{name}: expected 0 < low <= high (m), got {(low, high)}")


def zones(*kinds: str) -> frozenset[str]:
    return frozenset(kinds)
