"""Export speed and size: a 15 m scene into MuJoCo, and a 1.2 km city to USD.

1. A 15 m x 15 m region scene (the Urban-Nav test size) with its terrain and 8 objects
   (the paper's test count), exported with :mod:`citygen.exporters.mjcf` and compiled with
   ``mujoco.MjModel.from_xml_path``; the same scene to USD for comparison. Medians over
   seeds (scene generation not timed). Target: MJCF export + compile <= 100 ms.
2. The 1,200 m city of ``bench_layout.py`` (300 blocks) with about 10,000 objects, to USD
   (usdc, then usda) in a fresh process: export time, peak memory, files on disk (the
   stage plus its asset layers), and usd-core's validators over the usdc stage. The
   generator's own objects are used; when it places fewer than 10,000 (by default it fills
   the building lots and adds a handful), synthetic street furniture is added on sidewalk
   zones (catalog ids cycling through the sidewalk categories, 8 variants each), and the
   output says how many. Rough tiles are sampled every 0.625 m (4 cells a tile; the
   exporter refuses the default, 1/8 of the wavelength, at city scale). Targets: <= 60 s
   and < 200 MB, the latter thanks to instancing.

Run: ``python benchmarks/bench_export.py``. Last line: JSON figures.
"""

from __future__ import annotations

import json
import resource
import statistics
import subprocess
import sys
import tempfile
import time
import warnings
from pathlib import Path

import numpy as np
import shapely

from citygen.assets import CATEGORIES
from citygen.exporters import ExportWarning, usd
from citygen.generate import generate
from citygen.geometry.terrain import height_at
from citygen.spec.config import BlocksConfig, GeneratorConfig, PlacementConfig
from citygen.spec.placements import Placement
from citygen.spec.scene import Scene

SMALL = GeneratorConfig(size=(15.0, 15.0), placement=PlacementConfig(count=8))
SMALL_SEEDS = range(10)
CITY = GeneratorConfig(size=(1200.0, 1200.0), layout="blocks", blocks=BlocksConfig(count=300))
CITY_OBJECTS = 10_000
CITY_RESOLUTION = 0.625  # m between rough-tile samples
VARIANTS = 8


def synthetic_placements(scene: Scene, count: int, seed: int = 0) -> list[Placement]:
    """``count`` catalog objects at random spots of the sidewalk zones (area-weighted),
    categories that belong on sidewalks in turn, on the ground, turned at random."""
    rng = np.random.default_rng(seed)
    kinds = [name for name, c in CATEGORIES.items() if "sidewalk" in c.zones and name != "building"]
    walks = [shapely.Polygon(z.polygon, z.holes) for z in scene.zones if z.kind == "sidewalk"]
    if not walks:
        raise SystemExit("the city has no sidewalk zones to put synthetic objects on")
    area = shapely.area(walks)
    bounds = shapely.bounds(walks)
    polys = np.asarray(walks, dtype=object)
    xy = np.zeros((0, 2))
    while len(xy) < count:
        pick = rng.choice(len(walks), size=2 * count, p=area / area.sum())
        lo, hi = bounds[pick, :2], bounds[pick, 2:]
        pts = lo + rng.random((len(pick), 2)) * (hi - lo)
        inside = shapely.contains_xy(polys[pick], pts[:, 0], pts[:, 1])
        xy = np.concatenate([xy, pts[inside]])
    xy = xy[:count]
    z = height_at(scene, xy[:, 0], xy[:, 1])
    yaw = rng.uniform(-np.pi, np.pi, size=count)
    return [
        Placement(
            id=f"synthetic-{k:05d}",
            asset=f"{kinds[k % len(kinds)]}/{(k // len(kinds)) % VARIANTS:04d}",
            position=(round(float(xy[k, 0]), 4), round(float(xy[k, 1]), 4), round(float(z[k]), 4)),
            yaw=round(float(yaw[k]), 4),
        )
        for k in range(count)
    ]


# --- 1. a 15 m scene into MuJoCo ---------------------------------------------------------


def small_scene(seed: int) -> Scene:
    scene = generate(SMALL, seed)
    missing = 8 - len(scene.placements)
    if missing > 0:  # not expected: the generator places the count it is given
        extra = synthetic_placements(scene, missing, seed)
        scene = scene.model_copy(update={"placements": (*scene.placements, *extra)})
    return scene


