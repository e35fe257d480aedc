"""Terrain geometry: height_at, tile solids and heightfields agree with the spec and each other.

The central property (the issue's "done" criterion): along any straight line inside a
terrain whose neighbours agree on their edges, heights sampled 1 cm apart never jump by
more than the largest stair riser, beyond what the smooth parts climb in 1 cm.
"""

from __future__ import annotations

import importlib.util
import math

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import citygen
from citygen.geometry import terrain as geo
from citygen.geometry.terrain import (
    height_at,
    heightfield,
    max_slope,
    max_step,
    terrain_mesh,
    tile_boxes,
    tile_height,
    tile_mesh,
)
from citygen.spec import TILE_TYPES, FlatTile, RoughTile, Scene, SlopeTile, StairTile, Terrain
from citygen.spec import terrain as spec_terrain
from citygen.spec.base import quantize
from citygen.spec.terrain import SIDES, edge_profile, profiles_match, rise
from tests.conftest import ROOT
from tests.strategies import tiles as any_tile

SIZE = 2.5
ASCENTS = ("+x", "-x", "+y", "-y")
EDGE_TOL = 1e-3  # neighbours agree on edge heights within this (profiles_match's default)
TILE_CLASSES = {t.model_fields["kind"].annotation.__args__[0]: t for t in TILE_TYPES}


def example(kind: str, ascent: str = "+x", height: float = 0.3, shape: str | None = None) -> geo.AnyTile:
    """One tile of each kind, with parameters like the generator's."""
    cls = TILE_CLASSES[kind]
    params = {
        "flat": {},
        "slope": {"angle": 0.2, "ascent": ascent},
        "stair": {"step_height": 0.15, "step_count": 4, "ascent": ascent},
        "rough": {"amplitude": 0.08, "scale": 0.5, "seed": 11},
    }[kind]
    if shape is not None:
        params["shape"] = shape
    return cls(kind=kind, height=height, **params)


def _variants(cls) -> list[tuple[str, str, str | None]]:
    """Every ascent of a flight and every shape (pyramid, pit) its spec model allows."""
    kind = cls.model_fields["kind"].annotation.__args__[0]
    out = [(kind, a, None) for a in (ASCENTS if "ascent" in cls.model_fields else ("+x",))]
    if "shape" in cls.model_fields:
        out += [(kind, "+x", shape) for shape in ("pyramid", "pit")]
    return out


VARIANTS = [v for cls in TILE_TYPES for v in _variants(cls)]


def test_every_tile_kind_and_shape_is_covered():
    assert {k for k, _, _ in VARIANTS} == {"flat", "slope", "stair", "rough"}
    assert {(k, shape) for k, _, shape in VARIANTS if shape} == {
        (k, shape) for k in ("slope", "stair") for shape in ("pyramid", "pit")
    }


# --- one tile ------------------------------------------------------------------------


