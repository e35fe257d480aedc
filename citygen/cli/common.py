"""What the command groups share: the one error path of the whole CLI.

Every command runs inside :class:`Guarded`'s ``invoke``, which turns what a user can cause
into one line on stderr and an exit code, never a traceback:

- a :class:`~citygen.errors.CitygenError` (bad input, a bound exceeded, a missing extra, an
  output path that cannot be written): its lines, exit 2 (130 for
  :class:`~citygen.errors.Interrupted`);
- an :class:`OSError` the user can mend (a full or read-only disk, a file where a folder is
  expected) that reached the CLI without a path of citygen's own: the same kind of line;
- ``MemoryError``: one line, exit 2;
- Ctrl-C: ``interrupted``, with the command that resumes when the command has one
  (:func:`resumable`), exit 130.

Usage errors (an unknown option, a number out of its range) are one line too
(:func:`usage_line`).
"""

from __future__ import annotations

import contextlib
import contextvars
import errno
import shlex
import sys

import typer
from typer.core import TyperGroup

from citygen.errors import CitygenError, is_interrupt

try:  # typer 0.2x carries its own copy of click
    from typer._click import exceptions as click_exceptions
except ImportError:  # older typer uses click itself
    from click import exceptions as click_exceptions  # type: ignore[no-redef]

#: What click raises for a usage error (an unknown option, a value out of its range).
ClickException = click_exceptions.ClickException
#: ``citygen`` alone: its help, not an error (click >= 8.2; older click prints help itself).
NoArgsIsHelp = getattr(click_exceptions, "NoArgsIsHelpError", ())

_RESUME: contextvars.ContextVar[str | None] = contextvars.ContextVar("citygen_resume", default=None)


def print_error(exc: CitygenError) -> None:
    """One line per problem on stderr (``FILE: $.json.path: expected ..., got ...``)."""
    for line in exc.lines():
        typer.echo(line, err=True)


def plural(n: int, word: str, words: str | None = None) -> str:
    """``1 scene``, ``2 scenes``, ``1,536 scenes``."""
    return f"{n:,} {word if n == 1 else (words or word + 's')}"


def invoked_command() -> str:
    """The command line as the user typed it (``citygen ARGS``)."""
    return "citygen " + shlex.join(sys.argv[1:])


def resumable(command: str | None = None) -> None:
    """Say that the running command can be resumed, by ``command`` (default: the command as
    typed, with ``--resume`` added): Ctrl-C then names it."""
    if command is None:
        args = sys.argv[1:]
        command = "citygen " + shlex.join(args if "--resume" in args else [*args, "--resume"])
    _RESUME.set(command)


def interrupted_line() -> str:
    """What Ctrl-C prints: nothing half-written is left, and how to go on."""
    hint = _RESUME.get()
    if hint:
        return f"interrupted (Ctrl-C); every file written is whole; resume with: {hint}"
    return "interrupted (Ctrl-C); no half-written file was left"


def usage_line(exc: ClickException) -> str:
    """A usage error as one line: the command, the message, and where help is."""
    ctx = getattr(exc, "ctx", None)
    path = ctx.command_path if ctx is not None else "citygen"
    message = " ".join(exc.format_message().split()).removesuffix(".")
    param = getattr(exc, "param", None)
    low, high = getattr(param, "min", None), getattr(param, "max", None)
    if low is not None or high is not None:  # the bound, whichever side the value missed
        allowed = f"{low:,} to {high:,}" if low is not None and high is not None else (
            f"at least {low:,}" if low is not None else f"at most {high:,}"
        )  # fmt: skip
        message += f"; allowed: {allowed}"
    return f"{path}: {message} (see '{path} --help')"


def _os_line(exc: OSError) -> str | None:
    """One line for an OSError a user can mend, or None for one that is a bug."""
    from citygen.outputs import OUTPUT_ERRNOS, output_error

    if exc.errno not in OUTPUT_ERRNOS or exc.errno == errno.EPIPE:
        return None
    if exc.filename is not None:
        return str(output_error(exc, exc.filename))
    return f"expected a writable disk, got {exc.strerror or type(exc).__name__}"


def splits_line() -> str:
    """The named splits, for ``citygen --help``: ``urban-nav-1 (train, test), ...``."""
    from citygen.generate.manifests import PARTS, splits

    parts: dict[str, list[str]] = {}
    for name in splits():
        family, _, part = name.rpartition("-")
        if part in PARTS:
            parts.setdefault(family, []).append(part)
        else:
            parts[name] = []
    listed = ", ".join(f"{f} ({', '.join(p)})" if p else f for f, p in parts.items())
    return f"Named splits (`--split NAME`; a family name means all its parts): {listed}."


class Guarded(TyperGroup):
    """The app's group: every command's failures as one line (see the module docstring); its
    help lists the named splits (read from seeds/ when the help is shown)."""

    def format_help(self, ctx, formatter) -> None:
        if ctx.parent is None and self.help and "Named splits" not in self.help:
            with contextlib.suppress(CitygenError):
                self.help = f"{self.help}\n\n{splits_line()}"
        return super().format_help(ctx, formatter)

    def invoke(self, ctx: typer.Context):
        _RESUME.set(None)
        try:
            return super().invoke(ctx)
        except CitygenError as exc:
            print_error(exc)
            raise typer.Exit(exc.exit_code) from None
        except (KeyboardInterrupt, SystemError) as exc:
            if not is_interrupt(exc):
                raise
            with contextlib.suppress(Exception):
                typer.echo(interrupted_line(), err=True)
            raise typer.Exit(130) from None
        except MemoryError:
            typer.echo(
                "out of memory: expected a task that fits this machine's memory, got more; "
                "ask for less (fewer scenes, a coarser resolution) or free memory",
                err=True,
            )
            raise typer.Exit(2) from None
        except OSError as exc:
            line = _os_line(exc)
            if line is None:
                raise
            typer.echo(line, err=True)
            raise typer.Exit(2) from None
