"""Named splits, ``citygen.generate(split, ...)``, ``citygen.splits()`` and ``citygen generate``."""

from __future__ import annotations

import itertools
import json
import math
import subprocess
import sys

import pytest

import citygen
from citygen.generate.splits import families, relative_path, resolve, splits
from citygen.io import dumps, load_scene
from citygen.seeding import scene_seed
from citygen.spec.config import GeneratorConfig
from tests.conftest import ROOT

NAV = [f"urban-nav-{k}-{part}" for k in (1, 2, 3) for part in ("train", "test")]


def test_the_urban_nav_manifest_matches_the_paper():
    table = splits()
    assert set(NAV) <= set(table)
    assert sum(table[n].scenes for n in NAV) == 1536
    for name in NAV:
        cfg = table[name].config
        train = name.endswith("train")
        assert cfg.size == ((10.0, 10.0) if train else (15.0, 15.0))
        assert cfg.layout == "region" and cfg.terrain.layout == "wfc"
        assert all(getattr(cfg.terrain.mix, k) > 0 for k in ("flat", "slope", "stair", "rough"))
        level = name.split("-")[2]
        objects = 0 if level == "1" else (4 if train else 8)
        people = (2 if train else 3) if level == "3" else 0
        assert (cfg.placement.count, cfg.agents.people) == (objects, people)
    assert table["urban-nav-2-train"].config.placement.density_levels == (0.5, 1.0, 1.5)
    assert table["urban-nav-3-test"].config.agents.density_levels == (0.5, 1.0, 1.5)


def test_names_resolve_to_splits_and_families():
    assert [s.name for s in resolve("urban-nav-2")] == ["urban-nav-2-train", "urban-nav-2-test"]
    assert [s.name for s in resolve("urban-nav")] == NAV
    assert [s.name for s in resolve("urban-nav-3-test")] == ["urban-nav-3-test"]
    assert [s.seed for s in resolve("urban-nav-2", seed=7)] == [7, 7]
    assert families()["urban-nav-1"] == ("urban-nav-1-train", "urban-nav-1-test")
    assert relative_path("urban-nav-1-test", 12).as_posix() == "urban-nav-1/test/0012.json"
    assert relative_path("urban-tra-city", 0).as_posix() == "urban-tra-city/0000.json"


def test_the_top_level_api_is_lazy_and_callable():
    code = (
        "import sys, citygen\n"
        "assert 'citygen.generate' not in sys.modules\n"
        "s = citygen.generate('urban-nav-2-train', seed=7, index=3)\n"
        "import citygen.generate.pipeline\n"  # importing submodules does not rebind the name
        "assert callable(citygen.generate) and citygen.generate is sys.modules['citygen.generate']\n"
        "assert 'urban-nav-3-test' in citygen.splits()\n"
        "print(s.meta.split, s.meta.index, s.meta.seed)\n"
    )
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["urban-nav-2-train", "3", str(scene_seed(7, "urban-nav-2-train", 3))]


def test_a_split_scene_is_its_config_with_the_derived_seed():
    from citygen.generate import generate

    split = splits()["urban-nav-3-train"]
    scene = citygen.generate("urban-nav-3-train", index=4)
    seed = scene_seed(split.seed, split.name, 4)
    assert (scene.meta.split, scene.meta.index, scene.meta.seed) == ("urban-nav-3-train", 4, seed)
    assert dumps(scene) == dumps(generate(split.config, seed, split=split.name, index=4))
    # A config object is generated with the seed as the scene's own seed.
    assert dumps(citygen.generate(split.config, seed=seed, index=4)).count('"seed"') >= 1
    assert citygen.generate("urban-nav-3-train", seed=8, index=4).meta.seed != seed


