"""``citygen bench`` and ``citygen run``: the runner's commands (registered on the app by
:mod:`citygen.cli`). The runner and MuJoCo are imported when a command runs, so the rest of
the CLI starts without them."""

from __future__ import annotations

import typer


def register(app: typer.Typer) -> None:
    """Add the runner's commands to ``app``."""
