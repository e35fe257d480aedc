"""``citygen generate``, ``citygen dataset`` (``verify``, ``lock``) and ``citygen rebuild``:
scenes of named splits, the canonical dataset and its lock, and a hand-edited scene's later
stages made again."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

import citygen
from citygen.cli.common import plural, print_error, resumable
from citygen.errors import Problem, SpecError
from citygen.outputs import check_output
from citygen.spec.limits import MAX_RUN_SCENES, MAX_SCENE_INDEX

#: Most worker processes a command starts.
MAX_JOBS = 256


def _jobs_option(value: int | None) -> int | None:
    if value is not None and value < 1:
        raise typer.BadParameter(f"expected at least 1 worker, got {value}")
    if value is not None and value > MAX_JOBS:
        raise typer.BadParameter(f"expected at most {MAX_JOBS} workers, got {value}")
    return value


JobsOption = Annotated[
    int | None,
    typer.Option(
        "--jobs",
        "-j",
        callback=_jobs_option,
        help=f"Worker processes, 1 to {MAX_JOBS}.  [default: every core]",
    ),
]

ExecutorOption = Annotated[
    str,
    typer.Option(
        "--executor",
        help="`local`: a process pool here. `ray`: Ray tasks (many scenes each) on the cluster at "
        "RAY_ADDRESS (`auto`: the one `ray start` began on this machine), else on a Ray started here "
        "with --jobs CPUs; this process writes the files. Needs `pip install 'citygen[scale]'`.",
    ),
]


def generate(
    split: Annotated[
        str | None,
        typer.Option(
            "--split",
            "-s",
            help="A split (`urban-nav-2-train`), a family (`urban-nav-2`: both parts), or a "
            "generator config / split manifest file (.toml, .json).",
            show_default=False,
        ),
    ] = None,
    seed: Annotated[
        int | None,
        typer.Option(
            "--seed", min=0, max=2**64 - 1, help="Master seed.  [default: the split's canonical seed]"
        ),
    ] = None,
    count: Annotated[
        int | None,
        typer.Option(
            "--count",
            "-n",
            min=1,
            max=MAX_RUN_SCENES,
            help=f"Scenes per split, at most {MAX_RUN_SCENES:,} in one run.  "
            "[default: 1 with --index, else every scene]",
        ),
    ] = None,
    index: Annotated[
        int | None,
        typer.Option("--index", "-i", min=0, max=MAX_SCENE_INDEX, help="First scene index.  [default: 0]"),
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder to write into.")] = Path("out"),
    jobs: JobsOption = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Keep scene files already written and valid.")
    ] = False,
    executor: ExecutorOption = "local",
    osm: Annotated[
        Path | None,
        typer.Option(
            "--osm",
            help="A real place: an OpenStreetMap extract on disk (.osm, .osm.pbf).",
            show_default=False,
        ),
    ] = None,
    bbox: Annotated[
        str | None,
        typer.Option(
            "--bbox", help="With --osm: the box WEST,SOUTH,EAST,NORTH in degrees.", show_default=False
        ),
    ] = None,
) -> None:
    """Generate scenes of a named split (or of your own config) as JSON scene files.

    Scene `i` of split `S` gets the seed derived from (master seed, `S`, `i`), written into its
    `meta`; files go to `OUT/<family>/<part>/<index:04d>.json`, e.g. `out/urban-nav-2/train/0000.json`.
    With `--osm FILE --bbox W,S,E,N` (and no `--split`), the real place FILE maps in the box,
    made with `--seed` (default 0), goes to `OUT/<name>.json`.
    """
    if osm is not None or bbox is not None:
        from citygen.cli.place import generate_place

        generate_place(osm, bbox, split=split, seed=seed, out=out)
        return
    if split is None:
        raise SpecError(
            "--split: expected a split, family or config file (or --osm FILE --bbox W,S,E,N), got none"
        )
    from citygen.cli.progress import scenes_progress
    from citygen.generate.dataset import check_executor, write_scenes
    from citygen.generate.splits import indices, resolve

    check_executor(executor)
    chosen = resolve(split, seed=seed)
    total = sum(len(indices(s, index, count)) for s in chosen)
    if total > MAX_RUN_SCENES:
        raise SpecError([Problem("--count", f"at most {MAX_RUN_SCENES:,} scenes in one run", f"{total:,}")])
    check_output(out, folder=True, option="--out")
    resumable()
    with scenes_progress(total, "generating") as advance:
        written = write_scenes(
            chosen,
            out,
            index=index,
            count=count,
            jobs=jobs,
            resume=resume,
            on_progress=advance,
            executor=executor,
        )
    _report_written(written, out)


def _report_written(written, out: Path) -> None:
    """One line per folder: the scenes written and those kept (``--resume``)."""
    if len(written) == 1:
        verb = "kept" if written[0].skipped else "wrote"
        note = " (already there and valid)" if written[0].skipped else ""
        typer.echo(f"{verb} {out / written[0].path}{note}")
        return
    folders: dict[str, list[int]] = {}
    for w in written:
        tally = folders.setdefault(str(out / Path(w.path).parent), [0, 0])
        tally[w.skipped] += 1
    for folder, (new, kept) in folders.items():
        if not new:
            typer.echo(f"kept {plural(kept, 'scene')} already in {folder}/ (valid; none written)")
        else:
            note = f" (kept {kept:,} already there and valid)" if kept else ""
            typer.echo(f"wrote {plural(new, 'scene')} to {folder}/{note}")


dataset_app = typer.Typer(
    help="The canonical 1,536-scene Urban-Nav dataset: write it, verify it, lock its digests.",
    invoke_without_command=True,
)

ManifestOption = Annotated[
    Path | None,
    typer.Option("--manifest", help="Split manifest of the dataset.  [default: seeds/urban-nav.toml]"),
]


@dataset_app.callback()
def dataset(
    ctx: typer.Context,
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder to write into.")] = Path("dataset"),
    jobs: JobsOption = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Keep scene files already written whose digest matches.")
    ] = False,
    manifest: ManifestOption = None,
    executor: ExecutorOption = "local",
) -> None:
    """Write every scene of the Urban-Nav splits (`OUT/urban-nav-1/train/0000.json` ...) and
    `OUT/index.json`. Subcommands: `verify DIR`, `lock`."""
    if ctx.invoked_subcommand is not None:
        return
    from citygen.cli.progress import scenes_progress
    from citygen.generate.dataset import INDEX_NAME, check_executor, dataset_size, write_dataset

    check_executor(executor)
    total = dataset_size(manifest)
    check_output(out, folder=True, option="--out")
    resumable()
    with scenes_progress(total, "dataset") as advance:
        written = write_dataset(
            out, manifest=manifest, jobs=jobs, resume=resume, on_progress=advance, executor=executor
        )
    _report_written(written, out)
    typer.echo(f"wrote {out / INDEX_NAME} ({plural(len(written), 'scene')})")


@dataset_app.command("verify")
def dataset_verify(
    folder: Annotated[Path, typer.Argument(help="A folder `citygen dataset` wrote.", show_default=False)],
    manifest: ManifestOption = None,
    lock: Annotated[
        Path | None, typer.Option("--lock", help="Lock file.  [default: beside the manifest]")
    ] = None,
) -> None:
    """Check every scene file in FOLDER against the SHA-256 digests of the lock file in `seeds/`."""
    from citygen.generate.dataset import read_lock, verify_dataset

    problems = verify_dataset(folder, manifest=manifest, lock=lock)
    if problems:
        print_error(SpecError(problems))
        if len(problems) > 1:
            typer.echo(f"{folder}: {plural(len(problems), 'problem')}", err=True)
        raise typer.Exit(2)
    from citygen.generate.dataset import lock_path

    typer.echo(
        f"{folder}: {plural(len(read_lock(lock or lock_path(manifest))), 'scene')} match the lock file"
    )


@dataset_app.command("lock")
def dataset_lock(
    manifest: ManifestOption = None,
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="Lock file to write.  [default: beside the manifest]")
    ] = None,
    jobs: JobsOption = None,
) -> None:
    """Regenerate the dataset in a temporary folder, validate every scene and record its digests
    in the lock file (`seeds/urban-nav.lock.json`). Run after a deliberate generator change,
    and say in the commit what changed."""
    import tempfile

    from citygen.cli.progress import scenes_progress
    from citygen.generate.dataset import dataset_size, lock_path, write_dataset, write_lock

    check_output(out if out is not None else lock_path(manifest), option="--out" if out is not None else None)
    with tempfile.TemporaryDirectory(prefix="citygen-lock-") as tmp:
        with scenes_progress(dataset_size(manifest), "locking") as advance:
            written = write_dataset(tmp, manifest=manifest, jobs=jobs, on_progress=advance)
        bad = 0
        for w in written:
            problems = citygen.validate(citygen.load_scene(Path(tmp, w.path)))
            if problems:
                print_error(SpecError(problems, file=w.path))
                bad += 1
        if bad:
            typer.echo(f"{plural(bad, 'scene')} invalid; the lock file was not written", err=True)
            raise typer.Exit(2)
    path = write_lock(written, manifest=manifest, path=out)
    typer.echo(f"wrote {path} ({plural(len(written), 'scene')})")


def rebuild(
    scene: Annotated[Path, typer.Argument(help="A scene file (.json), edited by hand.", show_default=False)],
    stage: Annotated[
        str,
        typer.Option(
            "--from",
            help="The last stage to keep as it is in the file: layout, terrain, placement, agents "
            "or task. Every stage after it is made again.",
            show_default=False,
        ),
    ],
    out: Annotated[
        Path | None, typer.Option("--out", "-o", help="File to write.  [default: SCENE itself]")
    ] = None,
    config: Annotated[
        Path | None,
        typer.Option(
            "--config",
            help="The generator config (.toml, .json) or split manifest the scene came from.  "
            "[default: the named split in the scene's meta.split]",
        ),
    ] = None,
    seed: Annotated[
        int | None,
        typer.Option("--seed", min=0, max=2**64 - 1, help="The scene's seed.  [default: its meta.seed]"),
    ] = None,
) -> None:
    """Re-run the generator stages after `--from` on a hand-edited scene, keeping the rest.

    `citygen rebuild scene.json --from placement` keeps the layout (blocks, zones), terrain
    and objects as they are in the file (an object an edit left floating or buried is seated
    on the ground under it) and makes the agents and the task again, with the
    scene's own seed and config: an unedited scene comes back byte for byte. The task's start,
    goal and route belong to the layout: rebuilding from `layout` chooses them again, from any
    later stage keeps them. The result is checked as `citygen validate` does; nothing is
    written unless it is valid.
    """
    from citygen.generate import rebuild as rebuild_scene
    from citygen.generate.pipeline import STAGES
    from citygen.generate.splits import config_for

    if stage not in STAGES:
        raise SpecError([Problem("--from", f"one of {', '.join(STAGES)}", repr(stage))])
    edited = citygen.load_scene(scene)
    target = out if out is not None else scene
    check_output(target, option="--out" if out is not None else None)
    try:
        generator_config = config_for(edited, config)
        result = rebuild_scene(edited, stage, generator_config, seed=seed)
    except SpecError as exc:
        raise SpecError(exc.message or exc.problems, file=exc.file or str(scene)) from None
    problems = citygen.validate(result, base_dir=target.parent)
    if problems:
        raise SpecError(problems, file=f"{scene} rebuilt from {stage}")
    citygen.save_scene(result, target)
    kept = ", ".join(STAGES[: STAGES.index(stage) + 1])
    remade = ", ".join(STAGES[STAGES.index(stage) + 1 :]) or "nothing"
    note = ""
    if STAGES.index(stage) >= STAGES.index("placement"):  # the objects kept, some perhaps re-seated
        pairs = zip(edited.placements, result.placements, strict=True)
        seated = sum(a.position != b.position for a, b in pairs)
        note = f"; {plural(seated, 'object')} seated on the ground" if seated else ""
    typer.echo(f"wrote {target} (kept {kept}; made again: {remade}{note})")


def register(app: typer.Typer) -> None:
    """Add ``generate``, the ``dataset`` group and ``rebuild`` to ``app``."""
    app.command()(generate)
    app.add_typer(dataset_app, name="dataset")
    app.command()(rebuild)
