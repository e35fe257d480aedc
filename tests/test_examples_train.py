"""The example files a documented command names: every training config under
``examples/train`` loads for the task and robot its header's command names, and every split
manifest under ``examples/splits`` resolves to splits of its own (no name of the shipped
seeds' splits, so none of its scenes is a test or training scene: a scene's seed is made from
its split's name, master seed and index)."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from citygen.generate.manifests import resolve, splits
from citygen.runner.learn.config import load_config

ROOT = Path(__file__).resolve().parent.parent
CONFIGS = sorted((ROOT / "examples" / "train").rglob("*.toml"))
SPLITS = sorted((ROOT / "examples" / "splits").glob("*.toml"))


def _named(path: Path) -> tuple[str, str]:
    """The task and robot of a config's documented command (its header), else by its name."""
    text = path.read_text()
    loco = path.name.startswith("loco") or path.parent.name == "humanoid"
    if path.parent.name == "humanoid" or "humanoid" in path.name:
        robot = "humanoid"
    elif not loco:
        robot = "wheeled"
    else:
        robot = "wheeled_legged" if "wheeled" in path.name else "quadruped"
    task = re.search(r"--task ((?:nav|loco)-[a-z]+)", text)
    named_robot = re.search(r"--robot (\w+)", text)
    return (
        task.group(1) if task else "loco-flat" if loco else "nav-clear",
        named_robot.group(1) if named_robot else robot,
    )


def test_there_are_examples():
    assert len(CONFIGS) >= 40 and len(SPLITS) >= 4


@pytest.mark.parametrize("path", CONFIGS, ids=lambda p: str(p.relative_to(ROOT / "examples" / "train")))
def test_training_configs_load_for_the_command_they_document(path):
    task, robot = _named(path)
    cfg = load_config(path, task=task, robot=robot)
    assert cfg.task == task and cfg.robot == robot


@pytest.mark.parametrize("path", SPLITS, ids=lambda p: p.name)
def test_example_splits_resolve_to_splits_of_their_own(path):
    found = resolve(path)
    shipped = splits()
    assert found and all(s.name not in shipped for s in found)
    assert path.read_text().startswith("#")  # says what it is for and the command that uses it


@pytest.mark.parametrize(
    ("file", "like"),
    [("urban-nav-1-val", "urban-nav-1-test"), ("urban-nav-2-val", "urban-nav-2-test")],
)
def test_validation_splits_are_drawn_like_their_test_split(file, like):
    (val,) = resolve(ROOT / "examples" / "splits" / f"{file}.toml")
    test = splits()[like]
    assert val.config == test.config and val.seed != test.seed and val.scenes >= test.scenes


@pytest.mark.parametrize(
    ("file", "kind", "field"),
    [
        ("urban-loc-2-wide", 2, "slope_angle"),
        ("urban-loc-3-wide", 3, "step_height"),
        ("urban-loc-4-wide", 4, "roughness_amplitude"),
    ],
)
def test_widened_loco_grids_run_from_the_training_range_to_the_test_range(file, kind, field):
    (wide,) = resolve(ROOT / "examples" / "splits" / f"{file}.toml")
    train, test = splits()[f"urban-loc-{kind}-train"], splits()[f"urban-loc-{kind}-test"]
    span = getattr(wide.config.terrain, field)
    assert span == (getattr(train.config.terrain, field)[0], getattr(test.config.terrain, field)[1])
    assert (
        wide.config.terrain.mix == train.config.terrain.mix
        and wide.config.terrain.grid == train.config.terrain.grid
    )
    assert wide.config.task.kind == train.config.task.kind
