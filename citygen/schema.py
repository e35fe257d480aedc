"""JSON Schema files generated from the spec models (``citygen schema``).

``schemas/scene.schema.json`` describes a scene file and ``schemas/split.schema.json``
a split manifest (``seeds/*.toml``). They are generated, never edited by hand; a
test fails when the checked-in files drift from the models.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from pydantic import BaseModel

from citygen.io import write_atomic
from citygen.spec.config import SplitManifest
from citygen.spec.scene import Scene

DRAFT = "https://json-schema.org/draft/2020-12/schema"

#: File name -> (model, title, description) of every schema citygen publishes.
SCHEMAS: dict[str, tuple[type[BaseModel], str]] = {
    "scene.schema.json": (Scene, "citygen scene (citygen.scene/1)"),
    "split.schema.json": (SplitManifest, "citygen split manifest (citygen.splits/1)"),
}


def schema_of(model: type[BaseModel], title: str) -> dict[str, Any]:
    """The Draft 2020-12 JSON Schema of a spec model."""
    body = model.model_json_schema(by_alias=True, mode="validation")
    body["title"] = title
    return {"$schema": DRAFT, **body}


def render(name: str) -> str:
    """The exact text of one schema file."""
    model, title = SCHEMAS[name]
    return json.dumps(schema_of(model, title), indent=2, ensure_ascii=False) + "\n"


def write_schemas(out_dir: str | Path) -> list[Path]:
    """Write every schema into ``out_dir``; returns the files written."""
    out = Path(out_dir)
    written = []
    for name in SCHEMAS:
        write_atomic(out / name, render(name).encode("utf-8"))
        written.append(out / name)
    return written


def stale_schemas(out_dir: str | Path) -> list[str]:
    """Names of the schema files in ``out_dir`` that are missing or differ from the models."""
    out = Path(out_dir)
    return [
        name
        for name in SCHEMAS
        if not (out / name).is_file() or (out / name).read_text(encoding="utf-8") != render(name)
    ]
