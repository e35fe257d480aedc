"""``citygen validate`` and ``citygen schema``: the scene spec's checks and its JSON Schema files."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

import citygen
from citygen.cli.common import print_error
from citygen.errors import SpecError


def validate(
    files: Annotated[
        list[Path],
        typer.Argument(
            help="Scene files (.json), split manifests or generator configs (.toml).", show_default=False
        ),
    ],
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Print only problems.")] = False,
) -> None:
    """Check scene files (and split manifests, generator configs): their shape against the schema,
    then their meaning.

    Semantic checks: polygons valid and inside the bounds, zones and objects not
    overlapping, neighbouring terrain tiles agreeing on shared edges, agents and the
    task on walkable ground, mesh paths staying inside the scene's folder. Exits 0
    when every file is valid, 2 otherwise, with one line per problem:
    `FILE: $.json.path: expected ..., got ...`
    """
    from citygen.generate.splits import resolve

    bad = 0
    for file in files:
        try:
            if file.suffix.lower() == ".toml":
                resolve(str(file))  # manifests and generator configs are checked entirely on loading
                problems = []
            else:
                problems = citygen.validate(citygen.load_scene(file), base_dir=file.parent)
        except SpecError as exc:
            print_error(exc)
            bad += 1
            continue
        if problems:
            print_error(SpecError(problems, file=str(file)))
            bad += 1
        elif not quiet:
            typer.echo(f"{file}: valid")
    if bad:
        raise typer.Exit(2)


def schema(
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder to write the schema files into.")] = Path(
        "schemas"
    ),
    check: Annotated[
        bool,
        typer.Option("--check", help="Write nothing; exit 2 if the files in OUT differ from the models."),
    ] = False,
) -> None:
    """Write the JSON Schema files (scene, split manifest) generated from the spec models."""
    from citygen.schema import stale_schemas, write_schemas

    if check:
        stale = stale_schemas(out)
        for name in stale:
            typer.echo(
                f"{out / name}: out of date with the models; run 'citygen schema --out {out}'", err=True
            )
        raise typer.Exit(2 if stale else 0)
    from citygen.outputs import check_output

    check_output(out, folder=True, option="--out")
    for path in write_schemas(out):
        typer.echo(f"wrote {path}")


def register(app: typer.Typer) -> None:
    """Add ``validate`` and ``schema`` to ``app``."""
    app.command()(validate)
    app.command()(schema)
