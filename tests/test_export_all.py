"""Every exporter on a sample of generated scenes covering every kind of split, through the
command line as a user runs it: MJCF compiles, USD validates, URDF loads in PyBullet, the
occupancy files load, GLB and HTML are written, the PNG pictures exist.

The sample: one scene of each of the six Urban-Nav parts, of each Urban-Loc test part (flat,
slope, stair, rough curriculum grids, on 4 x 4 of the split's 16 x 16 tiles), of
urban-tra-standard and a street network with buildings, traffic and a traverse route: 12 in
all. urban-tra-city itself
is exported to every format in test_export_city. (8, then 4 of each Urban-Nav part made this
one of the suite's longest tests, 10 minutes of a 30-minute run on one worker, and 2 still
11 minutes of a loaded one; one covers the same kinds.)
"""

from __future__ import annotations

import os
import subprocess
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pytest

import citygen
from citygen import save_scene
from citygen.generate import generate
from citygen.seeding import scene_seed
from citygen.spec.config import (
    AgentsConfig,
    BlocksConfig,
    GeneratorConfig,
    PlacementConfig,
    TaskConfig,
)

ROOT = Path(__file__).resolve().parents[1]


def sample() -> list[tuple[str, GeneratorConfig, int]]:
    splits = citygen.splits()
    out = []
    for name in sorted(n for n in splits if n.startswith("urban-nav-")):
        out += [(name, splits[name].config, 0)]
    # The test parts of Urban-Loc on 4 x 4 tiles of their ranges (easiest row to hardest): the
    # split's 16 x 16 grid is the same tile kinds 16 times over.
    for name in sorted(n for n in splits if n.startswith("urban-loc-") and n.endswith("-test")):
        config = splits[name].config
        tiles = config.terrain.model_copy(update={"grid": (4, 4)})
        side = 4 * config.terrain.tile_size
        out += [(name, config.model_copy(update={"size": (side, side), "terrain": tiles}), 0)]
    out += [("urban-tra-standard", splits["urban-tra-standard"].config, 0)]
    # urban-tra-city itself is exported in test_export_city; a street network of a few blocks
    # stands in for it here.
    streets = GeneratorConfig(
        size=(150.0, 150.0),
        layout="blocks",
        blocks=BlocksConfig(count=3, straight_length=(25.0, 45.0)),
        placement=PlacementConfig(count=None, density_per_100m2=1.0),
        agents=AgentsConfig(people=10, vehicles=3),
        task=TaskConfig(kind="traverse", min_distance=40.0, time_limit=300.0),
    )
    return [*out, ("streets", streets, 0)]


def _export(args: tuple[str, str, str]) -> tuple[str, str, int, str]:
    scene, out, fmt = args
    env = {**os.environ, "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    proc = subprocess.run(
        [sys.executable, "-m", "citygen", "export", scene, "--format", fmt, "--out", out],
        capture_output=True,
        text=True,
        env=env,
    )
    return scene, out, proc.returncode, proc.stderr


def _check(out: Path, name: str) -> None:
    import mujoco
    import pybullet
    from pxr import Usd

    mujoco.MjModel.from_xml_path(str(out / f"{name}.xml"))
    stage = Usd.Stage.Open(str(next(out.glob(f"{name}.usd*"))))
    assert stage.GetDefaultPrim()
    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.loadURDF(str(out / f"{name}.urdf"), useFixedBase=True, physicsClientId=client)
    finally:
        pybullet.disconnect(client)
    with np.load(out / f"{name}.npz", allow_pickle=False) as grid:
        assert grid["labels"].dtype == np.uint8 and grid["labels"].shape == grid["heights"].shape
    assert (out / f"{name}.yaml").is_file() and (out / f"{name}.pgm").is_file()
    for suffix in (".glb", ".html", ".png", "-perspective.png"):
        assert (out / f"{name}{suffix}").stat().st_size > 0, suffix


@pytest.mark.slow
def test_a_sample_of_every_split_exports_to_every_format(tmp_path: Path) -> None:
    scenes = []
    for k, (split, config, index) in enumerate(sample()):
        seed = scene_seed(2025, split, index)
        path = tmp_path / "scenes" / f"{k:02d}-{split}.json"
        save_scene(
            generate(config, seed, split=split if split.startswith("urban") else None, index=index), path
        )
        scenes.append(path)
    assert len(scenes) == 12
    jobs = [(str(p), str(tmp_path / "out" / p.stem), "all") for p in scenes]
    with ProcessPoolExecutor(2) as pool:
        results = list(pool.map(_export, jobs))
    for scene, out, code, err in results:
        assert code == 0, (scene, err[-2000:])
        assert "Traceback" not in err
        _check(Path(out), Path(scene).stem)


def test_export_command_writes_each_format_and_reports_what_a_format_drops(tmp_path: Path) -> None:
    scene = ROOT / "examples" / "nav_static_10m.json"
    for fmt in ("mjcf", "urdf", "occupancy"):
        scene_out = tmp_path / fmt
        _, _, code, err = _export((str(scene), str(scene_out), fmt))
        assert code == 0, err
        assert (
            sorted(p.suffix for p in scene_out.iterdir() if p.is_file())
            == {
                "mjcf": [".xml"],
                "urdf": [".urdf"],
                "occupancy": [".npz", ".pgm", ".png", ".yaml"],
            }[fmt]
        ), fmt
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "citygen",
            "export",
            str(scene),
            "--format",
            "urdf",
            "--out",
            str(tmp_path / "u"),
        ],
        capture_output=True,
        text=True,
    )
    assert proc.returncode == 0, proc.stderr
    assert "warning: $.agents" in proc.stderr or "warning: $.task" in proc.stderr
    assert any(line.startswith("wrote ") and line.endswith(".urdf") for line in proc.stdout.splitlines())


