"""Hypothesis strategies for scene documents, scenes and mutated documents.

- :func:`documents` draws plain JSON data (dicts, lists, str, int, float, None) that is a
  valid scene *in shape*: every top-level key, every block, zone, tile, agent and task
  kind, optional keys present, absent or ``null``. Floats are arbitrary finite values
  inside each field's declared bounds (before quantisation: values needing rounding,
  ``-0.0``, values a hair inside a bound, huge coordinates), sometimes written as JSON
  integers, and integer fields are sometimes written as whole floats (``3.0``).
  Semantic validity (non-overlap, tile counts ...) is not attempted.
- :func:`scenes` is the same documents validated into :class:`citygen.spec.Scene`.
- :func:`mutations` applies one random change to a document at a random node (which may
  or may not keep it valid); :func:`mutated_documents` is ``documents()`` mutated once.

NaN and infinities are never drawn: :func:`citygen.io.read_json` rejects them before any
model sees them.
"""

from __future__ import annotations

import copy
import json
import math
import types
from dataclasses import dataclass
from functools import cache
from typing import Annotated, Any, Union, get_args, get_origin

import annotated_types as at
from hypothesis import note
from hypothesis import strategies as st
from pydantic import BaseModel
from pydantic.fields import FieldInfo

from citygen.errors import SpecError
from citygen.io import parse
from citygen.spec import (
    Curve,
    Diverge,
    FlatTile,
    Intersection,
    JunctionArm,
    Merge,
    NavTask,
    Person,
    Placement,
    Pose2,
    RoughTile,
    Roundabout,
    Scene,
    SlopeTile,
    StairTile,
    Straight,
    Terrain,
    TIntersection,
    TraverseTask,
    Vehicle,
    Zone,
)
from citygen.spec.scene import Meta
from citygen.spec.surfaces import MATERIALS, ZONE_KINDS

SCENE_FORMAT = "citygen.scene/1"

# --- numbers ---------------------------------------------------------------------


@dataclass(frozen=True)
class Bound:
    """The declared range of a numeric field: ``lo <= x <= hi`` (``<`` where open)."""

    lo: float
    hi: float
    lo_open: bool = False
    hi_open: bool = False
    integer: bool = False

    def __contains__(self, x: float) -> bool:
        above = self.lo < x if self.lo_open else self.lo <= x
        below = x < self.hi if self.hi_open else x <= self.hi
        return above and below


def _constraint_parts(field: FieldInfo) -> list[Any]:
    """The numeric type and ``annotated_types`` bounds of a field, through ``Annotated``
    aliases, nested ``Field(...)`` and ``X | None``."""
    found: list[Any] = []
    stack: list[Any] = [field]
    while stack:
        node = stack.pop()
        if isinstance(node, FieldInfo):
            stack.extend(node.metadata)
            stack.append(node.annotation)
        elif isinstance(node, at.Ge | at.Gt | at.Le | at.Lt | at.Interval):
            found.append(node)
        elif get_origin(node) is Annotated or get_origin(node) in (Union, types.UnionType):
            stack.extend(get_args(node))
        elif node in (int, float):
            found.append(node)
    return found


def bound_of(model: type[BaseModel], name: str) -> Bound:
    """The bounds the model declares for its numeric field ``name`` (read from the model, so
    the strategies follow the spec when a bound changes)."""
    lo, hi, lo_open, hi_open, integer = -math.inf, math.inf, False, False, False
    for part in _constraint_parts(model.model_fields[name]):
        if part is int:
            integer = True
        for attr in ("ge", "gt"):
            if getattr(part, attr, None) is not None:
                lo, lo_open = getattr(part, attr), attr == "gt"
        for attr in ("le", "lt"):
            if getattr(part, attr, None) is not None:
                hi, hi_open = getattr(part, attr), attr == "lt"
    if not (math.isfinite(lo) and math.isfinite(hi)):
        raise ValueError(f"{model.__name__}.{name} has no finite bounds")
    return Bound(lo, hi, lo_open, hi_open, integer)