def test_generate_writes_both_parts_where_it_says(cli, tmp_path):
    out = tmp_path / "out"
    result = cli("generate", "--split", "urban-nav-2", "--seed", "7", "--count", "2", "--out", out)
    assert result.code == 0, result.err
    assert f"wrote 2 scenes to {out}/urban-nav-2/train/" in result.out
    assert f"wrote 2 scenes to {out}/urban-nav-2/test/" in result.out
    files = sorted(p.relative_to(out).as_posix() for p in out.rglob("*.json"))
    assert files == [f"urban-nav-2/{p}/000{i}.json" for p in ("test", "train") for i in (0, 1)]
    scene = load_scene(out / "urban-nav-2/test/0001.json")
    assert (scene.meta.split, scene.meta.index) == ("urban-nav-2-test", 1)
    assert scene.meta.seed == scene_seed(7, "urban-nav-2-test", 1)
    assert citygen.validate(scene) == []
    # The same command writes the same bytes, in this process or in a pool of two.
    again = tmp_path / "again"
    assert cli("generate", "-s", "urban-nav-2", "--seed", "7", "-n", "2", "-o", again, "-j", "2").code == 0
    for path in out.rglob("*.json"):
        assert path.read_bytes() == (again / path.relative_to(out)).read_bytes()


def test_index_alone_makes_one_scene(cli, tmp_path):
    result = cli("generate", "--split", "urban-nav-1-test", "--index", "9", "--out", tmp_path)
    assert result.code == 0, result.err
    assert result.out.strip() == f"wrote {tmp_path}/urban-nav-1/test/0009.json"
    assert [p.name for p in tmp_path.rglob("*.json")] == ["0009.json"]


def test_a_users_config_file_is_a_split(cli, tmp_path):
    config = GeneratorConfig(size=(10.0, 12.0)).model_dump(mode="json", by_alias=True)
    for suffix, text in ((".json", json.dumps(config)), (".toml", "size = [10.0, 12.0]\n")):
        path = tmp_path / f"My Config{suffix}"
        path.write_text(text)
        out = tmp_path / f"out{suffix}"
        result = cli("generate", "--split", path, "--seed", "3", "--count", "2", "--out", out)
        assert result.code == 0, result.err
        scene = load_scene(out / "my-config/0001.json")
        assert scene.bounds.max == (10.0, 12.0)
        assert scene.meta.seed == scene_seed(3, "my-config", 1)


@pytest.mark.parametrize(
    ("args", "message"),
    [
        (["--split", "urban-nav-9"], "urban-nav-2, urban-nav-2-test, urban-nav-2-train"),
        (["--split", "nope.toml"], "nope.toml: $: expected an existing file, got no such file"),
        (["--split", "urban-nav-2", "--jobs", "0"], "expected at least 1 worker"),
    ],
)
def test_bad_input_is_one_line_and_exit_2(cli, tmp_path, args, message):
    result = cli("generate", *args, "--out", tmp_path)
    assert result.code == 2
    assert message in result.err
    if "urban-nav-9" in args:
        assert len(result.err.strip().splitlines()) == 1
    assert not list(tmp_path.rglob("*.json"))


def test_a_bad_config_file_names_the_field(cli, tmp_path):
    path = tmp_path / "bad.toml"
    path.write_text("size = [10.0, 12.0]\n[terrain]\nstep_height = [0.3, 0.1]\n")
    result = cli("generate", "--split", path, "--out", tmp_path)
    assert result.code == 2
    assert (
        result.err.strip()
        == f"{path}: $.terrain.step_height: expected [low, high] with low <= high, got [0.3, 0.1]"
    )


SPLITS = sorted(splits())


@pytest.mark.parametrize("name", [n for n in SPLITS if n != "urban-tra-city"])
def test_every_split_generates_a_valid_scene(name):
    check_split_scene(name, citygen.generate(name, index=1))


@pytest.mark.slow
def test_the_city_generates_a_valid_scene(city_file):
    """urban-tra-city's scene, generated once for the run by conftest's ``city_file`` (which
    also validates it; the city files of the export and traffic tests read the same one)."""
    check_split_scene("urban-tra-city", citygen.load_scene(city_file))


def check_split_scene(name: str, scene) -> None:
    assert citygen.validate(scene) == []
    config = splits()[name].config
    assert scene.bounds.max == config.size
    assert scene.task is not None and scene.task.kind == config.task.kind


