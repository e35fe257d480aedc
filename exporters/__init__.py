"""citygen.exporters: compile a scene spec to the files other simulators load.

Every exporter module has ``export(scene, out_dir, **options) -> list[Path]``,
taking a :class:`~citygen.spec.Scene` or the path of a scene file and returning the
files it wrote. Exporters read only the spec (and the asset catalog): importing
one never imports the generator or the runner, so another simulator's code can
write ``from citygen.exporters import mjcf`` with no generator involved.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from types import MappingProxyType
from typing import Protocol

from citygen.errors import ExportError
from citygen.io import load_scene, write_atomic
from citygen.spec.scene import Scene


class Exporter(Protocol):
    """What every exporter module provides."""

    def export(self, scene: Scene | str | Path, out_dir: str | Path, **options: object) -> list[Path]: ...


def as_scene(scene: Scene | str | Path) -> tuple[Scene, Path | None]:
    """The scene itself and the folder its mesh paths are relative to (None for a model)."""
    if isinstance(scene, Scene):
        return scene, None
    path = Path(scene)
    return load_scene(path), path.parent


class ExportWarning(UserWarning):
    """Something in the scene the target format cannot express, and what was done instead.

    Exporters never drop content silently: they ``warnings.warn(ExportWarning(...))``
    with a one-line message naming the JSON path (``$.agents[2]``) and what the
    format lost; ``citygen export`` prints these on stderr.
    """


def shared_file(out_dir: str | Path, data: bytes, suffix: str) -> Path:
    """Write ``data`` once under ``out_dir/assets/`` named by its content digest.

    Repeated assets (the same bench in many scenes of a dataset exported to one
    folder) are written once and shared; an existing file with the same name has
    the same bytes, so it is left alone. The write is atomic. Returns the path.
    """
    digest = hashlib.sha256(data).hexdigest()[:20]
    path = Path(out_dir) / "assets" / f"{digest}{suffix}"
    if not path.exists():
        write_atomic(path, data)
    return path


#: The colour of each zone kind, shared by every exporter that draws zones (the PNG map,
#: MJCF materials, GLB, the HTML viewer, the occupancy picture).
ZONE_COLORS = MappingProxyType(
    {
        "roadway": "#4d5257",
        "bike_lane": "#2f8f83",
        "parking": "#8795a6",
        "curb": "#bdbdbd",
        "sidewalk": "#ebe6da",
        "crosswalk": "#3b4a5e",
        "plaza": "#e0c59a",
        "trail": "#bf9960",
        "building": "#9c8f86",
        "vegetation": "#8cc269",
        "water": "#7fb4e0",
    }
)
#: The colour of placed objects in the drawn maps (the PNG map, the occupancy picture).
OBJECT_COLOR = "#c0622d"


def output_name(scene: Scene | str | Path, name: object, fmt: str) -> str:
    """The file stem an exporter writes ``scene`` under: ``name`` when given, else the scene
    file's stem, else ``<split>-<index>`` from its meta, else ``scene``. A name with folders
    in it is an :class:`~citygen.errors.ExportError` naming the format."""
    if name is None:
        if not isinstance(scene, Scene):
            name = Path(scene).stem
        elif scene.meta.split is not None and scene.meta.index is not None:
            name = f"{scene.meta.split}-{scene.meta.index:05d}"
        else:
            name = "scene"
    if not isinstance(name, str) or not name or "/" in name or "\\" in name or name in (".", ".."):
        raise ExportError(f"{fmt} export: expected a file name without folders for 'name', got {name!r}")
    return name
