"""Navigation failures against where the goal starts: each episode of ``citygen bench -o``
documents binned by the goal's bearing at the start (degrees off the robot's heading, 0 ahead,
180 behind), with each bin's episodes and failures (success below 50 %).

A learned navigator that sees a 6.4 m local map and the goal's direction fails more where
the goal starts behind it than the planner, which plans on the whole scene. On the wheeled
NavClear validation split (1,024 episodes):

    citygen bench --task nav-clear --robot wheeled --split examples/splits/urban-nav-1-val.toml \\
        --policy ppo --episodes 1024 -o shipped.json    # and --policy planner -o planner.json
    python benchmarks/nav_bearing.py shipped.json planner.json

The bearings come from resetting the task's environment with each episode's seed and scene,
as the benchmark did (``citygen.runner.bench.run_episode``), and reading the ``goal``
observation (the robot's frame). Every document must be of the same task, split and seed.
Last line: JSON, per file its bins.
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path

EDGES = (0.0, 45.0, 90.0, 135.0, 180.0)


def bearings(task: str, split: str, robot: str, seed: int, n: int) -> list[float]:
    """The goal's bearing (degrees, 0-180) at the start of episodes 0 .. ``n - 1``."""
    from citygen.runner.make import make_env

    env = make_env(task, split=split, robot=robot)
    out = []
    for i in range(n):
        obs, _ = env.reset(seed=seed + i, options={"index": i})
        x, y = (float(v) for v in obs["goal"][:2])
        out.append(abs(math.degrees(math.atan2(y, x))))
    env.close()
    return out


def bins(bearing: Sequence[float], success: Sequence[float]) -> list[dict]:
    """Episodes and failures per bearing bin of :data:`EDGES` (the last bin holds 180)."""
    rows = []
    for k, (lo, hi) in enumerate(itertools.pairwise(EDGES)):
        last = k == len(EDGES) - 2
        inside = [s for b, s in zip(bearing, success, strict=True) if lo <= b < hi or (last and b == hi)]
        failures = sum(1 for s in inside if s < 50.0)
        rows.append({"from": lo, "to": hi, "episodes": len(inside), "failures": failures})
    return rows


def main(argv: Sequence[str] | None = None) -> dict:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("results", nargs="+", type=Path, help="`citygen bench -o` JSON documents")
    args = ap.parse_args(argv)
    docs = {}
    for path in args.results:
        try:
            docs[path] = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            sys.exit(f"{path}: expected a JSON document of `citygen bench -o` ({exc})")
    first = next(iter(docs.values()))
    key = ("task", "split", "robot", "seed")
    for path, doc in docs.items():
        if any(k not in doc for k in (*key, "rows")):
            sys.exit(f"{path}: expected a `citygen bench -o` document (task, split, robot, seed, rows)")
        if tuple(doc[k] for k in key) != tuple(first[k] for k in key):
            sys.exit(f"{path}: another task, split, robot or seed than {next(iter(docs))}")
    n = max(len(d["rows"]) for d in docs.values())
    bearing = bearings(first["task"], first["split"], first["robot"], first["seed"], n)
    out = {}
    for path, doc in docs.items():
        success = [float(r["success_rate"]) for r in sorted(doc["rows"], key=lambda r: r["index"])]
        out[str(path)] = rows = bins(bearing[: len(success)], success)
        share = sum(success) / len(success)
        print(f"{path}: {len(success)} episodes, success {share:.2f} %")
        for r in rows:
            rate = 100.0 * r["failures"] / r["episodes"] if r["episodes"] else float("nan")
            print(
                f"  goal {r['from']:3.0f}-{r['to']:3.0f} degrees off the heading: {r['episodes']:4d} "
                f"episodes, {r['failures']:3d} failures ({rate:.1f} %)"
            )
    print(json.dumps(out))
    return out


if __name__ == "__main__":
    main()
