"""USD export: the stage opens in usd-core, passes every registered validator, and holds the
scene: ground heights and friction, instanced objects with their labels and collision
parts, agents and the task; the same scene gives the same bytes."""

from __future__ import annotations

import math
import re
import warnings
from pathlib import Path

import numpy as np
import pytest
import shapely
from pxr import Gf, Usd, UsdGeom, UsdPhysics, UsdShade

from citygen.assets import resolve
from citygen.errors import ExportError, SpecError
from citygen.exporters import ExportWarning, usd
from citygen.exporters.usd import terrain as usd_terrain
from citygen.geometry.terrain import height_at, tile_mesh
from citygen.io import load_scene
from citygen.spec import Terrain
from citygen.spec.blocks import Pose2
from citygen.spec.placements import Placement
from citygen.spec.scene import Scene
from citygen.spec.surfaces import FRICTION
from citygen.spec.task import LocoTask
from tests.conftest import ROOT

EXAMPLES = ROOT / "examples"

CUBE_OBJ = """\
v -0.5 -0.5 0
v 0.5 -0.5 0
v 0.5 0.5 0
v -0.5 0.5 0
v -0.5 -0.5 1
v 0.5 -0.5 1
v 0.5 0.5 1
v -0.5 0.5 1
f 1 3 2
f 1 4 3
f 5 6 7
f 5 7 8
f 1 2 6
f 1 6 5
f 2 3 7
f 2 7 6
f 3 4 8
f 3 8 7
f 4 1 5
f 4 5 8
"""


def _terrain_scene() -> Scene:
    """A hand-built scene with every kind of ground the exporter distinguishes: flat tiles
    at two levels (some on the grid's edge above the ground outside it), a stair flight, a
    pyramid slope, a stair pit, rough tiles inside the grid and on its edge, a tile with
    its own material, a level slope; zones with a friction of their own, holes, ground no
    zone covers and ground outside the grid; objects turned and scaled, a mesh file,
    people and a vehicle, a traverse task."""
    flat, high = {"kind": "flat"}, {"kind": "flat", "height": 0.3}
    tiles = [
        # row 0: y in [0, 2.5]
        flat,
        {"kind": "stair", "step_height": 0.1, "step_count": 3},
        high,
        {"kind": "rough", "height": 0.3, "amplitude": 0.05, "scale": 1.0, "seed": 11},
        # row 1: y in [2.5, 5]
        {"kind": "slope", "angle": 0.1, "shape": "pyramid"},
        {"kind": "rough", "amplitude": 0.04, "scale": 0.8, "seed": 5},
        {"kind": "flat", "height": 0.3, "material": "rubber"},
        {"kind": "slope", "height": 0.3, "angle": 0.0},
        # row 2: y in [5, 7.5]
        flat,
        {"kind": "stair", "step_height": 0.1, "step_count": 2, "shape": "pit"},
        flat,
        flat,
    ]
    return Scene.model_validate(
        {
            "format": "citygen.scene/1",
            "meta": {"split": "test-usd", "index": 3, "seed": 2**64 - 1},
            "bounds": {"min": [0, 0], "max": [12, 8]},
            "zones": [
                {"id": "walk", "kind": "sidewalk", "polygon": [[0, 0], [6, 0], [6, 8], [0, 8]]},
                {
                    "id": "square",
                    "kind": "plaza",
                    "polygon": [[6, 0], [12, 0], [12, 4], [6, 4]],
                    "holes": [
                        [[6.5, 0.5], [7, 0.5], [7, 1], [6.5, 1]],
                        [[8, 1], [9, 1], [9, 2], [8, 2]],
                    ],
                    "friction": 0.65,
                },
            ],
            "terrain": {"origin": [0, 0], "tile_size": 2.5, "rows": 3, "cols": 4, "tiles": tiles},
            "placements": [
                {"id": "bench-1", "asset": "bench/0012", "position": [1.0, 1.0, 0.0], "yaw": 0.7},
                {"id": "bench-2", "asset": "bench/0012", "position": [11.0, 3.5, 0.0], "scale": 1.5},
                {"id": "lamp", "asset": "lamp_post/0002", "position": [5.8, 5.5, 0.0], "yaw": -2.0},
                {"id": "tree", "asset": "tree/0004", "position": [11.0, 6.0, 0.0]},
                {"id": "kiosk", "asset": "meshes/kiosk.obj", "position": [6.5, 6.5, 0.0], "yaw": 1.0},
            ],
            "agents": [
                {"id": "p1", "kind": "pedestrian", "start": [0.5, 0.5], "goal": [7.0, 1.5], "radius": 0.25},
                {"id": "s1", "kind": "scooter", "start": [3.0, 6.0], "goal": [3.0, 6.0]},
                {
                    "id": "car",
                    "kind": "vehicle",
                    "start": [11.0, 0.5],
                    "goal": [6.5, 0.5],
                    "length": 4.0,
                    "route": ["a", "b"],
                },
            ],
            "task": {
                "kind": "traverse",
                "robot": "quadruped",
                "start": {"position": [0.5, 3.0], "yaw": 0.5},
                "time_limit": 100.0,
                "route": [[4.0, 3.0], [8.5, 1.5], [11.5, 5.5]],
            },
        }
    )


