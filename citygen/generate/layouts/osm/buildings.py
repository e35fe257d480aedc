"""Stage 2 for ``layout = "osm"``: a mapped building is a solid, its footprint extruded.

Each building zone (:mod:`.ground`: the mapped footprint, courtyards as holes) carries its
``height`` (:attr:`~citygen.spec.zones.Zone.height`): the map's ``height`` tag, else
:data:`LEVEL` metres a level of ``building:levels`` (:mod:`.place` reads them), else
:data:`DEFAULT_LEVELS` levels' worth. Every exporter stands the zone's polygon up to that
height, so the building covers exactly the ground the map says it covers; no catalog massing
stands in it.
"""

from __future__ import annotations

from collections.abc import Sequence

from citygen.spec.zones import Zone

#: Height (m) of one level of ``building:levels``.
LEVEL = 3.0
#: Levels of a building whose map gives neither ``height`` nor ``building:levels``.
DEFAULT_LEVELS = 3
#: The heights a zone may carry (m; :attr:`~citygen.spec.zones.Zone.height`'s bounds): a
#: mapped height outside them is taken to the nearest.
LOWEST, HIGHEST = 0.5, 500.0


def with_heights(zones: Sequence[Zone], heights: dict[str, float]) -> tuple[Zone, ...]:
    """``zones`` with every building zone's ``height``: ``heights`` (m) by OSM id (a zone
    ``building-w45`` or ``building-w45-2`` is way 45's), else :data:`DEFAULT_LEVELS` levels."""
    default = DEFAULT_LEVELS * LEVEL
    out = []
    for zone in zones:
        if zone.kind == "building":
            osm_id = zone.id.removeprefix("building-").split("-")[0]
            h = min(max(heights.get(osm_id, default), LOWEST), HIGHEST)
            zone = zone.model_copy(update={"height": round(h, 3)})
        out.append(zone)
    return tuple(out)
