"""Scenes survive a save and a load unchanged, and are saved as canonical, stable bytes."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from decimal import Decimal
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings

import citygen.io
from citygen.io import dumps, load_scene, parse, read_json, save_scene
from citygen.spec import Scene, quantize
from citygen.spec.config import SplitManifest
from tests.strategies import declared_bounds, scenes

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.json"))

ROUNDTRIP = settings(
    max_examples=200,
    deadline=None,
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture],
)


def _files(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir())


# --- the examples ------------------------------------------------------------------


def test_there_are_examples():
    assert EXAMPLES, "no examples/*.json found"


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.name)
def test_example_round_trips(example: Path, tmp_path: Path):
    scene = load_scene(example)
    first = save_scene(scene, tmp_path / "first.json")
    again = load_scene(first)
    assert again == scene
    second = save_scene(again, tmp_path / "second.json")
    assert first.read_bytes() == second.read_bytes()
    assert _files(tmp_path) == ["first.json", "second.json"]


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.name)
def test_example_is_canonical_and_reproduced_byte_for_byte(example: Path, tmp_path: Path):
    # The examples are kept in canonical form, so a load-save cycle of a hand-edited
    # copy shows exactly what was edited and nothing else.
    original = example.read_bytes()
    saved = save_scene(load_scene(example), tmp_path / example.name)
    assert saved.read_bytes() == original, f"re-save {example.name} with citygen.save_scene"


# --- any scene ---------------------------------------------------------------------


def _floats_in(text: str) -> list[Decimal]:
    found: list[Decimal] = []
    json.loads(text, parse_float=lambda s: found.append(Decimal(s)) or float(s))
    return found


@ROUNDTRIP
@given(scene=scenes())
def test_scene_round_trips_exactly(scene: Scene, tmp_path: Path):
    path = tmp_path / "scene.json"
    save_scene(scene, path)
    first = path.read_bytes()
    again = load_scene(path)
    assert again == scene, f"changed by a save and a load:\n{first.decode()}"
    save_scene(again, path)
    assert path.read_bytes() == first, "saving the reloaded scene gave different bytes"
    save_scene(scene, path)
    assert path.read_bytes() == first, "saving the same scene twice gave different bytes"
    assert _files(tmp_path) == ["scene.json"], "a temporary file was left behind"


@ROUNDTRIP
@given(scene=scenes())
def test_dumps_is_json_with_quantised_floats(scene: Scene):
    text = dumps(scene)
    assert text.endswith("\n") and not text.endswith("\n\n")
    document = json.loads(text)
    assert parse(Scene, document) == scene
    assert dumps(parse(Scene, document)) == text
    for number in _floats_in(text):
        assert number.is_finite()
        exponent = number.as_tuple().exponent
        assert isinstance(exponent, int) and exponent >= -4, f"{number} has more than 4 decimals in:\n{text}"


@pytest.mark.parametrize("root", [Scene, SplitManifest], ids=lambda m: m.__name__)
def test_every_bound_survives_quantisation(root: type):
    """Bounds are inclusive multiples of 1e-4: a number inside one stays inside once rounded
    to 4 decimals (an exclusive ``gt=0`` would let 4e-05 in, then hold 0.0)."""
    bad = []
    for where, bound in declared_bounds(root):
        for value in (bound.lo, bound.hi):
            if bound.lo_open or bound.hi_open or (not bound.integer and quantize(value) != value):
                bad.append(f"{where}: {bound}")
    assert not bad, "\n".join(bad)


# --- the same bytes in every process ---------------------------------------------

_SAVE_IN_SUBPROCESS = """
import sys
from citygen.io import parse, read_json, save_scene
from citygen.spec import Scene, quantize
from citygen.spec.config import SplitManifest
save_scene(parse(Scene, read_json(sys.argv[1])), sys.argv[2])
"""


def _a_rich_document() -> dict[str, Any]:
    """A scene touching every top-level key, written with unsorted keys and raw floats."""
    return {
        "task": {
            "time_limit": 12.345678,
            "kind": "traverse",
            "start": {"yaw": -0.0, "position": [1, 2]},
            "route": [[3.00001, 4.99996], [5, 6]],
        },
        "agents": [
            {"kind": "vehicle", "id": "car", "start": [0, 0], "goal": [1e5, -1e5], "route": ["b", "a"]},
            {"speed": 1.23456, "kind": "scooter", "id": "s", "start": [0.1, 0.2], "goal": [0.3, 0.4]},
        ],
        "placements": [{"position": [1, 2, 3], "asset": "meshes/ü.obj", "id": "p"}],
        "terrain": {
            "tiles": [{"kind": "rough", "scale": 0.33333, "amplitude": 0.1, "seed": 4294967295}],
            "rows": 1.0,
            "cols": 1,
            "tile_size": 2.5,
            "origin": [-1e-9, 1e9],
        },
        "zones": [
            {
                "polygon": [[0, 0], [1, 0], [0, 1]],
                "kind": "plaza",
                "id": "z",
                "holes": [[[0.1, 0.1], [0.2, 0.1], [0.1, 0.2]]],
                "friction": 0.70001,
            }
        ],
        "blocks": [
            {
                "kind": "roundabout",
                "radius": 12.5,
                "id": "r",
                "pose": {"position": [0, 0]},
                "sockets": [{"id": "x", "pose": {"position": [1, 1], "yaw": 3.14159265}}],
            }
        ],
        "bounds": {"max": [100, 100], "min": [-100, -100]},
        "meta": {"seed": 18446744073709551615, "description": "ünïcode ✓ \U0001f6b2"},
        "format": "citygen.scene/1",
        "$schema": "../schemas/scene.schema.json",
    }


@pytest.mark.parametrize("source", [*EXAMPLES, None], ids=[*(p.name for p in EXAMPLES), "rich-document"])
def test_bytes_identical_across_processes(source: Path | None, tmp_path: Path):
    if source is None:
        source = tmp_path / "source.json"
        source.write_text(json.dumps(_a_rich_document()), encoding="utf-8")
    outputs = []
    for hash_seed in ("0", "1", "4242"):
        out = tmp_path / f"out-{hash_seed}.json"
        env = {**os.environ, "PYTHONHASHSEED": hash_seed}
        subprocess.run(
            [sys.executable, "-c", _SAVE_IN_SUBPROCESS, str(source), str(out)],
            check=True,
            env=env,
            cwd=tmp_path,
            timeout=120,
        )
        outputs.append(out.read_bytes())
    assert outputs[0] == outputs[1] == outputs[2]
    # ... and the same bytes as this process writes.
    assert outputs[0] == dumps(parse(Scene, read_json(source))).encode("utf-8")


# --- atomic saving ---------------------------------------------------------------


@pytest.fixture
def rich_scene() -> Scene:
    return parse(Scene, _a_rich_document())


def test_save_leaves_no_temporary_file(rich_scene: Scene, tmp_path: Path):
    scene = rich_scene
    target = tmp_path / "scene.json"
    assert save_scene(scene, target) == target
    save_scene(scene, target)  # overwriting, too
    assert _files(tmp_path) == ["scene.json"]
    assert load_scene(target) == scene


def test_save_creates_missing_folders(rich_scene: Scene, tmp_path: Path):
    scene = rich_scene
    target = tmp_path / "a" / "b" / "scene.json"
    save_scene(scene, target)
    assert load_scene(target) == scene
    assert _files(target.parent) == ["scene.json"]


def _open_fds() -> set[str] | None:
    """This process's open file descriptors (Linux), or None where they cannot be listed."""
    fd_dir = Path("/proc/self/fd")
    return {p.name for p in fd_dir.iterdir()} if fd_dir.is_dir() else None


