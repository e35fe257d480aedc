"""``citygen render`` and ``citygen export``: a scene's picture, and its files for other simulators."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from citygen.exporters.batch import FORMATS as EXPORT_FORMATS
from citygen.outputs import check_output


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
    check_output(target, option="--out" if out is not None else None)
    path = render_picture(scene, target, size_px=size, terrain=terrain, legend=legend)
    typer.echo(f"wrote {path}")


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
            max=256,
            help="Worker processes, each exporting one format of one scene at a time (1: all in this "
            "process).  [default: every core]",
        ),
    ] = None,
    validate: Annotated[
        bool,
        typer.Option(
            "--validate/--no-validate",
            help="Check each scene as `citygen validate` does first, and export only the valid ones.",
        ),
    ] = True,
    visual: Annotated[
        bool,
        typer.Option(
            "--visual/--no-visual",
            help="URDF: write <visual> elements; --no-visual writes collision geometry only, for "
            "loaders on a machine without a rendering device (SAPIEN).",
        ),
    ] = True,
    mjcf_terrain: Annotated[
        str,
        typer.Option(
            "--mjcf-terrain",
            help="MJCF: slope and rough tiles as heightfield (MuJoCo), convex pieces (readers "
            "without heightfields: Genesis), or hybrid (slopes convex, rough tiles heightfields: "
            "what the runner gives a legged robot).",
        ),
    ] = "heightfield",
    piece_tolerance: Annotated[
        float | None,
        typer.Option(
            "--piece-tolerance",
            min=0.001,
            max=1.0,
            help="How far (m) rough tiles' convex pieces (URDF, --mjcf-terrain convex) may lie from "
            "height_at.  [default: 0.01, coarser for a city, with a warning]",
        ),
    ] = None,
) -> None:
    """Compile scenes to the files other simulators load: MJCF, USD, URDF, an occupancy map
    (npz, ROS yaml/pgm, png), GLB, a self-contained HTML viewer, PNG pictures.

    A generated scene (`<split>/<part>/NNNN.json`) is written as `<split>-NNNN.*`, any other
    as its file's stem. Assets repeated across scenes are written once, content-addressed,
    under `OUT/assets/`. Whatever a format cannot express or had to coarsen is reported on
    stderr as `FILE: warning: ...`. Each scene is first checked as `citygen validate` does; an
    invalid one is reported (one line per problem) and not exported. A scene or format that
    fails is reported as `FILE: error: ...` and the rest are still exported; the exit code is
    then 2. Formats and
    scenes are exported in --jobs processes at once; the output is the same, in the same order.
    """
    from citygen.errors import ExportError
    from citygen.exporters.batch import export_batch
    from citygen.exporters.mjcf import TERRAINS as MJCF_TERRAINS
    from citygen.generate.dataset import default_jobs

    if fmt != "all" and fmt not in EXPORT_FORMATS:
        raise ExportError(f"--format: expected one of {', '.join(EXPORT_FORMATS)} or all, got {fmt!r}")
    if mjcf_terrain not in MJCF_TERRAINS:
        raise ExportError(f"--mjcf-terrain: expected one of {', '.join(MJCF_TERRAINS)}, got {mjcf_terrain!r}")
    if resolution is not None and occupancy_resolution not in (None, resolution):
        raise ExportError(
            f"--resolution: the same as --occupancy-resolution, given both as {resolution:g} and "
            f"{occupancy_resolution:g}; pass one"
        )
    chosen = list(EXPORT_FORMATS) if fmt == "all" else [fmt]
    check_output(out, folder=True, option="--out")
    failed = set(_invalid(scenes)) if validate else set()
    for event in export_batch(
        [s for s in scenes if s not in failed], out, chosen, terrain_resolution=terrain_resolution,
        occupancy_resolution=occupancy_resolution if occupancy_resolution is not None else resolution,
        jobs=default_jobs() if jobs is None else jobs,
        options=_format_options(visual, mjcf_terrain, piece_tolerance),
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


def _format_options(visual: bool, mjcf_terrain: str, tolerance: float | None) -> dict[str, dict]:
    """The exporter modules' own options the flags ask for (only those not at their default)."""
    urdf: dict = {} if visual else {"visual": False}
    mjcf: dict = {} if mjcf_terrain == "heightfield" else {"terrain": mjcf_terrain}
    if tolerance is not None:
        urdf["tolerance"] = tolerance
        if mjcf:
            mjcf["tolerance"] = tolerance
    return {"urdf": urdf, "mjcf": mjcf}


def _invalid(scenes: list[Path]) -> list[Path]:
    """The scenes `citygen validate` rejects, each problem printed as the batch prints a
    failure: `FILE: error: $.json.path: expected ..., got ...`."""
    import citygen
    from citygen.errors import SpecError

    bad = []
    for scene in scenes:
        try:
            problems = citygen.validate(citygen.load_scene(scene), base_dir=scene.parent)
            lines = [str(p) for p in problems]
        except SpecError as exc:
            lines = [line.removeprefix(f"{scene}: ") for line in exc.lines()]
        for line in lines:
            typer.echo(f"{scene}: error: {line}", err=True)
        if lines:
            bad.append(scene)
    return bad


def register(app: typer.Typer) -> None:
    """Add ``render`` and ``export`` to ``app``."""
    app.command()(render)
    app.command()(export)
