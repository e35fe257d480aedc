"""Writes the OpenStreetMap extracts the OSM tests and benchmark read: a made-up town.

Self-made data, CC0 (public domain): the streets, buildings and furniture are drawn by this
script on a grid of city blocks placed at an arbitrary spot (near 47.37 N, 8.54 E); they map no
real place. ``python tests/data/osm/make_town.py`` writes ``town.osm`` (XML, 3 x 2 city blocks
of 100 m) and ``town.osm.pbf`` (the same data through pyosmium's writer) beside this file;
:func:`write_town` makes larger grids (the 1 km benchmark's, in a temporary folder).

The town has what a real extract maps: residential streets, a primary road (``lanes``,
``width``), a one-way street, ``sidewalk`` tags, junctions of four and of three streets,
traffic signals and a mid-block crossing on junction and street nodes, a footway crossing,
buildings with ``height`` or ``building:levels`` (rectangles, L shapes and a multipolygon with
a courtyard), a park with a pond, paths, trees, benches and waste baskets, a square with
bollards and bicycle parking, parking, street lamps and a fire hydrant.
"""

from __future__ import annotations

import math
from pathlib import Path

LAT0, LON0 = 47.37, 8.54
#: Metres per degree of latitude and of longitude at LAT0 (the sphere is close enough here:
#: the tests read positions back through the file, never through these numbers).
M_LAT = 111_320.0
M_LON = M_LAT * math.cos(math.radians(LAT0))


def lonlat(x: float, y: float) -> tuple[float, float]:
    """Degrees of the town's point ``(x, y)`` metres east and north of its origin."""
    return round(LON0 + x / M_LON, 8), round(LAT0 + y / M_LAT, 8)


class _Map:
    def __init__(self) -> None:
        self.nodes: list[str] = []
        self.ways: list[str] = []
        self.relations: list[str] = []
        self.at: dict[tuple[float, float], int] = {}
        self.next = {"n": 1, "w": 1, "r": 1}

    def _id(self, kind: str) -> int:
        self.next[kind] += 1
        return self.next[kind] - 1

    def node(self, x: float, y: float, tags: dict | None = None) -> int:
        key = (round(x, 3), round(y, 3))
        if key in self.at and not tags:
            return self.at[key]
        nid = self._id("n")
        lon, lat = lonlat(x, y)
        body = "".join(f'<tag k="{k}" v="{v}"/>' for k, v in (tags or {}).items())
        self.nodes.append(f' <node id="{nid}" version="1" lat="{lat}" lon="{lon}">{body}</node>')
        if not tags:
            self.at[key] = nid
        return nid

    def way(self, points, tags: dict, closed: bool = False) -> int:
        refs = [self.node(x, y) for x, y in points]
        if closed:
            refs.append(refs[0])
        return self.way_of(refs, tags)

    def way_of(self, refs, tags: dict) -> int:
        wid = self._id("w")
        body = "".join(f'<nd ref="{r}"/>' for r in refs) + "".join(
            f'<tag k="{k}" v="{v}"/>' for k, v in tags.items()
        )
        self.ways.append(f' <way id="{wid}" version="1">{body}</way>')
        return wid

    def multipolygon(self, outer, inner, tags: dict) -> int:
        wo, wi = self.way(outer, {}, closed=True), self.way(inner, {}, closed=True)
        rid = self._id("r")
        body = f'<member type="way" ref="{wo}" role="outer"/><member type="way" ref="{wi}" role="inner"/>'
        body += "".join(f'<tag k="{k}" v="{v}"/>' for k, v in {"type": "multipolygon", **tags}.items())
        self.relations.append(f' <relation id="{rid}" version="1">{body}</relation>')
        return rid

    def xml(self, extent) -> str:
        (w, s), (e, n) = lonlat(*extent[:2]), lonlat(*extent[2:])
        head = f' <bounds minlat="{s}" minlon="{w}" maxlat="{n}" maxlon="{e}"/>'
        top = [
            "<?xml version='1.0' encoding='UTF-8'?>",
            '<osm version="0.6" generator="citygen make_town.py">',
        ]
        return "\n".join([*top, head, *self.nodes, *self.ways, *self.relations, "</osm>", ""])


