"""Progress on anything that takes more than a few seconds: a rich bar on a terminal, and,
when stderr is a pipe or a log file, a plain line at most every :data:`EVERY` seconds (the
first only after that long, so a short run prints nothing)."""

from __future__ import annotations

import contextlib
import sys
import time
from collections.abc import Callable, Iterator

import typer

#: Seconds between two progress lines on output that is not a terminal.
EVERY = 10.0


def _clock(seconds: float) -> str:
    s = round(seconds)
    return f"{s // 60} min {s % 60:02d} s" if s >= 60 else f"{s} s"


class LineProgress:
    """``update(done, note)``: a line ``LABEL: done/total UNIT, 12 s elapsed, about 40 s left``
    on stderr, at most every ``every`` seconds."""

    def __init__(self, label: str, total: int, unit: str, every: float = EVERY) -> None:
        self.label, self.total, self.unit, self.every = label, total, unit, every
        self.t0 = self.last = time.monotonic()

    def update(self, done: int, note: str = "") -> None:
        now = time.monotonic()
        if now - self.last < self.every or done >= self.total:
            return
        self.last = now
        elapsed = now - self.t0
        left = f", about {_clock(elapsed / done * (self.total - done))} left" if done else ""
        typer.echo(
            f"{self.label}: {done:,}/{self.total:,} {self.unit}, {_clock(elapsed)} elapsed{left}{note}",
            err=True,
        )


@contextlib.contextmanager
def scenes_progress(total: int, label: str) -> Iterator[Callable[[int], None]]:
    """``advance(n)`` as ``n`` more of ``total`` scenes are done; for one scene, the stage it is
    in (a city takes half a minute)."""
    from citygen.generate.dataset import progress_bar

    if total == 1:
        with stage_progress(label):
            yield lambda n: None
    elif sys.stderr.isatty():
        with progress_bar(total, label) as advance:
            yield advance
    else:
        lines = LineProgress(label, total, "scenes")
        done = [0]

        def advance(n: int) -> None:
            done[0] += n
            lines.update(done[0])

        yield advance


@contextlib.contextmanager
def stage_progress(label: str) -> Iterator[None]:
    """The generator's stage as it starts (:data:`citygen.generate.pipeline.on_stage`): a spinner
    with the stage and the time on a terminal, else a line per stage once it has run for
    :data:`EVERY` seconds."""
    from citygen.generate.pipeline import on_stage

    t0 = time.monotonic()
    if sys.stderr.isatty():
        from rich.console import Console
        from rich.progress import Progress, SpinnerColumn, TextColumn, TimeElapsedColumn

        columns = (SpinnerColumn(), TextColumn("{task.description}"), TimeElapsedColumn())
        with Progress(*columns, console=Console(stderr=True), transient=True) as bar:
            job = bar.add_task(f"{label}: starting", total=None)
            token = on_stage.set(lambda stage: bar.update(job, description=f"{label}: {stage}"))
            try:
                yield
            finally:
                on_stage.reset(token)
        return

    def say(stage: str) -> None:
        if time.monotonic() - t0 >= EVERY:
            typer.echo(f"{label}: {stage} ({_clock(time.monotonic() - t0)} elapsed)", err=True)

    token = on_stage.set(say)
    try:
        yield
    finally:
        on_stage.reset(token)
