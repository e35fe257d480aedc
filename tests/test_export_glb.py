"""The GLB exporter, read back by trimesh: node names, instancing, bounds, colours, draping."""

from __future__ import annotations

import json
import struct
from pathlib import Path

import numpy as np
import pytest
import shapely
import trimesh

from citygen.assets import resolve
from citygen.errors import ExportError
from citygen.exporters import glb, urdf
from citygen.exporters.picture import ZONE_COLORS
from citygen.geometry.terrain import height_at
from citygen.io import load_scene
from citygen.spec.terrain import Terrain
from tests.conftest import ROOT
from tests.test_export_urdf import generated_scene, write_terrain_scene


@pytest.fixture(scope="module")
def street(tmp_path_factory) -> tuple[Path, object]:
    folder = tmp_path_factory.mktemp("street")
    path = write_terrain_scene(folder)
    return path, load_scene(path)


def gltf_json(path: Path) -> dict:
    """The JSON chunk of a GLB file."""
    data = path.read_bytes()
    magic, version, _ = struct.unpack("<4sII", data[:12])
    assert (magic, version) == (b"glTF", 2)
    length, kind = struct.unpack("<I4s", data[12:20])
    assert kind == b"JSON"
    return json.loads(data[20 : 20 + length])


def expected_names(scene) -> set[str]:
    names = {"scene/root", *(p.id for p in scene.placements), *(f"zone/{z.id}" for z in scene.zones)}
    names |= {f"agent/{a.id}" for a in scene.agents} | {f"agent/{a.id}/goal" for a in scene.agents}
    if scene.terrain is not None:
        names.add("ground/terrain")
    if scene.task is not None:
        names |= {"task/start", "task/goal"}
    return names


def z_up(loaded: trimesh.Scene, node: str) -> np.ndarray:
    """The node's transform in citygen's Z-up frame (undoing the root's turn to Y-up)."""
    matrix, _ = loaded.graph[node]
    return np.linalg.inv(glb.Z_UP_TO_Y_UP) @ matrix


def node_mesh(loaded: trimesh.Scene, node: str) -> trimesh.Trimesh:
    """The node's mesh in the world, Z up."""
    _, geometry = loaded.graph[node]
    return loaded.geometry[geometry].copy().apply_transform(z_up(loaded, node))


def test_nodes_are_named_by_ids_and_instanced(street, tmp_path):
    path, scene = street
    (out,) = glb.export(path, tmp_path)
    assert out == tmp_path / "street.glb"
    loaded = trimesh.load(out)
    names = set(loaded.graph.nodes) - {loaded.graph.base_frame}
    assert names == expected_names(scene) | {"ground/plane"}
    # One mesh per asset, referenced by every node that places it.
    doc = gltf_json(out)
    by_node = {n["name"]: n.get("mesh") for n in doc["nodes"]}
    meshes = {m["name"]: i for i, m in enumerate(doc["meshes"])}
    for pl in scene.placements:
        key = f"mesh/{pl.asset}" if pl.is_mesh else f"asset/{pl.asset}"
        assert by_node[pl.id] == meshes[key]
    assert by_node["agent/ped-1"] == by_node["agent/ped-1/goal"]
    assert len(doc["meshes"]) == len(set(by_node.values()) - {None})


def test_bounds_match_the_scene(street, tmp_path):
    path, scene = street
    loaded = trimesh.load(glb.export(path, tmp_path, y_up=False)[0])
    lo, hi = loaded.bounds
    assert lo[:2] == pytest.approx(scene.bounds.min, abs=1e-6)
    assert hi[:2] == pytest.approx(scene.bounds.max, abs=1e-6)
    assert lo[2] == pytest.approx(-1.0)  # the terrain's floor
    tallest = max(resolve(p.asset).height * p.scale + p.position[2] for p in scene.placements[:-1])
    assert hi[2] == pytest.approx(tallest, abs=1e-5)
    # Y up by default: the same scene, turned.
    turned = trimesh.load(glb.export(path, tmp_path / "y")[0])
    assert turned.bounds[:, 1] == pytest.approx([lo[2], hi[2]], abs=1e-5)
    assert sorted(-turned.bounds[:, 2]) == pytest.approx([lo[1], hi[1]], abs=1e-5)


