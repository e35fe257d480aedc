"""Real places: one scene of the place an OpenStreetMap extract on disk maps in a box.

``generate_place("campus.osm.pbf", (west, south, east, north), seed=7)`` is what
``citygen generate --osm campus.osm.pbf --bbox W,S,E,N --seed 7`` runs: the config of
:func:`~citygen.generate.layouts.osm.osm_config` through every stage
(:func:`~citygen.generate.pipeline.generate`). A split manifest does the same with
``config.layout = "osm"`` and an ``[osm]`` table (``file``, ``bbox``).
"""

from __future__ import annotations

from pathlib import Path

from citygen.generate.layouts.osm import osm_config
from citygen.generate.pipeline import generate
from citygen.spec.scene import Scene


def generate_place(
    file: str | Path, bbox: tuple[float, float, float, float], seed: int = 0, **updates
) -> Scene:
    """The scene of the place ``file`` maps in ``bbox`` (degrees), made with ``seed``;
    ``updates`` replace top-level fields of its config (:func:`osm_config`)."""
    return generate(osm_config(str(file), bbox, **updates), seed)


def place_name(file: str | Path) -> str:
    """The scene file's name for an extract: ``campus.osm.pbf`` gives ``campus.json``."""
    name = Path(file).name
    for suffix in (".osm.pbf", ".pbf", ".osm"):
        if name.endswith(suffix):
            return name[: -len(suffix)] + ".json"
    return Path(name).stem + ".json"
