"""Navigation on learned legs against the ideal servo (issue 47): the shipped NavStatic
quadruped policy (``--policy ppo``) on urban-nav-2-test, the same episodes (episode ``i``:
scene ``i``, seed ``i``) walked by the quadruped's general locomotion model
(``locomotion="learned"``, :mod:`citygen.runner.envs.legs`) and by the servo, and, when one
ships, the policy fine-tuned on the legs (``--policy ppo --locomotion learned``) on them; the
URBAN-BENCH table of each, the fall rate on legs, and the navigation steps per CPU second of
each (policy inference included), with their ratio.

Until a general locomotion model ships (``baselines/loco-general-quadruped.npz``), the
shipped LocoFlat model stands in for it (``--stand-in``, the default when none ships): a copy
whose metadata says it was trained on the general split, in a temporary folder beside copies
of the shipped baselines.

``python benchmarks/bench_legs.py [--episodes 8]`` (about a minute a mode on a free core; the
issue's figures: ``--episodes 32``); the last line is one JSON object of figures.
"""

from __future__ import annotations

import argparse
import json
import shutil
import tempfile
import time
from pathlib import Path

import numpy as np

from citygen.runner.bench import run_bench, summary_json
from citygen.runner.learn import shipped_models
from citygen.runner.learn.export import write_policy
from citygen.runner.metrics import format_table

TASK, SPLIT, ROBOT = "nav-static", "urban-nav-2-test", "quadruped"


def stand_in(folder: Path) -> None:
    """Point :mod:`citygen.runner.learn.shipped_models` at ``folder``: the shipped baselines
    and the LocoFlat model as the quadruped's general locomotion model."""
    for path in shipped_models.BASELINES.glob("*.npz"):
        shutil.copy(path, folder / path.name)
    with np.load(shipped_models.BASELINES / "loco-flat-quadruped.npz") as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays.pop("meta")))
    meta["train"] = {**meta["train"], "split": shipped_models.GENERAL_LOCO_SPLIT}
    write_policy(folder / "loco-general-quadruped.npz", meta, arrays)
    shipped_models.BASELINES = folder


def measure(locomotion: str, episodes: int, tuned: bool = False) -> tuple[dict, float]:
    """The summary of ``episodes`` episodes on ``locomotion`` and their steps per CPU second:
    the servo's shipped policy, or with ``tuned`` the one fine-tuned on learned legs."""
    policy = str(shipped_models.baseline(TASK, ROBOT, "learned" if tuned else "servo"))
    start = time.process_time()
    rows = run_bench(
        TASK, SPLIT, robot=ROBOT, policy=policy, episodes=episodes, jobs=1, locomotion=locomotion
    )
    cpu = time.process_time() - start
    summary = summary_json(rows)["summary"]
    which = "the shipped policy fine-tuned on legs" if tuned else "shipped policy"
    title = f"{TASK} {ROBOT}, {which}, on {locomotion}: {episodes} episodes"
    print(format_table(summary, title), flush=True)
    return summary, sum(r["steps"] for r in rows) / cpu


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--episodes", type=int, default=8)
    parser.add_argument("--only", choices=("servo", "learned"), help="measure one mode (no ratios)")
    parser.add_argument("--stand-in", action=argparse.BooleanOptionalAction, default=None)
    args = parser.parse_args()
    use_stand_in = args.stand_in
    if use_stand_in is None:
        use_stand_in = ROBOT not in shipped_models._shipped_files()[1]
    modes = (args.only,) if args.only else ("servo", "learned")
    figures: dict = {"episodes": args.episodes, "stand_in_loco_flat": bool(use_stand_in)}
    with tempfile.TemporaryDirectory() as tmp:
        if use_stand_in:
            stand_in(Path(tmp))
        for mode in modes:
            summary, rate = measure(mode, args.episodes)
            name = "legs" if mode == "learned" else mode
            figures[f"{name}_success_pct"] = summary["success_rate"]["mean"]
            figures[f"{name}_success_sem"] = summary["success_rate"]["sem"]
            if mode == "learned":
                figures["legs_fall_pct"] = summary["fall_rate"]["mean"]
            figures[f"{name}_steps_per_cpu_s"] = rate
        if "learned" in modes and shipped_models.baseline(TASK, ROBOT, "learned") != shipped_models.baseline(
            TASK, ROBOT
        ):  # a file fine-tuned on the legs ships: what --policy ppo --locomotion learned runs
            summary, _ = measure("learned", args.episodes, tuned=True)
            figures["tuned_success_pct"] = summary["success_rate"]["mean"]
            figures["tuned_success_sem"] = summary["success_rate"]["sem"]
            figures["tuned_fall_pct"] = summary["fall_rate"]["mean"]
    if len(modes) == 2:
        figures["legs_over_servo_success"] = figures["legs_success_pct"] / max(
            figures["servo_success_pct"], 1e-9
        )
        if "tuned_success_pct" in figures:  # the bar: at least 0.9
            figures["tuned_over_servo_success"] = figures["tuned_success_pct"] / max(
                figures["servo_success_pct"], 1e-9
            )
        figures["legs_over_servo_speed"] = figures["legs_steps_per_cpu_s"] / figures["servo_steps_per_cpu_s"]
    print(
        ", ".join(f"{k} {v:.1f}" for k, v in figures.items() if k.endswith("steps_per_cpu_s")),
        "(steps per CPU s)",
    )
    print(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in figures.items()}))


if __name__ == "__main__":
    main()