def edge_points(side: str, s: float, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Local coordinates of the points at fractions ``t`` along a side, in increasing x or y."""
    along = t * s
    return {
        "south": (along, np.zeros_like(t)),
        "north": (along, np.full_like(t, s)),
        "west": (np.zeros_like(t), along),
        "east": (np.full_like(t, s), along),
    }[side]


def profile_heights(profile: tuple, t: np.ndarray) -> np.ndarray:
    """What a profile says the heights are at fractions ``t`` along its edge."""
    if profile[0] == "level":
        return np.full_like(t, profile[1])
    start, end = profile[1], profile[2]
    if profile[0] == "ramp":
        return start + (end - start) * t
    n = profile[3]
    return start + (end - start) / n * np.minimum(np.floor(t * (n + 1)), n)


@pytest.mark.parametrize(("kind", "ascent", "shape"), VARIANTS)
@pytest.mark.parametrize("side", SIDES)
def test_edges_follow_the_spec_edge_profile(kind, ascent, shape, side):
    tile = example(kind, ascent, shape=shape)
    # Tread middles, so that a riser's own position (which belongs to one side) is avoided.
    t = np.r_[0.0, np.linspace(0.01, 0.99, 197), 1.0]
    if kind == "stair":
        n = tile.step_count
        t = (np.arange(n + 1) + np.linspace(0.05, 0.95, 9)[:, None]).ravel() / (n + 1)
    z = tile_height(tile, SIZE, *edge_points(side, SIZE, t))
    np.testing.assert_allclose(z, profile_heights(edge_profile(tile, side, SIZE), t), atol=1e-9)


@pytest.mark.parametrize("kind", ["slope", "stair"])
@pytest.mark.parametrize("ascent", ASCENTS)
def test_slopes_and_stairs_rise_by_their_rise_in_their_ascent(kind, ascent):
    tile = example(kind, ascent)
    d = np.linspace(0.0, SIZE, 101)
    u, v = {"+x": (d, 1.0), "-x": (SIZE - d, 1.0), "+y": (1.0, d), "-y": (1.0, SIZE - d)}[ascent]
    z = tile_height(tile, SIZE, u, v)
    assert np.all(np.diff(z) >= 0)
    assert z[0] == pytest.approx(tile.height)
    assert z[-1] == pytest.approx(tile.height + rise(tile, SIZE))


@pytest.mark.parametrize(("kind", "shape"), [(k, sh) for k, _, sh in VARIANTS if sh])
def test_pyramids_and_pits_follow_the_spec_formulas(kind, shape):
    tile = example(kind, shape=shape, height=-0.2)
    rng = np.random.default_rng(4)
    u, v = rng.uniform(0, SIZE, (2, 2000))
    e = np.minimum(np.minimum(u, v), np.minimum(SIZE - u, SIZE - v))
    sign = 1.0 if shape == "pyramid" else -1.0
    if kind == "slope":
        expected = -0.2 + sign * math.tan(tile.angle) * np.minimum(e, SIZE / 3)
    else:
        tread = SIZE / (2 * tile.step_count + 2)
        expected = -0.2 + sign * tile.step_height * np.minimum(np.floor(e / tread), tile.step_count)
    keep = away_from_risers(tile, u, v, SIZE)
    np.testing.assert_allclose(tile_height(tile, SIZE, u, v)[keep], expected[keep], atol=1e-12)
    centre = float(tile_height(tile, SIZE, SIZE / 2, SIZE / 2))
    assert centre == pytest.approx(-0.2 + spec_terrain.peak(tile, SIZE))


def splitmix64(z: int) -> int:
    """SplitMix64's output function in plain Python integers, as docs/terrain.md states it."""
    mask = (1 << 64) - 1
    z = (z + 0x9E3779B97F4A7C15) & mask
    z = ((z ^ (z >> 30)) * 0xBF58476D1CE4E5B9) & mask
    z = ((z ^ (z >> 27)) * 0x94D049BB133111EB) & mask
    return z ^ (z >> 31)


def node_value(seed: int, i: int, j: int) -> float:
    h = splitmix64(splitmix64(splitmix64(seed) ^ i) ^ j)
    return (h >> 11) / 2.0**52 - 1.0


@pytest.mark.parametrize("seed", [0, 1, 2**32 - 1])
def test_rough_noise_is_the_documented_hash_at_lattice_nodes(seed):
    tile = RoughTile(kind="rough", amplitude=0.25, scale=0.5, seed=seed, height=1.0)
    spacing = tile.scale / 2
    nodes = [(i, j) for i in range(2, 9) for j in range(2, 9)]  # inside the taper band
    u = np.array([i * spacing for i, _ in nodes])
    v = np.array([j * spacing for _, j in nodes])
    expected = [1.0 + tile.amplitude * node_value(seed, i, j) for i, j in nodes]
    np.testing.assert_allclose(tile_height(tile, SIZE, u, v), expected, atol=1e-12)


def test_rough_noise_stays_within_its_amplitude_reaches_it_and_tapers_to_the_edges():
    g = np.linspace(0.0, SIZE, 501)
    u, v = np.meshgrid(g, g)
    peaks, patterns = [], set()
    for seed in range(6):
        tile = RoughTile(kind="rough", amplitude=0.1, scale=0.3, seed=seed, height=-0.5)
        dev = tile_height(tile, SIZE, u, v) + 0.5
        assert np.abs(dev).max() <= tile.amplitude
        for border in (dev[0], dev[-1], dev[:, 0], dev[:, -1]):
            assert np.all(border == 0.0)
        peaks.append(np.abs(dev).max())
        patterns.add(dev.round(6).tobytes())
        again = tile_height(tile.model_copy(), SIZE, u, v) + 0.5
        assert np.array_equal(dev, again)
    assert min(peaks) > 0.8 * 0.1  # hundreds of lattice nodes: some come close to the peak
    assert len(patterns) == 6  # every seed gives its own surface


def test_rough_gradient_stays_within_max_slope():
    step = 1e-3
    g = np.arange(0.0, 1.0 + step / 2, step)
    u, v = np.meshgrid(g, g)
    for amplitude, scale in ((0.1, 0.2), (0.05, 1.0), (0.5, 3.0)):
        tile = RoughTile(kind="rough", amplitude=amplitude, scale=scale, seed=5)
        terrain = Terrain(origin=(0, 0), tile_size=1.0, rows=1, cols=1, tiles=[tile])
        z = tile_height(tile, 1.0, u, v)
        steepest = max(np.abs(np.diff(z, axis=0)).max(), np.abs(np.diff(z, axis=1)).max()) / step
        assert 0 < steepest <= max_slope(terrain)


# --- the whole terrain -------------------------------------------------------------------------


def strip(*tiles, origin=(1.0, -2.0), size=SIZE) -> Terrain:
    return Terrain(origin=origin, tile_size=size, rows=1, cols=len(tiles), tiles=list(tiles))


STRIP = strip(
    FlatTile(kind="flat"),
    StairTile(kind="stair", step_height=0.15, step_count=3),
    FlatTile(kind="flat", height=0.45),
    RoughTile(kind="rough", height=0.45, amplitude=0.05, scale=0.4, seed=3),
)


def test_outside_the_grid_and_without_terrain_the_ground_is_at_zero():
    x0, y0 = STRIP.origin
    width = STRIP.cols * SIZE
    xs = np.array([x0 - 0.01, x0 + width + 0.01, x0 + 1.0, x0 + 6.0])
    ys = np.array([y0 + 1.0, y0 + 1.0, y0 - 0.01, y0 + SIZE + 0.01])
    assert np.all(height_at(STRIP, xs, ys) == 0.0)
    assert np.all(height_at(None, xs, ys) == 0.0)
    scene = Scene(format="citygen.scene/1", bounds={"min": [-10, -10], "max": [20, 10]})
    assert np.all(height_at(scene, xs, ys) == 0.0)
    # The grid includes its outer edges.
    assert height_at(STRIP, x0 + 6.25, y0 + SIZE) == pytest.approx(0.45)


def test_a_scene_and_its_terrain_give_the_same_heights_and_the_package_exports_it():
    scene = Scene(format="citygen.scene/1", bounds={"min": [-10, -10], "max": [20, 10]}, terrain=STRIP)
    xs = np.linspace(-1, 13, 300)
    assert np.array_equal(height_at(scene, xs, -1.0), height_at(STRIP, xs, -1.0))
    assert citygen.height_at is height_at
    assert "height_at" in citygen.__all__


def test_shapes_broadcast_and_nan_propagates():
    z = height_at(STRIP, np.linspace(1, 11, 5)[:, None], np.array([-1.0, -0.5, 0.0]))
    assert z.shape == (5, 3)
    assert height_at(STRIP, 4.9, -1.0).shape == ()
    assert height_at(STRIP, [], []).shape == (0,)
    assert np.isnan(height_at(STRIP, [np.nan, 2.0], -1.0)).tolist() == [True, False]


def test_bad_arguments_are_clear_errors():
    with pytest.raises(TypeError, match="a Scene, a Terrain or None"):
        height_at({"tiles": []}, 0.0, 0.0)
    short = Terrain(origin=(0, 0), tile_size=1.0, rows=2, cols=2, tiles=[FlatTile(kind="flat")] * 3)
    with pytest.raises(ValueError, match="needs 4 tiles, got 3"):
        height_at(short, 0.5, 0.5)


def test_height_at_is_tile_height_in_each_tile():
    rng = np.random.default_rng(3)
    x0, y0 = STRIP.origin
    for col, tile in enumerate(STRIP.tiles):
        u, v = rng.uniform(0, SIZE, 500), rng.uniform(0, SIZE, 500)
        # Equal up to the rounding of u, v through world coordinates and back.
        np.testing.assert_allclose(
            height_at(STRIP, x0 + col * SIZE + u, y0 + v), tile_height(tile, SIZE, u, v), atol=1e-12
        )


def test_on_a_border_the_higher_index_tile_answers_and_its_neighbour_agrees():
    x0, y0 = STRIP.origin
    v = np.linspace(0, SIZE, 11)
    for col in range(1, STRIP.cols):
        on_border = height_at(STRIP, x0 + col * SIZE, y0 + v)
        np.testing.assert_array_equal(on_border, tile_height(STRIP.tiles[col], SIZE, 0.0, v))
        left = tile_height(STRIP.tiles[col - 1], SIZE, SIZE, v)
        assert np.abs(on_border - left).max() <= EDGE_TOL


def mixed_terrain(rows: int, cols: int, seed: int = 0) -> Terrain:
    """Every variant of every kind, at random heights (not edge-consistent: for speed and
    sampling checks)."""
    rng = np.random.default_rng(seed)
    tiles = []
    for k in rng.choice(len(VARIANTS), rows * cols).tolist():
        kind, ascent, shape = VARIANTS[k]
        tile = example(kind, ascent, quantize(float(rng.uniform(-1, 1))), shape)
        if isinstance(tile, RoughTile):
            tile = tile.model_copy(update={"seed": int(rng.integers(2**32))})
        tiles.append(tile)
    return Terrain(origin=(-3.0, 4.0), tile_size=SIZE, rows=rows, cols=cols, tiles=tiles)


def test_a_million_points_at_once_agree_with_one_at_a_time():
    # Speed is measured in benchmarks/bench_wfc.py, not here: this checks the vectorised path.
    terrain = mixed_terrain(20, 20)
    rng = np.random.default_rng(0)
    xs = rng.uniform(-4.0, 48.0, 1_000_000)
    ys = rng.uniform(3.0, 55.0, 1_000_000)
    z = height_at(terrain, xs, ys)
    assert z.shape == (1_000_000,)
    # ... and the vectorised answer is each point's own tile's answer.
    pick = rng.choice(xs.size, 300, replace=False)
    for k in pick.tolist():
        col = math.floor((xs[k] + 3.0) / SIZE)
        row = math.floor((ys[k] - 4.0) / SIZE)
        if 0 <= col < 20 and 0 <= row < 20:
            u, v = xs[k] + 3.0 - col * SIZE, ys[k] - 4.0 - row * SIZE
            assert z[k] == pytest.approx(float(tile_height(terrain.tile(row, col), SIZE, u, v)), abs=1e-12)
        else:
            assert z[k] == 0.0


def test_heightfield_samples_height_at_on_a_grid_including_the_edges():
    terrain = mixed_terrain(3, 4, seed=2)
    z, extent = heightfield(terrain, 0.07)
    x_min, x_max, y_min, y_max = extent
    assert extent == (-3.0, -3.0 + 4 * SIZE, 4.0, 4.0 + 3 * SIZE)
    ny, nx = z.shape
    assert (x_max - x_min) / (nx - 1) <= 0.07 and (y_max - y_min) / (ny - 1) <= 0.07
    xs, ys = np.linspace(x_min, x_max, nx), np.linspace(y_min, y_max, ny)
    np.testing.assert_array_equal(z, height_at(terrain, xs[None, :], ys[:, None]))
    scene = Scene(format="citygen.scene/1", bounds={"min": [-10, -10], "max": [20, 20]})
    with pytest.raises(ValueError, match="has none"):
        heightfield(scene, 0.1)
    with pytest.raises(ValueError, match="positive"):
        heightfield(terrain, 0.0)
    with pytest.raises(ValueError, match="coarser"):
        heightfield(terrain, 1e-4)


def test_max_step_and_max_slope():
    assert max_step(None) == 0.0 and max_slope(None) == 0.0
    assert max_step(STRIP) == 0.15
    slope = SlopeTile(kind="slope", angle=0.3)
    assert max_step(strip(slope)) == 0.0
    assert max_slope(strip(slope, FlatTile(kind="flat"))) == pytest.approx(math.tan(0.3))


# --- solids -------------------------------------------------------------------------------------


def top_of(mesh, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """Highest z at which a vertical line through each ``(x, y)`` meets the mesh (a ray cast)."""
    tri = mesh.triangles[mesh.face_normals[:, 2] > 1e-9]
    a, b, c = tri[:, 0], tri[:, 1], tri[:, 2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    px, py = x[:, None] - a[:, 0], y[:, None] - a[:, 1]
    l1 = (px * (c[:, 1] - a[:, 1]) - py * (c[:, 0] - a[:, 0])) / det
    l2 = (py * (b[:, 0] - a[:, 0]) - px * (b[:, 1] - a[:, 1])) / det
    hit = (l1 >= -1e-12) & (l2 >= -1e-12) & (l1 + l2 <= 1 + 1e-12)
    z = a[:, 2] + l1 * (b[:, 2] - a[:, 2]) + l2 * (c[:, 2] - a[:, 2])
    return np.where(hit, z, -np.inf).max(axis=1)


def away_from_risers(tile, u, v, s):
    """Mask of points more than 1 mm from a stair riser (where the top is two heights at once)."""
    if not isinstance(tile, StairTile):
        return np.ones(u.shape, bool)
    if getattr(tile, "shape", None):  # rings around the centre, treads of s / (2n + 2)
        tread = s / (2 * tile.step_count + 2)
        d = np.minimum(np.minimum(u, v), np.minimum(s - u, s - v))
    else:
        tread = s / (tile.step_count + 1)
        d = u if tile.ascent.endswith("x") else v
    phase = d / tread
    return np.abs(phase - np.round(phase)) * tread > 1e-3


def check_solid(mesh, tile, s, bottom):
    assert mesh.is_watertight and mesh.is_winding_consistent and mesh.is_volume
    lo, hi = mesh.bounds
    np.testing.assert_allclose(lo[:2], 0.0, atol=1e-12)
    np.testing.assert_allclose(hi[:2], s, atol=1e-12)
    assert lo[2] == pytest.approx(bottom)
    # The volume is the integral of (height - bottom) over the tile.
    g = (np.arange(400) + 0.5) * s / 400
    u, v = np.meshgrid(g, g)
    integral = float((tile_height(tile, s, u, v) - bottom).mean()) * s * s
    tol = 0.02 if isinstance(tile, RoughTile) else 1e-3
    assert mesh.volume == pytest.approx(integral, rel=tol)


@pytest.mark.parametrize(("kind", "ascent", "shape"), VARIANTS)
def test_tile_mesh_is_a_closed_solid_whose_top_is_tile_height(kind, ascent, shape):
    tile = example(kind, ascent, shape=shape)
    mesh = tile_mesh(tile, SIZE, floor=-0.4)
    check_solid(mesh, tile, SIZE, -0.4)
    rng = np.random.default_rng(7)
    u, v = rng.uniform(0, SIZE, 400), rng.uniform(0, SIZE, 400)
    keep = away_from_risers(tile, u, v, SIZE)
    top, exact = top_of(mesh, u[keep], v[keep]), tile_height(tile, SIZE, u[keep], v[keep])
    if kind == "rough":
        # Vertices lie on the surface; between them the mesh is its linear interpolation.
        surface = mesh.vertices[mesh.vertices[:, 2] > -0.4]
        np.testing.assert_allclose(surface[:, 2], tile_height(tile, SIZE, surface[:, 0], surface[:, 1]))
        assert np.abs(top - exact).max() <= 0.25 * tile.amplitude
    else:
        np.testing.assert_allclose(top, exact, atol=1e-9)


def test_the_floor_is_lowered_below_the_lowest_point():
    tile = example("rough", height=-3.0)
    mesh = tile_mesh(tile, SIZE, floor=-1.0)
    assert mesh.bounds[0, 2] == pytest.approx(-3.0 - tile.amplitude - geo.MIN_THICKNESS)
    assert mesh.is_volume
    with pytest.raises(ValueError, match="finite"):
        tile_mesh(tile, SIZE, floor=math.nan)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tile=any_tile(), size=st.sampled_from([0.25, 1.0, 2.5, 7.0]), floor=st.floats(-5, 5))
def test_any_valid_tile_makes_a_closed_solid(tile, size, floor):
    tile = TILE_CLASSES[tile["kind"]](**tile)
    mesh = tile_mesh(tile, size, floor=floor)
    assert mesh.is_watertight and mesh.is_volume
    u, v, z = mesh.vertices[mesh.vertices[:, 2] > mesh.bounds[0, 2]].T
    gap = np.abs(z - tile_height(tile, size, u, v))
    if isinstance(tile, StairTile):  # the foot of a riser lies on the tread next to it
        for du, dv in ((-1e-6, 0), (1e-6, 0), (0, -1e-6), (0, 1e-6)):
            gap = np.minimum(gap, np.abs(z - tile_height(tile, size, u + du, v + dv)))
    assert gap.max() <= 1e-9


@pytest.mark.parametrize(("ascent", "shape"), [(a, sh) for k, a, sh in VARIANTS if k == "stair"])
def test_stair_boxes_fill_the_stair_solid(ascent, shape):
    tile = example("stair", ascent, shape=shape)
    boxes = tile_boxes(tile, SIZE, floor=-0.4)
    n = tile.step_count
    assert boxes.shape == ((4 * n + 1) if shape else (n + 1), 2, 3)
    assert np.all(boxes[:, 1] > boxes[:, 0])
    # They cover the tile once: their footprints add up to it and no two overlap.
    lo, hi = boxes[:, 0, :2], boxes[:, 1, :2]
    assert float(np.prod(hi - lo, axis=1).sum()) == pytest.approx(SIZE * SIZE)
    overlap = np.clip(np.minimum(hi[:, None], hi[None]) - np.maximum(lo[:, None], lo[None]), 0, None)
    assert np.all(np.triu(np.prod(overlap, axis=2), 1) < 1e-12)
    volume = float(np.prod(boxes[:, 1] - boxes[:, 0], axis=1).sum())
    assert volume == pytest.approx(tile_mesh(tile, SIZE, floor=-0.4).volume)
    centres = boxes.mean(axis=1)
    np.testing.assert_allclose(boxes[:, 1, 2], tile_height(tile, SIZE, centres[:, 0], centres[:, 1]))
    flat = tile_boxes(example("flat"), SIZE, floor=-0.4)
    assert flat.tolist() == [[[0.0, 0.0, -0.4], [SIZE, SIZE, 0.3]]]
    with pytest.raises(TypeError, match="tile_mesh"):
        tile_boxes(example("slope"), SIZE)


def test_terrain_mesh_holds_every_tile_in_place():
    terrain = mixed_terrain(3, 4, seed=5)
    terrain = terrain.model_copy(update={"tiles": (*terrain.tiles[:-2], terrain.tiles[0], terrain.tiles[0])})
    mesh = terrain_mesh(terrain, floor=-5.0)
    assert mesh.is_watertight and mesh.is_volume
    assert mesh.bounds[0, 2] == pytest.approx(-5.0)
    face_tile = mesh.metadata["face_tile"]
    assert face_tile.shape == (len(mesh.faces),) and set(face_tile.tolist()) == set(range(12))
    assert len(mesh.split(only_watertight=True)) == 12
    rng = np.random.default_rng(1)
    for k, tile in enumerate(terrain.tiles):
        local = tile_mesh(tile, SIZE, floor=-5.0)
        part = mesh.submesh([np.flatnonzero(face_tile == k)], append=True)
        row, col = divmod(k, terrain.cols)
        corner = np.array([terrain.origin[0] + col * SIZE, terrain.origin[1] + row * SIZE, 0.0])
        np.testing.assert_allclose(np.sort(part.vertices - corner, axis=0), np.sort(local.vertices, axis=0))
        u, v = rng.uniform(0.01, SIZE - 0.01, (2, 50))
        keep = away_from_risers(tile, u, v, SIZE)
        x, y = corner[0] + u[keep], corner[1] + v[keep]
        tol = 0.25 * tile.amplitude if isinstance(tile, RoughTile) else 1e-9
        assert np.abs(top_of(part, x, y) - height_at(terrain, x, y)).max() <= tol
    again = terrain_mesh(terrain, floor=-5.0)
    assert np.array_equal(again.vertices, mesh.vertices) and np.array_equal(again.faces, mesh.faces)


# --- the 1 cm line property ----------------------------------------------------------------------


def edges_agree(terrain: Terrain) -> bool:
    s = terrain.tile_size
    for r in range(terrain.rows):
        for c in range(terrain.cols):
            if c + 1 < terrain.cols and not profiles_match(
                edge_profile(terrain.tile(r, c), "east", s), edge_profile(terrain.tile(r, c + 1), "west", s)
            ):
                return False
            if r + 1 < terrain.rows and not profiles_match(
                edge_profile(terrain.tile(r, c), "north", s), edge_profile(terrain.tile(r + 1, c), "south", s)
            ):
                return False
    return True


def largest_jump(terrain: Terrain, p0, p1, step: float = 0.01) -> tuple[float, float]:
    """Largest height difference between neighbouring samples ``<= step`` apart on a segment."""
    n = max(1, math.ceil(math.dist(p0, p1) / step))
    t = np.linspace(0.0, 1.0, n + 1)
    z = height_at(terrain, p0[0] + t * (p1[0] - p0[0]), p0[1] + t * (p1[1] - p0[1]))
    return float(np.abs(np.diff(z)).max()), math.dist(p0, p1) / n


def allowed_jump(terrain: Terrain, spacing: float) -> float:
    return max_step(terrain) + max_slope(terrain) * spacing + EDGE_TOL


q = st.floats(0.0, 1.0).map(quantize)


@st.composite
def consistent_terrains(draw) -> Terrain:
    """Columns of level-edged ground (flat, rough, pyramids and pits, drawn per tile) and of
    slope and stair flights in x, each starting where the previous ended; every row the same
    profile; sometimes transposed."""
    size = draw(st.sampled_from([0.5, 1.0, 2.5, 4.0]))
    rows, cols = draw(st.integers(1, 4)), draw(st.integers(1, 6))
    h = quantize(draw(st.floats(-2.0, 2.0)))
    columns = []  # per column: a tile shared by all rows, or None for level ground at `h`
    levels = []
    for _ in range(cols):
        kind = draw(st.sampled_from(["level", "slope", "stair"]))
        up = draw(st.booleans())
        if kind == "level":
            columns.append(None)
        elif kind == "slope":
            tile = SlopeTile(
                kind="slope", angle=quantize(draw(st.floats(0.0, 0.6))), ascent="+x" if up else "-x"
            )
        else:
            tile = StairTile(
                kind="stair",
                step_height=quantize(draw(st.floats(0.02, 0.25))),
                step_count=draw(st.integers(1, 8)),
                ascent="+x" if up else "-x",
            )
        if kind != "level":
            rise_ = rise(tile, size)
            tile = tile.model_copy(update={"height": quantize(h if up else h - rise_)})
            columns.append(tile)
        levels.append(h)
        if kind != "level":
            h = quantize(h + rise_ if up else h - rise_)

    def level(at: float):
        kind = draw(st.sampled_from(["flat", "rough", "slope", "stair"]))
        if kind == "flat":
            return FlatTile(kind="flat", height=at)
        shape = draw(st.sampled_from(["pyramid", "pit"]))
        if kind == "slope":
            return SlopeTile(kind="slope", height=at, angle=quantize(draw(st.floats(0.0, 0.6))), shape=shape)
        if kind == "stair":
            return StairTile(
                kind="stair",
                height=at,
                step_height=quantize(draw(st.floats(0.02, 0.25))),
                step_count=draw(st.integers(1, 8)),
                shape=shape,
            )
        return RoughTile(
            kind="rough",
            height=at,
            amplitude=quantize(draw(st.floats(0.0, 0.12))),
            scale=quantize(draw(st.floats(0.1, 2.0))),
            seed=draw(st.integers(0, 2**32 - 1)),
        )

    grid = [[columns[c] or level(levels[c]) for c in range(cols)] for _ in range(rows)]
    if draw(st.booleans()):  # transpose: the profile runs in y
        flip = {"+x": "+y", "-x": "-y"}
        grid = [
            [t.model_copy(update={"ascent": flip[t.ascent]}) if hasattr(t, "ascent") else t for t in col]
            for col in zip(*grid, strict=True)
        ]
        rows, cols = cols, rows
    origin = (quantize(draw(st.floats(-50, 50))), quantize(draw(st.floats(-50, 50))))
    tiles = [t for row in grid for t in row]
    return Terrain(origin=origin, tile_size=size, rows=rows, cols=cols, tiles=tiles)


def lines_in(terrain: Terrain, fraction) -> list[tuple[tuple[float, float], tuple[float, float]]]:
    """Segments inside the grid (1 um in from its outer edge, where the ground drops to 0):
    its diagonals, middle lines, lines along interior tile borders, and 4 from ``fraction()``."""
    x0, y0 = terrain.origin
    s, w, d = terrain.tile_size, terrain.cols * terrain.tile_size, terrain.rows * terrain.tile_size
    m = 1e-6

    def point(fx: float, fy: float) -> tuple[float, float]:
        return (x0 + m + fx * (w - 2 * m), y0 + m + fy * (d - 2 * m))

    lines = [(point(0, 0), point(1, 1)), (point(0, 1), point(1, 0))]
    lines += [(point(0, 0.5), point(1, 0.5)), (point(0.5, 0), point(0.5, 1))]
    if terrain.cols > 1:
        x = x0 + s * (terrain.cols // 2)
        lines.append(((x, y0 + m), (x, y0 + d - m)))
    if terrain.rows > 1:
        y = y0 + s * (terrain.rows // 2)
        lines.append(((x0 + m, y), (x0 + w - m, y)))
    lines += [(point(fraction(), fraction()), point(fraction(), fraction())) for _ in range(4)]
    return lines


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(terrain=consistent_terrains(), data=st.data())
def test_lines_sampled_every_cm_jump_no_more_than_the_largest_step(terrain, data):
    assert edges_agree(terrain)
    for p0, p1 in lines_in(terrain, lambda: data.draw(st.floats(0.0, 1.0))):
        jump, spacing = largest_jump(terrain, p0, p1)
        assert jump <= allowed_jump(terrain, spacing), (p0, p1)


def test_the_line_property_sees_a_cliff():
    cliff = strip(FlatTile(kind="flat"), FlatTile(kind="flat", height=0.5))
    assert not edges_agree(cliff)
    jump, spacing = largest_jump(cliff, (1.0, -1.0), (6.0, -1.0))
    assert jump == pytest.approx(0.5) and jump > allowed_jump(cliff, spacing)
    # A stair facing the wrong way is a cliff too.
    wrong = strip(
        FlatTile(kind="flat"),
        StairTile(kind="stair", step_height=0.15, step_count=2, ascent="-x"),
        FlatTile(kind="flat", height=0.3),
    )
    jump, spacing = largest_jump(wrong, (1.0, -1.0), (8.5, -1.0))
    assert jump > allowed_jump(wrong, spacing)


def test_the_example_scenes_have_no_cliffs_inside_their_terrain():
    for path in sorted((ROOT / "examples").glob("*.json")):
        scene = citygen.load_scene(path)
        if scene.terrain is None:
            continue
        for p0, p1 in lines_in(scene.terrain, np.random.default_rng(0).uniform):
            jump, spacing = largest_jump(scene.terrain, p0, p1)
            assert jump <= allowed_jump(scene.terrain, spacing), (path.name, p0, p1)


@pytest.mark.parametrize("seed", range(6))
def test_the_generators_terrains_have_no_cliffs(seed):
    from citygen.generate.terrain import build_terrain, loc_config
    from citygen.seeding import stage_rng
    from citygen.spec import Bounds
    from citygen.spec.config import TerrainConfig

    rng = stage_rng(seed, "terrain")
    size = 10.0 + 5.0 * seed
    wfc = build_terrain(Bounds(min=(-2.0, 3.0), max=(size - 2.0, 3.0 + size)), [], TerrainConfig(), rng)
    curriculum = loc_config("train" if seed % 2 else "test").model_copy(update={"grid": (3, 8)})
    loco = build_terrain(Bounds(min=(0.0, 0.0), max=(64.0, 24.0)), [], curriculum, rng)
    fraction = np.random.default_rng(seed).uniform
    for terrain in (wfc, loco):
        assert edges_agree(terrain)
        for p0, p1 in lines_in(terrain, fraction):
            jump, spacing = largest_jump(terrain, p0, p1)
            assert jump <= allowed_jump(terrain, spacing), (p0, p1)


# --- the gallery -------------------------------------------------------------------------------


def test_the_gallery_renders_every_tile_kind(tmp_path):
    spec = importlib.util.spec_from_file_location("make_gallery", ROOT / "docs" / "make_gallery.py")
    gallery = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(gallery)
    assert {t.kind for _, t in gallery.TILES} == {"flat", "rough", "slope", "stair"}
    out = gallery.render(tmp_path / "tiles.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    committed = ROOT / "docs" / "terrain_tiles.png"
    assert committed.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert committed.stat().st_size < 300_000


def test_the_runners_ground_raster_is_height_at_within_a_cell():
    """The runner's height map and servo read the scene's 5 cm ground raster (bilinear): on
    slopes and rough ground within a centimetre of :func:`height_at`, exact at the cells'
    centres; a stair's edge becomes a ramp one cell wide."""
    from citygen.runner.make import make_env

    env = make_env("nav-static", robot="quadruped")
    for index in range(4):
        env.reset(seed=index, options={"index": index})
        p = env.unwrapped.prepared
        assert p.fine_ground
        grid = p.occupancy.grid
        rng = np.random.default_rng(index)
        (x0, y0), (x1, y1) = p.scene.bounds.min, p.scene.bounds.max
        xs, ys = rng.uniform(x0 + 0.1, x1 - 0.1, 2000), rng.uniform(y0 + 0.1, y1 - 0.1, 2000)
        raster = p.ground(xs, ys)
        exact = height_at(p.scene, xs, ys)
        err = np.abs(raster - exact)
        assert np.percentile(err, 95) < 0.01
        assert err.max() <= 0.25  # a stair riser or a curb smeared over one cell
        one_by_one = [p.ground_at(x, y) for x, y in zip(xs[:50], ys[:50], strict=True)]
        assert one_by_one == pytest.approx(raster[:50])
        cx = np.repeat(grid.xs()[7::37], grid.ys()[7::37].size)
        cy = np.tile(grid.ys()[7::37], grid.xs()[7::37].size)
        assert p.ground(cx, cy) == pytest.approx(height_at(p.scene, cx, cy), abs=1e-6)
    env.close()


def test_the_tiled_ground_is_the_5cm_map_to_the_bit_and_a_city_servo_casts_no_rays(monkeypatch):
    """A city's servo stands on the 5 cm raster made tile by tile (TiledGround): on a scene
    whose map is 5 cm it is Prepared.ground_at to the bit, inside, across tile borders (a
    tile's last row and column are the next one's first) and past the edges; an environment
    on a scene whose map is coarser binds it, and a servo step casts no ray."""
    from citygen.runner import ground as tiled
    from citygen.runner import scenes
    from citygen.runner.envs import base
    from citygen.runner.make import make_env

    monkeypatch.setattr(tiled, "TILE_CELLS", 16)  # many borders on a small scene
    env = make_env("nav-static", robot="quadruped")
    env.reset(seed=0, options={"index": 2})
    p = env.unwrapped.prepared
    assert p.fine_ground
    t = tiled.TiledGround.of_scene(p.scene, scenes.MAP_RESOLUTION)
    assert t.tile_cells == 16
    assert t.grid == p.occupancy.grid
    (x0, y0), (x1, y1) = p.scene.bounds.min, p.scene.bounds.max
    rng = np.random.default_rng(3)
    xs = np.concatenate([rng.uniform(x0 - 1, x1 + 1, 3000), t.grid.x0 + 16 * 0.05 * np.arange(1, 9)])
    ys = np.concatenate([rng.uniform(y0 - 1, y1 + 1, 3000), t.grid.y0 + 16 * 0.05 * np.arange(1, 9) + 0.025])
    ours = np.array([t.ground_at(x, y) for x, y in zip(xs.tolist(), ys.tolist(), strict=True)])
    theirs = np.array([p.ground_at(x, y) for x, y in zip(xs.tolist(), ys.tolist(), strict=True)])
    np.testing.assert_array_equal(ours.view(np.int64), theirs.view(np.int64))
    env.close()

    # A map coarser than 5 cm (as a city's): the environment's servo reads the tiles.
    monkeypatch.setattr(scenes, "map_resolution", lambda scene: 0.2)
    monkeypatch.setenv("CITYGEN_CACHE_DIR", "off")  # nothing stored under the usual key
    cache = scenes.SceneCache()
    monkeypatch.setattr(base, "process_cache", lambda: cache)
    env = make_env("nav-static", robot="quadruped")
    env.reset(seed=0, options={"index": 2})
    u = env.unwrapped
    assert not u.prepared.fine_ground and u.handle.terrain is u.prepared.fine_tiles
    rays = []
    monkeypatch.setattr(u.handle._mj, "mj_ray", lambda *a: rays.append(a) or -1.0, raising=False)
    for _ in range(5):
        env.step(np.array([0.5, 0.0], dtype=np.float32))
    assert not rays
    env.close()


def test_bilinear_at_one_point_is_the_array_version_to_the_bit():
    """The environments read the ground under the base every step with Grid.bilinear_point
    (plain Python); observations equal bit for bit only if it is Grid.bilinear's float,
    inside the grid, past its edges and on grids of one row or column."""
    from citygen.geometry.raster import Grid

    rng = np.random.default_rng(7)
    for _ in range(20):
        rows, cols = int(rng.integers(1, 40)), int(rng.integers(1, 40))
        res = float(rng.choice([0.05, 0.1, 0.37]))
        grid = Grid(float(rng.uniform(-30, 30)), float(rng.uniform(-30, 30)), res, rows, cols)
        values = rng.normal(size=(rows, cols))
        xs = rng.uniform(grid.x0 - 1, grid.x0 + cols * res + 1, 500)
        ys = rng.uniform(grid.y0 - 1, grid.y0 + rows * res + 1, 500)
        points = zip(xs.tolist(), ys.tolist(), strict=True)
        one = np.array([grid.bilinear_point(values, x, y) for x, y in points])
        np.testing.assert_array_equal(one.view(np.int64), grid.bilinear(values, xs, ys).view(np.int64))
