"""The HTML viewer: self-contained, deterministic, and showing the scene in a real browser.

The screenshot tests open the page in headless Chromium with software WebGL (SwiftShader
through ANGLE) and look for the zones' colours in the 3-D view. Without Chromium they
skip, except under CI (the ``CI`` environment variable), where Chromium must be installed
(``apt-get install -y chromium``) and its absence fails.
"""

from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from citygen.errors import ExportError
from citygen.exporters import html
from citygen.exporters.meshes import MESH_RGBA
from citygen.exporters.picture import ZONE_COLORS
from citygen.io import load_scene
from tests.conftest import ROOT
from tests.test_export_glb import expected_names
from tests.test_export_urdf import write_terrain_scene

#: Headless Chromium with WebGL in software: ANGLE on SwiftShader (Chromium 150 needs
#: --enable-unsafe-swiftshader for it; --use-gl=swiftshader gives a blank page).
CHROMIUM_FLAGS = (
    "--headless",
    "--disable-gpu",
    "--no-sandbox",
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
    "--hide-scrollbars",
    "--window-size=800,600",
)
#: Columns left of this are the legend's; the 3-D view is checked right of it.
LEGEND_PX = 220


def chromium() -> str:
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        path = shutil.which(name)
        if path:
            return path
    if os.environ.get("CI"):
        pytest.fail("Chromium is not installed, and CI must run the viewer test: apt-get install -y chromium")
    pytest.skip("Chromium is not installed (apt-get install -y chromium); CI runs this test")


def screenshot(page: Path, folder: Path) -> np.ndarray:
    """The page as headless Chromium shows it in an 800 x 600 window: RGB pixels."""
    png = folder / f"{page.stem}.png"
    proc = subprocess.run(
        [
            chromium(),
            *CHROMIUM_FLAGS,
            f"--user-data-dir={folder / 'profile'}",
            f"--screenshot={png}",
            page.as_uri(),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert proc.returncode == 0 and png.is_file(), proc.stderr[-2000:]
    return np.asarray(Image.open(png).convert("RGB"), dtype=np.int16)


def share(pixels: np.ndarray, colour: str | tuple, tol: int = 3) -> float:
    """The fraction of pixels within ``tol`` (per channel, 0-255) of ``colour``."""
    rgb = colour if not isinstance(colour, str) else tuple(int(colour[i : i + 2], 16) for i in (1, 3, 5))
    return float((np.abs(pixels - np.asarray(rgb)) <= tol).all(axis=-1).mean())


def payload(page: Path) -> dict:
    text = page.read_text(encoding="utf-8")
    match = re.search(r'<script type="application/json" id="scene-data">(.*?)</script>', text, re.S)
    return json.loads(match.group(1))


@pytest.fixture(scope="module")
def street(tmp_path_factory) -> Path:
    return write_terrain_scene(tmp_path_factory.mktemp("street"))


def test_the_page_is_self_contained(street, tmp_path):
    (page,) = html.export(street, tmp_path)
    assert page == tmp_path / "street.html"
    text = page.read_text(encoding="utf-8")
    # Nothing is fetched: no src or href attributes, every import a data: URL.
    assert not re.search(r"\s(src|href)=", text)
    importmap = json.loads(re.search(r'<script type="importmap">(.*?)</script>', text, re.S).group(1))
    assert set(importmap["imports"]) == {"three", "three/addons/controls/OrbitControls.js"}
    assert all(url.startswith("data:text/javascript;base64,") for url in importmap["imports"].values())
    assert "three.js authors" in text and "MIT License" in text
    # The geometry is the GLB's: every node, each mesh once with its instances.
    data = payload(page)
    nodes = [name for mesh in data["meshes"] for name, _ in mesh["instances"]]
    assert len(nodes) == len(set(nodes))
    assert set(nodes) == expected_names(load_scene(street)) - {"scene/root"} | {"ground/plane"}
    bins = next(m for m in data["meshes"] if m["name"] == "asset/trash_bin/0011")
    assert [name for name, _ in bins["instances"]] == ["bin-1"]
    legend = [label for label, _ in data["legend"]]
    assert legend == [
        "roadway",
        "curb",
        "sidewalk",
        "plaza",
        "vegetation",
        "pedestrian",
        "vehicle",
        "start",
        "goal",
    ]


def test_same_scene_same_bytes(street, tmp_path):
    a = html.export(street, tmp_path / "a")[0].read_bytes()
    b = html.export(street, tmp_path / "b")[0].read_bytes()
    assert a == b


def test_the_legend_can_be_hidden_and_the_title_set(street, tmp_path):
    text = html.to_html(street, legend=False, title="Corner <3>")
    assert '<div id="legend" hidden>' in text
    assert "<title>Corner &lt;3&gt;</title>" in text


def test_bad_options_are_clear_errors(street, tmp_path):
    with pytest.raises(ExportError, match="unknown option 'camera'"):
        html.export(street, tmp_path, camera="top")
    with pytest.raises(ExportError, match="'title'"):
        html.export(street, tmp_path, title=3)


def test_chromium_shows_the_street_corner(tmp_path):
    example = ROOT / "examples" / "street_corner.json"
    pixels = screenshot(html.export(example, tmp_path)[0], tmp_path)
    assert pixels.shape == (600, 800, 3)
    view = pixels[:, LEGEND_PX:]
    assert len(np.unique(view.reshape(-1, 3), axis=0)) > 100  # not blank
    assert share(view, html.BACKGROUND) < 0.9
    for kind in ("roadway", "sidewalk", "crosswalk", "plaza", "building"):
        assert share(view, ZONE_COLORS[kind]) > 0.005, kind
    # The legend shows the kinds too, in its corner.
    assert share(pixels[:, :LEGEND_PX], ZONE_COLORS["curb"]) > 0.0005


def test_chromium_shows_terrain_and_a_mesh_object(street, tmp_path):
    pixels = screenshot(html.export(street, tmp_path, legend=False)[0], tmp_path)
    view = pixels[:, LEGEND_PX:]
    for kind in ("roadway", "sidewalk", "plaza"):
        assert share(view, ZONE_COLORS[kind]) > 0.005, kind
    # The kiosk's flat roof, seen from above, in the colour of mesh objects.
    roof = tuple(round(c * 255) for c in MESH_RGBA[:3])
    assert share(view, roof) > 0.001
