"""``citygen bench`` and ``citygen run``: the runner's commands (registered on the app by
:mod:`citygen.cli.app`). The runner and MuJoCo are imported when a command runs, so the rest
of the CLI starts without them."""

from __future__ import annotations

import contextlib
import json
import sys
from pathlib import Path
from typing import Annotated, Any, get_args

import typer

from citygen.cli.common import plural
from citygen.errors import Problem, SpecError
from citygen.outputs import check_output
from citygen.spec.task import TASK_KINDS
from citygen.spec.task import Robot as RobotName  # the registry's BUILTIN (tests check)

TASKS = TASK_KINDS
#: Bounds on what sizes a run's time and memory.
MAX_EPISODES = 10_000
MAX_STEPS = 1_000_000
MAX_JOBS = 256
#: Pictures ``run`` keeps in memory for --frames and --animation (640 x 480 RGB: 0.9 MB each).
MAX_FRAMES = 2_000


#: ``--locomotion``: how a legged robot moves in navigation and the traverse
#: (citygen.runner.envs.legs.LOCOMOTION).
Locomotion = Annotated[
    str,
    typer.Option(
        "--locomotion",
        help="Navigation and the traverse with a legged robot: servo (the ideal locomotion servo on its "
        "base) or learned (its legs walked by its general locomotion model at 50 Hz; human-ai-mode-1 "
        "swaps in its terrain models by the ground ahead).",
    ),
]


def _locomotion(value: str, task: str, robot: Any) -> dict[str, str]:
    """The environment option of ``--locomotion`` (none for the default servo, so that the
    runs and their JSON stay as they were); a one-line error for another value, or for
    learned legs that ``task`` and ``robot`` (the Robot) cannot have, before any episode."""
    from citygen.runner.envs.legs import LOCOMOTION, general_model

    if value not in LOCOMOTION:
        raise SpecError([Problem("--locomotion", " or ".join(LOCOMOTION), repr(value))])
    if value == "servo":
        return {}
    general_model(task, robot)
    return {"locomotion": value}


def _robot_help() -> str:
    return (
        f"A built-in robot ({', '.join(get_args(RobotName))}; locomotion needs a legged one) "
        "or an MJCF/URDF file (with --adapter).  [default: wheeled; quadruped for locomotion]"
    )


def _robot_and_policy(task: str, robot: str | None, policy: str | None, options: dict, locomotion: str):
    """The Robot and the policy to run (a baseline's name, or a learned model's file checked
    against the task's environment on the ``--locomotion`` asked for: ``ppo`` on learned legs
    is the file fine-tuned on them where one ships), and that locomotion's environment option
    (also added to ``options``); a one-line SpecError when they do not fit the task."""
    from citygen.runner.learn.policy import is_model, load_policy, observations_for, resolve_policy
    from citygen.runner.tasks import check_policy, check_robot, default_policy

    loaded = check_robot(task, robot, options.get("adapter"))
    walk = _locomotion(locomotion, task, loaded)
    options.update(walk)
    policy = policy or default_policy(task)
    if Path(policy).is_dir():  # a run folder of `citygen train`: its exported policy
        exported = Path(policy, "policy.npz")
        if not exported.is_file():
            raise SpecError(
                f"--policy {policy}: expected a model file (.npz, .zip) or a run folder of "
                "`citygen train` holding policy.npz, got a folder without one"
            )
        policy = str(exported)
    if is_model(policy):
        path = resolve_policy(policy, task, robot, (), **options)
        options.update(observations_for(load_policy(path)))  # keys it reads that no env gives unasked
        return loaded, path, walk
    return loaded, check_policy(task, loaded, policy), walk


