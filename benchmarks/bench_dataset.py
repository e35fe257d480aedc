"""The canonical 1,536-scene Urban-Nav dataset: wall time at --jobs 1 and --jobs 2, scenes/s,
and resident memory at the start and the end of a long in-process generation run.

    python benchmarks/bench_dataset.py [--rss-scenes N] [--city] [--skip-full]

Target (issue 6): the whole dataset in at most 30 s wall on a 2-core machine. The two runs
must write the same bytes (checked). ``--city`` also times one urban-tra-city scene (target
at most 60 s). The last line is one JSON object of the figures.
"""

from __future__ import annotations

import argparse
import json
import os
import tempfile
import time
from pathlib import Path

import citygen
from citygen.generate.dataset import sha256, write_dataset
from citygen.io import dumps


def rss_mb() -> float:
    """Resident set size of this process, in MiB (Linux /proc)."""
    pages = int(Path("/proc/self/statm").read_text().split()[1])
    return pages * os.sysconf("SC_PAGE_SIZE") / 2**20


def full_run(jobs: int) -> tuple[float, dict[str, str]]:
    with tempfile.TemporaryDirectory(prefix="bench-dataset-") as tmp:
        t = time.perf_counter()
        written = write_dataset(tmp, jobs=jobs)
        wall = time.perf_counter() - t
        return wall, {w.path: w.sha256 for w in written}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rss-scenes", type=int, default=1000, help="scenes for the memory run")
    parser.add_argument("--city", action="store_true", help="also time one urban-tra-city scene")
    parser.add_argument("--skip-full", action="store_true", help="skip the two full dataset runs")
    args = parser.parse_args()
    figures: dict[str, float] = {"cores": float(len(os.sched_getaffinity(0)))}
    print(f"{'run':<34} {'wall s':>9} {'scenes/s':>9}")
    if not args.skip_full:
        digests = {}
        for jobs in (1, 2):
            wall, digests[jobs] = full_run(jobs)
            n = len(digests[jobs])
            print(f"{f'dataset, {n} scenes, --jobs {jobs}':<34} {wall:>9.1f} {n / wall:>9.1f}")
            figures[f"dataset_jobs{jobs}_s"] = round(wall, 2)
            figures[f"dataset_jobs{jobs}_scenes_per_s"] = round(n / wall, 2)
        if digests[1] != digests[2]:
            raise SystemExit("--jobs 1 and --jobs 2 wrote different bytes")
        figures["speedup_jobs2_vs_jobs1"] = round(figures["dataset_jobs1_s"] / figures["dataset_jobs2_s"], 2)
        figures["target_30s_met"] = float(figures["dataset_jobs2_s"] <= 30.0)
    # Memory: many scenes in one process (indices past 256 extend the splits).
    names = ["urban-nav-1-train", "urban-nav-2-train", "urban-nav-3-train"]
    for i in range(30):  # warm caches (asset parts, tile meshes) before the first reading
        dumps(citygen.generate(names[i % 3], index=i))
    start = rss_mb()
    t = time.perf_counter()
    digest = ""
    for i in range(args.rss_scenes):
        digest = sha256(dumps(citygen.generate(names[i % 3], index=1000 + i)).encode())
    wall = time.perf_counter() - t
    end = rss_mb()
    label = f"in-process, {args.rss_scenes} scenes"
    print(f"{label:<34} {wall:>9.1f} {args.rss_scenes / wall:>9.1f}")
    print(f"RSS start {start:.1f} MiB, end {end:.1f} MiB (last digest {digest[:12]})")
    figures.update(rss_start_mb=round(start, 1), rss_end_mb=round(end, 1), rss_scenes=args.rss_scenes)
    figures["rss_growth_mb"] = round(end - start, 1)
    if args.city:
        t = time.perf_counter()
        scene = citygen.generate("urban-tra-city")
        wall = time.perf_counter() - t
        print(f"{'urban-tra-city, 1 scene':<34} {wall:>9.1f}  ({len(scene.placements)} objects)")
        figures["urban_tra_city_s"] = round(wall, 1)
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
