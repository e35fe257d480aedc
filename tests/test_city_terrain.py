"""Terrain where a city has it (issue 19): front steps at building entrances, raised plaza
terraces with steps and a ramp, as terrain features every consumer sees."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest
from shapely.geometry import LineString, Point, Polygon

import citygen
from citygen.exporters import mjcf, occupancy
from citygen.geometry.features import feature_polygon
from citygen.geometry.terrain import height_at, max_step, terrain_mesh
from citygen.geometry.traversable import blocked_cells
from citygen.io import dumps, load_scene
from citygen.spec.scene import Scene
from citygen.spec.task import ROBOTS
from citygen.spec.terrain import LandingFeature, RampFeature, StepsFeature
from tests.test_city import small_city


def at(f, a: float) -> tuple[float, float]:
    """The point ``a`` metres from a feature's low edge along its centre line."""
    c, s = math.cos(f.yaw), math.sin(f.yaw)
    return f.center[0] + c * (a - f.length / 2), f.center[1] + s * (a - f.length / 2)


@pytest.mark.parametrize("seed", [0, 3])
def test_a_city_has_front_steps_and_plaza_terraces(seed):
    scene = small_city(seed)
    features = scene.terrain.features
    assert sum(f.id.startswith("front-steps") for f in features) >= 20
    assert not citygen.validate(scene)
    if seed == 3:  # a city with large plazas: terraces with steps, a 1:12 ramp and its landing
        kinds = {f.id.rsplit("-", 1)[0] for f in features}
        assert {"terrace", "terrace-steps", "terrace-ramp", "terrace-top"} <= kinds
        ramp = next(f for f in features if f.id.startswith("terrace-ramp-"))
        assert ramp.rise / ramp.length <= 1 / 12 + 1e-3
        terrace = next(f for f in features if f.id == ramp.id.replace("-ramp", ""))
        assert float(height_at(scene, *at(ramp, ramp.length - 0.01))) == pytest.approx(
            terrace.height + terrace.rise, abs=2e-3
        )


def test_height_at_a_front_step_is_the_step_height_above_the_sidewalk():
    scene = small_city(0)
    stoop = next(f for f in scene.terrain.features if f.id.startswith("front-steps") and f.step_count >= 2)
    x0, y0 = at(stoop, -0.2)  # the sidewalk in front of the steps
    x1, y1 = at(stoop, 0.1)  # the first tread
    x2, y2 = at(stoop, stoop.length - 0.1)  # the top tread, at the door
    base, first, top = height_at(scene, [x0, x1, x2], [y0, y1, y2]).tolist()
    assert first - base == pytest.approx(stoop.step_height, abs=1e-9)
    assert top - base == pytest.approx(stoop.step_count * stoop.step_height, abs=1e-9)
    # The steps rise towards a building: the door is just past the top tread.
    buildings = [Polygon(z.polygon, z.holes) for z in scene.zones if z.kind == "building"]
    assert min(b.distance(feature_polygon(stoop)) for b in buildings) < 0.01


def test_features_stay_off_hard_ground_and_the_route_which_runs_on_curb_level():
    scene = small_city(1)
    route = LineString([scene.task.start.position, *scene.task.route])
    hard = [
        Polygon(z.polygon, z.holes)
        for z in scene.zones
        if z.kind in ("roadway", "curb", "crosswalk", "parking")
    ]
    curb = next(f.rise for f in scene.terrain.features if f.id.startswith("curb-"))
    # Front steps and terraces; the curbs' slabs and ramps are tested in test_city_curbs.
    shapes = [feature_polygon(f) for f in scene.terrain.features if not f.id.startswith("curb-")]
    for shape in shapes:
        probe = shape.buffer(-0.05)
        assert not any(h.intersects(probe) for h in hard)
        assert shape.distance(route) >= ROBOTS["quadruped"].radius
    points = [route.interpolate(d) for d in np.arange(0.0, route.length, 0.5)]
    z = height_at(scene, [p.x for p in points], [p.y for p in points])
    # On the sidewalks' level, down a ramp to a crosswalk's, now and then on rough paving.
    assert np.mean((np.abs(z - curb) < 1e-9) | (np.abs(z) < 1e-9)) >= 0.95
    assert z.min() > -0.1 and z.max() < curb + 0.1
    assert sum(shape.distance(route) < 5.0 for shape in shapes) >= 1


def test_wheels_cannot_cross_steps_and_a_terrace_is_walled_but_where_its_steps_are():
    scene = small_city(0)
    stoop = next(f for f in scene.terrain.features if f.id.startswith("front-steps"))
    x, y = at(stoop, stoop.length / 2)
    xs, ys = np.array([x]), np.array([y])
    assert blocked_cells(scene.terrain, ROBOTS["wheeled"], xs, ys)[0, 0]
    assert not blocked_cells(scene.terrain, ROBOTS["quadruped"], xs, ys)[0, 0]
    city = small_city(3)
    terrace = next(f for f in city.terrain.features if f.id.startswith("terrace-") and f.kind == "landing")
    # Its top is level ground; its side away from its steps and its ramp is a wall to legs too.
    c, s = math.cos(terrace.yaw), math.sin(terrace.yaw)
    hw = terrace.width / 2 - 0.02
    side = (terrace.center[0] + s * hw, terrace.center[1] - c * hw)
    for (x, y), walled in ((terrace.center, False), (side, True)):
        assert blocked_cells(city.terrain, ROBOTS["quadruped"], np.array([x]), np.array([y]))[0, 0] == walled
    assert max_step(scene) >= max(
        f.step_count * f.step_height for f in scene.terrain.features if f.kind == "steps"
    )