def _generated_scenes() -> dict[str, Scene]:
    """A region scene (terrain of every kind) and a small road network; a few more objects
    (turned, repeated) are added by hand to both."""
    from citygen.generate import generate
    from citygen.spec.config import BlocksConfig, GeneratorConfig

    scenes = {
        "region": generate(GeneratorConfig(size=(60.0, 60.0)), 1),
        "blocks": generate(
            GeneratorConfig(size=(100.0, 100.0), layout="blocks", blocks=BlocksConfig(count=2)), 0
        ),
    }
    out = {}
    for name, scene in scenes.items():
        walk = [z for z in scene.zones if z.walkable]
        spots = [shapely.Polygon(z.polygon, z.holes).representative_point() for z in walk[:3]]
        extra = [
            Placement(
                id=f"extra-{k}",
                asset=("bench/0001", "trash_bin/0003")[k % 2],
                position=(p.x, p.y, float(height_at(scene, p.x, p.y))),
                yaw=0.3 * k,
            )
            for k, p in enumerate(spots * 2)
        ]
        out[name] = scene.model_copy(update={"placements": (*scene.placements, *extra)})
    return out


@pytest.fixture(scope="module")
def terrain_dir(tmp_path_factory) -> Path:
    folder = tmp_path_factory.mktemp("terrain-scene")
    (folder / "meshes").mkdir()
    (folder / "meshes" / "kiosk.obj").write_text(CUBE_OBJ)
    return folder


@pytest.fixture(scope="module")
def exported(tmp_path_factory, terrain_dir) -> dict[str, tuple[Scene, list[Path]]]:
    """Every test scene exported once (usda; the small example also as usdc)."""
    out = tmp_path_factory.mktemp("usd")
    found = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportWarning)
        for name in ("street_corner", "nav_static_10m"):
            found[name] = (load_scene(EXAMPLES / f"{name}.json"), usd.export(EXAMPLES / f"{name}.json", out))
        usdc = usd.export(EXAMPLES / "street_corner.json", out / "c", format="usdc")
        found["street_corner_usdc"] = (found["street_corner"][0], usdc)
        terrain = _terrain_scene()
        found["terrain"] = (terrain, usd.export(terrain, out, name="terrain", mesh_dir=terrain_dir))
        for name, scene in _generated_scenes().items():
            files = usd.export(scene, out, name=name, terrain_resolution=0.5)
            found[name] = (scene, files)
    return found


@pytest.fixture(scope="module")
def terrain_warnings(tmp_path_factory, terrain_dir) -> list[str]:
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        usd.export(_terrain_scene(), tmp_path_factory.mktemp("warn"), mesh_dir=terrain_dir)
        usd.export(EXAMPLES / "street_corner.json", tmp_path_factory.mktemp("warn"))
        usd.export(EXAMPLES / "nav_static_10m.json", tmp_path_factory.mktemp("warn"))
    return [str(w.message) for w in caught if issubclass(w.category, ExportWarning)]


SCENES = ("street_corner", "nav_static_10m", "street_corner_usdc", "terrain", "region", "blocks")


def _stage(files: list[Path]) -> Usd.Stage:
    stage = Usd.Stage.Open(str(files[0]))
    assert stage is not None
    return stage


# --- the stage as a whole ---------------------------------------------------------------


@pytest.mark.parametrize("name", SCENES)
def test_stage_metadata(exported, name):
    _, files = exported[name]
    stage = _stage(files)
    assert UsdGeom.GetStageUpAxis(stage) == UsdGeom.Tokens.z
    assert UsdGeom.GetStageMetersPerUnit(stage) == 1.0
    assert UsdPhysics.GetStageKilogramsPerUnit(stage) == 1.0
    assert stage.GetDefaultPrim().GetPath() == "/World"
    scene_physics = UsdPhysics.Scene(stage.GetPrimAtPath("/World/PhysicsScene"))
    assert scene_physics
    assert scene_physics.GetGravityDirectionAttr().Get() == Gf.Vec3f(0, 0, -1)
    assert scene_physics.GetGravityMagnitudeAttr().Get() == pytest.approx(9.81)
    assert files[0].suffix == (".usdc" if name.endswith("usdc") else ".usda")
    assert all(f.suffix == files[0].suffix and f.parent.name == "assets" for f in files[1:])


@pytest.mark.parametrize("name", SCENES)
def test_validators_find_nothing(exported, name):
    _, files = exported[name]
    for path in files:
        assert usd.check(path, warnings=True) == [], path


