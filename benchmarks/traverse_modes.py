"""The paper's traverse table (issue 47): urban-tra-standard's whole track, the quadruped on
learned legs, one episode (seed 0) of each of the four control modes (Human, Human-AI-Mode-1,
Human-AI-Mode-2, AI; docs/training.md, "The paper's four modes, on learned legs"), the
paper's metrics beside its figures, and the legs' own (falls, time on a terrain model, route
completion).

``python benchmarks/traverse_modes.py [--jobs 2] [--modes human ai]``: each mode is one
``citygen bench --task traverse --split urban-tra-standard --robot quadruped --locomotion
learned --policy MODE --episodes 1`` (the same figures), run in ``--jobs`` processes (a mode
takes 2-4 minutes on a free core). The table is printed and the last line is one JSON object
of figures.
"""

from __future__ import annotations

import argparse
import json
import time
from concurrent.futures import ProcessPoolExecutor

MODES = ("human", "human-ai-mode-1", "human-ai-mode-2", "ai")
#: The paper's traverse table (urban-tra-standard, its quadruped): metric -> per mode.
PAPER = {
    "attempts": (4, 27, 58, 66),
    "labor_cost": (1189.27, 189.52, 187.52, 0.0),
    "interventions": (14, 67, 32, 0),
    "mcot": (0.65, 0.76, 1.03, 0.99),
    "speed": (0.76, 0.96, 1.01, 0.98),
    "collision_times": (15, 20, 32, 49),
}
ROWS = {
    "attempts": "Trials to Success (Attempts)",
    "labor_cost": "Labor Cost (s)",
    "interventions": "Human Intervention Times",
    "mcot": "MCoT",
    "speed": "Speed (m/s)",
    "collision_times": "Collision Times",
    "falls": "Falls",
    "terrain_model_time": "Terrain Model Time (s)",
    "time": "Time (s)",
    "route_completion": "Route Completion (%)",
}


def run_mode(mode: str) -> tuple[dict, float]:
    """One episode of ``mode`` on the whole track; its metrics and wall time (s)."""
    from citygen.runner.bench import run_episode
    from citygen.runner.make import make_env
    from citygen.runner.policies import make_policy

    env = make_env("traverse", split="urban-tra-standard", robot="quadruped", locomotion="learned")
    t = time.perf_counter()
    row = run_episode(env, make_policy(mode, task="traverse"), seed=0, index=0)
    return row, time.perf_counter() - t


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--jobs", type=int, default=2, help="modes run at once (processes)")
    parser.add_argument("--modes", nargs="+", choices=MODES, default=list(MODES))
    args = parser.parse_args()
    with ProcessPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = {mode: pool.submit(run_mode, mode) for mode in args.modes}
        rows = {mode: future.result() for mode, future in futures.items()}
    print("| metric | " + " | ".join(f"{m} (paper / citygen)" for m in args.modes) + " |")
    print("|---|" + "---|" * len(args.modes))
    for key, label in ROWS.items():
        cells = []
        for mode in args.modes:
            ours = rows[mode][0][key]
            paper = PAPER[key][MODES.index(mode)] if key in PAPER else "-"
            cells.append(f"{paper} / {ours:,.2f}")
        print(f"| {label} | " + " | ".join(cells) + " |")
    print("| wall time (s) | " + " | ".join(f"{rows[m][1]:.0f}" for m in args.modes) + " |")
    figures = {f"{m.replace('-', '_')}_{k}": rows[m][0][k] for m in args.modes for k in ROWS}
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
