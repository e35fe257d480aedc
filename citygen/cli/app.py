"""The ``citygen`` typer app with every command group on it, and the console script's entry point."""

from __future__ import annotations

import sys
from typing import Annotated

import typer

import citygen
from citygen.cli import assets, export, generate, runner, train, validate
from citygen.cli.common import ClickException, Guarded, NoArgsIsHelp, print_error, usage_line
from citygen.errors import CitygenError

app = typer.Typer(
    name="citygen",
    cls=Guarded,
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

    Every failure a user can cause is one line on stderr: citygen's errors and the
    operating system's refusals (by :class:`~citygen.cli.common.Guarded`, exit 2; Ctrl-C
    130) and usage errors (an unknown option, a number out of its range: exit 2).
    """
    try:
        code = app(prog_name="citygen", standalone_mode=False)
    except NoArgsIsHelp as exc:
        exc.show()
        code = exc.exit_code
    except ClickException as exc:
        typer.echo(usage_line(exc), err=True)
        code = exc.exit_code
    except typer.Abort:
        typer.echo("aborted", err=True)
        code = 1
    except CitygenError as exc:
        print_error(exc)
        code = exc.exit_code
    sys.exit(code if isinstance(code, int) else 0)