def test_validators_do_run(tmp_path):
    """check() is not vacuous: a stage without metadata and with a bad collider fails."""
    path = tmp_path / "bad.usda"
    stage = Usd.Stage.CreateNew(str(path))
    cylinder = UsdGeom.Cylinder.Define(stage, "/Bad")
    cylinder.AddScaleOp().Set(Gf.Vec3f(1.0, 2.0, 1.0))
    UsdPhysics.CollisionAPI.Apply(cylinder.GetPrim())
    stage.GetRootLayer().Save()
    errors = usd.check(path)
    names = {e.split(":")[0] for e in errors}
    assert {"MissingUpAxisMetadata", "MissingMetersPerUnitMetadata", "MissingDefaultPrim"} <= names
    assert any("Non-uniform scale" in e for e in errors)


def test_layer_data_keeps_the_meta(exported):
    _, files = exported["terrain"]
    stage = _stage(files)
    data = stage.GetRootLayer().customLayerData
    assert data["citygen:format"] == "citygen.scene/1"
    assert data["citygen:split"] == "test-usd" and data["citygen:index"] == 3
    assert data["citygen:seed"] == str(2**64 - 1)


# --- objects ----------------------------------------------------------------------------


@pytest.mark.parametrize("name", SCENES)
def test_every_placement_is_an_instance_where_the_spec_puts_it(exported, name):
    scene, files = exported[name]
    stage = _stage(files)
    cache = UsdGeom.XformCache()
    names = usd.prim_names(p.id for p in scene.placements)
    assert len(scene.placements) > 0
    for pl, prim_name in zip(scene.placements, names, strict=True):
        prim = stage.GetPrimAtPath(f"/World/Objects/{prim_name}")
        assert prim.IsValid() and prim.IsInstance(), prim_name
        assert prim.GetAttribute("citygen:id").Get() == pl.id
        m = cache.GetLocalToWorldTransform(prim)
        assert np.allclose(m.ExtractTranslation(), pl.position, atol=1e-9)
        # The asset's +x axis turns by the yaw and stretches by the scale.
        x_axis = m.TransformDir(Gf.Vec3d(1, 0, 0))
        assert x_axis[0] == pytest.approx(pl.scale * math.cos(pl.yaw), abs=1e-9)
        assert x_axis[1] == pytest.approx(pl.scale * math.sin(pl.yaw), abs=1e-9)
        assert m.TransformDir(Gf.Vec3d(0, 0, 1))[2] == pytest.approx(pl.scale)
        expected = "object" if pl.is_mesh else resolve(pl.asset).semantic_class
        assert usd.semantic_class(prim) == expected
        assert prim.GetAttribute("semantic:Semantics:params:semanticType").Get() == "class"
        assert prim.GetAttribute("semantic:Semantics:params:semanticData").Get() == expected
        assert "SemanticsLabelsAPI:class" in prim.GetAppliedSchemas()


@pytest.mark.parametrize("name", SCENES)
def test_one_prototype_and_one_file_per_distinct_asset(exported, name):
    scene, files = exported[name]
    stage = _stage(files)
    distinct = {p.asset for p in scene.placements}
    assert len(stage.GetPrototypes()) == len(distinct)
    assert len(files) - 1 == len(distinct)
    refs = {
        str(ref.assetPath)
        for prim in stage.GetPrimAtPath("/World/Objects").GetChildren()
        for ref in prim.GetMetadata("references").GetAddedOrExplicitItems()
    }
    assert refs == {f"./assets/{f.name}" for f in files[1:]}


def _asset_of(stage: Usd.Stage, scene: Scene, asset_id: str) -> Usd.Prim:
    names = usd.prim_names(p.id for p in scene.placements)
    index = next(i for i, p in enumerate(scene.placements) if p.asset == asset_id)
    return stage.GetPrimAtPath(f"/World/Objects/{names[index]}")


@pytest.mark.parametrize("name", ["street_corner", "terrain", "blocks"])
def test_parts_are_colliders_of_the_assets_geometry(exported, name):
    scene, files = exported[name]
    stage = _stage(files)
    bbox = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_])
    for asset_id in sorted({p.asset for p in scene.placements if not p.is_mesh}):
        asset = resolve(asset_id)
        instance = _asset_of(stage, scene, asset_id)
        children = instance.GetFilteredChildren(Usd.TraverseInstanceProxies())
        parts = [c for c in children if c.GetName().startswith("part_")]
        assert len(parts) == len(asset.parts), asset_id
        for prim, part in zip(parts, asset.parts, strict=True):
            assert prim.IsInstanceProxy()
            assert prim.HasAPI(UsdPhysics.CollisionAPI), prim.GetPath()
            if prim.IsA(UsdGeom.Mesh):
                approx = UsdPhysics.MeshCollisionAPI(prim).GetApproximationAttr().Get()
                assert approx == UsdPhysics.Tokens.convexHull
            # In the asset frame the part spans what its hull points span.
            box = bbox.ComputeRelativeBound(prim, instance).ComputeAlignedRange()
            hull = part.hull_points()
            assert np.allclose(box.GetMin(), hull.min(axis=0), atol=2e-5), (asset_id, prim.GetName())
            assert np.allclose(box.GetMax(), hull.max(axis=0), atol=2e-5), (asset_id, prim.GetName())
            # Its material: the part's colour and a friction for its material name.
            visual = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial()[0]
            physical = UsdShade.MaterialBindingAPI(prim).ComputeBoundMaterial("physics")[0]
            assert visual and physical and visual.GetPath() == physical.GetPath()
            shader = UsdShade.Shader(visual.GetPrim().GetChild("Surface"))
            assert np.allclose(shader.GetInput("diffuseColor").Get(), part.material.rgba[:3], atol=1e-6)
            mu = UsdPhysics.MaterialAPI(physical.GetPrim()).GetStaticFrictionAttr().Get()
            expected = FRICTION.get(part.material.name, usd.OBJECT_FRICTION.get(part.material.name, 0.5))
            assert mu == pytest.approx(expected)