def test_objects_stand_where_the_spec_puts_them(street, tmp_path):
    path, scene = street
    loaded = trimesh.load(glb.export(path, tmp_path)[0])
    for pl in scene.placements:
        np.testing.assert_allclose(z_up(loaded, pl.id), glb.placement_matrix(pl), atol=1e-6)
        if not pl.is_mesh:
            mesh = node_mesh(loaded, pl.id)
            expected = resolve(pl.asset).visual_mesh().apply_transform(glb.placement_matrix(pl))
            np.testing.assert_allclose(mesh.bounds, expected.bounds, atol=1e-5)
            colours = {tuple(c) for c in mesh.visual.vertex_colors[:, :3].tolist()}
            parts = {tuple(round(x * 255) for x in p.material.rgba[:3]) for p in resolve(pl.asset).parts}
            assert colours == parts, pl.id
    for agent in scene.agents:
        m = z_up(loaded, f"agent/{agent.id}")
        assert m[:3, 3] == pytest.approx([*agent.start, float(height_at(scene, *agent.start))], abs=1e-6)
        g = z_up(loaded, f"agent/{agent.id}/goal")
        assert g[:2, 3] == pytest.approx(agent.goal, abs=1e-6)
    start = z_up(loaded, "task/start")
    assert start[:2, 3] == pytest.approx(scene.task.start.position)
    assert np.arctan2(start[1, 0], start[0, 0]) == pytest.approx(scene.task.start.yaw, abs=1e-9)
    goal = node_mesh(loaded, "task/goal")
    assert goal.extents[:2] == pytest.approx([2 * scene.task.goal_tolerance] * 2, rel=0.01)


def test_zones_are_coloured_by_kind_and_draped_on_the_terrain(street, tmp_path):
    path, scene = street
    loaded = trimesh.load(glb.export(path, tmp_path)[0])
    for zone in scene.zones:
        mesh = node_mesh(loaded, f"zone/{zone.id}")
        hexes = {"#{:02x}{:02x}{:02x}".format(*c) for c in mesh.visual.vertex_colors[:, :3].tolist()}
        assert hexes == {ZONE_COLORS[zone.kind]}
        area = shapely.Polygon(zone.polygon, zone.holes).area
        flat = np.abs(np.cross(*(mesh.triangles[:, 1:, :2] - mesh.triangles[:, :1, :2]).transpose(1, 0, 2)))
        assert flat.sum() / 2 == pytest.approx(area, rel=1e-6)
        # Every face lies on the ground, ZONE_LIFT above it: at its centroid, as height_at
        # says; on rough tiles, whose mesh samples the noise, within a few millimetres.
        c = mesh.triangles_center
        error = np.abs(c[:, 2] - glb.ZONE_LIFT - height_at(scene, c[:, 0], c[:, 1]))
        t = scene.terrain
        col = np.floor((c[:, 0] - t.origin[0]) / t.tile_size).astype(int)
        row = np.floor((c[:, 1] - t.origin[1]) / t.tile_size).astype(int)
        inside = (col >= 0) & (col < t.cols) & (row >= 0) & (row < t.rows)
        kind = np.array([t.tiles[k].kind for k in (row * t.cols + col)[inside]])
        rough = np.zeros(len(c), dtype=bool)
        rough[inside] = kind == "rough"
        assert error[~rough].max(initial=0) < 1e-6, zone.id
        assert error[rough].max(initial=0) < 0.02, zone.id  # a quarter of the amplitude
        assert (mesh.face_normals[:, 2] > 0).all()


def test_the_spec_beyond_geometry_rides_in_extras(street, tmp_path):
    path, scene = street
    extras = gltf_json(glb.export(path, tmp_path)[0])["scenes"][0]["extras"]["citygen"]
    assert extras["task"] == scene.task.model_dump(mode="json", exclude_none=True)
    assert [a["id"] for a in extras["agents"]] == [a.id for a in scene.agents]
    assert extras["agents"][1]["speed"] == scene.agents[1].speed


def test_same_scene_same_bytes(street, tmp_path):
    path, scene = street
    a = glb.export(path, tmp_path / "a")[0].read_bytes()
    b = glb.export(scene, tmp_path / "b", scene_dir=path.parent, name="street")[0].read_bytes()
    assert a == b


