"""``citygen generate --osm FILE --bbox W,S,E,N``: a real place from an OpenStreetMap extract."""

from __future__ import annotations

import math
from pathlib import Path

import typer

import citygen
from citygen.errors import SpecError
from citygen.outputs import check_output


def parse_bbox(text: str | None) -> tuple[float, float, float, float]:
    """``WEST,SOUTH,EAST,NORTH`` in degrees, or a one-line :class:`SpecError` naming ``--bbox``."""
    expected = (
        "--bbox: expected WEST,SOUTH,EAST,NORTH in degrees (four numbers, e.g. 8.539,47.369,8.545,47.373)"
    )
    if text is None:
        raise SpecError(f"{expected}, got none")
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        values = ()
    if len(values) != 4 or not all(math.isfinite(v) for v in values):
        raise SpecError(f"{expected}, got {text!r}")
    return values  # type: ignore[return-value]


def generate_place(
    osm: Path | None, bbox: str | None, *, split: str | None, seed: int | None, out: Path
) -> None:
    """Generate, validate and write the scene of ``osm`` in ``bbox`` to ``out/<name>.json``, and
    its generator config to ``out/<name>.config.json`` (for ``citygen rebuild --config``)."""
    from citygen.generate import generate
    from citygen.generate.layouts.osm import osm_config
    from citygen.generate.places import left_out_line, place_name
    from citygen.io import dumps, write_atomic

    if split is not None:
        raise SpecError("--split: expected either --split or --osm, got both")
    if osm is None:
        raise SpecError("--osm: expected an OpenStreetMap file with --bbox, got none")
    box = parse_bbox(bbox)
    target = out / place_name(osm)
    check_output(out, folder=True, option="--out")
    config = osm_config(str(osm), box)
    scene = generate(config, 0 if seed is None else seed)
    problems = citygen.validate(scene)
    if problems:
        raise SpecError(problems, file=f"{osm} in {bbox}")
    citygen.save_scene(scene, target)
    # The config beside the scene: `citygen rebuild SCENE --from STAGE --config` takes it.
    settings = target.with_suffix(".config.json")
    write_atomic(settings, dumps(config).encode("utf-8"))
    typer.echo(
        f"wrote {target} ({len(scene.zones):,} zones, {len(scene.placements):,} objects) and {settings.name}"
    )
    note = left_out_line(scene, config)
    if note is not None:
        typer.echo(f"{osm}: warning: {note}", err=True)
