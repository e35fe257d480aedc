"""A perspective picture of a scene as MuJoCo renders it (``<name>-perspective.png``).

The scene is compiled as :func:`citygen.exporters.mjcf.build` does (a large one in chunks,
:func:`_compile`, the same picture sooner) and drawn offscreen by
``mujoco.Renderer`` from one of the model's cameras (``perspective`` or ``top``, see
:mod:`citygen.exporters.mjcf`), so the picture shows exactly what a simulation sees.

Rendering needs OpenGL without a display: MuJoCo picks its backend from ``MUJOCO_GL``
when it is first imported. When that is unset, citygen sets it (on Linux) to ``egl`` if
libEGL is installed, else ``osmesa`` if libOSMesa is (Debian: ``apt-get install libegl1
libegl-mesa0 libgl1-mesa-dri`` or ``libosmesa6``). Where no backend works,
:func:`render_perspective` raises ``RuntimeError("no OpenGL ...")``, which callers turn
into a clean skip message. Set ``MUJOCO_GL`` yourself if mujoco is imported before
citygen chooses.

Level of detail: a picture cannot show ground finer than its pixels, so a scene drawn
without an explicit ``resolution`` gets rough tiles' heightfields sampled about once a pixel
of the scene's larger side (slopes, which are planes, 4 times coarser) where that is
coarser than the MJCF default (:func:`picture_resolution`; a 1.2 km city in 640 x 480 px:
rough tiles every 1.9 m): the same picture, far less to build and upload.

Units: sizes in pixels (width, height).
"""

from __future__ import annotations

import io
from pathlib import Path
from typing import Any

import numpy as np

from citygen.errors import ExportError
from citygen.exporters import as_scene, mjcf
from citygen.io import write_atomic
from citygen.spec.scene import Scene

#: Smallest and largest side (px) of a picture.
MIN_SIDE, MAX_SIDE = 16, 4096
_OPTIONS = ("name", "size", "camera", "resolution", "apron", "mesh_dir")
#: Pixels of the picture's larger side the ``resolution`` a picture is built with spans (see
#: the module docstring): rough tiles are sampled 4 times finer (:mod:`citygen.exporters.mjcf`),
#: about once a pixel.
PIXELS_PER_SAMPLE = 4.0


def picture_resolution(scene: Scene, size: tuple[int, int]) -> float | None:
    """The heightfield ``resolution`` (m) a picture of ``size`` px is built with:
    :data:`PIXELS_PER_SAMPLE` pixels of the scene's (and its terrain grid's) larger side, or
    None (the MJCF default) where a pixel is not larger than ``mjcf.DEFAULT_RESOLUTION``."""
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    t = scene.terrain
    if t is not None:
        x0, y0 = min(x0, t.origin[0]), min(y0, t.origin[1])
        x1, y1 = max(x1, t.origin[0] + t.cols * t.tile_size), max(y1, t.origin[1] + t.rows * t.tile_size)
    pixel = max(x1 - x0, y1 - y0) / max(size)
    return PIXELS_PER_SAMPLE * pixel if pixel > mjcf.DEFAULT_RESOLUTION else None


def _check_size(size: object) -> tuple[int, int]:
    ok = isinstance(size, tuple | list) and len(size) == 2
    ok = ok and all(isinstance(v, int | np.integer) and not isinstance(v, bool) for v in size)
    if not ok or not all(MIN_SIDE <= v <= MAX_SIDE for v in size):
        raise ExportError(
            f"size: expected (width, height) in pixels, each {MIN_SIDE} to {MAX_SIDE}, got {size!r}"
        )
    return int(size[0]), int(size[1])


def _png(pixels: np.ndarray) -> bytes:
    """An RGB image (h, w, 3 uint8) as PNG bytes, without time or software metadata."""
    from PIL import Image

    buf = io.BytesIO()
    Image.fromarray(pixels, mode="RGB").save(buf, format="PNG", optimize=False)
    return buf.getvalue()


