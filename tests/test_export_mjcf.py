"""MJCF exporter: the model loads in MuJoCo and is the scene, seen through MuJoCo's eyes.

Boxes dropped on every kind of tile come to rest on ``height_at``; a ray cast down at
random points hits ground of the zone's friction at the terrain's height; objects,
agents, sites and cameras stand where the spec puts them; the same scene gives the
same bytes in another process.
"""

from __future__ import annotations

import math
import subprocess
import sys
import warnings

import mujoco
import numpy as np
import pytest
import shapely
import trimesh
from shapely.geometry import Point, Polygon

from citygen.assets import Box, Capsule, ConvexMesh, Cylinder, resolve
from citygen.errors import ExportError, SpecError
from citygen.exporters import ExportWarning, mjcf
from citygen.exporters.mjcf import heightfield
from citygen.exporters.mjcf.text import ints, num
from citygen.generate import generate, layout
from citygen.geometry import convex
from citygen.geometry.terrain import height_at
from citygen.io import save_scene
from citygen.spec import Scene
from citygen.spec.config import BlocksConfig, GeneratorConfig
from citygen.spec.scene import Meta
from citygen.spec.surfaces import FRICTION
from tests.conftest import ROOT

EXAMPLES = [ROOT / "examples" / "street_corner.json", ROOT / "examples" / "nav_static_10m.json"]
HALF = 0.05  # half side (m) of the boxes dropped on the ground


def scene_of(**parts) -> Scene:
    return Scene.model_validate({"format": "citygen.scene/1", **parts})


def labels(model) -> list:
    return mjcf.geom_labels(model)


def text(model, name: str) -> str:
    i = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXT, name)
    start = model.text_adr[i]
    return bytes(model.text_data[start : start + model.text_size[i] - 1]).decode()


# --- a scene with every kind of tile ----------------------------------------------------

S = 2.5  # tile size, m
TILES = [  # a 3 x 4 grid, row-major from the south-west; neighbours agree on their edges
    {"kind": "flat", "height": 0.0},
    {"kind": "slope", "angle": 0.15, "ascent": "+x"},
    {"kind": "flat", "height": round(S * math.tan(0.15), 4), "friction": 1.1},
    {"kind": "stair", "step_height": 0.1, "step_count": 3, "ascent": "-x", "height": 0.0},
    {"kind": "rough", "amplitude": 0.06, "scale": 1.0, "seed": 3},
    {"kind": "stair", "step_height": 0.12, "step_count": 3, "ascent": "+y"},
    {"kind": "slope", "angle": 0.2, "shape": "pyramid"},
    {"kind": "stair", "step_height": 0.1, "step_count": 2, "shape": "pit"},
    {"kind": "slope", "angle": 0.12, "ascent": "+y", "height": 0.0},
    {"kind": "flat", "height": 0.36},
    {"kind": "slope", "angle": 0.2, "shape": "pit"},
    {"kind": "stair", "step_height": 0.1, "step_count": 2, "shape": "pyramid"},
]
ORIGIN = (1.0, 2.0)
ZONES = [
    {"id": "walk", "kind": "sidewalk", "polygon": [[0, 0], [12, 0], [12, 6], [0, 6]]},
    {"id": "lawn", "kind": "vegetation", "polygon": [[0, 6], [12, 6], [6, 9.5], [0, 9.5]]},
    {"id": "yard", "kind": "plaza", "polygon": [[12, 0], [14, 0], [14, 14], [8, 14], [12, 10]],
     "holes": [[[12.5, 5], [13.5, 5], [13.5, 6], [12.5, 6]]]},
]  # fmt: skip


def terrain_scene() -> Scene:
    # The stair at tile 3 falls towards +x from 0.3 at its west edge; row 1 tile 1 (index 5)
    # climbs +y by 0.36 into the flat tile at 0.36 (index 9); the pyramids and pits are level.
    tiles = [dict(t) for t in TILES]
    tiles[3]["height"] = 0.0
    tiles[2]["height"] = 0.3
    tiles[1]["angle"] = round(math.atan(0.3 / S), 4)
    tiles[8]["angle"] = 0.0  # a slope of angle 0: level ground
    return scene_of(
        bounds={"min": [0, 0], "max": [14, 14]},
        terrain={"origin": list(ORIGIN), "tile_size": S, "rows": 3, "cols": 4, "tiles": tiles},
        zones=ZONES,
    )


