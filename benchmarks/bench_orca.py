"""ORCA benchmark: citygen's ORCA (numba kernel) against the reference RVO2 library (C++, through
pyrvo) and against citygen's plain-numpy reference solver.

What is measured
    The cost of one ORCA step per agent (microseconds per agent-step) for 25, 50, 100 and
    200 agents in two scenes, run by both in the same process with the same settings
    (time step 0.1 s, time horizon 2 s, neighbour distance 5 m, 10 neighbours, radius
    0.3 m, top speed 1.5 m/s):

    - ``circle``: agents on a circle (spaced 0.8 m apart, at least 8 m across) swapping
      to the antipodes: they all meet in the middle, the densest case;
    - ``random``: agents at random in a square (about 4 m^2 each), each to a random goal.

    Each step sets every agent's preferred velocity (towards its goal, as a runner would)
    and advances all agents. For citygen that is one :func:`citygen.runner.agents.orca.orca_velocities`
    call (neighbours and lines in numpy, each agent's linear programs in the numba kernel of
    :mod:`citygen.runner.agents.orca_kernel`) and the position update; ``citygen_numpy_us``
    is the same with the plain-numpy reference solver (``reference=True``); for RVO2 it is
    ``set_agent_pref_velocity`` per agent, ``do_step`` and reading the positions back
    (``rvo2_us``), and ``do_step`` alone (``rvo2_core_us``: the C++ without the Python calls
    a runner cannot avoid). Also
    citygen batched: 8 environments of the same agents in one call (``citygen_batch8_us``
    per agent-step), what a vector environment does. Times are CPU time of this process
    (the machine may be shared), best of 3 runs of ``steps`` steps.

Run: ``python benchmarks/bench_orca.py`` (well under a minute). The last line is one JSON
object of the figures. :func:`measure` is what ``benchmarks/bench_runner.py`` imports.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from citygen.runner.agents.orca import orca_velocities

DT, TAU, NEIGHBOR_DIST, MAX_NEIGHBORS, RADIUS, MAX_SPEED = 0.1, 2.0, 5.0, 10, 0.3, 1.5
SIZES = (25, 50, 100, 200)
SCENES = ("circle", "random")
REPEATS = 3


def scene(kind: str, n: int, seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Start and goal positions ``(n, 2)`` (m) of a benchmark scene."""
    if kind == "circle":
        r = max(8.0, n * 0.8 / (2 * math.pi))
        ang = np.arange(n) * (2 * math.pi / n)
        start = r * np.stack([np.cos(ang), np.sin(ang)], axis=-1)
        return start, -start
    if kind == "random":
        rng = np.random.default_rng(seed)
        side = 2.0 * math.sqrt(n)
        # A jittered grid keeps the starts apart; goals anywhere in the square.
        k = math.ceil(math.sqrt(n))
        cells = np.stack(np.meshgrid(np.arange(k), np.arange(k)), -1).reshape(-1, 2)[:n]
        start = (cells + 0.5 + rng.uniform(-0.2, 0.2, (n, 2))) * (side / k)
        return start, rng.uniform(0, side, (n, 2))
    raise ValueError(f"scene: expected one of {', '.join(SCENES)}, got {kind!r}")


def _pref(pos: np.ndarray, goal: np.ndarray) -> np.ndarray:
    d = goal - pos
    dist = np.linalg.norm(d, axis=-1, keepdims=True)
    return d / np.maximum(dist, 1e-9) * np.minimum(1.0, dist / DT)


def run_citygen(
    start: np.ndarray, goal: np.ndarray, steps: int, batch: int = 1, reference: bool = False
) -> float:
    """CPU seconds for ``steps`` steps (``batch`` copies of the scene in one call when > 1; the
    plain-numpy solver when ``reference``)."""
    pos = np.broadcast_to(start, (batch, *start.shape)).copy() if batch > 1 else start.copy()
    goal = np.broadcast_to(goal, pos.shape)
    vel = np.zeros_like(pos)
    t0 = time.process_time()
    for _ in range(steps):
        vel = orca_velocities(
            pos, vel, _pref(pos, goal), RADIUS, MAX_SPEED, dt=DT, tau=TAU,
            neighbor_dist=NEIGHBOR_DIST, max_neighbors=MAX_NEIGHBORS, reference=reference,
        )  # fmt: skip
        pos = pos + vel * DT
    return time.process_time() - t0


