"""citygen under hostile input (issue 44): every wrong invocation a new user can type, with
files that lie, paths that cannot be written, full disks and Ctrl-C, is one line on stderr
naming the file, option or JSON path, exit code 2 (130 on Ctrl-C), no traceback, and no file
left behind.

Every command runs in this process through the console script's entry point (the ``cli``
fixture): a subprocess costs 1.5 s of imports, so only the real-signal test starts one. The
full disk is a size-limited tmpfs when the tests run as root and ``mount`` works; elsewhere
it is a write budget in ``citygen.io`` after which every write fails with ENOSPC (the same
error the kernel gives).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import shutil
import signal
import subprocess
import sys
import time
import types
import uuid
from pathlib import Path

import pytest

from tests.conftest import ROOT

EXAMPLE = ROOT / "examples" / "nav_static_10m.json"


# --- the folder every case runs in ----------------------------------------------------------


def _scene(**edit) -> str:
    doc = json.loads(EXAMPLE.read_text())
    for key, value in edit.items():
        if key == "z":
            doc["placements"][0]["position"][2] = value
        elif key == "asset":
            doc["placements"][0]["asset"] = value
    return json.dumps(doc)


FILES = {
    "scene.json": EXAMPLE.read_text(),
    "float.json": _scene(z=5.0),
    "buried.json": _scene(z=-1.0),
    "flatmesh.json": _scene(asset="meshes/flat.obj"),
    "meshes/flat.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 0 1\nf 1 1 2\nf 2 3 3\n",
    "unterminated.json": '{"format": "citygen.scene/1", "meta": {"description": "cafe',
    "nulls.json": '{"format": "citygen.scene/1", "bounds": null}',
    "garbage.npz": "this is not a policy",
    "run/config.json": "{}",
    "tiny.toml": "size = [0.5, 0.5]\n",
    "crowded.toml": "[placement]\ncount = 400\n",
    "unknown.toml": "sise = [10.0, 10.0]\n",
    "broken.toml": "size = [10.0, 10.0\n",
    "bignet.toml": "net_arch = [4096, 4096, 4096]\n",
    "rollout.toml": "envs = 64\nn_steps = 100000\n",
    "trainfield.toml": "learning_rat = 0.1\n",
    "afile": "",
}


@pytest.fixture
def work(tmp_path, monkeypatch):
    """A folder holding the cases' files, the current directory while a case runs."""
    for name, text in FILES.items():
        (tmp_path / name).parent.mkdir(parents=True, exist_ok=True)
        (tmp_path / name).write_text(text)
    (tmp_path / "adir").mkdir()
    monkeypatch.chdir(tmp_path)
    return tmp_path


def _tree(folder: Path) -> dict[str, int]:
    """Every file and folder under ``folder`` (hidden ones too) with its size."""
    return {str(p.relative_to(folder)): p.stat().st_size if p.is_file() else -1 for p in folder.rglob("*")}


@contextlib.contextmanager
def _mounted(folder: Path, options: str):
    """A tmpfs at ``folder`` (as root, where mount works), else nothing."""
    folder.mkdir(parents=True, exist_ok=True)
    if os.geteuid() != 0 or not shutil.which("mount"):
        yield False
        return
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(folder)], capture_output=True)
    try:
        yield done.returncode == 0
    finally:
        if done.returncode == 0:
            subprocess.run(["umount", "-l", str(folder)], capture_output=True)


@pytest.fixture
def readonly(work):
    """``work/ro``: a folder this process cannot write in (a read-only tmpfs as root, else a
    folder without write permission); the case is skipped where neither can be made."""
    folder = work / "ro"
    with _mounted(folder, "ro,size=64k") as mounted:
        if not mounted:
            if os.geteuid() == 0:
                pytest.skip("root writes anywhere and cannot mount a read-only tmpfs here")
            folder.chmod(0o555)
        yield folder
        if not mounted:
            folder.chmod(0o755)


# --- the table: (arguments, what the one line says) -----------------------------------------

