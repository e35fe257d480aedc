"""Buildings from their footprints (issue 48): a building zone with a ``height`` is a solid,
its polygon (holes cut out) extruded, in every format. A hand-written scene of an L-shaped
building and one around a courtyard, checked in each format's real reader: spheres dropped
in MuJoCo into the courtyard and the L's inner corner reach the ground, those dropped on the
roofs rest at the roofs' heights."""

from __future__ import annotations

import numpy as np
import pytest
import trimesh
from shapely.geometry import Point, Polygon

from citygen import validate
from citygen.exporters import mjcf
from citygen.exporters.solids import solids
from citygen.spec import Scene

ELL = [[2, 2], [16, 2], [16, 8], [8, 8], [8, 20], [2, 20]]
COURT_OUTER = [[20, 2], [38, 2], [38, 20], [20, 20]]
COURT_HOLE = [[25, 7], [33, 7], [33, 15], [25, 15]]
#: Where a sphere is dropped, and the height (m) its lowest point should come to rest at.
DROPS = {
    "corner": ((11.0, 12.0), 0.0),  # inside the L's convex hull, outside the L
    "courtyard": ((29.0, 11.0), 0.0),
    "ell_roof": ((5.0, 5.0), 10.0),
    "court_roof": ((22.0, 5.0), 12.5),
}
RADIUS = 0.3


@pytest.fixture(scope="module")
def scene() -> Scene:
    return Scene.model_validate({
        "format": "citygen.scene/1",
        "bounds": {"min": [0, 0], "max": [40, 24]},
        "zones": [
            {"id": "ell", "kind": "building", "height": 10.0, "polygon": ELL},
            {"id": "court", "kind": "building", "height": 12.5, "polygon": COURT_OUTER,
             "holes": [COURT_HOLE]},
            {"id": "yard", "kind": "plaza", "polygon": COURT_HOLE},
        ],
    })  # fmt: skip


def test_the_scene_is_valid_and_its_solids_tile_the_footprints(scene):
    assert validate(scene) == []
    ell, court = solids(scene)
    assert (ell.bottom, ell.top, court.top) == (0.0, 10.0, 12.5)
    for solid in (ell, court):
        pieces = solid.pieces()
        tops = [Polygon(p[:, :2]) for p in pieces.prisms]
        for centre, half, _ in pieces.boxes:  # axis-aligned here
            tops.append(Polygon([(centre[0] + sx * half[0], centre[1] + sy * half[1])
                                 for sx, sy in ((-1, -1), (1, -1), (1, 1), (-1, 1))]))  # fmt: skip
        assert sum(t.area for t in tops) == pytest.approx(solid.shape.area)
        assert all(t.convex_hull.area == pytest.approx(t.area) for t in tops)
        verts, faces = solid.mesh()
        mesh = trimesh.Trimesh(verts, faces)
        assert mesh.is_watertight and mesh.volume == pytest.approx(solid.shape.area * solid.zone.height)


def _with_spheres(xml: str) -> str:
    bodies = "".join(
        f'<body name="drop:{name}" pos="{x} {y} 15"><freejoint/>'
        f'<geom type="sphere" size="{RADIUS}" contype="{mjcf.ROBOT_BIT}" '
        f'conaffinity="{mjcf.ROBOT_CONAFFINITY}"/></body>'
        for name, ((x, y), _) in DROPS.items()
    )
    return xml.replace("</worldbody>", bodies + "</worldbody>")


def test_mujoco_collides_with_the_solid_not_its_convex_hull(scene):
    import mujoco

    model_xml = mjcf.to_mjcf(scene)
    labels = {lab for lab in mjcf.geom_labels(mjcf.build(scene)) if lab is not None}
    assert ("solid", "building", "ell") in labels and ("solid", "building", "court") in labels
    model = mujoco.MjModel.from_xml_string(_with_spheres(model_xml.xml), dict(model_xml.assets))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=1500)
    for name, (_, rest) in DROPS.items():
        z = data.body(f"drop:{name}").xpos[2] - RADIUS
        assert z == pytest.approx(rest, abs=0.02), name
        assert np.linalg.norm(data.body(f"drop:{name}").cvel) < 1e-2, name


def test_usd_has_each_solid_as_a_closed_mesh_collider(scene, tmp_path):
    from pxr import Usd, UsdGeom, UsdPhysics

    from citygen.exporters import usd

    files = usd.export(scene, tmp_path)
    assert usd.check(files[0], warnings=True) == []
    stage = Usd.Stage.Open(str(files[0]))
    for solid in solids(scene):
        prim = stage.GetPrimAtPath(f"/World/Solids/{solid.zone.id}")
        assert prim and prim.HasAPI(UsdPhysics.CollisionAPI)
        mesh = UsdGeom.Mesh(prim)
        points = np.asarray(mesh.GetPointsAttr().Get(), dtype=float)
        faces = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
        assert points[:, 2].min() == 0.0 and points[:, 2].max() == pytest.approx(solid.top)
        body = trimesh.Trimesh(points, faces)
        assert body.is_watertight and body.volume == pytest.approx(
            solid.shape.area * solid.zone.height, rel=1e-6
        )
        assert prim.GetAttribute("semantics:labels:class").Get() == ["building"]


