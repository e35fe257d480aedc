"""Datasets: resumable pool runs, lock files, verify, byte-identical bytes across processes."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import citygen
from citygen.generate.dataset import (
    INDEX_NAME,
    lock_path,
    read_lock,
    sha256,
    verify_dataset,
    write_dataset,
    write_lock,
    write_scenes,
)
from citygen.generate.splits import resolve, seeds_dir, splits
from tests.conftest import ROOT

# A small dataset: three tiny splits (clear, static, dynamic) of the Urban-Nav kind.
SMALL = """\
format = "citygen.splits/1"

[[splits]]
name = "tiny-1-train"
scenes = 12
seed = 5
config.placement.count = 0
config.agents.people = 0
config.task.kind = "nav-clear"

[[splits]]
name = "tiny-2-train"
scenes = 8
seed = 5
config.agents.people = 0
config.task.kind = "nav-static"

[[splits]]
name = "tiny-3-test"
scenes = 6
seed = 6
config.size = [15.0, 15.0]
config.task.kind = "nav-dynamic"
"""


@pytest.fixture
def small(tmp_path) -> Path:
    path = tmp_path / "tiny.toml"
    path.write_text(SMALL)
    return path


def digests(folder: Path) -> dict[str, str]:
    return {
        p.relative_to(folder).as_posix(): sha256(p.read_bytes())
        for p in sorted(folder.rglob("*.json"))
        if p.name != INDEX_NAME
    }


def test_a_dataset_run_writes_every_scene_an_index_and_verifies(small, tmp_path, cli):
    out = tmp_path / "data"
    written = write_dataset(out, manifest=small, jobs=2)
    assert [w.path for w in written][:2] == ["tiny-1/train/0000.json", "tiny-1/train/0001.json"]
    assert len(written) == 26 == len(digests(out))
    index = json.loads((out / INDEX_NAME).read_text())
    assert index["scenes"] == 26
    assert {f["path"]: f["sha256"] for f in index["files"]} == digests(out)
    for f in index["files"][::5]:
        scene = citygen.load_scene(out / f["path"])
        assert (scene.meta.split, scene.meta.index, scene.meta.seed) == (f["split"], f["index"], f["seed"])
        assert citygen.validate(scene) == []
    lock = write_lock(written, manifest=small)
    assert lock == tmp_path / "tiny.lock.json" == lock_path(small)
    assert verify_dataset(out, manifest=small) == []
    result = cli("dataset", "verify", out, "--manifest", small)
    assert result.code == 0, result.err
    assert "26 scenes match the lock file" in result.out
    # One changed byte, one missing file, one extra file: three lines, exit 2.
    victim = out / "tiny-2/train/0003.json"
    victim.write_bytes(victim.read_bytes().replace(b'"seed"', b'"seeD"', 1))
    (out / "tiny-1/train/0004.json").unlink()
    (out / "tiny-1/train/0099.json").write_text("{}")
    result = cli("dataset", "verify", out, "--manifest", small)
    assert result.code == 2
    lines = result.err.strip().splitlines()
    assert len(lines) == 4 and lines[-1] == f"{out}: 3 problems"
    assert any("tiny-2/train/0003.json: expected sha256" in line for line in lines)
    assert any("tiny-1/train/0004.json: expected a scene file, got no such file" in line for line in lines)
    assert any("0099.json: expected only the files tiny.lock.json lists" in line for line in lines)
    # Resuming against the lock makes exactly the two damaged scenes again.
    (out / "tiny-1/train/0099.json").unlink()
    again = write_dataset(out, manifest=small, jobs=1, resume=True)
    remade = sorted(w.path for w in again if not w.skipped)
    assert remade == ["tiny-1/train/0004.json", "tiny-2/train/0003.json"]
    assert verify_dataset(out, manifest=small) == []


def test_resume_without_a_lock_keeps_only_the_scene_it_would_make(tmp_path):
    split = resolve("urban-nav-1-train", seed=3)
    write_scenes(split, tmp_path, count=3, jobs=1)
    path = tmp_path / "urban-nav-1/train/0001.json"
    other = tmp_path / "urban-nav-1/train/0002.json"
    before = path.read_bytes()
    other.write_bytes(path.read_bytes())  # a valid scene, but not scene 2
    again = write_scenes(split, tmp_path, count=3, jobs=1, resume=True)
    assert [w.skipped for w in again] == [True, True, False]
    assert path.read_bytes() == before and other.read_bytes() != before


def _run(out: str, manifest: str, jobs: int) -> None:
    write_dataset(out, manifest=manifest, jobs=jobs, resume=True)


def test_a_resume_removes_what_a_kill_left_beside_the_index(small, tmp_path):
    """A kill while the index was written leaves its temporary file in the dataset's folder
    (seen once in the random-kill test below): the next run removes it, as it removes those
    beside the scenes."""
    out = tmp_path / "out"
    out.mkdir()
    (out / f".{INDEX_NAME}.x1y2z3.tmp").write_text("{")
    write_dataset(out, manifest=small, jobs=1, resume=True)
    assert not [p.name for p in out.rglob("*") if p.name.endswith(".tmp")]
    assert (out / INDEX_NAME).is_file()


@pytest.mark.slow
def test_sigkill_at_random_moments_then_resume_gives_the_uninterrupted_bytes(small, tmp_path):
    reference = tmp_path / "reference"
    write_dataset(reference, manifest=small, jobs=1)
    out = tmp_path / "killed"
    rng = np.random.default_rng(2025)
    fork = multiprocessing.get_context("fork")
    for round_ in range(20):
        # Generation already imported here: forked children start writing at once.
        child = fork.Process(target=_run, args=(str(out), str(small), 1 + round_ % 2))
        child.start()
        time.sleep(float(rng.uniform(0.02, 0.5)))
        os.kill(child.pid, signal.SIGKILL)
        child.join()
        # Whatever was there at the kill is whole: every scene file parses.
        for path in out.rglob("*.json"):
            if path.name != INDEX_NAME:
                citygen.load_scene(path)
    write_dataset(out, manifest=small, jobs=2, resume=True)
    assert digests(out) == digests(reference)
    assert (out / INDEX_NAME).read_bytes() == (reference / INDEX_NAME).read_bytes()
    assert not [p for p in out.rglob("*") if p.name.endswith(".tmp")]


@pytest.mark.slow
def test_bytes_are_the_same_with_any_pythonhashseed(tmp_path):
    code = (
        "import sys, hashlib, citygen\n"
        "from citygen.io import dumps\n"
        "for name in ('urban-nav-1-test', 'urban-nav-2-train', 'urban-nav-3-test'):\n"
        "    b = dumps(citygen.generate(name, index=2)).encode()\n"
        "    print(hashlib.sha256(b).hexdigest())\n"
    )
    outs = []
    for hashseed in ("0", "1", "4242"):
        env = {**os.environ, "PYTHONHASHSEED": hashseed}
        proc = subprocess.run(
            [sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, env=env, timeout=120
        )
        assert proc.returncode == 0, proc.stderr
        outs.append(proc.stdout.split())
    from citygen.io import dumps

    here = [
        sha256(dumps(citygen.generate(n, index=2)).encode())
        for n in ("urban-nav-1-test", "urban-nav-2-train", "urban-nav-3-test")
    ]
    assert outs[0] == outs[1] == outs[2] == here


def test_the_canonical_lock_file_covers_the_1536_scenes_and_matches_fresh_scenes(tmp_path):
    lock = read_lock(seeds_dir() / "urban-nav.lock.json")
    assert len(lock) == 1536 == sum(s.scenes for n, s in splits().items() if n.startswith("urban-nav-"))
    assert "urban-nav-1/train/0000.json" in lock and "urban-nav-3/test/0255.json" in lock
    # A sample of the canonical scenes, made here, has the recorded digests.
    rng = np.random.default_rng(0)
    for name in ("urban-nav-1-train", "urban-nav-2-test", "urban-nav-3-train"):
        for i in rng.integers(0, 256, size=2):
            written = write_scenes(resolve(name), tmp_path, index=int(i), jobs=1)
            assert lock[written[0].path] == written[0].sha256


def test_dataset_command_counts_and_index(small, tmp_path, cli):
    out = tmp_path / "d"
    result = cli("dataset", "--out", out, "--manifest", small, "--jobs", "2")
    assert result.code == 0, result.err
    assert f"wrote 12 scenes to {out}/tiny-1/train/" in result.out
    assert f"wrote {out}/index.json (26 scenes)" in result.out
    result = cli("dataset", "verify", out, "--manifest", small)
    assert result.code == 2 and "tiny.lock.json" in result.err  # no lock file yet


# --- executors ---------------------------------------------------------------------------


@pytest.mark.parametrize("command", [["generate", "--split", "urban-nav-2", "-n", "1"], ["dataset"]])
def test_ray_without_ray_installed_is_one_line_naming_the_extra(cli, tmp_path, monkeypatch, command):
    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` fails as if not installed
    result = cli(*command, "--out", tmp_path / "out", "--executor", "ray")
    assert result.code == 2
    assert result.err.strip() == (
        "--executor ray needs the package 'ray', which is not installed: pip install 'citygen[scale]'"
    )
    assert not (tmp_path / "out").exists()


def test_an_unknown_executor_is_one_line(cli, tmp_path):
    result = cli("generate", "--split", "urban-nav-2", "--out", tmp_path, "--executor", "dask")
    assert result.code == 2
    assert result.err.strip() == "--executor: expected one of local, ray, got 'dask'"
    assert not list(tmp_path.rglob("*.json"))


def test_chunks_hold_many_consecutive_scenes_of_one_split(small):
    from citygen.generate.dataset import MAX_CHUNK, chunks
    from citygen.io import load_manifest

    parts = load_manifest(small).splits
    work = [(s, i) for s in parts for i in range(s.scenes)]
    plan = list(chunks(work, 2))
    assert [(s.name, c) for s, c in plan][:2] == [
        ("tiny-1-train", [0, 1, 2, 3]),
        ("tiny-1-train", [4, 5, 6, 7]),
    ]
    assert sorted((s.name, i) for s, c in plan for i in c) == sorted((s.name, i) for s, i in work)
    big = [(parts[0], i) for i in range(10_000)]
    sizes = [len(c) for _, c in chunks(big, 8)]
    assert set(sizes[:-1]) == {MAX_CHUNK} and sum(sizes) == 10_000
