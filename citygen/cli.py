"""The ``citygen`` command: a thin layer over the library's public functions.

Every error a user can cause is a :class:`~citygen.errors.CitygenError`; it is
printed as one line per problem on stderr and the command exits with code 2.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Annotated

import typer

import citygen
from citygen.cli_runner import register as register_runner
from citygen.cli_train import register as register_train
from citygen.errors import CitygenError, Problem, SpecError
from citygen.exporters.batch import FORMATS as EXPORT_FORMATS

app = typer.Typer(
    name="citygen",
    help="Seeded urban scenes for robot learning: generate, validate and export them.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode="markdown",
    context_settings={"help_option_names": ["-h", "--help"]},
)


def _version(value: bool) -> None:
    if value:
        typer.echo(f"citygen {citygen.__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: Annotated[
        bool, typer.Option("--version", callback=_version, is_eager=True, help="Print the version and exit.")
    ] = False,
) -> None:
    """Seeded urban scenes for robot learning: generate, validate and export them."""


@app.command()
def validate(
    files: Annotated[
        list[Path], typer.Argument(help="Scene files (.json) or split manifests (.toml).", show_default=False)
    ],
    quiet: Annotated[bool, typer.Option("--quiet", "-q", help="Print only problems.")] = False,
) -> None:
    """Check scene files (and split manifests): their shape against the schema, then their meaning.

    Semantic checks: polygons valid and inside the bounds, zones and objects not
    overlapping, neighbouring terrain tiles agreeing on shared edges, agents and the
    task on walkable ground, mesh paths staying inside the scene's folder. Exits 0
    when every file is valid, 2 otherwise, with one line per problem:
    `FILE: $.json.path: expected ..., got ...`
    """
    from citygen.io import load_manifest

    bad = 0
    for file in files:
        try:
            if file.suffix.lower() == ".toml":
                load_manifest(file)  # split manifests are checked entirely on loading
                problems = []
            else:
                problems = citygen.validate(citygen.load_scene(file), base_dir=file.parent)
        except SpecError as exc:
            _print_error(exc)
            bad += 1
            continue
        if problems:
            _print_error(SpecError(problems, file=str(file)))
            bad += 1
        elif not quiet:
            typer.echo(f"{file}: valid")
    if bad:
        raise typer.Exit(2)


@app.command()
def schema(
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder to write the schema files into.")] = Path(
        "schemas"
    ),
    check: Annotated[
        bool,
        typer.Option("--check", help="Write nothing; exit 2 if the files in OUT differ from the models."),
    ] = False,
) -> None:
    """Write the JSON Schema files (scene, split manifest) generated from the spec models."""
    from citygen.schema import stale_schemas, write_schemas

    if check:
        stale = stale_schemas(out)
        for name in stale:
            typer.echo(
                f"{out / name}: out of date with the models; run 'citygen schema --out {out}'", err=True
            )
        raise typer.Exit(2 if stale else 0)
    for path in write_schemas(out):
        typer.echo(f"wrote {path}")


@app.command()
def render(
    scene: Annotated[Path, typer.Argument(help="Scene file (.json).", show_default=False)],
    out: Annotated[
        Path | None,
        typer.Option("--out", "-o", help="PNG file to write.  [default: SCENE.png beside the scene]"),
    ] = None,
    size: Annotated[
        int, typer.Option("--size", min=64, max=8192, help="Larger side of the picture, in pixels.")
    ] = 1600,
    terrain: Annotated[
        bool, typer.Option("--terrain/--no-terrain", help="Shade the terrain and mark stairs, slopes, rough.")
    ] = True,
    legend: Annotated[bool, typer.Option("--legend/--no-legend", help="Draw the legend.")] = True,
) -> None:
    """Draw a top-down map of a scene as a PNG: zones coloured by kind, road blocks and
    their sockets, objects, agents, the task's start and goal, terrain, scale bar, legend.

    The same scene always gives the same bytes. A scene that `citygen validate` rejects
    for its meaning (overlapping zones, say) is still drawn, to show what is wrong.
    """
    from citygen.exporters.picture import render as render_picture

    target = out if out is not None else scene.with_suffix(".png")
    path = render_picture(scene, target, size_px=size, terrain=terrain, legend=legend)
    typer.echo(f"wrote {path}")


@app.command()
def export(
    scenes: Annotated[list[Path], typer.Argument(help="Scene files (.json).", show_default=False)],
    fmt: Annotated[
        str,
        typer.Option(
            "--format", "-f", help=f"One of {', '.join(EXPORT_FORMATS)}, or all.", show_default=True
        ),
    ] = "all",
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder to write into.")] = Path("export"),
    terrain_resolution: Annotated[
        float | None,
        typer.Option(
            "--terrain-resolution",
            min=0.005,
            max=10.0,
            help="Spacing of terrain samples (m): MJCF heightfields, rough tiles' meshes in USD, URDF, "
            "GLB, HTML.  [default: each format's own, coarsened to fit its limits with a warning]",
        ),
    ] = None,
    occupancy_resolution: Annotated[
        float | None,
        typer.Option(
            "--occupancy-resolution",
            min=0.005,
            max=10.0,
            help="Cell size of the occupancy map (m).  [default: 0.05, coarser for a city, with a warning]",
        ),
    ] = None,
    resolution: Annotated[
        float | None,
        typer.Option("--resolution", min=0.005, max=10.0, help="The same as --occupancy-resolution."),
    ] = None,
    jobs: Annotated[
        int | None,
        typer.Option(
            "--jobs",
            "-j",
            min=1,
            help="Worker processes, each exporting one format of one scene at a time (1: all in this "
            "process).  [default: every core]",
        ),
    ] = None,
) -> None:
    """Compile scenes to the files other simulators load: MJCF, USD, URDF, an occupancy map
    (npz, ROS yaml/pgm, png), GLB, a self-contained HTML viewer, PNG pictures.

    A generated scene (`<split>/<part>/NNNN.json`) is written as `<split>-NNNN.*`, any other
    as its file's stem. Assets repeated across scenes are written once, content-addressed,
    under `OUT/assets/`. Whatever a format cannot express or had to coarsen is reported on
    stderr as `FILE: warning: ...`. A scene or format that fails is reported as
    `FILE: error: ...` and the rest are still exported; the exit code is then 2. Formats and
    scenes are exported in --jobs processes at once; the output is the same, in the same order.
    """
    from citygen.errors import ExportError
    from citygen.exporters.batch import export_batch
    from citygen.generate.dataset import default_jobs

    if fmt != "all" and fmt not in EXPORT_FORMATS:
        raise ExportError(f"--format: expected one of {', '.join(EXPORT_FORMATS)} or all, got {fmt!r}")
    if resolution is not None and occupancy_resolution not in (None, resolution):
        raise ExportError(
            f"--resolution: the same as --occupancy-resolution, given both as {resolution:g} and "
            f"{occupancy_resolution:g}; pass one"
        )
    chosen = list(EXPORT_FORMATS) if fmt == "all" else [fmt]
    failed: set[Path] = set()
    for event in export_batch(
        scenes, out, chosen, terrain_resolution=terrain_resolution,
        occupancy_resolution=occupancy_resolution if occupancy_resolution is not None else resolution,
        jobs=default_jobs() if jobs is None else jobs,
    ):  # fmt: skip
        if event.kind == "wrote":
            typer.echo(f"wrote {event.text}")
        else:
            typer.echo(f"{event.scene}: {event.kind}: {event.text}", err=True)
            if event.kind == "error":
                failed.add(event.scene)
    if len(failed) > 1 or (failed and len(scenes) > 1):
        typer.echo(
            f"export: {len(failed)} of {len(scenes)} scene(s) failed, in part or whole (see above)", err=True
        )
    if failed:
        raise typer.Exit(2)


def _jobs_option(value: int | None) -> int | None:
    if value is not None and value < 1:
        raise typer.BadParameter(f"expected at least 1 worker, got {value}")
    return value


JobsOption = Annotated[
    int | None,
    typer.Option("--jobs", "-j", callback=_jobs_option, help="Worker processes.  [default: every core]"),
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


@app.command()
def generate(
    split: Annotated[
        str,
        typer.Option(
            "--split",
            "-s",
            help="A split (`urban-nav-2-train`), a family (`urban-nav-2`: both parts), or a "
            "generator config / split manifest file (.toml, .json).",
            show_default=False,
        ),
    ],
    seed: Annotated[
        int | None,
        typer.Option(
            "--seed", min=0, max=2**64 - 1, help="Master seed.  [default: the split's canonical seed]"
        ),
    ] = None,
    count: Annotated[
        int | None,
        typer.Option(
            "--count", "-n", min=0, help="Scenes per split.  [default: 1 with --index, else every scene]"
        ),
    ] = None,
    index: Annotated[
        int | None, typer.Option("--index", "-i", min=0, help="First scene index.  [default: 0]")
    ] = None,
    out: Annotated[Path, typer.Option("--out", "-o", help="Folder to write into.")] = Path("out"),
    jobs: JobsOption = None,
    resume: Annotated[
        bool, typer.Option("--resume", help="Keep scene files already written and valid.")
    ] = False,
    executor: ExecutorOption = "local",
) -> None:
    """Generate scenes of a named split (or of your own config) as JSON scene files.

    Scene `i` of split `S` gets the seed derived from (master seed, `S`, `i`), written into its
    `meta`; files go to `OUT/<family>/<part>/<index:04d>.json`, e.g. `out/urban-nav-2/train/0000.json`.
    """
    from citygen.generate.dataset import check_executor, progress_bar, write_scenes
    from citygen.generate.splits import indices, resolve

    check_executor(executor)
    chosen = resolve(split, seed=seed)
    total = sum(len(indices(s, index, count)) for s in chosen)
    with progress_bar(total, "generating", enabled=sys.stderr.isatty() and total > 1) as advance:
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
    kept = sum(w.skipped for w in written)
    if len(written) == 1:
        typer.echo(f"wrote {out / written[0].path}")
        return
    folders = list(dict.fromkeys(str(out / Path(w.path).parent) for w in written))
    for folder in folders:
        n = sum(str(out / Path(w.path).parent) == folder for w in written)
        typer.echo(f"wrote {n} scenes to {folder}/")
    if kept:
        typer.echo(f"({kept} already there and valid, kept)")


dataset_app = typer.Typer(
    help="The canonical 1,536-scene Urban-Nav dataset: write it, verify it, lock its digests.",
    invoke_without_command=True,
)
app.add_typer(dataset_app, name="dataset")

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
    from citygen.generate.dataset import (
        INDEX_NAME,
        check_executor,
        dataset_size,
        progress_bar,
        write_dataset,
    )

    check_executor(executor)
    total = dataset_size(manifest)
    with progress_bar(total, "dataset", enabled=sys.stderr.isatty()) as advance:
        written = write_dataset(
            out, manifest=manifest, jobs=jobs, resume=resume, on_progress=advance, executor=executor
        )
    _report_written(written, out)
    typer.echo(f"wrote {out / INDEX_NAME} ({len(written)} scenes)")


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
        _print_error(SpecError(problems))
        typer.echo(f"{folder}: {len(problems)} problems", err=True)
        raise typer.Exit(2)
    from citygen.generate.dataset import lock_path

    typer.echo(f"{folder}: {len(read_lock(lock or lock_path(manifest)))} scenes match the lock file")


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

    from citygen.generate.dataset import dataset_size, progress_bar, write_dataset, write_lock

    with tempfile.TemporaryDirectory(prefix="citygen-lock-") as tmp:
        with progress_bar(dataset_size(manifest), "locking", enabled=sys.stderr.isatty()) as advance:
            written = write_dataset(tmp, manifest=manifest, jobs=jobs, on_progress=advance)
        bad = 0
        for w in written:
            problems = citygen.validate(citygen.load_scene(Path(tmp, w.path)))
            if problems:
                _print_error(SpecError(problems, file=w.path))
                bad += 1
        if bad:
            typer.echo(f"{bad} scenes are invalid; the lock file was not written", err=True)
            raise typer.Exit(2)
    path = write_lock(written, manifest=manifest, path=out)
    typer.echo(f"wrote {path} ({len(written)} scenes)")


@app.command()
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
    and objects as they are in the file and makes the agents and the task again, with the
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
    typer.echo(f"wrote {target} (kept {kept}; made again: {remade})")


assets_app = typer.Typer(
    help="The asset catalog: list its categories, draw contact sheets of their variants.",
    no_args_is_help=True,
)
app.add_typer(assets_app, name="assets")


@assets_app.command("list")
def assets_list() -> None:
    """Every category: semantic class, zones it belongs in, anchor, variants, and the
    height and footprint ranges (m) measured over its first 100 variants."""
    from citygen.exporters.sheet import list_categories

    rows = list_categories()
    typer.echo(
        f"{'category':<20} {'class':<18} {'anchor':<9} {'variants':>8}  {'height m':>12}  "
        f"{'size x m':>12}  {'size y m':>12}  zones"
    )
    for r in rows:
        h, x, y = r["height"], r["size_x"], r["size_y"]
        typer.echo(
            f"{r['name']:<20} {r['semantic_class']:<18} {r['anchor']:<9} {r['variants']:>8}  "
            f"{h[0]:>5.2f}-{h[1]:<6.2f}  {x[0]:>5.2f}-{x[1]:<6.2f}  {y[0]:>5.2f}-{y[1]:<6.2f}  "
            f"{', '.join(sorted(r['zones']))}"
        )
    typer.echo(f"{len(rows)} categories")


@assets_app.command("render")
def assets_render(
    category: Annotated[str, typer.Argument(help="Category name (see `citygen assets list`).")],
    out: Annotated[Path, typer.Option("--out", "-o", help="PNG file to write.")] = Path("sheet.png"),
    count: Annotated[int, typer.Option("--count", min=1, max=400, help="Variants to draw.")] = 16,
    start: Annotated[int, typer.Option("--start", min=0, max=9999, help="First variant number.")] = 0,
    size: Annotated[int, typer.Option("--size", min=200, max=8192, help="Width in pixels.")] = 1600,
) -> None:
    """Draw a contact sheet of a category's variants `CATEGORY/START` onwards as a PNG."""
    from citygen.exporters.sheet import contact_sheet

    path = contact_sheet(category, out, count=count, start=start, size_px=size)
    typer.echo(f"wrote {path}")


# `citygen bench` and `citygen run` (the MuJoCo runner) live in their own module.
register_runner(app)
register_train(app)  # `citygen train` (the optional `train` extra)


def _print_error(exc: CitygenError) -> None:
    for line in exc.lines():
        typer.echo(line, err=True)


def main() -> None:
    """Entry point of the ``citygen`` console script.

    Click handles its own usage errors (exit 2), ``--help`` and Ctrl-C; citygen's
    errors are printed here, one line per problem, with exit code 2.
    """
    try:
        app()
    except CitygenError as exc:
        _print_error(exc)
        sys.exit(2)


if __name__ == "__main__":
    main()
