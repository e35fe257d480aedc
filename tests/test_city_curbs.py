"""Curbs of a city (issue 19): sidewalks a curb above the street, a 1:12 curb ramp at each
end of every crosswalk, and what wheels and legs make of them."""

from __future__ import annotations

import numpy as np
import pytest
import shapely
from shapely.geometry import LineString, Polygon

import citygen
from citygen.generate.layouts.city.curbs import CURB, rectangles
from citygen.geometry import raster
from citygen.geometry.features import feature_polygon
from citygen.geometry.terrain import height_at, height_grid
from citygen.geometry.traversable import blocked_cells, landing_rims
from citygen.runner.scenes import step_edges
from citygen.spec.surfaces import WALKABLE_ZONES
from citygen.spec.task import ROBOTS
from tests.test_city import polygons, small_city
from tests.test_city_terrain import at


def curb_height(scene) -> float:
    return next(f.rise for f in scene.terrain.features if f.id.startswith("curb-"))


def test_sidewalks_stand_a_curb_above_the_roadway_and_the_crosswalks():
    scene = small_city(0)
    h = curb_height(scene)
    assert CURB[0] <= h <= CURB[1]
    rng = np.random.default_rng(0)

    def sample(kind, strip=None):
        zones = [
            Polygon(z.polygon, z.holes)
            for z in scene.zones
            if z.kind == kind and (strip is None or z.strip == strip)
        ]
        pts = [p.representative_point() for p in rng.permutation(np.array(zones, dtype=object))[:60]]
        return height_at(scene, [p.x for p in pts], [p.y for p in pts])

    # The clear strip of the sidewalk is on the curb's level (rough paving stays under it).
    assert np.mean(np.abs(sample("sidewalk", "clear") - h) < 1e-9) >= 0.95
    assert np.all(sample("crosswalk") < h - 0.02)
    assert np.all(sample("roadway") < h - 0.02)


def test_every_crosswalk_end_has_a_curb_ramp_at_1_in_12():
    scene = small_city(0)
    h = curb_height(scene)
    ramps = [f for f in scene.terrain.features if f.id.startswith("curb-ramp-")]
    walks = shapely.get_parts(shapely.union_all(polygons(scene, "crosswalk"), grid_size=1e-3))
    assert len(ramps) >= 0.9 * 2 * len(walks)
    sidewalks = shapely.union_all(polygons(scene, "sidewalk", "curb"), grid_size=1e-3).buffer(1e-3)
    for ramp in ramps:
        assert ramp.rise == h and ramp.rise / ramp.length <= 1 / 12 + 1e-6
        assert sidewalks.contains(feature_polygon(ramp).buffer(-0.01))
        low, high = at(ramp, 0.01), at(ramp, ramp.length - 0.1)
        # It rises from a crosswalk's end to the sidewalk's level.
        assert any(w.distance(shapely.Point(at(ramp, -0.05))) < 0.01 for w in walks)
        z = height_at(scene, [low[0], high[0]], [low[1], high[1]])
        assert z[0] == pytest.approx(h / ramp.length * 0.01, abs=1e-6)
        assert z[1] == pytest.approx(h * (ramp.length - 0.1) / ramp.length, abs=1e-6)
        assert float(height_at(scene, *at(ramp, ramp.length + 0.05))) == pytest.approx(h, abs=1e-9)


