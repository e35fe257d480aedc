"""The errors citygen raises, and the one-line problem reports the CLI prints.

Every error a user can cause is a :class:`CitygenError`. The CLI catches exactly
this hierarchy, prints one line per problem and exits with code 2; anything else
escaping is a bug in citygen, not in the user's input.

>>> p = Problem("$.placements[3].position", "3 numbers [x, y, z] in metres", "[1.0, 2.0]")
>>> str(p)
'$.placements[3].position: expected 3 numbers [x, y, z] in metres, got [1.0, 2.0]'
>>> str(SpecError([p], file="scene.json"))
'scene.json: $.placements[3].position: expected 3 numbers [x, y, z] in metres, got [1.0, 2.0]'
>>> str(SpecError("--policy: expected one of stand, trot, got 'planner'"))
"--policy: expected one of stand, trot, got 'planner'"
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass


@dataclass(frozen=True, slots=True)
class Problem:
    """One thing wrong with a document, located by a JSON path (``$`` is the root)."""

    path: str
    expected: str
    found: str

    def __str__(self) -> str:
        return f"{self.path}: expected {self.expected}, got {self.found}"

    def line(self, file: str | None = None) -> str:
        """The problem as the CLI prints it, prefixed by the file when there is one."""
        return f"{file}: {self}" if file else str(self)


class CitygenError(Exception):
    """Base of every error caused by input or environment rather than by a bug."""

    #: The CLI's exit status for this error.
    exit_code = 2

    def lines(self) -> list[str]:
        """The error as one or more self-contained lines, ready to print."""
        return [str(self)]


class SpecError(CitygenError):
    """A scene, config or manifest document is malformed or inconsistent: a list of
    :class:`Problem` (each located by its JSON path), or one message already written as a
    line (an option or a combination of options that does not fit)."""

    def __init__(self, problems: Iterable[Problem] | str, file: str | None = None) -> None:
        self.message = problems if isinstance(problems, str) else None
        self.problems = [] if isinstance(problems, str) else list(problems)
        self.file = file
        super().__init__("\n".join(self.lines()))

    def lines(self) -> list[str]:
        if self.message is not None:
            return [f"{self.file}: {self.message}" if self.file else self.message]
        return [p.line(self.file) for p in self.problems]


class GenerationError(CitygenError):
    """A generator stage could not produce a scene (for example WFC contradictions)."""

    def __init__(self, stage: str, seed: int | None, message: str) -> None:
        self.stage, self.seed, self.message = stage, seed, message
        super().__init__(f"generation failed in stage {stage!r} (seed {seed}): {message}")

    def __reduce__(self):
        # A worker process's error reaches its parent pickled: rebuilt from its three parts.
        return type(self), (self.stage, self.seed, self.message)


class ExportError(CitygenError):
    """A scene cannot be written in the requested format."""


class OutputError(CitygenError, OSError):
    """A file or folder cannot be written where the user asked: a file where a folder is
    expected, a read-only or full disk. One line naming the path, what was expected there and
    what was found. Built from one message, so it survives pickling from a worker process; an
    :class:`OSError` too, so code that caught the operating system's error still catches it
    (its ``strerror`` is ``reason``, the line without the path: ``expected ..., got ...``)."""

    def __init__(self, message: str, reason: str | None = None) -> None:
        super().__init__(message)
        self.strerror = reason or message

    def __reduce__(self):
        return type(self), (str(self), self.strerror)

    def __str__(self) -> str:
        return self.args[0]


class Interrupted(CitygenError):
    """The user stopped a command (Ctrl-C, SIGTERM): what was kept and how to go on. The CLI
    exits with code 130 (128 + SIGINT), as a shell reports an interrupted command."""

    exit_code = 130


def is_interrupt(exc: BaseException) -> bool:
    """Whether ``exc`` is a Ctrl-C (or SIGTERM turned into one): a :class:`KeyboardInterrupt`,
    or the :class:`SystemError` a numba-compiled function raises when the interrupt arrives
    while it runs (``returned a result with an exception set``, the interrupt its cause)."""
    seen = 0
    while exc is not None and seen < 8:
        if isinstance(exc, KeyboardInterrupt):
            return True
        if not isinstance(exc, SystemError):
            return False
        exc, seen = exc.__cause__ or exc.__context__, seen + 1
    return False


class DependencyMissing(CitygenError):
    """An optional dependency needed for the requested feature is not installed."""

    def __init__(self, package: str, feature: str, extra: str | None = None) -> None:
        hint = f"pip install 'citygen[{extra}]'" if extra else f"pip install {package}"
        super().__init__(f"{feature} needs the package {package!r}, which is not installed: {hint}")
