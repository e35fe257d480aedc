"""Shared fixtures: the repository's folders and a way to run the CLI as a user does."""

from __future__ import annotations

import os
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pytest

# Offscreen rendering through EGL (software Mesa in CI) unless the caller chose a backend;
# MuJoCo reads this once, at its first import.
os.environ.setdefault("MUJOCO_GL", "egl")

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = sorted((ROOT / "examples").glob("*.json"))
MANIFESTS = sorted((ROOT / "seeds").glob("*.toml"))


@dataclass
class Result:
    code: int
    out: str
    err: str


@pytest.fixture
def cli(capsys, monkeypatch):
    """Run ``citygen ARGS...`` in this process through the console script's entry point."""
    from citygen.cli import main

    def run(*args: str) -> Result:
        monkeypatch.setattr(sys, "argv", ["citygen", *map(str, args)])
        code = 0
        try:
            main()
        except SystemExit as exc:
            code = exc.code if isinstance(exc.code, int) else (0 if exc.code is None else 1)
        captured = capsys.readouterr()
        return Result(code, captured.out, captured.err)

    return run


def run_subprocess(*args: str, env: dict | None = None, cwd: Path = ROOT) -> Result:
    """Run ``python -m citygen ARGS...`` in a fresh interpreter."""
    proc = subprocess.run(
        [sys.executable, "-m", "citygen", *map(str, args)],
        capture_output=True,
        text=True,
        cwd=cwd,
        env=env,
        timeout=120,
    )
    return Result(proc.returncode, proc.stdout, proc.stderr)
