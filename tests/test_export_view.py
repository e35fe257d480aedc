"""The MuJoCo perspective picture: rendered offscreen, it shows the scene; without OpenGL
it fails with one clear message.

Rendering runs in a fresh interpreter, as ``citygen`` does: MuJoCo fixes its GL backend
when it is first imported, and another test may have imported it without one.
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
from PIL import Image

from citygen.errors import ExportError
from citygen.exporters import view
from tests.conftest import ROOT

STREET = ROOT / "examples" / "street_corner.json"

LAWN = """{"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [20, 10]},
 "zones": [{"id": "lawn", "kind": "vegetation", "polygon": [[0, 0], [10, 0], [10, 10], [0, 10]]},
           {"id": "road", "kind": "roadway", "polygon": [[10, 0], [20, 0], [20, 10], [10, 10]]}]}"""


def run(script: str, *args: str, env: dict | None = None) -> subprocess.CompletedProcess:
    base = {k: v for k, v in os.environ.items() if k != "MUJOCO_GL"}
    return subprocess.run(
        [sys.executable, "-c", script, *args], capture_output=True, text=True, cwd=ROOT,
        env={**base, **(env or {})}, timeout=240,
    )  # fmt: skip


RENDER = """
import sys
from citygen.exporters import view
out = sys.argv[1]
print(view.export(sys.argv[2], out)[0])
print(view.render_perspective(sys.argv[3], out + "/lawn-top.png", camera="top", size=(400, 200)))
"""


def test_pictures_show_the_scene(tmp_path):
    lawn = tmp_path / "lawn.json"
    lawn.write_text(LAWN)
    done = run(RENDER, str(tmp_path), str(STREET), str(lawn))
    assert done.returncode == 0, done.stderr[-2000:]
    first, second = done.stdout.split()
    assert first == str(tmp_path / "street_corner-perspective.png")
    street = np.asarray(Image.open(first))
    assert street.shape == (480, 640, 3)
    assert street.std() > 20 and len(np.unique(street.reshape(-1, 3), axis=0)) > 200  # not blank
    # The top camera looks straight down: the lawn (west) is green, the road (east) dark grey.
    top = np.asarray(Image.open(second)).astype(int)
    assert top.shape == (200, 400, 3)
    west, east = top[90:110, 110:130].mean(axis=(0, 1)), top[90:110, 270:290].mean(axis=(0, 1))
    assert west[1] > west[0] + 30 and west[1] > west[2] + 30, west
    assert abs(east[0] - east[1]) < 15 and east.mean() < 110, east


def test_without_opengl_the_error_says_so(tmp_path):
    # GLFW with no display to open a window on: the same failure as a machine without GL.
    script = (
        "import sys\nfrom citygen.exporters import view\n"
        "try:\n    view.render_perspective(sys.argv[1], sys.argv[2])\n"
        "except RuntimeError as e:\n    print(e)\n"
    )
    env = {"MUJOCO_GL": "glfw", "DISPLAY": "", "WAYLAND_DISPLAY": ""}
    done = run(script, str(STREET), str(tmp_path / "x.png"), env=env)
    assert done.returncode == 0, done.stderr[-2000:]
    assert done.stdout.startswith("no OpenGL for offscreen rendering (MUJOCO_GL=glfw)"), done.stdout
    assert len(done.stdout.strip().splitlines()) == 1
    assert not (tmp_path / "x.png").exists()


def test_bad_arguments_fail_before_rendering(tmp_path):
    with pytest.raises(ExportError, match=r"ending in \.png"):
        view.render_perspective(STREET, tmp_path / "x.jpg")
    with pytest.raises(ExportError, match="size"):
        view.render_perspective(STREET, tmp_path / "x.png", size=(0, 10))
    with pytest.raises(ExportError, match="size"):
        view.render_perspective(STREET, tmp_path / "x.png", size=(640.0, 480))
    with pytest.raises(ExportError, match="camera: expected one of"):
        view.render_perspective(STREET, tmp_path / "x.png", camera="side")
    with pytest.raises(ExportError, match="unknown option 'dpi'"):
        view.export(STREET, tmp_path, dpi=3)
    assert not list(tmp_path.iterdir())


SAME_PICTURE = """
import sys
import numpy as np
from citygen.exporters import mjcf, view
from citygen.io import load_scene
scene = load_scene(sys.argv[1])
coarse = view.render_array(scene).astype(float)  # the picture's own level of detail
exported = mjcf.build(scene)  # the MJCF file's
fine = view.render_array(exported).astype(float)
drawn = mjcf.build(scene, resolution=view.picture_resolution(scene, (640, 480)))
pooled = [a.reshape(60, 8, 80, 8, 3).mean(axis=(1, 3)) for a in (coarse, fine)]
ground = (slice(200, 400), slice(150, 500))
print(np.abs(pooled[0] - pooled[1]).mean(), coarse[ground].std(), fine[ground].std(), drawn.nhfielddata,
      exported.nhfielddata)
"""


def test_a_large_scene_is_drawn_from_coarser_ground_that_looks_the_same(tmp_path):
    """A picture samples the ground no finer than its pixels show: far fewer heightfield
    samples for 256 rough tiles, and the same picture: within a grey level on average at
    the scale of 8 x 8 pixels, its rough ground as contrasted (the bumps still show)."""
    import citygen

    scene = citygen.generate("urban-loc-4-test", index=0)
    assert view.picture_resolution(scene, (640, 480)) > 0.1
    assert view.picture_resolution(citygen.load_scene(STREET), (640, 480)) is None  # small: unchanged
    path = tmp_path / "rough.json"
    citygen.save_scene(scene, path)
    done = run(SAME_PICTURE, str(path))
    assert done.returncode == 0, done.stderr[-2000:]
    difference, coarse_std, fine_std, coarse, fine = (float(x) for x in done.stdout.split())
    assert coarse * 4 < fine, (coarse, fine)
    assert difference < 1.0, difference
    assert 0.8 < coarse_std / fine_std < 1.25 and fine_std > 5, (coarse_std, fine_std)


CHUNKED = """
import sys
import numpy as np
from citygen.exporters import mjcf, view
whole = view.render_array(mjcf.build(sys.argv[1]))  # the model parsed in one piece
view.CHUNK = 4  # as if the street were a city: parsed in chunks of 4 geoms, 1 body
chunked = view._compile(mjcf.to_mjcf(sys.argv[1]))
drawn = view.render_array(sys.argv[1]).astype(int)
print(mjcf.build(sys.argv[1]).ngeom, chunked.ngeom, int(np.abs(drawn - whole).max()))
"""


def test_a_scene_parsed_in_chunks_is_the_same_picture(tmp_path):
    """A large scene's model is parsed in chunks (MuJoCo's parse time grows with the square
    of its elements): the same geoms, and the same pixels."""
    done = run(CHUNKED, str(STREET))
    assert done.returncode == 0, done.stderr[-2000:]
    assert "WARNING" not in done.stdout + done.stderr and not (ROOT / "MUJOCO_LOG.TXT").exists()
    whole, chunked, difference = (int(x) for x in done.stdout.split())
    assert whole == chunked > 20 and difference == 0
