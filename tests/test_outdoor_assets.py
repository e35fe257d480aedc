"""What the outdoor categories promise beyond the catalog-wide checks of test_assets.py:
where they go, which way they face, how they stand on the ground and how their pieces
sit together (chairs pushed in but never into each other, a shelter open to the road,
a building's footprint filling a lot).
"""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import MultiPoint

from citygen.assets import CATEGORIES, Asset, Box, Cylinder, Part, resolve
from citygen.assets.outdoor import CATEGORIES as OUTDOOR

VARIANTS = 200
MOST_PARTS = 40  # keeps the union mesh of an asset quick to build


def variants(category: str, count: int = VARIANTS) -> list[Asset]:
    return [resolve(f"{category}/{v:04d}") for v in range(count)]


def inside(part: Part, points: np.ndarray) -> np.ndarray:
    """Which ``points`` (n, 3) lie strictly inside the convex ``part`` (by its face planes)."""
    mesh = part.to_trimesh()
    normals = mesh.face_normals
    offsets = np.einsum("ij,ij->i", mesh.triangles[:, 0], normals)
    return (np.asarray(points) @ normals.T - offsets < -1e-9).all(axis=1)


def z_range(part: Part) -> tuple[float, float]:
    z = part.hull_points()[:, 2]
    return float(z.min()), float(z.max())


def size(asset: Asset) -> tuple[float, float]:
    x0, y0, x1, y1 = asset.footprint.bounds
    return x1 - x0, y1 - y0


def test_registered_with_their_place_in_the_street() -> None:
    expected = {
        "bus_stop_shelter": ("curb", {"sidewalk", "curb"}),
        "tree": ("free", {"vegetation", "sidewalk", "plaza"}),
        "bush": ("free", {"vegetation", "plaza"}),
        "bike_rack": ("curb", {"sidewalk", "plaza"}),
        "traffic_cone": ("free", {"sidewalk", "curb", "plaza"}),
        "parked_scooter": ("curb", {"sidewalk", "plaza"}),
        "cafe_table": ("frontage", {"sidewalk", "plaza"}),
        "building": ("lot", {"building"}),
    }
    assert set(OUTDOOR) == set(expected)
    for name, (anchor, kinds) in expected.items():
        assert CATEGORIES[name] is OUTDOOR[name]
        assert (OUTDOOR[name].anchor, set(OUTDOOR[name].zones)) == (anchor, kinds), name
        assert "roadway" not in OUTDOOR[name].zones
    assert OUTDOOR["building"].semantic_class == "building"


@pytest.mark.parametrize("category", sorted(OUTDOOR))
def test_part_counts_stay_modest(category: str) -> None:
    counts = [len(a.parts) for a in variants(category)]
    assert max(counts) <= MOST_PARTS


def test_bus_stop_shelter_is_open_towards_the_road_and_closed_behind() -> None:
    for asset in variants("bus_stop_shelter", 60):
        depth, length = size(asset)
        # walking in from the road (+x) at mid length: nothing in the way from knee to head height
        xs, zs = np.linspace(0.0, depth / 2 + 0.1, 25), np.linspace(0.3, 2.0, 18)
        for y in (0.0, -length / 6, length / 6):
            way_in = np.array([(x, y, z) for x in xs for z in zs])
            for part in asset.parts:
                assert not inside(part, way_in).any(), (asset.id, part)
        # at the back, waist high, the wind meets glass or a post across the middle of the shelter
        behind = np.array([(x, 0.0, 1.2) for x in np.linspace(-depth / 2, -depth / 4, 400)])
        assert any(inside(part, behind).any() for part in asset.parts), asset.id
        # the roof: one part high up covering nearly all of the footprint
        roof = max(asset.parts, key=lambda p: z_range(p)[1])
        assert z_range(roof)[0] > 2.0
        assert roof.footprint().area >= 0.95 * asset.footprint.area


def test_trees_stand_on_a_trunk_at_the_origin_under_a_round_crown() -> None:
    heights = []
    for asset in variants("tree"):
        sx, sy = size(asset)
        assert sx == pytest.approx(sy, abs=1e-3), asset.id  # the crown is as wide both ways
        trunk_foot = np.array([[0.0, 0.0, 0.5]])
        assert any(inside(p, trunk_foot)[0] for p in asset.parts if p.material.name == "wood"), asset.id
        crown = [p for p in asset.parts if p.material.name == "foliage"]
        assert crown and min(z_range(p)[0] for p in crown) >= 0.3
        assert max(z_range(p)[1] for p in crown) == pytest.approx(asset.height)
        heights.append(asset.height)
    assert min(heights) < 5.0 and max(heights) > 11.0  # young trees and big ones