def test_mesh_file_placement_is_a_triangle_mesh_collider(exported):
    scene, files = exported["terrain"]
    stage = _stage(files)
    kiosk = _asset_of(stage, scene, "meshes/kiosk.obj")
    mesh = UsdGeom.Mesh(kiosk.GetChild("mesh"))
    assert mesh and len(mesh.GetPointsAttr().Get()) == 8 and len(mesh.GetFaceVertexCountsAttr().Get()) == 12
    assert UsdPhysics.MeshCollisionAPI(mesh.GetPrim()).GetApproximationAttr().Get() == UsdPhysics.Tokens.none
    world = UsdGeom.BBoxCache(Usd.TimeCode.Default(), [UsdGeom.Tokens.default_]).ComputeWorldBound(kiosk)
    assert world.ComputeAlignedRange().GetMax()[2] == pytest.approx(1.0)


# --- ground -------------------------------------------------------------------------------


def _ground(stage: Usd.Stage):
    """Every upward-facing ground triangle: ``(tris (n, 3, 3), friction (n,), label (n,), path (n,))``."""
    tris, mus, labels, paths = [], [], [], []
    for prim in Usd.PrimRange(stage.GetPrimAtPath("/World/Ground")):
        if not prim.IsA(UsdGeom.Mesh):
            continue
        assert prim.HasAPI(UsdPhysics.CollisionAPI)
        assert UsdPhysics.MeshCollisionAPI(prim).GetApproximationAttr().Get() == UsdPhysics.Tokens.none
        mesh = UsdGeom.Mesh(prim)
        points = np.asarray(mesh.GetPointsAttr().Get(), dtype=np.float64)
        faces = np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)
        assert set(np.asarray(mesh.GetFaceVertexCountsAttr().Get()).tolist()) == {3}
        face_mu = np.full(len(faces), np.nan)
        binding = UsdShade.MaterialBindingAPI(prim)
        subsets = binding.GetMaterialBindSubsets()
        sources = [(s.GetPrim(), s.GetIndicesAttr().Get()) for s in subsets] or [(prim, range(len(faces)))]
        for source, indices in sources:
            mat = UsdShade.MaterialBindingAPI(source).ComputeBoundMaterial("physics")[0]
            mu = UsdPhysics.MaterialAPI(mat.GetPrim()).GetStaticFrictionAttr().Get()
            assert UsdPhysics.MaterialAPI(mat.GetPrim()).GetDynamicFrictionAttr().Get() == mu
            face_mu[np.asarray(indices, dtype=np.int64)] = mu
        assert not np.isnan(face_mu).any(), prim.GetPath()
        t = points[faces]
        normal_z = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])[:, 2]
        up = normal_z > 1e-12
        tris.append(t[up])
        mus.append(face_mu[up])
        labels += [usd.semantic_class(prim)] * int(up.sum())
        paths += [str(prim.GetPath())] * int(up.sum())
    return np.concatenate(tris), np.concatenate(mus), np.array(labels), np.array(paths)


def _surface_at(ground, xy: np.ndarray):
    """For each probe: how many upward triangles hold it, and the z, friction, label and
    path of the highest one."""
    tris, mus, labels, paths = ground
    a, b, c = tris[:, 0, :2], tris[:, 1, :2], tris[:, 2, :2]
    det = (b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1])
    counts, zs, found_mu, found_label, found_path = [], [], [], [], []
    for x, y in xy:
        l1 = ((b[:, 0] - x) * (c[:, 1] - y) - (c[:, 0] - x) * (b[:, 1] - y)) / det
        l2 = ((c[:, 0] - x) * (a[:, 1] - y) - (a[:, 0] - x) * (c[:, 1] - y)) / det
        l3 = 1.0 - l1 - l2
        hit = np.flatnonzero((l1 >= -1e-9) & (l2 >= -1e-9) & (l3 >= -1e-9))
        z = l1[hit] * tris[hit, 0, 2] + l2[hit] * tris[hit, 1, 2] + l3[hit] * tris[hit, 2, 2]
        counts.append(len(hit))
        top = hit[np.argmax(z)] if len(hit) else None
        zs.append(z.max() if len(hit) else np.nan)
        found_mu.append(mus[top] if top is not None else np.nan)
        found_label.append(labels[top] if top is not None else "")
        found_path.append(paths[top] if top is not None else "")
    return np.array(counts), np.array(zs), np.array(found_mu), np.array(found_label), np.array(found_path)


