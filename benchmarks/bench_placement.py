"""Placement benchmark: 10,000 objects in a city-scale scene, against textbook rejection sampling.

What is measured
    1. ``place_objects`` (stage 4) placing 10,000 catalog objects (plus a building in every
       lot) over a 1,200 m x 1,200 m road network's zones: wall clock and CPU time of this
       process (compare CPU time when the machine is shared), objects placed, and the
       target of the issue (<= 20 s).
    2. The same stage and :func:`naive_place` below on a 400 m x 400 m network with 1,000
       objects: the textbook way (a random point in the bounds, a random asset and heading,
       accepted when the union of the zones its category suits covers its base and its
       distance to *every* placed object is at least the clearance). The ratio of CPU time
       per placed object is the speed-up; the naive way is quadratic, so it is measured at
       the smaller size only.

Run: ``python benchmarks/bench_placement.py`` (about a minute on 2 cores). The last line is
one JSON object of the figures.
"""

from __future__ import annotations

import json
import math
import sys
import time
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import Polygon

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from citygen.assets import CATEGORIES, resolve
from citygen.generate.pipeline import layout
from citygen.generate.placement import place_objects
from citygen.seeding import stage_rng
from citygen.spec.config import BlocksConfig, GeneratorConfig, PlacementConfig

CITY = GeneratorConfig(size=(1200.0, 1200.0), layout="blocks", blocks=BlocksConfig(count=120))
SMALL = GeneratorConfig(size=(400.0, 400.0), layout="blocks", blocks=BlocksConfig(count=15))
SEED = 3


def timed(fn, *args, **kwargs):
    wall, cpu = time.perf_counter(), time.process_time()
    out = fn(*args, **kwargs)
    return out, time.perf_counter() - wall, time.process_time() - cpu


def naive_place(scene, count: int, rng: np.random.Generator, clearance: float = 0.5) -> int:
    """Textbook rejection sampling; returns how many objects it placed (at most ``count``)."""
    names = [n for n in sorted(CATEGORIES) if CATEGORIES[n].anchor != "lot"]
    polys = [(Polygon(z.polygon, z.holes), z.kind) for z in scene.zones]
    regions = {}
    for n in names:
        kinds = CATEGORIES[n].zones
        regions[n] = shapely.union_all([p for p, k in polys if k in kinds])
    placed: list[Polygon] = []
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    tries = 0
    while len(placed) < count and tries < 200 * count:
        tries += 1
        name = names[int(rng.integers(len(names)))]
        asset = resolve(f"{name}/{int(rng.integers(6)):04d}")
        x, y, yaw = rng.uniform(x0, x1), rng.uniform(y0, y1), rng.uniform(-math.pi, math.pi)
        c, s = math.cos(yaw), math.sin(yaw)
        ring = np.asarray(asset.base.exterior.coords) @ np.array([[c, s], [-s, c]]) + (x, y)
        base = Polygon(ring)
        if not regions[name].covers(base):
            continue
        gap = max(clearance, asset.clearance)
        if all(base.distance(o) >= gap for o in placed):
            placed.append(base)
    return len(placed)


def main() -> None:
    figures: dict[str, float] = {}
    print("placement benchmark (stage 4)\n")

    small, _, _ = timed(layout, SMALL, SEED)
    cfg = PlacementConfig(count=1000)
    ours, wall, cpu = timed(place_objects, small.bounds, small.zones, None, cfg, stage_rng(SEED, "placement"))
    furniture = sum(not p.asset.startswith("building/") for p in ours)
    naive, nwall, ncpu = timed(naive_place, small, 1000, np.random.default_rng(SEED))
    ours_per = cpu / max(furniture, 1)
    naive_per = ncpu / max(naive, 1)
    print(f"{'400 m, 1,000 objects':<32} {'placed':>7} {'wall s':>8} {'cpu s':>8} {'cpu ms/object':>14}")
    print(f"{'  citygen place_objects':<32} {furniture:>7} {wall:>8.2f} {cpu:>8.2f} {1000 * ours_per:>14.3f}")
    print(
        f"{'  naive rejection sampling':<32} {naive:>7} {nwall:>8.2f} {ncpu:>8.2f} {1000 * naive_per:>14.3f}"
    )
    print(f"  speed-up (cpu per object): {naive_per / ours_per:.1f}x\n")
    figures.update(
        small_objects=furniture,
        small_cpu_s=round(cpu, 3),
        naive_objects=naive,
        naive_cpu_s=round(ncpu, 3),
        speedup_vs_naive=round(naive_per / ours_per, 2),
    )

    city, lwall, _ = timed(layout, CITY, SEED)
    cfg = PlacementConfig(count=10_000)
    placed, wall, cpu = timed(place_objects, city.bounds, city.zones, None, cfg, stage_rng(SEED, "placement"))
    furniture = sum(not p.asset.startswith("building/") for p in placed)
    print(f"1,200 m city: {len(city.blocks)} blocks, {len(city.zones)} zones (layout {lwall:.1f} s wall)")
    print(f"  placed {furniture} objects + {len(placed) - furniture} buildings")
    print(f"  wall {wall:.2f} s, cpu {cpu:.2f} s (target <= 20 s): {'met' if wall <= 20 else 'NOT met'}")
    figures.update(
        city_objects=furniture,
        city_buildings=len(placed) - furniture,
        city_wall_s=round(wall, 3),
        city_cpu_s=round(cpu, 3),
    )
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
