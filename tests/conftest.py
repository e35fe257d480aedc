"""Shared fixtures: the repository's folders and a way to run the CLI as a user does."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

# Offscreen rendering through EGL (software Mesa in CI) unless the caller chose a backend;
# MuJoCo reads this once, at its first import.
os.environ.setdefault("MUJOCO_GL", "egl")
# No on-disk store of prepared scenes (citygen.runner.scene_store) unless a test asks for one:
# tests measure what a process does alone, and leave nothing in the user's cache folder.
os.environ["CITYGEN_CACHE_DIR"] = "off"

ROOT = Path(__file__).resolve().parent.parent

#: Test files that take minutes (city-scale exports and traffic, the every-split export,
#: training runs), heaviest first. README's command (`-n 2 --dist loadfile
#: --no-loadscope-reorder`) hands files to the two workers in collection order: these go
#: first, so the many short files fill in behind them and both workers finish together.
#: (xdist's own order, most tests first, started the city files last: one worker ran them
#: alone for the last ~8 minutes while the other sat idle.)
HEAVY_FIRST = (
    "test_export_city.py",
    "test_export_all.py",
    "test_traffic_city.py",
    "test_learn.py",
    "test_layout.py",
    "test_placement.py",
    "test_generate_cli.py",
)


def pytest_collection_modifyitems(config, items):
    rank = {name: i for i, name in enumerate(HEAVY_FIRST)}
    items.sort(key=lambda item: rank.get(item.path.name, len(rank)))  # stable: in-file order kept


EXAMPLES = sorted((ROOT / "examples").glob("*.json"))
MANIFESTS = sorted((ROOT / "seeds").glob("*.toml"))


@dataclass
class Result:
    code: int
    out: str
    err: str


@pytest.fixture
def cli(capsys, monkeypatch):
    """Run ``citygen ARGS...`` in this process through the console script's entry point."""
    from citygen.cli import main

    def run(*args: str) -> Result:
        monkeypatch.setattr(sys, "argv", ["citygen", *map(str, args)])
        code = 0
        try:
            main()
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        captured = capsys.readouterr()
        return Result(code, captured.out, captured.err)

    return run


def run_subprocess(*args: str, env: dict | None = None, cwd: Path = ROOT) -> Result:
    """Run ``python -m citygen ARGS...`` in a fresh interpreter."""
    proc = subprocess.run(
        [sys.executable, "-m", "citygen", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=env,
        timeout=120,
    )
    return Result(proc.returncode, proc.stdout, proc.stderr)


@pytest.fixture(scope="session")
def city_file(tmp_path_factory, worker_id) -> Path:
    """urban-tra-city's scene 0 as its JSON file, generated (and validated) once for the whole
    run: under xdist the first worker to ask writes it into the run's shared temporary folder
    and the other waits on a lock (a city takes ~45 s to generate; three files need one)."""
    from filelock import FileLock

    import citygen

    base = tmp_path_factory.getbasetemp()
    root = base if worker_id == "master" else base.parent  # the run's folder, shared by workers
    path = root / "urban-tra-city-0000.json"
    with FileLock(str(path) + ".lock"):
        if not path.is_file():
            scene = citygen.generate("urban-tra-city")
            assert scene.signals and citygen.validate(scene) == []
            part = path.with_suffix(".part")
            citygen.save_scene(scene, part)
            part.replace(path)
    return path


@pytest.fixture(scope="session")
def town_config():
    """urban-tra-city's config on 400 m x 400 m (a ninth of its area, with a ninth of its
    objects, people and vehicles and a 300 m traverse): the ``town`` fixture's config."""
    from citygen.generate.splits import town_config

    return town_config(400.0)


@pytest.fixture(scope="module")
def town(town_config):
    """A town of ``town_config``, where a test needs the city's kinds of streets, signals,
    objects and agents but not its size: MuJoCo's and dm_control's parsers take minutes on
    the whole city, whose own MJCF test_export_city compiles and steps. Module-scoped;
    test_traffic_city's environment and test_export_city's dm_control check."""
    import citygen
    from citygen.generate import generate
    from citygen.seeding import scene_seed

    scene = generate(town_config, scene_seed(2025, "urban-tra-city", 0))
    assert scene.signals and citygen.validate(scene) == []
    return scene


def loco_grid(kind: str, robot: str) -> str:
    """A 2 x 2 Urban-Loc grid (16 m) of ``kind`` tiles (``flat``, ``rough``, ...) for a
    ``loco-<kind>`` task of ``robot``, as a split file's TOML: the train and test splits'
    30 x 30 and 16 x 16 grids take longer to generate than a whole tiny training run."""
    mix = ", ".join(f"{k} = {1.0 if k == kind else 0.0}" for k in ("flat", "slope", "stair", "rough"))
    return f"""
size = [16.0, 16.0]
layout = "curriculum"
terrain.layout = "curriculum"
terrain.tile_size = 8.0
terrain.grid = [2, 2]
terrain.mix = {{ {mix} }}
placement.count = 0
agents.people = 0
task.kind = "loco-{kind}"
task.robot = "{robot}"
"""


#: A tiny locomotion training run's config (seconds): add a line or two for what a test tries.
TINY_LOCO = """
envs = 2
processes = 0
n_steps = 64
minibatches = 2
n_epochs = 1
net_arch = [16]
checkpoint_every = 1000
"""


def tiny_loco_run(tmp_path: Path, task: str, robot: str, grid: Path, config: str) -> tuple[Path, str]:
    """``citygen train`` of ``config`` (TOML) for 128 steps on ``grid``, then ``citygen bench``
    of its policy.npz for one episode, both as a user runs them (asserting both succeed): the
    run folder and what the bench printed."""
    import subprocess
    import sys

    (tmp_path / "tiny.toml").write_text(config)
    out = tmp_path / "run"
    common = ["--task", task, "--robot", robot, "--split", str(grid)]
    for args in (
        ["train", *common, "--steps", "128", "--config", str(tmp_path / "tiny.toml"), "--out", str(out)],
        ["bench", *common, "--policy", str(out / "policy.npz"), "--episodes", "1", "--jobs", "1"],
    ):
        r = subprocess.run(
            [sys.executable, "-m", "citygen", *args], capture_output=True, text=True, cwd=ROOT, timeout=300
        )
        assert r.returncode == 0, r.stderr
    return out, r.stdout


def scripted_and_zero_residual(env, gait: str, steps: int = 100):
    """``steps`` steps of ``env`` from ``reset(seed=0)`` twice, by the scripted gait
    (``--policy trot``: the quadruped's trot, the humanoid's walk) and by a zero residual over
    ``gait``, asserting neither falls: both runs' qpos, shape ``(2, steps, nq)``, and the
    residual (to read its phase after the last step)."""
    import numpy as np

    from citygen.runner.learn.residual import GaitResidual
    from citygen.runner.policies import make_policy

    runs = []
    for residual in (False, True):
        obs, _ = env.reset(seed=0)
        driver = GaitResidual(gait, 0.2) if residual else make_policy("trot")
        driver.reset(env)
        trail = []
        for _ in range(steps):
            a = driver.action(env, np.zeros(env.n_actions + 1)) if residual else driver.act(obs)
            obs, _, fallen, _, _ = env.step(a)
            assert not fallen
            trail.append(env.data.qpos.copy())
        runs.append(np.array(trail))
    return np.array(runs), driver
