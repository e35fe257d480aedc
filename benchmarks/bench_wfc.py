"""WFC benchmark: citygen's solver against a straightforward pure-Python WFC, and the
terrain stage's guarantees over 10,000 seeds.

What is measured
    1. Solve time of the mixed-terrain tileset (22 variants: flat and rough tiles at 3
       levels, slope and stair flights in 4 rotations across 2 level boundaries; no pins)
       on square grids of 16, 32, 64 and 128 tiles a side: the median of several seeds,
       wall clock and CPU time of this process (the CPU time is what to compare when the
       machine is shared).
    2. The same tileset and weights solved by :func:`naive_wfc` below, the textbook
       implementation (a Python set per cell, a scan of every cell for the lowest entropy
       at each step, propagation by set comprehension, a restart on contradiction), at the
       same sizes up to 64; the ratio of medians is the speed-up.
    3. ``build_terrain`` on a 32 x 32 mixed grid (80 m x 80 m, the default config) for
       seeds 0 .. 9,999, in 2 worker processes: contradictions left unresolved (raised
       errors), pairs of neighbours whose shared edges disagree (``profiles_match``),
       parameters outside their configured range, and each kind's share of all tiles
       against its mix weight.
    4. ``build_terrain`` over a 1,200 m x 1,200 m city without zones (480 x 480 tiles) in a
       fresh process: time and peak resident memory.

Run: ``python benchmarks/bench_wfc.py`` (about 2 to 3 minutes on 2 cores). The last line
is one JSON object of the figures.
"""

from __future__ import annotations

import json
import math
import multiprocessing
import resource
import statistics
import sys
import time
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent.parent))

from citygen.generate.terrain import KINDS, build_terrain, terrain_tileset
from citygen.generate.wfc import Tileset, check, solve
from citygen.seeding import stage_rng
from citygen.spec.config import TerrainConfig
from citygen.spec.scene import Bounds
from citygen.spec.terrain import SIDES, RoughTile, SlopeTile, StairTile, edge_profile, profiles_match

SIZES = (16, 32, 64, 128)
RUNS = {16: 21, 32: 15, 64: 11, 128: 5}
NAIVE_RUNS = {16: 5, 32: 3, 64: 1}
SEEDS = 10_000
OFFSETS = ((1, 0), (0, 1), (-1, 0), (0, -1))  # north, east, south, west


# --- the baseline --------------------------------------------------------------------------


def naive_wfc(
    ts: Tileset, rows: int, cols: int, rng: np.random.Generator, max_restarts: int = 100
) -> np.ndarray:
    """Textbook WFC: sets of variants, a full scan for the lowest entropy, restarts."""
    n = len(ts)
    weights = np.diff(np.concatenate([[0.0], ts.distribution((1 << n) - 1)[2]])).tolist()
    allowed = [[set(np.flatnonzero(ts.allowed[d, a]).tolist()) for a in range(n)] for d in range(4)]
    for _ in range(max_restarts):
        cells = [[set(range(n)) for _ in range(cols)] for _ in range(rows)]
        ok = True
        while ok:
            best, pick = math.inf, None
            for r in range(rows):
                for c in range(cols):
                    dom = cells[r][c]
                    if len(dom) > 1:
                        w = [weights[v] for v in dom]
                        total = sum(w)
                        h = -sum(x / total * math.log(x / total) for x in w if x > 0) + 1e-6 * rng.random()
                        if h < best:
                            best, pick = h, (r, c)
            if pick is None:
                return np.array([[next(iter(d)) for d in row] for row in cells])
            r, c = pick
            options = sorted(cells[r][c])
            p = np.array([weights[v] for v in options])
            cells[r][c] = {options[int(rng.choice(len(options), p=p / p.sum()))]}
            stack = [(r, c)]
            while stack and ok:
                r, c = stack.pop()
                for d, (dr, dc) in enumerate(OFFSETS):
                    rr, cc = r + dr, c + dc
                    if 0 <= rr < rows and 0 <= cc < cols:
                        supported = set().union(*(allowed[d][a] for a in cells[r][c]))
                        new = cells[rr][cc] & supported
                        if new != cells[rr][cc]:
                            if not new:
                                ok = False
                                break
                            cells[rr][cc] = new
                            stack.append((rr, cc))
    raise RuntimeError("naive WFC: too many restarts")


# --- timing -------------------------------------------------------------------------------------


def timed(fn, runs: int) -> tuple[float, float]:
    """Median wall and CPU milliseconds of ``fn(seed)`` over seeds 0 .. runs - 1."""
    wall, cpu = [], []
    for seed in range(runs):
        w0, c0 = time.perf_counter(), time.process_time()
        fn(seed)
        wall.append(time.perf_counter() - w0)
        cpu.append(time.process_time() - c0)
    return 1000 * statistics.median(wall), 1000 * statistics.median(cpu)


# --- the 10,000-seed property check ----------------------------------------------------------


