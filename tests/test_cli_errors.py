"""Bad input gets exit code 2 and one line per problem naming the file and the JSON path,
never a traceback. Each case is something a person editing a scene by hand can do."""

from __future__ import annotations

import json
import re

import pytest

from tests.conftest import EXAMPLES, run_subprocess

EXAMPLE = next(p for p in EXAMPLES if p.name == "nav_static_10m.json")


def _doc() -> dict:
    return json.loads(EXAMPLE.read_text())


def _edit(fn):
    doc = _doc()
    fn(doc)
    return json.dumps(doc).encode()


def _set(path, value):
    def fn(doc):
        node = doc
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value

    return fn


def _del(path):
    def fn(doc):
        node = doc
        for key in path[:-1]:
            node = node[key]
        del node[path[-1]]

    return fn


# name -> (file bytes or None for "no file", JSON path the message must name)
CASES = {
    "missing file": (None, "$"),
    "empty file": (b"", "$"),
    "whitespace only": (b"  \n\t\n", "$"),
    "truncated JSON": (EXAMPLE.read_bytes()[:200], "$"),
    "not UTF-8": ('{"format": "citygen.scene/1", "meta": {"description": "caf\xe9"}}'.encode("latin-1"), "$"),
    "NaN literal": (EXAMPLE.read_bytes().replace(b'"time_limit": 20.0', b'"time_limit": NaN'), "$"),
    "Infinity literal": (EXAMPLE.read_bytes().replace(b'"time_limit": 20.0', b'"time_limit": Infinity'), "$"),
    "number overflowing to inf": (
        EXAMPLE.read_bytes().replace(b'"time_limit": 20.0', b'"time_limit": 1e999'),
        "$",
    ),
    "duplicate key": (
        EXAMPLE.read_bytes().replace(b'"time_limit": 20.0', b'"time_limit": 20.0, "time_limit": 5'),
        "$",
    ),
    "top level is an array": (b"[1, 2, 3]", "$"),
    "unknown format version": (_edit(_set(["format"], "citygen.scene/2")), "$.format"),
    "missing bounds": (_edit(_del(["bounds"])), "$.bounds"),
    "position with two numbers": (
        _edit(_set(["placements", 1, "position"], [6.0, 4.1])),
        "$.placements[1].position",
    ),
    "string where a number goes": (_edit(_set(["task", "time_limit"], "20")), "$.task.time_limit"),
    "boolean where an integer goes": (_edit(_set(["terrain", "rows"], True)), "$.terrain.rows"),
    "misspelt zone kind": (_edit(_set(["zones", 1, "kind"], "sidewalks")), "$.zones[1].kind"),
    "misspelt tile kind": (_edit(_set(["terrain", "tiles", 0, "kind"], "stairs")), "$.terrain.tiles[0]"),
    "misspelt field name": (
        _edit(lambda d: d["placements"][0].update(positon=d["placements"][0].pop("position"))),
        "$.placements[0].positon",
    ),
    "unknown top-level key": (_edit(_set(["objects"], [])), "$.objects"),
    "negative friction": (_edit(_set(["zones", 0, "friction"], -0.3)), "$.zones[0].friction"),
    "malformed asset id": (_edit(_set(["placements", 0, "asset"], "trash bin #7")), "$.placements[0].asset"),
    "mesh path escaping the folder": (
        _edit(_set(["placements", 0, "asset"], "../../etc/mesh.obj")),
        "$.placements[0].asset",
    ),
    "absolute mesh path": (_edit(_set(["placements", 0, "asset"], "/tmp/mesh.obj")), "$.placements[0].asset"),
    "missing mesh file": (
        _edit(_set(["placements", 0, "asset"], "meshes/kiosk.obj")),
        "$.placements[0].asset",
    ),
    "unknown asset category": (
        _edit(_set(["placements", 0, "asset"], "spaceship/0001")),
        "$.placements[0].asset",
    ),
    "zones overlapping": (
        _edit(_set(["zones", 1, "polygon"], [[0, 3], [10, 3], [10, 6.25], [0, 6.25]])),
        "$.zones[0]",
    ),
    "self-intersecting polygon": (
        _edit(_set(["zones", 2, "polygon"], [[0, 6.25], [10, 10], [10, 6.25], [0, 10]])),
        "$.zones[2].polygon",
    ),
    "self-intersecting sidewalk under the task": (
        _edit(_set(["zones", 1, "polygon"], [[0, 3.75], [10, 6.25], [10, 3.75], [0, 6.25]])),
        "$.zones[1].polygon",
    ),
    "polygon outside bounds": (
        _edit(_set(["zones", 2, "polygon"], [[0, 6.25], [10, 6.25], [10, 12], [0, 12]])),
        "$.zones[2].polygon",
    ),
    "cliff between tiles": (_edit(_set(["terrain", "tiles", 2, "height"], 0.5)), "$.terrain.tiles[1]"),
    "too few tiles": (_edit(lambda d: d["terrain"]["tiles"].pop()), "$.terrain.tiles"),
    "objects overlapping": (_edit(_set(["placements", 1, "position"], [1.1, 4.3, 0.0])), "$.placements[0]"),
    "goal in the shrubs": (_edit(_set(["task", "goal"], [5.0, 1.0])), "$.task.goal"),
    "agent outside bounds": (_edit(_set(["agents", 0, "start"], [-3.0, 5.0])), "$.agents[0].start"),
    "duplicate ids": (_edit(_set(["placements", 1, "id"], "bin-1")), "$.placements[1].id"),
    "inverted bounds": (_edit(_set(["bounds"], {"min": [10, 10], "max": [0, 0]})), "$.bounds"),
    "polygon over the vertex limit": (
        _edit(_set(["zones", 0, "polygon"], [[i * 1e-4, (i % 2) * 1e-4] for i in range(20_001)])),
        "$.zones[0].polygon",
    ),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_bad_input_gives_one_line_per_problem_and_exit_2(case, tmp_path, cli):
    content, json_path = CASES[case]
    file = tmp_path / "scene.json"
    if content is not None:
        file.write_bytes(content)
    result = cli("validate", file)
    assert result.code == 2, result
    lines = result.err.splitlines()
    assert lines, "no problem reported"
    assert "Traceback" not in result.err + result.out
    for line in lines:
        assert line.startswith(f"{file}: $"), line
        assert re.search(r": expected .+, got .+", line), line
    assert any(line.startswith(f"{file}: {json_path}") for line in lines), (json_path, lines)


def test_cases_cover_at_least_fifteen_kinds():
    assert len(CASES) >= 15


@pytest.mark.parametrize("target", ["directory", "missing"])
def test_console_script_reports_without_traceback(tmp_path, target):
    file = tmp_path if target == "directory" else tmp_path / "nope.json"
    result = run_subprocess("validate", file)
    assert result.code == 2
    assert result.err.strip() == f"{file}: $: expected " + (
        "a JSON file, got a directory" if target == "directory" else "an existing file, got no such file"
    )
    assert "Traceback" not in result.err


def test_one_bad_file_among_good_ones(tmp_path, cli):
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    result = cli("validate", *EXAMPLES, bad)
    assert result.code == 2
    assert [line.split(":")[0] for line in result.err.splitlines()] == [str(bad)]
    assert result.out.count(": valid") == len(EXAMPLES)


def test_usage_errors_exit_2(cli):
    assert cli("validate").code == 2
    assert cli("no-such-command").code == 2


def test_valid_examples_exit_0(cli):
    result = cli("validate", *EXAMPLES)
    assert result.code == 0, result.err
    assert result.err == ""
