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

Attaching also costs the assets already in the model it attaches to (a city's 38,000 meshes
and 1,400 heightfields: half the 12 s of CPU its 30 attachments took), so the assets are read
last, on their own spec attached after the worldbody's chunks: the same assets in the same
order, the same model to the byte.

With ``frames=True`` (what the runner asks for a town or a city, which it compiles with
MuJoCo's ``fusestatic``), each static body of the worldbody that holds only geoms is read as a
``<frame>`` of the same pose and class instead (:func:`static_frames`): its geoms are the
world's from the start, placed by the same arithmetic as fusing places them (``mjCFrame``'s
``mjuu_frameaccumChild`` is ``FuseStatic``'s ``changeframe``), so the compiled model is the
fused one to the byte, without ``FuseStatic``'s cost: it re-indexes every geom and rebuilds
the world's bounding volume hierarchy once per body it fuses, 17 of the 21 s of CPU a city's
compile took (7,900 bodies, 118,000 geoms).
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from collections.abc import Iterator
from typing import Any

from citygen.exporters.mjcf.contract import MJCF, MJCFTree, import_mujoco

#: Elements (geoms, bodies, ...) of a model parsed in one piece; a bigger model's worldbody
#: is parsed in chunks of about this many. Parsing a chunk costs its size squared (6,000
#: elements: 0.05 s), attaching it about 8 us an element plus the model's size so far (some
#: 2.6 us an element): on a city's 126,000 elements (its bodies read as frames, its assets
#: attached last) chunks of 4,000 took 7.8 s of CPU, 6,000 7.4-7.7 s, 8,000 7.7 s, 12,000 8.5 s.
CHUNK_ELEMENTS = 6000
#: The sections a chunk repeats from the model: what the parser applies to an element as it
#: reads it (angles' unit, default classes). Assets, options and the rest are the model's.
_SHARED = ("compiler", "default")
#: What MuJoCo says of an empty prefix (names could clash with the parent's): the chunks'
#: names are the model's own, unique there.
_EMPTY_PREFIX = "Attaching a spec with an empty prefix"


def elements(mjcf: MJCF | MJCFTree, tag: str) -> int:
    """How many ``tag`` elements (``"geom"``, ``"body"``) the model has: counted in its text,
    or in its tree (MjSpec.geoms wraps every element in Python: minutes for a city)."""
    if isinstance(mjcf, MJCFTree):
        return sum(1 for _ in mjcf.root.iter(tag))
    return mjcf.xml.count(f"<{tag} ")


def scene_spec(mjcf: MJCF | MJCFTree, chunk: int = CHUNK_ELEMENTS, frames: bool = False) -> Any:
    """``mujoco.MjSpec.from_string(mjcf.xml, assets=...)``, in chunks of ``chunk`` elements
    when the model has more, its static bodies read as frames if ``frames`` (see the module
    docstring: for a model compiled with ``fusestatic``). Raises ValueError as MuJoCo does.
    An :class:`~citygen.exporters.mjcf.contract.MJCFTree` is read from its tree (which
    this changes), not parsed from text."""
    mujoco = import_mujoco()
    assets = dict(mjcf.assets)
    tree = isinstance(mjcf, MJCFTree)
    hfields = mjcf.hfields if tree else {}
    small = elements(mjcf, "geom") + elements(mjcf, "body") <= chunk
    if small and not frames:
        return _filled(mujoco.MjSpec.from_string(mjcf.xml, assets=assets), hfields)
    root = _shallow(mjcf.root) if tree else ET.fromstring(mjcf.xml)
    world = root.find("worldbody")
    if world is None or len(world.attrib):
        return _filled(mujoco.MjSpec.from_string(mjcf.xml, assets=assets), hfields)
    if frames:
        static_frames(root)
    if small:
        text = ET.tostring(root, encoding="unicode")
        return _filled(mujoco.MjSpec.from_string(text, assets=assets), hfields)
    children = list(world)
    del world[:]
    name = root.get("model", "scene")
    shared = [el for el in root if el.tag in _SHARED]
    own = root.find("asset")  # read last (see the module docstring)
    if own is not None:
        root.remove(own)
    spec = mujoco.MjSpec.from_string(ET.tostring(root, encoding="unicode"))
    previous = mujoco.get_mju_user_warning()
    mujoco.set_mju_user_warning(_quiet)
    try:
        for group in _chunks(children, chunk):
            part = ET.Element("mujoco", model=name)
            part.extend(shared)
            ET.SubElement(part, "worldbody").extend(group)
            piece = mujoco.MjSpec.from_string(ET.tostring(part, encoding="unicode"))
            spec.attach(piece, prefix="", frame=spec.worldbody.add_frame())
        if own is not None:
            part = ET.Element("mujoco", model=name)
            part.extend(shared)
            part.append(own)
            piece = mujoco.MjSpec.from_string(ET.tostring(part, encoding="unicode"), assets=assets)
            spec.attach(_filled(piece, hfields), prefix="", frame=spec.worldbody.add_frame())
    finally:
        mujoco.set_mju_user_warning(previous)
    return spec


#: A body's attributes a ``<frame>`` has too (its name is dropped, as fusing drops it).
_FRAME_ATTRIBUTES = frozenset({"name", "childclass", "pos", "quat", "axisangle", "xyaxes", "zaxis", "euler"})
#: Sections whose elements may name a body: a model with any is left as it is.
_REFERRING = ("contact", "equality", "tendon", "actuator", "sensor")


def static_frames(root: ET.Element) -> int:
    """Turn each static body of ``root``'s worldbody that MuJoCo's ``fusestatic`` would fuse
    into the world, and that holds geoms only (no joint, not mocap, no child body, site,
    camera or light), into a ``<frame>`` with its pose and child class; the number turned.

    The frames go after the worldbody's last geom, in their order: fusing appends a body's
    geoms to the world's, after the world's own, so the geoms keep the fused model's order.
    Nothing changes in a model with sections that could name a body (:data:`_REFERRING`)."""
    world = root.find("worldbody")
    if world is None or any(root.find(tag) is not None for tag in _REFERRING):
        return 0
    children = list(world)
    turned = [
        child
        for child in children
        if child.tag == "body"
        and set(child.attrib) <= _FRAME_ATTRIBUTES
        and len(child)
        and all(el.tag == "geom" for el in child)
    ]
    if not turned:
        return 0
    for body in turned:
        body.tag = "frame"
        body.attrib.pop("name", None)
    keep = {id(el) for el in turned}
    last = max((k for k, el in enumerate(children) if el.tag == "geom"), default=-1)
    if any(k < last for k, el in enumerate(children) if id(el) in keep):
        rest = [el for el in children if id(el) not in keep]
        at = rest.index(children[last]) + 1
        del world[:]
        world.extend(rest[:at] + turned + rest[at:])
    return len(turned)


def _filled(spec: Any, hfields: Any) -> Any:
    """``spec`` with the samples of its heightfields named in ``hfields`` set (an
    :class:`~citygen.exporters.mjcf.contract.MJCFTree`'s, as the text's parse sets them)."""
    if hfields:
        for hfield in spec.hfields:
            data = hfields.get(hfield.name)
            if data is not None:
                hfield.userdata = memoryview(data)  # a buffer: 3 times faster than an array
    return spec


def _shallow(root: ET.Element) -> ET.Element:
    """A copy of ``root`` that :func:`scene_spec` may change: new elements for the root, its
    worldbody and the worldbody's bodies (what :func:`static_frames` and the chunks change),
    sharing every other element with ``root``, which stays as it was."""
    out = ET.Element(root.tag, dict(root.attrib))
    for child in root:
        if child.tag == "worldbody":
            world = ET.SubElement(out, child.tag, dict(child.attrib))
            world.extend(_copy(el) if el.tag == "body" else el for el in child)
        else:
            out.append(child)
    return out


def _copy(el: ET.Element) -> ET.Element:
    """``el`` alone copied: its tag and attributes; its children shared."""
    out = ET.Element(el.tag, dict(el.attrib))
    out.text, out.tail = el.text, el.tail
    out.extend(el)
    return out


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