def tile_points(scene: Scene) -> list[tuple[int, float, float]]:
    """Three points inside each tile, away from its edges: (tile index, x, y)."""
    t = scene.terrain
    out = []
    for k in range(len(t.tiles)):
        r, c = divmod(k, t.cols)
        for u, v in ((0.45, 0.5), (1.3, 1.95), (2.05, 0.9)):
            out.append((k, t.origin[0] + c * S + u, t.origin[1] + r * S + v))
    return out


def with_boxes(xml: str, points, z: float) -> str:
    bodies = "".join(
        f'<body name="drop{i}" pos="{x} {y} {z + height}"><freejoint/>'
        f'<geom type="box" size="{HALF} {HALF} {HALF}" mass="0.2" contype="{mjcf.ROBOT_BIT}" '
        f'conaffinity="{mjcf.ROBOT_CONAFFINITY}"/></body>'
        for i, (x, y, height) in enumerate(points)
    )
    return xml.replace("</worldbody>", bodies + "</worldbody>")


def test_boxes_dropped_on_every_tile_kind_rest_on_the_ground():
    scene = terrain_scene()
    assert {t.kind for t in scene.terrain.tiles} == {"flat", "slope", "stair", "rough"}
    mj = mjcf.to_mjcf(scene)
    pts = [*tile_points(scene), (-1, 0.5, 0.5), (-1, 13.5, 13.5), (-1, -5.0, 7.0)]
    drops = [(x, y, float(height_at(scene, x, y))) for _, x, y in pts]
    model = mujoco.MjModel.from_xml_string(with_boxes(mj.xml, drops, 0.25), dict(mj.assets))
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, 1000)  # 2 s
    for i, (k, x, y) in enumerate(pts):
        pos = data.body(f"drop{i}").xpos
        ground = float(height_at(scene, pos[0], pos[1]))
        assert abs(pos[2] - HALF - ground) < 0.03, (k, (x, y), pos, ground)
        assert np.linalg.norm(data.body(f"drop{i}").cvel) < 0.05, (k, (x, y))  # at rest


def test_hybrid_terrain_is_slopes_as_prisms_and_rough_tiles_as_heightfields():
    """``terrain="hybrid"`` (the runner's under feet): every slope tile is convex pieces, every
    rough tile one heightfield, stairs boxes, and the ground under a ray is where it was."""
    scene = terrain_scene()
    model = mjcf.build(scene, terrain="hybrid")
    kinds: dict[str, set[int]] = {}
    for (layer, cls, _), g in zip(labels(model), range(model.ngeom), strict=True):
        if layer == "terrain":
            kinds.setdefault(cls, set()).add(int(model.geom_type[g]))
    hfield, mesh, box = (
        int(t) for t in (mujoco.mjtGeom.mjGEOM_HFIELD, mujoco.mjtGeom.mjGEOM_MESH, mujoco.mjtGeom.mjGEOM_BOX)
    )
    assert kinds["slope"] <= {mesh, box} and mesh in kinds["slope"]
    assert kinds["rough"] == {hfield} and kinds["stair"] == {box}
    stiff = model.geom_solref[model.geom_type == hfield]  # feet sink too deep at MuJoCo's 0.02 s
    assert (stiff == (heightfield.HYBRID_HFIELD_TIMECONST, 1.0)).all()
    plain = mjcf.build(scene)
    assert (plain.geom_solref[plain.geom_type == hfield][:, 0] == 0.02).all()
    assert check_ground_by_rays(scene, model, 200, seed=6, own={2: 1.1}) > 30