@pytest.mark.parametrize("kind", ["flat", "slope", "stair", "rough"])
@pytest.mark.parametrize("part", ["train", "test"])
def test_urban_loc_manifests_are_the_papers_curriculum(kind, part):
    from citygen.generate.terrain import loc_config

    k = ["flat", "slope", "stair", "rough"].index(kind) + 1
    config = splits()[f"urban-loc-{k}-{part}"].config
    assert config.terrain == loc_config(part, kind)
    rows, cols = config.terrain.grid
    assert (rows, cols) == ((30, 30) if part == "train" else (16, 16))
    assert config.size == (cols * config.terrain.tile_size, rows * config.terrain.tile_size)
    assert config.task.kind == f"loco-{kind}"


def test_the_general_locomotion_grid_mixes_the_four_kinds_by_column():
    from citygen.generate.terrain import loc_config

    config = splits()["urban-loc-mixed-train"].config
    assert config.terrain == loc_config("train", "mixed")
    assert config.size == (240.0, 240.0)


# --- urban-tra-standard: the six-unit track ----------------------------------------------


def test_urban_tra_standard_is_the_papers_track(cli, tmp_path):
    result = cli("generate", "--split", "urban-tra-standard", "--out", tmp_path)
    assert result.code == 0, result.err
    path = tmp_path / "urban-tra-standard/0000.json"
    assert cli("validate", path).code == 0
    scene = load_scene(path)
    assert scene.bounds.max == (120.0, 10.0)
    # Six 20 m x 10 m units along x, one zone each.
    assert [z.id for z in scene.zones] == [f"unit-{u}" for u in range(1, 7)]
    for u, zone in enumerate(scene.zones):
        xs, ys = [p[0] for p in zone.polygon], [p[1] for p in zone.polygon]
        assert (min(xs), max(xs), min(ys), max(ys)) == (20.0 * u, 20.0 * (u + 1), 0.0, 10.0)

    def unit(x: float) -> int:
        return min(5, int(x // 20.0))

    # Units 1-3 even: every tile flat at street level; units 4-6 uneven: slopes, stairs, rough.
    t = scene.terrain
    kinds = {u: [] for u in range(6)}
    for r in range(t.rows):
        for c in range(t.cols):
            tile = t.tile(r, c)
            kinds[unit(t.origin[0] + (c + 0.5) * t.tile_size)].append((tile.kind, tile.height))
    for u in range(3):
        assert set(kinds[u]) == {("flat", 0.0)}, u
    for u in range(3, 6):
        assert "flat" not in {k for k, _ in kinds[u]}, u
    assert {k for u in range(3, 6) for k, _ in kinds[u]} == {"slope", "stair", "rough"}
    # Clear, static, dynamic on each surface: objects in units 2, 3, 5, 6; people in 3 and 6.
    objects = [unit(p.position[0]) for p in scene.placements]
    assert sorted(set(objects)) == [1, 2, 4, 5] and all(objects.count(u) == 8 for u in (1, 2, 4, 5))
    for a in scene.agents:
        assert unit(a.start[0]) == unit(a.goal[0]) in (2, 5)
    assert sorted(unit(a.start[0]) for a in scene.agents) == [2] * 4 + [5] * 4
    # The traverse route: laps of the track, 1,200 m in all, back where it started.
    task = scene.task
    points = [task.start.position, *task.route]
    legs = [math.dist(a, b) for a, b in itertools.pairwise(points)]
    assert task.kind == "traverse" and sum(legs) == pytest.approx(1200.0, abs=0.01)
    assert max(legs) <= 25.0 and task.route[-1] == task.start.position
    assert {p[1] for p in points} == {2.5, 7.5}
    assert min(p[0] for p in points) == 2.5 and max(p[0] for p in points) == 117.5
    assert sum(p == task.start.position for p in task.route) == 5  # five laps


def test_a_track_of_your_own_from_a_config_file(cli, tmp_path):
    config = tmp_path / "track.toml"
    config.write_text(
        'size = [45.0, 8.0]\nlayout = "track"\n[track]\nunit_length = 15.0\nroute_length = 500.0\n'
        'units = [{ surface = "uneven", setting = "dynamic", zone = "trail" }, { setting = "static" },'
        ' { surface = "uneven" }]\n[placement]\ncount = 3\n[agents]\npeople = 2\n[task]\nkind = "traverse"\n'
    )
    result = cli("generate", "--split", config, "--count", "2", "--out", tmp_path)
    assert result.code == 0, result.err
    for path in sorted((tmp_path / "track").glob("*.json")):
        scene = load_scene(path)
        assert citygen.validate(scene) == []
        assert [z.kind for z in scene.zones] == ["trail", "plaza", "plaza"]
        assert len(scene.placements) == 6 and len(scene.agents) == 2
        points = [scene.task.start.position, *scene.task.route]
        assert sum(math.dist(a, b) for a, b in itertools.pairwise(points)) >= 500.0


@pytest.mark.parametrize(
    ("text", "message"),
    [
        (
            'size = [100.0, 10.0]\nlayout = "track"\n',
            "$.track.units: expected units spanning the scene's width size[0] = 100 m, "
            "got 6 units of 20 m = 120 m",
        ),
        (
            'size = [20.0, 10.0]\nlayout = "track"\n[track]\nunits = [{ surface = "bumpy" }]\n',
            "$.track.units[0].surface: expected one of 'even' or 'uneven', got \"bumpy\"",
        ),
        (
            'size = [20.0, 1.0]\nlayout = "track"\n[track]\nunits = [{}]\n[task]\nkind = "traverse"\n',
            "no room for two lanes of laps",
        ),
    ],
)
def test_a_bad_track_is_one_line(cli, tmp_path, text, message):
    path = tmp_path / "track.toml"
    path.write_text(text)
    result = cli("generate", "--split", path, "--out", tmp_path)
    assert result.code == 2
    assert len(result.err.strip().splitlines()) == 1 and message in result.err
    assert not list(tmp_path.rglob("*.json"))


# --- placement.count = "density" in TOML -----------------------------------------------------


def test_density_mode_is_count_density_in_toml_and_null_in_json(cli, tmp_path):
    toml = tmp_path / "dense.toml"
    toml.write_text('size = [30.0, 30.0]\n[placement]\ncount = "density"\ndensity_per_100m2 = 6.0\n')
    data = GeneratorConfig(size=(30.0, 30.0)).model_dump(mode="json", by_alias=True)
    data["placement"].update(count=None, density_per_100m2=6.0)
    (tmp_path / "json").mkdir()
    js = tmp_path / "json/dense.json"
    js.write_text(json.dumps(data))
    for path in (toml, js):
        result = cli("generate", "--split", path, "--count", "3", "--out", path.parent / "out")
        assert result.code == 0, result.err
    counts = []
    for i in range(3):
        a = (tmp_path / f"out/dense/{i:04d}.json").read_bytes()
        assert a == (tmp_path / f"json/out/dense/{i:04d}.json").read_bytes()
        counts.append(len(load_scene(tmp_path / f"out/dense/{i:04d}.json").placements))
    # Density mode, not the default count of 4: 6 per 100 m2 of the suitable ground.
    assert max(counts) > 4
    from citygen.io import parse, read_document

    assert parse(GeneratorConfig, read_document(toml)).placement.count is None


@pytest.mark.parametrize("value", ['"dens"', '"4"', "-1", "true"])
def test_a_bad_count_is_one_line(cli, tmp_path, value):
    path = tmp_path / "c.toml"
    path.write_text(f"[placement]\ncount = {value}\n")
    result = cli("generate", "--split", path, "--out", tmp_path)
    assert result.code == 2 and len(result.err.strip().splitlines()) == 1
    assert result.err.startswith(f"{path}: $.placement.count: expected ")


def test_the_manifest_documents_density_mode():
    text = (ROOT / "seeds/urban-tra.toml").read_text()
    assert 'placement.count = "density"' in text
