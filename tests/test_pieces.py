"""The terrain as convex pieces (citygen.geometry.pieces): their tops are the ground of
``height_at`` (exactly for flat, stair and slope tiles, within the tolerance for rough
ones), and every prism is a closed convex mesh, what Genesis needs to keep it as it is."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from scipy.spatial.transform import Rotation

from citygen.geometry.pieces import ROUGH_TOLERANCE, prism_mesh, rpy_quat, tile_pieces
from citygen.geometry.terrain import tile_height
from citygen.spec.terrain import FlatTile, RoughTile, SlopeTile, StairTile

S = 2.5
TILES = {
    "flat": FlatTile(kind="flat", height=0.3),
    "stairs": StairTile(kind="stair", step_height=0.15, step_count=3, ascent="-y"),
    "stair pit": StairTile(kind="stair", step_height=0.1, step_count=2, shape="pit", height=0.5),
    "slope": SlopeTile(kind="slope", angle=0.2, ascent="-x", height=0.1),
    "slope pyramid": SlopeTile(kind="slope", angle=0.3, shape="pyramid"),
    "slope pit": SlopeTile(kind="slope", angle=0.3, shape="pit", height=0.4),
    "rough": RoughTile(kind="rough", amplitude=0.08, scale=0.5, seed=7, height=0.2),
}


def solid(pieces) -> trimesh.Trimesh:
    meshes = []
    for centre, half, rpy in pieces.boxes:
        transform = np.eye(4)
        transform[:3, :3] = Rotation.from_euler("xyz", rpy).as_matrix()  # URDF's fixed axes
        transform[:3, 3] = centre
        meshes.append(trimesh.creation.box(extents=2 * half, transform=transform))
    for top in pieces.prisms:
        meshes.append(trimesh.Trimesh(*prism_mesh(top, pieces.bottom), process=False))
    return trimesh.util.concatenate(meshes)


def tops(mesh: trimesh.Trimesh, xy: np.ndarray) -> np.ndarray:
    """The highest point of ``mesh`` above each point (rays from above)."""
    origins = np.c_[xy, np.full(len(xy), 50.0)]
    hits, ray, _ = mesh.ray.intersects_location(origins, np.tile([0.0, 0.0, -1.0], (len(xy), 1)))
    out = np.full(len(xy), -np.inf)
    np.maximum.at(out, ray, hits[:, 2])
    return out


@pytest.mark.parametrize("name", list(TILES))
def test_the_pieces_tops_are_the_ground(name):
    tile = TILES[name]
    pieces = tile_pieces(tile, S, floor=-1.0)
    xy = np.random.default_rng(3).uniform(0.02, S - 0.02, size=(600, 2))
    off = tops(solid(pieces), xy) - tile_height(tile, S, xy[:, 0], xy[:, 1])
    if name == "rough":
        assert pieces.error <= ROUGH_TOLERANCE
        # Between the samples and where widened cells overlap, a little more.
        assert np.abs(off).max() <= 2 * ROUGH_TOLERANCE
        assert np.mean(np.abs(off) <= ROUGH_TOLERANCE) > 0.95
    else:
        assert np.abs(off).max() < 1e-6, name
    assert solid(pieces).bounds[0][2] <= -1.0 + 1e-9  # down to the floor


def test_prisms_are_closed_convex_meshes():
    for name in ("slope", "slope pyramid", "slope pit"):
        pieces = tile_pieces(TILES[name], S)
        assert len(pieces.prisms) == (1 if name == "slope" else 5)
        for top in pieces.prisms:
            mesh = trimesh.Trimesh(*prism_mesh(top, pieces.bottom), process=False)
            assert mesh.is_watertight and mesh.is_winding_consistent and mesh.is_convex and mesh.volume > 0


def test_a_coarser_tolerance_takes_fewer_pieces_and_a_gentle_tile_one():
    tile = TILES["rough"]
    counts = [len(tile_pieces(tile, S, tolerance=t)) for t in (0.005, 0.01, 0.03)]
    assert counts[0] > counts[1] > counts[2] > 1
    assert len(tile_pieces(tile, S, tolerance=0.1)) == 1  # bumps within the tolerance: a box
    with pytest.raises(ValueError, match="tolerance"):
        tile_pieces(tile, S, tolerance=0.0)


def test_quaternions_are_the_roll_pitch_yaw_rotations():
    rpy = np.array([[0.1, -0.2, 0.3], [0.0, 0.4, 0.0]])
    wxyz = rpy_quat(rpy)
    xyzw = Rotation.from_euler("xyz", rpy).as_quat()
    np.testing.assert_allclose(np.abs((wxyz[:, [1, 2, 3, 0]] * xyzw).sum(axis=1)), 1.0, atol=1e-12)


def test_as_rectangle_is_its_numpy_reference_to_the_bit():
    """convex.as_rectangle (plain Python) gives as_rectangle_numpy's centre, sides and yaw to
    the bit, and None alike: rotated and axis-aligned rectangles, rounded corners, slightly
    skewed ones, flat and empty ones, signed zeros."""
    import math
    import warnings

    from citygen.geometry.convex import as_rectangle, as_rectangle_numpy

    rng = np.random.default_rng(0)
    for k in range(3000):
        c, (length, width), yaw = rng.uniform(-500, 500, 2), rng.uniform(0, 20, 2), rng.uniform(-4, 4)
        if k % 5 == 0:
            yaw = int(rng.integers(-4, 5)) * math.pi / 2
        if k % 7 == 0:
            width = 0.0
        if k % 11 == 0:
            length = width = 0.0
        half = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * np.array([length, width]) / 2
        ring = half @ np.array([[math.cos(yaw), math.sin(yaw)], [-math.sin(yaw), math.cos(yaw)]]) + c
        if k % 3 == 0:
            ring = np.round(ring, 4)
        if k % 13 == 0:
            ring[1] += rng.normal(0, 1e-6, 2)
        if k % 17 == 0:
            ring = -ring * 0.0
        ring = np.roll(ring, int(rng.integers(4)), axis=0)
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numpy's 0/0 on a flat ring
            got, want = as_rectangle(ring), as_rectangle_numpy(ring)
        assert (got is None) == (want is None)
        if got is not None:
            assert got[0].tobytes() == want[0].tobytes()
            assert [(v, math.copysign(1, v)) for v in got[1:]] == [
                (float(v), math.copysign(1, float(v))) for v in want[1:]
            ]
    assert as_rectangle(np.zeros((3, 2))) is None
