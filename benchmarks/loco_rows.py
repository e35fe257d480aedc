"""A locomotion policy's Balance and X-displacement per row of a task's Urban-Loc test grid
(rows rise in difficulty: LocoStair's risers from 0.10 to 0.30 m), where ``citygen bench``
gives one mean over the whole grid: which riser height, slope or roughness a model stops at.

    python benchmarks/loco_rows.py --task loco-stair --robot quadruped --policy FILE [--cols 4] [--every 2]

Episode ``(row, k)`` starts in region ``(row, k * 16 // cols + k % 2)`` with seed
``row * 16 + k`` under the task's own command (1 m/s ahead, heading held); the last line is
one JSON object of the rows' figures. The columns alternate in kind (the grids' even columns
are pyramids, whose episodes start on the top and go down; the odd ones pits, climbed out
of), so that every row's figure holds both: before 2026-12-02 the columns were ``k * 16 //
cols``, all even, and these figures were of descents only.
"""

from __future__ import annotations

import argparse
import json

import numpy as np

from citygen.runner.envs import DEFAULT_SPLIT
from citygen.runner.make import make_env
from citygen.runner.policies import make_policy


def row_figures(task: str, robot: str, policy: str, cols: int, every: int) -> list[dict]:
    env = make_env(task, split=DEFAULT_SPLIT[task], robot=robot)
    grid = env.unwrapped.source.scene(0).terrain
    out = []
    try:
        for row in range(0, grid.rows, every):
            balance, x = [], []
            for k in range(cols):
                seed = row * grid.cols + k
                pol = make_policy(policy, seed=seed, task=task)
                col = min(k * grid.cols // cols + k % 2, grid.cols - 1)
                obs, info = env.reset(seed=seed, options={"region": (row, col)})
                pol.reset(env.unwrapped)
                while True:
                    obs, _, terminated, truncated, info = env.step(pol.act(obs))
                    if terminated or truncated:
                        break
                balance.append(info["metrics"]["balance"])
                x.append(info["metrics"]["x_displacement"])
            out.append({"row": row, "balance": float(np.mean(balance)), "x_displacement": float(np.mean(x))})
            fig = out[-1]
            print(
                f"row {row:2d}: balance {fig['balance']:5.1f} %, X {fig['x_displacement']:5.2f} m", flush=True
            )
    finally:
        env.close()
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--task", default="loco-stair")
    p.add_argument("--robot", default="quadruped")
    p.add_argument("--policy", required=True, help="a locomotion policy file, or ppo")
    p.add_argument("--cols", type=int, default=4, help="episodes per row")
    p.add_argument("--every", type=int, default=2, help="every how many rows")
    a = p.parse_args()
    policy = a.policy
    if policy == "ppo":
        from citygen.runner.learn.shipped_models import baseline

        policy = str(baseline(a.task, a.robot))
    rows = row_figures(a.task, a.robot, policy, a.cols, a.every)
    print(json.dumps({"task": a.task, "robot": a.robot, "policy": a.policy, "rows": rows}))


if __name__ == "__main__":
    main()
