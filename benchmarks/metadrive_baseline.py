"""MetaDrive baseline for the road-layout benchmark: seconds per procedurally generated map.

``benchmarks/bench_layout.py`` compares citygen's block network with MetaDrive's
(``metadrive-simulator`` on PyPI) in the same run. This module measures MetaDrive.

What is timed
    MetaDrive builds a map inside a running engine: ``PGMapManager.reset`` constructs a
    ``PGMap`` whose ``BIG`` generator samples the block sequence (with MetaDrive's
    overlap-reject-and-backtrack search), lays out the road network and creates every
    block's Bullet collision bodies (lanes, lane lines, sidewalks, crosswalks), then attaches
    them to the physics world. That call is the *map* time, wrapped in place during an
    ordinary ``env.reset(seed=...)``, so it is exactly what MetaDrive spends on a new map.
    The whole reset (map plus ego vehicle, sensors and one engine step; traffic density 0)
    is reported as the *reset* time. Interpreter start-up, ``import metadrive`` and the
    one-time engine initialisation (Panda3D ``ShowBase`` in physics-only mode, Bullet world,
    managers) are measured separately and never counted per map. The first map after the
    engine starts is cold (first calls into code paths and Panda3D); it is measured and
    reported on its own, then the same seed is generated again among the timed ones.

Run headless without the asset archive
    MetaDrive downloads ``assets.zip`` from GitHub at first engine start unless
    ``<site-packages>/metadrive/assets`` (``AssetLoader.asset_path``, a class constant, no
    environment variable) holds ``version.txt`` whose first line equals
    ``metadrive.version.VERSION`` and the file
    ``textures/grass1/GroundGrassGreen002_COL_1K.jpg``. With ``use_render=False`` and the
    default plane terrain, MetaDrive only checks that the texture *exists* (it never opens
    it) and reads ``version.txt``; no other asset file is touched. :func:`prepare_assets`
    writes exactly these two files, the texture empty. The worker also replaces MetaDrive's
    download function with one that raises, so a benchmark can never reach the network.

Isolation
    MetaDrive runs in a child process: its globals (engine singleton), Panda3D and its
    dependency pins cannot disturb the caller, and the child may be another interpreter
    (``python=...``, or the ``CITYGEN_METADRIVE_PYTHON`` environment variable), so a caller
    whose venv lacks MetaDrive can still measure it. This file runs on the Python versions
    MetaDrive supports (3.8 to 3.11); the parent side uses only the standard library (the
    step benchmark's child also uses numpy, a MetaDrive dependency).

Environment steps per second (:func:`measure_metadrive_steps`)
    The runner benchmark's MetaDrive figure: an ordinary ``MetaDriveEnv`` (MetaDrive's
    defaults: a 3-block map, scenario 0 only, no horizon) with ``use_render=False`` and no
    image observation, so the observation is MetaDrive's default state vector (ego state,
    navigation and a 240-beam lidar, 259 floats). The loop is ``env.step(action)`` with
    uniform random actions in [-1, 1]^2 (``numpy.random.default_rng(0)``, drawn before the
    clock starts, as ``bench_runner.py`` drives NavStatic) and ``env.reset()`` whenever the
    episode ends; resets inside the loop count against the rate. Each traffic density runs
    in its own child, so each pays its own one-time start (import, engine initialisation,
    first reset, 20 warm-up steps), reported separately and never counted in the rate. One
    env step advances ``decision_repeat`` physics steps of ``physics_world_step_size``
    seconds (MetaDrive's defaults 5 x 0.02 s = 0.1 s), reported so rates can be compared
    per simulated second.

Standalone: ``python benchmarks/metadrive_baseline.py [--blocks 7] [--seeds 10] [--python PATH]``
prints a table and, as its last line, one JSON object of figures in milliseconds;
``--steps N [--traffic 0.1 0]`` measures environment steps per second instead.
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass

#: Environment variable naming the interpreter that has ``metadrive-simulator`` installed.
PYTHON_ENV = "CITYGEN_METADRIVE_PYTHON"

#: The texture MetaDrive checks for (relative to its assets folder); it only tests existence.
GRASS_TEXTURE = ("textures", "grass1", "GroundGrassGreen002_COL_1K.jpg")

_RESULT_TAG = "METADRIVE_BASELINE_RESULT "
_DEFAULT_TIMEOUT_S = 300.0

#: Steps taken (and not timed) after the first reset, before the steps/s clock starts.
WARMUP_STEPS = 20

#: Traffic densities :func:`measure_metadrive_steps` measures by default; 0.1 is MetaDrive's default.
DEFAULT_TRAFFIC_DENSITIES = (0.1, 0.0)

#: Keys of one traffic density's run in :func:`measure_metadrive_steps`' result (see there).
_RUN_KEYS = (
    "traffic_density",
    "steps_per_s",
    "cpu_steps_per_s",
    "simulated_s_per_wall_s",
    "loop_s",
    "loop_cpu_s",
    "resets",
    "reset_s",
    "traffic_vehicles",
    "import_s",
    "engine_init_s",
    "first_reset_s",
    "warmup_s",
    "process_s",
)


class MetaDriveBaselineError(RuntimeError):
    """MetaDrive is missing, its assets folder is unusable, or the measuring child failed."""


@dataclass(frozen=True)
class MetaDriveTimings:
    """One measuring run: every duration in seconds, one entry of each tuple per seed."""

    version: str
    python: str
    blocks: int
    seeds: tuple[int, ...]
    import_s: float
    engine_init_s: float
    first_map_s: float
    first_reset_s: float
    map_s: tuple[float, ...]
    map_cpu_s: tuple[float, ...]
    reset_s: tuple[float, ...]
    block_ids: tuple[str, ...]
    process_s: float

    @property
    def median_map_s(self) -> float:
        """Median seconds to generate one map (block sequence, road network, collision bodies)."""
        return statistics.median(self.map_s)

    @property
    def median_map_cpu_s(self) -> float:
        """Median CPU seconds (this process only) per map: steadier than wall time on a busy machine."""
        return statistics.median(self.map_cpu_s)

    @property
    def median_reset_s(self) -> float:
        """Median seconds of a whole ``env.reset`` onto a new map."""
        return statistics.median(self.reset_s)


def default_python() -> str:
    """The interpreter used for MetaDrive: ``$CITYGEN_METADRIVE_PYTHON`` or this one."""
    return os.environ.get(PYTHON_ENV) or sys.executable


def metadrive_available(python: str | None = None) -> bool:
    """True when ``python`` (default :func:`default_python`) can import ``metadrive``.

    Only looks the package up (``importlib.util.find_spec``); nothing is imported or started.
    """
    code = "import importlib.util, sys; sys.exit(0 if importlib.util.find_spec('metadrive') else 1)"
    try:
        done = subprocess.run(
            [python or default_python(), "-c", code],
            env=_child_env(),
            capture_output=True,
            timeout=60,
            check=False,
        )
    except (OSError, subprocess.TimeoutExpired):
        return False
    return done.returncode == 0


def prepare_assets(python: str | None = None) -> None:
    """Write MetaDrive's ``assets/version.txt`` and the empty grass texture if missing.

    Idempotent. Works on the MetaDrive installed for ``python`` (default
    :func:`default_python`). A ``version.txt`` naming another version is rewritten only when
    the folder holds nothing but these two placeholder files (left by an older MetaDrive);
    a real, outdated asset folder is reported instead of being disguised.
    Raises :class:`MetaDriveBaselineError` when MetaDrive is missing or the folder unusable.
    """
    _run_child(["--prepare-assets"], python, timeout_s=60)


def measure_metadrive(
    blocks: int = 7,
    seeds: Sequence[int] = range(10),
    python: str | None = None,
    timeout_s: float = _DEFAULT_TIMEOUT_S,
) -> MetaDriveTimings:
    """Time MetaDrive generating one ``blocks``-block map per seed, in a child process.

    ``blocks`` counts the sampled blocks, as MetaDrive's ``map=7`` does (its fixed entry
    block comes on top). ``seeds`` are MetaDrive scenario indices (non-negative ints).
    Prepares the assets first (see :func:`prepare_assets`).
    """
    seeds = tuple(int(s) for s in seeds)
    if not seeds or min(seeds) < 0:
        raise ValueError(f"seeds: expected one or more non-negative ints, got {seeds!r}")
    if not 1 <= blocks <= 50:
        raise ValueError(f"blocks: expected an int in [1, 50], got {blocks!r}")
    interpreter = python or default_python()
    started = time.perf_counter()
    result = _run_child(["--worker", json.dumps({"blocks": blocks, "seeds": seeds})], interpreter, timeout_s)
    process_s = time.perf_counter() - started
    return MetaDriveTimings(
        version=result["version"],
        python=interpreter,
        blocks=blocks,
        seeds=seeds,
        import_s=result["import_s"],
        engine_init_s=result["engine_init_s"],
        first_map_s=result["first_map_s"],
        first_reset_s=result["first_reset_s"],
        map_s=tuple(result["map_s"]),
        map_cpu_s=tuple(result["map_cpu_s"]),
        reset_s=tuple(result["reset_s"]),
        block_ids=tuple(result["block_ids"]),
        process_s=process_s,
    )


def time_metadrive_maps(
    blocks: int = 7, seeds: Sequence[int] = range(10), python: str | None = None
) -> list[float]:
    """Seconds MetaDrive spends generating each seed's ``blocks``-block map, warm engine.

    One entry per seed, in order; see :func:`measure_metadrive` for the other figures.
    """
    return list(measure_metadrive(blocks, seeds, python).map_s)


def measure_metadrive_steps(
    steps: int = 2000,
    python: str | None = None,
    timeout_s: float = _DEFAULT_TIMEOUT_S,
    traffic_densities: Sequence[float] = DEFAULT_TRAFFIC_DENSITIES,
) -> dict:
    """Headless ``MetaDriveEnv`` steps per second, one child process per traffic density.

    Each child builds an ordinary ``MetaDriveEnv`` (``use_render=False``, state-vector
    observation, the given ``traffic_density``), resets it, takes :data:`WARMUP_STEPS`
    untimed steps, then times ``steps`` calls of ``env.step`` with uniform random actions,
    resetting whenever an episode ends (those resets are inside the timed loop).
    ``timeout_s`` bounds each child. Prepares the assets first (see :func:`prepare_assets`).

    Returns a JSON-ready dict. Shared by every run: ``version`` (MetaDrive's), ``python``,
    ``steps``, ``map_blocks`` (blocks in MetaDrive's default map), ``observation_size``
    (floats per observation), ``decision_repeat`` (physics steps per env step),
    ``physics_world_step_size_s`` (seconds per physics step) and ``simulated_s_per_step``
    (their product, seconds). ``runs`` holds one dict per density, in the order given:
    ``traffic_density``; ``steps_per_s`` (env steps per wall second) and ``cpu_steps_per_s``
    (per CPU second of the child process, steadier on a busy machine); ``simulated_s_per_wall_s``
    (the real-time factor); ``loop_s`` and ``loop_cpu_s`` (the timed loop, seconds);
    ``resets`` (episodes ended in the loop) and ``reset_s`` (wall seconds those resets took);
    ``traffic_vehicles`` (traffic vehicles MetaDrive placed at the first reset); and the
    one-time start cost, never in the rate: ``import_s`` (``import metadrive``),
    ``engine_init_s`` (env construction and engine start), ``first_reset_s`` (first map and
    vehicles), ``warmup_s`` and ``process_s`` (the whole child, seconds, interpreter start
    included). The first run's figures are repeated at the top level, so ``result["steps_per_s"]``
    is the rate at the first density (MetaDrive's default traffic unless told otherwise).
    """
    if isinstance(steps, bool) or not isinstance(steps, int) or not 1 <= steps <= 10_000_000:
        raise ValueError(f"steps: expected an int in [1, 10000000], got {steps!r}")
    densities = tuple(traffic_densities)
    bad = [d for d in densities if isinstance(d, bool) or not isinstance(d, (int, float)) or not 0 <= d <= 1]
    if not densities or bad:
        raise ValueError(f"traffic_densities: expected one or more numbers in [0, 1], got {densities!r}")
    interpreter = python or default_python()
    shared: dict = {}
    runs = []
    for density in densities:
        job = {"steps": steps, "traffic_density": float(density), "warmup": WARMUP_STEPS}
        started = time.perf_counter()
        result = _run_child(["--steps-worker", json.dumps(job)], interpreter, timeout_s)
        result["process_s"] = time.perf_counter() - started
        run = {key: result.pop(key) for key in _RUN_KEYS}
        if shared and result != shared:
            raise MetaDriveBaselineError(
                f"MetaDrive children disagree on the step settings: {shared} vs {result}"
            )
        shared = result
        runs.append(run)
    return {"python": interpreter, "steps": steps, **shared, **runs[0], "runs": runs}


# --------------------------------------------------------------------------- parent side


def _child_env() -> dict[str, str]:
    """The caller's environment minus what would mix two interpreters' packages."""
    env = {k: v for k, v in os.environ.items() if k not in ("PYTHONPATH", "PYTHONHOME", "PYTHONSTARTUP")}
    env["PYGAME_HIDE_SUPPORT_PROMPT"] = "1"
    return env


def _run_child(args: list[str], python: str | None, timeout_s: float) -> dict:
    interpreter = python or default_python()
    command = [interpreter, os.path.abspath(__file__), *args]
    try:
        done = subprocess.run(
            command, env=_child_env(), capture_output=True, text=True, timeout=timeout_s, check=False
        )
    except OSError as exc:
        raise MetaDriveBaselineError(f"cannot start {interpreter!r}: {exc}") from exc
    except subprocess.TimeoutExpired as exc:
        raise MetaDriveBaselineError(f"MetaDrive child {args[0]} exceeded {timeout_s:.0f} s") from exc
    lines = [line for line in done.stdout.splitlines() if line.startswith(_RESULT_TAG)]
    if done.returncode != 0 or not lines:
        tail = " | ".join((done.stderr or done.stdout).strip().splitlines()[-6:])
        raise MetaDriveBaselineError(
            f"MetaDrive child {args[0]} with {interpreter} exited {done.returncode}: {tail}"
        )
    return json.loads(lines[-1][len(_RESULT_TAG) :])


# --------------------------------------------------------------------------- child side


def _emit(result: dict) -> None:
    print(_RESULT_TAG + json.dumps(result), flush=True)


def _prepare_assets_here() -> str:
    """Create the two placeholder asset files for this interpreter's MetaDrive; its version."""
    import importlib.util

    spec = importlib.util.find_spec("metadrive")
    if spec is None or not spec.submodule_search_locations:
        raise MetaDriveBaselineError(f"metadrive is not installed for {sys.executable}")
    package = next(iter(spec.submodule_search_locations))
    # Read metadrive/version.py without running metadrive/__init__ (pygame, Panda3D, envs).
    version_spec = importlib.util.spec_from_file_location(
        "_metadrive_version", os.path.join(package, "version.py")
    )
    module = importlib.util.module_from_spec(version_spec)
    version_spec.loader.exec_module(module)
    version = module.VERSION

    assets = os.path.join(package, "assets")
    version_file = os.path.join(assets, "version.txt")
    texture = os.path.join(assets, *GRASS_TEXTURE)
    if os.path.exists(version_file):
        with open(version_file, encoding="utf-8") as fh:
            found = fh.readline().replace("\n", "").replace(" ", "")
        if found != version:
            placeholder_only = (
                sorted(_files_under(assets)) == sorted(["version.txt", "/".join(GRASS_TEXTURE)])
                and os.path.getsize(texture) == 0
            )
            if not placeholder_only:
                raise MetaDriveBaselineError(
                    f"{version_file} says {found!r} but MetaDrive is {version!r}; MetaDrive would "
                    f"download new assets. Remove {assets} (or update it) and rerun"
                )
            _write_atomically(version_file, version)
    else:
        _write_atomically(version_file, version)
    if not os.path.exists(texture):
        _write_atomically(texture, "")
    return version


def _files_under(folder: str) -> list[str]:
    out = []
    for root, _dirs, files in os.walk(folder):
        out.extend(os.path.relpath(os.path.join(root, f), folder).replace(os.sep, "/") for f in files)
    return out


def _write_atomically(path: str, text: str) -> None:
    os.makedirs(os.path.dirname(path), exist_ok=True)
    tmp = f"{path}.{os.getpid()}.tmp"
    with open(tmp, "w", encoding="utf-8") as fh:
        fh.write(text)
    os.replace(tmp, path)


def _refuse_download(*_args, **_kwargs) -> None:
    raise MetaDriveBaselineError("MetaDrive tried to download its assets; run prepare_assets() first")


def _import_metadrive() -> tuple[type, float]:
    """Import MetaDrive with its asset download refused: ``(MetaDriveEnv, seconds importing)``."""
    started = time.perf_counter()
    import metadrive  # noqa: F401  (the package import is part of the measured import cost)
    from metadrive.engine import base_engine
    from metadrive.engine.asset_loader import AssetLoader
    from metadrive.envs.metadrive_env import MetaDriveEnv

    import_s = time.perf_counter() - started

    if AssetLoader.should_update_asset():
        raise MetaDriveBaselineError(
            f"MetaDrive still wants to download assets into {AssetLoader.asset_path}"
        )
    base_engine.pull_asset = _refuse_download
    return MetaDriveEnv, import_s


def _worker(blocks: int, seeds: list[int]) -> dict:
    """Runs in the child: time one cold map, then one map and one reset per seed."""
    perf, cpu = time.perf_counter, time.process_time
    version = _prepare_assets_here()
    MetaDriveEnv, import_s = _import_metadrive()

    env = MetaDriveEnv(
        {
            "map": blocks,
            "use_render": False,
            "image_observation": False,
            "start_seed": min(seeds),
            "num_scenarios": max(seeds) - min(seeds) + 1,
            "traffic_density": 0.0,
            "store_map": False,  # every reset builds its map from scratch
            "log_level": logging.CRITICAL,
        }
    )
    started = perf()
    env.lazy_init()
    engine_init_s = perf() - started

    map_manager = env.engine.map_manager
    build_map = map_manager.reset
    spent: list[tuple[float, float]] = []  # (wall, cpu) seconds of each map build

    def timed_build_map():
        began, began_cpu = perf(), cpu()
        out = build_map()
        spent.append((perf() - began, cpu() - began_cpu))
        return out

    map_manager.reset = timed_build_map

    def reset(seed: int) -> tuple[tuple[float, float], float, str]:
        del spent[:]
        began = perf()
        env.reset(seed=seed)
        total = perf() - began
        if len(spent) != 1:
            raise MetaDriveBaselineError(f"seed {seed}: expected one map build per reset, saw {len(spent)}")
        ids = "".join(block.ID for block in env.current_map.blocks)
        return spent[0], total, ids

    try:
        (first_map_s, _), first_reset_s, _ = reset(seeds[0])
        map_s, map_cpu_s, reset_s, block_ids = [], [], [], []
        for seed in seeds:
            (one_map, one_map_cpu), one_reset, ids = reset(seed)
            if len(ids) != blocks + 1:
                raise MetaDriveBaselineError(
                    f"seed {seed}: expected {blocks} blocks after the entry, got {ids!r}"
                )
            map_s.append(one_map)
            map_cpu_s.append(one_map_cpu)
            reset_s.append(one_reset)
            block_ids.append(ids)
    finally:
        env.close()
    return {
        "version": version,
        "import_s": import_s,
        "engine_init_s": engine_init_s,
        "first_map_s": first_map_s,
        "first_reset_s": first_reset_s,
        "map_s": map_s,
        "map_cpu_s": map_cpu_s,
        "reset_s": reset_s,
        "block_ids": block_ids,
    }


def _steps_worker(steps: int, traffic_density: float, warmup: int) -> dict:
    """Runs in the child: time ``steps`` random-action env steps after the untimed start."""
    perf, cpu = time.perf_counter, time.process_time
    version = _prepare_assets_here()
    MetaDriveEnv, import_s = _import_metadrive()
    import numpy as np  # a MetaDrive dependency, already imported by it

    actions = np.random.default_rng(0).uniform(-1.0, 1.0, (warmup + steps, 2)).astype(np.float32)

    started = perf()
    env = MetaDriveEnv(
        {
            "use_render": False,
            "image_observation": False,
            "traffic_density": traffic_density,
            "log_level": logging.CRITICAL,
        }
    )
    env.lazy_init()
    engine_init_s = perf() - started
    try:
        started = perf()
        observation, _ = env.reset()
        first_reset_s = perf() - started
        if np.ndim(observation) != 1:
            raise MetaDriveBaselineError(
                f"expected a state-vector observation, got shape {np.shape(observation)}"
            )
        traffic_vehicles = len(env.engine.traffic_manager.spawned_objects)

        started = perf()
        for action in actions[:warmup]:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                env.reset()
        warmup_s = perf() - started

        resets, reset_s = 0, 0.0
        started, started_cpu = perf(), cpu()
        for action in actions[warmup:]:
            _, _, terminated, truncated, _ = env.step(action)
            if terminated or truncated:
                began = perf()
                env.reset()
                reset_s += perf() - began
                resets += 1
        loop_s, loop_cpu_s = perf() - started, cpu() - started_cpu

        decision_repeat = int(env.config["decision_repeat"])
        physics_step_s = float(env.config["physics_world_step_size"])
        map_blocks = int(env.config["map"])
    finally:
        env.close()
    simulated_s_per_step = decision_repeat * physics_step_s
    return {
        "version": version,
        "map_blocks": map_blocks,
        "observation_size": int(np.size(observation)),
        "decision_repeat": decision_repeat,
        "physics_world_step_size_s": physics_step_s,
        "simulated_s_per_step": simulated_s_per_step,
        "traffic_density": traffic_density,
        "steps_per_s": steps / loop_s,
        "cpu_steps_per_s": steps / loop_cpu_s,
        "simulated_s_per_wall_s": steps * simulated_s_per_step / loop_s,
        "loop_s": loop_s,
        "loop_cpu_s": loop_cpu_s,
        "resets": resets,
        "reset_s": reset_s,
        "traffic_vehicles": traffic_vehicles,
        "import_s": import_s,
        "engine_init_s": engine_init_s,
        "first_reset_s": first_reset_s,
        "warmup_s": warmup_s,
    }


# --------------------------------------------------------------------------- standalone


def _table(t: MetaDriveTimings) -> str:
    rows = [f"MetaDrive {t.version} ({t.python}), {t.blocks}-block maps, physics only, no assets"]
    rows.append(f"{'seed':>6} {'map ms':>9} {'map cpu':>9} {'reset ms':>9}  blocks (entry + sampled)")
    for i, seed in enumerate(t.seeds):  # indexed, not zip(strict=): the file also runs on Python 3.8
        m, c, r = t.map_s[i], t.map_cpu_s[i], t.reset_s[i]
        rows.append(f"{seed:>6} {m * 1e3:>9.1f} {c * 1e3:>9.1f} {r * 1e3:>9.1f}  {t.block_ids[i]}")
    medians = (t.median_map_s, t.median_map_cpu_s, t.median_reset_s)
    rows.append(f"{'median':>6} " + " ".join(f"{v * 1e3:>9.1f}" for v in medians))
    rows.append(
        f"first map {t.first_map_s * 1e3:.1f} ms (reset {t.first_reset_s * 1e3:.1f} ms), "
        f"engine init {t.engine_init_s * 1e3:.1f} ms, import {t.import_s * 1e3:.1f} ms, "
        f"child process {t.process_s:.2f} s"
    )
    return "\n".join(rows)


def _figures(t: MetaDriveTimings) -> dict[str, float]:
    b = t.blocks
    return {
        f"metadrive_map{b}_median_ms": round(t.median_map_s * 1e3, 2),
        f"metadrive_map{b}_median_cpu_ms": round(t.median_map_cpu_s * 1e3, 2),
        f"metadrive_map{b}_first_ms": round(t.first_map_s * 1e3, 2),
        f"metadrive_reset{b}_median_ms": round(t.median_reset_s * 1e3, 2),
        "metadrive_engine_init_ms": round(t.engine_init_s * 1e3, 2),
        "metadrive_import_ms": round(t.import_s * 1e3, 2),
    }


def _steps_table(r: dict) -> str:
    rows = [
        f"MetaDrive {r['version']} ({r['python']}), MetaDriveEnv headless, {r['map_blocks']}-block map, "
        f"{r['observation_size']}-float state observation, random actions, {r['steps']} steps per run",
        f"one env step = {r['decision_repeat']} physics steps x {r['physics_world_step_size_s'] * 1e3:g} ms "
        f"= {r['simulated_s_per_step'] * 1e3:g} ms simulated",
        f"{'traffic':>7} {'steps/s':>9} {'per CPU s':>9} {'sim s/s':>8} {'resets':>6} {'reset s':>7} "
        f"{'vehicles':>8}   start: {'import':>7} {'engine':>7} {'1st reset':>9} {'warm-up':>7} {'child':>6}",
    ]
    for run in r["runs"]:
        rows.append(
            f"{run['traffic_density']:>7g} {run['steps_per_s']:>9.1f} {run['cpu_steps_per_s']:>9.1f} "
            f"{run['simulated_s_per_wall_s']:>8.1f} {run['resets']:>6} {run['reset_s']:>7.2f} "
            f"{run['traffic_vehicles']:>8}          {run['import_s']:>6.2f}s {run['engine_init_s']:>6.2f}s "
            f"{run['first_reset_s']:>8.2f}s {run['warmup_s']:>6.2f}s {run['process_s']:>5.1f}s"
        )
    return "\n".join(rows)


def _steps_figures(r: dict) -> dict[str, float | str]:
    figures: dict[str, float | str] = {
        "metadrive_version": r["version"],
        "metadrive_decision_repeat": r["decision_repeat"],
        "metadrive_physics_step_ms": round(r["physics_world_step_size_s"] * 1e3, 3),
        "metadrive_simulated_ms_per_step": round(r["simulated_s_per_step"] * 1e3, 3),
    }
    for run in r["runs"]:
        tag = f"traffic{run['traffic_density']:g}"
        figures[f"metadrive_steps_per_s_{tag}"] = round(run["steps_per_s"], 1)
        figures[f"metadrive_cpu_steps_per_s_{tag}"] = round(run["cpu_steps_per_s"], 1)
        figures[f"metadrive_start_ms_{tag}"] = round(
            (run["import_s"] + run["engine_init_s"] + run["first_reset_s"]) * 1e3, 1
        )
    return figures


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--blocks", type=int, default=7, help="sampled blocks per map (default 7)")
    parser.add_argument("--seeds", type=int, default=10, help="number of seeds, 0..N-1 (default 10)")
    parser.add_argument("--python", default=None, help=f"interpreter with metadrive (default ${PYTHON_ENV})")
    parser.add_argument(
        "--steps", type=int, default=None, help="measure N env steps per traffic density instead of maps"
    )
    parser.add_argument(
        "--traffic",
        type=float,
        nargs="+",
        default=list(DEFAULT_TRAFFIC_DENSITIES),
        help="traffic densities for --steps, one child each (default 0.1 0)",
    )
    parser.add_argument("--worker", help=argparse.SUPPRESS)
    parser.add_argument("--steps-worker", help=argparse.SUPPRESS)
    parser.add_argument("--prepare-assets", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args(argv)

    if args.prepare_assets or args.worker or args.steps_worker:  # child side: errors as one line, exit 1
        try:
            if args.worker:
                job = json.loads(args.worker)
                _emit(_worker(int(job["blocks"]), [int(s) for s in job["seeds"]]))
            elif args.steps_worker:
                job = json.loads(args.steps_worker)
                _emit(_steps_worker(int(job["steps"]), float(job["traffic_density"]), int(job["warmup"])))
            else:
                _emit({"version": _prepare_assets_here()})
        except MetaDriveBaselineError as exc:
            print(f"error: {exc}", file=sys.stderr)
            return 1
        return 0

    python = args.python or default_python()
    if not metadrive_available(python):
        print(
            f"error: metadrive is not importable by {python}; pip install metadrive-simulator "
            f"there or set {PYTHON_ENV}",
            file=sys.stderr,
        )
        print("{}")
        return 1
    try:
        if args.steps is not None:
            result = measure_metadrive_steps(args.steps, python, traffic_densities=args.traffic)
            print(_steps_table(result))
            print(json.dumps(_steps_figures(result)))
            return 0
        timings = measure_metadrive(args.blocks, range(args.seeds), python)
    except (MetaDriveBaselineError, ValueError) as exc:
        print(f"error: {exc}", file=sys.stderr)
        print("{}")
        return 1
    print(_table(timings))
    print(json.dumps(_figures(timings)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
