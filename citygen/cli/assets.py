"""``citygen assets``: the asset catalog's categories and contact sheets of their variants."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

assets_app = typer.Typer(
    help="The asset catalog: list its categories, draw contact sheets of their variants.",
    no_args_is_help=True,
)


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


def register(app: typer.Typer) -> None:
    """Add the ``assets`` group to ``app``."""
    app.add_typer(assets_app, name="assets")