def _models(root: Any, seen: dict[str, type[BaseModel]] | None = None) -> list[type[BaseModel]]:
    """Every model class reachable from ``root`` through its fields' annotations."""
    seen = {} if seen is None else seen
    if isinstance(root, type) and issubclass(root, BaseModel):
        if root.__qualname__ in seen:
            return list(seen.values())
        seen[root.__qualname__] = root
        for field in root.model_fields.values():
            _models(field.annotation, seen)
    else:
        for arg in get_args(root):
            _models(arg, seen)
    return list(seen.values())


def declared_bounds(root: type[BaseModel]) -> list[tuple[str, Bound]]:
    """``("Model.field", bound)`` for every bounded numeric field reachable from ``root``."""
    out = []
    for model in _models(root):
        for name, field in model.model_fields.items():
            if any(isinstance(p, at.BaseMetadata) for p in _constraint_parts(field)):
                out.append((f"{model.__name__}.{name}", bound_of(model, name)))
    return out


def _bounds_by_name(root: type[BaseModel]) -> dict[str, tuple[Bound, ...]]:
    out: dict[str, set[Bound]] = {}
    for where, bound in declared_bounds(root):
        out.setdefault(where.rpartition(".")[2], set()).add(bound)
    return {k: tuple(sorted(v, key=repr)) for k, v in sorted(out.items())}


#: Every bound a numeric field of a given name has in some scene model (names are shared:
#: ``speed``, ``radius``, ``length`` ...). Mutations push numbers just outside (or onto)
#: one of them.
BOUNDS_BY_NAME: dict[str, tuple[Bound, ...]] = _bounds_by_name(Scene)

_TINY = (5e-324, 1e-9, 1e-5, 4e-5, 4.9999e-5, 5e-5, 5.0001e-5, 6e-5, 1e-4)
"""Offsets from a bound: below, at and above half a quantisation step (0.5e-4)."""


@cache
def finite_floats() -> st.SearchStrategy[float]:
    """Any finite float, huge magnitudes and ``-0.0`` included (unbounded coordinates)."""
    return st.one_of(
        st.floats(allow_nan=False, allow_infinity=False),
        st.floats(-1e4, 1e4, allow_nan=False),
        st.integers(-(10**6), 10**6),  # JSON integers are numbers too
    )


@cache
def number(bound: Bound) -> st.SearchStrategy[float | int]:
    """A JSON number inside ``bound``: arbitrary, hugging a bound, 4-decimal, or integral."""
    lo, hi = bound.lo, bound.hi
    if bound.integer:
        low = math.floor(lo) + 1 if bound.lo_open else math.ceil(lo)
        high = math.ceil(hi) - 1 if bound.hi_open else math.floor(hi)
        return st.one_of(
            st.integers(low, high),
            st.integers(low, min(high, 2**53)).map(float),  # 3.0 is an integer too
            st.sampled_from([low, high]),
        )
    near = [lo, hi, *(lo + d for d in _TINY), *(hi - d for d in _TINY)]
    whole = range(math.ceil(lo), math.floor(hi) + 1)
    return st.one_of(
        st.floats(lo, hi, exclude_min=bound.lo_open, exclude_max=bound.hi_open),
        st.sampled_from([x for x in near if x in bound]),
        st.integers(math.ceil(lo * 10**4), math.floor(hi * 10**4))
        .map(lambda n: n / 10**4)
        .filter(lambda x: x in bound),
        st.sampled_from([*whole[:3], *whole[-3:]] or [hi]).filter(lambda x: x in bound),
    )


@cache
def vec2() -> st.SearchStrategy[list[Any]]:
    return st.lists(finite_floats(), min_size=2, max_size=2)


@cache
def vec3() -> st.SearchStrategy[list[Any]]:
    return st.lists(finite_floats(), min_size=3, max_size=3)


# --- strings ---------------------------------------------------------------------

_ID_FIRST = "abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_"
_ID_REST = _ID_FIRST + ".:-"