def check_ground_by_rays(scene: Scene, model, n: int, seed: int, own: dict[int, float] | None = None) -> int:
    """Cast ``n`` rays down at random points in and around the scene: each hits the ground
    at ``height_at``, on the geom of the tile (a stair, slope or rough one) or of the zone
    under it, with that zone's friction (or the tile's own, ``own``: tile index -> mu).
    Returns how many rays hit a zone slab inside the scene."""
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    zones = [(z, Polygon(z.polygon, z.holes)) for z in scene.zones]
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    rng = np.random.default_rng(seed)
    ground_only = np.array([1, 0, 0, 0, 0, 0], dtype=np.uint8)
    geomid = np.zeros(1, dtype=np.int32)
    lab = labels(model)
    own = own or {}
    t = scene.terrain
    on_zones = 0
    xs = rng.uniform(x0 - 3, x1 + 3, n)
    ys = rng.uniform(y0 - 3, y1 + 3, n)
    for x, y in zip(xs, ys, strict=True):
        start = np.array([x, y, 50.0])
        dist = mujoco.mj_ray(model, data, start, np.array([0, 0, -1.0]), ground_only, 1, -1, geomid)
        assert dist > 0, (x, y)
        g = int(geomid[0])
        assert abs((50.0 - dist) - float(height_at(scene, x, y))) < 0.02, (x, y, lab[g])
        layer, cls, ident = lab[g]
        tile = None
        if t is not None:
            col, row = (
                math.floor((x - t.origin[0]) / t.tile_size),
                math.floor((y - t.origin[1]) / t.tile_size),
            )
            if 0 <= col < t.cols and 0 <= row < t.rows:
                tile = row * t.cols + col
        if tile is not None and not heightfield.level(t.tiles[tile]):
            assert layer == "terrain" and ident == f"{row}_{col}" and cls == t.tiles[tile].kind
            continue
        assert layer == "zone", (x, y, lab[g])
        if not (x0 <= x <= x1 and y0 <= y <= y1) and tile is None:
            assert (cls, ident) == ("none", "outside")
            continue
        p = Point(x, y)
        if any(poly.boundary.distance(p) < 1e-6 for _, poly in zones):
            continue  # on a border: either side is right
        hit = [z for z, poly in zones if poly.contains(p)]
        if hit:
            on_zones += 1
            assert (cls, ident) == (hit[0].kind, hit[0].id), (x, y)
            assert model.geom_friction[g, 0] == pytest.approx(own.get(tile, hit[0].mu)), (x, y, ident)
        else:
            assert (cls, ident) == ("none", "ground")
            assert model.geom_friction[g, 0] == pytest.approx(own.get(tile, mjcf.DEFAULT_FRICTION))
    return on_zones


def test_a_ray_cast_down_hits_the_zone_friction_at_the_terrain_height():
    scene = terrain_scene()
    assert check_ground_by_rays(scene, mjcf.build(scene), 400, seed=5, own={2: 1.1}) > 60


@pytest.mark.parametrize("seed", [3, 4])
def test_generated_scenes_compile_with_zone_friction_everywhere(seed):
    """A whole generated scene (region layout: terrain, objects, agents, task) and a road
    block's curved zones (blocks layout, stages 1 and 2)."""
    scene = generate(GeneratorConfig(size=(15.0, 15.0)), seed)
    model = mjcf.build(scene)
    assert check_ground_by_rays(scene, model, 300, seed=seed) > 50
    assert model.nmocap == len(scene.agents)
    assert model.nbody == 1 + len(scene.placements) + len(scene.agents)
    blocks = GeneratorConfig(size=(60.0, 60.0), layout="blocks", blocks=BlocksConfig(count=1))
    roads = layout(blocks, seed)
    model = mjcf.build(roads)
    assert model.nmesh > 20  # curved zones are convex meshes
    assert check_ground_by_rays(roads, model, 300, seed=seed) > 150