def bench(
    task: Annotated[
        str, typer.Option("--task", "-t", help=f"One of {', '.join(TASKS)}.", show_default=False)
    ],
    split: Annotated[
        str | None,
        typer.Option("--split", "-s", help="Split to sample scenes from.  [default: the task's test split]"),
    ] = None,
    robot: Annotated[str | None, typer.Option("--robot", "-r", help=_robot_help())] = None,
    adapter: Annotated[
        Path | None, typer.Option("--adapter", help="Adapter config (TOML/JSON) of a --robot file.")
    ] = None,
    policy: Annotated[
        str | None,
        typer.Option(
            "--policy",
            "-p",
            help="random, planner (navigation, traverse), stand, trot (legged locomotion), human, ai, "
            "human-ai-mode-1, human-ai-mode-2, shared-cautious, shared-efficient (traverse); ppo "
            "(the shipped learned baseline) or a model file of `citygen train` (.npz, .zip).  "
            "[default: planner; trot for locomotion; ai for the traverse]",
        ),
    ] = None,
    episodes: Annotated[
        int,
        typer.Option("--episodes", "-n", min=1, max=MAX_EPISODES, help="Episodes (episode i runs scene i)."),
    ] = 16,
    jobs: Annotated[
        int | None,
        typer.Option("--jobs", "-j", min=1, max=MAX_JOBS, help="Worker processes.  [default: every core]"),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", min=0, help="Seed of episode 0 (episode i: seed + i).")] = 0,
    output: Annotated[
        Path | None, typer.Option("--output", "-o", help="Write the table and every episode as JSON.")
    ] = None,
    max_steps: Annotated[
        int | None,
        typer.Option(
            "--max-steps",
            min=1,
            max=MAX_STEPS,
            help="Cut each episode after this many steps (0.1 s each in navigation and the traverse, "
            "0.02 s in locomotion).  [default: the task's time limit]",
        ),
    ] = None,
    locomotion: Locomotion = "servo",
) -> None:
    """Run a baseline on a split and print the URBAN-BENCH table (mean and standard error per metric)."""
    from citygen.runner.bench import run_bench
    from citygen.runner.envs import DEFAULT_SPLIT
    from citygen.runner.tasks import check_split, check_task

    check_task(task)
    split = check_split(task, split or DEFAULT_SPLIT[task])
    options = {} if adapter is None else {"adapter": str(adapter)}
    loaded, policy, walk = _robot_and_policy(task, robot, policy, options, locomotion)
    if output is not None:  # before the episodes run, not after
        check_output(output, option="--output")
    with progress_bar(episodes, _bar_enabled()) as advance:
        limit = {} if max_steps is None else {"max_steps": max_steps}
        rows = run_bench(task, split, robot=robot, policy=policy, episodes=episodes, jobs=jobs, seed=seed,
                         progress=advance, **options, **limit)  # fmt: skip
    header = {"task": task, "split": split, "robot": loaded.name, "policy": policy, "seed": seed}
    _print_table(rows, output=output, **header, **walk)


def _print_table(rows: list, *, output: Path | None = None, **header) -> None:
    """The URBAN-BENCH table of ``rows`` (and the JSON document at ``output``)."""
    from citygen.runner.bench import summary_json
    from citygen.runner.metrics import format_table

    doc = summary_json(rows, **header)
    n = len(rows)
    legs = " on learned legs" if header.get("locomotion") == "learned" else ""
    title = (
        f"{header['task']} on {header['split']}: {header['robot']} robot{legs}, {header['policy']} policy, "
        f"{n} episode{'s' if n != 1 else ''}"
    )
    typer.echo(format_table(doc["summary"], title))
    if output is not None:
        _write_results(output, (json.dumps(doc, indent=1, sort_keys=True, default=float) + "\n").encode())
        typer.echo(f"wrote {output}")


def _write_results(output: Path, data: bytes) -> None:
    """Write the results to ``output``; if that fails (the disk filled up while the episodes
    ran), to a file in the temporary folder instead, and say where in the one-line error."""
    import tempfile

    from citygen.errors import OutputError
    from citygen.io import write_atomic

    try:
        write_atomic(output, data)
    except OutputError as exc:
        try:
            fd, rescue = tempfile.mkstemp(prefix=f"citygen-{output.stem}-", suffix=output.suffix or ".json")
            with open(fd, "wb") as f:
                f.write(data)
        except OSError:
            raise OutputError(f"{exc}; the results are only in the table above") from None
        raise OutputError(f"{exc}; the results were written to {rescue} instead") from None


def _bar_enabled() -> bool:
    return sys.stderr.isatty()


@contextlib.contextmanager
def progress_bar(episodes: int, enabled: bool, horizon: int | None = None):
    """A rich progress bar on stderr like ``citygen generate``'s: episodes (or, for one
    episode, its steps against the horizon), steps so far, success so far, elapsed and ETA;
    with ``enabled`` False (stderr is not a terminal), a line every few seconds instead
    (:class:`~citygen.cli.progress.LineProgress`). Yields ``advance(done, total, row)`` (an
    episode's row when one ends, else None)."""
    tally = {"steps": 0, "success": 0.0, "ended": 0}

    def count(row: dict | None) -> str:
        if row is not None:
            tally["steps"] += int(row.get("steps", 0))
            tally["success"] += float(row.get("success_rate", row.get("balance", 0.0)))
            tally["ended"] += 1
        return f"{tally['success'] / tally['ended']:.0f} %" if tally["ended"] else "-"

    unit = "steps" if horizon else "episodes"
    if not enabled:
        from citygen.cli.progress import LineProgress

        lines = LineProgress("running", horizon or episodes, unit)

        def say(done: int, total: int, row: dict | None = None) -> None:
            rate = count(row)
            lines.update(done, "" if horizon else f", success {rate}")

        yield say
        return
    from citygen.generate.dataset import rich_bar

    with rich_bar("{task.fields[steps]} steps", "success {task.fields[success]}") as bar:
        job = bar.add_task(unit, total=horizon or episodes, steps=0, success="-")

        def advance(done: int, total: int, row: dict | None = None) -> None:
            rate = count(row)
            steps = done if horizon else tally["steps"]
            bar.update(job, completed=done, total=total, steps=steps, success=rate)

        yield advance


def run(
    scene: Annotated[Path, typer.Argument(help="A scene file.", show_default=False)],
    task: Annotated[
        str | None, typer.Option("--task", "-t", help="Task kind.  [default: the scene's own task]")
    ] = None,
    robot: Annotated[str | None, typer.Option("--robot", "-r", help=_robot_help())] = None,
    adapter: Annotated[
        Path | None, typer.Option("--adapter", help="Adapter config of a --robot file.")
    ] = None,
    policy: Annotated[
        str | None,
        typer.Option("--policy", "-p", help="As for `citygen bench`.  [default: by task, as there]"),
    ] = None,
    seed: Annotated[
        int,
        typer.Option(
            "--seed",
            min=0,
            help="Seed of the episode: the random policy's actions, the people's motion; in locomotion "
            "also the region, start pose and command.",
        ),
    ] = 0,
    frames: Annotated[
        Path | None, typer.Option("--frames", help="Save every step's picture as PNG here.")
    ] = None,
    animation: Annotated[
        Path | None,
        typer.Option(
            "--animation", help="Save the episode as an animation: .gif, or .png (animated PNG), or .webp."
        ),
    ] = None,
    every: Annotated[
        int,
        typer.Option(
            "--every", min=1, max=MAX_STEPS, help=f"Keep every k-th frame (at most {MAX_FRAMES:,} are kept)."
        ),
    ] = 1,
    output: Annotated[
        Path | None, typer.Option("--output", "-o", help="Write the table and the episode as JSON.")
    ] = None,
    locomotion: Locomotion = "servo",
) -> None:
    """Run one episode on a scene and print its URBAN-BENCH table (as `citygen bench` does); optionally
    save frames or an animation."""
    from citygen.io import load_scene
    from citygen.runner.bench import run_episode
    from citygen.runner.make import make_env
    from citygen.runner.policies import make_policy
    from citygen.runner.tasks import check_scene_task, check_task

    spec = load_scene(scene)
    kind = task or (spec.task.kind if spec.task is not None else None)
    if kind is None:
        raise SpecError(
            f"{scene}: $.task: expected a task in the scene, or give --task (one of {', '.join(TASKS)})"
        )
    check_task(kind)
    check_scene_task(kind, spec.task, str(scene))
    options = {} if adapter is None else {"adapter": str(adapter)}
    loaded, policy, walk = _robot_and_policy(kind, robot, policy, options, locomotion)
    _check_run_outputs(output, frames, animation)
    want_pictures = frames is not None or animation is not None
    env = make_env(kind, spec, robot=robot, render_mode="rgb_array" if want_pictures else None, **options)
    pictures: list = []
    horizon = int(getattr(env, "horizon", 0)) or None
    if want_pictures and horizon is not None and horizon // every + 1 > MAX_FRAMES:
        env.close()
        raise SpecError([Problem(
            "--every", f"at most {MAX_FRAMES:,} frames kept (an episode of up to {horizon:,} steps: "
            f"--every {-(-horizon // MAX_FRAMES)} or more)", str(every),
        )])  # fmt: skip

    with progress_bar(1, _bar_enabled() and horizon is not None, horizon=horizon) as advance:

        def keep(e, t: int) -> None:
            if want_pictures and t % every == 0:
                pictures.append(e.render())
            advance(t, max(horizon or 1, t))

        try:
            result = run_episode(env, make_policy(policy, seed=seed, task=kind), seed=seed, on_step=keep)
        finally:
            env.close()
        advance(result["steps"], result["steps"], result)
    header = {"task": kind, "split": str(scene), "robot": loaded.name, "policy": policy, "seed": seed}
    _print_table([result], output=output, **header, **walk)
    if frames is not None:
        _write_frames(frames, pictures)
        typer.echo(f"wrote {plural(len(pictures), 'frame')} to {frames}/")
    if animation is not None:
        _write_animation(animation, pictures, fps=max(1, round(1.0 / (env.dt * every))))
        typer.echo(f"wrote {animation}")


#: Animation formats of ``run --animation``, by suffix: Pillow's format name.
ANIMATIONS = {".gif": "GIF", ".png": "PNG", ".webp": "WEBP"}


def _check_run_outputs(output: Path | None, frames: Path | None, animation: Path | None) -> None:
    """Every output of ``citygen run`` writable, and the animation's suffix known, before the episode."""
    from citygen.outputs import check_output

    if output is not None:
        check_output(output, option="--output")
    if frames is not None:
        check_output(frames, folder=True, option="--frames")
    if animation is not None:
        if animation.suffix.lower() not in ANIMATIONS:
            raise SpecError(
                [Problem("--animation", f"a file ending in {', '.join(ANIMATIONS)}", str(animation))]
            )
        check_output(animation, option="--animation")


def _write_frames(folder: Path, pictures: list) -> None:
    import io

    from PIL import Image

    from citygen.io import write_atomic

    for k, img in enumerate(pictures):
        buf = io.BytesIO()
        Image.fromarray(img).save(buf, format="PNG")
        write_atomic(folder / f"{k:05d}.png", buf.getvalue())


def _write_animation(path: Path, pictures: list, fps: int) -> None:
    import io

    from PIL import Image

    from citygen.io import write_atomic

    images = [Image.fromarray(p) for p in pictures]
    buf = io.BytesIO()
    images[0].save(
        buf, format=ANIMATIONS[path.suffix.lower()], save_all=True, append_images=images[1:],
        duration=round(1000 / fps), loop=0,
    )  # fmt: skip
    write_atomic(path, buf.getvalue())


def register(app: typer.Typer) -> None:
    """Add the runner's commands to ``app``."""
    app.command()(bench)
    app.command()(run)
