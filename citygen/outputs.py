"""Where citygen writes: output paths checked before the work starts, and the operating
system's refusals (a file where a folder is expected, a read-only folder, a full disk) as
one-line errors (:class:`~citygen.errors.OutputError`) naming the path, what was expected
there and what was found; and multi-file outputs (a ROS map's yaml and pgm, a city's URDF tiles)
that appear whole or not at all (:func:`staged`).

A command that computes for a while (``bench``, ``run``, ``generate``, ``train``) calls
:func:`check_output` first, so a typo in ``--output`` costs nothing; whatever still fails
while writing (the disk fills up meanwhile) is :func:`output_error`'s one line.

>>> import tempfile, pathlib
>>> folder = pathlib.Path(tempfile.mkdtemp())
>>> (folder / "taken").write_text("")
0
>>> check_output(folder / "taken" / "b.json", option="--output")
Traceback (most recent call last):
...
citygen.errors.OutputError: --output .../taken/b.json: expected a folder at .../taken, got a file
"""

from __future__ import annotations

import contextlib
import errno
import os
import shutil
import signal
import tempfile
import threading
from collections.abc import Iterator
from pathlib import Path

from citygen.errors import OutputError

#: What writing failed on, as (expected, found), by errno: the refusals a user can cause and mend.
REASONS = {
    errno.ENOSPC: ("free space on its disk", "a full disk"),
    errno.EDQUOT: ("room in the disk quota", "the quota used up"),
    errno.EROFS: ("a writable folder", "a read-only file system"),
    errno.EACCES: ("a writable folder", "permission denied"),
    errno.EPERM: ("a writable folder", "permission denied"),
    errno.EFBIG: ("a file within the size limit", "the file size limit (ulimit -f) reached"),
    errno.ENAMETOOLONG: ("a shorter path", "a name too long for the file system"),
    errno.ENOTDIR: ("a folder", "a file"),
    errno.EISDIR: ("a file path", "a folder"),
    errno.EEXIST: ("a folder", "a file"),
    errno.ENOENT: ("an existing folder", "none"),
    errno.EMFILE: ("a free file descriptor", "too many open files (ulimit -n)"),
    errno.EIO: ("a working disk", "an input/output error"),
}
#: The errnos :func:`output_error` explains; any other OSError is a bug to report.
OUTPUT_ERRNOS = frozenset(REASONS)


def _file_in_the_way(path: Path) -> Path | None:
    """The nearest ancestor of ``path`` that exists, if it is not a folder."""
    for parent in path.parents:
        if parent.exists() or parent.is_symlink():
            return None if parent.is_dir() else parent
    return None


def _nearest_folder(path: Path) -> Path:
    """``path`` itself when it is a folder, else its nearest existing ancestor."""
    if path.is_dir():
        return path
    for parent in path.parents:
        if parent.is_dir():
            return parent
    return Path(".")


def _error(where: str, expected: str, found: str) -> OutputError:
    reason = f"expected {expected}, got {found}"
    return OutputError(f"{where}: {reason}", reason)


def output_error(exc: OSError, path: str | Path, option: str | None = None) -> OutputError:
    """The one line for ``exc``, met writing ``path`` (given as ``option``, when there is one)."""
    path = Path(path)
    where = f"{option} {path}" if option else str(path)
    blocker = _file_in_the_way(path)
    if blocker is not None:
        return _error(where, f"a folder at {blocker}", "a file")
    if path.is_dir() and exc.errno in (errno.EISDIR, errno.EEXIST):
        return _error(where, "a file path", "a folder")
    expected, found = REASONS.get(exc.errno, ("a writable path", exc.strerror or type(exc).__name__))
    if exc.errno in (errno.EROFS, errno.EACCES, errno.EPERM, errno.ENOSPC, errno.EDQUOT):
        expected += f" at {_nearest_folder(path.parent)}"
    return _error(where, expected, found)


