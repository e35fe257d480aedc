"""Generator configs and split manifests: paper defaults, semantic checks, manifests in seeds/."""

from __future__ import annotations

import pytest

from citygen.errors import SpecError
from citygen.io import load_manifest
from citygen.spec.config import GeneratorConfig, TerrainConfig, TerrainMix, check_config
from tests.conftest import MANIFESTS


def test_defaults_are_the_papers_urban_nav_training_setting():
    cfg = GeneratorConfig()
    assert cfg.size == (10.0, 10.0)
    assert cfg.placement.count == 4 and cfg.agents.people == 2
    t = cfg.terrain
    assert (
        t.step_height == (0.05, 0.23)
        and t.slope_angle == (0.0, 0.4)
        and t.roughness_amplitude == (0.02, 0.10)
    )
    assert {t.mix.flat, t.mix.slope, t.mix.stair, t.mix.rough} == {1.0}
    assert cfg.blocks.curve_radius == (25.0, 60.0) and cfg.blocks.curve_angle_deg == (45.0, 135.0)
    assert check_config(cfg) == []


def test_configs_are_immutable():
    cfg = GeneratorConfig()
    with pytest.raises(ValueError):
        cfg.size = (1.0, 1.0)
    assert cfg.model_copy(update={"size": (15.0, 15.0)}).size == (15.0, 15.0)


def test_check_config_finds_inverted_ranges_and_zero_weights():
    cfg = GeneratorConfig(
        terrain=TerrainConfig(step_height=(0.3, 0.1), mix=TerrainMix(flat=0, slope=0, stair=0, rough=0))
    )
    assert sorted(p.path for p in check_config(cfg)) == ["$.terrain.mix", "$.terrain.step_height"]


@pytest.mark.parametrize("path", MANIFESTS, ids=lambda p: p.name)
def test_manifests_load(path):
    manifest = load_manifest(path)
    assert manifest.splits


def test_urban_nav_is_1536_scenes_in_six_parts():
    (nav,) = [load_manifest(p) for p in MANIFESTS if p.name == "urban-nav.toml"]
    parts = {s.name: s for s in nav.splits}
    assert sorted(parts) == [f"urban-nav-{i}-{part}" for i in (1, 2, 3) for part in ("test", "train")]
    assert sum(s.scenes for s in nav.splits) == 1536
    for i in (1, 2, 3):
        train, test = parts[f"urban-nav-{i}-train"].config, parts[f"urban-nav-{i}-test"].config
        assert train.size == (10.0, 10.0) and test.size == (15.0, 15.0)
    assert parts["urban-nav-2-train"].config.placement.count == 4
    assert parts["urban-nav-2-test"].config.placement.count == 8
    assert parts["urban-nav-2-test"].config.placement.density_levels == (0.5, 1.0, 1.5)
    assert parts["urban-nav-3-train"].config.agents.people == 2
    assert parts["urban-nav-3-test"].config.agents.people == 3


HEAD = 'format = "citygen.splits/1"\n[[splits]]\nname = "a"\n'


@pytest.mark.parametrize(
    ("text", "path"),
    [
        (HEAD + "scenes = 0\n", "$.splits[0].scenes"),
        (
            HEAD + "scenes = 1\nconfig.terrain.step_height = [0.3, 0.1]\n",
            "$.splits[0].config.terrain.step_height",
        ),
        (
            HEAD + 'scenes = 1\n[[splits]]\nname = "a"\nscenes = 2\n',
            "$.splits[1].name",
        ),
        ('format = "citygen.splits/1"\nsplits = [\n', "$"),
        (
            HEAD + 'scenes = 1\nconfig.layout = "grid"\n',
            "$.splits[0].config.layout",
        ),
    ],
)
def test_bad_manifests_name_the_path(tmp_path, cli, text, path):
    file = tmp_path / "m.toml"
    file.write_text(text)
    with pytest.raises(SpecError) as info:
        load_manifest(file)
    assert any(p.path == path for p in info.value.problems), info.value.problems
    result = cli("validate", file)
    assert result.code == 2 and all(line.startswith(f"{file}: $") for line in result.err.splitlines())


def test_cli_validates_manifests(cli):
    result = cli("validate", *MANIFESTS)
    assert result.code == 0, result.err