def check_seeds(seeds: range) -> dict:
    cfg = TerrainConfig()
    bounds = Bounds(min=(0.0, 0.0), max=(80.0, 80.0))
    ranges = {
        SlopeTile: (("angle", cfg.slope_angle),),
        StairTile: (("step_height", cfg.step_height), ("step_count", cfg.step_count)),
        RoughTile: (("amplitude", cfg.roughness_amplitude), ("scale", cfg.roughness_scale)),
    }
    kinds: Counter = Counter()
    errors = mismatched = outside = 0
    agree: dict[tuple, bool] = {}  # profiles_match of each distinct pair of edge profiles
    for seed in seeds:
        try:
            t = build_terrain(bounds, (), cfg, stage_rng(seed, "terrain"), seed=seed)
        except Exception:
            errors += 1
            continue
        prof = {id(x): {s: edge_profile(x, s, t.tile_size) for s in SIDES} for x in t.tiles}
        for r in range(t.rows):
            for c in range(t.cols):
                here = prof[id(t.tile(r, c))]
                pairs = []
                if c + 1 < t.cols:
                    pairs.append((here["east"], prof[id(t.tile(r, c + 1))]["west"]))
                if r + 1 < t.rows:
                    pairs.append((here["north"], prof[id(t.tile(r + 1, c))]["south"]))
                for pair in pairs:
                    ok = agree.get(pair)
                    if ok is None:
                        ok = agree[pair] = profiles_match(*pair)
                    mismatched += not ok
        for x in {id(x): x for x in t.tiles}.values():
            outside += sum(not lo <= getattr(x, f) <= hi for f, (lo, hi) in ranges.get(type(x), ()))
        kinds.update(x.kind for x in t.tiles)
    return {"kinds": kinds, "errors": errors, "mismatched": mismatched, "outside": outside}


def city() -> tuple[float, float]:
    w0 = time.perf_counter()
    build_terrain(Bounds(min=(0.0, 0.0), max=(1200.0, 1200.0)), (), TerrainConfig(), stage_rng(1, "terrain"))
    return time.perf_counter() - w0, resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def main() -> None:
    ts = terrain_tileset().tileset
    print(f"mixed-terrain tileset: {len(ts)} variants ({ts._reduced().n} classes of interchangeable ones)")
    ours: dict[int, tuple[float, float]] = {}
    naive: dict[int, tuple[float, float]] = {}
    for size in SIZES:
        solve(ts, size, size, np.random.default_rng(99))  # warm the caches
        ours[size] = timed(lambda s, n=size: check(ts, solve(ts, n, n, np.random.default_rng(s))), RUNS[size])
        if size in NAIVE_RUNS:
            naive[size] = timed(
                lambda s, n=size: naive_wfc(ts, n, n, np.random.default_rng(s)), NAIVE_RUNS[size]
            )
    print(
        f"\n{'grid':>9} {'citygen ms':>11} {'(cpu ms)':>9} {'naive ms':>10} {'(cpu ms)':>9} {'speed-up':>9}"
    )
    for size in SIZES:
        (w, c), nv = ours[size], naive.get(size)
        extra = f"{nv[0]:10.1f} {nv[1]:9.1f} {nv[0] / w:8.0f}x" if nv else f"{'-':>10} {'-':>9} {'-':>9}"
        print(f"{size:>4}x{size:<4} {w:11.2f} {c:9.2f} {extra}")

    w0 = time.perf_counter()
    chunks = [range(k, min(k + 500, SEEDS)) for k in range(0, SEEDS, 500)]
    with ProcessPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(check_seeds, chunks))
    with ProcessPoolExecutor(max_workers=1, mp_context=multiprocessing.get_context("spawn")) as pool:
        city_s, city_mb = pool.submit(city).result()
    kinds = sum((r["kinds"] for r in results), Counter())
    total = sum(kinds.values())
    errors = sum(r["errors"] for r in results)
    mismatched = sum(r["mismatched"] for r in results)
    outside = sum(r["outside"] for r in results)
    mix = TerrainConfig().mix
    weights = {k: getattr(mix, k) / sum(getattr(mix, j) for j in KINDS) for k in KINDS}
    dev = {k: 100 * (kinds[k] / total - weights[k]) for k in KINDS}
    print(f"\n32 x 32 mixed grids, seeds 0 .. {SEEDS - 1} ({time.perf_counter() - w0:.0f} s on 2 processes):")
    print(f"  unresolved contradictions {errors}, neighbour edges disagreeing {mismatched},")
    print(f"  parameters out of range {outside}")
    for k in KINDS:
        share = 100 * kinds[k] / total
        print(f"  {k:6} {share:5.1f} % of tiles (weight {100 * weights[k]:.1f} %, {dev[k]:+.2f} pp)")
    print(f"\n1,200 m x 1,200 m city, 480 x 480 tiles, no zones: {city_s:.2f} s, peak RSS {city_mb:.0f} MB")

    figures = {
        "wfc_variants": len(ts),
        **{f"wfc_{s}x{s}_ms": round(ours[s][0], 2) for s in SIZES},
        **{f"wfc_{s}x{s}_cpu_ms": round(ours[s][1], 2) for s in SIZES},
        **{f"naive_{s}x{s}_ms": round(naive[s][0], 1) for s in naive},
        "wfc_speedup_vs_naive": round(naive[64][0] / ours[64][0], 1),
        "terrain_seeds": SEEDS,
        "terrain_unresolved_contradictions": errors,
        "terrain_edge_mismatches": mismatched,
        "terrain_params_out_of_range": outside,
        "terrain_mix_max_abs_dev_pp": round(max(abs(v) for v in dev.values()), 2),
        "city_480x480_s": round(city_s, 2),
        "city_480x480_peak_rss_mb": round(city_mb, 1),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