@pytest.mark.parametrize(
    ("args", "needle"),
    [
        (["--format", "obj"], "--format: expected one of mjcf"),
        (
            ["--mjcf-terrain", "mesh"],
            "--mjcf-terrain: expected one of heightfield, convex, hybrid, got 'mesh'",
        ),
        (["missing.json"], "missing.json"),
    ],
)
def test_export_command_rejects_bad_input_in_one_line(tmp_path: Path, args: list[str], needle: str) -> None:
    files = [str(ROOT / "examples" / "street_corner.json")] if args[0].startswith("--") else []
    proc = subprocess.run(
        [sys.executable, "-m", "citygen", "export", *files, *args, "--out", str(tmp_path / "o")],
        capture_output=True,
        text=True,
        cwd=tmp_path,
    )
    assert proc.returncode == 2
    assert needle in proc.stderr and "Traceback" not in proc.stderr
    assert len(proc.stderr.strip().splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_sample_covers_every_kind_of_split() -> None:
    kinds = {c.task.kind for _, c, _ in sample()}
    assert kinds >= {"nav-clear", "nav-static", "nav-dynamic", "loco-flat", "loco-slope", "loco-stair",
                     "loco-rough", "traverse"}  # fmt: skip
    nav = sorted(n for n in citygen.splits() if n.startswith("urban-nav-"))
    assert {n for n, _, _ in sample()} >= set(nav) and len(nav) == 6
    names = [n for n, _, _ in sample()]
    assert len(names) == len(set(names)) == 12  # one scene of each split kind, none twice


def test_parts_of_a_split_never_overwrite_each_other_and_a_bad_scene_stops_nothing(tmp_path: Path) -> None:
    """train/0000.json and test/0000.json become urban-nav-2-train-0000 and -test-0000; a
    broken scene between them is one error line, exit 2, and every other scene is written."""
    splits = citygen.splits()
    scenes = []
    for part in ("train", "test"):
        split = f"urban-nav-2-{part}"
        path = tmp_path / "in" / "urban-nav-2" / part / "0000.json"
        save_scene(generate(splits[split].config, scene_seed(2025, split, 0), split=split, index=0), path)
        scenes.append(path)
    bad = tmp_path / "in" / "bad.json"
    bad.write_text('{"format": "citygen.scene/1"}')
    out = tmp_path / "out"
    proc = subprocess.run(
        [sys.executable, "-m", "citygen", "export", str(scenes[0]), str(bad), str(scenes[1]),
         "--format", "occupancy", "--out", str(out), "--resolution", "0.25"],
        capture_output=True, text=True,
    )  # fmt: skip
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr
    errors = [line for line in proc.stderr.splitlines() if ": error: " in line]
    assert len(errors) == 1 and errors[0].startswith(f"{bad}: error: ")
    assert proc.stderr.strip().splitlines()[-1].startswith("export: 1 of 3 scene(s) failed")
    for part in ("train", "test"):
        grid = np.load(out / f"urban-nav-2-{part}-0000.npz", allow_pickle=False)
        assert float(grid["resolution"]) == 0.25  # --resolution still sets the occupancy cell size


def test_a_scene_twice_in_one_batch_is_refused_not_written_over(tmp_path: Path) -> None:
    scene = ROOT / "examples" / "nav_static_10m.json"
    copy = tmp_path / "nav_static_10m.json"
    copy.write_bytes(scene.read_bytes())
    proc = subprocess.run(
        [sys.executable, "-m", "citygen", "export", str(scene), str(copy), "--format", "mjcf", "--out",
         str(tmp_path / "o")],
        capture_output=True, text=True,
    )  # fmt: skip
    assert proc.returncode == 2
    assert f"{copy}: error: its files would be named 'nav_static_10m', as those of {scene}" in proc.stderr
    assert (tmp_path / "o" / "nav_static_10m.xml").is_file()


def test_conflicting_occupancy_resolutions_are_one_line(tmp_path: Path) -> None:
    scene = ROOT / "examples" / "nav_static_10m.json"
    proc = subprocess.run(
        [sys.executable, "-m", "citygen", "export", str(scene), "--resolution", "0.1",
         "--occupancy-resolution", "0.2", "--out", str(tmp_path / "o")],
        capture_output=True, text=True,
    )  # fmt: skip
    assert proc.returncode == 2
    assert proc.stderr.strip().splitlines() == [
        "--resolution: the same as --occupancy-resolution, given both as 0.1 and 0.2; pass one"
    ]
    assert not (tmp_path / "o").exists()


def test_terrain_resolution_reaches_the_mesh_formats(tmp_path: Path) -> None:
    """--terrain-resolution sets the spacing of MJCF heightfields and of GLB rough-tile meshes."""
    scene = tmp_path / "rough.json"
    save_scene(citygen.generate("urban-loc-4-test", index=0), scene)  # 256 rough tiles
    sizes: dict[float, list[int]] = {1.0: [], 0.25: []}
    for res in sizes:
        for fmt, suffix in (("mjcf", ".xml"), ("glb", ".glb")):
            out = tmp_path / str(res)
            proc = subprocess.run(
                [sys.executable, "-m", "citygen", "export", str(scene), "--format", fmt,
                 "--terrain-resolution", str(res), "--out", str(out)],
                capture_output=True, text=True,
            )  # fmt: skip
            assert proc.returncode == 0, proc.stderr
            sizes[res].append((out / f"rough{suffix}").stat().st_size)
    assert all(fine > 4 * coarse for fine, coarse in zip(sizes[0.25], sizes[1.0], strict=True)), sizes
