"""Locomotion models under navigation's changing commands (issue 47): how often a quadruped's
model falls or sits down, and how much of the commanded speed it makes good, when its command
changes every second as a navigation policy's does (every 0.1 s, between a hard turn, a step
back and a straight walk), on the easier rows of a locomotion task's test grid (the traverse's
slopes are grades of 0.2-0.34; LocoSlope's test rows go to 0.8).

``python benchmarks/loco_switching.py FILE [FILE ...] [--task loco-slope] [--episodes 63]
[--rows 0.45] [--period 1.0]``: each episode starts on a random tile of the first ``--rows``
share of the grid's rows, facing any way, and runs 20 s (the task's horizon) or to a fall; its
command is drawn from :data:`COMMANDS` every ``--period`` s. A sit is the base lower than 0.2 m
over the ground under it for 2 s (the quadruped stands at 0.30). Progress is the mean over
steps of the share of the commanded speed made good along the command (clipped to [-1, 1]).
The same seed draws the same tiles, headings and commands for every file. The last line is one
JSON object of figures.
"""

from __future__ import annotations

import argparse
import json
import math

import numpy as np

#: Commands drawn (forward m/s, sideways m/s, yaw rate rad/s): what the navigation models ask on
#: the traverse's slopes (a turn with way on, a step back, a straight walk, a turn in place).
COMMANDS = ((1.0, 0.0, -1.0), (-0.5, 0.0, 0.0), (1.0, 0.0, 0.2), (0.5, 0.0, 1.0), (1.0, 0.0, 0.0),
            (0.0, 0.0, -1.0), (1.0, 0.0, -0.3))  # fmt: skip
#: Base height (m) over the ground below which the robot counts as sitting, and for how long (s).
SIT = (0.2, 2.0)


def run(path: str, task: str, episodes: int, rows: float, period: float, seed: int = 0) -> dict:
    """Falls, sits and progress of the model in ``path`` (see the module docstring)."""
    from citygen.runner.learn.policy import load_policy
    from citygen.runner.make import make_env

    policy = load_policy(path)
    env = make_env(task, robot=policy.meta["robot"])
    rng = np.random.default_rng(seed)
    falls = sits = 0
    progress = []
    grid = env.unwrapped.source.scene(0).terrain  # every Urban-Loc split is one scene
    try:
        for ep in range(episodes):
            region = (int(rng.integers(max(1, int(grid.rows * rows)))), int(rng.integers(grid.cols)))
            first = COMMANDS[ep % len(COMMANDS)]
            obs, _ = env.reset(seed=int(rng.integers(1 << 30)), options={"command": first, "region": region})
            u = env.unwrapped
            h = u.handle
            every = max(1, round(period / u.dt))
            low, sat, made, steps = 0, False, 0.0, 0
            info: dict = {}
            for k in range(u.horizon):
                if k and k % every == 0:
                    c = COMMANDS[int(rng.integers(len(COMMANDS)))]
                    u.command[:] = c
                    u.held_heading = None
                    obs = {**obs, "command": np.asarray(c, dtype=np.float32)}
                obs, _, end, cut, info = env.step(policy.act(obs))
                steps += 1
                x, y, z = u.data.qpos[h.qadr : h.qadr + 3].tolist()
                vx, vy, _, _ = u.base_velocity
                c0, c1, _ = u.command.tolist()
                asked = c0 * c0 + c1 * c1
                if asked > 0.01:
                    made += min(max((vx * c0 + vy * c1) / asked, -1.0), 1.0)
                low = low + 1 if z - u.prepared.ground_at(x, y) < SIT[0] else 0
                sat = sat or low * u.dt >= SIT[1]
                if end or cut:
                    break
            falls += bool(info.get("fallen"))
            sits += sat
            progress.append(made / steps)
    finally:
        env.close()
    return {"falls": 100.0 * falls / episodes, "sits": 100.0 * sits / episodes,
            "progress": float(np.mean(progress)), "episodes": episodes}  # fmt: skip


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("files", nargs="+", help="locomotion model files (.npz or checkpoint .zip)")
    parser.add_argument("--task", default="loco-slope", help="locomotion task whose test grid is walked")
    parser.add_argument("--episodes", type=int, default=63)
    parser.add_argument("--rows", type=float, default=0.45, help="share of the grid's rows, easiest first")
    parser.add_argument("--period", type=float, default=1.0, help="seconds between command changes")
    args = parser.parse_args(argv)
    rows = []
    print(f"{'file':<48} {'falls %':>8} {'sits %':>8} {'progress':>9}")
    for path in args.files:
        row = run(path, args.task, args.episodes, args.rows, args.period)
        rows.append({"file": path, **row})
        line = f"{path[-48:]:<48} {row['falls']:>8.1f} {row['sits']:>8.1f} {row['progress']:>9.2f}"
        print(line, flush=True)
    for r in rows:  # the binomial standard error of the fall rate
        r["falls_se"] = math.sqrt(r["falls"] * (100 - r["falls"]) / r["episodes"])
    print(json.dumps({"task": args.task, "rows": args.rows, "period": args.period, "models": rows}))


if __name__ == "__main__":
    main()
