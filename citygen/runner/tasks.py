"""Which robots, policies and splits fit which task: the one place that says so.

The environments, ``citygen bench``, ``citygen run`` and the tests all ask here, so a robot
or policy added later is offered (and refused) everywhere the same way.

- a **locomotion** task (``loco-*``) needs a robot with leg joints; ``stand`` and ``trot``
  need a four-legged robot of twelve joints (:mod:`citygen.runner.control.gaits`) or a
  biped (:mod:`citygen.runner.control.gaits_biped`: its stand and its scripted walk);
- **navigation** (``nav-*``) and the **traverse** take every robot; the traverse control
  modes (``human``, ``ai``, ``shared-*``) only drive a traverse;
- a split fits a task of its own family: navigation scenes (a goal), locomotion grids or a
  traverse route.

>>> policies_for("nav-static", "wheeled")
('random', 'planner')
>>> print(policies_for("loco-flat", "quadruped"), robots_for("loco-flat")[:2])
('random', 'stand', 'trot') ('quadruped', 'wheeled_legged')
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from citygen.errors import SpecError
from citygen.spec.task import TASK_KINDS

#: The policy a command runs when none is given, by task family.
DEFAULT_POLICY = {"nav": "planner", "loco": "trot", "traverse": "ai"}
#: The robot an environment runs when given none, by task family (the traverse's quadruped is
#: the robot both Urban-Tra scenes are set for: the wheeled robot cannot climb the track's stairs).
DEFAULT_ROBOT = {"nav": "wheeled", "loco": "quadruped", "traverse": "quadruped"}
#: The traverse control modes (see :mod:`citygen.runner.policies`).
TRAVERSE_MODES = ("human", "ai", "human-ai-mode-1", "human-ai-mode-2", "shared-cautious", "shared-efficient")


def family(task: str) -> str:
    """``"nav"``, ``"loco"`` or ``"traverse"``; a :class:`SpecError` for an unknown kind."""
    check_task(task)
    return "loco" if task.startswith("loco") else "nav" if task.startswith("nav") else "traverse"


def check_task(task: str) -> str:
    if task not in TASK_KINDS:
        raise SpecError(f"--task: expected one of {', '.join(TASK_KINDS)}, got {task!r}")
    return task


def can_walk(robot: Any) -> bool:
    """The robot has leg joints a locomotion action drives."""
    return robot.n_joints > 0


def can_gait(robot: Any) -> bool:
    """The model-based stand and trot of :mod:`citygen.runner.control.gaits` (four legs,
    twelve joints) or the biped stand and walk of :mod:`citygen.runner.control.gaits_biped`
    can drive it."""
    return (len(robot.legs) == 4 and robot.n_joints == 12) or len(robot.legs) == 2


def robot_fits(task: str, robot: Any) -> bool:
    """The robot (a :class:`~citygen.runner.robots.Robot`) can run the task."""
    return can_walk(robot) if family(task) == "loco" else True


def robots_for(task: str) -> tuple[str, ...]:
    """The built-in robots (:data:`~citygen.runner.robots.BUILTIN`) that can run ``task``."""
    from citygen.runner.robots import BUILTIN, load_robot

    return tuple(name for name in BUILTIN if robot_fits(task, load_robot(name)))


def policies_for(task: str, robot: Any) -> tuple[str, ...]:
    """The baseline policies that drive ``task`` with ``robot`` (a name or a Robot)."""
    kind = family(task)
    if kind == "loco":
        robot = _robot(robot)
        return ("random", "stand", "trot") if can_gait(robot) else ("random",)
    if kind == "nav":
        return ("random", "planner")
    return ("random", "planner", *TRAVERSE_MODES)


def default_policy(task: str) -> str:
    return DEFAULT_POLICY[family(task)]


def default_robot(task: str) -> str:
    """The robot the task's environment runs when given none (:data:`DEFAULT_ROBOT`)."""
    return DEFAULT_ROBOT[family(task)]


def _robot(robot: Any, adapter: Any = None):
    """A Robot from a name or file (a one-line error prefixed by ``--robot``), or as given."""
    if isinstance(robot, str | Path):
        from citygen.errors import CitygenError
        from citygen.runner.robots import load_robot

        try:
            return load_robot(robot, adapter)
        except SpecError:
            raise
        except CitygenError as exc:
            raise SpecError(f"--robot: {exc}") from None
    return robot


def check_robot(task: str, robot: str | Path | None, adapter: Any = None):
    """The Robot of ``robot`` (default: the task's); a one-line :class:`SpecError` when the
    task cannot use it, naming the robots that fit."""
    loaded = _robot(robot if robot is not None else default_robot(task), adapter)
    if not robot_fits(task, loaded):
        raise SpecError(
            f"--robot: {task} needs a legged robot and {loaded.name!r} has no leg joints; "
            f"expected one of {', '.join(robots_for(task))}"
        )
    return loaded


def check_policy(task: str, robot: Any, policy: str) -> str:
    """``policy`` if it drives ``task`` with ``robot``; else a one-line :class:`SpecError`."""
    robot = _robot(robot)
    fits = policies_for(task, robot)
    if policy not in fits:
        raise SpecError(
            f"--policy: {policy!r} does not drive {task} with the {robot.name} robot; "
            f"expected one of {', '.join(fits)}"
        )
    return policy


def scene_family(task: Any) -> str | None:
    """The family of a scene's task model (None: the scene has no task)."""
    if task is None:
        return None
    return family(task.kind)


def check_scene_task(task: str, scene_task: Any, where: str) -> None:
    """A one-line :class:`SpecError` unless a scene whose task is ``scene_task`` (``where``
    names the scene or split) can run ``task``."""
    have = scene_family(scene_task)
    if have is None:
        raise SpecError(f"{where}: $.task: expected a task ({_WHAT[family(task)]}) to run {task}, got none")
    if have != family(task):
        raise SpecError(
            f"{where}: $.task: {task} needs a {_WHAT[family(task)]}, got a {scene_task.kind} task "
            f"({_WHAT[have]})"
        )


_WHAT = {"nav": "navigation scene with a goal", "loco": "locomotion grid", "traverse": "traverse route"}


def splits_for(task: str) -> tuple[str, ...]:
    """The named splits whose scenes run ``task``."""
    from citygen.generate.splits import splits

    return tuple(name for name, part in splits().items() if family(part.config.task.kind) == family(task))


def check_split(task: str, split: str) -> str:
    """``split`` if its scenes run ``task``; else a one-line :class:`SpecError` naming the
    splits that fit (an unknown split is refused by the split resolver)."""
    from citygen.generate.splits import resolve

    kinds = sorted({p.config.task.kind for p in resolve(split)})
    if any(family(k) != family(task) for k in kinds):
        raise SpecError(
            f"--split: {split} holds {', '.join(kinds)} scenes, not {family(task)} scenes for {task}; "
            f"expected one of {', '.join(splits_for(task))}"
        )
    return split