S, R = "scene.json", "{ro}"
CASES: dict[str, tuple[list[str], list[str]]] = {
    # validate
    "validate: a device": (["validate", "/dev/zero"], ["/dev/zero: $: expected a JSON file, got a device"]),
    "validate: no such file": (["validate", "nope.json"], ["nope.json: $: expected an existing file"]),
    "validate: a folder": (["validate", "adir"], ["adir: $: expected a JSON file, got a directory"]),
    "validate: unterminated string": (["validate", "unterminated.json"], ["starting at line 1 column"]),
    "validate: null bounds": (["validate", "nulls.json"], ["$.bounds: expected an object, got null"]),
    "validate: object floating": (
        ["validate", "float.json"],
        ["$.placements[0].position", "above it", "rebuild"],
    ),
    "validate: object buried": (["validate", "buried.json"], ["$.placements[0].position", "buried 1.00 m"]),
    "validate: mesh without volume": (
        ["validate", "flatmesh.json"],
        ["$.placements[0].asset", "without volume"],
    ),
    "validate: config too small": (["validate", "tiny.toml"], ["tiny.toml: $.size: expected at least 4.2 m"]),
    "validate: config unknown field": (["validate", "unknown.toml"], ["$.sise", 'got unknown field "sise"']),
    "validate: broken TOML": (["validate", "broken.toml"], ["broken.toml: $: expected valid TOML"]),
    "validate: no file given": (["validate"], ["citygen validate: Missing argument"]),
    "validate: unknown option": (["validate", S, "--strict"], ["No such option: --strict"]),
    # schema
    "schema: --out a file": (["schema", "--out", "afile"], ["--out afile: expected a folder, got a file"]),
    "schema: --out under a file": (
        ["schema", "--out", "afile/s"],
        ["expected a folder at afile, got a file"],
    ),
    "schema: --out read-only": (["schema", "--out", R], ["--out", "expected a writable folder"]),
    # render
    "render: --out under a file": (["render", S, "--out", "afile/x.png"], ["expected a folder at afile"]),
    "render: --out not a png": (["render", S, "--out", "x.jpg"], ["x.jpg: expected a path ending in .png"]),
    "render: --size too small": (
        ["render", S, "--size", "10"],
        ["citygen render: Invalid value for '--size'", "allowed: 64 to 8,192"],
    ),
    "render: --size not a number": (["render", S, "--size", "big"], ["'--size'", "valid integer"]),
    "render: no such scene": (["render", "nope.json"], ["nope.json: $: expected an existing file"]),
    "render: --out read-only": (["render", S, "--out", "{ro}/x.png"], ["expected a writable folder"]),
    # export
    "export: --out a file": (["export", S, "--out", "afile"], ["--out afile: expected a folder, got a file"]),
    "export: --out under a file": (["export", S, "--out", "afile/x"], ["expected a folder at afile"]),
    "export: --out read-only": (["export", S, "--out", R], ["expected a writable folder"]),
    "export: unknown format": (["export", S, "--format", "obj"], ["--format: expected one of mjcf"]),
    "export: invalid scene": (
        ["export", "float.json", "-f", "mjcf"],
        ["float.json: error: $.placements[0].position"],
    ),
    "export: mesh without volume": (["export", "flatmesh.json", "-f", "mjcf"], ["without volume"]),
    "export: mesh, not validated": (
        ["export", "flatmesh.json", "-f", "mjcf", "--no-validate", "-j", "1"],
        ["flatmesh.json: error: mjcf: QhullError: QH6214"],
    ),
    "export: two resolutions": (
        ["export", S, "--resolution", "0.1", "--occupancy-resolution", "0.2"],
        ["--resolution: the same as --occupancy-resolution"],
    ),
    "export: resolution too fine": (["export", S, "--terrain-resolution", "0"], ["'--terrain-resolution'"]),
    "export: --jobs 0": (["export", S, "--jobs", "0"], ["'--jobs' / '-j'"]),
    "export: no such scene": (["export", "nope.json"], ["nope.json: error: $: expected an existing file"]),
    # generate
    "generate: unknown split": (["generate", "--split", "urban-nav-9"], ["--split: expected a split"]),
    "generate: --index past the bound": (
        ["generate", "-s", "urban-nav-1-test", "--index", "99999999999"],
        ["'--index'", "allowed: 0 to 10,000,000"],
    ),
    "generate: --count past the bound": (
        ["generate", "-s", "urban-nav-1-test", "--count", "1000000000"],
        ["'--count'", "allowed: 1 to 100,000"],
    ),
    "generate: --count 0": (
        ["generate", "-s", "urban-nav-1-test", "--count", "0"],
        ["'--count'", "greater than or equal to 1"],
    ),
    "generate: past the last index": (
        ["generate", "-s", "urban-nav-1-test", "--index", "9999999", "--count", "5"],
        ["--index: expected scenes up to index 10,000,000"],
    ),
    "generate: family past the bound": (
        ["generate", "-s", "urban-nav", "--count", "20000"],
        ["--count: expected at most 100,000 scenes in one run"],
    ),
    "generate: --out a file": (
        ["generate", "-s", "urban-nav-1-test", "--out", "afile"],
        ["--out afile: expected a folder"],
    ),
    "generate: --out under a file": (
        ["generate", "-s", "urban-nav-1-test", "--out", "afile/x"],
        ["expected a folder at afile"],
    ),
    "generate: --out read-only": (
        ["generate", "-s", "urban-nav-1-test", "--out", R],
        ["expected a writable folder"],
    ),
    "generate: config too small": (
        ["generate", "-s", "tiny.toml"],
        ["tiny.toml: $.size: expected at least 4.2 m"],
    ),
    "generate: config too crowded": (
        ["generate", "-s", "crowded.toml", "--out", "adir"],
        ["stage 'placement'", "of the 400 objects asked for"],
    ),
    "generate: config unknown field": (["generate", "-s", "unknown.toml"], ["$.sise"]),
    "generate: --jobs 0": (
        ["generate", "-s", "urban-nav-1-test", "--jobs", "0"],
        ["expected at least 1 worker"],
    ),
    "generate: unknown executor": (
        ["generate", "-s", "urban-nav-1-test", "--executor", "slurm"],
        ["--executor: expected one of local, ray"],
    ),
    "generate: negative seed": (["generate", "-s", "urban-nav-1-test", "--seed", "-1"], ["'--seed'"]),
    "generate: no such config": (
        ["generate", "-s", "nope.toml"],
        ["nope.toml: $: expected an existing file"],
    ),
    "generate: no --split": (["generate"], ["--split: expected a split", "--osm FILE --bbox"]),
    # dataset
    "dataset verify: no such folder": (
        ["dataset", "verify", "nope"],
        ["nope: expected a folder 'citygen dataset' wrote, got no such folder"],
    ),
    "dataset verify: a file": (
        ["dataset", "verify", "afile"],
        ["afile: expected a folder 'citygen dataset' wrote, got a file"],
    ),
    "dataset verify: an empty folder": (
        ["dataset", "verify", "adir"],
        ["adir: expected the 1,536 scene files", "none of them"],
    ),
    "dataset: --out a file": (["dataset", "--out", "afile"], ["--out afile: expected a folder, got a file"]),
    "dataset lock: --out under a file": (
        ["dataset", "lock", "--out", "afile/x.json"],
        ["expected a folder at afile"],
    ),
    # rebuild
    "rebuild: unknown stage": (
        ["rebuild", S, "--from", "roads"],
        ["--from: expected one of layout, terrain"],
    ),
    "rebuild: --out under a file": (
        ["rebuild", S, "--from", "placement", "--out", "afile/x.json"],
        ["expected a folder at afile"],
    ),
    "rebuild: no such scene": (
        ["rebuild", "nope.json", "--from", "placement"],
        ["nope.json: $: expected an existing file"],
    ),
    "rebuild: no split to rebuild from": (
        ["rebuild", S, "--from", "placement", "--out", "x.json"],
        ["$.meta.split"],
    ),
    "rebuild: negative seed": (["rebuild", S, "--from", "placement", "--seed", "-1"], ["'--seed'"]),
    "rebuild: no such config": (
        ["rebuild", S, "--from", "agents", "--config", "nope.toml", "--out", "x.json"],
        ["nope.toml"],
    ),
    # bench
    "bench: unknown task": (["bench", "--task", "nav-fast"], ["--task: expected one of nav-clear"]),
    "bench: split of another task": (
        ["bench", "--task", "nav-static", "--split", "urban-loc-1-test"],
        ["--split: urban-loc-1-test holds loco-flat scenes"],
    ),
    "bench: a garbage policy": (
        ["bench", "--task", "nav-clear", "--policy", "garbage.npz", "-n", "1", "-j", "1"],
        ["garbage.npz: expected a policy saved by `citygen train`, got a file that is not an .npz archive"],
    ),
    "bench: a run folder without a policy": (
        ["bench", "--task", "nav-clear", "--policy", "run"],
        ["--policy run: expected a model file", "holding policy.npz"],
    ),
    "bench: no such policy": (
        ["bench", "--task", "nav-clear", "--policy", "nope.npz"],
        ["--policy: expected a model file", "no such file"],
    ),
    "bench: --output under a file": (
        ["bench", "--task", "nav-clear", "--output", "afile/b.json"],
        ["--output afile/b.json: expected a folder at afile"],
    ),
    "bench: --output a folder": (
        ["bench", "--task", "nav-clear", "--output", "adir"],
        ["--output adir: expected a file path, got a folder"],
    ),
    "bench: --output read-only": (
        ["bench", "--task", "nav-clear", "--output", "{ro}/b.json"],
        ["expected a writable folder"],
    ),
    "bench: --episodes 0": (["bench", "--task", "nav-clear", "--episodes", "0"], ["'--episodes'"]),
    "bench: --episodes past the bound": (
        ["bench", "--task", "nav-clear", "--episodes", "100000"],
        ["'--episodes'", "allowed: 1 to 10,000"],
    ),
    "bench: --max-steps 0": (["bench", "--task", "nav-clear", "--max-steps", "0"], ["'--max-steps'"]),
    "bench: unknown robot": (["bench", "--task", "nav-clear", "--robot", "robbie"], ["--robot"]),
    "bench: --jobs 0": (["bench", "--task", "nav-clear", "--jobs", "0"], ["'--jobs'"]),
    "bench: policy of another task": (["bench", "--task", "nav-clear", "--policy", "trot"], ["--policy"]),
    # run
    "run: no such scene": (["run", "nope.json"], ["nope.json: $: expected an existing file"]),
    "run: animation of an unknown format": (
        ["run", S, "--animation", "x.jpg"],
        ["--animation: expected a file ending in .gif, .png, .webp"],
    ),
    "run: animation under a file": (
        ["run", S, "--animation", "afile/x.gif"],
        ["--animation afile/x.gif: expected a folder at afile"],
    ),
    "run: frames in a file": (
        ["run", S, "--frames", "afile"],
        ["--frames afile: expected a folder, got a file"],
    ),
    "run: --output under a file": (
        ["run", S, "--output", "afile/r.json"],
        ["--output afile/r.json: expected a folder at afile"],
    ),
    "run: a task the scene cannot run": (
        ["run", S, "--task", "loco-flat"],
        ["scene.json: $.task: loco-flat needs a locomotion grid"],
    ),
    "run: --every 0": (["run", S, "--every", "0"], ["'--every'"]),
    "run: a garbage policy": (["run", S, "--policy", "garbage.npz"], ["not an .npz archive"]),
    # train
    "train: unknown robot": (
        ["train", "--robot", "robbie", "--out", "t"],
        ["--robot: unknown robot 'robbie'"],
    ),
    "train: split of another task": (
        ["train", "--split", "urban-loc-1-train", "--out", "t"],
        ["--split: urban-loc-1-train holds loco-flat scenes"],
    ),
    "train: a garbage --init": (
        ["train", "--init", "garbage.npz", "--out", "t"],
        ["--init garbage.npz: expected a policy exported by `citygen train`"],
    ),
    "train: no such --init": (
        ["train", "--init", "nope", "--out", "t"],
        ["--init nope: expected a run folder", "no such file"],
    ),
    "train: --out a file": (["train", "--out", "afile"], ["--out afile: expected a folder, got a file"]),
    "train: a huge network": (
        ["train", "--config", "bignet.toml", "--out", "t"],
        ["$.net_arch: expected hidden layers of at most 20,000,000 weights"],
    ),
    "train: a huge rollout": (
        ["train", "--config", "rollout.toml", "--out", "t"],
        ["$.n_steps: expected a rollout of at most 1,000,000 samples"],
    ),
    "train: unknown config field": (
        ["train", "--config", "trainfield.toml", "--out", "t"],
        ["'learning_rate' (misspelt?)"],
    ),
    "train: --steps 0": (["train", "--steps", "0"], ["'--steps'"]),
    "train: --envs past the bound": (["train", "--envs", "5000"], ["'--envs'", "allowed: 1 to 4,096"]),
    "train: a seed numpy cannot take": (["train", "--seed", str(2**40)], ["'--seed'"]),
    # assets
    "assets render: unknown category": (["assets", "render", "spaceship", "--out", "x.png"], ["spaceship"]),
    "assets render: --out under a file": (["assets", "render", "bench", "--out", "afile/x.png"], ["afile"]),
    "assets render: --count 0": (["assets", "render", "bench", "--count", "0"], ["'--count'"]),
    # the app
    "unknown option": (["--bogus"], ["citygen: No such option: --bogus"]),
    "unknown command": (["frobnicate"], ["citygen: No such command 'frobnicate'"]),
}