def test_zone_slabs_tile_the_flat_ground_exactly():
    """The slabs' tops add up to the flat ground's area, with no overlap (a ray hits one)."""
    scene = terrain_scene()
    model = mjcf.build(scene, apron=0.0)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    area = 0.0
    for g, lab in enumerate(labels(model)):
        if lab and lab[0] == "zone":
            if model.geom_type[g] == mujoco.mjtGeom.mjGEOM_BOX:
                area += 4 * model.geom_size[g, 0] * model.geom_size[g, 1]
            else:
                verts = world_vertices(model, data, g)
                top = verts[verts[:, 2] > verts[:, 2].max() - 1e-4]
                area += shapely.MultiPoint(top[:, :2]).convex_hull.area
    t = scene.terrain
    level = sum(1 for k, tile in enumerate(t.tiles) if tile.kind == "flat" or k == 8)
    expected = 14 * 14 - t.rows * t.cols * S * S + level * S * S
    assert area == pytest.approx(expected, rel=1e-5)


def test_friction_of_non_level_tiles_and_a_warning_for_mixed_zones():
    scene = terrain_scene()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = mjcf.build(scene)
    messages = [str(w.message) for w in caught if issubclass(w.category, ExportWarning)]
    # Row 2 (y 7 to 9.5) straddles the sidewalk, the lawn and the ground between.
    assert len(messages) == 1 and "different friction" in messages[0], messages
    lab = labels(model)
    stair = [g for g, x in enumerate(lab) if x and x[:3] == ("terrain", "stair", "0_3")]
    assert len(stair) == 4  # one box per tread
    assert all(model.geom_friction[g, 0] == pytest.approx(FRICTION["concrete"]) for g in stair)


# --- objects ----------------------------------------------------------------------------


def objects_scene() -> Scene:
    return scene_of(
        bounds={"min": [0, 0], "max": [20, 20]},
        placements=[
            {"id": "bench-1", "asset": "bench/0003", "position": [4, 5, 0], "yaw": 0.7, "scale": 1.2},
            {"id": "bench-2", "asset": "bench/0003", "position": [10, 5, 0.25], "yaw": -2.0},
            {"id": "lamp", "asset": "lamp_post/0002", "position": [15, 15, 0]},
            {"id": "hydrant", "asset": "fire_hydrant/0001", "position": [3, 12, 0], "scale": 0.8},
            {"id": "bin", "asset": "trash_bin/0011", "position": [7, 12, 0], "yaw": 1.0},
            {"id": "bollard", "asset": "bollard/0004", "position": [12, 10, 0]},
            {"id": "planter", "asset": "planter/0005", "position": [16, 4, 0], "yaw": 3.0},
        ],
        agents=[
            {"id": "ped", "kind": "pedestrian", "start": [2, 2], "goal": [2, 8], "radius": 0.35},
            {"id": "big", "kind": "scooter", "start": [6, 2], "goal": [6, 8], "radius": 1.2},
            {"id": "car", "kind": "vehicle", "start": [18, 2], "goal": [8, 2], "length": 4.2, "width": 1.9},
        ],
        task={"kind": "traverse", "start": {"position": [1, 1], "yaw": 0.5}, "time_limit": 60,
              "route": [[5, 18], [19, 18]], "goal_tolerance": 0.8},
    )  # fmt: skip


def transform(points: np.ndarray, pl) -> np.ndarray:
    c, s = math.cos(pl.yaw), math.sin(pl.yaw)
    turn = np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])
    return (np.asarray(points) * pl.scale) @ turn.T + np.asarray(pl.position)


def world_vertices(model, data, g: int) -> np.ndarray:
    m = model.geom_dataid[g]
    start, n = model.mesh_vertadr[m], model.mesh_vertnum[m]
    return model.mesh_vert[start : start + n] @ data.geom_xmat[g].reshape(3, 3).T + data.geom_xpos[g]