_TEXT_CHARS = st.characters(exclude_categories=("Cs",))  # no lone surrogates


@cache
def identifiers() -> st.SearchStrategy[str]:
    """Identifiers: ``[A-Za-z0-9_][A-Za-z0-9_.:-]*``, 1 to 64 characters."""
    return st.one_of(
        st.builds(
            lambda a, b: a + b,
            st.sampled_from(_ID_FIRST),
            st.text(st.sampled_from(_ID_REST), max_size=12),
        ),
        st.sampled_from(["a", "road-0", "ped.1", "x:y", "_", "9" * 64]),
    )


@cache
def text(max_size: int) -> st.SearchStrategy[str]:
    return st.one_of(
        st.text(_TEXT_CHARS, max_size=min(max_size, 20)),
        st.just(max_size).map(lambda n: "é" * n),  # the longest allowed, not ASCII
    )


_MESH_CHARS = st.characters(exclude_categories=("Cs",), exclude_characters='\\:*?"<>|')


@cache
def asset_refs() -> st.SearchStrategy[str]:
    """Catalog ids (``bench/0012``) and relative mesh paths (``meshes/a.obj``)."""
    catalog = st.builds(
        lambda cat, n: f"{cat}/{n:04d}",
        st.from_regex(r"[a-z][a-z0-9_]{0,10}", fullmatch=True),
        st.integers(0, 9999),
    )
    mesh = st.builds(
        lambda stem, ext: f"{stem}.{ext}",
        st.text(_MESH_CHARS, min_size=1, max_size=16),
        st.sampled_from(["obj", "stl", "ply", "glb", "gltf", "off"]),
    )
    fixed = st.sampled_from(["bench/0012", "meshes/a.obj", "trash_bin/0007", "kiosk v2.glb"])
    return st.one_of(catalog, mesh, fixed)


# --- objects ---------------------------------------------------------------------


def _maybe_null(strategy: st.SearchStrategy[Any]) -> st.SearchStrategy[Any]:
    """An optional field that defaults to ``None``: a value, or an explicit ``null``."""
    return st.one_of(st.none(), strategy, strategy)


def _obj(required: dict[str, Any], optional: dict[str, Any] | None = None) -> st.SearchStrategy:
    return st.fixed_dictionaries(
        {k: v if isinstance(v, st.SearchStrategy) else st.just(v) for k, v in required.items()},
        optional=optional or {},
    )


def _few(strategy: st.SearchStrategy[Any], min_size: int = 0, max_size: int = 3):
    return st.lists(strategy, min_size=min_size, max_size=max_size)


@cache
def poses() -> st.SearchStrategy[dict[str, Any]]:
    return _obj({"position": vec2()}, {"yaw": number(bound_of(Pose2, "yaw"))})


@cache
def sockets() -> st.SearchStrategy[dict[str, Any]]:
    return _obj({"id": identifiers(), "pose": poses()})


@cache
def connections() -> st.SearchStrategy[dict[str, Any]]:
    return _obj({"socket": identifiers(), "block": identifiers(), "to_socket": identifiers()})


def _numbers(model: type[BaseModel], *names: str) -> dict[str, Any]:
    return {name: number(bound_of(model, name)) for name in names}


_BLOCK_FIELDS: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {
    "straight": (_numbers(Straight, "length"), {}),
    "curve": (_numbers(Curve, "radius", "angle"), {}),
    "roundabout": (_numbers(Roundabout, "radius"), _numbers(Roundabout, "arms")),
    "diverge": (_numbers(Diverge, "length", "branch_angle"), _numbers(Diverge, "branch_lanes")),
    "merge": (_numbers(Merge, "length", "branch_angle"), _numbers(Merge, "branch_lanes")),
    "intersection": (_numbers(Intersection, "arm_length"), _numbers(Intersection, "corner_radius")),
    "t_intersection": (
        _numbers(TIntersection, "arm_length"),
        {**_numbers(TIntersection, "corner_radius"), "side": st.sampled_from(["left", "right"])},
    ),
}
_JUNCTION_ARM = st.fixed_dictionaries(
    {"yaw": number(bound_of(JunctionArm, "yaw")), "length": number(bound_of(JunctionArm, "length"))},
    optional={
        "lanes": number(bound_of(JunctionArm, "lanes")),
        "lane_width": number(bound_of(JunctionArm, "lane_width")),
    },
)
_BLOCK_FIELDS["junction"] = (
    {
        "centre": vec2(),
        "arms": st.lists(_JUNCTION_ARM, min_size=3, max_size=4),
        "polygon": st.lists(vec2(), min_size=3, max_size=4),
    },
    {},
)
BLOCK_KINDS = tuple(_BLOCK_FIELDS)