def test_the_table_covers_every_command_eighty_times_over():
    assert len(CASES) >= 80
    commands = {args[0] for args, _ in CASES.values()}
    assert {"validate", "schema", "render", "export", "generate", "dataset", "rebuild", "bench", "run",
            "train", "assets"} <= commands  # fmt: skip


@pytest.mark.parametrize("name", list(CASES))
def test_a_hostile_invocation_is_one_line_exit_2_and_leaves_nothing(name, work, cli, request):
    args, says = CASES[name]
    if any("{ro}" in a for a in args):
        ro = request.getfixturevalue("readonly")
        args = [a.replace("{ro}", str(ro.relative_to(work))) for a in args]
    before = _tree(work)
    result = cli(*args)
    lines = result.err.strip().splitlines()
    assert result.code == 2, (name, result)
    assert len(lines) == 1, (name, lines)
    assert "Traceback" not in result.err + result.out
    for words in says:
        assert words in lines[0], (name, words, lines[0])
    assert _tree(work) == before, f"{name}: left files behind"


# --- full disks -----------------------------------------------------------------------------


@pytest.fixture
def small_disk(work, monkeypatch):
    """``(folder, size)``: a folder on a disk with ``size`` bytes free: a tmpfs of that size as
    root where mount works, else a budget of ``size`` bytes for citygen.io's writes under the
    folder, after which each fails with ENOSPC as a full disk's do."""
    made = []

    def make(size: int) -> Path:
        folder = work / f"disk{len(made)}"
        stack = contextlib.ExitStack()
        mounted = stack.enter_context(_mounted(folder, f"size={size}"))
        made.append(stack)
        if not mounted:
            _budget(monkeypatch, folder, size)
        return folder

    yield make
    for stack in made:
        stack.close()