def test_pybullet_collides_with_the_urdf_solid_not_its_convex_hull(scene, tmp_path):
    import pybullet as p

    from citygen.exporters import urdf

    path = urdf.export(scene, tmp_path)[0]
    client = p.connect(p.DIRECT)
    try:
        p.setGravity(0, 0, -9.81, physicsClientId=client)
        p.loadURDF(str(path), useFixedBase=True, physicsClientId=client)
        shape = p.createCollisionShape(p.GEOM_SPHERE, radius=RADIUS, physicsClientId=client)
        balls = {
            name: p.createMultiBody(1.0, shape, basePosition=(x, y, 15.0), physicsClientId=client)
            for name, ((x, y), _) in DROPS.items()
        }
        for _ in range(1500):
            p.stepSimulation(physicsClientId=client)
        for name, (_, rest) in DROPS.items():
            (_, _, z), _ = p.getBasePositionAndOrientation(balls[name], physicsClientId=client)
            assert z - RADIUS == pytest.approx(rest, abs=0.03), name
    finally:
        p.disconnect(client)


def test_the_runner_takes_the_solid_for_an_obstacle_in_contacts_and_the_local_map(scene):
    from citygen.runner import localmap
    from citygen.runner.robots import load_robot
    from citygen.runner.scenes import prepare

    prepared = prepare(scene, load_robot("wheeled"))
    names = [prepared.model.geom(g).name for g in np.flatnonzero(prepared.obstacle_geoms)]
    assert names and all(n.startswith("solid:building:") for n in names)
    layers = localmap.static_layers(scene, prepared.occupancy)
    m = localmap.LocalMap()
    # At the courtyard's middle facing +x: its walls 4 m ahead, open ground between.
    grid = m(layers, (29.0, 11.0, 0.0), 0.0)
    ahead = m.u.reshape(m.shape)
    across = np.abs(m.v.reshape(m.shape)) < 1.0
    wall = across & (ahead > 4.2) & (ahead < 5.5)
    yard = across & (ahead > -3.0) & (ahead < 3.0)
    assert np.all(grid[0][wall] == localmap.MAX_ELEVATION) and np.all(grid[1][wall] == 0)
    assert np.all(grid[0][yard] == 0.0) and np.all(grid[1][yard] == 1)


def test_glb_draws_each_solid_and_the_occupancy_map_blocks_its_footprint_only(scene):
    from citygen.exporters import glb
    from citygen.exporters.occupancy import occupancy

    graph = glb.build(scene, y_up=False)
    for solid in solids(scene):
        mesh = graph.geometry[f"solid/{solid.zone.id}"]
        assert f"solid/{solid.zone.id}" in graph.graph.nodes
        assert mesh.is_watertight and mesh.bounds[1, 2] == pytest.approx(solid.top)
        assert mesh.volume == pytest.approx(solid.shape.area * solid.zone.height)
    occ = occupancy(scene, resolution=0.25)
    blocked, walkable = occ.obstacle_mask(), occ.walkable_mask()
    for (x, y), _ in DROPS.values():
        inside = any(s.shape.contains(Point(x, y)) for s in solids(scene))
        assert blocked[occ.cell(x, y)] == inside
    assert walkable[occ.cell(29.0, 11.0)]  # the courtyard's plaza


def test_a_robot_driving_at_a_wall_stops_at_it_and_is_in_collision(scene):
    from citygen.runner.make import make_env

    data = scene.model_dump(mode="json", exclude_none=True)
    walk = [[38, 0], [40, 0], [40, 24], [38, 24]]  # east of the courtyard building
    data["zones"].append({"id": "walk", "kind": "sidewalk", "polygon": walk})
    data["task"] = {
        "kind": "nav-static", "robot": "wheeled", "start": {"position": [28.0, 11.0], "yaw": 0.0},
        "goal": [39.0, 11.0], "time_limit": 60.0,
    }  # fmt: skip
    env = make_env("nav-static", Scene.model_validate(data), max_steps=200)
    env.reset(seed=0)
    hits, furthest = 0, 0.0
    for _ in range(100):  # full speed ahead, at the courtyard's east wall (x = 33)
        *_, info = env.step(np.array([1.0, 0.0], dtype=np.float32))
        hits += bool(info["collision"])
        furthest = max(furthest, env.handle.pose(env.data)[0])
    assert hits > 10 and 32.0 < furthest < 33.0
