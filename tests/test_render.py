"""The PNG exporter and ``citygen render``: valid PNGs of the asked size, the same bytes for
the same scene, each zone kind's colour where the zone is, a legend of what is there, the
terrain shaded and its tiles marked, errors as one line and exit 2."""

from __future__ import annotations

import io
import json
import math
import shutil
import subprocess
import sys

import matplotlib
import numpy as np
import pytest
from matplotlib.colors import to_rgb
from PIL import Image

from citygen.errors import ExportError, SpecError
from citygen.exporters import picture
from citygen.io import load_scene
from citygen.spec import Scene
from citygen.spec.surfaces import ZONE_KINDS
from tests.conftest import EXAMPLES, ROOT

CORNER = next(p for p in EXAMPLES if p.name == "street_corner.json")
NAV = next(p for p in EXAMPLES if p.name == "nav_static_10m.json")
SIZE = 600


def _pixels(path) -> np.ndarray:
    with Image.open(path) as im:
        assert im.format == "PNG"
        return np.asarray(im.convert("RGB"))


def _rgb(colour: str) -> tuple[int, int, int]:
    return tuple(round(c * 255) for c in to_rgb(colour))


def _at(img: np.ndarray, fig, x: float, y: float) -> tuple[int, int, int]:
    """The colour of the picture at world point (x, y) (m), located through the map's axes."""
    px, py = fig.axes[0].transData.transform((x, y))
    return tuple(int(v) for v in img[int(img.shape[0] - py), int(px)])


def _near(img: np.ndarray, fig, x: float, y: float) -> set[tuple[int, int, int]]:
    """The colours within a pixel of world point (x, y): matplotlib snaps axis-aligned
    shapes to pixel centres, so a small zone's fill may sit half a pixel off."""
    px, py = fig.axes[0].transData.transform((x, y))
    row, col = int(img.shape[0] - py), int(px)
    return {tuple(int(v) for v in p) for p in img[row - 1 : row + 2, col - 1 : col + 2].reshape(-1, 3)}


def _legend(fig) -> list[str]:
    return [t.get_text() for t in fig.legends[0].get_texts()] if fig.legends else []


