"""Exporting many scenes to many formats at once: what ``citygen export`` runs.

One scene or one format failing never stops the others: :func:`export_batch` reports the
failure as one line and goes on, and says at the end how many failed. Names never collide:
a scene file as ``citygen generate`` writes it (``<split>/<part>/NNNN.json``, whose stem is
only its index) is exported as ``<split>-NNNN`` from its ``meta`` (``urban-nav-2-test-0000``),
any other file under its own stem; a second scene of a batch that would still take a name
already written is refused, never written over the first.

Each format's level of detail is the exporter's own automatic choice
(:mod:`citygen.exporters.lod`) unless ``terrain_resolution`` or ``occupancy_resolution``
is given.

>>> from pathlib import Path
>>> from citygen.io import load_scene
>>> export_name(Path("out/urban-nav-2/test/0000.json"), load_scene("examples/nav_static_10m.json"))
'0000'
"""

from __future__ import annotations

import contextlib
import importlib
import multiprocessing
import os
import signal
import sys
import warnings
from collections.abc import Iterable, Iterator, Mapping, Sequence
from dataclasses import dataclass
from multiprocessing.connection import Connection, wait
from pathlib import Path
from types import MappingProxyType
from typing import Any

from citygen.errors import CitygenError
from citygen.exporters import ExportWarning
from citygen.io import load_scene
from citygen.outputs import staged, unstaged
from citygen.spec.scene import Scene

#: Formats and the exporter modules that write them (``png``: the top-down map and, where
#: OpenGL exists, MuJoCo's perspective view).
FORMATS = MappingProxyType(
    {
        "mjcf": ("mjcf",),
        "usd": ("usd",),
        "urdf": ("urdf",),
        "occupancy": ("occupancy",),
        "glb": ("glb",),
        "html": ("html",),
        "png": ("picture", "view"),
    }
)
#: The option each exporter module takes the terrain's sample spacing (m) as.
TERRAIN_OPTION = MappingProxyType(
    {"mjcf": "resolution", "usd": "terrain_resolution", "urdf": "resolution", "glb": "resolution",
     "html": "resolution", "view": "resolution"}
)  # fmt: skip


@dataclass(frozen=True)
class Event:
    """One thing a batch did: ``kind`` is ``wrote`` (``text`` a path), ``warning``,
    ``skipped`` (a format this machine cannot write) or ``error``; ``scene`` the file."""

    kind: str
    scene: Path
    text: str


def export_name(path: Path, scene: Scene) -> str:
    """The stem a scene's files get: ``<split>-NNNN`` for a file named by its index alone,
    as ``citygen generate`` names them (so parts and splits never collide), else its stem."""
    meta = scene.meta
    if meta.split is not None and meta.index is not None and path.stem == f"{meta.index:04d}":
        return f"{meta.split}-{path.stem}"
    return path.stem


def module_options(
    module: str, terrain_resolution: float | None, occupancy_resolution: float | None,
    extra: Mapping[str, Mapping[str, Any]] | None = None,
) -> dict:  # fmt: skip
    """The options a batch passes to an exporter module besides ``name``: the resolutions,
    and ``extra[module]`` (``{"urdf": {"visual": False}, "mjcf": {"terrain": "convex"}}``)."""
    own = dict((extra or {}).get(module, {}))
    if module == "occupancy":
        return own if occupancy_resolution is None else {"resolution": occupancy_resolution, **own}
    if module in TERRAIN_OPTION and terrain_resolution is not None:
        return {TERRAIN_OPTION[module]: terrain_resolution, **own}
    return own


@dataclass(frozen=True)
class _Unit:
    """One exporter module to run on one scene: what a worker process does."""

    path: Path
    out: Path
    name: str
    fmt: str
    module: str
    terrain: float | None
    occupancy: float | None
    extra: tuple[tuple[str, Any], ...] = ()
    """The module's own options (``export_batch``'s ``options[module]``), as items."""


