"""The runner's speed, as ratios against baselines measured in the same run.

1. NavStatic environment steps per second with the state and height-map observations, on
   one core (one environment) and on both cores (an asynchronous vector environment of two,
   each sub-environment on its own scene), next to the raw ``mj_step`` rate of the same
   compiled model: *runner cost over physics cost* is the time of one environment step over
   the time of the ``mj_step`` calls it contains (the physics floor).
2. The same with a 64 x 64 depth camera (MuJoCo's offscreen renderer).
3. MetaDrive's headless steps per second where it is installed (``benchmarks/
   metadrive_baseline.py``; set ``CITYGEN_METADRIVE_PYTHON`` to an interpreter that has it).
4. ORCA: citygen's vectorised ORCA against the reference RVO2 library (``pyrvo``) at 100
   agents, cost per agent-step (``benchmarks/bench_orca.py``).

``python benchmarks/bench_runner.py [--steps 600]``; the last line is one JSON object of figures.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
os.environ.setdefault("MUJOCO_GL", "egl")


def _env(**kwargs):
    from citygen.runner.bench import make_env

    return make_env("nav-static", split="urban-nav-2-test", **kwargs)


def env_rate(steps: int, **kwargs) -> dict:
    """Steps/s of one NavStatic environment driven by random actions (resets included)."""
    env = _env(**kwargs)
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    actions = rng.uniform(-1, 1, (steps, 2)).astype(np.float32)
    for k in range(20):  # warm-up: the scene cache, the renderer
        _, _, term, trunc, _ = env.step(actions[k])
        if term or trunc:
            env.reset()
    t0, c0 = time.perf_counter(), time.process_time()
    resets = 0
    for a in actions:
        _, _, term, trunc, _ = env.step(a)
        if term or trunc:
            env.reset()
            resets += 1
    wall, cpu = time.perf_counter() - t0, time.process_time() - c0
    out = {"steps_per_s": steps / wall, "cpu_steps_per_s": steps / cpu, "resets": resets,
           "substeps": env.unwrapped._substeps, "model": env.unwrapped.model}  # fmt: skip
    env.close()
    return out


def mj_rate(model, steps: int = 4000) -> float:
    """Raw ``mj_step`` calls per second of ``model`` (the robot at rest at its start)."""
    import mujoco

    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for _ in range(200):
        mujoco.mj_step(model, data)
    t0 = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return steps / (time.perf_counter() - t0)


def vector_rate(steps: int, num_envs: int = 2) -> float:
    """Total steps/s of an asynchronous vector env of ``num_envs`` NavStatic environments."""
    from citygen.runner.bench import make_vector_env

    venv = make_vector_env("nav-static", split="urban-nav-2-test", num_envs=num_envs)
    venv.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(10):
        venv.step(rng.uniform(-1, 1, (num_envs, 2)).astype(np.float32))
    t0 = time.perf_counter()
    for _ in range(steps):
        venv.step(rng.uniform(-1, 1, (num_envs, 2)).astype(np.float32))
    rate = steps * num_envs / (time.perf_counter() - t0)
    venv.close()
    return rate


def metadrive_rate() -> tuple[float | None, str]:
    import metadrive_baseline as md

    if not md.metadrive_available():
        return None, "MetaDrive not installed (set CITYGEN_METADRIVE_PYTHON to an interpreter that has it)"
    measure = getattr(md, "measure_metadrive_steps", None)
    if measure is None:
        return None, "metadrive_baseline has no step benchmark"
    try:
        # NavStatic has no moving agents: MetaDrive without traffic is the like-for-like case.
        r = measure(steps=2000, traffic_densities=(0.0,))
    except md.MetaDriveBaselineError as exc:
        return None, f"MetaDrive failed: {exc}"
    return float(r["cpu_steps_per_s"]), f"MetaDrive {r.get('version', '?')}, no traffic, per CPU second"


def orca_figures() -> dict:
    try:
        import bench_orca
    except ImportError as exc:  # pragma: no cover
        return {"orca_note": f"bench_orca unavailable: {exc}"}
    return bench_orca.measure(100, 200)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--steps", type=int, default=600)
    args = p.parse_args(argv)
    warnings.simplefilter("ignore")

    state = env_rate(args.steps)
    model = state.pop("model")
    raw = mj_rate(model)
    physics_per_step = state["substeps"] / raw
    runner_over_physics = (1.0 / state["steps_per_s"]) / physics_per_step
    depth = env_rate(max(100, args.steps // 3), depth=True, image_size=64)
    depth.pop("model")
    vec = vector_rate(args.steps // 2, 2)
    md, md_note = metadrive_rate()
    orca = orca_figures()

    print("NavStatic (urban-nav-2-test, wheeled robot, random actions)")
    print(
        f"  state + height map, 1 env:     {state['steps_per_s']:8.1f} steps/s ({state['cpu_steps_per_s']:.1f} per CPU s)"
    )
    print(f"  raw mj_step of the same model: {raw:8.0f} /s; {state['substeps']} per env step")
    print(f"  runner cost over physics cost: {runner_over_physics:8.2f}x")
    print(f"  2 envs, 2 processes (async):   {vec:8.1f} steps/s ({vec / state['steps_per_s']:.2f}x one env)")
    print(f"  + 64x64 depth camera, 1 env:   {depth['steps_per_s']:8.1f} steps/s")
    print(f"  MetaDrive headless:            {md if md is None else f'{md:8.1f} steps/CPU s'} ({md_note})")
    for key, value in orca.items():
        print(f"  {key}: {value}")
    figures = {
        "bench": "runner",
        "navstatic_steps_per_s": round(state["steps_per_s"], 1),
        "navstatic_cpu_steps_per_s": round(state["cpu_steps_per_s"], 1),
        "navstatic_2proc_steps_per_s": round(vec, 1),
        "navstatic_2proc_speedup": round(vec / state["steps_per_s"], 3),
        "mj_step_per_s": round(raw, 0),
        "substeps_per_env_step": state["substeps"],
        "runner_over_physics": round(runner_over_physics, 3),
        "depth64_steps_per_s": round(depth["steps_per_s"], 1),
        "depth64_over_state": round(depth["steps_per_s"] / state["steps_per_s"], 3),
        "metadrive_steps_per_s": None if md is None else round(md, 1),
        "navstatic_vs_metadrive_cpu": None if md is None else round(state["cpu_steps_per_s"] / md, 3),
        **{k: v for k, v in orca.items() if not isinstance(v, dict | list)},
    }
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
