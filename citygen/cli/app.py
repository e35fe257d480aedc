"""The ``citygen`` typer app with every command group on it, and the console script's entry point."""

from __future__ import annotations

import sys
from typing import Annotated

import typer

import citygen
from citygen.cli import assets, export, generate, runner, train, validate
from citygen.cli.common import print_error
from citygen.errors import CitygenError

app = typer.Typer(
    name="citygen",
    help="Seeded urban scenes for robot learning: generate, validate and export them.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="markdown",
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"citygen {citygen.__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")
    ] = False,
) -> None:
    """Seeded urban scenes for robot learning: generate, validate and export them."""


# In the order `citygen --help` lists them.
for group in (validate, export, generate, assets, runner, train):
    group.register(app)


def main() -> None:
    """Entry point of the ``citygen`` console script.

    Click handles its own usage errors (exit 2), ``--help`` and Ctrl-C; citygen's
    errors are printed here, one line per problem, with exit code 2.
    """
    try:
        app()
    except CitygenError as exc:
        print_error(exc)
        sys.exit(2)