def check_output(
    path: str | Path, *, folder: bool = False, option: str | None = None, exist_ok: bool = True
) -> Path:
    """Raise a one-line :class:`~citygen.errors.OutputError` now, before any work, if ``path``
    cannot be written: a file where a folder is expected (``path`` itself with ``folder=True``,
    or one of its parents), a folder where a file is expected, a folder this process may not
    write in, a read-only or full disk. Creates nothing (a probe file is made and removed in
    the nearest existing folder). ``exist_ok=False``: an existing file is refused too."""
    path = Path(path)
    where = f"{option} {path}" if option else str(path)
    blocker = _file_in_the_way(path)
    if blocker is not None:
        raise _error(where, f"a folder at {blocker}", "a file")
    if path.exists():
        if folder and not path.is_dir():
            raise _error(where, "a folder", "a file")
        if not folder and path.is_dir():
            raise _error(where, "a file path", "a folder")
        if not folder and not exist_ok:
            raise _error(where, "a new file", "an existing one")
    home = _nearest_folder(path)
    try:
        fd, probe = tempfile.mkstemp(prefix=".citygen-probe-", dir=home)
        os.close(fd)
        os.unlink(probe)
    except OSError as exc:
        expected, found = REASONS.get(exc.errno, ("a writable folder", exc.strerror or "an error"))
        raise _error(where, f"{expected} at {home}", found) from None
    if shutil.disk_usage(home).free == 0:
        raise _error(where, f"free space at {home}", "a full disk")
    return path


#: Name prefix of the hidden folders :func:`staged` writes in (``.citygen-stage-<pid>-*``).
STAGE_PREFIX = ".citygen-stage-"


@contextlib.contextmanager
def staged(out: str | Path) -> Iterator[Path]:
    """A hidden folder inside ``out`` to write a multi-file output into. When the block ends
    without an error its files move into ``out`` (same relative paths, each an atomic rename,
    with Ctrl-C held off until all are in place); otherwise they are removed, so a failure, a
    full disk or Ctrl-C never leaves part of the output (a yaml naming a missing pgm, 3 of 25
    tiles). Files that name each other do so by relative path, so they stay valid. Folders
    a killed process left behind are removed the next time."""
    out = Path(out)
    made = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
        _remove_orphans(out)
        stage = Path(tempfile.mkdtemp(prefix=f"{STAGE_PREFIX}{os.getpid()}-", dir=out))
    except OSError as exc:
        raise output_error(exc, out) from None
    try:
        yield stage
        with _signals_held():
            for folder, _, files in os.walk(stage):
                for name in files:
                    source = Path(folder, name)
                    target = out / source.relative_to(stage)
                    target.parent.mkdir(parents=True, exist_ok=True)
                    os.replace(source, target)
    finally:
        shutil.rmtree(stage, ignore_errors=True)
        if made:  # a folder made for nothing goes too
            with contextlib.suppress(OSError):
                out.rmdir()


def unstaged(path: Path, stage: Path, out: Path) -> Path:
    """Where a file written at ``path`` inside ``stage`` is once :func:`staged` moved it to ``out``."""
    return out / Path(path).relative_to(stage)


def _remove_orphans(out: Path) -> None:
    """Remove staging folders in ``out`` whose process is gone (killed with SIGKILL)."""
    for folder in out.glob(f"{STAGE_PREFIX}*"):
        pid = folder.name.removeprefix(STAGE_PREFIX).split("-")[0]
        if pid.isdigit() and not _alive(int(pid)):
            shutil.rmtree(folder, ignore_errors=True)


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True
    return True


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """Ctrl-C and SIGTERM wait until the block is done (in the main thread; elsewhere the
    block runs as it is)."""
    if threading.current_thread() is not threading.main_thread():
        yield
        return
    got: list[int] = []
    held = (signal.SIGINT, signal.SIGTERM)
    previous = {s: signal.signal(s, lambda number, _frame: got.append(number)) for s in held}
    try:
        yield
    finally:
        for number, handler in previous.items():
            signal.signal(number, handler)
        if got:
            signal.raise_signal(got[0])