FEATURES = (
    StepsFeature(
        id="steps-1", kind="steps", center=(2.0, 5.0), yaw=0.5, length=1.5, width=2.0,
        step_height=0.15, step_count=3, landing=0.6,
    ),
    RampFeature(
        id="ramp-1", kind="ramp", center=(6.0, 5.0), yaw=2.0, length=3.6, width=1.5, height=0.3, rise=0.3,
    ),
    LandingFeature(
        id="landing-1", kind="landing", center=(8.5, 5.0), yaw=-0.3, length=1.5, width=1.0, height=0.3,
        rise=0.3,
    ),
)  # fmt: skip


@pytest.fixture(scope="module")
def featured() -> Scene:
    scene = load_scene("examples/nav_static_10m.json")
    return scene.model_copy(update={"terrain": scene.terrain.model_copy(update={"features": FEATURES})})


def test_features_round_trip_and_scenes_without_them_leave_the_key_out(featured):
    assert Scene.model_validate_json(dumps(featured)) == featured
    assert '"features"' not in dumps(load_scene("examples/nav_static_10m.json"))
    assert '"features"' not in dumps(citygen.generate("urban-nav-2-train", index=0))


def test_mjcf_ground_under_features_is_height_at(featured):
    model = mjcf.build(featured)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    assert any(model.geom(g).name.startswith("terrain:steps:steps-1:") for g in range(model.ngeom))
    rng = np.random.default_rng(0)
    geom = np.zeros(1, dtype=np.int32)
    groups = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)
    for x, y in rng.uniform([0.2, 3.9], [9.8, 6.1], size=(800, 2)):
        dist = mujoco.mj_ray(
            model, data, np.array([x, y, 5.0]), np.array([0.0, 0.0, -1.0]), groups, 1, -1, geom
        )
        assert 5.0 - dist == pytest.approx(float(height_at(featured, x, y)), abs=1e-4)


def test_occupancy_and_the_terrain_mesh_show_the_steps(featured):
    m = occupancy.occupancy(featured, 0.05)
    x, y = at(FEATURES[0], 0.5)
    cell = m.cell(x, y)
    assert m.terrain_classes[m.terrain[cell]] == "stair"
    assert m.heights[cell] == pytest.approx(0.3, abs=1e-6)
    assert m.terrain_classes[m.terrain[m.cell(*at(FEATURES[1], 1.0))]] == "slope"
    mesh = terrain_mesh(featured)
    assert mesh.is_watertight
    hit, _, _ = mesh.ray.intersects_location([[x, y, 5.0]], [[0.0, 0.0, -1.0]], multiple_hits=False)
    assert hit[0][2] == pytest.approx(0.3, abs=1e-9)


def test_urdf_ground_under_features_is_height_at(featured, tmp_path):
    from citygen.exporters import urdf
    from tests.test_export_urdf import Bullet

    path = urdf.export(featured, tmp_path)[0]
    body = Bullet(path)
    try:
        rng = np.random.default_rng(1)
        for x, y in rng.uniform([0.2, 3.9], [9.8, 6.1], size=(400, 2)):
            link, z = body.ray((x, y))
            if link is not None and link.startswith(("ground/", "zone")):
                assert z == pytest.approx(float(height_at(featured, x, y)), abs=2e-3)
        for f, a in ((FEATURES[0], 1.4), (FEATURES[1], 1.8), (FEATURES[2], 0.7)):  # on each feature
            x, y = at(f, a)
            assert body.ray((x, y))[1] == pytest.approx(float(height_at(featured, x, y)), abs=2e-3)
    finally:
        body.close()


def test_usd_terrain_holds_the_feature_solids(featured, tmp_path):
    from pxr import Usd, UsdGeom

    from citygen.exporters import usd

    stage = Usd.Stage.Open(str(usd.export(featured, tmp_path)[0]))
    points = np.concatenate(
        [
            np.asarray(UsdGeom.Mesh(p).GetPointsAttr().Get())
            for p in stage.Traverse()
            if p.GetTypeName() == "Mesh" and "/Terrain/" in str(p.GetPath())
        ]
    )
    for f in FEATURES:  # the top of each feature, over its rectangle
        top = points[np.abs(points[:, 2] - (f.height + (f.rise if f.kind != "steps" else 0.45))) < 1e-4]
        assert any(feature_polygon(f).buffer(0.01).contains(Point(p[:2])) for p in top)
