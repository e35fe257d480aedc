"""``--executor ray``: the same scenes, byte for byte, as the local process pool.

Ray runs in subprocesses (a local Ray of 2 CPUs, no dashboard), each with a timeout, so a
Ray that hangs fails the test instead of the suite. These tests need the ``ray`` package
(``pip install -e ".[scale]"``); without it they fail with that instruction, never skip.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

from citygen.generate.dataset import INDEX_NAME, sha256, write_dataset, write_scenes
from citygen.generate.splits import resolve
from tests.conftest import ROOT

MANIFEST = """\
format = "citygen.splits/1"

[[splits]]
name = "tiny-1-train"
scenes = 10
seed = 5
config.placement.count = 0
config.agents.people = 0
config.task.kind = "nav-clear"

[[splits]]
name = "tiny-3-test"
scenes = 6
seed = 6
config.size = [15.0, 15.0]
config.task.kind = "nav-dynamic"

[[splits]]
name = "tiny-tra"
scenes = 2
seed = 1
config.size = [60.0, 10.0]
config.layout = "track"
config.track.units = [
  { setting = "dynamic" },
  { surface = "uneven", setting = "static" },
  { surface = "uneven" },
]
config.track.route_length = 300.0
config.task.kind = "traverse"
"""

# In a fresh interpreter: a local Ray, the dataset through the Ray executor (recording how
# many scenes each task returned), a resumed run after damage, and a failing split.
SCRIPT = """
import json, logging, sys
from pathlib import Path
try:
    import ray
except ImportError:
    sys.exit("ray is not installed: pip install -e '.[scale]' (or .ci/run's test extras)")
from citygen.errors import CitygenError
from citygen.generate.dataset import write_dataset, write_scenes
from citygen.generate.splits import resolve

manifest, out, bad = sys.argv[1:4]
quiet = {"log_to_driver": False, "logging_level": logging.WARNING}
ray.init(address="local", num_cpus=2, include_dashboard=False, **quiet)
report = {}
tasks = []
write_dataset(out, manifest=manifest, executor="ray", on_progress=tasks.append)
report["tasks"] = tasks
Path(out, "tiny-1/train/0003.json").unlink()
victim = Path(out, "tiny-3/test/0002.json")
victim.write_bytes(victim.read_bytes()[:-10])
again = write_dataset(out, manifest=manifest, executor="ray", resume=True)
report["remade"] = sorted(w.path for w in again if not w.skipped)
try:
    write_scenes(resolve(bad), str(Path(out, "bad")), executor="ray")
except CitygenError as exc:
    report["error"] = str(exc)
report["still_initialized"] = ray.is_initialized()
print(json.dumps(report))
"""


def _digests(folder: Path) -> dict[str, str]:
    return {p.relative_to(folder).as_posix(): sha256(p.read_bytes()) for p in sorted(folder.rglob("*.json"))}


def _env() -> dict[str, str]:
    env = {k: v for k, v in os.environ.items() if k != "RAY_ADDRESS"}
    return {**env, "RAY_DISABLE_USAGE_STATS": "1"}


def test_ray_writes_the_bytes_of_the_local_pool_and_resumes(tmp_path):
    manifest = tmp_path / "tiny.toml"
    manifest.write_text(MANIFEST)
    bad = tmp_path / "impossible.toml"  # a goal 30 m away in a 10 m square
    bad.write_text("[task]\nmin_distance = 30.0\n")
    local = tmp_path / "local"
    write_dataset(local, manifest=manifest, jobs=2)
    out = tmp_path / "ray"
    proc = subprocess.run(
        [sys.executable, "-c", SCRIPT, str(manifest), str(out), str(bad)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=_env(),
        timeout=240,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    report = json.loads(proc.stdout.strip().splitlines()[-1])
    # Many scenes per task: 18 scenes on 2 CPUs in chunks of up to 3 (about 4 chunks per CPU).
    assert sum(report["tasks"]) == 18 and max(report["tasks"]) > 1 and len(report["tasks"]) < 18
    ray_files = {k: v for k, v in _digests(out).items() if not k.startswith("bad/")}
    assert ray_files == _digests(local)
    assert (out / INDEX_NAME).read_bytes() == (local / INDEX_NAME).read_bytes()
    assert report["remade"] == ["tiny-1/train/0003.json", "tiny-3/test/0002.json"]
    assert report["error"].startswith("impossible/0000.json: generation failed in stage 'task'")
    assert "\n" not in report["error"] and not list((out / "bad").rglob("*.json"))
    assert report["still_initialized"]  # a Ray the caller started is left running


def test_the_generate_command_on_ray_writes_what_the_pool_writes(tmp_path):
    out = tmp_path / "ray"
    args = ["generate", "--split", "urban-nav-3", "-n", "5", "--seed", "9", "--out", str(out)]
    proc = subprocess.run(
        [sys.executable, "-m", "citygen", *args, "--executor", "ray", "--jobs", "2"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        env=_env(),
        timeout=240,
    )
    assert proc.returncode == 0, proc.stderr[-3000:]
    assert f"wrote 5 scenes to {out}/urban-nav-3/test/" in proc.stdout
    local = tmp_path / "local"
    write_scenes(resolve("urban-nav-3", seed=9), local, count=5, jobs=2)
    assert _digests(out) == _digests(local) and len(_digests(local)) == 10