def test_objects_stand_where_the_spec_puts_them():
    scene = objects_scene()
    model = mjcf.build(scene)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    lab = labels(model)
    kinds = set()
    for pl in scene.placements:
        asset = resolve(pl.asset)
        geoms = [g for g, x in enumerate(lab) if x and x[0] == "object" and x[2] == pl.id]
        assert len(geoms) == len(asset.parts)
        assert model.body(f"object:{pl.id}").id == model.geom_bodyid[geoms[0]]
        for g, part in zip(geoms, asset.parts, strict=True):
            assert lab[g][1] == asset.semantic_class
            kinds.add(type(part).__name__)
            if isinstance(part, ConvexMesh):
                want = transform(part.hull_points(), pl)
                got = world_vertices(model, data, g)
                np.testing.assert_allclose(got.min(axis=0), want.min(axis=0), atol=2e-4)
                np.testing.assert_allclose(got.max(axis=0), want.max(axis=0), atol=2e-4)
                continue
            np.testing.assert_allclose(data.geom_xpos[g], transform([part.pos], pl)[0], atol=1e-6)
            size = model.geom_size[g]
            if isinstance(part, Box):
                np.testing.assert_allclose(size, np.asarray(part.size) * pl.scale / 2, atol=1e-6)
                yaw = pl.yaw + part.yaw
                np.testing.assert_allclose(
                    data.geom_xmat[g].reshape(3, 3)[:2, 0], [math.cos(yaw), math.sin(yaw)], atol=1e-6
                )
            elif isinstance(part, Cylinder):
                np.testing.assert_allclose(
                    size[:2], [part.radius * pl.scale, part.height * pl.scale / 2], atol=1e-6
                )
            elif isinstance(part, Capsule):
                np.testing.assert_allclose(size[0], part.radius * pl.scale, atol=1e-6)
    assert {"Box", "Cylinder", "ConvexMesh"} <= kinds


def test_agents_are_mocap_bodies_of_their_size_that_touch_only_robots():
    scene = objects_scene()
    model = mjcf.build(scene)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for a in scene.agents:
        body = model.body(f"agent:{a.id}")
        assert body.mocapid[0] >= 0
        np.testing.assert_allclose(data.mocap_pos[body.mocapid[0]], [*a.start, 0.0], atol=1e-9)
        np.testing.assert_allclose(data.site(f"agent:{a.id}:goal").xpos, [*a.goal, 0.0])
        assert model.numeric(f"agent:{a.id}:speed").data[0] == pytest.approx(a.speed)
        g = model.geom(f"agent:{a.kind}:{a.id}:0")
        assert (g.contype[0], g.conaffinity[0]) == (mjcf.AGENT_BIT, 0)
        if a.kind == "vehicle":
            np.testing.assert_allclose(g.size, [a.length / 2, a.width / 2, mjcf.VEHICLE_HEIGHT / 2])
            heading = data.geom_xmat[g.id].reshape(3, 3)[:2, 0]
            np.testing.assert_allclose(heading, [-1.0, 0.0], atol=1e-6)  # towards its goal
        else:
            assert g.size[0] == pytest.approx(a.radius)
            assert data.geom_xpos[g.id][2] - g.size[0] - (
                g.size[1] if g.type[0] == 3 else 0
            ) == pytest.approx(0)
    # Moving an agent into an object makes no contact; a robot-like box there does.
    car = model.body("agent:car").mocapid[0]
    data.mocap_pos[car] = [4.0, 5.0, 0.0]
    mujoco.mj_forward(model, data)
    lab = labels(model)
    pairs = {
        (lab[c.geom1][0] if lab[c.geom1] else None, lab[c.geom2][0] if lab[c.geom2] else None)
        for c in data.contact
    }
    assert not any("agent" in p for p in pairs), pairs
    static = [g for g, x in enumerate(lab) if x and x[0] in ("zone", "terrain", "object")]
    assert set(model.geom_contype[static]) == {mjcf.STATIC_BIT}
    assert set(model.geom_conaffinity[static]) == {0}
    assert set(model.geom_priority[static]) == {1}


