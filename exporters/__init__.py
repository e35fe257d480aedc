"""citygen.exporters: compile a scene spec to the files other simulators load.

Every exporter module has ``export(scene, out_dir, **options) -> list[Path]``,
taking a :class:`~citygen.spec.Scene` or the path of a scene file and returning the
files it wrote. Exporters read only the spec (and the asset catalog): importing
one never imports the generator or the runner, so another simulator's code can
write ``from citygen.exporters import mjcf`` with no generator involved.
"""

from __future__ import annotations

from pathlib import Path
from typing import Protocol

from citygen.io import load_scene
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
