"""The asset catalog, tested category by category straight from its registry.

A category added to :data:`citygen.assets.CATEGORIES` is covered by every test
here the day it is added.
"""

from __future__ import annotations

import doctest
import hashlib
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import shapely
import trimesh
from shapely.geometry import Polygon

import citygen.assets
from citygen.assets import CATEGORIES, Asset, UnknownAsset, catalog, categories, parts, resolve
from citygen.spec.surfaces import ZONE_KINDS

ROOT = Path(__file__).resolve().parents[1]
VARIANTS = 50  # distinct variants every category must give
MESHED = 12  # variants whose part and visual meshes are checked (the slow part)
TOL = 1e-6  # m

#: Prints one digest of the parts per asset id given on the command line. The same
#: code computes the digests in this process, so both sides agree by construction.
DIGESTS = """
import hashlib, sys
from citygen.assets import resolve
for asset_id in sys.argv[1:]:
    print(hashlib.sha256(repr(resolve(asset_id).parts).encode()).hexdigest())
"""


def digest(asset: Asset) -> str:
    return hashlib.sha256(repr(asset.parts).encode()).hexdigest()


def variants(category: str, count: int = VARIANTS) -> list[Asset]:
    return [resolve(f"{category}/{v:04d}") for v in range(count)]


def is_convex(mesh: trimesh.Trimesh) -> bool:
    """Closed, consistently wound, and no vertex in front of any face's plane.

    This is the definition trimesh's ``is_convex`` checks; that property needs scipy,
    which is not a citygen dependency.
    """
    if not (mesh.is_watertight and mesh.is_winding_consistent and mesh.volume > 0):
        return False
    normals = mesh.face_normals
    offsets = np.einsum("ij,ij->i", mesh.triangles[:, 0], normals)
    return bool((mesh.vertices @ normals.T - offsets).max() <= 1e-9)


def bodies(mesh: trimesh.Trimesh) -> int:
    """Connected pieces of a mesh (networkx, as trimesh's default engine needs scipy)."""
    pieces = trimesh.graph.connected_components(
        mesh.face_adjacency, nodes=np.arange(len(mesh.faces)), engine="networkx"
    )
    return len(pieces)


every_category = pytest.mark.parametrize("category", categories())


def test_categories_are_sorted_and_registered() -> None:
    assert categories() == tuple(sorted(CATEGORIES))
    expected = {"bench", "trash_bin", "bollard", "planter", "lamp_post", "fire_hydrant"}
    assert expected <= set(categories())


@every_category
def test_category_metadata(category: str) -> None:
    entry = CATEGORIES[category]
    assert entry.semantic_class and entry.zones and entry.zones <= set(ZONE_KINDS)
    assert entry.clearance >= 0
    asset = resolve(f"{category}/0000")
    assert (asset.id, asset.category) == (f"{category}/0000", category)
    assert (asset.semantic_class, asset.zones, asset.clearance) == (
        entry.semantic_class,
        entry.zones,
        entry.clearance,
    )


@every_category
def test_variants_are_distinct(category: str) -> None:
    assert len({digest(a) for a in variants(category)}) == VARIANTS


@every_category
def test_resolve_is_deterministic(category: str) -> None:
    first = variants(category, 5)
    resolve.cache_clear()
    again = variants(category, 5)
    for a, b in zip(first, again, strict=True):
        assert a is not b and a == b
        assert a.footprint.equals_exact(b.footprint, 0.0)


def test_same_parts_in_another_process() -> None:
    ids = [f"{c}/{v:04d}" for c in categories() for v in (0, 1, 9999)]
    env = {**os.environ, "PYTHONHASHSEED": "12345", "PYTHONPATH": str(ROOT)}
    out = subprocess.run(
        [sys.executable, "-c", DIGESTS, *ids], env=env, capture_output=True, text=True, check=True
    )
    assert out.stdout.split() == [digest(resolve(i)) for i in ids]


@every_category
def test_parts_are_convex_and_dressed(category: str) -> None:
    for asset in variants(category, MESHED):
        for part in asset.parts:
            assert isinstance(part.material, parts.Look)
            assert is_convex(part.to_trimesh()), (asset.id, part)


@every_category
def test_visual_mesh_is_one_watertight_solid(category: str) -> None:
    for asset in variants(category, MESHED):
        mesh = asset.visual_mesh()
        assert mesh.is_watertight and mesh.is_winding_consistent, asset.id
        assert bodies(mesh) == 1, f"{asset.id}: parts do not all touch"
        volumes = [p.to_manifold().volume() for p in asset.parts]
        assert max(volumes) - TOL <= mesh.volume <= sum(volumes) + TOL
        assert mesh.bounds[1][2] == pytest.approx(asset.height, abs=TOL)