def _boom(*args: Any, **kwargs: Any) -> Any:
    raise OSError(28, "No space left on device (simulated)")


@pytest.mark.parametrize(
    "where",
    [
        ("citygen.io", "dumps"),
        ("os", "replace"),
        ("os", "fsync"),
        ("os", "fchmod"),
    ],
    ids=lambda w: ".".join(w),
)
def test_failed_save_leaves_existing_file_and_no_temporary(
    where: tuple[str, str], rich_scene: Scene, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    target = tmp_path / "scene.json"
    old = b'{"an existing": "file"}\n'
    target.write_bytes(old)
    fds = _open_fds()
    module = citygen.io if where[0] == "citygen.io" else citygen.io.os
    monkeypatch.setattr(module, where[1], _boom)
    # A write's OS error becomes one line naming the file (OutputError, an OSError too).
    with pytest.raises(OSError, match=r"simulated|scene\.json: expected free space .*, got a full disk"):
        if where[1] == "fsync":  # only a durable write syncs
            citygen.io.write_atomic(target, citygen.io.dumps(rich_scene).encode(), durable=True)
        else:
            save_scene(rich_scene, target)
    monkeypatch.undo()
    assert target.read_bytes() == old
    assert _files(tmp_path) == ["scene.json"], "a temporary file was left behind"
    if fds is not None:
        assert _open_fds() == fds, "the temporary file's descriptor was left open"


def test_failed_first_save_leaves_nothing(rich_scene: Scene, tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    monkeypatch.setattr(citygen.io.os, "replace", _boom)
    # The OS error becomes one line naming the file (OutputError, an OSError too).
    with pytest.raises(OSError, match=r"scene\.json: expected free space .*, got a full disk"):
        save_scene(rich_scene, tmp_path / "scene.json")
    monkeypatch.undo()
    assert _files(tmp_path) == []


def test_interrupted_write_leaves_existing_file(
    rich_scene: Scene, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
):
    """A KeyboardInterrupt half-way through writing (not only an OSError) cleans up too."""
    target = tmp_path / "scene.json"
    save_scene(rich_scene, target)
    before = target.read_bytes()
    other = parse(Scene, {**_a_rich_document(), "meta": {"description": "changed"}})

    def interrupted(*args: Any, **kwargs: Any) -> Any:
        raise KeyboardInterrupt

    monkeypatch.setattr(citygen.io.os, "replace", interrupted)  # the bytes are written, not renamed
    with pytest.raises(KeyboardInterrupt):
        save_scene(other, target)
    monkeypatch.undo()
    assert target.read_bytes() == before
    assert _files(tmp_path) == ["scene.json"]


@pytest.mark.parametrize("durable", [False, True])
def test_only_durable_writes_sync_to_disk(durable: bool, tmp_path: Path, monkeypatch: pytest.MonkeyPatch):
    """A rename is atomic without fsync (kill-safe); fsync (3 ms a file) is for power cuts only."""
    synced: list[int] = []
    monkeypatch.setattr(citygen.io.os, "fsync", synced.append)
    citygen.io.write_atomic(tmp_path / "a.json", b"{}\n", durable=durable)
    assert (tmp_path / "a.json").read_bytes() == b"{}\n"
    assert len(synced) == (1 if durable else 0)