@cache
def blocks(kind: str | None = None) -> st.SearchStrategy[dict[str, Any]]:
    """A road block of ``kind`` (any kind when ``None``)."""
    if kind is None:
        return st.sampled_from(BLOCK_KINDS).flatmap(blocks)
    required, optional = _BLOCK_FIELDS[kind]
    return _obj(
        {"id": identifiers(), "kind": kind, "pose": poses(), **required},
        {
            "lanes": number(bound_of(Straight, "lanes")),
            "lane_width": number(bound_of(Straight, "lane_width")),
            "sockets": _few(sockets(), max_size=2),
            "connections": _few(connections(), max_size=1),
            **optional,
        },
    )


@cache
def zones() -> st.SearchStrategy[dict[str, Any]]:
    return _obj(
        {
            "id": identifiers(),
            "kind": st.sampled_from(ZONE_KINDS),
            "polygon": st.lists(vec2(), min_size=3, max_size=4),
        },
        {
            "holes": _few(st.lists(vec2(), max_size=3), max_size=1),
            "material": _maybe_null(st.sampled_from(MATERIALS)),
            "friction": _maybe_null(number(bound_of(Zone, "friction"))),
            "strip": _maybe_null(st.sampled_from(["frontage", "clear", "furnishing"])),
        },
    )


_DIRECTIONS = st.sampled_from(["+x", "+y", "-x", "-y"])
_TILE_FIELDS: dict[str, tuple[dict[str, Any], dict[str, Any]]] = {
    "flat": ({}, {}),
    "slope": (_numbers(SlopeTile, "angle"), {"ascent": _DIRECTIONS}),
    "stair": (_numbers(StairTile, "step_height", "step_count"), {"ascent": _DIRECTIONS}),
    "rough": (_numbers(RoughTile, "amplitude", "scale"), _numbers(RoughTile, "seed")),
}
TILE_KINDS = tuple(_TILE_FIELDS)


@cache
def tiles(kind: str | None = None) -> st.SearchStrategy[dict[str, Any]]:
    """A terrain tile of ``kind`` (any of the four when ``None``)."""
    if kind is None:
        return st.sampled_from(TILE_KINDS).flatmap(tiles)
    required, optional = _TILE_FIELDS[kind]
    return _obj(
        {"kind": kind, **required},
        {
            "height": number(bound_of(FlatTile, "height")),
            "material": _maybe_null(st.sampled_from(MATERIALS)),
            "friction": _maybe_null(number(bound_of(FlatTile, "friction"))),
            **optional,
        },
    )


@cache
def terrains() -> st.SearchStrategy[dict[str, Any]]:
    return _terrains()


@st.composite
def _terrains(draw: st.DrawFn) -> dict[str, Any]:
    """A grid of ``rows * cols`` tiles (up to 3 x 3); ``rows``/``cols`` sometimes as ``2.0``."""
    rows, cols = draw(st.integers(1, 2)), draw(st.integers(1, 3))
    return {
        "origin": draw(vec2()),
        "tile_size": draw(number(bound_of(Terrain, "tile_size"))),
        "rows": draw(st.sampled_from([rows, float(rows)])),
        "cols": draw(st.sampled_from([cols, float(cols)])),
        "tiles": draw(st.lists(tiles(), min_size=rows * cols, max_size=rows * cols)),
    }