def _steps(
    scenes: Sequence[str | Path], out: Path, formats: Sequence[str], terrain: float | None,
    occupancy: float | None, options: Mapping[str, Mapping[str, Any]],
) -> Iterator[_Unit | list[Event]]:  # fmt: skip
    """The batch in its order: each scene's exporter modules to run, or the error events of a
    scene that cannot be read or would take a name already used."""
    used: dict[str, Path] = {}
    for raw in scenes:
        path = Path(raw)
        try:
            model = load_scene(path)
        except CitygenError as exc:
            yield [Event("error", path, line.removeprefix(f"{path}: ")) for line in exc.lines()]
            continue
        name = export_name(path, model)
        del model
        if name in used:
            yield [Event(
                "error", path, f"its files would be named {name!r}, as those of {used[name]}; rename one of "
                "them or export it with another --out",
            )]  # fmt: skip
            continue
        used[name] = path
        for fmt in formats:
            for module_name in FORMATS[fmt]:
                extra = tuple(sorted(options.get(module_name, {}).items()))
                yield _Unit(path, out, name, fmt, module_name, terrain, occupancy, extra)


def export_batch(
    scenes: Sequence[str | Path],
    out: str | Path,
    formats: Sequence[str] = tuple(FORMATS),
    *,
    terrain_resolution: float | None = None,
    occupancy_resolution: float | None = None,
    jobs: int = 1,
    options: Mapping[str, Mapping[str, Any]] | None = None,
) -> Iterator[Event]:
    """Export every scene file to every format into ``out``, yielding what happens as it
    happens; failures are ``error`` events (``FORMAT: message``), never exceptions. A warning
    two formats of one scene share (the PNG view compiles the MJCF) is yielded once.

    ``jobs`` above 1 runs the exporter modules (one scene's formats as well as different
    scenes) in up to that many worker processes at once, a process each (:func:`_parallel`):
    the same files and the same events in the same order, each module's as soon as it and
    every one before it have finished. A worker that dies (killed, out of memory) is that
    format's error; the others go on. ``options`` are exporter modules' own options by module
    name (``{"urdf": {"visual": False}}``)."""
    steps: Iterable[_Unit | list[Event]] = _steps(
        scenes, Path(out), formats, terrain_resolution, occupancy_resolution, options or {}
    )
    if jobs > 1:
        steps = list(steps)
        jobs = min(jobs, sum(isinstance(step, _Unit) for step in steps))
    if jobs > 1:
        results: Iterator[list[Event] | Iterator[Event]] = _parallel(list(steps), jobs)
    else:  # one at a time, here
        results = (step if isinstance(step, list) else _run(step) for step in steps)
    said: dict[Path, set[str]] = {}  # a warning two formats share (png's view is MJCF's) is said once
    for events in results:
        for event in events:
            seen = said.setdefault(event.scene, set())
            if event.kind == "warning" and event.text in seen:
                continue
            seen.add(event.text)
            yield event


def _run(unit: _Unit) -> Iterator[Event]:
    return _one(
        unit.path, unit.out, unit.name, unit.fmt, unit.module, unit.terrain, unit.occupancy, unit.extra
    )


#: About how long each exporter module takes on a city, relative to the others (CPU seconds
#: on urban-tra-city, ``benchmarks/bench_export.py --all-formats``): :func:`_parallel` starts
#: the longest first so that the last to finish is a short one.
COST = MappingProxyType(
    {"urdf": 76.0, "view": 70.0, "glb": 62.0, "html": 54.0, "occupancy": 36.0, "mjcf": 36.0, "usd": 26.0,
     "picture": 3.0}
)  # fmt: skip


def _worker(conn: Connection, unit: _Unit) -> None:
    """A worker process: run one unit and send its events back."""
    if sys.platform.startswith("linux"):  # end when the batch's process is killed
        import ctypes
        import signal

        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
    try:
        events = list(_run(unit))
    except Exception as exc:  # a bug in one exporter must not lose the other formats
        events = [Event("error", unit.path, f"{unit.fmt}: {type(exc).__name__}: {exc}")]
    except KeyboardInterrupt:  # Ctrl-C reached every process: the batch's process reports it
        return
    conn.send(events)
    conn.close()


def _context() -> multiprocessing.context.BaseContext:
    """Where :func:`_parallel`'s workers come from: a fork server where the platform has one
    (so a script calling :func:`export_batch` with ``jobs > 1`` needs the usual
    ``if __name__ == "__main__":`` guard), else the platform's default."""
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("forkserver" if "forkserver" in methods else None)


