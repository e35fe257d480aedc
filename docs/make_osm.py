"""Draws docs/osm.png and docs/osm-helsinki.png: an OpenStreetMap extract as the map draws it,
beside the scene citygen makes of it (``citygen render``): the made-up town
(tests/data/osm/town.osm) and a real place, 400 m of central Helsinki around the Esplanadi park
(tests/data/osm/helsinki-esplanadi.osm.pbf; (c) OpenStreetMap contributors, ODbL).

Left: every way and tagged node of the extract, projected with the scene's own recorded
projection (``meta.source.projection``) and drawn with matplotlib. Right: the PNG ``citygen
render`` draws of the scene ``citygen generate --osm FILE --bbox BOX`` writes (seed 0). Run:
``python docs/make_osm.py``.
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import osmium
from matplotlib.patches import Polygon as Patch
from pyproj import Transformer

from citygen.exporters.picture import render
from citygen.generate.places import generate_place

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "osm"
#: (extract, box, picture, title of the left panel)
PLACES = (
    (DATA / "town.osm", (8.5397, 47.3697, 8.5443, 47.3720), "osm.png", "town.osm"),
    (
        DATA / "helsinki-esplanadi.osm.pbf",
        (24.9422, 60.1647, 24.9494, 60.1683),
        "osm-helsinki.png",
        "Helsinki, Esplanadi (OpenStreetMap, ODbL)",
    ),
)
COLOURS = {
    "building": "#9c8f86",
    "park": "#8cc26a",
    "water": "#7fb2e5",
    "parking": "#8a96a8",
    "square": "#e2c79a",
}
NODES = {"bench": "#8b4513", "tree": "#2e7d32", "bollard": "#555555", "street_lamp": "#f2b01e",
         "traffic_signals": "#d32f2f", "crossing": "#ffffff", "waste_basket": "#444444",
         "fire_hydrant": "#e53935", "bicycle_parking": "#1565c0"}  # fmt: skip


def _kind(tags) -> str | None:
    if "building" in tags:
        return "building"
    if tags.get("leisure") == "park":
        return "park"
    if tags.get("natural") == "water":
        return "water"
    if tags.get("amenity") == "parking":
        return "parking"
    if tags.get("place") == "square":
        return "square"
    return None


def _width(text: str | None, default: float) -> float:
    try:
        return float(str(text).split(";")[0].removesuffix("m").strip())
    except ValueError:
        return default


def draw_source(ax, scene, file: Path, title: str) -> None:
    t = Transformer.from_crs("EPSG:4326", scene.meta.source.projection, always_xy=True)
    for obj in osmium.FileProcessor(str(file)).with_locations().with_areas():
        if isinstance(obj, osmium.osm.Area) and (kind := _kind(obj.tags)):
            for outer in obj.outer_rings():
                ax.add_patch(Patch([t.transform(n.lon, n.lat) for n in outer], color=COLOURS[kind], lw=0))
                for inner in obj.inner_rings(outer):
                    ax.add_patch(Patch([t.transform(n.lon, n.lat) for n in inner], color="white", lw=0))
        elif isinstance(obj, osmium.osm.Way) and "highway" in obj.tags and obj.tags.get("area") != "yes":
            points = [t.transform(n.lon, n.lat) for n in obj.nodes if n.location.valid()]
            if len(points) < 2:
                continue
            xs, ys = zip(*points, strict=True)
            street = obj.tags["highway"] not in ("footway", "path", "cycleway", "steps", "pedestrian")
            width = _width(obj.tags.get("width"), 6.0 if street else 2.0)
            ax.plot(
                xs,
                ys,
                color="#4a4a4a" if street else "#c9b48a",
                lw=width * 1.25,
                solid_capstyle="butt",
                zorder=2,
            )
            ax.plot(xs, ys, color="white", lw=0.5, ls=(0, (4, 4)), zorder=3)
        elif isinstance(obj, osmium.osm.Node):
            tag = next(
                (v for k, v in obj.tags if k in ("amenity", "natural", "barrier", "highway", "emergency")),
                None,
            )
            if tag in NODES:
                x, y = t.transform(obj.location.lon, obj.location.lat)
                ax.plot(x, y, "o", ms=4, mfc=NODES[tag], mec="black", mew=0.4, zorder=4, label=tag)
    handles, labels = ax.get_legend_handles_labels()
    unique = dict(zip(labels, handles, strict=True))
    ax.legend(
        unique.values(), unique.keys(), loc="upper left", bbox_to_anchor=(1.0, 1.0), fontsize=7, frameon=False
    )
    ax.set_xlim(scene.bounds.min[0], scene.bounds.max[0])
    ax.set_ylim(scene.bounds.min[1], scene.bounds.max[1])
    ax.set_aspect("equal")
    ax.set_title(f"{title} as the map draws it (matplotlib)", fontsize=9)
    ax.tick_params(labelsize=7)


def draw(file: Path, box: tuple[float, float, float, float], name: str, title: str) -> Path:
    scene = generate_place(file, box, seed=0)
    square = scene.bounds.max[0] - scene.bounds.min[0] < 1.5 * (scene.bounds.max[1] - scene.bounds.min[1])
    size = (15, 6.4) if square else (15, 4.8)
    fig, (left, right) = plt.subplots(1, 2, figsize=size, gridspec_kw={"width_ratios": [1.12, 1.45]})
    draw_source(left, scene, file, title)
    with tempfile.TemporaryDirectory() as tmp:
        png = render(scene, Path(tmp) / "town.png", size_px=1400)
        right.imshow(plt.imread(png))
    right.set_axis_off()
    right.set_title("citygen's scene of it (citygen render)", fontsize=9)
    out = ROOT / "docs" / name
    fig.tight_layout()
    fig.savefig(out, dpi=110, metadata={"Software": None})
    plt.close(fig)
    return out


if __name__ == "__main__":
    for place in PLACES:
        print(f"wrote {draw(*place)}")