def _rough_tiles(scene: Scene) -> list[shapely.Polygon]:
    t = scene.terrain
    if t is None:
        return []
    s, (ox, oy) = t.tile_size, t.origin
    out = []
    for k, tile in enumerate(t.tiles):
        if tile.kind == "rough" and tile.amplitude > 0:
            r, c = divmod(k, t.cols)
            out.append(shapely.box(ox + c * s, oy + r * s, ox + (c + 1) * s, oy + (r + 1) * s))
    return out


@pytest.mark.parametrize("name", ["street_corner", "nav_static_10m", "terrain", "region", "blocks"])
def test_ground_covers_the_bounds_once_at_the_height_of_height_at(exported, name):
    """One upward surface over every point of the bounds, at height_at (exact away from
    rough tiles, whose surfaces are sampled)."""
    scene, files = exported[name]
    ground = _ground(_stage(files))
    rng = np.random.default_rng(0)
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    xy = rng.uniform((x0, y0), (x1, y1), size=(400, 2))
    counts, zs, _, _, _ = _surface_at(ground, xy)
    assert (counts == 1).all(), xy[counts != 1][:5]
    rough = shapely.union_all(_rough_tiles(scene))
    exact = ~shapely.contains_xy(rough, xy[:, 0], xy[:, 1]) if not rough.is_empty else np.ones(len(xy), bool)
    assert np.allclose(zs[exact], height_at(scene, xy[exact, 0], xy[exact, 1]), atol=2e-5)


@pytest.mark.parametrize("name", ["terrain", "region"])
def test_rough_surfaces_are_sampled_on_height_at(exported, name):
    scene, files = exported[name]
    rough = _rough_tiles(scene)
    assert rough
    stage = _stage(files)
    points = np.concatenate(
        [
            np.asarray(UsdGeom.Mesh(p).GetPointsAttr().Get(), dtype=np.float64)
            for p in stage.GetPrimAtPath("/World/Ground/Terrain").GetChildren()
        ]
    )
    cells = shapely.union_all(rough)
    inside = shapely.contains_xy(cells, points[:, 0], points[:, 1]) & (points[:, 2] > -0.5)  # not the floor
    assert inside.sum() > 50
    p = points[inside]
    assert np.allclose(p[:, 2], height_at(scene, p[:, 0], p[:, 1]), atol=2e-5)


def test_rough_sampling_matches_tile_mesh():
    """The exporter's batched rough surfaces use tile_mesh's sampling, at its default and at
    a given resolution."""
    tile = _terrain_scene().terrain.tiles[3]
    for resolution in (None, 0.3):
        mesh = tile_mesh(tile, 2.5, resolution=resolution)
        top = np.asarray(mesh.vertices)
        per_side = len(np.unique(top[top[:, 2] > tile.height - tile.amplitude - 1e-9][:, 0].round(9)))
        assert usd_terrain._rough_cells([tile], 2.5, resolution) == [per_side - 1]


def test_ground_friction_and_labels_follow_zones_and_tiles(exported):
    _, files = exported["terrain"]
    ground = _ground(_stage(files))
    # Probes off the meshes' vertices and edges (the corners of cells are on them).
    probes = {
        (1.03, 4.07): (0.75, "sidewalk"),  # pyramid slope in the sidewalk zone (concrete)
        (4.03, 1.07): (0.75, "sidewalk"),  # stair flight
        (3.53, 3.57): (0.75, "sidewalk"),  # rough tile inside the grid
        (1.03, 1.07): (0.75, "sidewalk"),  # flat ground in the sidewalk zone
        (6.53, 3.07): (0.9, "sidewalk"),  # the tile with its own material, mostly in the sidewalk
        (7.53, 1.07): (0.65, "plaza"),  # flat tile at 0.3 m, plaza with its own friction
        (6.71, 0.83): (0.75, "ground"),  # a hole of the plaza on flat ground: no zone, concrete
        (8.53, 1.57): (0.65, "plaza"),  # the other hole, in the rough tile: the tile's majority zone
        (9.53, 2.07): (0.65, "plaza"),  # that rough tile
        (11.03, 5.07): (0.75, "ground"),  # outside the grid, no zone
        (11.03, 3.57): (0.65, "plaza"),  # outside the grid, in the plaza
        (8.03, 4.57): (0.75, "ground"),  # the level slope at 0.3 m, no zone
    }
    counts, _, mus, labels, _ = _surface_at(ground, np.array(list(probes)))
    assert (counts == 1).all()
    assert mus.tolist() == pytest.approx([mu for mu, _ in probes.values()])
    assert labels.tolist() == [label for _, label in probes.values()]


