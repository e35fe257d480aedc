"""The checked-in JSON Schemas match the models, and accept exactly what pydantic accepts.

An editor validating a scene against ``schemas/scene.schema.json`` and ``citygen`` loading
it must never disagree: the models check shape only, which is what JSON Schema expresses.

JSON Schema regular expressions are ECMA-262 ones. The ``jsonschema`` package runs them
with Python's :func:`re.search`, whose ``$`` also matches before a final newline, so it
would let ``"road-0\\n"`` through ``^[A-Za-z0-9_]...$`` where an ECMA-262 engine (an
editor, Ajv, pydantic's Rust regex) does not. :data:`Validator` is Draft 2020-12 with
ECMA-262's ``$``; nothing else is changed.
"""

from __future__ import annotations

import copy
import json
import re
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from jsonschema import Draft202012Validator, ValidationError, validators

from citygen.errors import SpecError
from citygen.io import parse
from citygen.schema import SCHEMAS, render
from citygen.spec import Scene
from citygen.spec.config import SplitManifest
from tests.strategies import documents, mutated_documents

ROOT = Path(__file__).resolve().parent.parent
SCHEMA_DIR = ROOT / "schemas"
EXAMPLES = sorted((ROOT / "examples").glob("*.json"))

AGREEMENT = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


# --- an ECMA-262-faithful "pattern" ----------------------------------------------


def ecma_to_python(pattern: str) -> str:
    """``pattern`` with every ``$`` assertion (outside a class, unescaped) as ``\\Z``."""
    out, in_class, i = [], False, 0
    while i < len(pattern):
        c = pattern[i]
        if c == "\\":
            out.append(pattern[i : i + 2])
            i += 2
            continue
        if c == "[":
            in_class = True
        elif c == "]":
            in_class = False
        out.append(r"\Z" if c == "$" and not in_class else c)
        i += 1
    return "".join(out)


def _pattern(validator: Any, pattern: str, instance: Any, schema: Any) -> Iterator[ValidationError]:
    if validator.is_type(instance, "string") and not re.search(ecma_to_python(pattern), instance):
        yield ValidationError(f"{instance!r} does not match {pattern!r}")


Validator = validators.extend(Draft202012Validator, {"pattern": _pattern})


def test_ecma_dollar():
    assert re.search(ecma_to_python("^a$"), "a\n") is None
    assert re.search(ecma_to_python("^a$"), "a")
    assert ecma_to_python(r"^[$]\$(x|y)$") == r"^[$]\$(x|y)\Z"


# --- fixtures --------------------------------------------------------------------


def _load(name: str) -> dict[str, Any]:
    return json.loads((SCHEMA_DIR / name).read_text(encoding="utf-8"))


class Checked:
    """A checked-in schema and its validator (with a short repr for Hypothesis reports)."""

    def __init__(self, name: str, validator: Any) -> None:
        self.name, self.validator = name, validator

    def __repr__(self) -> str:
        return f"Checked({self.name!r})"


@pytest.fixture(scope="module")
def scene_schema() -> Checked:
    return Checked("scene.schema.json", Validator(_load("scene.schema.json")))


@pytest.fixture(scope="module")
def split_schema() -> Checked:
    return Checked("split.schema.json", Validator(_load("split.schema.json")))


def _accepts(model: type, document: Any) -> tuple[bool, str]:
    try:
        parse(model, document)
    except SpecError as exc:
        return False, str(exc)
    return True, ""


def _schema_accepts(validator: Any, document: Any) -> tuple[bool, str]:
    error = next(iter(validator.iter_errors(document)), None)
    if error is None:
        return True, ""
    return False, f"{error.json_path}: {error.message}"[:300]


def assert_agree(schema: Checked, model: type, document: Any, expected: bool | None = None):
    by_pydantic, why_pydantic = _accepts(model, document)
    by_schema, why_schema = _schema_accepts(schema.validator, document)
    verdict = {True: "accepts", False: "rejects"}
    message = (
        f"pydantic {verdict[by_pydantic]}, JSON Schema {verdict[by_schema]} the document\n"
        f"  {json.dumps(document)[:2000]}\n"
        f"  pydantic: {why_pydantic or 'ok'}\n  JSON Schema: {why_schema or 'ok'}"
    )
    assert by_pydantic == by_schema, message
    if expected is not None:
        assert by_pydantic == expected, (
            f"expected the document to be {'valid' if expected else 'invalid'}; " + message
        )