def _budget(monkeypatch, folder: Path, size: int) -> None:
    import citygen.io

    left = [size]
    real = os

    class Limited:
        def __init__(self, f):
            self._f = f

        def write(self, data):
            left[0] -= len(data)
            if left[0] < 0:
                raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
            return self._f.write(data)

        def __getattr__(self, name):
            return getattr(self._f, name)

        def __enter__(self):
            self._f.__enter__()
            return self

        def __exit__(self, *exc):
            return self._f.__exit__(*exc)

    def fdopen(fd, *a, **k):
        f = real.fdopen(fd, *a, **k)
        target = Path(real.readlink(f"/proc/self/fd/{fd}"))
        return Limited(f) if target.is_relative_to(folder.resolve()) else f

    monkeypatch.setattr(citygen.io, "os", types.SimpleNamespace(**{**vars(real), "fdopen": fdopen}))


def _no_partial_files(folder: Path) -> None:
    for path in folder.rglob("*"):
        assert not path.name.startswith((".", "part-")), f"a partial file is left: {path}"
        if path.suffix == ".json":
            json.loads(path.read_text())  # whole


def test_generate_onto_a_disk_that_fills_up_is_one_line_and_keeps_whole_files(small_disk, cli):
    disk = small_disk(16384)  # room for a few 10 m scenes (3 kB each, a 4 kB page on a tmpfs), not 20
    result = cli("generate", "-s", "urban-nav-1-test", "--count", "20", "--out", disk, "-j", "1")
    assert result.code == 2, result
    assert result.err.strip().splitlines() == [result.err.strip()]
    assert "got a full disk" in result.err and str(disk) in result.err
    assert 0 < len(list(disk.rglob("*.json"))) < 20
    _no_partial_files(disk)