def test_mixed_zone_tiles_warn_once(terrain_warnings):
    """The rough tile on the terrain scene's edge holds a hole of the plaza (no zone, other
    friction): one ExportWarning names it. The tile with its own material spans three zones
    but loses nothing; the example scenes give no warning."""
    messages = terrain_warnings
    assert len(messages) == 1
    assert messages[0].startswith("$.terrain.tiles[3]: 1 stair, slope or rough tile(s) lie on zones")


def test_cliff_walls_close_raised_ground_at_the_grid_edge(exported):
    """The flat tiles at 0.3 m on the grid's edge stand above the ground outside it: the
    terrain mesh has walls there (vertical faces reaching from the floor to 0.3 m)."""
    _, files = exported["terrain"]
    stage = _stage(files)
    walls = 0
    for prim in stage.GetPrimAtPath("/World/Ground/Terrain").GetChildren():
        mesh = UsdGeom.Mesh(prim)
        p = np.asarray(mesh.GetPointsAttr().Get(), dtype=np.float64)
        t = p[np.asarray(mesh.GetFaceVertexIndicesAttr().Get()).reshape(-1, 3)]
        n = np.cross(t[:, 1] - t[:, 0], t[:, 2] - t[:, 0])
        vertical = np.abs(n[:, 2]) < 1e-9
        # the south edge of tile (0, 2): y = 0, x in [5, 7.5], up to z = 0.3
        south = vertical & (np.abs(t[:, :, 1]).max(axis=1) < 1e-6) & (t[:, :, 0].min(axis=1) >= 5 - 1e-6)
        south &= (t[:, :, 0].max(axis=1) <= 7.5 + 1e-6) & (np.isclose(t[:, :, 2].max(axis=1), 0.3, atol=1e-6))
        walls += int(south.sum())
    assert walls >= 2


def test_level_terrain_leaves_the_ground_to_the_zones(tmp_path):
    """Flat tiles at z = 0 need no terrain mesh: the zones (and the unzoned rest) are the ground."""
    scene = load_scene(EXAMPLES / "street_corner.json")
    terrain = Terrain(origin=(0, 0), tile_size=6.0, rows=4, cols=4, tiles=[{"kind": "flat"}] * 16)
    files = usd.export(scene.model_copy(update={"terrain": terrain}), tmp_path)
    stage = _stage(files)
    assert not stage.GetPrimAtPath("/World/Ground/Terrain")
    assert len(stage.GetPrimAtPath("/World/Ground/Zones").GetChildren()) == len(scene.zones)
    assert usd.check(files[0]) == []


def test_ground_materials_get_distinct_names(tmp_path):
    """Frictions that print alike at four decimals still get a material each."""
    scene = load_scene(EXAMPLES / "nav_static_10m.json")
    zones = [
        z.model_copy(update={"material": "concrete", "friction": 0.60001 + 0.00002 * k})
        for k, z in enumerate(scene.zones)
    ]
    files = usd.export(scene.model_copy(update={"zones": tuple(zones)}), tmp_path)
    stage = _stage(files)
    looks = stage.GetPrimAtPath("/World/Looks").GetChildren()
    frictions = sorted(UsdPhysics.MaterialAPI(p).GetStaticFrictionAttr().Get() for p in looks)
    assert len(looks) == len({p.GetName() for p in looks}) >= 3
    assert frictions[:3] == pytest.approx([0.60001, 0.60003, 0.60005], abs=1e-7)


# --- agents and task ------------------------------------------------------------------------


def test_agents_and_task(exported):
    scene, files = exported["terrain"]
    stage = _stage(files)
    cache = UsdGeom.XformCache()
    for agent, name in zip(scene.agents, usd.prim_names(a.id for a in scene.agents), strict=True):
        prim = stage.GetPrimAtPath(f"/World/Agents/{name}")
        start = (*agent.start, float(height_at(scene, *agent.start)))
        goal = (*agent.goal, float(height_at(scene, *agent.goal)))
        assert np.allclose(cache.GetLocalToWorldTransform(prim).ExtractTranslation(), start)
        assert np.allclose(prim.GetAttribute("citygen:start").Get(), start)
        assert np.allclose(prim.GetAttribute("citygen:goal").Get(), goal)
        assert prim.GetAttribute("citygen:kind").Get() == agent.kind
        assert prim.GetAttribute("citygen:speed").Get() == agent.speed
    car = stage.GetPrimAtPath("/World/Agents/car")
    assert car.GetAttribute("citygen:length").Get() == 4.0
    assert list(car.GetAttribute("citygen:route").Get()) == ["a", "b"]
    facing = cache.GetLocalToWorldTransform(car).TransformDir(Gf.Vec3d(1, 0, 0))
    assert np.allclose(facing, (-1, 0, 0), atol=1e-9)  # the car heads west, to its goal
    assert stage.GetPrimAtPath("/World/Agents/p1").GetAttribute("citygen:radius").Get() == 0.25

    task = stage.GetPrimAtPath("/World/Task")
    assert task.GetAttribute("citygen:kind").Get() == "traverse"
    assert task.GetAttribute("citygen:robot").Get() == "quadruped"
    assert task.GetAttribute("citygen:timeLimit").Get() == 100.0
    start = cache.GetLocalToWorldTransform(task.GetChild("Start"))
    assert np.allclose(start.ExtractTranslation(), (0.5, 3.0, height_at(scene, 0.5, 3.0)))
    assert np.allclose(start.TransformDir(Gf.Vec3d(1, 0, 0))[:2], (math.cos(0.5), math.sin(0.5)))
    goal = cache.GetLocalToWorldTransform(task.GetChild("Goal")).ExtractTranslation()
    assert np.allclose(goal, (11.5, 5.5, 0.0))
    route = np.asarray(task.GetAttribute("citygen:route").Get())
    assert route.shape == (3, 3) and np.allclose(route[1], (8.5, 1.5, height_at(scene, 8.5, 1.5)))