# --- the checked-in files ----------------------------------------------------------


@pytest.mark.parametrize("name", sorted(SCHEMAS))
def test_checked_in_schema_is_up_to_date(name: str):
    path = SCHEMA_DIR / name
    assert path.is_file(), f"{path} is missing: run `citygen schema` to generate it"
    assert path.read_text(encoding="utf-8") == render(name), (
        f"schemas/{name} differs from the models: run `citygen schema` to regenerate it"
    )


def test_schema_check_command_passes():
    proc = subprocess.run(
        [sys.executable, "-m", "citygen", "schema", "--check", "--out", "schemas"],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=120,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr


@pytest.mark.parametrize("name", sorted(SCHEMAS))
def test_schema_is_valid_draft_2020_12(name: str):
    schema = _load(name)
    assert schema["$schema"] == "https://json-schema.org/draft/2020-12/schema"
    Draft202012Validator.check_schema(schema)


# Vocabulary keywords of Draft 2020-12 (core, applicator, validation, meta-data, format,
# content, unevaluated) and the OpenAPI ``discriminator`` annotation pydantic emits.
_KEYWORDS = {
    "$schema",
    "$id",
    "$ref",
    "$defs",
    "$anchor",
    "$dynamicRef",
    "$dynamicAnchor",
    "$comment",
    "$vocabulary",
    "allOf",
    "anyOf",
    "oneOf",
    "not",
    "if",
    "then",
    "else",
    "dependentSchemas",
    "prefixItems",
    "items",
    "contains",
    "properties",
    "patternProperties",
    "additionalProperties",
    "propertyNames",
    "unevaluatedItems",
    "unevaluatedProperties",
    "type",
    "enum",
    "const",
    "multipleOf",
    "maximum",
    "exclusiveMaximum",
    "minimum",
    "exclusiveMinimum",
    "maxLength",
    "minLength",
    "pattern",
    "maxItems",
    "minItems",
    "uniqueItems",
    "maxContains",
    "minContains",
    "maxProperties",
    "minProperties",
    "required",
    "dependentRequired",
    "title",
    "description",
    "default",
    "deprecated",
    "readOnly",
    "writeOnly",
    "examples",
    "format",
    "contentEncoding",
    "contentMediaType",
    "contentSchema",
    "discriminator",
}


def _unknown_keywords(node: Any, path: str = "#") -> Iterator[str]:
    """Keys of schema objects that no vocabulary defines (a validator silently ignores them)."""
    if isinstance(node, list):
        for i, item in enumerate(node):
            yield from _unknown_keywords(item, f"{path}/{i}")
        return
    if not isinstance(node, dict):
        return
    for key, value in node.items():
        if key in ("properties", "$defs", "patternProperties", "dependentSchemas"):
            for name, sub in value.items():
                yield from _unknown_keywords(sub, f"{path}/{key}/{name}")
        elif key in ("default", "examples", "const", "enum", "discriminator"):
            continue
        else:
            if key not in _KEYWORDS:
                yield f"{path}/{key}"
            yield from _unknown_keywords(value, f"{path}/{key}")


@pytest.mark.parametrize("name", sorted(SCHEMAS))
def test_schema_uses_only_known_keywords(name: str):
    """A constraint written as ``ge``/``le`` (not ``minimum``/``maximum``) is silently ignored."""
    unknown = list(_unknown_keywords(_load(name)))
    assert not unknown, f"{len(unknown)} unknown keywords, for example: {unknown[:8]}"


# ECMA-262 escapes valid with the ``u`` flag (which Ajv and editors use): an identity
# escape of any other character (``\"``, ``\:``) is a syntax error there.
_U_MODE_ESCAPES = set("^$\\.*+?()[]{}|/-dDsSwWbBfnrtv0123456789cxukpP")


def _patterns(node: Any) -> Iterator[str]:
    if isinstance(node, dict):
        for key, value in node.items():
            if key == "pattern" and isinstance(value, str):
                yield value
            elif key not in ("default", "examples", "const", "enum"):
                yield from _patterns(value)
    elif isinstance(node, list):
        for item in node:
            yield from _patterns(item)


@pytest.mark.parametrize("name", sorted(SCHEMAS))
def test_patterns_are_valid_unicode_ecma_regexes(name: str):
    for pattern in _patterns(_load(name)):
        re.compile(pattern)
        bad = [m.group(0) for m in re.finditer(r"\\(.)", pattern, re.S) if m.group(1) not in _U_MODE_ESCAPES]
        assert not bad, f"{pattern!r}: {bad} are invalid escapes for ECMA-262 /u regexes"


@pytest.mark.parametrize("example", EXAMPLES, ids=lambda p: p.name)
def test_example_matches_schema(example: Path, scene_schema: Checked):
    document = json.loads(example.read_text(encoding="utf-8"))
    errors = [f"{e.json_path}: {e.message}" for e in scene_schema.validator.iter_errors(document)]
    assert not errors, "\n".join(errors)


# --- hand-written documents ------------------------------------------------------

BASE: dict[str, Any] = {"format": "citygen.scene/1", "bounds": {"min": [0, 0], "max": [10, 10]}}

FULL: dict[str, Any] = {
    "$schema": "../schemas/scene.schema.json",
    "format": "citygen.scene/1",
    "meta": {
        "generator": "citygen 0.1.0",
        "split": "s-1",
        "index": 3,
        "seed": 2**64 - 1,
        "description": "every key",
    },
    "bounds": {"min": [-5.5, 0], "max": [10, 10.25]},
    "blocks": [
        {
            "id": "s",
            "kind": "straight",
            "pose": {"position": [0, 0], "yaw": 0},
            "length": 20,
            "lanes": 2,
            "lane_width": 3.5,
            "sockets": [{"id": "in", "pose": {"position": [0, 0], "yaw": 3.1416}}],
            "connections": [{"socket": "in", "block": "c", "to_socket": "out"}],
        },
        {"id": "c", "kind": "curve", "pose": {"position": [20, 0]}, "radius": 30, "angle": -1.5},
        {"id": "r", "kind": "roundabout", "pose": {"position": [9, 9]}, "radius": 12, "arms": 5},
        {
            "id": "d",
            "kind": "diverge",
            "pose": {"position": [1, 1]},
            "length": 30,
            "branch_angle": 0.3,
            "branch_lanes": 2,
        },
        {"id": "m", "kind": "merge", "pose": {"position": [1, 2]}, "length": 30, "branch_angle": -0.3},
        {
            "id": "i",
            "kind": "intersection",
            "pose": {"position": [1, 3]},
            "arm_length": 15,
            "corner_radius": 0,
        },
        {
            "id": "t",
            "kind": "t_intersection",
            "pose": {"position": [1, 4]},
            "arm_length": 15,
            "side": "right",
        },
    ],
    "zones": [
        {
            "id": "z",
            "kind": "sidewalk",
            "polygon": [[0, 0], [1, 0], [1, 1]],
            "holes": [[[0.5, 0.2], [0.6, 0.2], [0.6, 0.3]]],
            "material": "brick",
            "friction": 0.7,
            "strip": "clear",
        },
        {"id": "w", "kind": "water", "polygon": [[2, 2], [3, 2], [3, 3]], "material": None},
    ],
    "terrain": {
        "origin": [0, 0],
        "tile_size": 2.5,
        "rows": 2,
        "cols": 2,
        "tiles": [
            {"kind": "flat", "height": 0.3, "material": "wood", "friction": 0.6},
            {"kind": "slope", "angle": 0.0833, "ascent": "-y"},
            {"kind": "stair", "step_height": 0.15, "step_count": 2, "ascent": "+x"},
            {"kind": "rough", "amplitude": 0.05, "scale": 0.5, "seed": 7},
        ],
    },
    "placements": [
        {"id": "b", "asset": "bench/0012", "position": [1, 2, 0], "yaw": -1, "scale": 1.5},
        {"id": "k", "asset": "meshes/kiosk.obj", "position": [3, 4, 0.1]},
    ],
    "agents": [
        {"id": "p", "kind": "pedestrian", "start": [0, 0], "goal": [1, 1], "radius": 0.3, "speed": 1.3},
        {"id": "c1", "kind": "cyclist", "start": [0, 0], "goal": [1, 1]},
        {"id": "s1", "kind": "scooter", "start": [0, 0], "goal": [1, 1]},
        {
            "id": "v",
            "kind": "vehicle",
            "start": [0, 0],
            "goal": [9, 0],
            "length": 4.5,
            "width": 1.8,
            "speed": 8,
            "route": ["s", "c"],
        },
    ],
    "task": {
        "kind": "nav-dynamic",
        "robot": "humanoid",
        "start": {"position": [0.5, 0.5]},
        "goal": [9, 9],
        "time_limit": 60,
        "goal_tolerance": 0.5,
    },
}


def _with(base: dict[str, Any], path: str, value: Any = ..., delete: bool = False) -> dict:
    """A copy of ``base`` with the value at ``path`` (``a.b.0.c``) replaced or deleted."""
    doc = copy.deepcopy(base)
    *parents, last = path.split(".")
    node: Any = doc
    for part in parents:
        node = node[int(part)] if isinstance(node, list) else node[part]
    key: Any = int(last) if isinstance(node, list) else last
    if delete:
        del node[key]
    else:
        node[key] = value
    return doc


def _terrain(*tiles: dict[str, Any], **fields: Any) -> dict[str, Any]:
    grid = {"origin": [0, 0], "tile_size": 1.0, "rows": 1, "cols": len(tiles), **fields}
    return {**BASE, "terrain": {**grid, "tiles": list(tiles)}}


def _block(**fields: Any) -> dict[str, Any]:
    block = {"id": "b", "kind": "straight", "pose": {"position": [0, 0]}, "length": 10}
    return {**BASE, "blocks": [{**block, **fields}]}


def _task(**fields: Any) -> dict[str, Any]:
    task = {"kind": "nav-clear", "start": {"position": [0, 0]}, "goal": [1, 1], "time_limit": 20}
    return {**BASE, "task": {**task, **fields}}


_STAIR = {"kind": "stair", "step_height": 0.15, "step_count": 2}
TRAVERSE = {"kind": "traverse", "start": {"position": [0, 0]}, "route": [[1, 1]], "time_limit": 5}

# (id, document, expected verdict: True valid, False invalid, None only "both agree")
CASES: list[tuple[str, Any, bool | None]] = [
    ("minimal", BASE, True),
    ("every-key-and-kind", FULL, True),
    ("schema-key", {**BASE, "$schema": "https://example.org/scene.schema.json"}, True),
    ("empty-object", {}, False),
    ("not-an-object", [BASE], False),
    ("bounds-missing", {"format": "citygen.scene/1"}, False),
    ("format-missing", {"bounds": BASE["bounds"]}, False),
    ("format-other-version", {**BASE, "format": "citygen.scene/2"}, False),
    ("format-of-splits", {**BASE, "format": "citygen.splits/1"}, False),
    ("unknown-top-level-key", {**BASE, "colour": "red"}, False),
    ("python-name-of-schema-key", {**BASE, "schema_": "x"}, False),
    ("optional-null", {**BASE, "task": None, "terrain": None, "$schema": None}, True),
    ("meta-null", {**BASE, "meta": None}, False),
    ("blocks-null", {**BASE, "blocks": None}, False),
    ("zone-kind-missing", _with(FULL, "zones.0.kind", delete=True), False),
    ("zone-kind-unknown", _with(FULL, "zones.0.kind", "lawn"), False),
    ("zone-polygon-two-points", _with(FULL, "zones.0.polygon", [[0, 0], [1, 0]]), False),
    ("zone-friction-above-bound", _with(FULL, "zones.0.friction", 2.5), False),
    ("zone-id-is-number", _with(FULL, "zones.0.id", 5), False),
    ("zone-id-trailing-newline", _with(FULL, "zones.0.id", "z\n"), False),
    ("polygon-as-object", _with(FULL, "zones.0.polygon", {"0": [0, 0], "1": [1, 0]}), False),
    ("tile-wrong-kind", _terrain({**_STAIR, "kind": "stairs"}), False),
    ("tile-extra-key", _terrain({"kind": "flat", "colour": "red"}), False),
    ("tile-parameter-of-another-kind", _terrain({"kind": "flat", "angle": 0.1}), False),
    ("tile-kind-missing", _terrain({"height": 0.0}), False),
    ("tile-height-above-bound", _terrain({"kind": "flat", "height": 1000.5}), False),
    ("tile-step-count-3.0", _terrain({**_STAIR, "step_count": 3.0}), True),
    ("tile-step-count-3.5", _terrain({**_STAIR, "step_count": 3.5}), False),
    ("tile-step-count-string", _terrain({**_STAIR, "step_count": "3"}), False),
    ("tile-step-height-zero", _terrain({**_STAIR, "step_height": 0}), False),
    ("negative-tile-size", _terrain({"kind": "flat"}, tile_size=-1.0), False),
    ("tile-size-string-number", _terrain({"kind": "flat"}, tile_size="1.5"), False),
    ("tile-size-bool", _terrain({"kind": "flat"}, tile_size=True), False),
    ("rows-2.0", _terrain({"kind": "flat"}, {"kind": "flat"}, rows=2.0, cols=1), True),
    ("rows-true", _terrain({"kind": "flat"}, rows=True), False),
    ("rows-2.5", _terrain({"kind": "flat"}, rows=2.5), False),
    ("rows-zero", _terrain({"kind": "flat"}, rows=0), False),
    ("tiles-empty", _terrain(), False),
    ("vec2-three-items", {**BASE, "bounds": {"min": [0, 0, 0], "max": [1, 1]}}, False),
    ("vec2-one-item", {**BASE, "bounds": {"min": [0], "max": [1, 1]}}, False),
    ("vec2-as-object", {**BASE, "bounds": {"min": {"x": 0, "y": 0}, "max": [1, 1]}}, False),
    ("vec2-null-item", {**BASE, "bounds": {"min": [0, None], "max": [1, 1]}}, False),
    ("vec3-two-items", _with(FULL, "placements.0.position", [1, 2]), False),
    ("float-as-string", {**BASE, "bounds": {"min": ["1.5", 0], "max": [1, 1]}}, False),
    ("huge-but-finite-float", {**BASE, "bounds": {"min": [-1.7e308, 0], "max": [1e300, 1]}}, True),
    ("required-number-null", _task(time_limit=None), False),
    ("time-limit-zero", _task(time_limit=0), False),
    ("traverse", {**BASE, "task": TRAVERSE}, True),
    ("traverse-empty-route", {**BASE, "task": {**TRAVERSE, "route": []}}, False),
    ("traverse-route-point-3d", {**BASE, "task": {**TRAVERSE, "route": [[1, 1, 1]]}}, False),
    ("loco-with-goal", _task(kind="loco-flat"), False),
    (
        "loco-command",
        {
            **BASE,
            "task": {
                "kind": "loco-rough",
                "start": {"position": [0, 0]},
                "time_limit": 5,
                "command": [0.5, 0, 0.1],
            },
        },
        True,
    ),
    ("task-kind-misspelt", _task(kind="nav_clear"), False),
    ("task-robot-unknown", _task(robot="drone"), False),
    ("block-kind-misspelt", _block(kind="t-intersection"), False),
    ("block-kind-number", _block(kind=5), False),
    ("block-lanes-2.0", _block(lanes=2.0), True),
    ("block-lanes-above-bound", _block(lanes=5), False),
    ("block-lanes-below-bound", _block(lanes=0), False),
    ("block-lane-width-below-bound", _block(lane_width=1.5), False),
    ("block-length-above-bound", _block(length=1000.5), False),
    ("block-yaw-above-bound", _block(pose={"position": [0, 0], "yaw": 7}), False),
    # Raw 6.28324 is outside [-6.2832, 6.2832] (JSON Schema sees the raw number), although it
    # rounds to 6.2832: bounds are checked before quantisation.
    ("yaw-just-above-bound", _block(pose={"position": [0, 0], "yaw": 6.28324}), False),
    (
        "too-many-sockets",
        _block(sockets=[{"id": f"s{i}", "pose": {"position": [0, 0]}} for i in range(9)]),
        False,
    ),
    ("connection-missing-key", _block(connections=[{"socket": "a", "block": "b"}]), False),
    ("curve-with-length", _block(kind="curve", radius=10, angle=1), False),
    ("placement-absolute-windows-path", _with(FULL, "placements.1.asset", "C:\\a.obj"), False),
    ("placement-catalog-id-5-digits", _with(FULL, "placements.0.asset", "bench/00123"), False),
    ("placement-unknown-extension", _with(FULL, "placements.1.asset", "meshes/a.fbx"), False),
    ("placement-scale-zero", _with(FULL, "placements.0.scale", 0), False),
    ("person-with-route", _with(FULL, "agents.0.route", []), False),
    ("person-kind-vehicle-field", _with(FULL, "agents.3.radius", 0.3), False),
    ("agent-kind-missing", _with(FULL, "agents.0.kind", delete=True), False),
    ("meta-index-3.0", {**BASE, "meta": {"index": 3.0}}, True),
    ("meta-index-3.5", {**BASE, "meta": {"index": 3.5}}, False),
    ("meta-index-negative", {**BASE, "meta": {"index": -1}}, False),
    ("meta-seed-2**64", {**BASE, "meta": {"seed": 2**64}}, False),
    ("meta-generator-too-long", {**BASE, "meta": {"generator": "x" * 201}}, False),
    ("meta-unknown-key", {**BASE, "meta": {"author": "me"}}, False),
    # Within (0, 1000] as written, but 0.0 once quantised: either both accept and the model
    # keeps a length it can save and load back, or both reject.
    ("block-length-below-quantum", _block(length=0.00001), None),
    ("time-limit-below-quantum", _task(time_limit=0.00004), None),
]


@pytest.mark.parametrize(("document", "expected"), [c[1:] for c in CASES], ids=[c[0] for c in CASES])
def test_hand_written_documents_agree(document: Any, expected: bool | None, scene_schema):
    assert_agree(scene_schema, Scene, document, expected)


def test_accepted_document_round_trips_through_the_schema(scene_schema):
    """What pydantic keeps of a borderline document is still valid for the schema."""
    for _, document, _ in CASES:
        ok, _ = _accepts(Scene, document)
        if ok:
            saved = json.loads(
                json.dumps(parse(Scene, document).model_dump(mode="json", by_alias=True, exclude_none=True))
            )
            assert_agree(scene_schema, Scene, saved, True)


@AGREEMENT
@given(document=documents())
def test_generated_documents_agree(document: dict[str, Any], scene_schema):
    assert_agree(scene_schema, Scene, document, True)


@AGREEMENT
@given(document=mutated_documents())
def test_mutated_documents_agree(document: Any, scene_schema):
    assert_agree(scene_schema, Scene, document)


# --- split manifests ---------------------------------------------------------------

SPLIT: dict[str, Any] = {"format": "citygen.splits/1", "splits": [{"name": "a", "scenes": 1}]}


def _split(**fields: Any) -> dict[str, Any]:
    return {**SPLIT, "splits": [{**SPLIT["splits"][0], **fields}]}


SPLIT_CASES: list[tuple[str, Any, bool | None]] = [
    ("minimal", SPLIT, True),
    ("schema-key", {**SPLIT, "$schema": "../schemas/split.schema.json"}, True),
    (
        "two-splits",
        {
            **SPLIT,
            "splits": [{"name": "a", "scenes": 1}, {"name": "b", "scenes": 2, "seed": 9, "description": "x"}],
        },
        True,
    ),
    ("scenes-2.0", _split(scenes=2.0), True),
    ("scenes-2.5", _split(scenes=2.5), False),
    ("scenes-zero", _split(scenes=0), False),
    ("scenes-true", _split(scenes=True), False),
    ("name-with-space", _split(name="a b"), False),
    ("name-trailing-newline", _split(name="a\n"), False),
    ("seed-2**64", _split(seed=2**64), False),
    ("config-size", _split(config={"size": [20, 20.5]}), True),
    ("config-size-one-item", _split(config={"size": [20]}), False),
    ("config-unknown-key", _split(config={"colour": 1}), False),
    ("config-weight-negative", _split(config={"blocks": {"weights": {"straight": -1}}}), False),
    ("config-weight-huge", _split(config={"blocks": {"weights": {"curve": 1e7}}}), False),
    ("splits-empty", {**SPLIT, "splits": []}, False),
    ("splits-missing", {"format": "citygen.splits/1"}, False),
    ("format-of-scenes", {**SPLIT, "format": "citygen.scene/1"}, False),
    ("unknown-top-level-key", {**SPLIT, "extra": 1}, False),
    ("python-name-of-schema-key", {**SPLIT, "schema_": "x"}, False),
]


@pytest.mark.parametrize(
    ("document", "expected"), [c[1:] for c in SPLIT_CASES], ids=[c[0] for c in SPLIT_CASES]
)
def test_split_manifests_agree(document: Any, expected: bool | None, split_schema):
    assert_agree(split_schema, SplitManifest, document, expected)