def _scene(**parts) -> Scene:
    doc = {"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [12, 12]}, **parts}
    return Scene.model_validate(doc)


@pytest.fixture(scope="module")
def corner_png(tmp_path_factory):
    path = tmp_path_factory.mktemp("render") / "corner.png"
    return picture.render(CORNER, path, size_px=SIZE, terrain=False)


# --- the file -------------------------------------------------------------------------


def test_png_of_the_requested_size(corner_png):
    with Image.open(corner_png) as im:
        im.verify()
    with Image.open(corner_png) as im:
        assert im.format == "PNG"
        # A square scene with a legend beside it: the width is the larger side.
        assert im.width == SIZE
        assert 0.5 * SIZE < im.height < SIZE
        # No version or time that would change the bytes from one run to the next.
        assert set(im.info) <= {"dpi"}


@pytest.mark.parametrize(("bounds", "legend"), [((10, 40), True), ((40, 10), False), ((300, 7), True)])
def test_larger_side_is_size_px_whatever_the_shape(bounds, legend):
    scene = Scene(format="citygen.scene/1", bounds={"min": [0, 0], "max": list(bounds)})
    width, height = picture.figure(scene, size_px=500, legend=legend).canvas.get_width_height()
    assert max(width, height) == 500
    assert (height > width) == (bounds[1] > bounds[0])


def test_same_bytes_twice_and_in_a_fresh_process(corner_png, tmp_path):
    again = picture.render(CORNER, tmp_path / "again.png", size_px=SIZE, terrain=False)
    assert again.read_bytes() == corner_png.read_bytes()
    fresh = tmp_path / "fresh.png"
    code = (
        "from citygen.exporters import picture\n"
        f"picture.render({str(CORNER)!r}, {str(fresh)!r}, size_px={SIZE}, terrain=False)\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True, cwd=tmp_path, timeout=120)
    assert fresh.read_bytes() == corner_png.read_bytes()


def test_users_style_changes_nothing_and_is_left_as_it_was(corner_png, tmp_path):
    user = {"font.size": 17.0, "axes.facecolor": "#ff00ff", "lines.linewidth": 4.0, "hatch.linewidth": 3.0}
    with matplotlib.rc_context(user):
        out = picture.render(CORNER, tmp_path / "styled.png", size_px=SIZE, terrain=False)
        assert {k: matplotlib.rcParams[k] for k in user} == user
    assert out.read_bytes() == corner_png.read_bytes()


def test_no_pyplot_and_the_backend_untouched(tmp_path):
    code = (
        "import sys, matplotlib\n"
        "matplotlib.use('svg')\n"
        "from citygen.exporters import picture\n"
        f"picture.render({str(NAV)!r}, 'nav.png', size_px=200)\n"
        "print(matplotlib.get_backend(), 'matplotlib.pyplot' in sys.modules)\n"
    )
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=tmp_path, timeout=120
    )
    assert proc.returncode == 0, proc.stderr
    assert proc.stdout.split() == ["svg", "False"]


def test_written_atomically_leaving_nothing_else(tmp_path):
    out = tmp_path / "deep" / "er" / "nav.png"
    assert picture.render(NAV, out, size_px=200) == out
    assert [p.name for p in out.parent.iterdir()] == ["nav.png"]


# --- what is drawn ------------------------------------------------------------------------

# Points of examples/street_corner.json inside a zone, clear of objects, agents and lines.
CORNER_POINTS = {
    "roadway": (7.0, 8.5),
    "sidewalk": (5.0, 12.9),
    "building": (5.0, 20.0),
    "plaza": (17.0, 22.5),
    "vegetation": (19.5, 19.0),
    "curb": (17.0, 3.1),
}


@pytest.mark.parametrize("kind", sorted(CORNER_POINTS))
def test_zone_colour_where_the_zone_is(kind, corner_png):
    fig = picture.figure(CORNER, size_px=SIZE, terrain=False)
    assert _at(_pixels(corner_png), fig, *CORNER_POINTS[kind]) == _rgb(picture.ZONE_COLORS[kind])


def test_palette_covers_every_zone_kind_with_distinct_colours():
    assert set(picture.ZONE_COLORS) == set(ZONE_KINDS)
    assert len(set(picture.ZONE_COLORS.values())) == len(ZONE_KINDS)


def test_holes_are_left_open():
    ring = [[1, 1], [11, 1], [11, 11], [1, 11]]
    hole = [[4, 4], [8, 4], [8, 8], [4, 8]]
    for polygon, holes in ((ring, [hole]), (ring[::-1], [hole[::-1]])):  # either orientation
        scene = _scene(zones=[{"id": "p", "kind": "plaza", "polygon": polygon, "holes": holes}])
        fig = picture.figure(scene, size_px=300, legend=False)
        buf = io.BytesIO()
        fig.savefig(buf, format="png", dpi=fig.dpi)
        img = np.asarray(Image.open(buf).convert("RGB"))
        assert _at(img, fig, 2.5, 2.5) == _rgb(picture.ZONE_COLORS["plaza"])
        assert _at(img, fig, 6.0, 6.0) != _rgb(picture.ZONE_COLORS["plaza"])


def test_holes_stay_with_their_polygon_when_paths_are_cut(monkeypatch):
    monkeypatch.setattr(picture, "_CHUNK_VERTICES", 12)  # a path every polygon or two
    zones = []
    for k in range(9):
        x, y = 4 * (k % 3), 4 * (k // 3)
        zones.append(
            {
                "id": f"z{k}",
                "kind": "plaza",
                "polygon": [[x, y], [x + 4, y], [x + 4, y + 4], [x, y + 4]],
                "holes": [[[x + 1, y + 1], [x + 3, y + 1], [x + 3, y + 3], [x + 1, y + 3]]],
            }
        )
    fig = picture.figure(_scene(zones=zones), size_px=400, legend=False)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=fig.dpi)
    img = np.asarray(Image.open(buf).convert("RGB"))
    plaza = _rgb(picture.ZONE_COLORS["plaza"])
    for k in range(9):
        x, y = 4 * (k % 3), 4 * (k // 3)
        assert _at(img, fig, x + 2, y + 2) != plaza, k
        assert _at(img, fig, x + 0.5, y + 2) == plaza, k


def test_legend_lists_the_kinds_present_and_only_those():
    scene = load_scene(CORNER)
    labels = _legend(picture.figure(CORNER, size_px=SIZE))
    present = {z.kind for z in scene.zones}
    assert [k for k in labels if k in ZONE_KINDS] == [k for k in ZONE_KINDS if k in present]
    for what in ("road block", "open socket", "object", "pedestrian", "cyclist", "vehicle", "goal"):
        assert what in labels
    assert "start (wheeled)" in labels
    assert not {"scooter", "mesh object", "route", "joined socket"} & set(labels)
    assert not any(label.startswith("terrain") for label in labels)  # the scene has none
    assert picture.figure(CORNER, size_px=SIZE, legend=False).legends == []


def test_terrain_shaded_and_stairs_marked(tmp_path):
    shaded = picture.render(NAV, tmp_path / "shaded.png", size_px=SIZE)
    flat = picture.render(NAV, tmp_path / "flat.png", size_px=SIZE, terrain=False)
    fig = picture.figure(NAV, size_px=SIZE)
    labels = _legend(fig)
    assert "terrain 0.00 to 0.30 m" in labels
    assert "stair (risers, up)" in labels
    assert "terrain 0.00 to 0.30 m" not in _legend(picture.figure(NAV, size_px=SIZE, terrain=False))
    a, b = _pixels(shaded), _pixels(flat)
    assert a.shape == b.shape
    # Level ground keeps its zone's colour; the stair tile (x 2.5 to 5 m) is drawn over.
    sidewalk = _rgb(picture.ZONE_COLORS["sidewalk"])
    assert _at(a, fig, 1.8, 5.9) == _at(b, fig, 1.8, 5.9) == sidewalk
    (x0, y0), (x1, y1) = (fig.axes[0].transData.transform(p) for p in ((2.5, 3.75), (5.0, 6.25)))
    rows = slice(int(a.shape[0] - y1) + 2, int(a.shape[0] - y0) - 2)
    cols = slice(int(x0) + 2, int(x1) - 2)
    assert np.any(a[rows, cols] != b[rows, cols])


TILES = [
    {"kind": "stair", "step_height": 0.15, "step_count": 4, "ascent": "+x"},
    {"kind": "slope", "angle": 0.2, "ascent": "-y"},
    {"kind": "rough", "amplitude": 0.1, "scale": 1.0, "seed": 3},
    {"kind": "flat", "height": 0.5},
]


def test_every_tile_kind_is_marked_and_shaded_both_ways():
    zone = {"id": "p", "kind": "plaza", "polygon": [[0, 0], [12, 0], [12, 12], [0, 12]]}
    terrain = {"origin": [0, 0], "tile_size": 6.0, "rows": 2, "cols": 2, "tiles": TILES}
    scene = _scene(zones=[zone], terrain=terrain)
    fig = picture.figure(scene, size_px=SIZE)
    labels = _legend(fig)
    assert {"stair (risers, up)", "slope (up)", "rough ground"} <= set(labels)
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=fig.dpi)
    img = np.asarray(Image.open(buf).convert("RGB")).astype(int)
    plaza = np.array(_rgb(picture.ZONE_COLORS["plaza"]))
    # The rough tile (x 0 to 6 m, y 6 to 12 m) has ground lit brighter and shaded darker.
    (x0, y0), (x1, y1) = (fig.axes[0].transData.transform(p) for p in ((1.0, 7.0), (5.0, 11.0)))
    patch = img[int(img.shape[0] - y1) : int(img.shape[0] - y0), int(x0) : int(x1)].sum(axis=2)
    assert patch.max() > plaza.sum() + 10
    assert patch.min() < plaza.sum() - 10
    # The slope (x 6 to 12, y 0 to 6) rises to the south: it faces north, to the light.
    assert sum(_at(img, fig, 7.0, 1.0)) > plaza.sum()


def test_big_grid_is_shaded_without_marks():
    n = 120
    tiles = [TILES[i % 3] for i in range(n * n)]
    terrain = {"origin": [0, 0], "tile_size": 1.0, "rows": n, "cols": n, "tiles": tiles}
    scene = Scene.model_validate(
        {"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [n, n]}, "terrain": terrain}
    )
    labels = _legend(picture.figure(scene, size_px=400))  # tiles of about 2 px
    assert any(label.startswith("terrain ") for label in labels)
    assert not {"stair (risers, up)", "slope (up)", "rough ground"} & set(labels)


def test_a_city_of_many_zones_renders(tmp_path):
    n, cell = 120, 10.0  # 14,400 zones over 1.2 km, every kind
    zones = [
        {
            "id": f"z{i}-{j}",
            "kind": ZONE_KINDS[(i * 7 + j) % len(ZONE_KINDS)],
            "polygon": [
                [j * cell, i * cell],
                [(j + 1) * cell, i * cell],
                [(j + 1) * cell, (i + 1) * cell],
                [j * cell, (i + 1) * cell],
            ],
        }
        for i in range(n)
        for j in range(n)
    ]
    scene = Scene.model_validate(
        {"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [n * cell, n * cell]}, "zones": zones}
    )
    out = picture.render(scene, tmp_path / "city.png", size_px=800)
    img = _pixels(out)
    fig = picture.figure(scene, size_px=800)
    for i, j in ((0, 0), (57, 31), (119, 119)):
        kind = ZONE_KINDS[(i * 7 + j) % len(ZONE_KINDS)]
        if kind != "crosswalk":  # hatched
            assert _rgb(picture.ZONE_COLORS[kind]) in _near(img, fig, (j + 0.5) * cell, (i + 0.5) * cell)


def test_everything_else_a_scene_can_hold():
    scene = _scene(
        placements=[
            {"id": "kiosk", "asset": "meshes/kiosk.obj", "position": [3, 3, 0]},
            {"id": "bench", "asset": "bench/0001", "position": [6, 6, 0], "yaw": 0.7, "scale": 1.5},
        ],
        agents=[
            {"id": "s", "kind": "scooter", "start": [1, 1], "goal": [2, 2]},
            {"id": "v", "kind": "vehicle", "start": [5, 5], "goal": [5, 5]},
        ],
        task={
            "kind": "traverse",
            "start": {"position": [1, 11]},
            "time_limit": 100,
            "route": [[6, 11], [11, 6]],
        },
    )
    labels = _legend(picture.figure(scene, size_px=300))
    assert {"object", "mesh object", "scooter", "vehicle", "route", "goal", "start (wheeled)"} <= set(labels)
    task = {"kind": "loco-flat", "robot": "quadruped", "start": {"position": [1, 11]}, "time_limit": 9}
    loco = _scene(task=task)
    labels = _legend(picture.figure(loco, size_px=300))
    assert "start (quadruped)" in labels
    assert "goal" not in labels


def _two_blocks(bounds: float) -> Scene:
    def block(name, x, joined, other):
        theirs = "in" if joined == "out" else "out"
        return {
            "id": name,
            "kind": "straight",
            "pose": {"position": [x, 6]},
            "length": 6,
            "sockets": [
                {"id": "in", "pose": {"position": [x, 6], "yaw": 3.1416}},
                {"id": "out", "pose": {"position": [x + 6, 6]}},
            ],
            "connections": [{"socket": joined, "block": other, "to_socket": theirs}],
        }

    doc = {
        "format": "citygen.scene/1",
        "bounds": {"min": [0, 0], "max": [bounds, bounds]},
        "blocks": [block("a", 0, "out", "b"), block("b", 6, "in", "a")],
    }
    return Scene.model_validate(doc)


def test_sockets_open_and_joined_and_left_out_when_too_small():
    labels = _legend(picture.figure(_two_blocks(12), size_px=400))
    assert {"road block", "open socket", "joined socket"} <= set(labels)
    labels = _legend(picture.figure(_two_blocks(1200), size_px=300))  # a 7 m road is a pixel wide
    assert "road block" in labels
    assert not {"open socket", "joined socket"} & set(labels)


def test_unknown_asset_names_the_placement():
    scene = _scene(placements=[{"id": "x", "asset": "spaceship/0001", "position": [3, 3, 0]}])
    with pytest.raises(SpecError) as err:
        picture.figure(scene, size_px=300)
    assert err.value.problems[0].path == "$.placements[0].asset"


@pytest.mark.parametrize("width", [0.3, 1.0, 3.0, 10.0, 24.0, 99.0, 1200.0, 7777.0])
def test_scale_bar_is_round_and_about_a_fifth(width):
    length = picture.scale_bar_length(width)
    mantissa = length / 10 ** math.floor(math.log10(length))
    assert round(mantissa, 6) in (1.0, 2.0, 5.0)
    assert width / 8 <= length <= width / 3


# --- export and options ------------------------------------------------------------------


def test_export_writes_name_png(tmp_path):
    scene_file = tmp_path / "corner.json"
    shutil.copy(CORNER, scene_file)
    assert picture.export(scene_file, tmp_path / "out", size_px=200) == [tmp_path / "out" / "corner.png"]
    scene = load_scene(CORNER)
    named = scene.model_copy(update={"meta": scene.meta.model_copy(update={"split": "demo", "index": 7})})
    assert picture.export(named, tmp_path, size_px=200)[0].name == "demo-00007.png"
    assert picture.export(scene, tmp_path, size_px=200, name="x")[0].name == "x.png"


@pytest.mark.parametrize(
    ("call", "message"),
    [
        (lambda d: picture.export(CORNER, d, colour="red"), "unknown option 'colour'"),
        (lambda d: picture.export(CORNER, d, name="../up"), "without folders"),
        (lambda d: picture.render(CORNER, d / "x.png", size_px=10), "size_px"),
        (lambda d: picture.render(CORNER, d / "x.png", size_px=True), "size_px"),
        (lambda d: picture.render(CORNER, d / "x.jpg"), ".png"),
        (lambda d: picture.render(CORNER, d), ".png"),
    ],
)
def test_bad_options_are_export_errors(call, message, tmp_path):
    with pytest.raises(ExportError, match=message.replace(".", r"\.")):
        call(tmp_path)


# --- the command ---------------------------------------------------------------------------


def test_cli_writes_beside_the_scene_by_default(tmp_path, cli):
    scene_file = tmp_path / "nav.json"
    shutil.copy(NAV, scene_file)
    result = cli("render", scene_file, "--size", "300")
    assert result.code == 0, result.err
    assert result.out.strip() == f"wrote {tmp_path / 'nav.png'}"
    assert max(Image.open(tmp_path / "nav.png").size) == 300


def test_cli_options(tmp_path, cli):
    out = tmp_path / "pics" / "corner.png"
    result = cli("render", CORNER, "--out", out, "--size", "256", "--no-terrain", "--no-legend")
    assert result.code == 0, result.err
    expected = tmp_path / "expected.png"
    picture.render(CORNER, expected, size_px=256, terrain=False, legend=False)
    assert out.read_bytes() == expected.read_bytes()


def _bad_scene() -> str:
    doc = json.loads(CORNER.read_text())
    doc["zones"][3]["kind"] = "roadways"
    return json.dumps(doc)


@pytest.mark.parametrize(
    ("content", "expected"),
    [
        (None, "$: expected an existing file"),
        ("{", "$: expected valid JSON"),
        (_bad_scene(), "$.zones[3].kind: expected one of"),
    ],
    ids=["missing file", "invalid JSON", "invalid scene"],
)
def test_cli_bad_input_is_one_line_and_exit_2(content, expected, tmp_path, cli):
    file = tmp_path / "scene.json"
    if content is not None:
        file.write_text(content)
    result = cli("render", file, "--out", tmp_path / "x.png")
    assert result.code == 2
    assert "Traceback" not in result.err + result.out
    assert result.err.splitlines() == [result.err.strip()]
    assert result.err.startswith(f"{file}: {expected}"), result.err
    assert not (tmp_path / "x.png").exists()


def test_cli_unwritable_output_is_one_line_and_exit_2(tmp_path, cli):
    blocker = tmp_path / "file"
    blocker.write_text("")
    result = cli("render", CORNER, "--out", blocker / "x.png")
    assert result.code == 2
    assert result.err.strip() == f"--out {blocker / 'x.png'}: expected a folder at {blocker}, got a file"
    assert len(result.err.strip().splitlines()) == 1


def test_cli_usage_errors_exit_2(cli):
    assert cli("render").code == 2
    assert cli("render", CORNER, "--size", "10").code == 2


def test_repository_examples_render(tmp_path):
    for example in EXAMPLES:
        out = picture.render(example, tmp_path / f"{example.stem}.png", size_px=256)
        assert out.stat().st_size > 1000
    assert ROOT.is_dir()