def _parallel(steps: list[_Unit | list[Event]], jobs: int) -> Iterator[list[Event]]:
    """Each step's events in order, running up to ``jobs`` units at once, each in a process of
    its own, scene by scene and each scene's costliest (:data:`COST`) first.

    Workers come from a fork server (a fresh interpreter that imports the exporter modules
    once, then forks a worker per unit), never from this process: a process that has made a
    GL context (the PNG view, a test or a notebook that rendered before) and is forked
    leaves the child's EGL initialisation waiting forever on a lock the parent held (seen:
    ``export --format all`` run in-process after a render hung in ``mujoco.Renderer``)."""
    context = _context()
    units = [i for i, step in enumerate(steps) if isinstance(step, _Unit)]
    if context.get_start_method() == "forkserver":  # imported once in the server, not per worker
        modules = [f"citygen.exporters.{m}" for m in dict.fromkeys(steps[i].module for i in units)]
        context.set_forkserver_preload(["citygen.exporters.batch", *modules])
    # Scene by scene (so that the first scenes' lines come first), each one's costliest first.
    first: dict[Path, int] = {}
    for i in units:
        first.setdefault(steps[i].path, i)
    queue = sorted(units, key=lambda i: (first[steps[i].path], -COST.get(steps[i].module, 1.0)))
    done: dict[int, list[Event]] = {i: step for i, step in enumerate(steps) if isinstance(step, list)}
    running: dict[int, tuple[Any, Connection]] = {}
    emitted = 0
    try:
        while emitted < len(steps):
            while queue and len(running) < jobs:
                i = queue.pop(0)
                receive, send = context.Pipe(duplex=False)
                process = context.Process(target=_worker, args=(send, steps[i]), name=f"citygen-export-{i}")
                process.start()
                send.close()
                running[i] = (process, receive)
            while emitted in done:
                yield done.pop(emitted)
                emitted += 1
            if emitted >= len(steps):
                break
            ready = wait([receive for _, receive in running.values()])
            for i, (process, receive) in list(running.items()):
                if receive not in ready:
                    continue
                try:
                    events = receive.recv()
                except (EOFError, OSError):
                    events = None
                receive.close()
                process.join()
                if events is None:
                    unit = steps[i]
                    events = [Event(
                        "error", unit.path, f"{unit.fmt}: its worker process ended without a result "
                        f"(exit code {process.exitcode}; out of memory?)",
                    )]  # fmt: skip
                done[i] = events
                del running[i]
    finally:
        for process, receive in running.values():
            with contextlib.suppress(OSError):  # Ctrl-C first: the worker removes its staged files
                os.kill(process.pid, signal.SIGINT)
            process.join(5)
            process.kill()
            process.join()
            receive.close()


def _one_line(exc: BaseException, named: bool = True) -> str:
    """An exception as one line: its type and its message's first line (Qhull's error runs to
    a dozen lines of options)."""
    text = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
    return f"{type(exc).__name__}: {text}" if named else text


def _one(
    path: Path,
    out: Path,
    name: str,
    fmt: str,
    module_name: str,
    terrain: float | None,
    occupancy: float | None,
    extra: tuple[tuple[str, Any], ...] = (),
) -> Iterator[Event]:
    module = importlib.import_module(f"citygen.exporters.{module_name}")
    options = {"name": name, **module_options(module_name, terrain, occupancy, {module_name: dict(extra)})}
    written: list[Path] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ExportWarning)
        try:
            with staged(out) as stage:  # all of a format's files, or none of them
                written = [unstaged(p, stage, out) for p in module.export(path, stage, **options)]
            failure = None
        except CitygenError as exc:
            failure = f"{fmt}: {' '.join(exc.lines())}"
        except RuntimeError as exc:
            if module_name != "view":
                failure = f"{fmt}: {_one_line(exc)}"
            else:
                failure = None
                yield Event(
                    "skipped", path, f"skipped the perspective picture: {_one_line(exc, named=False)}"
                )
        except (OSError, MemoryError, ValueError) as exc:
            failure = f"{fmt}: {_one_line(exc)}"
    for w in caught:
        if issubclass(w.category, ExportWarning):
            yield Event("warning", path, str(w.message))
    for p in written:
        yield Event("wrote", path, str(p))
    if failure is not None:
        yield Event("error", path, failure)
