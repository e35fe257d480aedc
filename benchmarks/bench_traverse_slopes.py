"""Human-AI-Mode-1's terrain dispatch against Mode-2's general legs (issue 47), on two
stretches of urban-tra-standard's slopes beyond its first stairs (docs/training.md, "The
paper's four modes, on learned legs"): the track's traverse cut to
each stretch (as ``tests/test_traverse.py`` cuts its stretches), the quadruped on learned
legs, one episode of each mode (seed 0): the paper's traverse metrics, the falls and the time
on a terrain model (Mode-1 walks a slope ahead on the slope model that follows navigation,
``loco-slope-quadruped-nav.npz``; Mode-2 on the general model).

``python benchmarks/bench_traverse_slopes.py [--seconds 60]`` (13 s on a free core on
2026-12-01, when the stretches end early; at most about two minutes); the last line is one
JSON object of figures.
"""

from __future__ import annotations

import argparse
import json
import math
import time

import citygen
from citygen.runner.bench import run_episode
from citygen.runner.make import make_env
from citygen.runner.policies import make_policy
from citygen.spec.blocks import Pose2

#: Stretch name -> (start, waypoints): up the slopes of the outward lane from x = 86 m, and
#: along the slopes of the lane back from x = 117 m.
STRETCHES = {
    "out": ((86.0, 2.5), [(94.5, 2.5), (97.0, 2.5)]),
    "back": ((117.0, 7.5), [(108.0, 7.5), (101.0, 7.5)]),
}
MODES = ("human-ai-mode-1", "human-ai-mode-2")
KEYS = ("route_completion", "attempts", "falls", "terrain_model_time", "labor_cost", "mcot", "speed")


def stretch(track, start: tuple[float, float], route: list[tuple[float, float]], seconds: float):
    """``track`` with its traverse cut to ``route`` from ``start`` (facing the route)."""
    yaw = math.atan2(route[0][1] - start[1], route[0][0] - start[0])
    update = {"start": Pose2(position=start, yaw=yaw), "route": tuple(route), "time_limit": seconds}
    return track.model_copy(update={"task": track.task.model_copy(update=update)})


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seconds", type=float, default=60.0, help="time limit of each stretch (s)")
    args = parser.parse_args()
    track = citygen.generate("urban-tra-standard", index=0)
    figures: dict[str, float] = {}
    print(f"{'stretch':<8} {'mode':<16} " + " ".join(f"{k:>18}" for k in KEYS) + "  wall (s)")
    for name, (start, route) in STRETCHES.items():
        for mode in MODES:
            env = make_env("traverse", stretch(track, start, route, args.seconds), robot="quadruped",
                           locomotion="learned")  # fmt: skip
            t = time.perf_counter()
            row = run_episode(env, make_policy(mode, task="traverse"), seed=0)
            wall = time.perf_counter() - t
            print(f"{name:<8} {mode:<16} " + " ".join(f"{row[k]:>18.2f}" for k in KEYS) + f"  {wall:8.0f}")
            tag = f"{name}_{mode.removeprefix('human-ai-').replace('-', '')}"
            figures[f"{tag}_falls"] = row["falls"]
            figures[f"{tag}_attempts"] = row["attempts"]
            figures[f"{tag}_terrain_model_s"] = row["terrain_model_time"]
            figures[f"{tag}_route_completion_pct"] = row["route_completion"]
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