def test_task_sites_and_cameras():
    scene = objects_scene()
    model = mjcf.build(scene)
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    start = data.site("task:start")
    np.testing.assert_allclose(start.xpos[:2], [1, 1])
    np.testing.assert_allclose(start.xmat.reshape(3, 3)[:2, 0], [math.cos(0.5), math.sin(0.5)], atol=1e-6)
    np.testing.assert_allclose(data.site("task:goal").xpos[:2], [19, 18])
    np.testing.assert_allclose(data.site("task:waypoint:0").xpos[:2], [5, 18])
    assert model.site("task:goal").size[0] == pytest.approx(0.8)
    assert text(model, "task:kind") == "traverse" and text(model, "task:robot") == "wheeled"
    assert model.numeric("task:time_limit").data[0] == 60
    top = model.camera("top")
    assert model.cam_projection[top.id] == mujoco.mjtProjection.mjPROJ_ORTHOGRAPHIC and top.fovy[0] >= 20
    np.testing.assert_allclose(data.cam("top").xpos[:2], [10, 10])
    # The perspective camera looks at the scene's centre.
    cam = data.cam("perspective")
    forward = -cam.xmat.reshape(3, 3)[:, 2]
    to_centre = np.array([10, 10, 0]) - cam.xpos
    cos = forward @ to_centre / np.linalg.norm(to_centre)
    assert cos > 0.99


# --- mesh files -------------------------------------------------------------------------


def test_mesh_placements_are_meshes_and_concave_ones_warn(tmp_path):
    (tmp_path / "meshes").mkdir()
    two = trimesh.util.concatenate(
        [trimesh.creation.box((1, 1, 1), trimesh.transformations.translation_matrix((0, 0, 0.5))),
         trimesh.creation.box((0.4, 0.4, 2), trimesh.transformations.translation_matrix((2, 0, 1)))]
    )  # fmt: skip
    two.export(tmp_path / "meshes" / "two.stl")
    ell = trimesh.creation.annulus(0.5, 1.0, 1.0)  # a ring: one part, not convex
    ell.apply_translation((0, 0, 0.5))
    ell.export(tmp_path / "meshes" / "ring.obj")
    scene = scene_of(
        bounds={"min": [0, 0], "max": [10, 10]},
        placements=[
            {"id": "kiosk", "asset": "meshes/two.stl", "position": [3, 3, 0], "yaw": 1.5708},
            {"id": "ring", "asset": "meshes/ring.obj", "position": [7, 7, 0], "scale": 2.0},
        ],
    )
    path = tmp_path / "scene.json"
    save_scene(scene, path)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        files = mjcf.export(path, tmp_path / "out")
    messages = [str(w.message) for w in caught if issubclass(w.category, ExportWarning)]
    assert (
        len(messages) == 1
        and messages[0].startswith("$.placements[1].asset")
        and "convex hull" in messages[0]
    )
    model = mujoco.MjModel.from_xml_path(str(files[0]))
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    kiosk = [model.geom(f"object:mesh:kiosk:{k}").id for k in (0, 1)]
    centres = sorted(tuple(np.round(data.geom_xpos[g], 3)) for g in kiosk)
    assert centres == [(3.0, 3.0, 0.5), (3.0, 5.0, 1.0)]  # the yaw turned +x into +y
    ring = world_vertices(model, data, model.geom("object:mesh:ring:0").id)
    np.testing.assert_allclose(ring.max(axis=0), [9, 9, 2], atol=1e-3)
    with pytest.raises(ExportError, match="mesh_dir"):
        mjcf.to_xml(scene)
    assert "object:mesh:ring:0" in mjcf.to_xml(scene, mesh_dir=tmp_path)
    bad = scene.model_copy(
        update={"placements": (scene.placements[0].model_copy(update={"asset": "meshes/none.obj"}),)}
    )
    with pytest.raises(SpecError, match=r"\$\.placements\[0\]\.asset.*no such file"):
        mjcf.to_xml(bad, mesh_dir=tmp_path)


# --- files, bytes, errors ----------------------------------------------------------------


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.stem)
def test_examples_export_and_load_from_path(path, tmp_path):
    files = mjcf.export(path, tmp_path)
    assert files[0] == tmp_path / f"{path.stem}.xml"
    assert all(f.is_file() for f in files) and all(f.parent == tmp_path / "assets" for f in files[1:])
    model = mujoco.MjModel.from_xml_path(str(files[0]))
    scene = Scene.model_validate_json(path.read_text())
    bodies = {model.body(b).name for b in range(model.nbody)}
    assert {f"object:{p.id}" for p in scene.placements} | {f"agent:{a.id}" for a in scene.agents} <= bodies
    assert model.nmocap == len(scene.agents)
    for a in scene.agents:
        if a.kind == "vehicle" and a.route:
            assert text(model, f"agent:{a.id}:route") == " ".join(a.route)


