"""``citygen train``: PPO on citygen's environments (registered on the app by :mod:`citygen.cli.app`).
Stable-Baselines3 and PyTorch (the optional ``train`` extra) are imported when it runs."""

from __future__ import annotations

import shlex
import sys
from pathlib import Path
from typing import Annotated

import typer

from citygen.cli.common import resumable
from citygen.errors import SpecError


def train(
    task: Annotated[
        str | None,
        typer.Option(
            "--task", "-t", help="nav-clear, nav-static, nav-dynamic or loco-*.  [default: nav-static]"
        ),
    ] = None,
    split: Annotated[
        str | None, typer.Option("--split", "-s", help="Training split.  [default: the task's train split]")
    ] = None,
    robot: Annotated[
        str | None, typer.Option("--robot", "-r", help="Robot.  [default: wheeled; quadruped for locomotion]")
    ] = None,
    steps: Annotated[
        int | None,
        typer.Option(
            "--steps", "-n", min=1, max=10**10, help="Environment steps in all.  [default: 1000000]"
        ),
    ] = None,
    envs: Annotated[
        int | None, typer.Option("--envs", min=1, max=4096, help="Parallel sub-environments.  [default: 8]")
    ] = None,
    out: Annotated[
        Path, typer.Option("--out", "-o", help="Run folder: checkpoints, logs, curve, model.")
    ] = Path("runs/ppo"),
    config: Annotated[
        Path | None,
        typer.Option("--config", "-c", help="TOML/JSON of TrainConfig fields; options override it."),
    ] = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Continue the run in --out from its last checkpoint.")
    ] = False,
    seed: Annotated[
        int | None, typer.Option("--seed", min=0, max=2**32 - 1, help="Seed of the run.  [default: 0]")
    ] = None,
    scenes: Annotated[
        int | None,
        typer.Option(
            "--scenes",
            min=1,
            max=100_000,
            help="Distinct training scenes.  [default: every scene of the split]",
        ),
    ] = None,
    processes: Annotated[
        int | None,
        typer.Option(
            "--processes",
            help="1: a process per core (a group of sub-environments each), 0: all in this one.  "
            "[default: 1 on a multi-core machine]",
        ),
    ] = None,
    sampling: Annotated[
        str | None,
        typer.Option("--sampling", help="async (a scene per sub-environment) or sync.  [default: async]"),
    ] = None,
    max_steps: Annotated[
        int | None,
        typer.Option(
            "--max-steps",
            min=1,
            max=1_000_000,
            help="Cut each training episode after this many steps (0.1 s each in navigation, 0.02 s "
            "in locomotion).  [default: the task's horizon]",
        ),
    ] = None,
    locomotion: Annotated[
        str | None,
        typer.Option(
            "--locomotion",
            help="Navigation with a legged robot: servo (the ideal servo on its base) or learned (its "
            "general locomotion model walks it).  [default: servo]",
        ),
    ] = None,
    init: Annotated[
        Path | None,
        typer.Option(
            "--init",
            help="Start from another run's weights and observation statistics (its folder, "
            "model.zip, or an exported policy.npz such as a shipped baseline, whose critic starts "
            "fresh; same observation keys and action space), e.g. another robot's or task's policy.",
        ),
    ] = None,
) -> None:
    """Train a PPO policy (the paper's hyperparameters) and export it for `citygen bench --policy`."""
    from citygen.runner.learn.config import load_config
    from citygen.runner.learn.extra import require_train
    from citygen.runner.learn.train import train as run

    cfg = load_config(
        config,
        task=task,
        split=split,
        robot=robot,
        steps=steps,
        envs=envs,
        seed=seed,
        scenes=scenes,
        sampling=sampling,
        processes=processes,
        locomotion=locomotion,
        max_steps=max_steps,
        init=None if init is None else str(init),
    )
    _check_run(cfg, out, resume)
    require_train()  # after the cheap checks: PyTorch takes seconds to import
    command = (
        "citygen " + shlex.join(sys.argv[1:]) if sys.argv and Path(sys.argv[0]).name == "citygen" else None
    )
    typer.echo(
        f"training PPO on {cfg.task} ({cfg.train_split}, robot {cfg.robot_name}) for {cfg.steps:,} steps "
        f"with {cfg.envs} sub-environments into {out}/"
    )
    result = run(cfg, out, resume=resume, command=command)
    rate = "-" if result.success_rate is None else f"{result.success_rate:.1f} %"
    typer.echo(
        f"{result.steps:,} steps in {result.seconds:.0f} s, training success {rate} (last 100 episodes)"
    )
    typer.echo(
        f"wrote {result.policy} (evaluate: citygen bench --task {cfg.task} --robot {cfg.robot_name} "
        f"--policy {result.policy})"
    )


def _check_run(cfg, out: Path, resume: bool) -> None:
    """What a run needs, checked before it says it starts: the robot and split fit the task,
    ``--init`` is there, the run folder can be written."""
    from citygen.outputs import check_output
    from citygen.runner.tasks import check_robot, check_split

    loaded = check_robot(cfg.task, cfg.robot_name)
    check_split(cfg.task, cfg.train_split)
    if cfg.locomotion == "learned":
        from citygen.runner.envs.legs import general_model

        general_model(cfg.task, loaded)
    if cfg.init is not None:
        init = Path(cfg.init)
        if not (init.is_file() or (init / "model.zip").is_file()):
            found = "a folder without model.zip" if init.is_dir() else "no such file"
            raise SpecError(
                f"--init {init}: expected a run folder of `citygen train`, its model.zip or a policy.npz, "
                f"got {found}"
            )
        if init.suffix == ".npz":
            from citygen.runner.learn.export import read_policy

            try:
                read_policy(init)
            except ValueError as exc:
                raise SpecError(
                    f"--init {init}: expected a policy exported by `citygen train`, got {exc}"
                ) from None
    check_output(out, folder=True, option="--out")
    if not resume:
        resumable(f"citygen train --resume --out {shlex.quote(str(out))}")


def register(app: typer.Typer) -> None:
    """Add ``citygen train`` to ``app``."""
    app.command()(train)
