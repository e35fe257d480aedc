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

import importlib
import warnings
from collections.abc import Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import MappingProxyType

from citygen.errors import CitygenError
from citygen.exporters import ExportWarning
from citygen.io import load_scene
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


def module_options(module: str, terrain_resolution: float | None, occupancy_resolution: float | None) -> dict:
    """The options a batch passes to an exporter module besides ``name``."""
    if module == "occupancy":
        return {} if occupancy_resolution is None else {"resolution": occupancy_resolution}
    if module in TERRAIN_OPTION and terrain_resolution is not None:
        return {TERRAIN_OPTION[module]: terrain_resolution}
    return {}


def export_batch(
    scenes: Sequence[str | Path],
    out: str | Path,
    formats: Sequence[str] = tuple(FORMATS),
    *,
    terrain_resolution: float | None = None,
    occupancy_resolution: float | None = None,
) -> Iterator[Event]:
    """Export every scene file to every format into ``out``, yielding what happens as it
    happens; failures are ``error`` events (``FORMAT: message``), never exceptions. A warning
    two formats of one scene share (the PNG view compiles the MJCF) is yielded once."""
    out = Path(out)
    used: dict[str, Path] = {}
    for raw in scenes:
        path = Path(raw)
        try:
            model = load_scene(path)
        except CitygenError as exc:
            for line in exc.lines():
                yield Event("error", path, line.removeprefix(f"{path}: "))
            continue
        name = export_name(path, model)
        if name in used:
            yield Event(
                "error", path, f"its files would be named {name!r}, as those of {used[name]}; rename one of "
                "them or export it with another --out",
            )  # fmt: skip
            continue
        used[name] = path
        said: set[str] = set()  # a warning two formats share (png's view is MJCF's) is said once
        for fmt in formats:
            for module_name in FORMATS[fmt]:
                lod = (terrain_resolution, occupancy_resolution)
                for event in _one(path, out, name, fmt, module_name, *lod):
                    if event.kind == "warning" and event.text in said:
                        continue
                    said.add(event.text)
                    yield event


def _one(
    path: Path,
    out: Path,
    name: str,
    fmt: str,
    module_name: str,
    terrain: float | None,
    occupancy: float | None,
) -> Iterator[Event]:
    module = importlib.import_module(f"citygen.exporters.{module_name}")
    options = {"name": name, **module_options(module_name, terrain, occupancy)}
    written: list[Path] = []
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ExportWarning)
        try:
            written = module.export(path, out, **options)
            failure = None
        except CitygenError as exc:
            failure = f"{fmt}: {' '.join(exc.lines())}"
        except RuntimeError as exc:
            if module_name != "view":
                failure = f"{fmt}: {type(exc).__name__}: {exc}"
            else:
                failure = None
                yield Event("skipped", path, f"skipped the perspective picture: {exc}")
        except (OSError, MemoryError, ValueError) as exc:
            failure = f"{fmt}: {type(exc).__name__}: {exc}"
    for w in caught:
        if issubclass(w.category, ExportWarning):
            yield Event("warning", path, str(w.message))
    for p in written:
        yield Event("wrote", path, str(p))
    if failure is not None:
        yield Event("error", path, failure)
