"""The URBAN-BENCH locomotion table: the shipped learned models and the scripted gaits of the
three legged robots on the four Urban-Loc test splits, beside the paper's figures.

Each cell is ``citygen bench --task T --robot R --policy P --episodes N`` (the paper's
metrics: Balance, X-displacement, TTF, Smoothness); ``P`` is ``ppo`` (the shipped model:
the terrain model of the task, else the robot's general model) and the scripted gait
(``trot``: the quadruped's and wheeled-legged robot's trot, the humanoid's scripted walk).
Cells are kept in ``benchmarks/results/loco_table.json`` keyed by the policy file's digest,
so a rerun measures only what changed; ``--readme`` rewrites the table in README.md between
its ``loco-table`` markers.

    python benchmarks/loco_table.py --episodes 256 --jobs 2 --readme
"""

from __future__ import annotations

import argparse
import hashlib
import json
import re
import time
from pathlib import Path

from citygen.io import write_atomic
from citygen.runner.bench import run_bench, summary_json
from citygen.runner.envs import DEFAULT_SPLIT
from citygen.runner.learn.policy import shipped

ROOT = Path(__file__).resolve().parents[1]
RESULTS = ROOT / "benchmarks" / "results" / "loco_table.json"
TASKS = ("loco-flat", "loco-slope", "loco-stair", "loco-rough")
ROBOTS = ("quadruped", "wheeled_legged", "humanoid")
#: The paper's locomotion table (Table "Urban Locomotion benchmark"): per robot and task,
#: (balance %, its sem), (X-displacement m, sem), (TTF s, sem), (smoothness, sem).
PAPER = {
    "quadruped": {
        "loco-flat": ((100.00, 0.00), (19.58, 0.41), (20.00, 0.00), (7.85, 0.04)),
        "loco-slope": ((90.56, 3.13), (4.63, 0.23), (19.50, 0.44), (5.18, 0.07)),
        "loco-stair": ((91.89, 2.07), (9.20, 0.36), (19.58, 0.39), (8.11, 0.12)),
        "loco-rough": ((72.18, 4.76), (4.88, 0.14), (18.31, 0.25), (10.02, 0.09)),
    },
    "wheeled_legged": {
        "loco-flat": ((100.00, 0.00), (19.62, 0.15), (20.00, 0.00), (210.43, 0.07)),
        "loco-slope": ((95.57, 3.31), (12.54, 0.34), (19.95, 0.02), (253.24, 0.28)),
        "loco-stair": ((83.01, 2.37), (16.73, 0.27), (19.07, 0.17), (236.52, 0.18)),
        "loco-rough": ((85.04, 2.16), (18.24, 0.22), (19.13, 0.11), (231.96, 0.14)),
    },
    "humanoid": {
        "loco-flat": ((100.00, 0.00), (16.61, 0.50), (20.00, 0.00), (40.94, 0.15)),
        "loco-slope": ((95.67, 2.24), (7.16, 0.22), (19.91, 0.03), (57.69, 0.31)),
        "loco-stair": ((80.98, 4.32), (13.99, 0.27), (19.03, 0.36), (42.36, 0.19)),
        "loco-rough": ((82.45, 3.15), (16.28, 0.31), (19.02, 0.33), (53.67, 0.24)),
    },
}
METRICS = ("balance", "x_displacement", "ttf", "smoothness")
NAMES = {"quadruped": "Quadruped", "wheeled_legged": "Wheeled-legged", "humanoid": "Humanoid"}
MARK = ("<!-- loco-table: made by benchmarks/loco_table.py -->", "<!-- /loco-table -->")
#: The physics a task's cells were measured on, where it changed since the first table: a
#: cell measured on other physics is measured again (docs/runner.md, "Terrain under feet").
PHYSICS = {
    "loco-slope": "slope tiles as convex prisms (4f6860a)",
    "loco-rough": "rough heightfields at solref 0.01 s (05b88de)",
}

#: What the episodes give a learned policy, where it changed since the first table: a learned
#: cell measured otherwise is measured again. The scripted gaits copy the command at the
#: start and are not affected.
PROTOCOL = " with heading control (citygen.runner.envs.loco.HEADING_STIFFNESS)"


def _digest(robot: str, task: str, policy: str, file: Path | None = None) -> str:
    """What a cell's figures depend on: the policy file's bytes (``file``, else the shipped
    model of the task), or the scripted gait's name, the task's physics where it changed
    (:data:`PHYSICS`) and, for a learned policy, the protocol (:data:`PROTOCOL`)."""
    physics = f" on {PHYSICS[task]}" if task in PHYSICS else ""
    if policy != "ppo":
        return policy + physics
    path = file or shipped().get((task, robot))
    return hashlib.sha256(path.read_bytes()).hexdigest()[:16] + physics + PROTOCOL if path else ""


