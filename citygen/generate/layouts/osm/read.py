"""Reading an OpenStreetMap extract on disk (``.osm`` XML, ``.osm.pbf``) with pyosmium.

pyosmium (the Python binding of libosmium, the library behind osmium-tool and most OSM
software) reads both formats from one call, resolves way node locations, and assembles
areas from closed ways and multipolygon relations (a building with a courtyard, a park made
of several rings), which is what a scene needs and what hand-written XML parsing gets wrong.
It never touches the network.

:func:`read_extract` keeps only what a scene uses and only near the box: tagged nodes
(furniture, trees, signals, crossings), highway ways (streets, footways, paths) and areas
(buildings, parks, plazas, parking, water), their coordinates in degrees. Everything else in
the file is streamed past, so memory grows with the box, not with the extract.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from citygen.errors import SpecError

#: Tags of the nodes a scene uses (furniture, trees, signals, crossings).
NODE_KEYS = ("amenity", "natural", "barrier", "highway", "emergency", "leisure", "advertising", "railway")
#: Tags of the areas a scene uses.
AREA_KEYS = (
    "building",
    "landuse",
    "leisure",
    "natural",
    "amenity",
    "place",
    "highway",
    "area:highway",
    "waterway",
)
#: Margin kept around the box, in degrees of latitude (about 110 m), so streets crossing its
#: edge keep their shape and junctions just outside it their arms.
MARGIN_DEG = 0.001


@dataclass(frozen=True)
class Feature:
    """One thing on the map: its OSM id (``n123``, ``w45``, ``r6``), tags and coordinates."""

    id: str
    tags: dict[str, str]
    coords: tuple = ()
    """A node: ``(lon, lat)``; a way: ``((lon, lat), ...)`` with ``nodes`` its node ids; an area:
    its rings ``(outer, (holes...))`` per polygon."""
    nodes: tuple[int, ...] = ()


@dataclass
class Extract:
    """What a box of an extract holds, in degrees."""

    nodes: list[Feature] = field(default_factory=list)
    ways: list[Feature] = field(default_factory=list)
    areas: list[Feature] = field(default_factory=list)
    extent: tuple[float, float, float, float] | None = None
    """``(west, south, east, north)`` of all the file's data (its header's box when it has one)."""


def read_extract(path: str | Path, bbox: tuple[float, float, float, float], option: str = "--osm") -> Extract:
    """The nodes, highway ways and areas of ``path`` near ``bbox`` (see the module docstring).

    Raises :class:`~citygen.errors.SpecError` (one line naming the file) when it is missing or
    not an OpenStreetMap file.
    """
    import osmium  # only where a real place is read

    path = Path(path)
    if not path.is_file():
        raise SpecError(
            f"{option}: expected an OpenStreetMap file (.osm, .osm.pbf), got {str(path)!r}: no such file"
        )
    west, south, east, north = bbox
    pad = MARGIN_DEG / max(math.cos(math.radians((south + north) / 2)), 0.1)
    near = (west - pad, south - MARGIN_DEG, east + pad, north + MARGIN_DEG)
    out = Extract()
    lo = [math.inf, math.inf]
    hi = [-math.inf, -math.inf]
    try:
        header = osmium.io.Reader(str(path), osmium.osm.osm_entity_bits.NOTHING).header()
        hbox = header.box()
        if hbox.valid():
            out.extent = (hbox.bottom_left.lon, hbox.bottom_left.lat, hbox.top_right.lon, hbox.top_right.lat)
        processor = osmium.FileProcessor(str(path)).with_locations().with_areas()
        for obj in processor:
            if isinstance(obj, osmium.osm.Node):
                loc = obj.location
                if not loc.valid():
                    continue
                lon, lat = loc.lon, loc.lat
                lo = [min(lo[0], lon), min(lo[1], lat)]
                hi = [max(hi[0], lon), max(hi[1], lat)]
                if obj.tags and _inside(lon, lat, near) and any(k in obj.tags for k in NODE_KEYS):
                    out.nodes.append(Feature(f"n{obj.id}", dict(obj.tags), (lon, lat)))
            elif isinstance(obj, osmium.osm.Way):
                if "highway" not in obj.tags or obj.tags.get("area") == "yes":
                    continue
                # A way cut by the extract's edge references nodes the file does not hold (no
                # location): it keeps the nodes it has, each beside its own point.
                kept = [(n.ref, (n.lon, n.lat)) for n in obj.nodes if n.location.valid()]
                pts = [p for _, p in kept]
                if len(pts) >= 2 and any(_inside(x, y, near) for x, y in pts):
                    out.ways.append(
                        Feature(f"w{obj.id}", dict(obj.tags), tuple(pts), tuple(ref for ref, _ in kept))
                    )
            elif isinstance(obj, osmium.osm.Area):
                if not any(k in obj.tags for k in AREA_KEYS):
                    continue
                polys = []
                for outer in obj.outer_rings():
                    ring = tuple((n.lon, n.lat) for n in outer)
                    holes = tuple(tuple((n.lon, n.lat) for n in inner) for inner in obj.inner_rings(outer))
                    polys.append((ring, holes))
                if any(_spans(ring, near) for ring, _ in polys):
                    kind = "w" if obj.from_way() else "r"
                    out.areas.append(Feature(f"{kind}{obj.orig_id()}", dict(obj.tags), tuple(polys)))
    except RuntimeError as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise SpecError(
            f"{option}: expected an OpenStreetMap file (.osm XML or .osm.pbf), got {str(path)!r}: {reason}"
        ) from None
    if out.extent is None and lo[0] <= hi[0]:
        out.extent = (lo[0], lo[1], hi[0], hi[1])
    return out


def _inside(lon: float, lat: float, box: tuple[float, float, float, float]) -> bool:
    return box[0] <= lon <= box[2] and box[1] <= lat <= box[3]


def _spans(ring, box: tuple[float, float, float, float]) -> bool:
    """Whether a ring's extent overlaps the box (a park larger than the box, around it)."""
    xs, ys = [p[0] for p in ring], [p[1] for p in ring]
    return min(xs) <= box[2] and max(xs) >= box[0] and min(ys) <= box[3] and max(ys) >= box[1]