def _rect(x0, y0, x1, y1):
    return [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]


def _streets(m: _Map, nx: int, ny: int, spacing: float, reach: float) -> None:
    """Streets along x = 0, spacing, ... and y = 0, spacing, ..., running ``reach`` past the grid."""
    top, right = ny * spacing, nx * spacing
    for i in range(nx + 1):
        x = i * spacing
        tags = {"highway": "residential", "name": f"Street {i}"}
        if i == 0:
            tags["sidewalk"] = "right"
        if i == 2:
            tags.update({"highway": "tertiary", "oneway": "yes", "lanes": "1", "width": "4.5"})
        end = top if i == 1 else top + reach  # street 1 ends at the top street: a T
        ys = [-reach, *(j * spacing for j in range(ny + 1) if j * spacing < end), end]
        m.way([(x, y) for y in ys], tags)
    for j in range(ny + 1):
        y = j * spacing
        tags = {"highway": "residential", "name": f"Avenue {j}"}
        if j == 1:
            tags.update({"highway": "primary", "lanes": "4", "width": "14", "sidewalk": "both"})
        xs = [-reach, *(i * spacing for i in range(nx + 1)), right + reach]
        if j == 0 and nx >= 2:  # a mid-block crossing node on the first avenue
            xs.insert(3, 1.5 * spacing)
        m.way([(x, y) for x in xs], tags)


def _block(m: _Map, i: int, j: int, spacing: float, dense: bool = False) -> None:
    """What stands in city block (i, j), whose south-west street corner is at (x, y)."""
    x, y = i * spacing, j * spacing
    s = spacing / 100.0
    kind = (i + 2 * j) % 4
    if (i, j) == (0, 0) or (kind == 3 and (i + j) % 3 == 0):  # a park with a pond, paths, trees
        m.way(_rect(x + 10 * s, y + 10 * s, x + 90 * s, y + 90 * s), {"leisure": "park"}, closed=True)
        m.way(_rect(x + 60 * s, y + 60 * s, x + 80 * s, y + 75 * s), {"natural": "water"}, closed=True)
        m.way(
            [(x + 10 * s, y + 50 * s), (x + 50 * s, y + 50 * s), (x + 50 * s, y + 10 * s)],
            {"highway": "footway"},
        )
        for k in range(4):
            m.node(x + (20 + 20 * k) * s, y + 30 * s, {"natural": "tree"})
        m.node(x + 30 * s, y + 55 * s, {"amenity": "bench"})
        m.node(x + 45 * s, y + 56 * s, {"amenity": "waste_basket"})
        return
    if kind == 1:  # a square with bollards, bicycle parking and a bench
        m.way(
            _rect(x + 12 * s, y + 12 * s, x + 88 * s, y + 88 * s),
            {"highway": "pedestrian", "area": "yes", "place": "square"},
            closed=True,
        )
        for k in range(3):
            m.node(x + (40 + 5 * k) * s, y + 20 * s, {"barrier": "bollard"})
        m.node(x + 50 * s, y + 60 * s, {"amenity": "bicycle_parking"})
        m.node(x + 30 * s, y + 70 * s, {"amenity": "bench"})
        return
    if dense:  # terraced houses all round the block, 10 m wide, 12 m deep, a yard inside
        _terrace(m, x, y, s)
        return
    # Buildings: three along the south side, an L and a courtyard block or parking behind.
    for k in range(3):
        tags = (
            {"building": "yes", "height": f"{8 + 3 * k}"}
            if k != 1
            else {"building": "house", "building:levels": "3"}
        )
        m.way(_rect(x + (14 + 25 * k) * s, y + 14 * s, x + (34 + 25 * k) * s, y + 38 * s), tags, closed=True)
    ell = [
        (x + 14 * s, y + 50 * s),
        (x + 44 * s, y + 50 * s),
        (x + 44 * s, y + 62 * s),
        (x + 26 * s, y + 62 * s),
        (x + 26 * s, y + 86 * s),
        (x + 14 * s, y + 86 * s),
    ]
    m.way(ell, {"building": "apartments", "building:levels": "5"}, closed=True)
    if kind == 2:
        m.way(_rect(x + 52 * s, y + 50 * s, x + 86 * s, y + 86 * s), {"amenity": "parking"}, closed=True)
    else:
        m.multipolygon(
            _rect(x + 52 * s, y + 50 * s, x + 86 * s, y + 86 * s),
            _rect(x + 62 * s, y + 60 * s, x + 76 * s, y + 76 * s),
            {"building": "commercial", "height": "16.5"},
        )