@cache
def placements() -> st.SearchStrategy[dict[str, Any]]:
    return _obj(
        {"id": identifiers(), "asset": asset_refs(), "position": vec3()},
        _numbers(Placement, "yaw", "scale"),
    )


@cache
def people() -> st.SearchStrategy[dict[str, Any]]:
    return _obj(
        {
            "id": identifiers(),
            "kind": st.sampled_from(["pedestrian", "cyclist", "scooter"]),
            "start": vec2(),
            "goal": vec2(),
        },
        _numbers(Person, "radius", "speed"),
    )


@cache
def vehicles() -> st.SearchStrategy[dict[str, Any]]:
    return _obj(
        {"id": identifiers(), "kind": "vehicle", "start": vec2(), "goal": vec2()},
        {
            **_numbers(Vehicle, "length", "width", "speed"),
            "route": _few(identifiers()),
        },
    )


@cache
def agents() -> st.SearchStrategy[dict[str, Any]]:
    return st.one_of(people(), vehicles())


_ROBOTS = st.sampled_from(["wheeled", "quadruped", "wheeled_legged", "humanoid", "wheelchair"])


@cache
def tasks() -> st.SearchStrategy[dict[str, Any]]:
    common = {"start": poses(), **_numbers(NavTask, "time_limit")}
    nav = _obj(
        {"kind": st.sampled_from(["nav-clear", "nav-static", "nav-dynamic"]), "goal": vec2(), **common},
        {"robot": _ROBOTS, **_numbers(NavTask, "goal_tolerance")},
    )
    loco = _obj(
        {"kind": st.sampled_from(["loco-flat", "loco-slope", "loco-stair", "loco-rough"]), **common},
        {"robot": _ROBOTS, "command": vec3()},
    )
    traverse = _obj(
        {"kind": "traverse", "route": _few(vec2(), min_size=1, max_size=4), **common},
        {"robot": _ROBOTS, **_numbers(TraverseTask, "goal_tolerance")},
    )
    return st.one_of(nav, loco, traverse)


@cache
def metas() -> st.SearchStrategy[dict[str, Any]]:
    return _obj(
        {},
        {
            "generator": _maybe_null(text(200)),
            "split": _maybe_null(identifiers()),
            "index": _maybe_null(number(bound_of(Meta, "index"))),
            "seed": _maybe_null(number(bound_of(Meta, "seed"))),
            "description": _maybe_null(text(10_000)),
        },
    )


@cache
def documents() -> st.SearchStrategy[dict[str, Any]]:
    """Scene documents as plain JSON data, valid in shape (not necessarily in meaning)."""
    return _obj(
        {
            "format": SCENE_FORMAT,
            "bounds": _obj({"min": vec2(), "max": vec2()}),
        },
        {
            "$schema": _maybe_null(
                st.sampled_from(["../schemas/scene.schema.json", "https://example.org/s.json"])
            ),
            "meta": metas(),
            "blocks": _few(blocks(), max_size=4),
            "zones": _few(zones(), max_size=4),
            "terrain": _maybe_null(terrains()),
            "placements": _few(placements(), max_size=4),
            "agents": _few(agents(), max_size=4),
            "task": _maybe_null(tasks()),
        },
    )


def to_scene(document: dict[str, Any]) -> Scene:
    """Validate a document drawn by :func:`documents`; it is valid by construction."""
    try:
        return parse(Scene, document)
    except SpecError as exc:
        raise AssertionError(
            "pydantic rejected a document whose every number lies within the field's declared "
            f"bounds:\n{exc}\ndocument: {json.dumps(document)}"
        ) from None


@cache
def scenes() -> st.SearchStrategy[Scene]:
    """:class:`Scene` models, valid in shape, through every top-level key and kind."""
    return documents().map(to_scene)


# --- mutations -------------------------------------------------------------------

Slot = tuple[Any, Any, str]
"""A place in a document: (container, key or index, JSON path)."""


