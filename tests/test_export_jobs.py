"""``citygen export --jobs``: formats and scenes exported in worker processes write the same
files and say the same lines, in the same order, as one process; a format whose worker fails
or dies is one error line, and every other format is still written."""

from __future__ import annotations

import multiprocessing
import os
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from citygen.exporters import batch, glb, occupancy

ROOT = Path(__file__).resolve().parents[1]
SCENES = [ROOT / "examples" / "nav_static_10m.json", ROOT / "examples" / "street_corner.json"]


def _export(out: Path, jobs: int, fmt: str = "all") -> subprocess.CompletedProcess:
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    return subprocess.run(
        [sys.executable, "-m", "citygen", "export", *map(str, SCENES), "--format", fmt, "--out", str(out),
         "--jobs", str(jobs)],
        capture_output=True, text=True, env=env,
    )  # fmt: skip


def _files(folder: Path) -> dict[str, bytes]:
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_workers_write_the_same_files_and_lines_as_one_process(tmp_path: Path) -> None:
    one, two = _export(tmp_path / "one", 1), _export(tmp_path / "two", 2)
    assert one.returncode == 0 and two.returncode == 0, (one.stderr, two.stderr)
    assert two.stderr == one.stderr
    lines = [
        proc.stdout.replace(str(tmp_path / folder), "OUT") for proc, folder in ((one, "one"), (two, "two"))
    ]
    assert lines[1] == lines[0]
    written = _files(tmp_path / "one")
    assert _files(tmp_path / "two") == written
    # every format of both scenes is there
    for stem in ("nav_static_10m", "street_corner"):
        for suffix in (".xml", ".usda", ".urdf", ".npz", ".glb", ".html", ".png", "-perspective.png"):
            assert stem + suffix in written, suffix


OOM = "out of memory?)"


def _die(*args: object, **kwargs: object) -> list[Path]:
    os.kill(os.getpid(), signal.SIGKILL)
    return []


def _bug(*args: object, **kwargs: object) -> list[Path]:
    raise KeyError("a bug in the exporter")


@pytest.mark.skipif(sys.platform != "linux", reason="the workers inherit the patched exporter by fork")
def test_a_worker_that_dies_or_fails_loses_no_other_format(tmp_path: Path, monkeypatch) -> None:
    # Forked workers (not the fork server's fresh ones) inherit the patched exporters.
    monkeypatch.setattr(batch, "_context", lambda: multiprocessing.get_context("fork"))
    monkeypatch.setattr(glb, "export", _die)
    monkeypatch.setattr(occupancy, "export", _bug)
    formats = ["mjcf", "occupancy", "glb", "urdf"]
    events = list(batch.export_batch(SCENES, tmp_path, formats, jobs=2))
    errors = [(e.scene.name, e.text) for e in events if e.kind == "error"]
    assert sorted(errors) == sorted(
        [(s.name, f"glb: its worker process ended without a result (exit code -9; {OOM}") for s in SCENES]
        + [(s.name, "occupancy: KeyError: 'a bug in the exporter'") for s in SCENES]
    )
    for stem in ("nav_static_10m", "street_corner"):
        assert (tmp_path / f"{stem}.xml").is_file() and (tmp_path / f"{stem}.urdf").is_file()
        assert not (tmp_path / f"{stem}.glb").exists()
    # events keep the batch's order: scene by scene, format by format
    order = [(e.scene.name, e.text.split(":")[0]) for e in events if e.kind == "error"]
    assert order == [(s.name, f) for s in SCENES for f in ("occupancy", "glb")]


@pytest.mark.timeout(300)
def test_workers_start_clean_after_this_process_has_rendered(tmp_path: Path) -> None:
    """A process that has made a GL context (a render in a notebook, a test before this one)
    and then exports with workers: a forked worker's EGL set-up waited forever on the
    parent's lock (``export --format all`` hung in ``mujoco.Renderer``); workers from the fork
    server start clean."""
    from citygen.exporters import view

    view.render_array(SCENES[0], size=(64, 48))  # this process now holds a GL context
    events = list(batch.export_batch(SCENES, tmp_path, ["png", "mjcf"], jobs=2))
    assert [e.text for e in events if e.kind == "error"] == []
    for stem in ("nav_static_10m", "street_corner"):
        assert (tmp_path / f"{stem}-perspective.png").stat().st_size > 0
        assert (tmp_path / f"{stem}.xml").is_file()