def time_small() -> dict:
    try:
        import mujoco

        from citygen.exporters import mjcf
    except ImportError as exc:
        return {"note": f"MJCF part skipped: {exc}"}
    scenes = [small_scene(seed) for seed in SMALL_SEEDS]
    export_ms, compile_ms, usd_ms, cpu_ms = [], [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        mjcf.export(scenes[0], Path(tmp) / "warm")  # imports and first calls
        for k, scene in enumerate(scenes):
            out = Path(tmp) / f"s{k}"
            c, t = time.process_time(), time.perf_counter()
            files = mjcf.export(scene, out)
            t1 = time.perf_counter()
            model = mujoco.MjModel.from_xml_path(str(files[0]))
            t2 = time.perf_counter()
            cpu_ms.append((time.process_time() - c) * 1e3)
            usd.export(scene, out, format="usdc")
            t3 = time.perf_counter()
            export_ms.append((t1 - t) * 1e3)
            compile_ms.append((t2 - t1) * 1e3)
            usd_ms.append((t3 - t2) * 1e3)
            assert model.ngeom > 0
    tiles = statistics.median(len(s.terrain.tiles) if s.terrain else 0 for s in scenes)
    return {
        "export_ms": statistics.median(export_ms),
        "compile_ms": statistics.median(compile_ms),
        "total_ms": statistics.median(e + c for e, c in zip(export_ms, compile_ms, strict=True)),
        "cpu_ms": statistics.median(cpu_ms),
        "usd_ms": statistics.median(usd_ms),
        "objects": statistics.median(len(s.placements) for s in scenes),
        "tiles": tiles,
    }


# --- 2. a 1.2 km city to USD -------------------------------------------------------------


def _size(files: list[Path]) -> int:
    return sum(f.stat().st_size for f in files)


def _flat_objects_bytes(stage_path: Path) -> int:
    """What the objects would weigh written out one by one instead of instanced: for every
    object prim, the size of the asset layer it references."""
    from pxr import Sdf

    layer = Sdf.Layer.FindOrOpen(str(stage_path))
    total = 0
    for spec in layer.GetPrimAtPath("/World/Objects").nameChildren:
        for ref in spec.referenceList.GetAddedOrExplicitItems():
            total += (stage_path.parent / ref.assetPath).stat().st_size
    return total


def city_child() -> None:
    """In a fresh process: the city, topped up with objects, to usdc and usda."""
    t = time.perf_counter()
    scene = generate(CITY, 0)
    generate_s = time.perf_counter() - t
    own = len(scene.placements)
    extra = synthetic_placements(scene, max(0, CITY_OBJECTS - own))
    scene = scene.model_copy(update={"placements": (*scene.placements, *extra)})
    result: dict = {"generate_s": generate_s, "own": own, "synthetic": len(extra), "zones": len(scene.zones)}
    result["tiles"] = len(scene.terrain.tiles) if scene.terrain else 0
    result["rough"] = sum(t.kind == "rough" for t in scene.terrain.tiles) if scene.terrain else 0
    result["assets"] = len({p.asset for p in scene.placements})
    with tempfile.TemporaryDirectory() as tmp:
        for fmt in ("usdc", "usda"):
            out = Path(tmp) / fmt
            c, w = time.process_time(), time.perf_counter()
            files = usd.export(scene, out, format=fmt, terrain_resolution=CITY_RESOLUTION)
            result[fmt] = {
                "cpu_s": time.process_time() - c,
                "wall_s": time.perf_counter() - w,
                "bytes": _size(files),
                "stage_bytes": files[0].stat().st_size,
                "files": len(files),
                "asset_bytes": _size(files[1:]),
                "flat_objects_bytes": _flat_objects_bytes(files[0]),
            }
            if fmt == "usdc":
                from pxr import Usd

                w = time.perf_counter()
                stage = Usd.Stage.Open(str(files[0]))
                result["open_s"] = time.perf_counter() - w
                result["prototypes"] = len(stage.GetPrototypes())
                result["instances"] = sum(
                    1 for p in stage.GetPrimAtPath("/World/Objects").GetChildren() if p.IsInstance()
                )
                del stage
                w = time.perf_counter()
                result["validator_errors"] = len(usd.check(files[0]))
                result["validate_s"] = time.perf_counter() - w
        # The objects alone (no ground): what instancing saves.
        bare = scene.model_copy(update={"zones": (), "terrain": None, "blocks": ()})
        files = usd.export(bare, Path(tmp) / "objects", format="usdc")
        result["objects_stage_bytes"] = files[0].stat().st_size
        result["objects_flat_bytes"] = _flat_objects_bytes(files[0])
    result["peak"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024  # Linux: KiB
    print(json.dumps(result))


def time_city() -> dict:
    proc = subprocess.run(
        [sys.executable, __file__, "--city"], capture_output=True, text=True, check=True, timeout=900
    )
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    figures: dict[str, float | int | None] = {}
    print(f"1. 15 m x 15 m scene with terrain and 8 objects (medians over {len(SMALL_SEEDS)} seeds)")
    small = time_small()
    if "note" in small:
        print(f"  {small['note']}")
        figures.update(
            mjcf15_export_ms=None, mjcf15_compile_ms=None, mjcf15_total_ms=None, usd15_export_ms=None
        )
    else:
        print(f"  {'':34}{'ms':>8}")
        print(f"  {'MJCF export':34}{small['export_ms']:>8.1f}")
        print(f"  {'MuJoCo compile (from_xml_path)':34}{small['compile_ms']:>8.1f}")
        print(f"  {'MJCF export + compile':34}{small['total_ms']:>8.1f}   (target <= 100 ms)")
        print(f"  {'  of which CPU time':34}{small['cpu_ms']:>8.1f}")
        print(f"  {'USD export (usdc)':34}{small['usd_ms']:>8.1f}")
        print(f"  {small['objects']:g} objects, {small['tiles']:g} terrain tiles per scene")
        figures.update(
            mjcf15_export_ms=round(small["export_ms"], 2),
            mjcf15_compile_ms=round(small["compile_ms"], 2),
            mjcf15_total_ms=round(small["total_ms"], 2),
            mjcf15_total_cpu_ms=round(small["cpu_ms"], 2),
            usd15_export_ms=round(small["usd_ms"], 2),
        )

    print("\n2. 1,200 m x 1,200 m city to USD (fresh process)")
    r = time_city()
    print(
        f"  generated in {r['generate_s']:.1f} s: {r['zones']} zones, {r['tiles']} tiles "
        f"({r['rough']} rough, sampled every {CITY_RESOLUTION} m), {r['own']} objects from the generator"
    )
    if r["synthetic"]:
        print(f"  + {r['synthetic']} synthetic objects on sidewalks (the generator placed < {CITY_OBJECTS})")
    print(f"  {r['own'] + r['synthetic']} objects of {r['assets']} distinct assets")
    print(
        f"  {'format':8}{'wall s':>9}{'cpu s':>9}{'MB on disk':>12}{'stage MB':>10}{'assets MB':>11}"
        f"{'files':>7}{'objects uninstanced MB':>24}"
    )
    for fmt in ("usdc", "usda"):
        f = r[fmt]
        print(
            f"  {fmt:8}{f['wall_s']:>9.1f}{f['cpu_s']:>9.1f}{f['bytes'] / 1e6:>12.1f}"
            f"{f['stage_bytes'] / 1e6:>10.1f}{f['asset_bytes'] / 1e6:>11.2f}{f['files']:>7}"
            f"{f['flat_objects_bytes'] / 1e6:>24.1f}"
        )
    print("  (uninstanced: every object's asset layer copied into the stage, an estimate)")
    saving = r["objects_flat_bytes"] / r["objects_stage_bytes"]
    print(
        f"  objects alone (usdc, no ground): {r['objects_stage_bytes'] / 1e6:.2f} MB instanced, "
        f"{r['objects_flat_bytes'] / 1e6:.1f} MB uninstanced ({saving:.0f}x)"
    )
    print(
        f"  usdc: opens in {r['open_s']:.1f} s, {r['instances']} instances of {r['prototypes']} prototypes;"
        f" validators: {r['validator_errors']} errors in {r['validate_s']:.1f} s;"
        f" peak {r['peak'] / 2**20:.0f} MiB"
    )
    print("  targets: export <= 60 s, size < 200 MB")
    figures.update(
        city1200_usdc_export_s=round(r["usdc"]["wall_s"], 2),
        city1200_usdc_mb=round(r["usdc"]["bytes"] / 1e6, 2),
        city1200_usda_export_s=round(r["usda"]["wall_s"], 2),
        city1200_usda_mb=round(r["usda"]["bytes"] / 1e6, 2),
        city1200_usdc_assets_mb=round(r["usdc"]["asset_bytes"] / 1e6, 3),
        city1200_objects_only_usdc_mb=round(r["objects_stage_bytes"] / 1e6, 3),
        city1200_objects_uninstanced_usdc_mb=round(r["objects_flat_bytes"] / 1e6, 1),
        city1200_instancing_size_ratio=round(saving, 1),
        city1200_objects=r["own"] + r["synthetic"],
        city1200_synthetic_objects=r["synthetic"],
        city1200_prototypes=r["prototypes"],
        city1200_validator_errors=r["validator_errors"],
        city1200_validate_s=round(r["validate_s"], 2),
        city1200_peak_mib=round(r["peak"] / 2**20, 1),
    )
    print(json.dumps(figures))


if __name__ == "__main__":
    warnings.simplefilter("ignore", ExportWarning)  # per-tile friction notes; not what is measured here
    if sys.argv[1:] == ["--city"]:
        city_child()
    else:
        main()
