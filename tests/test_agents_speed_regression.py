"""The agents stage's shortcuts give the draws of the plain formulas, to the bit.

Stage 5 samples people's starts and goals from a triangulation of their free space. Its
faster paths (triangle corners and areas read from the triangulation in one array, a
cumulative search instead of ``rng.choice``, prepared ``intersects_xy`` instead of
``covers(Point)``) must consume the generator in the same way and return the same values,
or every scene with people changes. Each is compared here with the plain formula it
replaces, kept in this file, on geometry like the generator's (free space with holes,
points on edges and corners), and whole agent stages are compared with the stage run on
the plain formulas.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import shapely
from shapely.geometry import Point

from citygen.generate import agents, generate, space
from citygen.spec.config import AgentsConfig, BlocksConfig, GeneratorConfig, PeopleMix, PlacementConfig


class PlainSampler:
    """:class:`citygen.generate.space.Sampler` as first written: a shapely polygon per triangle."""

    def __init__(self, polygon):
        tris = shapely.get_parts(shapely.constrained_delaunay_triangles(polygon))
        areas = shapely.area(tris)
        tris, areas = tris[areas > 0], areas[areas > 0]
        self.area = float(areas.sum())
        self._corners = shapely.get_coordinates(tris).reshape(-1, 4, 2)[:, :3]
        self._cumulative = np.cumsum(areas) / areas.sum() if len(areas) else areas

    def __bool__(self) -> bool:
        return self.area > 0

    def point(self, rng):
        k = min(int(np.searchsorted(self._cumulative, rng.random(), side="right")), len(self._cumulative) - 1)
        a, b, c = self._corners[k]
        u, v = rng.random(2)
        if u + v > 1.0:
            u, v = 1.0 - u, 1.0 - v
        x, y = a + u * (b - a) + v * (c - a)
        return (round(float(x), 3) + 0.0, round(float(y), 3) + 0.0)


def plain_trip(spaces, rng, trip, r, taken):
    """:func:`citygen.generate.agents._trip` as first written: ``rng.choice`` and ``covers``."""
    for _ in range(64):
        k = int(rng.choice(len(spaces), p=spaces.p))
        piece, sampler = spaces[k]
        start = sampler.point(rng)
        if not piece.covers(Point(start)):
            continue
        if any(math.dist(start, (x, y)) < r + q + agents.GAP for x, y, q in taken):
            continue
        best = None
        for _ in range(16):
            goal = sampler.point(rng)
            if not piece.covers(Point(goal)):
                continue
            d = math.dist(start, goal)
            if d >= trip:
                return start, goal
            if best is None or d > best[0]:
                best = (d, goal)
        if best is not None:
            return start, best[1]
    return None


def city_like_free_space(seed: int, radius: float = 0.35):
    """Free space of a street grid (sidewalk rings around blocks) with a few hundred
    objects, some overlapping, some touching the edges: holes, notches and slivers."""
    rng = np.random.default_rng(seed)
    blocks = [shapely.box(x, y, x + 40, y + 30) for x in range(0, 200, 50) for y in range(0, 160, 40)]
    ground = shapely.difference(shapely.box(-5, -5, 205, 165), shapely.union_all(blocks))
    ground = shapely.difference(ground, shapely.union_all([b.buffer(-4) for b in blocks]))
    ground = shapely.union_all([ground, *[b.exterior.buffer(4, cap_style="flat") for b in blocks]])
    objects = []
    for _ in range(300):
        x, y = rng.uniform(-5, 205), rng.uniform(-5, 165)
        w, h, yaw = rng.uniform(0.3, 2.0), rng.uniform(0.3, 1.2), rng.uniform(0, math.pi)
        box = shapely.affinity.rotate(shapely.box(-w / 2, -h / 2, w / 2, h / 2), yaw, use_radians=True)
        objects.append(shapely.affinity.translate(box, x, y))
    return space.free_space(ground, objects, radius)


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_sampler_draws_the_points_of_the_plain_formula(seed: int) -> None:
    polygons = space.pieces(city_like_free_space(seed))[:6]
    polygons += [shapely.box(0, 0, 3, 2), shapely.Point(1, 1).buffer(0.7, quad_segs=4)]
    assert len(polygons[0].interiors) > 10  # holes, as in a city's free space
    for polygon in polygons:
        fast, plain = space.Sampler(polygon), PlainSampler(polygon)
        assert fast.area == plain.area and bool(fast) == bool(plain)
        assert np.array_equal(fast._cumulative, plain._cumulative)
        a, b = np.random.default_rng(seed), np.random.default_rng(seed)
        assert [fast.point(a) for _ in range(300)] == [plain.point(b) for _ in range(300)]
        assert a.random() == b.random()  # the generator left in the same state


def test_triangle_areas_equal_shapely_area_to_the_bit() -> None:
    polygon = space.pieces(city_like_free_space(3, 0.5))[0]
    triangles = shapely.constrained_delaunay_triangles(polygon)
    rings = shapely.get_coordinates(triangles).reshape(-1, 4, 2)
    expected = shapely.area(shapely.get_parts(triangles))
    assert len(expected) > 1000
    assert np.array_equal(space.ring_areas(rings), expected)
    # Far from the origin and tiny: the shoelace's cancellation is the same as GEOS's.
    far = np.array([[[1e5 + 0.1, 7e4], [1e5 + 0.1004, 7e4 + 0.0003], [1e5, 7e4 + 0.0001], [1e5 + 0.1, 7e4]]])
    assert np.array_equal(space.ring_areas(far), shapely.area(shapely.polygons(far)))


def test_cumulative_choice_draws_what_rng_choice_draws() -> None:
    weights = np.random.default_rng(9)
    for trial in range(200):
        n = int(weights.integers(1, 70))
        areas = weights.pareto(1.0, n) + (0.0 if trial % 3 else 1e-12)
        p = areas / areas.sum()
        choice = agents._Choice(p)
        a, b = np.random.default_rng(trial), np.random.default_rng(trial)
        assert [choice.draw(a) for _ in range(50)] == [int(b.choice(n, p=p)) for _ in range(50)]
        assert a.random() == b.random()


def test_intersects_xy_on_a_prepared_piece_is_covers() -> None:
    piece = space.pieces(city_like_free_space(4))[0]
    prepared = shapely.Polygon(piece.exterior, piece.interiors)
    shapely.prepare(prepared)
    rng = np.random.default_rng(4)
    x0, y0, x1, y1 = piece.bounds
    points = [tuple(p) for p in rng.uniform((x0, y0), (x1, y1), size=(2000, 2)).round(3)]
    rings = [piece.exterior, *piece.interiors[:20]]
    points += [c for ring in rings for c in ring.coords[:8]]  # corners
    points += [tuple(ring.interpolate(t, normalized=True).coords[0]) for ring in rings for t in (0.1, 0.5)]
    expected = [piece.covers(Point(p)) for p in points]
    assert any(expected) and not all(expected)
    assert [bool(shapely.intersects_xy(prepared, *p)) for p in points] == expected


CITYISH = GeneratorConfig(
    size=(180.0, 180.0),
    layout="blocks",
    blocks=BlocksConfig(count=4, straight_length=(30.0, 50.0)),
    placement=PlacementConfig(count=None, density_per_100m2=2.0),
    agents=AgentsConfig(people=40, vehicles=0, mix=PeopleMix(pedestrian=3, cyclist=1, scooter=1)),
)


@pytest.mark.parametrize(("config", "seed"), [(CITYISH, 11), (CITYISH, 12)])
def test_the_agents_stage_equals_the_stage_on_the_plain_formulas(
    config: GeneratorConfig, seed: int, monkeypatch: pytest.MonkeyPatch
) -> None:
    fast = generate(config, seed)
    assert sum(1 for a in fast.agents if a.kind != "vehicle") == 40
    assert {a.kind for a in fast.agents} == {"pedestrian", "cyclist", "scooter"}
    monkeypatch.setattr(agents, "Sampler", PlainSampler)
    monkeypatch.setattr(agents, "_trip", plain_trip)
    plain = generate(config, seed)
    assert fast.agents == plain.agents