def test_export_onto_a_full_disk_writes_no_part_of_the_format(small_disk, cli):
    disk = small_disk(4096)  # the scene's MJCF file alone is 8 kB
    result = cli("export", EXAMPLE, "-f", "mjcf", "--out", disk, "-j", "1")
    assert result.code == 2, result
    assert result.err.strip().splitlines() == [result.err.strip()]
    assert "error: mjcf:" in result.err and "full disk" in result.err
    assert not [p for p in disk.rglob("*") if p.is_file()]


@pytest.mark.parametrize("command", ["bench", "train", "generate"])
def test_a_full_disk_is_found_before_the_work(small_disk, cli, command, monkeypatch):
    disk = small_disk(4096)
    with contextlib.suppress(OSError):  # fill it (a tmpfs) to the last byte
        (disk / "fill").write_bytes(b"\0" * 8192)
    if not (disk / "fill").exists() or shutil.disk_usage(disk).free:
        pytest.skip("no tmpfs to fill here (the write budget cannot fake free space)")
    import citygen.runner.bench

    monkeypatch.setattr(citygen.runner.bench, "_episode", lambda *a: pytest.fail("an episode ran"))
    args = {
        "bench": ["bench", "--task", "nav-clear", "-n", "1", "-j", "1", "--output", disk / "b.json"],
        "train": ["train", "--task", "nav-clear", "--out", disk / "run"],
        "generate": ["generate", "-s", "urban-nav-1-test", "--out", disk],
    }[command]
    result = cli(*args)
    assert result.code == 2, result
    assert result.err.strip() == f"--{'output' if command == 'bench' else 'out'} {args[-1]}: expected free " \
        f"space at {disk}, got a full disk"  # fmt: skip
    assert sorted(p.name for p in disk.iterdir()) == ["fill"]


