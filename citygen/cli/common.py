"""What the command groups share: printing citygen's errors as the CLI reports them."""

from __future__ import annotations

import typer

from citygen.errors import CitygenError


def print_error(exc: CitygenError) -> None:
    """One line per problem on stderr (``FILE: $.json.path: expected ..., got ...``)."""
    for line in exc.lines():
        typer.echo(line, err=True)
