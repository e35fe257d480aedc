"""Exports in the simulators people load them in: the sphere drop (``benchmarks/drop.py``).

About 100 spheres of 5 cm radius dropped from 1 m, 2 s with each simulator's default time
step, each sphere's bottom against ``citygen.height_at``: through the ground (more than 3 cm
below) and resting (within 3 cm), spheres over objects and agents left out. Target
(issue 49): 0 through and >= 95 % resting with each simulator's default loader, as
``docs/simulators/`` loads the scenes:

- MuJoCo: the MJCF (heightfields), and the MJCF with ``terrain="convex"``;
- PyBullet: the URDF, ``loadURDF(useFixedBase=True)``;
- SAPIEN 3 (CPU, no renderer): the URDF without visuals, ``create_urdf_loader()``;
- Genesis (CPU, ``--genesis``): ``gs.morphs.MJCF`` of the convex MJCF and
  ``gs.morphs.URDF(fixed=True)`` of the URDF without visuals, rough tiles within 2 cm, after
  docs/simulators/genesis.md's recipe run as written. Its first ``scene.build()`` compiles for
  about 15 minutes on 2 busy cores, and its memory grows with the square of a scene's geoms,
  so it is not in the default run.

Scenes: urban-nav-2-test scenes 3, 4 and 7 (stairs, slopes and rough ground, 15 m) and the
urban-tra-standard track (120 m x 10 m). ``--city``: urban-tra-city scene 0's URDF tiles (the
two at the scene's south-west corner, without visuals) in SAPIEN as static actors, spheres
over those tiles (generation and export take a few minutes).

SAPIEN installs with the dev extra; ``--genesis`` needs ``pip install genesis-world==1.4.5``
(about 8 minutes; it pins Pillow below 12). Run: ``python benchmarks/bench_simulators.py
[--genesis] [--city]``. Prints a table, then as
its last line a JSON object of the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shlex
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from benchmarks import drop
from citygen.exporters import ExportWarning, mjcf, urdf
from citygen.generate.splits import generate_split
from citygen.geometry.terrain import height_at
from citygen.io import load_scene
from citygen.spec.scene import Bounds

SCENES = {
    "nav-3": ("urban-nav-2-test", 3),
    "nav-4": ("urban-nav-2-test", 4),
    "nav-7": ("urban-nav-2-test", 7),
    "track": ("urban-tra-standard", 0),
}


#: The rough tiles' tolerance (m) of Genesis' files, as docs/simulators/genesis.md exports them.
GENESIS_TOLERANCE = 0.02


def _export(scene, out: Path, name: str, genesis: bool) -> dict[str, Path]:
    """The files each loader reads."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportWarning)
        files = {
            "mjcf": mjcf.export(scene, out / "hfield", name=name)[0],
            "convex": mjcf.export(scene, out / "convex", name=name, terrain="convex")[0],
            "urdf": urdf.export(scene, out / "urdf", name=name)[0],
            "novisual": urdf.export(scene, out / "novisual", name=name, visual=False)[0],
        }
        if genesis:
            tol = GENESIS_TOLERANCE
            files["genesis mjcf"] = mjcf.export(scene, out / "g", name=name, terrain="convex", tolerance=tol)[
                0
            ]
            files["genesis urdf"] = urdf.export(scene, out / "g", name=name, visual=False, tolerance=tol)[0]
        return files


def _loaders(genesis: bool) -> dict:
    out = {
        "mujoco mjcf": lambda f, p: drop.mujoco_drop(f["mjcf"], p),
        "mujoco mjcf convex": lambda f, p: drop.mujoco_drop(f["convex"], p),
        "pybullet urdf": lambda f, p: drop.pybullet_drop(f["urdf"], p),
        "sapien urdf": lambda f, p: drop.sapien_drop([f["novisual"]], p),
    }
    if genesis:
        out["genesis mjcf convex"] = lambda f, p: drop.genesis_drop([f["genesis mjcf"]], p)
        out["genesis urdf"] = lambda f, p: drop.genesis_drop([f["genesis urdf"]], p)
    return out


def _row(table: list, figures: dict, key: str, scene, points, run, files) -> None:
    start = time.perf_counter()
    try:
        score = drop.score(scene, points, run(files, points))
    except Exception as exc:  # a simulator missing or failing is a row, not the end
        table.append((key, f"{type(exc).__name__}: {exc}"[:70]))
        return
    seconds = time.perf_counter() - start
    table.append((key, score, seconds))
    slug = key.replace(" ", "_").replace("-", "_")
    figures[f"{slug}_through_pct"] = round(score["through_pct"], 1)
    figures[f"{slug}_resting_pct"] = round(score["resting_pct"], 1)
    figures[f"{slug}_s"] = round(seconds, 1)