def test_bushes_and_cones_sit_flat_on_the_ground() -> None:
    for category, share in (("bush", 0.05), ("traffic_cone", 0.999)):
        for asset in variants(category, 100):
            on_ground = np.vstack([p.hull_points() for p in asset.parts])
            on_ground = on_ground[on_ground[:, 2] < 1e-9][:, :2]
            contact = MultiPoint(on_ground).convex_hull
            assert contact.area >= share * asset.footprint.area, asset.id


def test_nothing_on_a_cone_reaches_past_its_base() -> None:
    for asset in variants("traffic_cone", 100):
        base = min(asset.parts, key=lambda p: z_range(p)[0] + z_range(p)[1])
        assert shapely.equals_exact(
            shapely.normalize(base.footprint()), shapely.normalize(asset.footprint), 1e-6
        ), asset.id


def test_parked_scooters_stand_on_both_wheels_and_a_stand() -> None:
    lengths = []
    for asset in variants("parked_scooter"):
        touching = [p for p in asset.parts if z_range(p)[0] <= 1e-3]
        assert len(touching) >= 3, asset.id  # two wheels and a kickstand or centre stand
        ys = np.concatenate([p.hull_points()[:, 1] for p in touching])
        assert ys.max() - ys.min() >= 0.78 + 0.2, asset.id  # from wheel to wheel
        sx, sy = size(asset)
        assert sy > sx  # lined up with the curb
        lengths.append(sy)
    assert min(lengths) < 1.25 and max(lengths) > 1.5  # kick scooters and mopeds


def test_cafe_chairs_are_pushed_in_but_never_into_each_other_or_the_table() -> None:
    counts = set()
    for asset in variants("cafe_table"):
        seats = [
            p
            for p in asset.parts
            if isinstance(p, Box)
            and 0.40 <= min(p.size[:2]) <= max(p.size[:2]) <= 0.46
            and 0.40 <= p.pos[2] <= 0.47
        ]
        tops = [p for p in asset.parts if 0.72 <= z_range(p)[1] <= 0.76 and p.footprint().area > 0.25]
        assert len(tops) == 1, asset.id
        top = tops[0]
        counts.add(len(seats))
        for i, a in enumerate(seats):
            assert a.footprint().intersects(top.footprint()), asset.id  # tucked under the table
            for b in seats[i + 1 :]:
                assert a.footprint().intersection(b.footprint()).area < 1e-9, asset.id
        low, high = z_range(top)
        for part in asset.parts:
            lo, hi = z_range(part)
            is_column = isinstance(part, Cylinder) and part.pos[:2] == (0.0, 0.0)
            if part is top or is_column or hi <= low or lo >= high:
                continue
            assert part.footprint().intersection(top.footprint()).area < 1e-9, (asset.id, part)
    assert counts == {2, 3, 4}


def test_buildings_fill_their_lot_from_the_ground_up() -> None:
    shapes = {"L": 0, "stepped": 0, "pitched": 0}
    for asset in variants("building"):
        x0, y0, x1, y1 = asset.footprint.bounds
        assert (x0 + x1, y0 + y1) == pytest.approx((0.0, 0.0), abs=1e-6), asset.id  # centred
        bbox = (x1 - x0) * (y1 - y0)
        assert asset.footprint.area >= 0.5 * bbox, asset.id  # compact: at worst a slim L
        walls = shapely.union_all([p.footprint() for p in asset.parts if z_range(p)[0] < 1e-9])
        assert walls.area >= 0.7 * asset.footprint.area, asset.id  # eaves overhang 0.6 m at most
        # a tower's upper tiers are at least 6 m wide and a storey high; plant rooms at most 5 m wide
        tiers = [p for p in asset.parts if isinstance(p, Box) and min(p.size[:2]) >= 6.0 and p.size[2] >= 2.9]
        shapes["L"] += asset.footprint.area < 0.95 * bbox
        shapes["stepped"] += any(z_range(p)[0] > 3.0 for p in tiers)
        shapes["pitched"] += not isinstance(max(asset.parts, key=lambda p: z_range(p)[1]), Box)
    assert all(count >= 5 for count in shapes.values()), shapes
