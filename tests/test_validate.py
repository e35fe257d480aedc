"""Semantic checks: each rule reports the right JSON path, and sound scenes pass."""

from __future__ import annotations

import math

import pytest
import trimesh

from citygen import load_scene, validate
from citygen.io import dumps
from citygen.spec import Scene
from citygen.spec.terrain import SIDES, edge_profile, profiles_match
from tests.conftest import EXAMPLES


def scene(**parts) -> Scene:
    return Scene.model_validate(
        {"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [20, 20]}, **parts}
    )


def paths(problems) -> list[str]:
    return [p.path for p in problems]


def square(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


@pytest.mark.parametrize("path", EXAMPLES, ids=lambda p: p.name)
def test_examples_are_valid(path):
    assert validate(load_scene(path), path.parent) == []


def test_one_way_and_dangling_connections():
    pose = {"position": [0, 10], "yaw": 0}
    a = {
        "id": "a",
        "kind": "straight",
        "pose": pose,
        "length": 10,
        "sockets": [{"id": "in", "pose": pose}, {"id": "out", "pose": {"position": [10, 10]}}],
        "connections": [{"socket": "out", "block": "b", "to_socket": "in"}],
    }
    b = {
        "id": "b",
        "kind": "straight",
        "pose": {"position": [10, 10]},
        "length": 5,
        "sockets": [{"id": "in", "pose": {"position": [10, 10]}}],
        "connections": [{"socket": "in", "block": "zzz", "to_socket": "in"}],
    }
    problems = validate(scene(blocks=[a, b]))
    assert paths(problems) == ["$.blocks[0].connections[0]", "$.blocks[1].connections[0].block"]
    b["connections"] = [{"socket": "in", "block": "a", "to_socket": "out"}]
    assert validate(scene(blocks=[a, b])) == []


def test_strip_only_on_sidewalks():
    problems = validate(
        scene(zones=[{"id": "z", "kind": "plaza", "strip": "clear", "polygon": square(0, 0, 5, 5)}])
    )
    assert paths(problems) == ["$.zones[0].strip"]


def test_height_only_on_buildings():
    building = {"id": "b", "kind": "building", "height": 12.5, "polygon": square(0, 0, 5, 5)}
    assert validate(scene(zones=[building])) == []
    problems = validate(scene(zones=[{**building, "kind": "plaza"}]))
    assert paths(problems) == ["$.zones[0].height"]
    assert str(problems[0]).endswith("expected no height on a zone that is not a building, got 12.5")


def test_a_zone_without_height_writes_no_height_key():
    zone = {"id": "b", "kind": "building", "polygon": square(0, 0, 5, 5)}
    assert "height" not in dumps(scene(zones=[zone]))
    assert '"height": 12.5' in dumps(scene(zones=[{**zone, "height": 12.5}]))


def test_zone_with_hole_and_its_filling_do_not_overlap():
    zones = [
        {"id": "plaza", "kind": "plaza", "polygon": square(0, 0, 10, 10), "holes": [square(4, 4, 6, 6)]},
        {"id": "pit", "kind": "vegetation", "polygon": square(4, 4, 6, 6)},
    ]
    assert validate(scene(zones=zones)) == []
    zones[1]["polygon"] = square(3, 3, 6, 6)
    assert paths(validate(scene(zones=zones))) == ["$.zones[0]"]


def test_object_inside_a_building():
    zones = [{"id": "house", "kind": "building", "polygon": square(0, 0, 10, 10)}]
    placements = [{"id": "b", "asset": "bench/0001", "position": [9.8, 5, 0]}]
    assert paths(validate(scene(zones=zones, placements=placements))) == ["$.placements[0]"]


def test_rotation_and_scale_enter_the_footprint():
    # Benches face +x, so their long side runs along y: two of them one metre apart in x
    # stand clear of each other until one is turned a quarter or made three times larger.
    a = {"id": "a", "asset": "bench/0001", "position": [10, 10, 0]}
    b = {"id": "b", "asset": "bench/0001", "position": [11, 10, 0]}
    assert validate(scene(placements=[a, b])) == []
    assert paths(validate(scene(placements=[a, {**b, "yaw": math.pi / 2}]))) == ["$.placements[0]"]
    assert paths(validate(scene(placements=[a, {**b, "scale": 3.0}]))) == ["$.placements[0]"]


def test_vehicle_must_be_on_the_road_and_people_on_walkable_ground():
    zones = [
        {"id": "road", "kind": "roadway", "polygon": square(0, 0, 20, 7)},
        {"id": "walk", "kind": "sidewalk", "polygon": square(0, 7, 20, 10)},
        {"id": "lawn", "kind": "vegetation", "polygon": square(0, 10, 20, 20)},
    ]
    agents = [
        {"id": "car", "kind": "vehicle", "start": [1, 3], "goal": [19, 8]},
        {"id": "ped", "kind": "pedestrian", "start": [1, 8], "goal": [5, 15]},
        {"id": "edge", "kind": "scooter", "start": [1, 7], "goal": [19, 10]},  # on zone borders: fine
    ]
    assert paths(validate(scene(zones=zones, agents=agents))) == ["$.agents[0].goal", "$.agents[1].goal"]


def test_scene_without_zones_is_walkable_everywhere():
    task = {"kind": "loco-rough", "start": {"position": [10, 10]}, "time_limit": 20}
    assert validate(scene(task=task)) == []
    task["start"] = {"position": [30, 10]}
    assert paths(validate(scene(task=task))) == ["$.task.start.position"]


def test_traverse_route_points_are_checked():
    zones = [{"id": "walk", "kind": "trail", "polygon": square(0, 0, 20, 5)}]
    task = {
        "kind": "traverse",
        "start": {"position": [1, 1]},
        "time_limit": 600,
        "route": [[10, 2], [19, 9], [19, 4]],
    }
    assert paths(validate(scene(zones=zones, task=task))) == ["$.task.route[1]"]


def test_start_inside_an_object():
    placements = [{"id": "bin", "asset": "trash_bin/0000", "position": [5, 5, 0]}]
    task = {"kind": "nav-static", "start": {"position": [5, 5]}, "goal": [15, 15], "time_limit": 20}
    assert paths(validate(scene(placements=placements, task=task))) == ["$.task.start.position"]


def test_mesh_placement_footprint_comes_from_the_file(tmp_path):
    (tmp_path / "meshes").mkdir()
    trimesh.creation.box((4.0, 2.0, 3.0)).export(tmp_path / "meshes" / "kiosk.obj")
    placements = [
        {"id": "kiosk", "asset": "meshes/kiosk.obj", "position": [10, 10, 0]},
        {"id": "bin", "asset": "trash_bin/0000", "position": [11.8, 10, 0]},
    ]
    assert paths(validate(scene(placements=placements), tmp_path)) == ["$.placements[0]"]
    placements[1]["position"] = [12.6, 10, 0]
    assert validate(scene(placements=placements), tmp_path) == []
    # Without the scene's folder only the path itself can be checked.
    assert validate(scene(placements=placements)) == []


def test_mesh_symlink_leading_out_of_the_folder(tmp_path):
    outside = tmp_path / "outside.obj"
    trimesh.creation.box((1, 1, 1)).export(outside)
    folder = tmp_path / "scene"
    folder.mkdir()
    (folder / "link.obj").symlink_to(outside)
    placements = [{"id": "x", "asset": "link.obj", "position": [10, 10, 0]}]
    problems = validate(scene(placements=placements), folder)
    assert paths(problems) == ["$.placements[0].asset"]
    assert "link" in problems[0].found


@pytest.mark.parametrize("asset", ["a/../../x.obj", "/abs/x.obj", "~/x.obj", "./../x.obj"])
def test_mesh_paths_that_leave_the_folder(asset):
    problems = validate(scene(placements=[{"id": "x", "asset": asset, "position": [1, 1, 0]}]))
    assert paths(problems) == ["$.placements[0].asset"]


def test_drive_letters_are_refused_by_the_schema():
    with pytest.raises(ValueError, match="asset"):
        scene(placements=[{"id": "x", "asset": "C:/x.obj", "position": [1, 1, 0]}])


def test_inner_dotdot_that_stays_inside_is_fine(tmp_path):
    (tmp_path / "a").mkdir()
    trimesh.creation.box((1, 1, 1)).export(tmp_path / "x.obj")
    placements = [{"id": "x", "asset": "a/../x.obj", "position": [5, 5, 0]}]
    assert validate(scene(placements=placements), tmp_path) == []


def test_huge_bounds_rejected():
    big = Scene.model_validate({"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [20_000, 10]}})
    assert paths(validate(big)) == ["$.bounds"]


# --- terrain edge profiles -------------------------------------------------------


def terrain(tiles, rows=1, cols=2, size=2.0):
    return {"origin": [0, 0], "tile_size": size, "rows": rows, "cols": cols, "tiles": tiles}


def test_slope_meets_a_flat_tile_at_its_top():
    rise = 2.0 * math.tan(0.2)
    tiles = [{"kind": "slope", "angle": 0.2, "ascent": "+x"}, {"kind": "flat", "height": round(rise, 4)}]
    assert validate(scene(terrain=terrain(tiles))) == []
    tiles[1]["height"] = 0.0
    assert paths(validate(scene(terrain=terrain(tiles)))) == ["$.terrain.tiles[0]"]


def test_stairs_side_by_side_must_match_step_for_step():
    stair = {"kind": "stair", "step_height": 0.15, "step_count": 3, "ascent": "+y"}
    assert validate(scene(terrain=terrain([stair, stair]))) == []
    assert paths(
        validate(scene(terrain=terrain([stair, {**stair, "step_count": 2, "step_height": 0.225}])))
    ) == ["$.terrain.tiles[0]"]


def test_rough_tiles_meet_flat_ones_at_their_base_height():
    rough = {"kind": "rough", "height": 0.1, "amplitude": 0.05, "scale": 0.5, "seed": 3}
    assert validate(scene(terrain=terrain([rough, {"kind": "flat", "height": 0.1}]))) == []


def test_terrain_grid_must_fit_the_bounds():
    tiles = [{"kind": "flat"}] * 4
    assert paths(validate(scene(terrain=terrain(tiles, rows=2, cols=2, size=15.0)))) == ["$.terrain"]


@pytest.mark.parametrize("ascent", ["+x", "-x", "+y", "-y"])
def test_edge_profiles_of_a_stair(ascent):
    from citygen.spec import StairTile

    tile = StairTile(kind="stair", height=1.0, step_height=0.2, step_count=2, ascent=ascent)
    profiles = {side: edge_profile(tile, side, 2.0) for side in SIDES}
    up = {"+x": "east", "-x": "west", "+y": "north", "-y": "south"}[ascent]
    down = {"east": "west", "west": "east", "north": "south", "south": "north"}[up]
    assert profiles[up] == ("level", 1.4)
    assert profiles[down] == ("level", 1.0)
    sides = [s for s in SIDES if s not in (up, down)]
    for s in sides:
        assert profiles[s][0] == "steps"
        assert sorted(profiles[s][1:3]) == [1.0, 1.4]
    assert profiles_match(profiles[sides[0]], profiles[sides[1]])