def _slots(node: Any, path: str = "$") -> list[Slot]:
    out: list[Slot] = []
    items = node.items() if isinstance(node, dict) else enumerate(node) if isinstance(node, list) else ()
    for key, value in items:
        where = f"{path}.{key}" if isinstance(key, str) else f"{path}[{key}]"
        out.append((node, key, where))
        out.extend(_slots(value, where))
    return out


def _containers(node: Any, path: str = "$") -> list[tuple[Any, str]]:
    out = [(node, path)] if isinstance(node, dict | list) else []
    for parent, key, where in _slots(node, path):
        if isinstance(parent[key], dict | list):
            out.append((parent[key], where))
    return out


def _is_number(value: Any) -> bool:
    return isinstance(value, int | float) and not isinstance(value, bool)


_UNKNOWN_KEYS = ["extra", "Kind", "colour", "schema_", "$comment", "format2", "id ", "x"]

_KIND_TYPOS = [
    "",
    " ",
    "Straight",
    "STAIR",
    "stairs",
    "t-intersection",
    "nav_static",
    "navclear",
    "pedestrians",
    "car",
    "slopee",
    "flat ",
    " rough",
    "loco",
    "traverse-",
    "vegetation",
    "vehicle",
    "flat",
    "straight",
    "pedestrian",
    "nav-clear",
    "sidewalk",
]

_FORMATS = [
    "citygen.scene/2",
    "citygen.scene/0",
    "citygen.scene/1 ",
    "Citygen.scene/1",
    "citygen.splits/1",
    "citygen.config/1",
    "citygen.scene",
    "",
    1,
    None,
]


def _mutate_delete(draw: st.DrawFn, doc: Any) -> str | None:
    slots = [s for s in _slots(doc) if isinstance(s[0], dict)]
    if not slots:
        return None
    parent, key, where = draw(st.sampled_from(slots))
    del parent[key]
    return f"delete {where}"


def _mutate_add_key(draw: st.DrawFn, doc: Any) -> str | None:
    objects = [(c, p) for c, p in _containers(doc) if isinstance(c, dict)]
    obj, where = draw(st.sampled_from(objects))
    misspelt = [k[:-1] + k[-1] * 2 for k in obj if k]
    key = draw(st.sampled_from(_UNKNOWN_KEYS + misspelt))
    if key in obj:
        return None
    obj[key] = draw(st.sampled_from([0, 1.5, "x", None, [], {}, True]))
    return f"add key {key!r} to {where}"


def _other_type(draw: st.DrawFn, value: Any) -> Any:
    if isinstance(value, bool):
        options: list[Any] = [int(value), "true", None, [value]]
    elif _is_number(value):
        options = [str(value), json.dumps(value), True, False, None, [value], {"value": value}]
    elif isinstance(value, str):
        options = [0, 1.5, len(value), None, True, [value], {value: value}]
    elif isinstance(value, list):
        options = [{str(i): v for i, v in enumerate(value)}, None, "[]", 0, True]
    elif isinstance(value, dict):
        options = [list(value.values()), list(value), None, "{}", 0]
    else:  # null
        options = [0, 0.0, "", "null", False, [], {}]
    return draw(st.sampled_from(options))


def _mutate_type(draw: st.DrawFn, doc: Any) -> str | None:
    parent, key, where = draw(st.sampled_from(_slots(doc)))
    new = _other_type(draw, parent[key])
    parent[key] = new
    return f"retype {where} -> {json.dumps(new)}"


def _mutate_bounds(draw: st.DrawFn, doc: Any) -> str | None:
    slots = [
        s for s in _slots(doc) if isinstance(s[1], str) and s[1] in BOUNDS_BY_NAME and _is_number(s[0][s[1]])
    ]
    if not slots:
        return None
    parent, key, where = draw(st.sampled_from(slots))
    bound = draw(st.sampled_from(BOUNDS_BY_NAME[key]))
    delta = draw(st.sampled_from((0, 1, 1e6, 1e300, *_TINY)))
    side = draw(st.sampled_from(["below", "above"]))
    new = bound.lo - delta if side == "below" else bound.hi + delta
    if bound.integer and draw(st.booleans()) and delta in (0, 1):
        new = int(new)
    parent[key] = new
    return f"{where} = {new!r} ({side} bound {bound})"


