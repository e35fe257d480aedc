"""Where generation spends its time: each pipeline stage's share, and the hotspots inside it.

    python benchmarks/profile_generate.py [--scenes N] [--no-city] [--out DIR] [--pyinstrument]

Three pipelines are profiled: an Urban-Nav train scene (``urban-nav-3-train``: region,
terrain, 4 objects, 2 people, a nav task), an Urban-Nav test scene (``urban-nav-3-test``)
and scene 0 of ``urban-tra-city`` (1,200 m x 1,200 m of road blocks). A Urban-Nav scene
takes tens of milliseconds, so its figures are over ``--scenes`` scenes (indices 256 and
up, outside the published dataset, after a few scenes of warm-up).

For each pipeline the script

1. times every stage with a wall clock, without a profiler (stage shares of the pipeline);
2. runs the same scenes again under ``cProfile``, one profiler per stage, and writes
   ``DIR/<pipeline>.txt``: per stage, the functions that cost the most, by cumulative and
   by own time, each as a share of the whole pipeline (a hotspot is a function above 20 %);
3. with ``--pyinstrument`` (``pip install pyinstrument``), also writes
   ``DIR/<pipeline>.pyinstrument.txt``, a call tree of the whole pipeline.

The stages are the functions :func:`citygen.generate.pipeline.generate` and the layouts it
dispatches to (:mod:`citygen.generate.layouts`) call, wrapped for the run in every generator
module that calls them (the code itself is unchanged); ``serialise`` is :func:`citygen.io.dumps`. The
last line is one JSON object of the figures.
"""

from __future__ import annotations

import argparse
import cProfile
import json
import pstats
import sys
import time
import warnings
from collections import defaultdict
from collections.abc import Callable
from contextlib import contextmanager
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

import citygen.generate.layouts  # noqa: F401  (the layouts call most stage functions)
from citygen.assets import resolve
from citygen.generate.splits import generate_scene, splits
from citygen.io import dumps

#: The functions generate() and the layouts call, by stage name.
STAGES = {
    "blocks": "connect_blocks",
    "ground": "plan_ground",
    "region": "plan_region",
    "walkable": "walkable_ground",
    "endpoints": "choose_endpoints",
    "terrain": "build_terrain",
    "placement": "place_objects",
    "agents": "place_agents",
    "task": "make_task",
}
HOTSPOT = 0.20
"""A function costing more than this share of its pipeline is a hotspot."""
PIPELINES = {
    "nav-train": ("urban-nav-3-train", 256),
    "nav-test": ("urban-nav-3-test", 256),
    "tra-city": ("urban-tra-city", 0),
}


def _callers() -> list:
    """The generator's modules (the pipeline and the layouts) that call stage functions."""
    return [m for name, m in sorted(sys.modules.items()) if name.startswith("citygen.generate") and m]


@contextmanager
def wrapped(hook: Callable[[str, Callable, tuple, dict], object]):
    """Replace each stage function, in every generator module that names it, by
    ``hook(stage, fn, args, kwargs)``."""
    saved = []
    for stage, name in STAGES.items():
        for module in _callers():
            with warnings.catch_warnings():  # the old module paths kept for a release warn
                warnings.simplefilter("ignore", DeprecationWarning)
                fn = getattr(module, name, None)
            if not callable(fn) or getattr(fn, "__module__", "") == __name__:
                continue
            saved.append((module, name, fn))

            def call(*args, _stage=stage, _fn=fn, **kwargs):
                return hook(_stage, _fn, args, kwargs)

            setattr(module, name, call)
    try:
        yield
    finally:
        for module, name, fn in saved:
            setattr(module, name, fn)


def make(split_name: str, indices: range, hook) -> float:
    """Generate and serialise scenes ``indices`` of a split under ``hook``; wall seconds."""
    split = splits()[split_name]
    t0 = time.perf_counter()
    with wrapped(hook):
        for i in indices:
            scene = generate_scene(split, i)
            hook("serialise", dumps, (scene,), {})
    return time.perf_counter() - t0


def cold() -> None:
    """Forget the assets resolved so far: a scene draws its variants at random from 10,000
    per category, so in a long run almost every asset a scene uses is new to the process."""
    resolve.cache_clear()


def stage_times(split_name: str, indices: range) -> tuple[float, float, dict[str, float]]:
    """Wall and CPU seconds of the whole run, and CPU seconds of each stage (no profiler;
    CPU time of this process, which other work on a shared machine disturbs less)."""
    spent: dict[str, float] = defaultdict(float)

    def hook(stage, fn, args, kwargs):
        t = time.process_time()
        try:
            return fn(*args, **kwargs)
        finally:
            spent[stage] += time.process_time() - t

    cold()
    cpu = time.process_time()
    wall = make(split_name, indices, hook)
    cpu = time.process_time() - cpu
    spent["other"] = max(0.0, cpu - sum(spent.values()))
    return wall, cpu, dict(spent)


def stage_profiles(split_name: str, indices: range) -> dict[str, cProfile.Profile]:
    """One cProfile per stage over the same scenes."""
    profiles: dict[str, cProfile.Profile] = defaultdict(cProfile.Profile)

    def hook(stage, fn, args, kwargs):
        prof = profiles[stage]
        prof.enable()
        try:
            return fn(*args, **kwargs)
        finally:
            prof.disable()

    cold()
    make(split_name, indices, hook)
    return dict(profiles)


