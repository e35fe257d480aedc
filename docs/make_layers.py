"""Draw docs/layers.svg: citygen's layers and which may import which, from the rule the tests enforce.

Run from the repository: ``python docs/make_layers.py [out.svg]``. The boxes and arrows come from
``ALLOWED`` in ``tests/test_architecture.py`` (an arrow for each direct permission,
the transitive ones left out), so the picture cannot drift from the rule; a test redraws it and
compares.
"""

from __future__ import annotations

import sys
from html import escape
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(ROOT))

from tests.test_architecture import ALLOWED  # noqa: E402

OUT = ROOT / "docs" / "layers.svg"
# Where each layer's box stands: (column, row), row 0 at the top.
POSITION = {
    "cli": (2.0, 0),
    "package": (0.2, 1),
    "runner": (2.0, 1),
    "generate": (1.5, 2),
    "exporters": (3.2, 2),
    "validate": (1.0, 3),
    "geometry": (1.0, 4),
    "assets": (2.8, 4),
    "spec": (1.9, 5),
    "base": (1.9, 6),
}
TITLE = {"package": "citygen (the package)"}
# What each layer holds, in a line (docs/architecture.md says it at length).
IDEA = {
    "cli": "the typer app: thin command modules",
    "package": "load_scene, save_scene, height_at",
    "runner": "MuJoCo envs, robots, agents, learning",
    "generate": "the six stages, layouts, splits",
    "exporters": "MJCF, USD, URDF, occupancy, GLB",
    "validate": "semantic checks of a scene",
    "geometry": "roads, terrain heights, solids",
    "assets": "the catalog: convex-part objects",
    "spec": "scene spec, configs, io, schema",
    "base": "errors, seeding, version",
}
UNIT_X, UNIT_Y, WIDTH, HEIGHT, MARGIN = 170, 92, 220, 50, 20


def may_import() -> nx.DiGraph:
    """Layer -> layer it may import directly (the transitive permissions left out)."""
    graph = nx.DiGraph()
    graph.add_nodes_from(ALLOWED)
    graph.add_edges_from((a, b) for a, allowed in ALLOWED.items() for b in allowed if a != b)
    return nx.transitive_reduction(graph)


def centre(layer: str) -> tuple[float, float]:
    col, row = POSITION[layer]
    return MARGIN + WIDTH / 2 + col * UNIT_X, MARGIN + HEIGHT / 2 + row * UNIT_Y


def border_point(layer: str, towards: tuple[float, float]) -> tuple[float, float]:
    """Where the line from the box's centre towards ``towards`` leaves the box."""
    (x, y), (tx, ty) = centre(layer), towards
    dx, dy = tx - x, ty - y
    scale = min(WIDTH / 2 / abs(dx) if dx else float("inf"), HEIGHT / 2 / abs(dy) if dy else float("inf"))
    return x + dx * scale, y + dy * scale


def render() -> str:
    graph = may_import()
    missing = set(graph) - (set(POSITION) & set(IDEA))
    assert not missing, f"place the new layers {sorted(missing)} in POSITION and IDEA"
    width = 2 * MARGIN + WIDTH + max(c for c, _ in POSITION.values()) * UNIT_X
    height = 2 * MARGIN + HEIGHT + max(r for _, r in POSITION.values()) * UNIT_Y + 24
    out = [
        f'<svg xmlns="http://www.w3.org/2000/svg" width="{width:.0f}" height="{height:.0f}" '
        f'viewBox="0 0 {width:.0f} {height:.0f}" font-family="sans-serif">',
        '<defs><marker id="arrow" viewBox="0 0 10 10" refX="10" refY="5" markerWidth="7" '
        'markerHeight="7" orient="auto-start-reverse"><path d="M0,0 L10,5 L0,10 z" fill="#555"/>'
        "</marker></defs>",
        f'<rect width="{width:.0f}" height="{height:.0f}" fill="white"/>',
    ]
    for a, b in sorted(graph.edges):
        (x1, y1), (x2, y2) = border_point(a, centre(b)), border_point(b, centre(a))
        out.append(
            f'<line x1="{x1:.1f}" y1="{y1:.1f}" x2="{x2:.1f}" y2="{y2:.1f}" stroke="#555" '
            'stroke-width="1.5" marker-end="url(#arrow)"/>'
        )
    for layer in sorted(POSITION):
        x, y = centre(layer)
        out += [
            f'<rect x="{x - WIDTH / 2:.1f}" y="{y - HEIGHT / 2:.1f}" width="{WIDTH}" height="{HEIGHT}" '
            'rx="6" fill="#eef3fb" stroke="#3b6ea8" stroke-width="1.5"/>',
            f'<text x="{x:.1f}" y="{y - 4:.1f}" text-anchor="middle" font-size="15" font-weight="bold">'
            f"{escape(TITLE.get(layer, layer))}</text>",
            f'<text x="{x:.1f}" y="{y + 14:.1f}" text-anchor="middle" font-size="10.5" fill="#333">'
            f"{escape(IDEA[layer])}</text>",
        ]
    out.append(
        f'<text x="{MARGIN}" y="{height - MARGIN / 2:.0f}" font-size="12" fill="#333">'
        "An arrow: the layer may import the one it points to (and, through it, all below).</text>"
    )
    out.append("</svg>")
    return "\n".join(out) + "\n"


if __name__ == "__main__":
    path = Path(sys.argv[1]) if len(sys.argv) > 1 else OUT
    path.write_text(render())
    print(path)
