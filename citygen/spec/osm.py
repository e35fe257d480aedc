"""Real places: the OpenStreetMap extract a scene is made from (``layout = "osm"``).

A generator config's ``osm`` table names the extract on disk and the box to cut from it
(:class:`OsmArea`); the scene's ``meta.source`` records where it came from
(:class:`OsmSource`): the file's name, the box, and the projection from longitude and latitude
to the scene's metres, so any object can be traced back to the map. Objects that came from the
map carry the OSM id in their own id: ``n123`` a node, ``w45`` a way, ``r6`` a relation
(``bench-n123``, ``building-w45``, the junction block ``j-n12``, the street block ``s-w45-3``).

Longitudes and latitudes are kept as written (not rounded to the spec's 1e-4 precision: a
ten-thousandth of a degree is 11 m).
"""

from __future__ import annotations

from typing import Annotated

from pydantic import AllowInfNan, Field, Strict

from citygen.spec.base import SpecModel

Degrees = Annotated[float, Strict(), AllowInfNan(False), Field(ge=-180.0, le=180.0)]
"""A longitude or latitude in degrees (WGS 84), kept as written."""

BBox = tuple[Degrees, Degrees, Degrees, Degrees]
"""``[west, south, east, north]`` in degrees (WGS 84)."""


class OsmArea(SpecModel):
    """The ``osm`` table of a generator config: which extract, and which box of it."""

    file: str = Field(min_length=1, max_length=4_096)
    """Path of the extract (``.osm`` XML or ``.osm.pbf``), relative to the working folder or the
    manifest that names it."""
    bbox: BBox
    """``[west, south, east, north]`` of the scene, in degrees (WGS 84)."""


class OsmSource(SpecModel):
    """Where a scene made from OpenStreetMap came from (``meta.source``)."""

    file: str = Field(min_length=1, max_length=1_000)
    """The extract's file name."""
    bbox: BBox
    """``[west, south, east, north]`` of the scene, in degrees (WGS 84)."""
    projection: str = Field(min_length=1, max_length=1_000)
    """A PROJ string taking longitude and latitude to the scene's x and y in metres (a
    transverse Mercator centred on the box, its south-west corner near the origin)."""