def run_rvo2(start: np.ndarray, goal: np.ndarray, steps: int) -> tuple[float, float]:
    """CPU seconds for ``steps`` steps of RVO2: the whole loop, and ``do_step`` alone."""
    import pyrvo

    sim = pyrvo.RVOSimulator(DT, NEIGHBOR_DIST, MAX_NEIGHBORS, TAU, TAU, RADIUS, MAX_SPEED)
    for p in start:
        sim.add_agent((float(p[0]), float(p[1])))
    n = len(start)
    pos = start.copy()
    core = 0.0
    t0 = time.process_time()
    for _ in range(steps):
        pref = _pref(pos, goal)
        for i in range(n):
            sim.set_agent_pref_velocity(i, (float(pref[i, 0]), float(pref[i, 1])))
        c0 = time.process_time()
        sim.do_step()
        core += time.process_time() - c0
        pos = np.array([sim.get_agent_position(i).to_tuple() for i in range(n)])
    return time.process_time() - t0, core


def measure(n_agents: int, steps: int = 100, kind: str = "circle") -> dict:
    """ORCA cost per agent-step (microseconds) of citygen, RVO2 and their ratio for one scene:
    ``{"agents", "scene", "citygen_us", "citygen_batch8_us", "citygen_numpy_us", "rvo2_us",
    "rvo2_core_us", "citygen_over_rvo2", "citygen_over_rvo2_core"}`` (``rvo2_*`` are ``None``
    without pyrvo)."""
    start, goal = scene(kind, n_agents)
    work = n_agents * steps
    run_citygen(start, goal, 1)  # loads (or compiles, the first time) the kernel
    ours = min(run_citygen(start, goal, steps) for _ in range(REPEATS)) / work * 1e6
    batch = min(run_citygen(start, goal, steps, batch=8) for _ in range(REPEATS)) / (8 * work) * 1e6
    out = {
        "agents": n_agents,
        "scene": kind,
        "citygen_us": round(ours, 2),
        "citygen_batch8_us": round(batch, 2),
        "citygen_numpy_us": round(
            min(run_citygen(start, goal, steps, reference=True) for _ in range(REPEATS)) / work * 1e6, 2
        ),
    }
    try:
        runs = [run_rvo2(start, goal, steps) for _ in range(REPEATS)]
    except ImportError:
        return {**out, "rvo2_us": None, "rvo2_core_us": None, "citygen_over_rvo2": None,
                "citygen_over_rvo2_core": None}  # fmt: skip
    rvo, core = min(r[0] for r in runs) / work * 1e6, min(r[1] for r in runs) / work * 1e6
    return {
        **out,
        "rvo2_us": round(rvo, 2),
        "rvo2_core_us": round(core, 2),
        "citygen_over_rvo2": round(ours / rvo, 2),
        "citygen_over_rvo2_core": round(ours / core, 2),
    }


def main() -> None:
    rows = [measure(n, 100, kind) for kind in SCENES for n in SIZES]
    head = (
        "scene",
        "agents",
        "citygen us",
        "citygen x8 us",
        "numpy ref us",
        "RVO2 us",
        "RVO2 core us",
        "ours/RVO2",
        "ours/core",
    )
    print("ORCA cost per agent-step (CPU microseconds; lower is better)")
    print("  ".join(f"{h:>13}" for h in head))
    for r in rows:
        keys = (
            "scene",
            "agents",
            "citygen_us",
            "citygen_batch8_us",
            "citygen_numpy_us",
            "rvo2_us",
            "rvo2_core_us",
        )
        cells = [r[k] for k in (*keys, "citygen_over_rvo2", "citygen_over_rvo2_core")]
        print("  ".join(f"{'-' if c is None else c:>13}" for c in cells))
    figures: dict[str, object] = {"bench": "orca"}
    for r in rows:
        key = f"{r['scene']}_{r['agents']}"
        figures[f"orca_{key}_citygen_us_per_agent_step"] = r["citygen_us"]
        figures[f"orca_{key}_citygen_batch8_us_per_agent_step"] = r["citygen_batch8_us"]
        figures[f"orca_{key}_citygen_numpy_us_per_agent_step"] = r["citygen_numpy_us"]
        figures[f"orca_{key}_rvo2_us_per_agent_step"] = r["rvo2_us"]
        figures[f"orca_{key}_rvo2_core_us_per_agent_step"] = r["rvo2_core_us"]
        figures[f"orca_{key}_citygen_over_rvo2"] = r["citygen_over_rvo2"]
        figures[f"orca_{key}_citygen_over_rvo2_core"] = r["citygen_over_rvo2_core"]
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