def _mutate_arity(draw: st.DrawFn, doc: Any) -> str | None:
    arrays = [(c, p) for c, p in _containers(doc) if isinstance(c, list) and c]
    if not arrays:
        return None
    arr, where = draw(st.sampled_from(arrays))
    how = draw(st.sampled_from(["truncate", "extend", "empty"]))
    if how == "truncate":
        arr.pop()
    elif how == "extend":
        arr.append(copy.deepcopy(arr[-1]) if not _is_number(arr[-1]) else 0.0)
    else:
        arr.clear()
    return f"{how} {where}"


def _mutate_kind(draw: st.DrawFn, doc: Any) -> str | None:
    holders = [(c, p) for c, p in _containers(doc) if isinstance(c, dict) and "kind" in c]
    if not holders:
        return None
    obj, where = draw(st.sampled_from(holders))
    obj["kind"] = draw(st.sampled_from(_KIND_TYPOS))
    return f"{where}.kind = {obj['kind']!r}"


def _mutate_format(draw: st.DrawFn, doc: Any) -> str | None:
    if not isinstance(doc, dict):
        return None
    doc["format"] = draw(st.sampled_from(_FORMATS))
    return f"$.format = {doc['format']!r}"


def _mutate_integer(draw: st.DrawFn, doc: Any) -> str | None:
    slots = [s for s in _slots(doc) if isinstance(s[0][s[1]], int) and _is_number(s[0][s[1]])]
    if not slots:
        return None
    parent, key, where = draw(st.sampled_from(slots))
    value = parent[key]
    new = draw(st.sampled_from([value + 0.5, float(value), -0.0 if value == 0 else value - 0.5]))
    parent[key] = new
    return f"{where} = {new!r} (was integer {value})"


def _mutate_string(draw: st.DrawFn, doc: Any) -> str | None:
    slots = [s for s in _slots(doc) if isinstance(s[0][s[1]], str)]
    if not slots:
        return None
    parent, key, where = draw(st.sampled_from(slots))
    value = parent[key]
    new = draw(
        st.sampled_from(
            [
                value + "\n",
                "",
                " " + value,
                value + " ",
                (value or "a") * 65 if len(value) < 65 else value[:1],
                value + "/",
                "a b",
                value.upper(),
            ]
        )
    )
    parent[key] = new
    return f"{where} = {new!r}"


_MUTATIONS = {
    "delete": _mutate_delete,
    "add_key": _mutate_add_key,
    "retype": _mutate_type,
    "bounds": _mutate_bounds,
    "arity": _mutate_arity,
    "kind": _mutate_kind,
    "format": _mutate_format,
    "integer": _mutate_integer,
    "string": _mutate_string,
}
MUTATION_KINDS = tuple(_MUTATIONS)


@st.composite
def mutations(draw: st.DrawFn, document: Any, kinds: tuple[str, ...] = MUTATION_KINDS) -> Any:
    """``document`` (left untouched) with one random change applied to a copy.

    The change is one of :data:`MUTATION_KINDS`: delete a key, add an unknown key, change
    a value's JSON type, push a number out of (or onto) its bounds, truncate, extend or
    empty an array, misspell a ``kind``, change ``format``, put ``3.5`` or ``3.0`` where an
    integer goes, or edit a string. It may leave the document valid (deleting an optional
    key, ``3.0`` for ``3``); the agreement tests only need both validators to agree.
    """
    doc = copy.deepcopy(document)
    order = draw(st.permutations(kinds))
    for kind in order:
        what = _MUTATIONS[kind](draw, doc)
        if what is not None:
            note(f"mutation: {what}")
            return doc
    return doc


@cache
def mutated_documents() -> st.SearchStrategy[Any]:
    """A document from :func:`documents` with one mutation applied."""
    return documents().flatmap(mutations)
