"""The runner's speed, as ratios against baselines measured in the same run.

1. NavStatic (urban-nav-2-test, wheeled robot, random actions) environment steps per second
   with the default observation (state + height map) on one environment in this process,
   and in asynchronous vector environments of 2 and 4 (one process each, every
   sub-environment on its own scenes), each environment doing the same number of steps
   (``runner_envs``, ``runner_envs_steps_per_s``).
2. The raw ``mj_step`` rate of the same compiled model (the robot at rest at its start):
   *runner cost over physics cost* (``runner_over_physics``) is the CPU time of one
   environment step over the CPU time of the ``mj_step`` calls it contains at that rate (the
   physics floor). A driving robot makes MuJoCo's solver work harder than one at rest, so
   ``runner_over_physics_in_env`` also gives the step's CPU time over the CPU time spent
   inside its physics loop (``mj_step`` plus the 100 Hz drive) during the same run.
3. One environment with each observation option (``runner_obs``): the default; ``rays=True``
   (32 horizontal rays); ``depth=True`` and ``rgb=True`` with ``image_size=64`` (MuJoCo's
   offscreen renderer, ``MUJOCO_GL=egl``): steps/s (wall) and the same physics-floor ratio
   (``runner_obs_physics_floor_ratio``, CPU). An option whose renderer fails on this machine
   is ``None`` with the reason under ``runner_obs_note``.
4. MetaDrive's headless steps per second where it is installed (``benchmarks/
   metadrive_baseline.py``; set ``CITYGEN_METADRIVE_PYTHON`` to an interpreter that has it).
5. ORCA: citygen's vectorised ORCA against the reference RVO2 library (``pyrvo``) at 100
   agents, cost per agent-step (``benchmarks/bench_orca.py``).

``python benchmarks/bench_runner.py [--steps 600]`` (about 1 minute on 2 cores); the last line
is one JSON object of figures.
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

TASK, SPLIT = "nav-static", "urban-nav-2-test"
#: Observation options of the ``runner_obs`` series: label -> make_env keyword arguments.
OBS = {
    "state + height map": {},
    "+ rays": {"rays": True},
    "+ depth 64x64": {"depth": True, "image_size": 64},
    "+ RGB 64x64": {"rgb": True, "image_size": 64},
}
VECTOR_ENVS = (2, 4)


def _env(**kwargs):
    from citygen.runner.bench import make_env

    return make_env(TASK, split=SPLIT, **kwargs)


class EnvRun:
    """One NavStatic environment (``make_env`` keyword arguments ``kwargs``) driven by random
    actions in chunks of steps. Each chunk keeps its steps, the wall and CPU seconds of its
    ``step`` calls, the CPU seconds inside their physics loop (``mj_step`` and the drive),
    and its resets (count, wall and CPU seconds: a reset draws a new scene, compiled unless
    this process's scene cache holds it)."""

    def __init__(self, **kwargs) -> None:
        self.env = _env(**kwargs)
        self.env.reset(seed=0)
        self.rng = np.random.default_rng(0)
        self.chunks: list[tuple[float, ...]] = []
        self.physics = 0.0
        u = self.env.unwrapped
        inner = u._physics

        def timed(command):
            c = time.process_time()
            inner(command)
            self.physics += time.process_time() - c

        for a in self.rng.uniform(-1, 1, (20, 2)).astype(np.float32):  # warm-up: the renderer
            _, _, term, trunc, _ = self.env.step(a)
            if term or trunc:
                self.env.reset()
        u._physics = timed
        self.substeps, self.model = u._substeps, u.model

    def run(self, n: int) -> None:
        step_wall = step_cpu = reset_wall = reset_cpu = 0.0
        resets, p0 = 0, self.physics
        for a in self.rng.uniform(-1, 1, (n, 2)).astype(np.float32):
            t0, c0 = time.perf_counter(), time.process_time()
            _, _, term, trunc, _ = self.env.step(a)
            t1, c1 = time.perf_counter(), time.process_time()
            step_wall, step_cpu = step_wall + t1 - t0, step_cpu + c1 - c0
            if term or trunc:
                self.env.reset()
                resets += 1
                reset_wall, reset_cpu = (
                    reset_wall + time.perf_counter() - t1,
                    reset_cpu + time.process_time() - c1,
                )
        self.chunks.append((n, step_wall, step_cpu, self.physics - p0, resets, reset_wall, reset_cpu))

    def rates(self) -> dict:
        """``steps_per_s``, ``cpu_steps_per_s``: medians over the chunks of steps per wall and
        CPU second of ``step`` calls; ``physics_cpu_share``: the physics loop's share of their
        CPU time; ``with_resets_per_s``, ``cpu_with_resets_per_s``: all steps over all time,
        resets included; ``resets``, ``reset_ms``: their number and mean wall time."""
        n, wall, cpu, phys, resets, rwall, rcpu = (
            np.array(c, dtype=float) for c in zip(*self.chunks, strict=True)
        )
        return {
            "steps_per_s": float(np.median(n / wall)),
            "cpu_steps_per_s": float(np.median(n / cpu)),
            "physics_cpu_share": float(phys.sum() / cpu.sum()),
            "with_resets_per_s": float(n.sum() / (wall.sum() + rwall.sum())),
            "cpu_with_resets_per_s": float(n.sum() / (cpu.sum() + rcpu.sum())),
            "resets": int(resets.sum()),
            "reset_ms": float(1e3 * rwall.sum() / resets.sum()) if resets.sum() else None,
        }

    def close(self) -> None:
        self.env.close()


class VectorRun:
    """An asynchronous vector env of ``num_envs`` NavStatic environments (one process each)
    stepped in chunks; environment steps per wall second over all chunks (resets included:
    the workers reset a finished sub-environment inside ``step``)."""

    def __init__(self, num_envs: int) -> None:
        from citygen.runner.bench import make_vector_env

        self.n = num_envs
        self.venv = make_vector_env(TASK, split=SPLIT, num_envs=num_envs)
        self.venv.reset(seed=0)
        self.rng = np.random.default_rng(0)
        self.steps, self.wall = 0, 0.0
        self._steps(10)

    def _steps(self, k: int) -> None:
        for _ in range(k):
            self.venv.step(self.rng.uniform(-1, 1, (self.n, 2)).astype(np.float32))

    def run(self, k: int) -> None:
        t0 = time.perf_counter()
        self._steps(k)
        self.wall += time.perf_counter() - t0
        self.steps += k * self.n

    def rate(self) -> float:
        return self.steps / self.wall

    def close(self) -> None:
        self.venv.close()


def mj_rate(model, steps: int) -> tuple[float, float]:
    """Raw ``mj_step`` calls per second of ``model`` (the robot at rest at its start), per
    wall second and per CPU second."""
    import mujoco

    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    for _ in range(200):
        mujoco.mj_step(model, data)
    t0, c0 = time.perf_counter(), time.process_time()
    for _ in range(steps):
        mujoco.mj_step(model, data)
    return steps / (time.perf_counter() - t0), steps / (time.process_time() - c0)


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


def _r(x: float | None, digits: int) -> float | None:
    return None if x is None else round(x, digits)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--steps", type=int, default=1200, help="steps per environment (images: a third)")
    p.add_argument("--rounds", type=int, default=4, help="chunks each configuration's steps are run in")
    args = p.parse_args(argv)
    if args.rounds < 1 or args.steps < 10 * args.rounds:
        p.error(
            f"--steps/--rounds: expected >= 10 steps in each of >= 1 rounds, got {args.steps}/{args.rounds}"
        )
    warnings.simplefilter("ignore")

    # Every configuration runs a chunk per round, so drift in the shared machine's load hits
    # them alike; figures are medians over the rounds. The vector environments fork their
    # workers: they start before this process opens a renderer.
    rounds = args.rounds
    per_round = max(1, args.steps // rounds)
    vectors = {n: VectorRun(n) for n in VECTOR_ENVS}
    base = EnvRun()
    runs: dict[str, EnvRun | None] = {"state + height map": base}
    notes: list[str] = []

    def failed(label: str, exc: Exception) -> None:  # a renderer failing here is a figure, not a crash
        runs[label] = None
        notes.append(f"{label}: {type(exc).__name__}: {(str(exc).splitlines() or [''])[0]}")

    for label, kwargs in list(OBS.items())[1:]:
        try:
            runs[label] = EnvRun(**kwargs)
        except Exception as exc:
            failed(label, exc)
    mj: list[tuple[float, float]] = []
    for _ in range(rounds):
        for v in vectors.values():
            v.run(per_round)
        for label, run in list(runs.items()):
            images = "depth" in OBS[label] or "rgb" in OBS[label]
            try:
                if run is not None:
                    run.run(max(10, per_round // 3) if images else per_round)
            except Exception as exc:
                failed(label, exc)
        mj.append(mj_rate(base.model, 2000))
    vec = {n: v.rate() for n, v in vectors.items()}
    for v in vectors.values():
        v.close()
    obs = {label: None if run is None else run.rates() for label, run in runs.items()}
    for run in runs.values():
        if run is not None:
            run.close()
    state = obs["state + height map"]
    substeps = base.substeps
    raw, raw_cpu = float(np.median([m[0] for m in mj])), float(np.median([m[1] for m in mj]))
    physics_cpu = substeps / raw_cpu  # CPU seconds of one step's mj_step calls, at rest
    md, md_note = metadrive_rate()
    orca = orca_figures()

    obs_rates = [None if r is None else r["steps_per_s"] for r in obs.values()]
    obs_ratios = [None if r is None else (1.0 / r["cpu_steps_per_s"]) / physics_cpu for r in obs.values()]
    runner_over_physics = obs_ratios[0]
    one = state["with_resets_per_s"]  # like the vector environments: resets included
    envs_rates = [one, *(vec[n] for n in VECTOR_ENVS)]
    depth = obs["+ depth 64x64"]

    print(
        f"NavStatic ({SPLIT}, wheeled robot, random actions), {args.steps} steps per env in {rounds} rounds"
    )
    cpu_one = state["cpu_with_resets_per_s"]
    print(f"  1 env, resets included:        {one:8.1f} steps/s ({cpu_one:.1f} per CPU s)")
    for n in VECTOR_ENVS:
        print(f"  {n} envs, {n} processes (async):   {vec[n]:8.1f} steps/s ({vec[n] / one:.2f}x one env)")
    print(f"  resets (new scene drawn):      {state['resets']:8d}, {state['reset_ms'] or 0:.0f} ms each")
    print(f"  raw mj_step of the same model: {raw:8.0f} /s (at rest); {substeps} per env step")
    print(
        f"  runner cost over physics cost: {runner_over_physics:8.2f}x (CPU: step over its mj_steps at rest)"
    )
    print(
        f"  physics loop share of a step:  {state['physics_cpu_share']:8.2f} "
        f"(step over its physics loop in the env: {1.0 / state['physics_cpu_share']:.2f}x)"
    )
    print("  1 env by observation, steps only: steps/s   CPU over physics floor")
    for (label, r), q in zip(obs.items(), obs_ratios, strict=True):
        text = "failed" if r is None else f"{r['steps_per_s']:8.1f}   {q:6.2f}x"
        print(f"    {label:<28} {text}")
    for note in notes:
        print(f"    note: {note}")
    print(f"  MetaDrive headless:            {md if md is None else f'{md:8.1f} steps/CPU s'} ({md_note})")
    for key, value in orca.items():
        print(f"  {key}: {value}")
    figures = {
        "bench": "runner",
        "navstatic_steps_per_s": round(one, 1),
        "navstatic_cpu_steps_per_s": round(cpu_one, 1),
        "navstatic_2proc_steps_per_s": round(vec[2], 1),
        "navstatic_2proc_speedup": round(vec[2] / one, 3),
        "navstatic_resets": state["resets"],
        "navstatic_reset_ms": _r(state["reset_ms"], 1),
        "mj_step_per_s": round(raw, 0),
        "mj_step_cpu_per_s": round(raw_cpu, 0),
        "substeps_per_env_step": substeps,
        "runner_over_physics": round(runner_over_physics, 3),
        "runner_over_physics_in_env": round(1.0 / state["physics_cpu_share"], 3),
        "depth64_steps_per_s": None if depth is None else round(depth["steps_per_s"], 1),
        "depth64_over_state": None if depth is None else round(depth["steps_per_s"] / obs_rates[0], 3),
        "runner_envs": [1, *VECTOR_ENVS],
        "runner_envs_steps_per_s": [round(r, 1) for r in envs_rates],
        "runner_obs": list(obs),
        "runner_obs_steps_per_s": [_r(r, 1) for r in obs_rates],
        "runner_obs_physics_floor_ratio": [_r(q, 3) for q in obs_ratios],
        **({"runner_obs_note": "; ".join(notes)} if notes else {}),
        "metadrive_steps_per_s": None if md is None else round(md, 1),
        "navstatic_vs_metadrive_cpu": None if md is None else round(cpu_one / md, 3),
        **{k: v for k, v in orca.items() if not isinstance(v, dict | list)},
    }
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
