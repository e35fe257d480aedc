"""Where exporting spends its time: each step's share, and the hotspot inside it.

    python benchmarks/profile_export.py [--scenes N] [--no-city]

Two pipelines, the two that issue 7 sets targets on:

- ``export-mjcf15``: a 15 m x 15 m scene with terrain and 8 objects (the Urban-Nav test
  size) to MJCF and compiled by MuJoCo, over ``--scenes`` seeds. Steps: ``export``
  (:func:`citygen.exporters.mjcf.export`: the MJCF text, the meshes, the files) and
  ``compile`` (``mujoco.MjModel.from_xml_path``).
- ``export-usd-city``: ``urban-tra-city`` scene 0 to usdc (its generation is not counted).
  Steps: ``export`` (:func:`citygen.exporters.usd.export`), ``open`` (``Usd.Stage.Open``).

Each step is timed in CPU seconds without a profiler, then profiled with ``cProfile``; the
top function is the costliest citygen or exporters function below the step's entry point,
as a share of the pipeline (a hotspot is above 20 %). The last line is one JSON object in
the shape of ``profile_generate.py``'s: ``<pipeline>_cpu_ms_per_scene``,
``<pipeline>_<step>_share``, ``<pipeline>_slowest_stage``, ``<pipeline>_top_function``,
``<pipeline>_top_function_share``.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import sys
import tempfile
import time
import warnings
from collections import defaultdict
from collections.abc import Callable
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))
sys.path.insert(0, str(Path(__file__).resolve().parent))

from profile_generate import HOTSPOT, short

from citygen.exporters import ExportWarning
from citygen.spec.scene import Scene

OWN = ("citygen/", "exporters/")
"""Path prefixes of citygen's own code in the shortened function names."""


def top_function(prof: cProfile.Profile, floor: float) -> tuple[str, float]:
    """The hotspot of a profiled step and its share of the step (shares of the step, so the
    profiler's overhead cancels): the deepest own function (least cumulative time) that
    still costs at least ``floor`` of the step, else the costliest one below the entry."""
    stats = pstats.Stats(prof).stats  # func -> (cc, nc, tt, ct, callers)
    total = max((v[3] for v in stats.values()), default=0.0)
    rows = sorted(((short(f), v[3]) for f, v in stats.items()), key=lambda r: r[1], reverse=True)
    own = [(n, s / total) for n, s in rows[1:] if n.startswith(OWN)] if total else []
    above = [r for r in own if r[1] >= floor]
    return above[-1] if above else own[0] if own else ("", 0.0)


class Steps:
    """CPU seconds per step (no profiler) and one profiler per step."""

    def __init__(self) -> None:
        self.cpu: dict[str, float] = defaultdict(float)
        self.profiles: dict[str, cProfile.Profile] = defaultdict(cProfile.Profile)

    def time(self, step: str, fn: Callable, *args, **kwargs):
        t = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            self.cpu[step] += time.process_time() - t

    def profile(self, step: str, fn: Callable, *args, **kwargs):
        prof = self.profiles[step]
        prof.enable()
        try:
            return fn(*args, **kwargs)
        finally:
            prof.disable()


def figures_of(label: str, steps: Steps, n: int) -> dict[str, float | str]:
    total = sum(steps.cpu.values())
    ranked = sorted(steps.cpu.items(), key=lambda kv: kv[1], reverse=True)
    out: dict[str, float | str] = {f"{label}_cpu_ms_per_scene": round(1000 * total / n, 2)}
    for step, s in ranked:
        out[f"{label}_{step}_share"] = round(s / total, 3)
    out[f"{label}_slowest_stage"] = ranked[0][0]
    worst = ("", 0.0)
    for step, s in ranked:
        if step in steps.profiles:
            name, frac = top_function(steps.profiles[step], HOTSPOT * total / s)
            if frac * s / total > worst[1]:
                worst = (name, frac * s / total)
    out[f"{label}_top_function"] = worst[0]
    out[f"{label}_top_function_share"] = round(worst[1], 3)
    print(f"\n{label}: {1000 * total / n:.1f} ms CPU a scene")
    for step, s in ranked:
        print(f"  {step:<10} {1000 * s / n:>9.2f} ms {s / total:>7.1%}")
    print(f"  top function: {worst[1]:.1%} {worst[0]}")
    return out


def mjcf15(count: int) -> dict[str, float | str]:
    import mujoco

    from citygen.exporters import mjcf
    from citygen.generate import generate
    from citygen.spec.config import GeneratorConfig, PlacementConfig

    config = GeneratorConfig(size=(15.0, 15.0), placement=PlacementConfig(count=8))
    scenes = [generate(config, seed) for seed in range(count)]
    steps = Steps()
    with tempfile.TemporaryDirectory() as tmp:
        mjcf.export(scenes[0], Path(tmp) / "warm")
        for run in (steps.time, steps.profile):
            for k, scene in enumerate(scenes):
                files = run("export", mjcf.export, scene, Path(tmp) / f"{run.__name__}{k}")
                run("compile", mujoco.MjModel.from_xml_path, str(files[0]))
    return figures_of("export-mjcf15", steps, count)


def usd_city() -> dict[str, float | str]:
    import citygen
    from citygen.exporters import usd

    scene: Scene = citygen.generate("urban-tra-city")
    steps = Steps()
    with tempfile.TemporaryDirectory() as tmp:
        from pxr import Usd

        for run in (steps.time, steps.profile):
            files = run("export", usd.export, scene, Path(tmp) / run.__name__, format="usdc")
            stage = run("open", Usd.Stage.Open, str(files[0]))
            del stage
    return figures_of("export-usd-city", steps, 1)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=20, help="15 m scenes for export-mjcf15")
    parser.add_argument("--no-city", action="store_true", help="skip the urban-tra-city export")
    args = parser.parse_args()
    warnings.simplefilter("ignore", ExportWarning)
    figures: dict[str, float | str] = {"bench": "profile-export"}
    figures.update(mjcf15(args.scenes))
    if not args.no_city:
        figures.update(usd_city())
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
