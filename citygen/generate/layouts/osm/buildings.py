"""Stage 4 for ``layout = "osm"``: a building massing in each mapped footprint, as tall as mapped.

Each building zone gets one massing from the catalog (``building/NNNN``), fitted inside the
footprint as the city fits one into its lot (:func:`~citygen.generate.placement._fit`: turned
to the footprint's long side, scaled to fill its rectangle and shrunk until it fits). Of a
palette of :data:`PALETTE` variants drawn for the scene, the one whose fitted height is nearest
the mapped ``height`` (or ``building:levels``) is chosen; without one, the one whose scale is
nearest 1, as the city chooses. The footprint itself is the zone, exact; the massing is what
stands on it.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from citygen.assets.catalog import resolve
from citygen.generate.placement import _base_ring, _fit, _Ground, _pose
from citygen.geometry.terrain import height_at
from citygen.spec.placements import Placement
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

#: Building variants one scene draws its massing from.
PALETTE = 12


def massing(
    zones: Sequence[Zone], heights: dict[str, float], terrain: Terrain | None, rng: np.random.Generator
) -> list[Placement]:
    """One massing per building zone (see the module docstring); ``heights`` (m) by OSM id."""
    ground = _Ground(zones)
    variants = [resolve(f"building/{int(v):04d}") for v in rng.choice(10_000, PALETTE, replace=False)]
    out = []
    for poly, zone in zip(ground.polys, ground.zones, strict=True):
        if zone.kind != "building" or poly.area < 4.0:
            continue
        fits = [(f, a) for a in variants if (f := _fit(a, poly, ground)) is not None]
        if not fits:
            continue
        want = heights.get(zone.id.removeprefix("building-").split("-")[0])

        def miss(fa, want=want):
            (_, _, _, scale), asset = fa
            return abs(math.log(asset.height * scale / want)) if want else abs(math.log(scale))

        (x, y, yaw, scale), asset = min(fits, key=miss)
        ring = _pose(_base_ring(asset), x, y, yaw, scale)
        z = float(np.min(height_at(terrain, np.append(ring[:, 0], x), np.append(ring[:, 1], y))))
        out.append(
            Placement(
                id=f"building-{len(out) + 1}",
                asset=asset.id,
                position=(x, y, round(z, 3) + 0.0),
                yaw=yaw,
                scale=scale,
            )
        )
    return out