def _city(table: list, figures: dict, folder: Path) -> None:
    """urban-tra-city's two south-west URDF tiles (without visuals) in SAPIEN, as static actors
    (its recipe for large scenes; a fixed articulation of 800 links steps too slowly)."""
    start = time.perf_counter()
    scene = generate_split("urban-tra-city", index=0)
    figures["city_generate_s"] = round(time.perf_counter() - start, 1)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ExportWarning)
        start = time.perf_counter()
        files = urdf.export(scene, folder / "city", name="city", visual=False)
        figures["city_urdf_export_s"] = round(time.perf_counter() - start, 1)
    for w in caught:
        if "convex pieces within" in str(w.message):
            figures["city_urdf_tolerance_cm"] = float(str(w.message).split("within ")[1].split(" cm")[0])
    index = json.loads(files[0].read_text())
    tiles = sorted(index["tiles"], key=lambda t: (t["row"], t["col"]))[:2]
    lo = np.min([t["min"] for t in tiles], axis=0)
    hi = np.max([t["max"] for t in tiles], axis=0)
    region = scene.model_copy(update={"bounds": Bounds(min=lo.tolist(), max=hi.tolist())})
    points = drop.drop_points(region, per_side=12, inset=1.0)
    paths = [folder / "city" / t["file"] for t in tiles]
    run = lambda f, p: drop.sapien_drop(paths, p, static=True)  # noqa: E731
    _row(table, figures, "city sapien urdf tiles static", scene, points, run, None)


ROBOT_URDF = """<?xml version="1.0"?>
<robot name="box"><link name="base">
  <inertial><mass value="5"/><inertia ixx="0.05" ixy="0" ixz="0" iyy="0.08" iyz="0" izz="0.1"/></inertial>
  <collision><geometry><box size="0.4 0.3 0.2"/></geometry></collision>
</link></robot>
"""


def genesis_recipe(folder: Path, figures: dict) -> None:
    """docs/simulators/genesis.md's recipe as written (its commands, then its Python lines with
    a box for a robot); the robot must end on the ground. Figures: its seconds, and whether."""
    page = (Path(__file__).resolve().parents[1] / "docs" / "simulators" / "genesis.md").read_text()
    shell = re.search(r"<!-- recipe-shell -->\n```bash\n(.*?)```", page, re.S).group(1)
    code = re.search(r"<!-- recipe -->\n```python\n(.*?)```", page, re.S).group(1)
    (folder / "robot.urdf").write_text(ROBOT_URDF)
    start = time.perf_counter()
    for line in shell.strip().splitlines():
        subprocess.run([sys.executable, "-m", "citygen", *shlex.split(line)[1:]], cwd=folder, check=True,
                       capture_output=True)  # fmt: skip
    here = os.getcwd()
    os.chdir(folder)
    try:
        namespace: dict = {}
        exec(compile(code, "genesis.md", "exec"), namespace)
        x, y, z = np.asarray(namespace["robot"].get_pos()).reshape(-1)[:3]
    finally:
        os.chdir(here)
    ground = float(height_at(load_scene(folder / "out/urban-nav-2/test/0003.json"), x, y))
    figures["genesis_recipe_s"] = round(time.perf_counter() - start, 1)
    figures["genesis_recipe_robot_on_ground"] = bool(ground + 0.05 < z < ground + 2.5)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--genesis", action="store_true", help="also Genesis (minutes to compile first)")
    parser.add_argument("--city", action="store_true", help="also urban-tra-city's URDF tiles")
    args = parser.parse_args()
    table: list = []
    figures: dict[str, float] = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        if args.genesis:  # first: the recipe calls gs.init itself
            (folder / "recipe").mkdir()
            genesis_recipe(folder / "recipe", figures)
        for label, (split, index) in SCENES.items():
            scene = generate_split(split, index=index)
            start = time.perf_counter()
            files = _export(scene, folder, label, args.genesis)
            figures[f"{label.replace('-', '_')}_export_s"] = round(time.perf_counter() - start, 1)
            points = drop.drop_points(scene)
            for key, run in _loaders(args.genesis).items():
                _row(table, figures, f"{label} {key}", scene, points, run, files)
        if args.city:
            _city(table, figures, folder)
    print(f"{'scene and loader':34} {'spheres':>7} {'through':>8} {'resting':>8} {'worst m':>8} {'s':>6}")
    for row in table:
        if len(row) == 2:
            print(f"{row[0]:34} {row[1]}")
            continue
        key, s, seconds = row
        print(f"{key:34} {s['spheres']:7d} {s['through_pct']:7.1f}% {s['resting_pct']:7.1f}% "
              f"{s['worst_m']:8.3f} {seconds:6.1f}")  # fmt: skip
    rows = [r for r in table if len(r) == 3]
    figures["drop_through_max_pct"] = max(r[1]["through_pct"] for r in rows)
    figures["drop_resting_min_pct"] = min(r[1]["resting_pct"] for r in rows)
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