def short(func: tuple[str, int, str]) -> str:
    """``package/module.py:line(name)`` for citygen, exporters and installed code."""
    path, line, name = func
    if path == "~":
        return name
    parts = Path(path).parts
    for root in ("exporters", "citygen", "site-packages"):
        if root in parts:
            at = len(parts) - 1 - parts[::-1].index(root)
            path = "/".join(parts[at + (root == "site-packages") :])
            break
    return f"{path}:{line}({name})"


def hotspots(prof: cProfile.Profile, key: int, top: int) -> list[tuple[str, float, float]]:
    """``(function, seconds, share of the stage)`` of the ``top`` functions by ``key`` (2: own
    time, 3: cumulative time); shares of the profiled stage, so the profiler's overhead cancels."""
    stats = pstats.Stats(prof).stats  # func -> (cc, nc, tt, ct, callers)
    stage_s = max((v[3] for v in stats.values()), default=0.0)
    rows = sorted(stats.items(), key=lambda kv: kv[1][key], reverse=True)[:top]
    return [(short(f), v[key], v[key] / stage_s if stage_s else 0.0) for f, v in rows]


def report(
    label: str, split_name: str, indices: range, out: Path, use_pyinstrument: bool, top: int
) -> dict[str, float | str]:
    """Profile one pipeline, write its summary, print its table; its figures."""
    wall, total, spent = stage_times(split_name, indices)
    n = len(indices)
    profiles = stage_profiles(split_name, indices)
    lines = [f"# {label}: {split_name} scenes {indices.start}..{indices.stop - 1}", ""]
    lines.append(
        f"{n} scene(s): wall {wall:.3f} s, CPU {total:.3f} s, {1000 * total / n:.1f} ms CPU a scene "
        "(no profiler)"
    )
    lines.append("")
    lines.append(f"{'stage':<12} {'CPU ms/scene':>12} {'share':>7}")
    ranked = sorted(spent.items(), key=lambda kv: kv[1], reverse=True)
    for stage, s in ranked:
        lines.append(f"{stage:<12} {1000 * s / n:>12.2f} {s / total:>7.1%}")
    figures: dict[str, float | str] = {
        f"{label}_cpu_ms_per_scene": round(1000 * total / n, 2),
        f"{label}_wall_ms_per_scene": round(1000 * wall / n, 2),
    }
    for stage, s in ranked:
        figures[f"{label}_{stage}_share"] = round(s / total, 3)
    slowest = ranked[0][0]
    figures[f"{label}_slowest_stage"] = slowest
    worst = (0.0, "")
    for stage, _ in ranked:
        if stage not in profiles:
            continue
        share = spent[stage] / total
        # Within-stage shares of the profile, scaled to the stage's share of the pipeline.
        cum = hotspots(profiles[stage], 3, top)
        own = hotspots(profiles[stage], 2, top)
        lines += [
            "",
            f"## {stage}: {share:.1%} of the pipeline",
            "",
            "by cumulative time (share of pipeline):",
        ]
        lines += [f"  {share * frac:>6.1%}  {name}" for name, _, frac in cum]
        lines += ["by own time (share of pipeline):"]
        lines += [f"  {share * frac:>6.1%}  {name}" for name, _, frac in own]
        # The costliest citygen function below the stage's entry point, by cumulative time.
        inner = [(share * frac, name) for name, _, frac in cum[1:] if name.startswith("citygen/")]
        if inner and inner[0][0] > worst[0]:
            worst = inner[0]
    figures[f"{label}_top_function"] = worst[1]
    figures[f"{label}_top_function_share"] = round(worst[0], 3)
    text = "\n".join(lines) + "\n"
    out.mkdir(parents=True, exist_ok=True)
    (out / f"{label}.txt").write_text(text)
    if use_pyinstrument:
        from pyinstrument import Profiler

        profiler = Profiler(interval=0.0005)
        cold()
        with profiler:
            make(split_name, indices, lambda stage, fn, args, kwargs: fn(*args, **kwargs))
        (out / f"{label}.pyinstrument.txt").write_text(profiler.output_text(unicode=False, color=False))
    print(f"\n{label} ({split_name}, {n} scene(s)): {1000 * total / n:.1f} ms CPU a scene")
    for stage, s in ranked:
        print(f"  {stage:<12} {1000 * s / n:>9.2f} ms {s / total:>7.1%}")
    placed = [ln for ln in lines if ln.startswith(f"## {slowest}")]
    at = lines.index(placed[0]) if placed else len(lines)
    print("  slowest stage, top functions by cumulative time:")
    for ln in lines[at + 3 : at + 3 + min(top, 8)]:
        print("  " + ln)
    return figures


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scenes", type=int, default=60, help="Urban-Nav scenes per pipeline")
    parser.add_argument("--no-city", action="store_true", help="skip urban-tra-city scene 0")
    parser.add_argument("--out", type=Path, default=Path("/tmp/citygen-profile"), help="summary folder")
    parser.add_argument("--pyinstrument", action="store_true", help="also write pyinstrument call trees")
    parser.add_argument("--top", type=int, default=15, help="functions listed per stage")
    args = parser.parse_args()
    figures: dict[str, float | str] = {"bench": "profile"}
    for label, (name, start) in PIPELINES.items():
        if label == "tra-city" and args.no_city:
            continue
        count = 1 if label == "tra-city" else args.scenes
        if label != "tra-city":  # warm-up: imports, lazily built tables
            make(name, range(start + 10_000, start + 10_005), lambda stage, fn, a, k: fn(*a, **k))
        figures.update(
            report(label, name, range(start, start + count), args.out, args.pyinstrument, args.top)
        )
    print(f"\nsummaries in {args.out}/")
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
