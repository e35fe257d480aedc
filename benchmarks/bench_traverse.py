"""The Traverse environment at city scale (issue 45): reset and step on a town of
urban-tra-city's config (its streets, signals, people and vehicles on a ninth of its area:
400 m x 400 m, 22 people, 3 vehicles, a 300 m route) and, with ``--city``, on the 1.2 km city
itself; the quadruped on the ideal-locomotion servo, driving ahead.

Figures: the first reset (the scene prepared: MJCF, compile, maps; no on-disk store; a
town's and a city's maps and crowd path tables made in a second process meanwhile,
:mod:`citygen.runner.scene_maps`, so on two cores the figure is the model's time), with
its CPU time in this process (``*_cpu_s``) and in that second one (``*_second_cpu_s``), a
reset from the on-disk store of prepared scenes (a second process's first visit), the
environment's step (ms, 0.1 s of simulated time), its real-time factor, and the baselines
measured in the same run: ``mj_step`` alone for the same 0.1 s of the same model (what
the physics costs, from the last step's state with the servo's forces held; the step over it
is the runner's share; ``*_mj_step_reach_ms``: the same with collisions restricted to the
robot's reach, as the environment steps it) and the step with the servo
casting its ground rays through the scene (``handle.terrain = None``: the runner before the
5 cm ground raster in tiles, :mod:`citygen.runner.ground`) and the step with every static geom
in MuJoCo's collision detection (``*_whole_*``: the runner before collisions were restricted to
the robot's reach, :mod:`citygen.runner.envs.reach`; ``*_static_geoms_kept``: how many of them
the reach keeps; a town's and a city's fused models are now stepped whole, the reach None,
and these figures repeat the step's), with their ratios.

``python benchmarks/bench_traverse.py [--steps 200] [--city] [--city-steps 50]`` (a few minutes
for the town on 2 cores; the city's first reset adds several, its steps are timed over
``--city-steps``); the last line is one JSON object of figures.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time

import numpy as np

os.environ.setdefault("MUJOCO_GL", "egl")


def _children_cpu() -> float:
    """CPU time (s) of this process's ended children: a first reset's second process."""
    import resource

    usage = resource.getrusage(resource.RUSAGE_CHILDREN)
    return usage.ru_utime + usage.ru_stime


def measure(label: str, scene, steps: int, robot: str) -> dict:
    """Reset (cold, then from the on-disk store) and step figures of Traverse on ``scene``."""
    import mujoco

    from citygen.runner.envs import base
    from citygen.runner.make import make_env
    from citygen.runner.scenes import SceneCache

    out: dict = {}
    with tempfile.TemporaryDirectory() as store:
        os.environ["CITYGEN_CACHE_DIR"] = store
        for kind in ("cold", "stored"):
            cache = SceneCache()  # each a first visit in this process
            base.process_cache = lambda cache=cache: cache
            # from the store, a copy of the scene, as a second process would hold: what is
            # kept per scene object (the terrain features' index) starts empty
            here = scene if kind == "cold" else type(scene).model_validate_json(scene.model_dump_json())
            env = make_env("traverse", scene=here, robot=robot)
            t, cpu, child = time.perf_counter(), time.process_time(), _children_cpu()
            env.reset(seed=0)
            out[f"{label}_reset_{kind}_s"] = time.perf_counter() - t
            out[f"{label}_reset_{kind}_cpu_s"] = time.process_time() - cpu
            out[f"{label}_reset_{kind}_second_cpu_s"] = _children_cpu() - child
            if kind == "cold":
                env.close()
    u = env.unwrapped
    action = np.zeros(env.action_space.shape, dtype=np.float32)
    action[0] = 0.8
    for _ in range(10):  # warm-up: the first tiles of ground, the agents' first plans
        env.step(action)
    t = time.perf_counter()
    for _ in range(steps):
        env.step(action)
    step = (time.perf_counter() - t) / steps
    terrain, u.handle.terrain = u.handle.terrain, None  # the servo's rays through the scene
    t = time.perf_counter()
    for _ in range(steps):
        env.step(action)
    rays = (time.perf_counter() - t) / steps
    u.handle.terrain = terrain
    reach, u._reach = u._reach, None  # every static geom in collision detection
    t = time.perf_counter()
    for _ in range(steps):
        env.step(action)
    whole = (time.perf_counter() - t) / steps
    u._reach = reach
    model, data = u.model, mujoco.MjData(u.model)
    mujoco.mj_copyData(data, model, u.data)  # the last step's state and forces (the servo's held)
    substeps = max(1, round(u.dt / model.opt.timestep))
    t = time.perf_counter()
    for _ in range(steps):
        mujoco.mj_step(model, data, nstep=substeps)
    physics = (time.perf_counter() - t) / steps
    near_physics = None
    if reach is not None:  # the same with the static geoms the reach leaves out
        mujoco.mj_copyData(data, model, u.data)
        t = time.perf_counter()
        for _ in range(steps):
            with reach.near(data):
                mujoco.mj_step(model, data, nstep=substeps)
        near_physics = (time.perf_counter() - t) / steps
    env.close()
    out.update(
        {
            f"{label}_ngeom": int(model.ngeom),
            f"{label}_nbody": int(model.nbody),
            f"{label}_step_ms": step * 1e3,
            f"{label}_realtime_factor": u.dt / step,
            f"{label}_mj_step_ms": physics * 1e3,
            f"{label}_step_over_mj_step": step / physics,
            f"{label}_mj_step_reach_ms": None if near_physics is None else near_physics * 1e3,
            f"{label}_rays_step_ms": rays * 1e3,
            f"{label}_rays_over_tiles": rays / step,
            f"{label}_whole_step_ms": whole * 1e3,
            f"{label}_whole_over_reach": whole / step,
            f"{label}_static_geoms_kept": None if reach is None else reach.kept,
        }
    )
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=int, default=200)
    parser.add_argument("--robot", default="quadruped")
    parser.add_argument("--city", action="store_true", help="the 1.2 km city too")
    parser.add_argument("--city-steps", type=int, default=50, help="steps per figure on the city")
    args = parser.parse_args()

    import citygen
    from citygen.generate import generate
    from citygen.generate.splits import town_config
    from citygen.seeding import scene_seed

    figures: dict = {"steps": args.steps, "robot": args.robot}
    if args.city:
        figures["city_steps"] = args.city_steps
    scenes = {"town": generate(town_config(), scene_seed(2025, "urban-tra-city", 0))}
    if args.city:
        scenes["city"] = citygen.generate("urban-tra-city")
    for label, scene in scenes.items():
        figures.update(measure(label, scene, args.city_steps if label == "city" else args.steps, args.robot))
        print(
            f"{label}: reset {figures[f'{label}_reset_cold_s']:.1f} s cold, "
            f"{figures[f'{label}_reset_stored_s']:.1f} s stored; step {figures[f'{label}_step_ms']:.1f} ms "
            f"({figures[f'{label}_realtime_factor']:.1f}x real time; mj_step "
            f"{figures[f'{label}_mj_step_ms']:.1f} ms; with rays {figures[f'{label}_rays_step_ms']:.1f} ms; "
            f"every static geom collidable {figures[f'{label}_whole_step_ms']:.1f} ms)",
            flush=True,
        )
        print(
            f"{label}: cold reset's CPU {figures[f'{label}_reset_cold_cpu_s']:.1f} s in this process, "
            f"{figures[f'{label}_reset_cold_second_cpu_s']:.1f} s in a second one",
            flush=True,
        )
    print(json.dumps({k: round(v, 4) if isinstance(v, float) else v for k, v in figures.items()}))


if __name__ == "__main__":
    main()
