"""A scene's MJCF into a ``mujoco.MjSpec`` in time linear in its size (:func:`scene_spec`).

MuJoCo's parser is quadratic in a model's elements: every geom or body it adds rebuilds the
model's lists of all the elements so far (``mjCModel::ResetTreeLists`` and
``MakeTreeLists``). For an Urban-Nav square that is nothing; for a 1.2 km city (118,000
geoms) it took minutes of a reset on the 2-core machine (20,000 geoms parse in 7 s, 118,000
in some 240 s). :func:`scene_spec` parses a big model's worldbody in chunks of about
:data:`CHUNK_ELEMENTS` elements, each a small spec of its own with the model's compiler
settings and default classes, and attaches them in order, each to an identity frame of the
worldbody, with an empty prefix so that every name stays as written. Attaching keeps the
order of bodies and geoms, and an identity frame changes no pose, so the compiled model is
the same to the byte (``mj_saveModel``) as the one-piece parse
(``tests/test_mjcf_parse.py``).
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from typing import Any

from citygen.exporters.mjcf.contract import MJCF, import_mujoco

#: Elements (geoms, bodies, ...) of a model parsed in one piece; a bigger model's worldbody
#: is parsed in chunks of about this many. Parsing a chunk, and attaching it, costs more than
#: its size times a constant (16,000 world geoms: 0.8 s to attach, 4,000: 0.013 s), and every
#: attachment costs the model's size so far (60,000 geoms: 0.1 s): on 118,000 geoms chunks of
#: 1,000 took 12 s of CPU, 4,000 some 5 s, 16,000 11 s.
CHUNK_ELEMENTS = 4000
#: The sections a chunk repeats from the model: what the parser applies to an element as it
#: reads it (angles' unit, default classes). Assets, options and the rest are the model's.
_SHARED = ("compiler", "default")
#: What MuJoCo says of an empty prefix (names could clash with the parent's): the chunks'
#: names are the model's own, unique there.
_EMPTY_PREFIX = "Attaching a spec with an empty prefix"


def scene_spec(mjcf: MJCF, chunk: int = CHUNK_ELEMENTS) -> Any:
    """``mujoco.MjSpec.from_string(mjcf.xml, assets=...)``, in chunks of ``chunk`` elements
    when the model has more (see the module docstring). Raises ValueError as MuJoCo does."""
    mujoco = import_mujoco()
    assets = dict(mjcf.assets)
    if mjcf.xml.count("<geom ") + mjcf.xml.count("<body ") <= chunk:
        return mujoco.MjSpec.from_string(mjcf.xml, assets=assets)
    root = ET.fromstring(mjcf.xml)
    world = root.find("worldbody")
    if world is None or len(world.attrib):
        return mujoco.MjSpec.from_string(mjcf.xml, assets=assets)
    children = list(world)
    for child in children:
        world.remove(child)
    spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"), assets=assets)
    shared = [el for el in root if el.tag in _SHARED]
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(_quiet)
    try:
        for group in _chunks(children, chunk):
            part = ET.Element("mujoco", model=root.get("model", "scene"))
            part.extend(shared)
            ET.SubElement(part, "worldbody").extend(group)
            piece = mujoco.MjSpec.from_string(ET.tostring(part, encoding="unicode"))
            spec.attach(piece, prefix="", frame=spec.worldbody.add_frame())
    finally:
        mujoco.set_mju_user_warning(previous)
    return spec


def compile_spec(spec: Any) -> Any:
    """``spec.compile()`` without MuJoCo's note on :func:`scene_spec`'s empty prefixes."""
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", message=_EMPTY_PREFIX)
        return spec.compile()


def _quiet(message: str) -> None:
    """MuJoCo's warnings while chunks are attached: the empty prefix's is expected; any other
    is passed on as a Python warning (MuJoCo's default handler writes a log file)."""
    if _EMPTY_PREFIX not in message:
        warnings.warn(f"MuJoCo: {message}", stacklevel=2)


def _chunks(children: list[ET.Element], size: int) -> Iterator[list[ET.Element]]:
    """The worldbody's children in order, in groups of about ``size`` elements (a body with
    everything in it counts whole: a body is never split)."""
    group: list[ET.Element] = []
    count = 0
    for child in children:
        group.append(child)
        count += sum(1 for _ in child.iter())
        if count >= size:
            yield group
            group, count = [], 0
    if group:
        yield group
