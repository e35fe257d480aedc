"""Pool workers that behave on Ctrl-C: a terminal's Ctrl-C reaches every process of its group,
so each worker of ``citygen generate`` or ``citygen bench`` gets it too. A worker interrupts
the work it is doing (its temporary files are removed as the exception unwinds) and sends the
interruption back; a worker waiting for work ignores it instead of dying with a traceback of
the pool's own code. The process that started the pool reports the interruption, once.
"""

from __future__ import annotations

import contextlib
import signal
import sys
from collections.abc import Callable
from types import FrameType
from typing import Any

_interrupted = False


def interrupt_only_in(*work: Callable[..., Any]) -> None:
    """In a pool worker: Ctrl-C raises :class:`KeyboardInterrupt` while one of the functions
    ``work`` runs (anywhere up the stack), and is ignored otherwise; either way
    :func:`check_interrupted` raises it from then on, so work the pool had already queued
    for this worker does not start."""
    codes = {f.__code__ for f in work}

    def handler(signum: int, frame: FrameType | None) -> None:
        global _interrupted
        _interrupted = True
        while frame is not None:
            if frame.f_code in codes:
                raise KeyboardInterrupt
            frame = frame.f_back

    signal.signal(signal.SIGINT, handler)


def check_interrupted() -> None:
    """Raise :class:`KeyboardInterrupt` in a pool worker that got Ctrl-C (see :func:`interrupt_only_in`)."""
    if _interrupted:
        raise KeyboardInterrupt


def die_with_parent() -> None:
    """In a pool worker: end when the process that started it is killed (Linux; elsewhere nothing)."""
    if sys.platform.startswith("linux"):
        import ctypes

        with contextlib.suppress(OSError, AttributeError):
            ctypes.CDLL("libc.so.6", use_errno=True).prctl(1, signal.SIGKILL)  # PR_SET_PDEATHSIG