def test_nav_task_goal_and_tolerance(exported):
    scene, files = exported["street_corner"]
    stage = _stage(files)
    task = stage.GetPrimAtPath("/World/Task")
    assert task.GetAttribute("citygen:goalTolerance").Get() == scene.task.goal_tolerance
    goal = UsdGeom.XformCache().GetLocalToWorldTransform(task.GetChild("Goal")).ExtractTranslation()
    assert np.allclose(goal[:2], scene.task.goal)


def test_loco_task_command(tmp_path):
    scene = load_scene(EXAMPLES / "nav_static_10m.json")
    task = LocoTask(
        kind="loco-stair", start=Pose2(position=(1.0, 5.0)), time_limit=20.0, command=(0.5, 0.0, 0.1)
    )
    files = usd.export(scene.model_copy(update={"task": task}), tmp_path)
    stage = _stage(files)
    prim = stage.GetPrimAtPath("/World/Task")
    assert tuple(prim.GetAttribute("citygen:command").Get()) == (0.5, 0.0, 0.1)
    assert not prim.GetChild("Goal")


# --- bytes --------------------------------------------------------------------------------


@pytest.mark.filterwarnings("ignore::citygen.exporters.ExportWarning")
@pytest.mark.parametrize("fmt", ["usda", "usdc"])
def test_same_scene_same_bytes(tmp_path, terrain_dir, fmt):
    scene = _terrain_scene()
    a = usd.export(scene, tmp_path / "a", format=fmt, mesh_dir=terrain_dir, name="s")
    b = usd.export(scene, tmp_path / "b", format=fmt, mesh_dir=terrain_dir, name="s")
    assert [p.name for p in a] == [p.name for p in b]
    for pa, pb in zip(a, b, strict=True):
        assert pa.read_bytes() == pb.read_bytes(), pa.name
    if fmt == "usda":
        text = a[0].read_text()
        assert str(tmp_path) not in text and "/tmp" not in text
        assert not re.search(r"\b(19|20)\d\d-\d\d-\d\d", text)  # no dates
    assert sorted(p.name for p in (tmp_path / "a").rglob("*") if p.is_file()) == sorted(
        [a[0].name, *(p.name for p in a[1:])]
    )  # no temporary file left behind


def test_assets_are_shared_between_scenes(tmp_path):
    first = usd.export(EXAMPLES / "street_corner.json", tmp_path)
    second = usd.export(EXAMPLES / "nav_static_10m.json", tmp_path)
    # both use a bench, a bin and a bollard, but other variants: no shared file expected
    # except where the variant matches; re-exporting leaves the files as they were.
    before = {p: p.read_bytes() for p in first[1:] + second[1:]}
    usd.export(EXAMPLES / "street_corner.json", tmp_path)
    assert {p: p.read_bytes() for p in before} == before
    assert len(list((tmp_path / "assets").iterdir())) == len(set(first[1:] + second[1:]))


# --- errors -------------------------------------------------------------------------------


def test_bad_options_are_one_line_errors(tmp_path):
    scene = EXAMPLES / "street_corner.json"
    with pytest.raises(ExportError, match="expected format 'usda' or 'usdc', got 'usdz'"):
        usd.export(scene, tmp_path, format="usdz")
    with pytest.raises(ExportError, match="unknown option 'resolution'"):
        usd.export(scene, tmp_path, resolution=1.0)
    for bad in (0, -1.0, True, "1", math.inf):
        with pytest.raises(ExportError, match="terrain_resolution"):
            usd.export(scene, tmp_path, terrain_resolution=bad)
    with pytest.raises(ExportError, match="file name without folders"):
        usd.export(scene, tmp_path, name="a/b")
    assert not list(tmp_path.iterdir())