def measure(robot: str, task: str, policy: str, episodes: int, jobs: int, file: Path | None = None) -> dict:
    """One cell: the summary of ``episodes`` test episodes of ``task``'s test split. ``file``
    is the learned model to run (for ``policy == "ppo"``; default the task's shipped model):
    benchmarks/loco_cross.py runs each terrain's model on every terrain with it."""
    start = time.perf_counter()
    shown = (str(file.relative_to(ROOT)) if file.is_relative_to(ROOT) else str(file)) if file else policy
    file = file or (shipped().get((task, robot)) if policy == "ppo" else None)
    name = str(file) if file else policy
    rows = run_bench(task, DEFAULT_SPLIT[task], robot=robot, policy=name, episodes=episodes, jobs=jobs)
    doc = summary_json(rows, task=task, robot=robot, policy=policy)
    summary = {k: doc["summary"][k] for k in METRICS}
    return {
        "summary": summary, "episodes": episodes, "seconds": round(time.perf_counter() - start, 1),
        "digest": _digest(robot, task, policy, file), "file": file.name if file else None,
        "command": f"citygen bench --task {task} --robot {robot} --policy {shown} --episodes {episodes}",
    }  # fmt: skip


def _cell(entry: dict | None, missing: str = "not trained") -> str:
    if entry is None:
        return missing
    s = entry["summary"]
    return (
        f"{s['balance']['mean']:.2f} ± {s['balance']['sem']:.2f} / {s['x_displacement']['mean']:.2f} ± "
        f"{s['x_displacement']['sem']:.2f}"
    )


def _paper(robot: str, task: str) -> str:
    (b, bs), (x, xs), _, _ = PAPER[robot][task]
    return f"{b:.2f} ± {bs:.2f} / {x:.2f} ± {xs:.2f}"


def _meets(robot: str, task: str, entry: dict | None) -> bool:
    """The issue's bar: balance at least the paper's minus one of its standard errors and
    X-displacement at least 90 % of the paper's."""
    if entry is None:
        return False
    (b, bs), (x, _), _, _ = PAPER[robot][task]
    s = entry["summary"]
    return s["balance"]["mean"] >= b - bs and s["x_displacement"]["mean"] >= 0.9 * x


def table(results: dict) -> str:
    """The README's markdown table: Balance % / X-displacement m per robot and task, learned,
    scripted and the paper's, with the models' files."""
    head = "| robot | policy | " + " | ".join("Loco" + t.removeprefix("loco-").title() for t in TASKS)
    lines = [head + " |", "|---|---|" + "---|" * len(TASKS)]
    for robot in ROBOTS:
        learned = [results.get(f"{robot}/{t}/ppo") for t in TASKS]
        cells = [
            (f"**{_cell(e)}**" if _meets(robot, t, e) else _cell(e))
            for t, e in zip(TASKS, learned, strict=True)
        ]
        lines.append(f"| {NAMES[robot]} | learned (`--policy ppo`) | " + " | ".join(cells) + " |")
        scripted = [_cell(results.get(f"{robot}/{t}/trot"), "not measured") for t in TASKS]
        lines.append("| | scripted (`--policy trot`) | " + " | ".join(scripted) + " |")
        lines.append("| | paper | " + " | ".join(_paper(robot, t) for t in TASKS) + " |")
    return "\n".join(lines)


def _save(key: str, entry: dict) -> dict:
    """Write one cell into the results file as it is now (other runs of this script may have
    written cells since this one read it); the file's cells, this one's included."""
    results = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    results[key] = entry
    RESULTS.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(RESULTS, (json.dumps(results, indent=1, sort_keys=True) + "\n").encode())
    return results


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--episodes", type=int, default=256)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--robots", nargs="*", default=list(ROBOTS), choices=list(ROBOTS))
    ap.add_argument("--tasks", nargs="*", default=list(TASKS), choices=list(TASKS))
    ap.add_argument("--policies", nargs="*", default=["ppo", "trot"], choices=["ppo", "trot"])
    ap.add_argument("--force", action="store_true", help="measure again cells whose inputs did not change")
    ap.add_argument("--readme", action="store_true", help="rewrite README.md's locomotion table")
    args = ap.parse_args()
    results = json.loads(RESULTS.read_text()) if RESULTS.exists() else {}
    have = shipped()
    for robot in args.robots:
        for task in args.tasks:
            for policy in args.policies:
                key = f"{robot}/{task}/{policy}"
                if policy == "ppo" and (task, robot) not in have:
                    results.pop(key, None)
                    continue
                old = results.get(key) or {}
                want = (_digest(robot, task, policy), args.episodes)
                fresh = (old.get("digest"), old.get("episodes")) == want
                if fresh and not args.force:
                    continue
                results[key] = measure(robot, task, policy, args.episodes, args.jobs)
                print(key, _cell(results[key]), f"({results[key]['seconds']} s)", flush=True)
                results = _save(key, results[key])
    text = table(results)
    print(text)
    if args.readme:
        readme = ROOT / "README.md"
        body = readme.read_text()
        pattern = re.compile(re.escape(MARK[0]) + ".*?" + re.escape(MARK[1]), re.S)
        if not pattern.search(body):
            raise SystemExit(f"README.md: no {MARK[0]} ... {MARK[1]} markers to write the table between")
        readme.write_text(pattern.sub(lambda _: f"{MARK[0]}\n{text}\n{MARK[1]}", body))


if __name__ == "__main__":
    main()
