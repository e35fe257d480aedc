"""``citygen bench`` and ``citygen run``: the runner's commands (registered on the app by
:mod:`citygen.cli`). The runner and MuJoCo are imported when a command runs, so the rest of
the CLI starts without them."""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Annotated, get_args

import typer

from citygen.errors import SpecError
from citygen.spec.task import TASK_KINDS
from citygen.spec.task import Robot as RobotName  # the registry's BUILTIN (tests check)

TASKS = TASK_KINDS


def _check(value: str, allowed: tuple[str, ...], what: str) -> str:
    if value not in allowed:
        raise typer.BadParameter(f"expected one of {', '.join(allowed)}, got {value!r}", param_hint=what)
    return value


def bench(
    task: Annotated[
        str, typer.Option("--task", "-t", help=f"One of {', '.join(TASKS)}.", show_default=False)
    ],
    split: Annotated[
        str | None,
        typer.Option("--split", "-s", help="Split to sample scenes from.  [default: the task's test split]"),
    ] = None,
    robot: Annotated[
        str | None,
        typer.Option(
            "--robot",
            "-r",
            help=f"{', '.join(get_args(RobotName))}, or an MJCF/URDF file (with --adapter).  "
            "[default: wheeled; quadruped for locomotion]",
        ),
    ] = None,
    adapter: Annotated[
        Path | None, typer.Option("--adapter", help="Adapter config (TOML/JSON) of a --robot file.")
    ] = None,
    policy: Annotated[
        str,
        typer.Option(
            "--policy",
            "-p",
            help="random, planner, stand, trot, human, ai, shared-cautious, shared-efficient; "
            "ppo (the shipped learned baseline) or a model file of `citygen train` (.npz, .zip).",
        ),
    ] = "planner",
    episodes: Annotated[
        int, typer.Option("--episodes", "-n", min=1, help="Episodes (episode i runs scene i).")
    ] = 16,
    jobs: Annotated[
        int | None, typer.Option("--jobs", "-j", min=1, help="Worker processes.  [default: every core]")
    ] = None,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of episode 0 (episode i: seed + i).")] = 0,
    output: Annotated[
        Path | None, typer.Option("--output", "-o", help="Write the table and every episode as JSON.")
    ] = None,
) -> None:
    """Run a baseline on a split and print the URBAN-BENCH table (mean and standard error per metric)."""
    from citygen.runner.bench import run_bench, summary_json
    from citygen.runner.envs import DEFAULT_SPLIT
    from citygen.runner.learn.policy import resolve_policy
    from citygen.runner.metrics import format_table
    from citygen.runner.policies import POLICIES

    _check(task, TASKS, "--task")
    split = split or DEFAULT_SPLIT[task]
    options = {} if adapter is None else {"adapter": str(adapter)}
    policy = resolve_policy(policy, task, robot, POLICIES, **options)  # a name, or a model file's path
    robot_arg = robot
    if output is not None and output.exists() and output.is_dir():
        raise SpecError(f"{output}: expected a file path for --output, got a folder")
    with _progress(episodes) as advance:
        rows = run_bench(task, split, robot=robot_arg, policy=policy, episodes=episodes, jobs=jobs, seed=seed,
                         progress=advance, **options)  # fmt: skip
    doc = summary_json(rows, task=task, split=split, robot=robot or "default", policy=policy, seed=seed)
    title = f"{task} on {split}: {robot or 'default robot'}, {policy} policy, {episodes} episodes"
    typer.echo(format_table(doc["summary"], title))
    if output is not None:
        from citygen.io import write_atomic

        write_atomic(output, (json.dumps(doc, indent=1, sort_keys=True, default=float) + "\n").encode())
        typer.echo(f"wrote {output}")


