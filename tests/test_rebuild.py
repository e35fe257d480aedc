"""``citygen rebuild SCENE --from STAGE`` and ``citygen.generate.rebuild``: stages after STAGE are
made again, everything up to it is kept; an unedited scene comes back byte for byte."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pytest

import citygen
from citygen.generate import STAGES, generate, rebuild
from citygen.generate.splits import splits
from citygen.io import dumps, load_scene
from citygen.spec.config import (
    AgentsConfig,
    BlocksConfig,
    GeneratorConfig,
    PlacementConfig,
    TaskConfig,
)
from tests.conftest import ROOT

SPLITS = [
    "urban-nav-1-test",
    "urban-nav-2-train",
    "urban-nav-3-test",
    "urban-loc-3-test",
    "urban-tra-standard",
]

STREETS = GeneratorConfig(
    size=(120.0, 120.0),
    layout="blocks",
    blocks=BlocksConfig(count=2, straight_length=(25.0, 40.0)),
    placement=PlacementConfig(count=None, density_per_100m2=0.5),
    agents=AgentsConfig(people=6, vehicles=2),
    task=TaskConfig(kind="nav-static", min_distance=20.0),
)


def saved(scene, path: Path) -> Path:
    citygen.save_scene(scene, path)
    return path


@pytest.mark.parametrize("name", SPLITS)
def test_an_unedited_scene_rebuilt_from_any_stage_is_the_same_bytes(name, tmp_path):
    for index in (0, 2):
        path = saved(citygen.generate(name, index=index), tmp_path / f"{index}.json")
        scene = load_scene(path)
        for stage in STAGES:
            assert dumps(rebuild(scene, stage)) == path.read_text(), (name, index, stage)


def test_a_street_network_from_its_own_config_is_the_same_bytes():
    for seed in (1, 2):
        scene = generate(STREETS, seed, split="streets", index=seed)
        assert scene.blocks and scene.agents
        for stage in STAGES:
            assert dumps(rebuild(scene, stage, STREETS)) == dumps(scene), (seed, stage)


def test_the_command_writes_the_same_bytes_and_says_what_it_kept(cli, tmp_path):
    path = saved(citygen.generate("urban-nav-3-train", index=5), tmp_path / "a.json")
    for stage in STAGES:
        out = tmp_path / f"{stage}.json"
        result = cli("rebuild", path, "--from", stage, "--out", out)
        assert result.code == 0, result.err
        assert out.read_bytes() == path.read_bytes()
        kept = ", ".join(STAGES[: STAGES.index(stage) + 1])
        assert result.out.startswith(f"wrote {out} (kept {kept}; made again: ")
    # Without --out the scene is rebuilt in place.
    before = path.read_bytes()
    assert cli("rebuild", path, "--from", "layout").code == 0
    assert path.read_bytes() == before


def test_a_deleted_object_stays_deleted_and_agents_are_made_again(cli, tmp_path):
    scene = citygen.generate("urban-nav-3-test", index=1)
    assert len(scene.placements) >= 2 and scene.agents
    edited = scene.model_copy(update={"placements": scene.placements[1:]})
    path = saved(edited, tmp_path / "edited.json")
    result = cli("rebuild", path, "--from", "placement")
    assert result.code == 0, result.err
    again = load_scene(path)
    assert again.placements == edited.placements
    assert scene.placements[0].id not in {p.id for p in again.placements}
    assert (again.zones, again.terrain, again.task) == (scene.zones, scene.terrain, scene.task)
    assert again.agents  # made again, around the objects that are left
    assert citygen.validate(again) == []


def test_a_zone_edit_survives_a_rebuild_from_layout(cli, tmp_path):
    # Turn the non-walkable ground of a NavStatic scene into a trail: the zones are kept, the
    # terrain, objects and task are made again on the new ground.
    for index in range(20):
        scene = citygen.generate("urban-nav-2-test", index=index)
        if any(z.kind == "vegetation" for z in scene.zones):
            break
    zones = tuple(
        z.model_copy(update={"kind": "trail"}) if z.kind == "vegetation" else z for z in scene.zones
    )
    edited = scene.model_copy(update={"zones": zones})
    path = saved(edited, tmp_path / "edited.json")
    out = tmp_path / "rebuilt.json"
    result = cli("rebuild", path, "--from", "layout", "--out", out)
    assert result.code == 0, result.err
    again = load_scene(out)
    assert again.zones == zones and "vegetation" not in {z.kind for z in again.zones}
    assert citygen.validate(again) == []
    assert path.read_bytes() == dumps(edited).encode()  # the input is left alone


def _far_walkable_point(scene, away_from, clearance=0.6):
    """A point of the walkable piece holding the task's start, ``clearance`` m inside it and
    as far from ``away_from`` as a 0.25 m grid finds."""
    import shapely

    from citygen.generate.space import walkable_ground

    ground = walkable_ground(scene.zones, (*scene.bounds.min, *scene.bounds.max)).buffer(-clearance)
    piece = next(g for g in shapely.get_parts(ground) if g.covers(shapely.Point(scene.task.start.position)))
    x0, y0, x1, y1 = piece.bounds
    points = [
        (x0 + 0.25 * i, y0 + 0.25 * j)
        for i in range(int((x1 - x0) / 0.25) + 1)
        for j in range(int((y1 - y0) / 0.25) + 1)
    ]
    inside = [p for p in points if piece.covers(shapely.Point(p))]
    return max(inside, key=lambda p: math.dist(p, away_from))


def test_a_moved_goal_is_kept_when_rebuilding_from_terrain(cli, tmp_path):
    scene = citygen.generate("urban-nav-2-test", index=4)
    task = scene.task
    goal = _far_walkable_point(scene, task.goal)
    assert math.dist(goal, task.goal) > 2.0
    edited = scene.model_copy(update={"task": task.model_copy(update={"goal": goal})})
    path = saved(edited, tmp_path / "edited.json")
    result = cli("rebuild", path, "--from", "terrain")
    assert result.code == 0, result.err
    again = load_scene(path)
    assert again.task.goal == goal and again.task.start == task.start
    assert again.terrain == scene.terrain
    assert citygen.validate(again) == []  # the objects made again keep clear of the moved goal


def test_a_terrain_edit_survives_and_objects_are_made_again(tmp_path):
    scene = citygen.generate("urban-nav-3-train", index=7)
    tiles = list(scene.terrain.tiles)
    k = next(i for i, t in enumerate(tiles) if t.kind == "rough")
    tiles[k] = tiles[k].model_copy(update={"amplitude": 0.01})
    edited = scene.model_copy(update={"terrain": scene.terrain.model_copy(update={"tiles": tuple(tiles)})})
    again = rebuild(load_scene(saved(edited, tmp_path / "e.json")), "terrain")
    assert again.terrain == edited.terrain and again.terrain.tiles[k].amplitude == 0.01
    assert citygen.validate(again) == []


def test_a_track_unit_cleared_by_hand_stays_clear(tmp_path):
    scene = citygen.generate("urban-tra-standard")
    in_unit_2 = [p for p in scene.placements if 20.0 <= p.position[0] < 40.0]
    assert in_unit_2
    edited = scene.model_copy(update={"placements": tuple(p for p in scene.placements if p not in in_unit_2)})
    again = rebuild(edited, "placement")
    assert again.placements == edited.placements and again.task == scene.task
    assert citygen.validate(again) == []


def test_a_hand_written_scene_gets_objects_people_and_a_task_from_a_config(cli, tmp_path):
    config = tmp_path / "corner.toml"
    config.write_text('size = [24.0, 24.0]\n[agents]\npeople = 5\n[task]\nkind = "nav-dynamic"\n')
    out = tmp_path / "corner.json"
    corner = ROOT / "examples/street_corner.json"
    before = load_scene(corner)
    result = cli("rebuild", corner, "--from", "placement", "--config", config, "--seed", "3", "--out", out)
    assert result.code == 0, result.err
    scene = load_scene(out)
    assert scene.placements == before.placements and scene.meta.seed == 3
    assert len([a for a in scene.agents if a.kind != "vehicle"]) == 5
    assert scene.task.start == before.task.start and scene.task.goal == before.task.goal
    assert citygen.validate(scene) == []


def test_a_users_config_is_given_with_config(cli, tmp_path):
    config = tmp_path / "mine.toml"
    config.write_text('size = [12.0, 12.0]\n[task]\nkind = "nav-static"\n[agents]\npeople = 0\n')
    assert cli("generate", "--split", config, "--seed", "4", "--out", tmp_path).code == 0
    path = tmp_path / "mine/0000.json"
    out = tmp_path / "again.json"
    result = cli("rebuild", path, "--from", "terrain", "--out", out)
    assert result.code == 2 and not out.exists()
    assert result.err.strip() == (
        f"{path}: $.meta.split: expected a split of seeds/*.toml (or give --config FILE), got 'mine'"
    )
    assert cli("rebuild", path, "--from", "terrain", "--config", config, "--out", out).code == 0
    assert out.read_bytes() == path.read_bytes()
    # A manifest of several splits gives the split the scene names.
    nav = saved(citygen.generate("urban-nav-2-test", index=3), tmp_path / "nav.json")
    manifest = ROOT / "seeds/urban-nav.toml"
    assert cli("rebuild", nav, "--from", "layout", "--config", manifest, "--out", out).code == 0
    assert out.read_bytes() == nav.read_bytes()


def _without_seed(scene) -> str:
    document = json.loads(dumps(scene))
    del document["meta"]["seed"]
    return json.dumps(document)


@pytest.mark.parametrize(
    ("case", "args", "message"),
    [
        (
            "stage",
            ["--from", "objects"],
            "--from: expected one of layout, terrain, placement, agents, task, got 'objects'",
        ),
        ("missing", ["--from", "task"], "missing.json: $: expected an existing file, got no such file"),
        (
            "seed",
            ["--from", "agents"],
            "$.meta.seed: expected the scene's seed (or give one: --seed S), got none",
        ),
        ("config", ["--from", "agents", "--config", "nope.toml"], "nope.toml: $: expected an existing file"),
        (
            "kind",
            ["--from", "terrain", "--config", "traverse.toml"],
            "$.task.kind: expected a task of the config's kind 'traverse'",
        ),
        ("ground", ["--from", "layout"], "generation failed in stage 'task'"),
        ("overlap", ["--from", "placement"], "expected no overlap with other objects"),
    ],
)
def test_bad_input_is_an_error_and_nothing_is_written(cli, tmp_path, monkeypatch, case, args, message):
    monkeypatch.chdir(tmp_path)
    scene = citygen.generate("urban-nav-2-test", index=2)
    Path("traverse.toml").write_text('size = [15.0, 15.0]\n[task]\nkind = "traverse"\n')
    path = tmp_path / ("missing.json" if case == "missing" else "scene.json")
    if case == "seed":
        path.write_text(_without_seed(scene))
    elif case == "ground":  # no walkable ground left for the task
        zones = tuple(z.model_copy(update={"kind": "vegetation"}) for z in scene.zones)
        saved(scene.model_copy(update={"zones": zones}), path)
    elif case == "overlap":  # one object moved onto another
        a, b = scene.placements[:2]
        moved = b.model_copy(update={"position": a.position})
        saved(scene.model_copy(update={"placements": (a, moved, *scene.placements[2:])}), path)
    elif case != "missing":
        saved(scene, path)
    before = path.read_bytes() if path.exists() else None
    out = tmp_path / "out.json"
    result = cli("rebuild", path, *args, "--out", out)
    assert result.code == 2
    lines = result.err.strip().splitlines()
    assert message in lines[0]
    if case != "overlap":
        assert len(lines) == 1, result.err
    assert not out.exists()
    assert (path.read_bytes() if path.exists() else None) == before


def test_every_stage_is_named_in_the_help(cli):
    result = cli("rebuild", "--help")
    assert result.code == 0
    for stage in STAGES:
        assert stage in result.out


def test_the_python_api_is_on_the_generate_package():
    assert citygen.generate.rebuild is rebuild and citygen.generate.STAGES == STAGES
    assert splits()["urban-nav-2-test"].config.placement.count == 8