def test_visual_mesh_is_cached_but_not_shared() -> None:
    asset = resolve("bench/0001")
    mesh = asset.visual_mesh()
    mesh.apply_translation([5.0, 0.0, 0.0])
    assert asset.visual_mesh().bounds[0][0] == pytest.approx(asset.footprint.bounds[0], abs=1e-3)


@every_category
def test_footprint_covers_the_parts(category: str) -> None:
    for asset in variants(category):
        footprint = asset.footprint
        assert isinstance(footprint, Polygon) and footprint.is_valid and footprint.area > 0
        grown = footprint.buffer(TOL)
        for part in asset.parts:
            xy = part.hull_points()[:, :2]
            assert shapely.contains_xy(grown, xy[:, 0], xy[:, 1]).all(), (asset.id, part)
            assert grown.covers(part.footprint()), (asset.id, part)


@every_category
def test_dimensions_within_documented_ranges(category: str) -> None:
    entry = CATEGORIES[category]
    for asset in variants(category, 200):
        x0, y0, x1, y1 = asset.footprint.bounds
        for name, value in (("height", asset.height), ("size_x", x1 - x0), ("size_y", y1 - y0)):
            low, high = getattr(entry, name)
            assert low - TOL <= value <= high + TOL, f"{asset.id}: {name} {value:.4f} m"
        lowest = min(p.hull_points()[:, 2].min() for p in asset.parts)
        assert lowest == pytest.approx(0.0, abs=TOL), f"{asset.id} does not stand on the ground"


@pytest.mark.parametrize(
    "asset_id", ["bench", "bench/12", "nope/0001", "Bench/0001", "bench/00012", "", "bench/0001 "]
)
def test_malformed_ids_raise_unknown_asset(asset_id: str) -> None:
    with pytest.raises(UnknownAsset) as caught:
        resolve(asset_id)
    message = str(caught.value)
    assert repr(asset_id) in message
    assert all(c in message for c in categories())
    assert isinstance(caught.value, ValueError) and isinstance(caught.value, LookupError)
    assert not isinstance(caught.value, KeyError)


@pytest.mark.parametrize("module", [citygen.assets, catalog, parts])
def test_docstring_examples_run(module: object) -> None:
    result = doctest.testmod(module)
    assert result.attempted > 0 and result.failed == 0


# The fast paths of resolve() against the plain formulas they replace, bit for bit.


def plain_part_footprint(part: parts.Part) -> Polygon:
    """A part's footprint as first written: the hull of a multipoint of its outline."""
    hull = shapely.convex_hull(shapely.multipoints(part._outline()))
    if not isinstance(hull, Polygon):
        hull = hull.buffer(1e-6, quad_segs=1)
    return shapely.normalize(hull)


def plain_outline(prints: list[Polygon]) -> Polygon:
    union = shapely.union_all(prints)
    if not isinstance(union, Polygon):
        union = union.convex_hull
    return shapely.normalize(Polygon(union.exterior))


def plain_rod(radius: float, start, end) -> np.ndarray:
    """The rod's vertices with np.cross, np.linalg.norm and np.outer, before rounding."""
    a, b = np.asarray(start, float), np.asarray(end, float)
    axis = b - a
    axis /= np.linalg.norm(axis)
    helper = np.array([0.0, 0.0, 1.0]) if abs(axis[2]) < 0.9 else np.array([1.0, 0.0, 0.0])
    u = np.cross(axis, helper)
    u /= np.linalg.norm(u)
    v = np.cross(axis, u)
    angles = np.arange(parts.SEGMENTS) * (2 * np.pi / parts.SEGMENTS)
    circle = radius * (np.outer(np.cos(angles), u) + np.outer(np.sin(angles), v))
    return np.vstack([a + circle, b + circle])


def wkb(geometry) -> bytes:
    return shapely.to_wkb(geometry)


