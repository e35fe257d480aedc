"""Real places: one scene of the place an OpenStreetMap extract on disk maps in a box.

``generate_place("campus.osm.pbf", (west, south, east, north), seed=7)`` is what
``citygen generate --osm campus.osm.pbf --bbox W,S,E,N --seed 7`` runs: the config of
:func:`~citygen.generate.layouts.osm.osm_config` through every stage
(:func:`~citygen.generate.pipeline.generate`). A split manifest does the same with
``config.layout = "osm"`` and an ``[osm]`` table (``file``, ``bbox``).
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path

from citygen.generate.layouts.osm import osm_config, place_of
from citygen.generate.pipeline import generate
from citygen.spec.config import GeneratorConfig
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


def left_out(scene: Scene, config: GeneratorConfig) -> list[tuple[str, str]]:
    """The mapped objects of the place ``config`` names that its ``scene`` does not hold, as
    ``(OSM id, category)``:
    those whose mapped point lies, even 0.45 m around it, on ground the scene draws as roadway,
    curb, a curb ramp, parking, water or a building (mapped inside a building, or beside a
    street its lanes keep wider than the real one where the street gives way no more), or on
    another object. Their points are in the extract; the scene's objects are named by their ids."""
    if config.osm is None:
        return []
    have = {p.id.rsplit("-", 1)[1] for p in scene.placements}
    return [(m.id, m.category) for m in place_of(config).mapped if m.id not in have]


def left_out_line(scene: Scene, config: GeneratorConfig) -> str | None:
    """One line saying how many mapped objects :func:`left_out` found, of which kinds, and
    the first ids; None when every one is there."""
    gone = left_out(scene, config)
    if not gone:
        return None
    total = len(place_of(config).mapped)
    kinds = ", ".join(f"{n} {c}" for c, n in sorted(Counter(c for _, c in gone).items(), key=lambda x: -x[1]))
    ids = ", ".join(i for i, _ in gone[:5]) + (", ..." if len(gone) > 5 else "")
    return (
        f"{len(gone)} of {total} mapped objects left out ({kinds}): each stands, even 0.45 m around "
        f"its point, on roadway, curb, a curb ramp, parking, water, a building or another object "
        f"as the scene draws them ({ids})"
    )