class _progress:
    def __init__(self, total: int):
        self.total = total
        self._bar = None

    def __enter__(self):
        if not sys.stderr.isatty() or self.total < 2:
            return lambda done, total: None
        from rich.progress import BarColumn, MofNCompleteColumn, Progress, TimeRemainingColumn

        self._bar = Progress(
            "episodes", BarColumn(), MofNCompleteColumn(), TimeRemainingColumn(), transient=True
        )
        self._bar.start()
        task = self._bar.add_task("episodes", total=self.total)
        return lambda done, total: self._bar.update(task, completed=done)

    def __exit__(self, *exc):
        if self._bar is not None:
            self._bar.stop()


def run(
    scene: Annotated[Path, typer.Argument(help="A scene file.", show_default=False)],
    task: Annotated[
        str | None, typer.Option("--task", "-t", help="Task kind.  [default: the scene's own task]")
    ] = None,
    robot: Annotated[str | None, typer.Option("--robot", "-r", help="As for `citygen bench`.")] = None,
    adapter: Annotated[
        Path | None, typer.Option("--adapter", help="Adapter config of a --robot file.")
    ] = None,
    policy: Annotated[str, typer.Option("--policy", "-p", help="As for `citygen bench`.")] = "planner",
    seed: Annotated[int, typer.Option("--seed", min=0)] = 0,
    frames: Annotated[
        Path | None, typer.Option("--frames", help="Save every step's picture as PNG here.")
    ] = None,
    animation: Annotated[
        Path | None, typer.Option("--animation", help="Save the episode as an animated GIF.")
    ] = None,
    every: Annotated[int, typer.Option("--every", min=1, help="Keep every k-th frame.")] = 1,
) -> None:
    """Run one episode on a scene and print its metrics; optionally save frames or an animation."""
    from citygen.io import load_scene
    from citygen.runner.bench import make_env, run_episode
    from citygen.runner.learn.policy import resolve_policy
    from citygen.runner.policies import POLICIES, make_policy

    spec = load_scene(scene)
    kind = task or (spec.task.kind if spec.task is not None else None)
    if kind is None:
        raise SpecError(f"{scene}: $.task: expected a task in the scene, or give --task")
    _check(kind, TASKS, "--task")
    options = {} if adapter is None else {"adapter": str(adapter)}
    policy = resolve_policy(policy, kind, robot, POLICIES, **options)  # a name, or a model file's path
    want_pictures = frames is not None or animation is not None
    env = make_env(kind, spec, robot=robot, adapter=None if adapter is None else str(adapter),
                   render_mode="rgb_array" if want_pictures else None)  # fmt: skip
    pictures: list = []

    def keep(e, t: int) -> None:
        if want_pictures and t % every == 0:
            pictures.append(e.render())

    try:
        result = run_episode(env, make_policy(policy, seed=seed), seed=seed, on_step=keep)
    finally:
        env.close()
    for key, value in result.items():
        typer.echo(f"{key}: {value:.4g}" if isinstance(value, float) else f"{key}: {value}")
    if frames is not None:
        _write_frames(frames, pictures)
        typer.echo(f"wrote {len(pictures)} frames to {frames}/")
    if animation is not None:
        _write_animation(animation, pictures, fps=max(1, round(1.0 / (env.dt * every))))
        typer.echo(f"wrote {animation}")


def _write_frames(folder: Path, pictures: list) -> None:
    import matplotlib.image

    folder.mkdir(parents=True, exist_ok=True)
    for k, img in enumerate(pictures):
        matplotlib.image.imsave(folder / f"{k:05d}.png", img)


def _write_animation(path: Path, pictures: list, fps: int) -> None:
    from PIL import Image

    images = [Image.fromarray(p) for p in pictures]
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".part")
    images[0].save(
        tmp, format="GIF", save_all=True, append_images=images[1:], duration=round(1000 / fps), loop=0
    )
    tmp.replace(path)


def register(app: typer.Typer) -> None:
    """Add the runner's commands to ``app``."""
    app.command()(bench)
    app.command()(run)
