"""The learned models that ship with citygen (``baselines/`` in this package): the task
models ``<task>-<robot>.npz`` behind ``--policy ppo``, each robot's general locomotion
model (trained on :data:`GENERAL_LOCO_SPLIT`), navigation models fine-tuned on a legged
robot's learned legs (``<task>-<robot>-legs.npz``, trained with ``locomotion="learned"``:
``--policy ppo`` with ``--locomotion learned``), and terrain locomotion models trained on
navigation's changing commands (``loco-<terrain>-<robot>-nav.npz``, metadata ``commands =
"navigation"``: the traverse's Human-AI-Mode-1 dispatches them in place of the task's).
Found by reading each file's metadata with numpy alone, so that an environment can find its
locomotion model without the rest of :mod:`citygen.runner.learn` (which makes
environments: an import circle)."""

from __future__ import annotations

import functools
from pathlib import Path
from typing import NamedTuple

from citygen.errors import CitygenError
from citygen.runner.learn.export import read_policy

#: Folder of the shipped baselines.
BASELINES = Path(__file__).with_name("baselines")
#: The Urban-Loc split the general locomotion models train on (every terrain kind).
GENERAL_LOCO_SPLIT = "urban-loc-mixed-train"
#: The locomotion tasks a general model serves.
LOCO_TASKS = ("loco-flat", "loco-slope", "loco-stair", "loco-rough")
#: On learned legs, navigation task -> the task whose model fine-tuned on the legs stands in
#: for it where none of its own ships: a model tuned on the legs walks them better than one
#: trained on the servo. The quadruped's NavStatic file tuned on the legs succeeds on NavClear
#: in 96.09 +- 1.21 % (2.34 % falls) where the servo's NavClear file does in 75.78 +- 2.68 %
#: (11.33 %), and on NavDynamic in 65.23 +- 2.98 % (17.58 %) against 39.84 +- 3.07 % (44.14 %);
#: 256 episodes each on learned legs at 11994cd (`citygen bench --task T --robot quadruped
#: --locomotion learned --policy FILE --episodes 256 --jobs 2`).
LEGS_STAND_IN = {"nav-clear": "nav-static", "nav-dynamic": "nav-static"}


class PolicyError(CitygenError):
    """A model file that cannot be used (unreadable, or made for other spaces)."""


@functools.lru_cache(maxsize=64)
def _meta(path: str, mtime: float) -> dict:
    """A shipped file's metadata, read (and the file checked) once per version of it."""
    return read_policy(path).meta


Files = dict[tuple[str, str], Path]


class ShippedFiles(NamedTuple):
    """The shipped files by role (see :func:`_shipped_files`)."""

    tasks: Files
    general: dict[str, Path]
    legs: Files
    steered: Files
    steered_general: dict[str, Path]


def _shipped_files() -> ShippedFiles:
    """The shipped files: ``tasks``, ``(task, robot) -> file`` of the task models (the task a
    file's metadata ``serves``, else the one it was trained on); ``general``, ``robot -> file``
    of the general locomotion models (``loco-general-<robot>.npz``, trained on
    :data:`GENERAL_LOCO_SPLIT`); ``legs``, ``(task, robot) -> file`` of the navigation models
    trained on learned legs; ``steered``, ``(task, robot) -> file`` of the terrain locomotion
    models trained on navigation's commands; ``steered_general``, ``robot -> file`` of the
    general models trained on them (``loco-general-<robot>-nav.npz``)."""
    found = ShippedFiles({}, {}, {}, {}, {})
    for path in sorted(BASELINES.glob("*.npz")):
        meta = _meta(str(path), path.stat().st_mtime)
        robot = meta["robot"]
        task = meta.get("serves", meta["task"])  # a model kept for a task it was not trained on
        if path.stem == f"loco-general-{robot}":
            found.general[robot] = path
        elif path.stem == f"loco-general-{robot}-nav":
            found.steered_general[robot] = path
        elif meta.get("locomotion") == "learned":
            found.legs[(meta["task"], robot)] = path
        elif meta.get("commands") == "navigation":
            found.steered[(task, robot)] = path
        else:
            found.tasks[(task, robot)] = path
    return found


def shipped(locomotion: str = "servo") -> dict[tuple[str, str], Path]:
    """The shipped baselines: ``(task, robot) -> file``. A robot's general locomotion model
    serves each locomotion task that has no terrain model of its own; with ``locomotion =
    "learned"`` a navigation model fine-tuned on learned legs replaces the servo's, and for a
    task without one of its own the one of :data:`LEGS_STAND_IN` does."""
    found = _shipped_files()  # fresh dicts on every call: ``out`` is the caller's
    out = found.tasks
    for robot, path in found.general.items():
        for task in LOCO_TASKS:
            out.setdefault((task, robot), path)
    if locomotion == "learned":
        stand_ins = {
            (task, robot): path
            for (tuned, robot), path in found.legs.items()
            for task, by in LEGS_STAND_IN.items()
            if by == tuned
        }
        out.update({**stand_ins, **found.legs})  # a task's own file before a stand-in
    return out


def general_locomotion(robot: str, commands: str | None = None) -> Path:
    """The shipped general locomotion model of ``robot`` (the paper's "general locomotion
    model", which follows velocity commands on every terrain), or a one-line error naming
    the robots that have one. ``commands="navigation"``: the one trained on navigation's
    changing commands (``loco-general-<robot>-nav.npz``) where it ships."""
    found = _shipped_files()
    general = found.general
    if commands == "navigation" and robot in found.steered_general:
        return found.steered_general[robot]
    if robot not in general:
        raise PolicyError(
            f"no general locomotion model shipped for robot {robot}; "
            f"shipped for: {', '.join(sorted(general)) or 'none'}"
        )
    return general[robot]


def terrain_locomotion(robot: str) -> dict[str, Path]:
    """The shipped terrain locomotion models of ``robot``: ``terrain -> file`` (``"slope"`` for
    ``loco-slope-<robot>.npz``), each trained on its one Urban-Loc terrain or kept for it
    (metadata ``serves``: the quadruped's LocoRough file is its general model before the one
    that climbs stairs, which falls more on rough ground), the general model not among them
    (the paper's "foundational" locomotion models, which Human-AI-Mode-1 of the traverse
    dispatches by the ground ahead). Where a terrain's model trained on navigation's changing
    commands ships (``loco-slope-<robot>-nav.npz``), it is that terrain's: the task's own,
    trained on the task's straight command, sits down or falls when navigation changes its
    command every 0.1 s."""
    found = _shipped_files()
    tasks, steered = found.tasks, found.steered
    return {
        task.removeprefix("loco-"): path
        for (task, owner), path in sorted({**tasks, **steered}.items())
        if owner == robot and task in LOCO_TASKS
    }


def baseline(task: str, robot: str, locomotion: str = "servo") -> Path:
    """The shipped baseline of ``task`` and ``robot`` (on learned legs: the one fine-tuned
    on them, or its :data:`LEGS_STAND_IN`, if any), or a one-line error naming the robots that
    have one for ``task`` and the tasks that have one for ``robot``."""
    found = shipped(locomotion)
    if (task, robot) not in found:
        robots = ", ".join(sorted(r for t, r in found if t == task)) or "none"
        tasks = ", ".join(sorted(t for t, r in found if r == robot)) or "none"
        raise PolicyError(
            f"--policy ppo: no shipped baseline for {task} with robot {robot}; "
            f"robots with one for {task}: {robots}; tasks with one for {robot}: {tasks}"
        )
    return found[(task, robot)]
