"""Flat ground in MJCF: convex slabs per zone on every level piece of ground (so friction
is exact per zone), the apron around the scene and the terrain's features as boxes; the
other tiles are :mod:`citygen.exporters.mjcf.heightfield`'s."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import shapely
from shapely.geometry import Polygon
from shapely.geometry import box as rect

from citygen.exporters.mjcf.builder import DEFAULT_FRICTION, FLOOR, GROUND_RGBA, ZONE_RGBA, Builder, friction
from citygen.exporters.mjcf.heightfield import hfield_plan, level, own_friction, shaped_tiles
from citygen.exporters.mjcf.text import nums
from citygen.geometry.convex import as_rectangle, convex_pieces, polygons
from citygen.geometry.features import feature_boxes
from citygen.geometry.terrain import MIN_THICKNESS
from citygen.geometry.tiles import tile_kind
from citygen.spec.surfaces import FRICTION
from citygen.spec.terrain import peak

#: Default of the ``apron`` option: width (m) of the flat ground around the scene.
DEFAULT_APRON = 20.0
_OUTSIDE_RGBA = (0.8, 0.8, 0.78, 1.0)


def _slab(b: Builder, parent: ET.Element, name: str, ring: np.ndarray, top: float, mu: float, mat: str):
    """One convex piece of flat ground from the floor up to ``top``: a box or a mesh prism."""
    bottom = b.floor
    box = as_rectangle(ring)
    attrs = {"name": name, "class": "static", "material": mat, "friction": friction(mu)}
    if box is not None:
        (cx, cy), length, width, yaw = box
        attrs |= {"type": "box", "pos": nums((cx, cy, (top + bottom) / 2))}
        attrs["size"] = nums((length / 2, width / 2, (top - bottom) / 2))
        if abs(yaw) > 1e-12:
            attrs["euler"] = nums((0, 0, yaw))
        ET.SubElement(parent, "geom", **attrs)
        return
    n = len(ring)
    verts = np.concatenate([np.c_[ring, np.full(n, bottom)], np.c_[ring, np.full(n, top)]])
    ET.SubElement(b.asset, "mesh", name=name, vertex=nums(verts))
    ET.SubElement(parent, "geom", type="mesh", mesh=name, **attrs)


def _zone_shapes(b: Builder) -> list[Polygon]:
    out = []
    for zone in b.scene.zones:
        poly = Polygon(zone.polygon, zone.holes)
        out.append(poly if poly.is_valid else shapely.make_valid(poly))
    return out


def add_ground(b: Builder) -> None:
    """Zone slabs on all flat ground, the apron, stair boxes and heightfields."""
    scene, terrain = b.scene, b.scene.terrain
    (bx0, by0), (bx1, by1) = scene.bounds.min, scene.bounds.max
    grid = None
    shaped: list[int] = []
    plan: dict[int, int] = {}
    if terrain is not None:
        # The heightfields' plan first: a resolution too fine for the sample limit fails here,
        # before the city's slabs are built (the runner retries coarser on that error).
        shaped = [k for k, tile in enumerate(terrain.tiles) if not level(tile)]
        plan = hfield_plan(b, shaped)  # {} when no tile is a heightfield
        s = terrain.tile_size
        ox, oy = terrain.origin
        grid = rect(ox, oy, ox + terrain.cols * s, oy + terrain.rows * s)
        gx0, gy0, gx1, gy1 = grid.bounds
        bx0, by0, bx1, by1 = min(bx0, gx0), min(by0, gy0), max(bx1, gx1), max(by1, gy1)
        lows = [
            t.height + min(0.0, peak(t, s))
            for t in terrain.tiles
            if level(t) or tile_kind(t).boxes is not None
        ]
        b.floor = min(FLOOR, min(lows, default=0.0) - MIN_THICKNESS)
    scene_rect = rect(bx0, by0, bx1, by1)
    # Flat areas by (height, own friction), in a fixed order: outside the grid first.
    areas: dict[tuple[float, float | None], list[Polygon]] = {
        (0.0, None): [scene_rect.difference(grid) if grid is not None else scene_rect]
    }
    if terrain is not None:
        s = terrain.tile_size
        for k, tile in enumerate(terrain.tiles):
            if level(tile):
                r, c = divmod(k, terrain.cols)
                x, y = terrain.origin[0] + c * s, terrain.origin[1] + r * s
                areas.setdefault((tile.height, own_friction(tile)), []).append(rect(x, y, x + s, y + s))
    zones = _zone_shapes(b)
    tree = shapely.STRtree(zones)
    counters: dict[str, int] = {}

    def name_of(prefix: str) -> str:
        k = counters.get(prefix, 0)
        counters[prefix] = k + 1
        return f"{prefix}:{k}"

    for (height, own), squares in areas.items():
        area = shapely.union_all(squares) if len(squares) > 1 else squares[0]
        if area.is_empty:
            continue
        covered = []
        for zi in sorted(tree.query(area, predicate="intersects").tolist()):
            zone = scene.zones[zi]
            piece = zones[zi].intersection(area)
            covered.append(piece)
            mat = b.material(f"zone:{zone.kind}", ZONE_RGBA[zone.kind])
            mu = own if own is not None else zone.mu
            for poly in polygons(piece):
                for ring in convex_pieces(poly):
                    _slab(b, b.world, name_of(f"zone:{zone.kind}:{zone.id}"), ring, height, mu, mat)
        rest = area.difference(shapely.union_all(covered)) if covered else area
        mat = b.material("ground", GROUND_RGBA)
        for poly in polygons(rest):
            for ring in convex_pieces(poly):
                mu = own if own is not None else DEFAULT_FRICTION
                _slab(b, b.world, name_of("zone:none:ground"), ring, height, mu, mat)
    if b.apron > 0:
        m = b.apron
        mat = b.material("outside", _OUTSIDE_RGBA)
        for x0, y0, x1, y1 in (
            (bx0 - m, by0 - m, bx1 + m, by0),
            (bx0 - m, by1, bx1 + m, by1 + m),
            (bx0 - m, by0, bx0, by1),
            (bx1, by0, bx1 + m, by1),
        ):
            ring = np.array([[x0, y0], [x1, y0], [x1, y1], [x0, y1]])
            _slab(b, b.world, name_of("zone:none:outside"), ring, 0.0, DEFAULT_FRICTION, mat)
    if terrain is not None:
        shaped_tiles(b, zones, tree, shaped, plan)
        _features(b)


def _features(b: Builder) -> None:
    """Each terrain feature as oriented boxes (:func:`~citygen.geometry.features.feature_boxes`):
    ``terrain:<feature kind>:<feature id>:<k>``, with its material's friction."""
    for f in b.scene.terrain.features or ():
        material = f.material or "concrete"
        mat = b.material(f"terrain:{material}", ZONE_RGBA["plaza" if material == "paving_stone" else "curb"])
        for k, (centre, half, yaw, pitch) in enumerate(feature_boxes(f)):
            # Yaw about z, then the pitch that raises the box's +x end (about its -y).
            cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(pitch / 2), math.sin(pitch / 2)
            quat = (cy * cp, sy * sp, -cy * sp, sy * cp)
            ET.SubElement(
                b.world, "geom", name=f"terrain:{f.kind}:{f.id}:{k}", type="box", pos=nums(centre),
                size=nums(half), quat=nums(quat), **{"class": "static"}, material=mat,
                friction=friction(FRICTION[material]),
            )  # fmt: skip