@every_category
def test_resolve_equals_the_plain_formulas(category: str) -> None:
    """Footprints, base and height as the unvectorised formulas give them, to the bit."""
    for v in range(7000, 7015):
        asset = catalog.resolve.__wrapped__(f"{category}/{v:04d}")  # fresh, not from the cache
        prints = [plain_part_footprint(p) for p in asset.parts]
        zs = [p.hull_points()[:, 2] for p in asset.parts]
        low = [f for f, z in zip(prints, zs, strict=True) if z.min() < catalog.BASE_HEIGHT]
        assert [wkb(f) for f in prints] == [wkb(p.footprint()) for p in asset.parts]
        assert wkb(asset.base) == wkb(plain_outline(low)), asset.id
        assert wkb(asset.footprint) == wkb(plain_outline(prints)), asset.id
        assert asset.height == max(float(z.max()) for z in zs)
        for p in asset.parts:
            z_low, z_high, xy = p.extent()
            assert (z_low, z_high) == (float(p.hull_points()[:, 2].min()), float(p.hull_points()[:, 2].max()))
            assert xy.tolist() == p._outline().tolist()


def test_footprint_is_the_base_unless_a_part_is_high() -> None:
    lamp, bin_ = resolve("lamp_post/0003"), resolve("trash_bin/0003")
    assert lamp.height > catalog.BASE_HEIGHT and lamp.footprint.area > lamp.base.area
    assert bin_.footprint is bin_.base


def test_rod_equals_np_cross_formula() -> None:
    rng = np.random.default_rng(3)
    for k in range(400):
        start = rng.normal(0, 2, 3).round(int(rng.integers(1, 7)))
        axis = rng.normal(0, 1, 3)
        if k % 4 == 0:  # near vertical: the other helper axis, and exactly vertical or horizontal
            axis = np.array([0.0, 0.0, 1.0]) if k % 8 == 0 else axis * [0.05, 0.05, 1.0]
        elif k % 4 == 1:
            axis[2] = 0.0
        radius = float(rng.uniform(0.005, 0.1))
        end = start + axis * rng.uniform(0.01, 3)
        fast = parts.rod(radius, start, end)
        assert fast == parts.ConvexMesh(tuple(map(tuple, plain_rod(radius, start, end).tolist())))
        assert fast.hull_points().tolist() == [list(v) for v in fast.vertices]


def test_unturned_box_outline_is_its_corners() -> None:
    rng = np.random.default_rng(4)
    for _ in range(500):
        size = np.maximum(rng.uniform(0, 5, 3).round(int(rng.integers(1, 7))), 1e-6)
        pos = rng.normal(0, 3, 3).round(int(rng.integers(0, 7))) * (rng.random() < 0.8)
        box = parts.Box(tuple(size), tuple(pos), float(rng.choice([0.0, 0.0, 0.3])))
        assert box._outline().tolist() == box.hull_points()[:, :2].tolist()
        assert box.extent()[:2] == (box.hull_points()[:, 2].min(), box.hull_points()[:, 2].max())


def test_volume_check_agrees_with_the_svd() -> None:
    """The Gram-determinant shortcut never says yes where the SVD says no, flat or nearly."""
    rng = np.random.default_rng(5)
    for k in range(2000):
        n = int(rng.integers(4, 60))
        points = rng.normal(0, float(rng.choice([1e-6, 1e-3, 1.0, 30.0])), (n, 3))
        squash = 10.0 ** -float(rng.uniform(0, 12)) if k % 2 else 1.0
        points[:, int(rng.integers(3))] *= squash  # from solid to flat within rounding
        if k % 5 == 0:
            points[:, 2] = points[:, 0] * 0.5 + points[:, 1] * 2.0  # exactly a plane
        spread = points - points.mean(axis=0)
        expected = bool(np.linalg.svd(spread, compute_uv=False)[-1] >= parts.MIN_SPREAD)
        assert parts._spans_volume(points) == expected, (k, n, squash)


def test_convex_mesh_from_array_equals_the_constructor() -> None:
    rng = np.random.default_rng(6)
    for _ in range(100):
        points = rng.normal(0, 1, (int(rng.integers(4, 40)), 3))
        mesh = parts.convex_mesh(points)
        assert mesh == parts.ConvexMesh(tuple(map(tuple, points.tolist())))
        assert repr(mesh) == repr(parts.ConvexMesh(tuple(map(tuple, points.tolist()))))
        parts.release([mesh])
        assert mesh.hull_points().tolist() == [list(v) for v in mesh.vertices]
    for bad in (np.zeros((5, 3)), np.eye(3), np.array([[0, 0, 0], [1, 0, 0], [0, 1, 0], [np.nan, 0, 1.0]])):
        with pytest.raises(ValueError, match=r"ConvexMesh\.vertices"):
            parts.convex_mesh(bad)
    with pytest.raises(ValueError, match=r"ConvexMesh\.vertices: expected >= 4 points"):
        parts.rod(1e-8, (0, 0, 0), (0, 0, 1))  # too thin to span a volume once rounded