def test_same_scene_same_bytes_in_another_process(tmp_path):
    a, b = tmp_path / "a", tmp_path / "b"
    files = mjcf.export(EXAMPLES[0], a)
    script = "import sys; from citygen.exporters import mjcf; mjcf.export(sys.argv[1], sys.argv[2])"
    env = {"PYTHONHASHSEED": "123", "PATH": "/usr/bin:/bin"}
    subprocess.run([sys.executable, "-c", script, str(EXAMPLES[0]), str(b)], check=True, cwd=ROOT, env=env)
    for f in files:
        assert (b / f.relative_to(a)).read_bytes() == f.read_bytes(), f.name
    assert sorted(p.name for p in (b / "assets").iterdir()) == sorted(f.name for f in files[1:])


def test_a_dataset_in_one_folder_shares_its_mesh_files(tmp_path):
    one = mjcf.export(objects_scene(), tmp_path, name="one")
    two = mjcf.export(objects_scene().model_copy(update={"agents": ()}), tmp_path, name="two")
    assert one[1:] == two[1:] and len(one) > 2
    assert len(list((tmp_path / "assets").iterdir())) == len(one) - 1
    assert (tmp_path / "one.xml").read_text() != (tmp_path / "two.xml").read_text()


def test_name_from_meta_and_bad_options(tmp_path):
    scene = objects_scene().model_copy(update={"meta": Meta(split="urban-nav-2", index=7)})
    assert mjcf.export(scene, tmp_path)[0].name == "urban-nav-2-00007.xml"
    assert mjcf.export(terrain_scene(), tmp_path)[0].name == "scene.xml"
    with pytest.raises(ExportError, match="unknown option 'size'"):
        mjcf.export(scene, tmp_path, size=3)
    with pytest.raises(ExportError, match="resolution"):
        mjcf.to_xml(scene, resolution=0)
    with pytest.raises(ExportError, match="name"):
        mjcf.export(scene, tmp_path, name="../x")
    bad = scene.model_copy(
        update={"placements": (scene.placements[0].model_copy(update={"asset": "nope/0001"}),)}
    )
    with pytest.raises(SpecError, match=r"\$\.placements\[0\]\.asset"):
        mjcf.to_xml(bad)


def test_numbers_are_compact():
    xml = mjcf.to_xml(objects_scene())
    assert "-0 " not in xml and "e-" not in xml and "e+" not in xml
    assert num(0.1 + 0.2) == "0.3" and num(-1e-9) == "0" and num(12.0) == "12"


def test_palette_is_the_pictures():
    from citygen.exporters.picture import ZONE_COLORS

    assert list(mjcf.ZONE_RGBA) == list(ZONE_COLORS)
    for kind, hex_colour in ZONE_COLORS.items():
        assert mjcf.ZONE_RGBA[kind][:3] == tuple(int(hex_colour[i : i + 2], 16) / 255 for i in (1, 3, 5))


# --- convex pieces -----------------------------------------------------------------------


def star(n: int, r0: float, r1: float) -> list[tuple[float, float]]:
    a = np.arange(2 * n) * math.pi / n
    r = np.where(np.arange(2 * n) % 2 == 0, r1, r0)
    return list(zip(r * np.cos(a), r * np.sin(a), strict=True))