def test_wheels_get_from_a_crosswalk_to_the_sidewalk_only_over_its_ramp():
    """The runner's rule (walkable ground, no step higher than the robot's, nothing its
    mobility cannot cross) on a 5 cm grid around one crosswalk end."""
    scene = small_city(0)
    ramp = next(f for f in scene.terrain.features if f.id.startswith("curb-ramp-"))
    wheeled = ROBOTS["wheeled"]
    cx, cy = ramp.center
    grid = raster.Grid.covering((cx - 8, cy - 8, cx + 8, cy + 8), 0.05)
    xs, ys = grid.xs(), grid.ys()
    walkable = np.zeros(grid.shape, dtype=bool)
    raster.paint(grid, walkable, shapely.union_all(polygons(scene, *WALKABLE_ZONES)), True)
    heights = height_grid(scene, xs, ys)
    free = walkable & ~step_edges(heights, wheeled.max_step) & ~blocked_cells(scene.terrain, wheeled, xs, ys)
    crosswalk, sidewalk = at(ramp, -1.0), at(ramp, ramp.length + 0.6)
    a, b = grid.cell(*crosswalk), grid.cell(*sidewalk)
    labels, _ = raster.components(free)
    assert labels[a] and labels[a] == labels[b]
    # Without the ramp the curb is in the way.
    on_ramp = np.zeros(grid.shape, dtype=bool)
    raster.paint(grid, on_ramp, feature_polygon(ramp), True)
    labels, _ = raster.components(free & ~on_ramp)
    assert labels[a] != labels[b]
    # Legs step up the curb anywhere.
    assert not landing_rims(scene.terrain, ROBOTS["quadruped"])


def test_the_traverse_runs_over_curb_ramps_with_no_step_a_quadruped_cannot_take():
    scene = small_city(1)
    assert citygen.validate(scene) == []
    h = curb_height(scene)
    route = LineString([scene.task.start.position, *scene.task.route])
    ramps = [feature_polygon(f) for f in scene.terrain.features if f.id.startswith("curb-ramp-")]
    assert sum(r.distance(route) < 2.0 for r in ramps) >= 4
    d = np.arange(0.0, route.length, 0.05)
    pts = shapely.get_coordinates(shapely.line_interpolate_point(route, d))
    z = height_at(scene, pts[:, 0], pts[:, 1])
    assert np.abs(np.diff(z)).max() <= ROBOTS["quadruped"].max_step
    assert np.mean(np.abs(z - h) < 1e-9) >= 0.5  # mostly on the sidewalks


def test_rectangles_cover_a_rounded_corner_to_within_the_slivers():
    corner = shapely.box(0, 0, 30, 30).buffer(-6).buffer(6, quad_segs=4)
    band = corner.difference(corner.buffer(-3, quad_segs=4))
    rects = [
        shapely.box(cx - lx / 2, cy - ly / 2, cx + lx / 2, cy + ly / 2)
        for cx, cy, _, lx, ly in rectangles(band)
    ]
    union = shapely.union_all(rects)
    assert sum(r.area for r in rects) == pytest.approx(union.area, rel=1e-9)  # no overlaps
    assert band.buffer(1e-3).contains(union)  # the slabs are snapped to 0.2 mm
    assert union.area >= 0.95 * band.area
    # The band stays one piece: no crack across it at the corners.
    assert len(shapely.get_parts(union.buffer(1e-4))) == 1
    # A straight side along y is one slab.
    assert any(r.buffer(1e-3).contains(shapely.box(0.0, 6.0, 3.0, 24.0)) for r in rects)
    assert len(rects) <= 80


@pytest.mark.slow
def test_the_runner_finds_the_traverse_one_piece_of_free_ground_for_the_quadruped():
    """The runner's free cells (walkable, no step higher than the robot's, inflated by its
    radius) hold every metre of the route, in one connected piece."""
    from citygen.exporters.occupancy import occupancy
    from citygen.runner.robots.registry import load_robot
    from citygen.runner.scenes import free_cells

    scene = small_city(1)
    occ = occupancy(scene, 0.2)
    labels, _ = raster.components(free_cells(occ, load_robot("quadruped"), scene.terrain))
    route = LineString([scene.task.start.position, *scene.task.route])
    pts = shapely.get_coordinates(shapely.line_interpolate_point(route, np.arange(0.0, route.length, 1.0)))
    on = {int(labels[occ.cell(x, y)]) for x, y in pts}
    assert len(on) == 1 and 0 not in on