def _terrace(m: _Map, x: float, y: float, s: float) -> None:
    """Terraced houses sharing their side walls along the four sides of a city block."""
    a, b, depth, wide = x + 12 * s, x + 88 * s, 12 * s, 10 * s
    count = int((b - a) // wide)
    for k in range(count):
        u0, u1 = a + k * wide, a + (k + 1) * wide
        levels = {"building": "house", "building:levels": str(2 + k % 3)}
        m.way(_rect(u0, y + 12 * s, u1, y + 12 * s + depth), levels, closed=True)  # south side
        m.way(_rect(u0, y + 88 * s - depth, u1, y + 88 * s), levels, closed=True)  # north side
    for k in range(count - 2):
        v0, v1 = y + 12 * s + depth + k * wide, y + 12 * s + depth + (k + 1) * wide
        if v1 > y + 88 * s - depth + 1e-6:
            break
        tags = {"building": "house", "height": f"{7 + k % 4}"}
        m.way(_rect(x + 12 * s, v0, x + 12 * s + depth, v1), tags, closed=True)  # west side
        m.way(_rect(x + 88 * s - depth, v0, x + 88 * s, v1), tags, closed=True)  # east side


def _furniture(m: _Map, nx: int, ny: int, spacing: float) -> None:
    """Street furniture on the sidewalks of the residential avenues, signals, crossings."""
    for j in range(ny + 1):
        if j == 1:
            continue  # the primary road: its signals and crossing below
        for i in range(nx):
            x, y = i * spacing + 30, j * spacing
            m.node(x, y + 4.8, {"amenity": "bench"})
            m.node(x + 20, y - 5.2, {"highway": "street_lamp"})
            m.node(x + 35, y + 5.0, {"natural": "tree"})
    m.node(spacing + 30, 4.5, {"emergency": "fire_hydrant"})
    m.node(spacing + 8, -4.6, {"barrier": "bollard"})


def write_town(
    path: str | Path,
    nx: int = 3,
    ny: int = 2,
    spacing: float = 100.0,
    reach: float = 40.0,
    dense: bool = False,
) -> Path:
    """Write a town of ``nx`` x ``ny`` city blocks of ``spacing`` metres as OSM XML to ``path``;
    ``dense``: the built blocks are rows of terraced houses all round (a city centre's density)."""
    m = _Map()
    _streets(m, nx, ny, spacing, reach)
    # Signals on two junctions of the primary road.
    _tag_node(m, (spacing, spacing), {"highway": "traffic_signals"})
    if nx >= 2:
        _tag_node(m, (2 * spacing, spacing), {"highway": "traffic_signals"})
    _tag_node(m, (1.5 * spacing, 0.0), {"highway": "crossing", "crossing": "zebra"})
    # A footway crossing the primary road half way between its first two junctions.
    m.way(
        [(spacing / 2, spacing - 12), (spacing / 2, spacing + 12)],
        {"highway": "footway", "footway": "crossing"},
    )
    for i in range(nx):
        for j in range(ny):
            _block(m, i, j, spacing, dense)
    _furniture(m, nx, ny, spacing)
    path = Path(path)
    path.write_text(m.xml((-reach - 10, -reach - 10, nx * spacing + reach + 10, ny * spacing + reach + 10)))
    return path


def _tag_node(m: _Map, at: tuple[float, float], tags: dict) -> None:
    """Tag the untagged node at ``at`` (a junction) in place."""
    nid = m.at[(round(at[0], 3), round(at[1], 3))]
    for k, line in enumerate(m.nodes):
        if line.startswith(f' <node id="{nid}" '):
            body = "".join(f'<tag k="{a}" v="{b}"/>' for a, b in tags.items())
            m.nodes[k] = line.replace("></node>", f">{body}</node>")


#: The corner's box (m east and north of the origin): west, south, east, north.
CORNER_BOX = (-60.0, -45.0, 100.0, 45.0)


def write_corner(path: str | Path) -> Path:
    """Write the corner: what a real map puts where a scene's streets are drawn, and signals
    away from junction nodes. Two junctions on Main Street (y = 0, a
    residential street drawn 6 m wide): A with Cross Street (x = 0), B with Signal Street
    (x = 80).

    - a tree 2.9 m and a bench 3.2 m from Main Street's centre line (on its drawn roadway and
      curb), a tree in the rounded corner of A, a tree where A's crosswalk lands (its curb
      ramp), a tree 0.35 m off a cycleway's centre line and a tree in a parking lot;
    - B signalised by a signal node on Main Street 18 m before it, with a signalised
      crossing 12 m before it; a signalised crossing mid-block on Cross Street; a signal node
      mid-block on Signal Street 35 m from B, with no crossing mapped.
    """
    m = _Map()
    main = {"highway": "residential", "name": "Main Street", "sidewalk:width": "3.5"}
    m.way([(-70, 0), (0, 0), (62, 0), (68, 0), (80, 0), (110, 0)], main)
    m.way([(0, -55), (0, 0), (0, 30), (0, 55)], {"highway": "residential", "name": "Cross Street"})
    m.way([(80, -55), (80, -35), (80, 0), (80, 55)], {"highway": "residential", "name": "Signal Street"})
    _tag_node(m, (62, 0), {"highway": "traffic_signals"})
    _tag_node(m, (68, 0), {"highway": "crossing", "crossing": "traffic_signals"})
    _tag_node(m, (0, 30), {"highway": "crossing", "crossing": "traffic_signals"})
    _tag_node(m, (80, -35), {"highway": "traffic_signals"})
    m.way([(20, 20), (50, 20)], {"highway": "cycleway"})
    m.way(_rect(20, -40, 50, -20), {"amenity": "parking"}, closed=True)
    for x, y, tags in (
        (25.0, 2.9, {"natural": "tree"}),
        (-30.0, -3.2, {"amenity": "bench"}),
        (3.6, 3.6, {"natural": "tree"}),
        (7.2, 4.2, {"natural": "tree"}),
        (35.0, 20.35, {"natural": "tree"}),
        (35.0, -30.0, {"natural": "tree"}),
    ):
        m.node(x, y, tags)
    w, s_, e, n = CORNER_BOX
    path = Path(path)
    path.write_text(m.xml((w - 20, s_ - 20, e + 20, n + 20)))
    return path


def to_pbf(xml: str | Path, pbf: str | Path) -> Path:
    """The same data as ``xml`` written as ``.osm.pbf`` by pyosmium's writer."""
    import osmium

    pbf = Path(pbf)
    pbf.unlink(missing_ok=True)
    with osmium.SimpleWriter(str(pbf)) as writer:
        for obj in osmium.FileProcessor(str(xml)):
            writer.add(obj)
    return pbf


if __name__ == "__main__":
    here = Path(__file__).parent
    to_pbf(write_town(here / "town.osm"), here / "town.osm.pbf")
    write_corner(here / "corner.osm")