#: Most static geoms or bodies :func:`_compile` has MuJoCo parse in one piece (see there).
CHUNK = 4_000


def _compile(mj: mjcf.MJCF) -> Any:
    """The model :func:`citygen.exporters.mjcf.build` compiles, for drawing: the same geoms in
    the same order, drawn the same, but its static geoms and bodies parsed in chunks of
    :data:`CHUNK` and attached under one static body. MuJoCo 4.0 walks the whole tree for
    each element it adds (google-deepmind/mujoco#3397), so a city's 130,000 geoms took
    about 145 s to parse in one piece and take about 25 s in chunks. Raises
    :class:`~citygen.errors.ExportError` if MuJoCo rejects the model."""
    import warnings
    import xml.etree.ElementTree as ET

    mujoco = mjcf.import_mujoco()
    root = ET.fromstring(mj.xml)
    world = root.find("worldbody")
    static = [e for e in world if e.tag == "geom" or (e.tag == "body" and e.get("mocap") is None)]
    try:
        if len(static) <= CHUNK:
            return mujoco.MjModel.from_xml_string(mj.xml, dict(mj.assets))
        for e in static:
            world.remove(e)
        geoms = [e for e in static if e.tag == "geom"]
        bodies = [e for e in static if e.tag == "body"]
        # World geoms come first in a compiled model, then the bodies (in order): keep that.
        groups = [geoms[i : i + CHUNK] for i in range(0, len(geoms), CHUNK)]
        groups += [bodies[i : i + CHUNK // 4] for i in range(0, len(bodies), CHUNK // 4)]
        head = "".join(ET.tostring(e, encoding="unicode") for e in root if e.tag in ("compiler", "default"))
        spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"), dict(mj.assets))
        holder = mujoco.MjSpec.from_string(
            f'<mujoco>{head}<worldbody><body name="{_HOLDER}"/></worldbody></mujoco>'
        )
        top = holder.body(_HOLDER)
        previous = mujoco.get_mju_user_warning()
        # Attached without a prefix, so that the geoms name the model's materials and meshes.
        mujoco.set_mju_user_warning(lambda text: None if _NO_PREFIX in text else (previous or _warn)(text))
        try:
            for k, group in enumerate(groups):
                text = "".join(ET.tostring(e, encoding="unicode") for e in group)
                chunk = mujoco.MjSpec.from_string(
                    f'<mujoco>{head}<worldbody><body name="{_HOLDER}:{k}">{text}</body></worldbody></mujoco>'
                )
                top.add_frame().attach_body(chunk.body(f"{_HOLDER}:{k}"), "", "")
            spec.worldbody.add_frame().attach_body(top, "", "")
        finally:
            mujoco.set_mju_user_warning(previous)
        spec.assets = dict(mj.assets)
        with warnings.catch_warnings():
            warnings.filterwarnings("ignore", message=f".*{_NO_PREFIX}")
            return spec.compile()
    except ValueError as exc:
        raise ExportError(f"MuJoCo rejected the exported model: {exc}") from None


def _warn(text: str) -> None:
    import warnings

    warnings.warn(f"MuJoCo: {text}", RuntimeWarning, stacklevel=2)


_HOLDER = "citygen:picture:static"
_NO_PREFIX = "with an empty prefix"


def render_array(
    scene_or_model: Any, *, size: tuple[int, int] = (640, 480), camera: str = "perspective", **options: object
) -> np.ndarray:
    """The picture as an ``(height, width, 3)`` uint8 array (see :func:`render_perspective`)."""
    width, height = _check_size(size)
    mujoco = mjcf.import_mujoco()
    if isinstance(scene_or_model, mujoco.MjModel):
        model = scene_or_model
        if options:
            raise ExportError(f"options {sorted(options)} apply to scenes, not to a compiled model")
    else:
        if options.get("resolution") is None:
            scene, folder = as_scene(scene_or_model)
            coarser = picture_resolution(scene, (width, height))
            if coarser is not None:  # the scene as loaded here, not read a second time
                options["resolution"] = coarser
                if options.get("mesh_dir") is None and folder is not None:
                    options["mesh_dir"] = folder
                scene_or_model = scene
        model = _compile(mjcf.to_mjcf(scene_or_model, **options))
    try:
        cam = model.camera(camera).id
    except KeyError:
        names = [model.camera(i).name for i in range(model.ncam)]
        raise ExportError(f"camera: expected one of {names}, got {camera!r}") from None
    # The offscreen buffer must hold the picture; a larger one costs nothing when unused.
    vis = model.vis.global_
    vis.offwidth, vis.offheight = max(vis.offwidth, width), max(vis.offheight, height)
    try:
        # Room for every geom (a city has more than the default 10,000; MuJoCo would print a
        # warning and leave the rest out of the picture).
        renderer = mujoco.Renderer(model, height=height, width=width, max_geom=max(10_000, 2 * model.ngeom))
    except Exception as exc:  # the GL backends raise many types (ImportError, EGL errors ...)
        import os

        backend = os.environ.get("MUJOCO_GL", "unset")
        reason = (str(exc).strip().splitlines() or [""])[0]
        raise RuntimeError(
            f"no OpenGL for offscreen rendering (MUJOCO_GL={backend}): {type(exc).__name__}: {reason}; "
            "install EGL (apt-get install libegl1 libegl-mesa0 libgl1-mesa-dri) or OSMesa (libosmesa6) "
            "and set MUJOCO_GL=egl or osmesa before importing mujoco"
        ) from exc
    try:
        data = mujoco.MjData(model)
        mujoco.mj_forward(model, data)
        renderer.update_scene(data, camera=cam)
        return renderer.render().copy()
    finally:
        renderer.close()


def render_perspective(
    scene_or_model: Any,
    path: str | Path,
    *,
    size: tuple[int, int] = (640, 480),
    camera: str = "perspective",
    **options: object,
) -> Path:
    """Render a scene (a :class:`~citygen.spec.Scene`, a scene file's path, or a compiled
    ``mujoco.MjModel`` from :mod:`~citygen.exporters.mjcf`) from one of its cameras and
    write a PNG to ``path`` (atomically); returns ``path``.

    ``size`` is ``(width, height)`` in pixels; ``camera`` names a camera of the model
    (``perspective`` or ``top``); other options go to :func:`citygen.exporters.mjcf.to_mjcf`.
    A model given here gets its offscreen buffer enlarged to ``size`` if it is smaller.
    Raises ``RuntimeError("no OpenGL ...")`` where nothing can render offscreen.
    """
    path = Path(path)
    if path.suffix.lower() != ".png":
        raise ExportError(f"{path}: expected a path ending in .png, got {path.suffix or 'no suffix'!r}")
    pixels = render_array(scene_or_model, size=size, camera=camera, **options)
    try:
        write_atomic(path, _png(pixels))
    except OSError as exc:
        raise ExportError(f"{path}: cannot write the picture: {exc.strerror or type(exc).__name__}") from None
    return path


def export(scene: Scene | str | Path, out_dir: str | Path, **options: object) -> list[Path]:
    """Write ``<out_dir>/<name>-perspective.png``; returns ``[that path]``.

    Options: ``name`` (as :func:`citygen.exporters.mjcf.scene_name`), ``size``,
    ``camera``, and the MJCF options ``resolution``, ``apron``, ``mesh_dir``.
    """
    unknown = sorted(set(options) - set(_OPTIONS))
    if unknown:
        raise ExportError(
            f"view export: unknown option {unknown[0]!r}; expected one of {', '.join(_OPTIONS)}"
        )
    name = mjcf.scene_name(scene, options.pop("name", None))
    return [render_perspective(scene, Path(out_dir) / f"{name}-perspective.png", **options)]
