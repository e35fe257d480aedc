"""The runner's speed (issue 17's targets), as ratios against baselines measured in the same run.

1. NavStatic (urban-nav-2-test, random actions) environment steps per second with the default
   observation (state + height map), resets included, each environment on its own scenes:
   one wheeled environment in this process; :func:`make_vector_env` of 2 (wheeled,
   quadruped, and 64 x 64 depth: one sub-environment in this process, one in a worker, both
   polling their pipe), beside Gymnasium's ``AsyncVectorEnv`` of the same 2 environments, the
   same :class:`~citygen.runner.vector.VectorEnv` with both in workers that sleep on their
   pipes (``local=0``, the previous default) and one environment at the old 2 ms physics
   step; and 8 sub-environments as ``citygen train`` runs them (a process per core, each
   stepping a group of 4), beside a worker per sub-environment (the layout before groups),
   and with ``observations=`` the keys the shipped policies read (:data:`POLICY_KEYS`), which
   is what ``citygen train`` asks for (``*_policy_keys_*``: nothing else is computed).
   Steady state: the environments draw from the split's first :data:`POOL` scenes
   (``scene_pool``), which every process has compiled before the measurement, so a reset
   swaps a cached scene; ``*_cold_*`` figures draw from the whole split, where most resets
   compile a new scene.
2. *Runner cost over physics cost*: CPU time of an environment step over the CPU time of the
   ``mj_step`` calls inside it (``runner_over_mj_step``, timed around each call; the same
   for one quadruped environment, ``quadruped_over_mj_step``), and over the raw ``mj_step``
   rate of the same model with the robot at rest (``runner_over_physics``). The steps per
   CPU second of the ``mj_step`` calls alone (``*_physics_steps_per_s``) are what an
   environment would reach if nothing but its physics cost anything.
3. Resets: to a scene of the process's cache (``reset_cached_ms``, median) and to a scene
   never seen by the process (``first_visit_ms``, median; ``scene_generate_ms``: the
   generation part of it, the scene spec from the seed; ``scene_mjcf_ms`` and
   ``scene_compile_ms``: writing its MJCF and MuJoCo's compile of it); and a fresh process's way to its
   first observation, imports included (``fresh_process_first_reset_ms``, what each
   sub-environment worker and each ``citygen run`` pays once), beside importing the
   libraries it cannot do without (``import_floor_ms``).
4. One environment with each observation option (``runner_obs``): the default; the shipped
   policies' keys alone and with the wide map (``local_map_wide``, given on request);
   ``rays=True``; depth and RGB at 64 x 64 and depth at 128 x 128 (MuJoCo's offscreen
   renderer, ``MUJOCO_GL=egl``, one per process and model, reused).
5. MetaDrive's headless steps per second where it is installed (``benchmarks/
   metadrive_baseline.py``; set ``CITYGEN_METADRIVE_PYTHON`` to an interpreter that has it).
6. ORCA against RVO2 (``pyrvo``) at 100 agents, cost per agent-step (``bench_orca.py``).
7. Locomotion (LocoFlat, quadruped, random actions: it falls and resets often), steps per wall
   second: one environment, ``make_vector_env(num_envs=8)`` and the layout ``citygen train
   --config examples/train/loco.toml`` steps (32 sub-environments), beside raw ``mj_step`` of
   the same model on one core and, ideal, on every core (:func:`loco_figures`).

``python benchmarks/bench_runner.py [--steps 1200] [--loco-only]`` (a few minutes on 2 cores;
``--loco-only``: section 7 alone, about a minute); the last line is one JSON object of figures.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
os.environ.setdefault("MUJOCO_GL", "egl")

TASK, SPLIT = "nav-static", "urban-nav-2-test"
#: Scenes of the split the steady-state runs draw from (every process compiles them first).
POOL = 8
#: Observation options of the ``runner_obs`` series: label -> make_env keyword arguments.
#: The keys the shipped NavStatic policies read (``citygen train``'s default config), which
#: ``citygen train`` asks its environments for (``observations=``): nothing else is computed.
POLICY_KEYS = ["goal", "velocity", "local_map", "local_map_crossable"]
OBS = {
    "state + height map": {},
    "policy's keys only": {"observations": POLICY_KEYS},
    # The wide map (local_map_wide), given on request: what a policy reading it pays.
    "policy's keys + wide map": {"observations": [*POLICY_KEYS, "local_map_wide"]},
    "+ rays": {"rays": True},
    "+ depth 64x64": {"depth": True, "image_size": 64},
    "+ RGB 64x64": {"rgb": True, "image_size": 64},
    "+ depth 128x128": {"depth": True, "image_size": 128},
}
#: Vector environments (of :data:`N_VEC` sub-environments unless ``num_envs`` says): label ->
#: (implementation, VectorRun keyword arguments).
VECTORS = {
    "citygen 2 workers": ("citygen", {}),
    "gymnasium async 2 workers": ("gymnasium", {}),
    "citygen 2 workers, none here": ("citygen-workers", {}),
    "citygen 2 workers, quadruped": ("citygen", {"robot": "quadruped"}),
    "citygen 2 workers, humanoid": ("citygen", {"robot": "humanoid"}),
    "citygen 2 workers, depth 64x64": ("citygen", {"depth": True, "image_size": 64}),
    "citygen 2 workers, cold": ("citygen", {"scene_pool": None}),
    # What `citygen train` runs by default: 8 sub-environments on the machine's cores.
    "citygen 8 envs": ("citygen", {"num_envs": 8}),
    "citygen 8 envs, a worker each": ("citygen-each", {"num_envs": 8}),
    "citygen 8 envs, policy's keys": ("citygen", {"num_envs": 8, "observations": POLICY_KEYS}),
}
N_VEC = 2


def _env(**kwargs):
    from citygen.runner.make import make_env

    return make_env(TASK, split=SPLIT, **{"scene_pool": POOL, **kwargs})


def _warm(env) -> None:
    """Compile the pool's scenes in this environment's process (and visit each once)."""
    for i in range(POOL):
        env.reset(seed=i, options={"index": i})


class _MjTimer:
    """CPU seconds spent inside ``mujoco.mj_step`` while installed (wraps the module function
    the environments call; about a microsecond of wrapper per call counts as physics)."""

    def __init__(self) -> None:
        import mujoco

        self.mj, self.inner, self.cpu = mujoco, mujoco.mj_step, 0.0

        def timed(*args, **kwargs):
            c = time.process_time()
            self.inner(*args, **kwargs)
            self.cpu += time.process_time() - c

        self.timed = timed

    def __enter__(self):
        self.mj.mj_step = self.timed
        return self

    def __exit__(self, *exc) -> None:
        self.mj.mj_step = self.inner


class EnvRun:
    """One NavStatic environment (``make_env`` keyword arguments ``kwargs``; ``timestep``:
    the robot's physics step replaced) driven by random actions in chunks of steps. Each
    chunk keeps its steps, the wall and CPU seconds of its ``step`` calls, the CPU seconds
    inside their ``mj_step`` calls, and its resets (count, wall and CPU seconds)."""

    def __init__(self, timestep: float | None = None, **kwargs) -> None:
        import dataclasses

        self.env = _env(**kwargs)
        u = self.env.unwrapped
        if timestep is not None:
            u.robot = dataclasses.replace(u.robot, timestep=timestep)
        _warm(self.env)
        self.env.reset(seed=0)
        self.rng = np.random.default_rng(0)
        self.chunks: list[tuple[float, ...]] = []
        for a in self.rng.uniform(-1, 1, (20, 2)).astype(np.float32):  # warm-up: the renderer
            _, _, term, trunc, _ = self.env.step(a)
            if term or trunc:
                self.env.reset()
        self.substeps, self.model = u._substeps, u.model

    def run(self, n: int) -> None:
        step_wall = step_cpu = reset_wall = reset_cpu = 0.0
        resets = 0
        with _MjTimer() as mj:
            for a in self.rng.uniform(-1, 1, (n, 2)).astype(np.float32):
                t0, c0 = time.perf_counter(), time.process_time()
                _, _, term, trunc, _ = self.env.step(a)
                t1, c1 = time.perf_counter(), time.process_time()
                step_wall, step_cpu = step_wall + t1 - t0, step_cpu + c1 - c0
                if term or trunc:
                    self.env.reset()
                    resets += 1
                    reset_wall += time.perf_counter() - t1
                    reset_cpu += time.process_time() - c1
        self.chunks.append((n, step_wall, step_cpu, mj.cpu, resets, reset_wall, reset_cpu))

    def rates(self) -> dict:
        """``steps_per_s``, ``cpu_steps_per_s``: medians over the chunks of steps per wall and
        CPU second of ``step`` calls; ``mj_cpu_share``: the ``mj_step`` calls' share of their
        CPU time; ``physics_steps_per_s``: steps per CPU second of the ``mj_step`` calls alone
        (what the runner would reach if nothing but its physics cost anything);
        ``with_resets_per_s``, ``cpu_with_resets_per_s``: all steps over all time, resets
        included; ``resets``, ``reset_ms``: their number and mean wall time."""
        n, wall, cpu, mj, resets, rwall, rcpu = (
            np.array(c, dtype=float) for c in zip(*self.chunks, strict=True)
        )
        return {
            "steps_per_s": float(np.median(n / wall)),
            "cpu_steps_per_s": float(np.median(n / cpu)),
            "mj_cpu_share": float(mj.sum() / cpu.sum()),
            "physics_steps_per_s": float(n.sum() / mj.sum()),
            "with_resets_per_s": float(n.sum() / (wall.sum() + rwall.sum())),
            "cpu_with_resets_per_s": float(n.sum() / (cpu.sum() + rcpu.sum())),
            "resets": int(resets.sum()),
            "reset_ms": float(1e3 * rwall.sum() / resets.sum()) if resets.sum() else None,
        }

    def close(self) -> None:
        self.env.close()


class VectorRun:
    """A vector env of ``num_envs`` NavStatic environments (``impl``: ``"citygen"``, the one
    :func:`make_vector_env` returns; ``"citygen-workers"``, the same with every
    sub-environment in a worker; ``"citygen-each"``, a worker per sub-environment, the
    layout before workers stepped groups; or ``"gymnasium"``'s ``AsyncVectorEnv`` of the
    same environments) stepped in chunks; environment steps per wall second over all chunks,
    resets included (a finished sub-environment resets on its next step)."""

    def __init__(self, impl: str, num_envs: int = N_VEC, **kwargs) -> None:
        import functools

        import gymnasium

        from citygen.runner.make import make_env, make_vector_env

        kw = {"scene_pool": POOL, **kwargs}
        self.n = num_envs
        fns = [functools.partial(make_env, TASK, split=SPLIT, **kw) for _ in range(self.n)]
        if impl == "citygen":
            self.venv = make_vector_env(TASK, split=SPLIT, num_envs=self.n, **kw)
        elif impl in ("citygen-workers", "citygen-each"):
            from citygen.runner.vector import VectorEnv

            # every sub-environment in a worker: none polled; or a worker each, none here
            self.venv = VectorEnv(fns, local=0, workers=self.n if impl == "citygen-each" else None)
        else:
            self.venv = gymnasium.vector.AsyncVectorEnv(fns, shared_memory=False)
        if kw["scene_pool"] is not None:
            for i in range(POOL):  # every worker compiles the pool first
                self.venv.reset(seed=i, options={"index": i})
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


def reset_times(new: int = 6, cached: int = 30) -> dict:
    """Median wall ms of a reset to a cached scene and of a first visit (a scene this process
    never compiled), and of three parts of one on other new scenes: generating the scene's
    spec, writing its MJCF and MuJoCo's compile of it with the robot."""
    from citygen.runner.make import make_env
    from citygen.runner.robots import compose
    from citygen.runner.scenes import _scene_mjcf, process_cache

    saved = os.environ.get("CITYGEN_CACHE_DIR")
    os.environ["CITYGEN_CACHE_DIR"] = "off"  # a cold first visit: no on-disk store
    env = make_env(TASK, split=SPLIT)
    size = env.unwrapped.source.size
    fresh = [size - 1 - 7 * k for k in range(2 * new)]  # far from the pool's and the runs' scenes
    first = []
    for i in fresh[:new]:
        t0 = time.perf_counter()
        env.reset(seed=i, options={"index": i})
        first.append(time.perf_counter() - t0)
    # The same first visits in a process whose on-disk store holds them (a second run, or
    # another worker): fill a store, forget the process's compiled scenes, visit again.
    with tempfile.TemporaryDirectory() as store:
        os.environ["CITYGEN_CACHE_DIR"] = store
        process_cache.cache_clear()  # the cold visits' compiled scenes: not in the store
        filler = make_env(TASK, split=SPLIT)
        for i in fresh[:new]:
            filler.reset(seed=i, options={"index": i})
        filler.close()
        process_cache.cache_clear()
        warm_env = make_env(TASK, split=SPLIT)
        warm = []
        for i in fresh[:new]:
            t0 = time.perf_counter()
            warm_env.reset(seed=i, options={"index": i})
            warm.append(time.perf_counter() - t0)
        warm_env.close()
    if saved is None:
        os.environ.pop("CITYGEN_CACHE_DIR", None)
    else:
        os.environ["CITYGEN_CACHE_DIR"] = saved
    hits = []
    for k in range(cached):
        i = fresh[k % new]
        t0 = time.perf_counter()
        env.reset(seed=k, options={"index": i})
        hits.append(time.perf_counter() - t0)
    gen, mjcf, compiled = [], [], []
    for i in fresh[new:]:
        t0 = time.perf_counter()
        scene = env.unwrapped.source.scene(i)
        t1 = time.perf_counter()
        xml = _scene_mjcf(scene)
        t2 = time.perf_counter()
        compose(xml, env.unwrapped.robot, (0.0, 0.0, 0.0, 0.0))
        gen.append(t1 - t0)
        mjcf.append(t2 - t1)
        compiled.append(time.perf_counter() - t2)
    env.close()
    return {
        "first_visit_ms": 1e3 * float(np.median(first)),
        "first_visit_store_ms": 1e3 * float(np.median(warm)),
        "reset_cached_ms": 1e3 * float(np.median(hits)),
        "scene_generate_ms": 1e3 * float(np.median(gen)),
        "scene_mjcf_ms": 1e3 * float(np.median(mjcf)),
        "scene_compile_ms": 1e3 * float(np.median(compiled)),
    }


#: What a fresh process runs to its first observation (a sub-environment worker, ``citygen
#: run``, ``citygen bench``): import the runner, make a NavStatic environment on the split and
#: reset it to a scene (a first visit); and the floor: importing the libraries it cannot do
#: without. Each prints its wall milliseconds from its first line on (interpreter start apart).
_FRESH = (
    "import time; t0 = time.perf_counter()\n"
    "from citygen.runner.make import make_env\n"
    f"env = make_env({TASK!r}, split={SPLIT!r})\n"
    "env.reset(seed=0, options={'index': 0})\n"
    "print(1e3 * (time.perf_counter() - t0))\n"
)
_FLOOR = (
    "import time; t0 = time.perf_counter()\n"
    "import numpy, scipy.ndimage, shapely, pydantic, mujoco, gymnasium\n"
    "print(1e3 * (time.perf_counter() - t0))\n"
)


def fresh_process_times(repeats: int = 3) -> dict:
    """Median wall ms of a fresh process's way to its first observation (:data:`_FRESH`) and
    of its import floor (:data:`_FLOOR`), each run ``repeats`` times in turn."""
    import subprocess

    def once(code: str) -> float:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
        return float(out.stdout.strip().splitlines()[-1])

    fresh, floor = [], []
    for _ in range(repeats):
        fresh.append(once(_FRESH))
        floor.append(once(_FLOOR))
    return {
        "fresh_process_first_reset_ms": float(np.median(fresh)),
        "import_floor_ms": float(np.median(floor)),
    }


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


# --- locomotion ------------------------------------------------------------------------------

#: The locomotion training config whose layout the ``loco_train_*`` figures measure.
LOCO_CONFIG = Path(__file__).resolve().parent.parent / "examples" / "train" / "loco.toml"


def _random_actions(space, n: int, rng) -> np.ndarray:
    return rng.uniform(-1, 1, (n, *space.shape)).astype(np.float32)


def loco_figures(steps: int = 3000) -> dict:
    """LocoFlat quadruped with random actions (it falls and resets often), environment steps
    per wall second, resets included: one environment; ``make_vector_env(num_envs=8)``; the
    layout ``citygen train --config examples/train/loco.toml`` steps (its 32 sub-environments,
    half in this process and half in a worker, LocoTraining and the scene schedule around
    each, behind SB3's ``VecEnv``); beside raw ``mj_step`` of the same model (``nstep`` the
    environment's substeps: one environment step of physics and nothing else, the robot
    unactuated from an episode's start; the median of a run after each configuration), on
    one core and, ideal, on every core this process may use. ``steps`` per configuration."""
    import mujoco

    from citygen.generate.dataset import default_jobs
    from citygen.runner.learn.config import load_config
    from citygen.runner.learn.vecenv import make_training_env
    from citygen.runner.make import make_env, make_vector_env

    rng = np.random.default_rng(0)
    out: dict[str, float] = {}
    env = make_env("loco-flat", robot="quadruped")
    env.reset(seed=0)
    resets = 0
    t0, c0 = time.perf_counter(), time.process_time()
    with _MjTimer() as mj:
        for a in _random_actions(env.action_space, steps, rng):
            _, _, term, trunc, _ = env.step(a)
            if term or trunc:
                env.reset()
                resets += 1
    out["loco_1env_steps_per_s"] = steps / (time.perf_counter() - t0)
    # CPU of the steps and resets over the CPU of their mj_step calls: what the runner adds
    # to its physics, a figure the machine's load barely moves (1.0: physics alone)
    out["loco_1env_cpu_over_mj_step"] = (time.process_time() - c0) / mj.cpu
    out["loco_1env_resets"] = resets
    u = env.unwrapped
    model, substeps = u.model, u._substeps
    env.reset(seed=0)
    data = mujoco.MjData(model)  # the robot standing at an episode's start, stepped unactuated
    data.qpos[:], data.qvel[:] = u.data.qpos, u.data.qvel
    env.close()
    raws: list[float] = []

    def raw_rate(n: int = 1000) -> None:  # after each configuration: the load drifts
        mujoco.mj_forward(model, data)
        t0 = time.perf_counter()
        for _ in range(n):
            mujoco.mj_step(model, data, nstep=substeps)
        raws.append(n / (time.perf_counter() - t0))

    raw_rate()
    venv = make_vector_env("loco-flat", robot="quadruped", num_envs=8)
    venv.reset(seed=0)
    k = max(10, steps // 8)
    acts = _random_actions(venv.action_space, k, rng)
    for a in acts[:5]:  # the workers' first steps
        venv.step(a)
    t0 = time.perf_counter()
    for a in acts:
        venv.step(a)
    out["loco_8env_steps_per_s"] = 8 * k / (time.perf_counter() - t0)
    venv.close()
    raw_rate()
    cfg = load_config(LOCO_CONFIG, task="loco-flat", robot="quadruped", seed=0)
    train = make_training_env(cfg)
    train.reset()
    k = max(10, steps // cfg.envs)
    acts = _random_actions(train.action_space, k * cfg.envs, rng).reshape(k, cfg.envs, -1)
    for a in acts[:5]:  # the workers' first steps
        train.step(a)
    t0 = time.perf_counter()
    for a in acts:
        train.step(a)
    out["loco_train_envs"] = cfg.envs
    out["loco_train_steps_per_s"] = cfg.envs * k / (time.perf_counter() - t0)
    train.close()
    raw_rate()
    cores = default_jobs()
    out["loco_mj_step_steps_per_s"] = float(np.median(raws))
    out["loco_mj_step_all_cores_steps_per_s"] = out["loco_mj_step_steps_per_s"] * cores
    for key in ("loco_1env", "loco_8env", "loco_train"):
        out[f"{key}_over_mj_step_all_cores"] = (
            out[f"{key}_steps_per_s"] / out["loco_mj_step_all_cores_steps_per_s"]
        )
    return {k: round(v, 3) if isinstance(v, float) else v for k, v in out.items()}


def loco_stair_figures(steps: int = 2000, rounds: int = 3) -> dict:
    """LocoStair's training grid (urban-loc-3-train: 30 x 30 regions, 29,700 box geoms), the
    quadruped with random actions through ``LocoTraining`` (as ``citygen train`` wraps each
    sub-environment), environment steps per wall second, resets included: the grid run a
    window at a time (:mod:`citygen.runner.envs.window`, the default) and whole
    (``windowed=False``), alternating in ``rounds`` chunks of ``steps`` each (medians), and
    their ratio; both step to the bit alike (``tests/test_window.py``)."""
    from citygen.runner.learn.loco import LocoTraining
    from citygen.runner.make import make_env

    envs = {}
    for windowed in (True, False):
        env = LocoTraining(
            make_env("loco-stair", robot="quadruped", split="urban-loc-3-train", windowed=windowed),
            seed=0, rank=0,
        )  # fmt: skip
        env.reset(seed=0)
        for _ in range(20):  # the first window's model and the kernels compiled
            env.step(np.zeros(env.action_space.shape, dtype=np.float32))
        envs[windowed] = env
    rates: dict[bool, list[float]] = {True: [], False: []}
    for r in range(rounds):
        for windowed, env in envs.items():
            acts = _random_actions(env.action_space, steps, np.random.default_rng(r))
            t0 = time.perf_counter()
            for a in acts:
                _, _, term, trunc, _ = env.step(a)
                if term or trunc:
                    env.reset()
            rates[windowed].append(steps / (time.perf_counter() - t0))
    out = {
        "loco_stair_windowed_steps_per_s": float(np.median(rates[True])),
        "loco_stair_whole_steps_per_s": float(np.median(rates[False])),
    }
    ratio = out["loco_stair_windowed_steps_per_s"] / out["loco_stair_whole_steps_per_s"]
    out["loco_stair_windowed_over_whole"] = ratio
    return {k: round(v, 3) for k, v in out.items()}


def _print_loco(loco: dict) -> None:
    raw, ideal = loco["loco_mj_step_steps_per_s"], loco["loco_mj_step_all_cores_steps_per_s"]
    print(
        "LocoFlat quadruped, random actions (resets included); "
        f"raw mj_step: {raw:.0f}/s a core, {ideal:.0f}/s ideal"
    )
    for label, key in (
        ("1 env", "loco_1env"),
        ("make_vector_env(num_envs=8)", "loco_8env"),
        (f"citygen train layout, {loco['loco_train_envs']} envs", "loco_train"),
    ):
        rate, share = loco[f"{key}_steps_per_s"], loco[f"{key}_over_mj_step_all_cores"]
        print(f"  {label:<34} {rate:9.1f} steps/s   {share:.3f} of raw mj_step on every core")
    print(
        f"  1 env: CPU over its mj_step calls' CPU {loco['loco_1env_cpu_over_mj_step']:.2f}x "
        "(1.0: physics alone)"
    )
    if "loco_stair_windowed_over_whole" in loco:
        print(
            "LocoStair training grid, quadruped, one training sub-environment: "
            f"{loco['loco_stair_windowed_steps_per_s']:.0f} steps/s a window at a time, "
            f"{loco['loco_stair_whole_steps_per_s']:.0f} whole "
            f"({loco['loco_stair_windowed_over_whole']:.2f}x)"
        )


def _r(x: float | None, digits: int) -> float | None:
    return None if x is None else round(x, digits)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--steps", type=int, default=1200, help="steps per environment (images: a third)")
    p.add_argument("--rounds", type=int, default=4, help="chunks each configuration's steps are run in")
    p.add_argument("--loco-only", action="store_true", help="measure locomotion (section 7) alone")
    args = p.parse_args(argv)
    if args.rounds < 1 or args.steps < 10 * args.rounds:
        p.error(
            f"--steps/--rounds: expected >= 10 steps in each of >= 1 rounds, got {args.steps}/{args.rounds}"
        )
    warnings.simplefilter("ignore")
    # Every figure but the store's own is of a process without the on-disk store (its workers
    # inherit this), so that a second run of the benchmark measures the same cold visits.
    os.environ["CITYGEN_CACHE_DIR"] = "off"
    if args.loco_only:
        loco = {**loco_figures(max(args.steps, 1000)), **loco_stair_figures()}
        _print_loco(loco)
        print(json.dumps({"bench": "runner", **loco}))
        return 0

    # Every configuration runs a chunk per round, so drift in the shared machine's load hits
    # them alike; figures are medians over the rounds. The vector environments fork their
    # workers: they start before this process opens a renderer.
    rounds = args.rounds
    per_round = max(1, args.steps // rounds)
    # The vector envs' workers compile the pool themselves (VectorRun) before timing.
    base = EnvRun()
    runs: dict[str, EnvRun | None] = {
        "state + height map": base,
        "old 2 ms physics step": EnvRun(timestep=0.002),
        "quadruped": EnvRun(robot="quadruped"),
    }
    vectors = {label: VectorRun(impl, **kw) for label, (impl, kw) in VECTORS.items()}
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
        for label, v in vectors.items():
            v.run(max(10, per_round // 3) if "depth" in label else max(10, per_round // v.n))
        for label, run in list(runs.items()):
            images = "depth" in label or "RGB" in label
            try:
                if run is not None:
                    run.run(max(10, per_round // 3) if images else per_round)
            except Exception as exc:
                failed(label, exc)
        mj.append(mj_rate(base.model, 1000))
    vec = {label: v.rate() for label, v in vectors.items()}
    for v in vectors.values():
        v.close()
    obs = {label: None if run is None else run.rates() for label, run in runs.items()}
    for run in runs.values():
        if run is not None:
            run.close()
    resets = reset_times()
    fresh = fresh_process_times()
    state, old = obs["state + height map"], obs["old 2 ms physics step"]
    substeps = base.substeps
    raw, raw_cpu = float(np.median([m[0] for m in mj])), float(np.median([m[1] for m in mj]))
    physics_cpu = substeps / raw_cpu  # CPU seconds of one step's mj_step calls, at rest
    md, md_note = metadrive_rate()
    orca = orca_figures()
    loco = {**loco_figures(max(args.steps, 1000)), **loco_stair_figures()}

    labels = [k for k in obs if k in OBS]
    obs_rates = [None if obs[k] is None else obs[k]["steps_per_s"] for k in labels]
    obs_ratios = [None if obs[k] is None else (1.0 / obs[k]["cpu_steps_per_s"]) / physics_cpu for k in labels]
    one = state["with_resets_per_s"]  # like the vector environments: resets included
    v2, gym2 = vec["citygen 2 workers"], vec["gymnasium async 2 workers"]
    workers2 = vec["citygen 2 workers, none here"]
    quad2, depth2 = vec["citygen 2 workers, quadruped"], vec["citygen 2 workers, depth 64x64"]
    human2 = vec["citygen 2 workers, humanoid"]
    cold2 = vec["citygen 2 workers, cold"]
    v8, each8 = vec["citygen 8 envs"], vec["citygen 8 envs, a worker each"]
    v8_keys = vec["citygen 8 envs, policy's keys"]
    keys_one = None if obs["policy's keys only"] is None else obs["policy's keys only"]["steps_per_s"]
    over_mj = 1.0 / state["mj_cpu_share"]
    quad = obs["quadruped"]
    depth = obs["+ depth 64x64"]

    old_one = old["with_resets_per_s"]
    floor_ratio = obs_ratios[0]
    ms = 1e3 * base.model.opt.timestep
    print(f"NavStatic ({SPLIT}, random actions), {args.steps} steps per env in {rounds} rounds;")
    print(
        f"steady state: scenes drawn from the split's first {POOL}, compiled before timing; resets included"
    )
    rows = [
        ("1 env, wheeled", one, "steps/s", f"2 ms physics step: {old_one:.1f} ({one / old_one:.2f}x)"),
        (
            "make_vector_env, 2 workers",
            v2,
            "steps/s",
            f"gymnasium AsyncVectorEnv: {gym2:.1f} ({v2 / gym2:.2f}x); one env: {v2 / one:.2f}x",
        ),
        ("  both in workers, none polled", workers2, "steps/s", f"the default: {v2 / workers2:.2f}x"),
        ("  quadruped", quad2, "steps/s", f"wheeled: {quad2 / v2:.2f}x"),
        ("  humanoid", human2, "steps/s", f"wheeled: {human2 / v2:.2f}x"),
        ("  depth 64x64", depth2, "steps/s", f"state only: {depth2 / v2:.2f}x"),
        ("  cold: whole split", cold2, "steps/s", "most resets compile a new scene"),
        ("make_vector_env, 8 envs", v8, "steps/s", f"a worker each: {each8:.1f} ({v8 / each8:.2f}x)"),
        ("  policy's keys only (citygen train)", v8_keys, "steps/s", f"every key: {v8_keys / v8:.2f}x"),
        (
            "reset to a cached scene",
            resets["reset_cached_ms"],
            "ms",
            f"first visit {resets['first_visit_ms']:.0f} ms",
        ),
        (
            "first visit to a scene",
            resets["first_visit_ms"],
            "ms",
            f"generating its spec alone: {resets['scene_generate_ms']:.0f} ms, its MJCF "
            f"{resets['scene_mjcf_ms']:.0f} ms, MuJoCo's compile {resets['scene_compile_ms']:.0f} ms",
        ),
        (
            "  with the on-disk store warm",
            resets["first_visit_store_ms"],
            "ms",
            f"cold: {resets['first_visit_ms'] / resets['first_visit_store_ms']:.2f}x "
            "(a second run or worker; citygen.runner.scene_store)",
        ),
        (
            "fresh process to its first reset",
            fresh["fresh_process_first_reset_ms"],
            "ms",
            f"importing the libraries it needs: {fresh['import_floor_ms']:.0f} ms",
        ),
        ("step CPU over its mj_step calls", over_mj, "x", "1.0 = nothing but physics"),
        (
            "  physics alone (runner free)",
            state["physics_steps_per_s"],
            "steps/s",
            f"the step: {state['cpu_steps_per_s']:.1f} steps/CPU s",
        ),
        (
            "  quadruped, step over mj_step",
            1.0 / quad["mj_cpu_share"],
            "x",
            f"{quad['cpu_steps_per_s']:.1f} steps/CPU s, physics alone {quad['physics_steps_per_s']:.1f}",
        ),
        ("step CPU over raw mj_step at rest", floor_ratio, "x", f"{substeps} x {ms:g} ms steps, {raw:.0f}/s"),
    ]
    for label, value, unit, baseline in rows:
        print(f"  {label:<34} {value:9.2f} {unit:<8} baseline: {baseline}")
    print("  1 env by observation, steps only: steps/s   CPU over physics floor")
    for label, r, q in zip(labels, obs_rates, obs_ratios, strict=True):
        text = "failed" if r is None else f"{r:8.1f}   {q:6.2f}x"
        print(f"    {label:<28} {text}")
    for note in notes:
        print(f"    note: {note}")
    print(f"  MetaDrive headless:            {md if md is None else f'{md:8.1f} steps/CPU s'} ({md_note})")
    for key, value in orca.items():
        print(f"  {key}: {value}")
    _print_loco(loco)
    figures = {
        "bench": "runner",
        "navstatic_steps_per_s": round(one, 1),
        "navstatic_cpu_steps_per_s": round(state["cpu_with_resets_per_s"], 1),
        "navstatic_2ms_steps_per_s": round(old_one, 1),
        "navstatic_over_2ms": round(one / old_one, 3),
        "navstatic_2proc_steps_per_s": round(v2, 1),
        "navstatic_2proc_gym_async_steps_per_s": round(gym2, 1),
        "navstatic_2proc_over_gym_async": round(v2 / gym2, 3),
        "navstatic_2proc_all_workers_steps_per_s": round(workers2, 1),
        "navstatic_2proc_over_all_workers": round(v2 / workers2, 3),
        "navstatic_2proc_speedup": round(v2 / one, 3),
        "navstatic_2proc_cold_steps_per_s": round(cold2, 1),
        "navstatic_8env_steps_per_s": round(v8, 1),
        "navstatic_8env_worker_each_steps_per_s": round(each8, 1),
        "navstatic_8env_over_worker_each": round(v8 / each8, 3),
        "navstatic_8env_policy_keys_steps_per_s": round(v8_keys, 1),
        "navstatic_8env_policy_keys_over_every_key": round(v8_keys / v8, 3),
        "navstatic_policy_keys_steps_per_s": _r(keys_one, 1),
        "quadruped_2proc_steps_per_s": round(quad2, 1),
        "humanoid_2proc_steps_per_s": round(human2, 1),
        "depth64_2proc_steps_per_s": round(depth2, 1),
        "reset_cached_ms": round(resets["reset_cached_ms"], 2),
        "first_visit_ms": round(resets["first_visit_ms"], 1),
        "first_visit_store_ms": round(resets["first_visit_store_ms"], 1),
        "first_visit_over_store": round(resets["first_visit_ms"] / resets["first_visit_store_ms"], 3),
        "scene_generate_ms": round(resets["scene_generate_ms"], 1),
        "scene_mjcf_ms": round(resets["scene_mjcf_ms"], 1),
        "scene_compile_ms": round(resets["scene_compile_ms"], 1),
        "navstatic_resets": state["resets"],
        "navstatic_reset_ms": _r(state["reset_ms"], 2),
        "mj_step_per_s": round(raw, 0),
        "mj_step_cpu_per_s": round(raw_cpu, 0),
        "substeps_per_env_step": substeps,
        "runner_over_mj_step": round(over_mj, 3),
        "navstatic_physics_steps_per_s": round(state["physics_steps_per_s"], 1),
        "quadruped_steps_per_s": round(quad["with_resets_per_s"], 1),
        "quadruped_over_mj_step": round(1.0 / quad["mj_cpu_share"], 3),
        "quadruped_physics_steps_per_s": round(quad["physics_steps_per_s"], 1),
        "fresh_process_first_reset_ms": round(fresh["fresh_process_first_reset_ms"], 1),
        "import_floor_ms": round(fresh["import_floor_ms"], 1),
        "fresh_process_over_import_floor": round(
            fresh["fresh_process_first_reset_ms"] / fresh["import_floor_ms"], 3
        ),
        "runner_over_physics": _r(obs_ratios[0], 3),
        "depth64_steps_per_s": None if depth is None else round(depth["steps_per_s"], 1),
        "depth64_over_state": None if depth is None else round(depth["steps_per_s"] / obs_rates[0], 3),
        "runner_envs": [1, N_VEC, 8],
        "runner_envs_steps_per_s": [round(one, 1), round(v2, 1), round(v8, 1)],
        "runner_obs": labels,
        "runner_obs_steps_per_s": [_r(r, 1) for r in obs_rates],
        "runner_obs_physics_floor_ratio": [_r(q, 3) for q in obs_ratios],
        **({"runner_obs_note": "; ".join(notes)} if notes else {}),
        "metadrive_steps_per_s": None if md is None else round(md, 1),
        "navstatic_vs_metadrive_cpu": None if md is None else round(state["cpu_with_resets_per_s"] / md, 3),
        **{k: v for k, v in orca.items() if not isinstance(v, dict | list)},
        **loco,
    }
    print(json.dumps(figures))
    return 0


if __name__ == "__main__":
    sys.exit(main())