@pytest.mark.parametrize(
    "poly",
    [
        Polygon(star(7, 1.0, 3.0)),
        Polygon(star(5, 2.0, 4.0), [[(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)]]),
        Polygon([(0, 0), (4, 0), (4, 1), (1, 1), (1, 3), (4, 3), (4, 4), (0, 4)]),
        Polygon(
            [(0, 0), (6, 0), (6, 6), (0, 6)],
            [[(1, 1), (2, 1), (2, 2), (1, 2)], [(3, 3), (5, 3), (5, 4), (3, 4)]],
        ),
        Polygon([(0, 0), (3, 0), (3, 1), (2, 1), (1, 2), (0, 1)]),
    ],
    ids=["star", "star-hole", "rectilinear-C", "rect-holes", "mixed"],
)
def test_convex_pieces_are_convex_and_tile_the_polygon(poly):
    pieces = [Polygon(r) for r in mjcf.convex_pieces(poly)]
    assert all(p.is_valid and p.area > 0 for p in pieces)
    assert all(p.convex_hull.area == pytest.approx(p.area, rel=1e-9) for p in pieces)
    assert sum(p.area for p in pieces) == pytest.approx(poly.area, rel=1e-9)
    assert shapely.union_all(pieces).symmetric_difference(poly).area < 1e-9
    if convex._rectilinear(poly):
        assert all(convex.as_rectangle(convex._clean_ring(np.asarray(p.exterior.coords))) for p in pieces)


@pytest.mark.parametrize("scale", [0.2, 0.7, 3.3])
@pytest.mark.parametrize("cells", [1, 5, 64])
def test_tile_grid_is_tile_height_bit_for_bit(scale, cells):
    """The heightfields sample rough tiles per axis (tile_grid): the same float64 bits as
    tile_height at every sample, also where the grid is coarser than the noise lattice
    (samples skip lattice nodes) and on an uneven grid."""
    from citygen.geometry.terrain import tile_grid, tile_height
    from citygen.spec.terrain import RoughTile

    s = 2.5
    tile = RoughTile(kind="rough", amplitude=0.08, scale=scale, seed=1234567, height=0.3)
    g = np.linspace(0.0, s, cells + 1)
    h = s * np.sqrt(np.linspace(0.0, 1.0, cells + 4))
    for us, vs in ((g, g), (g, h), (h, g)):
        grid = tile_grid(tile, s, us, vs)
        assert grid.shape == (len(vs), len(us))
        assert grid.tobytes() == tile_height(tile, s, us[None, :], vs[:, None]).tobytes()
    assert np.ptp(tile_grid(tile, s, g, g)) > 0 or cells == 1


def test_elevation_text_is_the_plain_join():
    """The heightfield's elevation text: integers separated by single spaces, as str writes
    them, across digit counts (powers of ten and their neighbours), zeros, negatives and
    a 2-d array read row by row."""
    rng = np.random.default_rng(3)
    cases = [[], [0], [7, 10, 99999, 0, 123456789012], [9, 10, 11, 99, 100, 101, 10**17], [-3, 0, 12]]
    cases += [
        rng.integers(0, 10 ** int(rng.integers(1, 18)), int(rng.integers(1, 300))).tolist() for _ in range(50)
    ]
    for values in cases:
        assert ints(values) == " ".join(map(str, values))
    grid = rng.integers(0, 5000, (17, 17))
    assert ints(grid[::-1]) == " ".join(map(str, grid[::-1].ravel().tolist()))


def test_zone_areas_are_the_per_tile_intersections():
    """The tiles' zone overlaps, computed at once, are each tile's own query, in ascending
    zone order, with the areas zone.intersection(square).area gives."""
    rng = np.random.default_rng(4)
    zones = [Point(rng.uniform(0, 10), rng.uniform(0, 10)).buffer(rng.uniform(0.5, 3)) for _ in range(12)]
    zones.append(Polygon([(0, 0), (10, 0), (10, 1), (0, 1)]))
    tree = shapely.STRtree(zones)
    xs, ys = np.meshgrid(np.arange(5) * 2.5 - 1.0, np.arange(4) * 2.5)
    xs, ys = xs.ravel(), ys.ravel()
    squares = shapely.box(xs, ys, xs + 2.5, ys + 2.5)
    tiles, zis, areas = heightfield._zone_areas(squares, zones, tree)
    expected = [
        (t, zi, zones[zi].intersection(squares[t]).area)
        for t in range(len(squares))
        for zi in sorted(tree.query(squares[t], predicate="intersects").tolist())
    ]
    assert len(expected) > len(squares)
    assert list(zip(tiles.tolist(), zis.tolist(), areas.tolist(), strict=True)) == expected
