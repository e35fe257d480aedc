"""Whole-pipeline generation time against scene area, with the JSON floor of each scene.

Square city scenes of 300, 600, 900 and 1,200 m a side go through every stage (blocks,
ground, terrain, objects, agents, task), with everything that scales with the city scaled
with its area: 300 blocks, 10,000 objects, 200 people and 30 vehicles at 1,200 m (the
densities of ``bench_layout.py`` and ``bench_placement.py``). Each size runs in a fresh
process (so its peak memory is its own) and reports CPU and wall seconds, the scene's
JSON size, and the time to serialise and write that JSON with pydantic-core's serialiser
(``model_dump_json``, compiled): the floor a generator cannot beat, measured in the same
process, so ``generate / JSON`` is a machine-independent ratio. The time of citygen's own
canonical layout (:func:`citygen.io.dumps`, what ``citygen generate`` writes) is given too.

The fitted exponent of CPU time against area (log-log least squares) says how generation
scales: 1 is linear, which is what a tiled city should cost. Issue 3's target (at most
1.1) is on the layout alone (``bench_layout.py``); this is the whole pipeline.

Run: ``python benchmarks/bench_generate.py [--sides 300 600 900 1200]``. Last line: JSON.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

SIDES = (300.0, 600.0, 900.0, 1200.0)
FULL = 1200.0
BLOCKS, OBJECTS, PEOPLE, VEHICLES = 300, 10_000, 200, 30
"""Counts at 1,200 m a side; smaller scenes get them in proportion to their area."""


def config(side: float):
    from citygen.spec.config import AgentsConfig, BlocksConfig, GeneratorConfig, PlacementConfig

    share = (side / FULL) ** 2
    return GeneratorConfig(
        size=(side, side),
        layout="blocks",
        blocks=BlocksConfig(count=max(3, round(BLOCKS * share))),
        placement=PlacementConfig(count=max(1, round(OBJECTS * share))),
        agents=AgentsConfig(people=max(1, round(PEOPLE * share)), vehicles=max(1, round(VEHICLES * share))),
    )


def child(side: float) -> None:
    """In a fresh process: one scene of ``side`` m, timed; prints one JSON line."""
    from citygen.generate import generate
    from citygen.io import dumps
    from citygen.spec.config import GeneratorConfig

    cfg = config(side)
    generate(GeneratorConfig(size=(15.0, 15.0), placement={"count": 8}), 1)  # warm: imports, first calls
    c, w = time.process_time(), time.perf_counter()
    scene = generate(cfg, 0)
    cpu, wall = time.process_time() - c, time.perf_counter() - w
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "scene.json"
        t = time.perf_counter()
        path.write_bytes(scene.model_dump_json().encode())  # pydantic-core's serialiser, in Rust
        json_s = time.perf_counter() - t
        t = time.perf_counter()
        path.write_text(dumps(scene))  # citygen's canonical layout, what a user's file holds
        canonical_s = time.perf_counter() - t
        size = path.stat().st_size
    print(
        json.dumps(
            {
                "side": side,
                "cpu_s": cpu,
                "wall_s": wall,
                "json_s": json_s,
                "canonical_s": canonical_s,
                "json_bytes": size,
                "peak_mib": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                "blocks": len(scene.blocks),
                "zones": len(scene.zones),
                "objects": len(scene.placements),
                "agents": len(scene.agents),
            }
        )
    )


def run(side: float) -> dict:
    proc = subprocess.run(
        [sys.executable, __file__, "--child", str(side)],
        capture_output=True,
        text=True,
        timeout=900,
    )
    if proc.returncode:
        raise SystemExit(f"{side:g} m scene failed: {proc.stderr.strip().splitlines()[-1]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def exponent(areas: list[float], seconds: list[float]) -> float:
    """Slope of log(seconds) against log(area): the power law's exponent."""
    return float(np.polyfit(np.log(areas), np.log(seconds), 1)[0])


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--sides", type=float, nargs="+", default=list(SIDES))
    p.add_argument("--child", type=float, help=argparse.SUPPRESS)
    args = p.parse_args(argv)
    if args.child is not None:
        child(args.child)
        return
    print("whole pipeline, one fresh process per size")
    head = (
        "side m",
        "blocks",
        "zones",
        "objects",
        "agents",
        "cpu s",
        "wall s",
        "JSON MB",
        "JSON s",
        "gen/JSON",
    )
    print("".join(f"{h:>10}" for h in head), f"{'peak MiB':>10}")
    rows = []
    for side in sorted(args.sides):
        r = run(side)
        rows.append(r)
        cells = (side, r["blocks"], r["zones"], r["objects"], r["agents"])
        print(
            "".join(f"{c:>10.0f}" for c in cells)
            + f"{r['cpu_s']:>10.2f}{r['wall_s']:>10.2f}{r['json_bytes'] / 1e6:>10.2f}{r['json_s']:>10.3f}"
            + f"{r['wall_s'] / r['json_s']:>10.0f}{r['peak_mib']:>10.0f}"
        )
    areas = [r["side"] ** 2 for r in rows]
    k = exponent(areas, [r["cpu_s"] for r in rows]) if len(rows) > 1 else None
    if k is not None:
        print(f"CPU time ~ area^{k:.2f}")
    figures = {
        "bench": "generate",
        "generate_sides_m": [r["side"] for r in rows],
        "generate_cpu_s": [round(r["cpu_s"], 3) for r in rows],
        "generate_wall_s": [round(r["wall_s"], 3) for r in rows],
        "generate_json_s": [round(r["json_s"], 4) for r in rows],
        "generate_canonical_json_s": [round(r["canonical_s"], 4) for r in rows],
        "generate_over_json": [round(r["wall_s"] / r["json_s"], 1) for r in rows],
        "generate_objects": [r["objects"] for r in rows],
        "generate_peak_mib": [round(r["peak_mib"], 1) for r in rows],
        "generate_time_area_exponent": None if k is None else round(k, 3),
    }
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
