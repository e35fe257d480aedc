"""What a runner relies on in an exported MJCF model: the contact bits of static geoms,
agents and a robot's geoms, the names' separator and layers (:func:`geom_labels`), the
model in memory (:class:`MJCF`), its arena size (:func:`arena_mb`), and MuJoCo imported
with a headless renderer (:func:`import_mujoco`). The robots import these from here."""

from __future__ import annotations

import math
import os
import sys
import xml.etree.ElementTree as ET
from collections.abc import Mapping
from ctypes.util import find_library
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

from citygen.errors import DependencyMissing

if TYPE_CHECKING:
    import mujoco

#: ``contype`` of every static geom (ground, terrain, objects); their ``conaffinity`` is 0.
STATIC_BIT = 1
#: The separator of the parts of every name this exporter gives (``object:bench:bench-1:0``).
#: Not ``/``: dm_control's ``mjcf`` reserves that for the scopes of attached models.
SEP = ":"
#: The first part of every geom name: what the geom stands for (``solid``: a zone's solid, a
#: building from its footprint; it stands up from the ground as an object does).
LAYERS = ("zone", "terrain", "object", "agent", "solid")

#: The bit a robot's geoms should set in ``contype``.
ROBOT_BIT = 2
#: ``contype`` of agents' geoms (mocap bodies); their ``conaffinity`` is 0.
AGENT_BIT = 4
#: The ``conaffinity`` a robot's geoms should have: touch the static world and agents.
ROBOT_CONAFFINITY = STATIC_BIT | AGENT_BIT

#: ``<size memory>``: MiB for contacts and constraints, plus bytes a geom (broadphase).
ARENA_BASE_MB, ARENA_PER_GEOM = 32, 4096


@dataclass(frozen=True)
class MJCF:
    """A compiled scene: the XML text and the asset files it names (path relative to the
    XML file -> bytes), ready for ``mujoco.MjModel.from_xml_string(xml, dict(assets))``."""

    xml: str
    assets: Mapping[str, bytes]


@dataclass(frozen=True)
class MJCFTree:
    """A scene's model for a reader in this process (the runner, :func:`to_tree
    <citygen.exporters.mjcf.to_tree>`): its XML as the element tree ``root`` (not indented,
    never written as text), the files it names, and each heightfield's samples (``hfields``:
    name -> float32, MuJoCo's ``userdata`` of it, rows from -y) rather than its ``elevation``
    text, for :func:`~citygen.exporters.mjcf.parse.scene_spec` to set: the same model to the
    byte as :class:`MJCF`'s, without writing and parsing a city's 100 MB of text, 70 of them
    heightfields (``tests/test_mjcf_parse.py``)."""

    root: ET.Element
    assets: Mapping[str, bytes]
    hfields: Mapping[str, Any] = field(default_factory=dict)

    @property
    def xml(self) -> str:
        """The tree as text (not indented; its heightfields without their samples, which
        :attr:`hfields` holds)."""
        return ET.tostring(self.root, encoding="unicode")


def arena_mb(ngeom: int) -> int:
    """The ``<size memory>`` (MiB) of a model with ``ngeom`` geoms: MuJoCo's broadphase
    takes about 700 bytes a geom of the arena at every step on a 62,000-geom city, and
    one ~148 MB block on the 0.3.0 city (115,000 geoms) on top of ~150 MB in use, contacts
    and constraints a few MiB; :data:`ARENA_PER_GEOM` a geom and
    :data:`ARENA_BASE_MB` leave room for a robot's contacts with heightfields."""
    return ARENA_BASE_MB + math.ceil(ngeom * ARENA_PER_GEOM / (1 << 20))


def import_mujoco() -> Any:
    """``import mujoco``, first choosing a headless OpenGL backend for its renderer when
    nobody did: on Linux with ``MUJOCO_GL`` unset and mujoco not yet imported, it is set
    to ``egl`` when libEGL is installed, else to ``osmesa`` when libOSMesa is."""
    if "mujoco" not in sys.modules and not os.environ.get("MUJOCO_GL") and sys.platform.startswith("linux"):
        backend = "egl" if find_library("EGL") else "osmesa" if find_library("OSMesa") else None
        if backend is not None:
            os.environ["MUJOCO_GL"] = backend
    try:
        import mujoco
    except ImportError:
        raise DependencyMissing("mujoco", "compiling MJCF") from None
    return mujoco


def geom_labels(model: mujoco.MjModel) -> list[tuple[str, str, str] | None]:
    """``(layer, class, id)`` of every geom by geom id (``("object", "bench", "bench-1")``),
    parsed from the names this exporter gives; None for a geom it did not name (a robot's).
    A runner maps a contact's ``geom1``/``geom2`` to a semantic class with it."""
    out: list[tuple[str, str, str] | None] = []
    for gid in range(model.ngeom):
        parts = model.geom(gid).name.split(SEP, 2)  # layer, class, "<id>:<k>" (an id may hold a ':')
        if len(parts) == 3 and parts[0] in LAYERS and SEP in parts[2]:
            out.append((parts[0], parts[1], parts[2].rsplit(SEP, 1)[0]))
        else:
            out.append(None)
    return out