def test_bench_results_survive_a_disk_that_fills_up_while_the_episodes_run(work, cli, monkeypatch):
    import citygen.io
    from citygen.errors import OutputError

    real = citygen.io.write_atomic

    def full(path, data, **kw):
        if Path(path).name == "b.json":
            raise OutputError(f"{path}: expected free space at ., got a full disk")
        return real(path, data, **kw)

    monkeypatch.setattr(citygen.io, "write_atomic", full)
    monkeypatch.setattr("tempfile.tempdir", str(work / "adir"))
    result = cli(
        "bench", "--task", "nav-clear", "-n", "1", "-j", "1", "--max-steps", "5", "--output", "b.json"
    )
    assert result.code == 2, result
    assert result.err.count("\n") == 1 and "the results were written to" in result.err
    rescued = Path(result.err.rsplit("written to ", 1)[1].split(" instead")[0])
    assert rescued.parent == work / "adir" and json.loads(rescued.read_text())["summary"]


# --- Ctrl-C ---------------------------------------------------------------------------------


def test_ctrl_c_in_generate_names_the_resume_command_and_leaves_whole_files(work, cli, monkeypatch):
    import citygen.generate.dataset as dataset

    made = dataset._scene_bytes
    calls = [0]

    def interrupted(split, index):
        calls[0] += 1
        if calls[0] == 3:
            raise KeyboardInterrupt
        return made(split, index)

    monkeypatch.setattr(dataset, "_scene_bytes", interrupted)
    result = cli("generate", "-s", "urban-nav-1-test", "--count", "5", "--out", "o", "-j", "1")
    assert result.code == 130, result
    assert result.err.strip() == (
        "interrupted (Ctrl-C); every file written is whole; resume with: "
        "citygen generate -s urban-nav-1-test --count 5 --out o -j 1 --resume"
    )
    assert len(list((work / "o").rglob("*.json"))) == 2
    _no_partial_files(work / "o")