@pytest.mark.parametrize("example", ["street_corner.json", "nav_static_10m.json"])
def test_examples(example, tmp_path):
    scene = load_scene(ROOT / "examples" / example)
    loaded = trimesh.load(glb.export(ROOT / "examples" / example, tmp_path)[0])
    assert set(loaded.graph.nodes) - {loaded.graph.base_frame, "ground/plane"} == expected_names(scene)
    ground = [n for n in loaded.graph.nodes_geometry if n.startswith(("zone/", "ground/"))]
    bounds = np.array([node_mesh(loaded, n).bounds for n in ground])
    assert bounds[:, 0, :2].min(axis=0) == pytest.approx(scene.bounds.min, abs=1e-6)
    assert bounds[:, 1, :2].max(axis=0) == pytest.approx(scene.bounds.max, abs=1e-6)


@pytest.mark.slow
def test_a_generated_street(tmp_path):
    scene = generated_scene(1)
    loaded = trimesh.load(glb.export(scene, tmp_path, resolution=0.1)[0])
    assert set(loaded.graph.nodes) - {loaded.graph.base_frame, "ground/plane"} == expected_names(scene)
    ground = [n for n in loaded.graph.nodes_geometry if n.startswith(("zone/", "ground/"))]
    bounds = np.array([node_mesh(loaded, n).bounds for n in ground])
    assert bounds[:, 0, :2].min(axis=0) == pytest.approx(scene.bounds.min, abs=1e-6)
    assert bounds[:, 1, :2].max(axis=0) == pytest.approx(scene.bounds.max, abs=1e-6)


def test_mesh_files_keep_their_colours(street, tmp_path):
    path, scene = street
    box = trimesh.creation.box((1.0, 1.0, 1.0))
    box.visual.face_colors = [[200, 30, 30, 255]] * 6 + [[30, 30, 200, 255]] * 6
    (path.parent / "meshes" / "box.ply").write_bytes(box.export(file_type="ply"))
    pl = scene.placements[-1].model_copy(update={"asset": "meshes/box.ply", "id": "box"})
    coloured = scene.model_copy(update={"placements": (pl,)})
    loaded = trimesh.load(glb.export(coloured, tmp_path, scene_dir=path.parent)[0])
    colours = {tuple(c) for c in node_mesh(loaded, "box").visual.vertex_colors[:, :3].tolist()}
    assert colours == {(200, 30, 30), (30, 30, 200)}


def test_vehicles_goals_are_discs(street, tmp_path):
    path, scene = street
    loaded = trimesh.load(glb.export(path, tmp_path)[0])
    car = next(a for a in scene.agents if a.kind == "vehicle")
    disc = node_mesh(loaded, f"agent/{car.id}/goal")
    assert disc.extents == pytest.approx([car.width, car.width, glb.MARKER_THICKNESS], rel=0.02)
    body = node_mesh(loaded, f"agent/{car.id}")
    assert sorted(body.extents[:2]) == pytest.approx(sorted([car.length, car.width]))


def test_a_terrain_too_fine_to_mesh_is_refused_before_building(tmp_path):
    """Memory stays bounded: 64 x 64 rough tiles at 5 mm would be ~10^9 triangles."""
    rough = {"kind": "rough", "amplitude": 0.05, "scale": 0.5}
    terrain = {"origin": [0.0, 0.0], "tile_size": 2.0, "rows": 64, "cols": 64, "tiles": [rough] * 4096}
    scene = load_scene(ROOT / "examples" / "nav_static_10m.json").model_copy(
        update={"terrain": Terrain.model_validate(terrain), "placements": ()}
    )
    with pytest.raises(ExportError, match=r"rough tiles need about [\d,]+ triangles.*coarser resolution"):
        glb.export(scene, tmp_path, resolution=0.005)
    with pytest.raises(ExportError, match="coarser resolution"):
        urdf.export(scene, tmp_path, resolution=0.005)


def test_bad_options_are_clear_errors(street, tmp_path):
    path, scene = street
    with pytest.raises(ExportError, match="unknown option 'size'"):
        glb.export(path, tmp_path, size=3)
    with pytest.raises(ExportError, match="'resolution'"):
        glb.export(path, tmp_path, resolution=0)
    with pytest.raises(ExportError, match="'y_up'"):
        glb.export(path, tmp_path, y_up="yes")
    with pytest.raises(ExportError, match="'name'"):
        glb.export(path, tmp_path, name="a/b")
    with pytest.raises(ExportError, match=r"\$\.placements\[6\]\.asset"):
        glb.export(scene, tmp_path)