def test_bad_placements_name_their_json_path(tmp_path):
    scene = _terrain_scene()
    with pytest.raises(SpecError, match=r"\$\.placements\[4\]\.asset: expected a catalog asset id when"):
        usd.export(scene, tmp_path)  # a model: no folder for the mesh file

    def with_asset(asset: str) -> Scene:
        return scene.model_copy(
            update={"placements": (scene.placements[0].model_copy(update={"asset": asset}),)}
        )

    with pytest.raises(SpecError, match=r"\$\.placements\[0\]\.asset: expected a catalog id"):
        usd.export(with_asset("unicorn/0001"), tmp_path)
    with pytest.raises(SpecError, match=r"inside the scene's folder"):
        usd.export(with_asset("../x.obj"), tmp_path, mesh_dir=tmp_path)
    with pytest.raises(SpecError, match=r"an existing mesh file"):
        usd.export(with_asset("m/x.obj"), tmp_path, mesh_dir=tmp_path)


def test_default_sampling_coarsens_on_big_terrains_with_a_warning(tmp_path, monkeypatch):
    """Without a terrain_resolution, rough tiles that would pass the triangle budget are
    sampled more coarsely, and an ExportWarning says how."""
    tile = {"kind": "rough", "amplitude": 0.05, "scale": 1.0}
    scene = Scene(
        format="citygen.scene/1",
        bounds={"min": [0, 0], "max": [30, 30]},
        terrain=Terrain(origin=(0, 0), tile_size=10.0, rows=3, cols=3, tiles=[tile] * 9),
    )
    # 80 x 80 cells a tile would be 115,200
    monkeypatch.setattr(usd_terrain, "DEFAULT_TERRAIN_TRIANGLES", 20_000)
    with pytest.warns(
        ExportWarning, match=r"USD samples rough tiles every 0.303 m \(up to [0-9.]+ cm off height_at\)"
    ):
        files = usd.export(scene, tmp_path)
    stage = _stage(files)
    faces = sum(
        len(UsdGeom.Mesh(p).GetFaceVertexCountsAttr().Get())
        for p in stage.GetPrimAtPath("/World/Ground/Terrain").GetChildren()
    )
    # Every tile's edges are level at 0 (no walls needed): 9 surfaces of 33 x 33 cells.
    assert faces == 9 * 2 * 33 * 33
    assert usd.check(files[0]) == []


def test_too_fine_a_terrain_is_refused_before_building_it(tmp_path):
    tile = {"kind": "rough", "amplitude": 0.05, "scale": 1.0}
    scene = Scene(
        format="citygen.scene/1",
        bounds={"min": [0, 0], "max": [30, 30]},
        terrain=Terrain(origin=(0, 0), tile_size=10.0, rows=3, cols=3, tiles=[tile] * 9),
    )
    with pytest.raises(
        ExportError, match=r"terrain: 9 rough tiles make \d+ triangles .* coarser terrain_resolution"
    ):
        usd.export(scene, tmp_path, terrain_resolution=0.001)


def test_height_grid_is_height_at_bit_for_bit():
    """The rough surfaces' heights come from height_grid: the float64 bits height_at gives at
    every sample, on tile grids (whose last row and column fall on the next tile, flat, slope,
    stair or rough), on grids straddling the terrain's edge and at NaN coordinates."""
    from citygen.geometry.terrain import height_grid

    kinds = [
        {"kind": "rough", "amplitude": 0.1, "scale": 0.6, "seed": 11},
        {"kind": "flat", "height": 0.2},
        {"kind": "rough", "amplitude": 0.05, "scale": 2.0, "seed": 12, "height": 0.1},
        {"kind": "slope", "angle": 0.1, "ascent": "-y"},
        {"kind": "stair", "step_height": 0.1, "step_count": 3},
        {"kind": "rough", "amplitude": 0.2, "scale": 0.3, "seed": 13},
    ]
    terrain = Terrain(origin=(-1.0, 2.0), tile_size=2.5, rows=2, cols=3, tiles=kinds)
    s, (ox, oy) = terrain.tile_size, terrain.origin
    ids = np.arange(6)
    rough = 0
    for cells in (1, 7, 40):
        g = np.linspace(0.0, s, cells + 1)
        xs = ox + (ids % 3)[:, None] * s + g[None, :]
        ys = oy + (ids // 3)[:, None] * s + g[None, :]
        grid = height_grid(terrain, xs, ys)
        assert grid.shape == (6, cells + 1, cells + 1)
        assert grid.tobytes() == height_at(terrain, xs[:, None, :], ys[:, :, None]).tobytes()
        rough += np.ptp(grid[0]) > 0
    assert rough
    rng = np.random.default_rng(5)
    xs, ys = rng.uniform(-4.0, 10.0, (3, 2, 9)), rng.uniform(0.0, 9.0, (3, 2, 5))
    xs[0, 0, 3], ys[2, 1, 0] = np.nan, np.nan
    grid = height_grid(terrain, xs, ys)
    assert grid.shape == (3, 2, 5, 9)
    assert grid.tobytes() == height_at(terrain, xs[..., None, :], ys[..., :, None]).tobytes()
    with pytest.raises(ValueError, match="same leading shape"):
        height_grid(terrain, np.zeros((2, 3)), np.zeros((3, 3)))