def test_ctrl_c_in_export_leaves_no_part_of_the_format(work, cli, monkeypatch):
    import citygen.exporters.mjcf as mjcf

    real = mjcf.export

    def interrupted(scene, out_dir, **options):
        real(scene, out_dir, **options)  # every file written, then Ctrl-C before the batch moves them
        raise KeyboardInterrupt

    monkeypatch.setattr(mjcf, "export", interrupted)
    result = cli("export", EXAMPLE, "-f", "mjcf", "--out", "x", "-j", "1")
    assert result.code == 130, result
    assert result.err.strip() == "interrupted (Ctrl-C); no half-written file was left"
    assert not [p for p in (work / "x").rglob("*") if p.is_file()]


def test_ctrl_c_inside_a_compiled_kernel_is_an_interrupt_too(work, cli, monkeypatch):
    """A Ctrl-C (or a background run's SIGTERM) that arrives while a numba kernel runs comes out
    as SystemError("... returned a result with an exception set") caused by the interrupt: the
    one line and exit 130 all the same, and anything else stays an error."""
    import citygen.runner.bench
    from citygen.errors import is_interrupt

    def kernel_interrupted(*args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise SystemError("CPUDispatcher(<function k>) returned a result with an exception set") from exc

    monkeypatch.setattr(citygen.runner.bench, "_episode", kernel_interrupted)
    result = cli("bench", "--task", "nav-clear", "-n", "3", "-j", "1", "--output", "b.json")
    assert result.code == 130 and result.err.strip() == "interrupted (Ctrl-C); no half-written file was left"
    assert not is_interrupt(SystemError("a real one")) and not is_interrupt(ValueError())


def test_ctrl_c_in_bench_stops_at_once(work, cli, monkeypatch):
    import citygen.runner.bench

    monkeypatch.setattr(citygen.runner.bench, "_episode", lambda *a: (_ for _ in ()).throw(KeyboardInterrupt))
    result = cli("bench", "--task", "nav-clear", "-n", "3", "-j", "1", "--output", "b.json")
    assert result.code == 130 and result.err.strip() == "interrupted (Ctrl-C); no half-written file was left"
    assert not (work / "b.json").exists()


def test_ctrl_c_before_training_starts_leaves_no_run_folder(work, cli, monkeypatch):
    pytest.importorskip("stable_baselines3")
    import citygen.runner.learn.vecenv as vecenv

    monkeypatch.setattr(vecenv, "make_training_env", lambda cfg: (_ for _ in ()).throw(KeyboardInterrupt))
    result = cli("train", "--task", "nav-clear", "--out", "run1", "--steps", "100")
    assert result.code == 130, result
    assert result.err.strip() == (
        "interrupted (Ctrl-C); every file written is whole; resume with: citygen train --resume --out run1"
    )
    assert not (work / "run1").exists()


def test_a_real_ctrl_c_reaches_the_workers_quietly(tmp_path):
    """SIGINT to the whole process group, as a terminal sends it: generate's pool workers stop
    their scenes without a traceback, and the command exits 130 within seconds."""
    out = tmp_path / f"o-{uuid.uuid4().hex[:6]}"
    proc = subprocess.Popen(
        [sys.executable, "-m", "citygen", "generate", "-s", "urban-nav-2-train", "--count", "200",
         "--out", str(out), "-j", "2"],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, start_new_session=True,
    )  # fmt: skip
    deadline = time.monotonic() + 60
    while not list(out.rglob("*.json")) and time.monotonic() < deadline:  # the pool is at work
        time.sleep(0.1)
    os.killpg(proc.pid, signal.SIGINT)
    t = time.monotonic()
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130, err
    assert time.monotonic() - t < 10
    assert err.strip().startswith("interrupted (Ctrl-C); every file written is whole; resume with: citygen ")
    assert err.strip().endswith("-j 2 --resume") and "Traceback" not in err, err
    _no_partial_files(out)
