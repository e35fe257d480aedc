"""Options the mesh exporters (GLB, HTML, URDF, the occupancy map) share: the output's
name, unknown options, the terrain's ``resolution`` (:data:`AUTO` lets the exporter choose)
and the folder mesh placements are relative to (``scene_dir``)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any

from citygen.errors import ExportError
from citygen.exporters import as_scene
from citygen.exporters import output_name as shared_output_name
from citygen.spec.scene import Scene


def output_name(scene: Scene | str | Path, options: dict[str, Any], fmt: str) -> str:
    """The file stem for ``scene`` (:func:`citygen.exporters.output_name` of option ``name``)."""
    return shared_output_name(scene, options.get("name"), fmt)


def check_options(options: dict[str, Any], allowed: Sequence[str], fmt: str) -> None:
    """An :class:`ExportError` naming the first option not in ``allowed``."""
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ExportError(
            f"{fmt} export: unknown option {unknown[0]!r}; expected one of {', '.join(allowed)}"
        )


#: The ``resolution`` that lets an exporter choose (:func:`fit_terrain`).
AUTO = "auto"


def resolution_option(value: Any, fmt: str) -> float | str | None:
    """The ``resolution`` option: None, :data:`AUTO` or a positive number of metres."""
    if value is None or value == AUTO:
        return value
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not (math.isfinite(value) and value > 0)
    ):
        raise ExportError(
            f"{fmt} export: expected a positive number of metres for 'resolution', got {value!r}"
        )
    return float(value)


def scene_dir_of(scene: Scene | str | Path, options: dict[str, Any]) -> tuple[Scene, Path | None]:
    """The scene model and the folder its mesh paths are relative to (option ``scene_dir``
    for a model, the file's folder for a path)."""
    model, folder = as_scene(scene)
    given = options.get("scene_dir")
    if given is not None:
        folder = Path(given)  # type: ignore[arg-type]
    return model, folder
