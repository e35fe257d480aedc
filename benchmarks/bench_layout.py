"""Road layout speed and scale: citygen's blocks + zones against MetaDrive, and city-size layouts.

1. A 7-block road network with its zones (roadway, curbs, sidewalk strips, crosswalks,
   plazas, buildings, vegetation, trails tiling a 250 m x 250 m scene), against MetaDrive
   building a 7-block map (``metadrive-simulator``, headless, physics only; see
   ``metadrive_baseline.py``), both measured in this run. Medians over seeds of CPU time
   (steadier than wall time on a shared machine; wall time is printed too). Target:
   citygen at most 1/5 of MetaDrive.
2. Layouts of 300, 600, 900 and 1,200 m squares with a block count proportional to the
   area (300 blocks at 1,200 m), each in a fresh process for its peak memory. Targets:
   1,200 m in under 60 s and 2 GiB; the fitted exponent of time against area at most 1.1.

Run: ``python benchmarks/bench_layout.py`` (MetaDrive: ``pip install -e '.[bench]'``, or
point ``CITYGEN_METADRIVE_PYTHON`` at an interpreter that has it). Last line: JSON figures.
"""

from __future__ import annotations

import json
import resource
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from citygen.generate.pipeline import layout
from citygen.spec.config import BlocksConfig, GeneratorConfig

SEEDS = range(20)
NETWORK = GeneratorConfig(size=(250.0, 250.0), layout="blocks", blocks=BlocksConfig(count=7))
CITY_SIDES = (300.0, 600.0, 900.0, 1200.0)
BLOCKS_PER_M2 = 300 / 1200.0**2


def city_config(side: float) -> GeneratorConfig:
    count = max(7, round(BLOCKS_PER_M2 * side * side))
    return GeneratorConfig(size=(side, side), layout="blocks", blocks=BlocksConfig(count=count))


def time_network() -> tuple[float, float, int]:
    """Median CPU and wall seconds of one 7-block network with zones; zones per scene."""
    layout(NETWORK, 1_000)  # warm: imports and first calls
    cpu, wall, zones = [], [], []
    for seed in SEEDS:
        c, w = time.process_time(), time.perf_counter()
        scene = layout(NETWORK, seed)
        cpu.append(time.process_time() - c)
        wall.append(time.perf_counter() - w)
        zones.append(len(scene.zones))
    return statistics.median(cpu), statistics.median(wall), int(statistics.median(zones))


def city_child(side: float) -> None:
    """In a fresh process: one city layout; prints seconds, peak memory, blocks and zones."""
    config = city_config(side)
    c, w = time.process_time(), time.perf_counter()
    scene = layout(config, 0)
    cpu, wall = time.process_time() - c, time.perf_counter() - w
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB
    print(
        json.dumps(
            {"cpu": cpu, "wall": wall, "peak": peak, "blocks": len(scene.blocks), "zones": len(scene.zones)}
        )
    )


def time_city(side: float) -> dict:
    proc = subprocess.run(
        [sys.executable, __file__, "--city", str(side)],
        capture_output=True,
        text=True,
        check=True,
        timeout=600,
    )
    return json.loads(proc.stdout.strip().splitlines()[-1])


def metadrive() -> tuple[float | None, float | None, str]:
    """MetaDrive's median CPU and wall seconds per 7-block map, or why it could not run."""
    import metadrive_baseline as md

    if not md.metadrive_available():
        return None, None, f"not installed for {md.default_python()} (pip install -e '.[bench]')"
    md.prepare_assets()
    t = md.measure_metadrive(blocks=7, seeds=range(10))
    return t.median_map_cpu_s, t.median_map_s, f"MetaDrive {t.version}"


def main() -> None:
    figures: dict[str, float | None] = {}
    print("7-block network with zones (medians over seeds)")
    cpu, wall, zones = time_network()
    md_cpu, md_wall, md_note = metadrive()
    print(f"  {'':28}{'cpu ms':>10}{'wall ms':>10}")
    print(f"  {'citygen (250 m, zones)':28}{cpu * 1e3:>10.1f}{wall * 1e3:>10.1f}   {zones} zones")
    if md_cpu is not None:
        print(f"  {md_note:28}{md_cpu * 1e3:>10.1f}{md_wall * 1e3:>10.1f}")
        print(f"  citygen / MetaDrive: {cpu / md_cpu:.3f} of the CPU time (target <= 0.2)")
    else:
        print(f"  MetaDrive: {md_note}")
    figures.update(
        layout7_cpu_ms=round(cpu * 1e3, 2),
        layout7_wall_ms=round(wall * 1e3, 2),
        metadrive7_cpu_ms=None if md_cpu is None else round(md_cpu * 1e3, 2),
        metadrive7_wall_ms=None if md_wall is None else round(md_wall * 1e3, 2),
        layout7_vs_metadrive_cpu_ratio=None if md_cpu is None else round(cpu / md_cpu, 4),
    )

    print("\nCity layouts (one fresh process each)")
    print(f"  {'side m':>8}{'blocks':>8}{'zones':>8}{'cpu s':>9}{'wall s':>9}{'peak MiB':>10}")
    rows = []
    for side in CITY_SIDES:
        r = time_city(side)
        rows.append((side, r))
        print(
            f"  {side:>8.0f}{r['blocks']:>8}{r['zones']:>8}{r['cpu']:>9.2f}{r['wall']:>9.2f}"
            f"{r['peak'] / 2**20:>10.0f}"
        )
    areas = np.array([side * side for side, _ in rows])
    cpus = np.array([r["cpu"] for _, r in rows])
    exponent = float(np.polyfit(np.log(areas), np.log(cpus), 1)[0])
    big = rows[-1][1]
    print(
        f"  time ~ area^{exponent:.2f} (target <= 1.1); 1,200 m: {big['wall']:.1f} s wall (target < 60 s), "
        f"{big['peak'] / 2**30:.2f} GiB peak (target < 2 GiB)"
    )
    figures.update(
        city1200_wall_s=round(big["wall"], 2),
        city1200_cpu_s=round(big["cpu"], 2),
        city1200_peak_mib=round(big["peak"] / 2**20, 1),
        city1200_blocks=big["blocks"],
        city1200_zones=big["zones"],
        city_time_area_exponent=round(exponent, 3),
        city_sides_m=[side for side, _ in rows],
        city_cpu_s=[round(r["cpu"], 3) for _, r in rows],
        city_peak_mib=[round(r["peak"] / 2**20, 1) for _, r in rows],
    )
    print(json.dumps(figures))


if __name__ == "__main__":
    if len(sys.argv) == 3 and sys.argv[1] == "--city":
        city_child(float(sys.argv[2]))
    else:
        main()
