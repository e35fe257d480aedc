"""Reading and writing spec documents: strict JSON in, canonical bytes out.

Reading never raises anything but :class:`~citygen.errors.SpecError`, whatever the
file holds (nothing, half a document, Latin-1 text, ``NaN``, a duplicated key, the
wrong shape); each problem names the JSON path. Writing is atomic (a temporary
file renamed into place) and canonical: the same model always gives the same
bytes, in any process, on any machine.
"""

from __future__ import annotations

import difflib
import json
import math
import os
import re
import stat
import tempfile
import tomllib
from collections.abc import Sequence
from pathlib import Path
from typing import Any, TypeVar

from pydantic import BaseModel, ValidationError

from citygen.errors import Problem, SpecError
from citygen.outputs import OUTPUT_ERRNOS, output_error
from citygen.spec import limits
from citygen.spec.base import to_jsonable
from citygen.spec.config import SplitManifest, check_config
from citygen.spec.scene import SCENE_FORMAT, Scene

M = TypeVar("M", bound=BaseModel)

# Files are created with the permissions an ordinary open() would give them.
_UMASK = os.umask(0o022)
os.umask(_UMASK)

# --- reading ------------------------------------------------------------------


class _Duplicate(ValueError):
    pass


def _reject_constant(name: str) -> float:
    raise ValueError(f"non-finite number {name}")


def _finite_float(text: str) -> float:
    value = float(text)
    if not math.isfinite(value):
        raise ValueError(f"number {text} is out of range")
    return value


def _sane_int(text: str) -> int:
    # Integers beyond 2**64 are no seed, count or coordinate citygen can use, and
    # huge digit strings would cost quadratic time to convert.
    if len(text.lstrip("-")) > 20:
        raise ValueError(f"integer {text[:12]}... ({len(text)} digits) is out of range")
    return int(text)


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    obj: dict[str, Any] = {}
    for key, value in pairs:
        if key in obj:
            raise _Duplicate(key)
        obj[key] = value
    return obj


def _fail(file: str, expected: str, found: str) -> SpecError:
    return SpecError([Problem("$", expected, found)], file=file)


def _read_text(path: str | Path, what: str) -> str:
    """The UTF-8 text of a document file (BOM dropped), or a :class:`SpecError` saying why not."""
    file, p = str(path), Path(path)
    try:
        info = p.stat()
        if p.is_dir():
            raise _fail(file, f"a {what} file", "a directory")
        if not (stat.S_ISREG(info.st_mode) or stat.S_ISFIFO(info.st_mode)):
            raise _fail(file, f"a {what} file", "a device or socket")
        if info.st_size > limits.MAX_FILE_BYTES:
            raise _fail(file, f"a file of at most {limits.MAX_FILE_BYTES:,} bytes", f"{info.st_size:,} bytes")
        with p.open("rb") as f:  # a pipe has no size: read one byte past the limit at most
            data = f.read(limits.MAX_FILE_BYTES + 1)
        if len(data) > limits.MAX_FILE_BYTES:
            raise _fail(file, f"a file of at most {limits.MAX_FILE_BYTES:,} bytes", "more")
    except FileNotFoundError:
        raise _fail(file, "an existing file", "no such file") from None
    except PermissionError:
        raise _fail(file, "a readable file", "permission denied") from None
    except OSError as exc:
        raise _fail(file, "a readable file", exc.strerror or type(exc).__name__) from None
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise _fail(file, "UTF-8 text", f"byte 0x{data[exc.start]:02x} at offset {exc.start}") from None
    return text.removeprefix("\ufeff")


def read_json(path: str | Path) -> Any:
    """The JSON document in ``path``, or a :class:`SpecError` saying why there is none."""
    file = str(path)

    def fail(expected: str, found: str) -> SpecError:
        return _fail(file, expected, found)

    text = _read_text(path, "JSON")
    if not text.strip():
        raise fail("a JSON document", "an empty file")
    try:
        return json.loads(
            text,
            parse_constant=_reject_constant,
            parse_float=_finite_float,
            parse_int=_sane_int,
            object_pairs_hook=_no_duplicates,
        )
    except json.JSONDecodeError as exc:
        where = f"at line {exc.lineno} column {exc.colno}"
        if exc.pos >= len(text.rstrip()):
            raise fail("valid JSON", f"the end of the file {where} (truncated?)") from None
        # Some of json's messages end in "at" ("unterminated string starting at"): not twice.
        raise fail("valid JSON", f"{exc.msg.lower().removesuffix(' at')} {where}") from None
    except _Duplicate as exc:
        raise fail("each key once per object", f"key {str(exc)!r} twice") from None
    except ValueError as exc:
        raise fail("finite numbers of sane size (JSON has no NaN or Infinity)", str(exc)) from None
    except RecursionError:
        raise fail("a document nested at most a few hundred levels deep", "deeper nesting") from None


def read_document(path: str | Path) -> Any:
    """A JSON (``.json``) or TOML (``.toml``) document, or a :class:`SpecError` saying why not."""
    if Path(path).suffix.lower() != ".toml":
        return read_json(path)
    text = _read_text(path, "TOML")
    try:
        return tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise _fail(str(path), "valid TOML", str(exc)) from None


def load_manifest(path: str | Path) -> SplitManifest:
    """Read a split manifest (``seeds/*.toml``), checking its shape and its ranges."""
    document = read_document(path)
    manifest = parse(SplitManifest, document, file=str(path))
    problems = check_config(manifest)
    if problems:
        raise SpecError(problems, file=str(path))
    return manifest


def parse(model: type[M], document: Any, file: str | None = None) -> M:
    """Validate a parsed JSON document against a spec model, as strictly as its JSON Schema."""
    try:
        # Validate the JSON text, not the Python object: JSON mode is what the schema
        # describes (arrays for tuples, numbers for floats).
        # Only the JSON names count: `schema_` is the Python name of `$schema`, not a key.
        return model.model_validate_json(json.dumps(document, allow_nan=False), by_alias=True, by_name=False)
    except ValidationError as exc:
        raise SpecError(problems_from(exc, document), file=file) from None


def load_scene(path: str | Path) -> Scene:
    """Read and shape-check a scene file. Semantic checks are :func:`citygen.validate`'s.

    >>> scene = load_scene("examples/nav_static_10m.json")
    >>> scene.task.kind
    'nav-static'
    """
    document = read_json(path)
    _check_format(document, str(path))
    return parse(Scene, document, file=str(path))


def _check_format(document: Any, file: str) -> None:
    if not isinstance(document, dict):
        raise SpecError([Problem("$", "a JSON object (a scene)", _kind_of(document))], file=file)
    fmt = document.get("format")
    if fmt is not None and fmt != SCENE_FORMAT:
        raise SpecError(
            [Problem("$.format", f"{SCENE_FORMAT!r} (the only version this citygen reads)", repr(fmt))],
            file=file,
        )


# --- pydantic errors as problems ------------------------------------------------


def problems_from(exc: ValidationError, document: Any) -> list[Problem]:
    """One :class:`Problem` per pydantic error, located by JSON path in ``document``."""
    errors = exc.errors(include_url=False)
    located = [(*_locate(document, err["loc"]), err) for err in errors]
    # A misspelt key shows up twice: unknown where it is, missing where it belongs.
    missing = {path: err for path, _, err in located if err["type"] == "missing"}
    problems, paired = [], set()
    for path, node, err in located:
        parent, _, name = path.rpartition(".")
        if err["type"] == "extra_forbidden":
            guesses = [p for p in missing if p.rpartition(".")[0] == parent]
            best = difflib.get_close_matches(name, [g.rpartition(".")[2] for g in guesses], 1, 0.6)
            if best:
                paired.add(f"{parent}.{best[0]}")
                problems.append(Problem(path, f"{best[0]!r} (misspelt?)", f"unknown field {name!r}"))
                continue
        problems.append(Problem(path, *_describe(err, node)))
    drop = {i for i, (path, _, err) in enumerate(located) if err["type"] == "missing" and path in paired}
    # pydantic counts a list's length without the items it refused; the refused item is
    # the problem, not the length.
    inner = {path for path, _, _ in located}
    drop |= {
        i
        for i, (path, _, err) in enumerate(located)
        if err["type"] in ("too_short", "too_long") and any(q.startswith(path + "[") for q in inner)
    }
    return [p for i, p in enumerate(problems) if i not in drop]


def _locate(document: Any, loc: Sequence[int | str]) -> tuple[str, Any]:
    """JSON path of a pydantic location, dropping the union tags pydantic inserts."""
    path, node = "$", document
    for part in loc:
        if isinstance(part, int) and isinstance(node, list) and 0 <= part < len(node):
            path, node = f"{path}[{part}]", node[part]
        elif isinstance(part, str) and isinstance(node, dict) and part in node:
            path, node = f"{path}.{_key(part)}", node[part]
        elif isinstance(part, str) and isinstance(node, dict) and node.get("kind") == part:
            continue  # a discriminated union's tag, not a key of the document
        elif isinstance(part, str) and part.startswith(("function-", "tagged-union[")):
            continue
        else:
            path, node = (f"{path}[{part}]" if isinstance(part, int) else f"{path}.{_key(part)}"), None
    return path, node


def _key(name: str) -> str:
    return name if name.isidentifier() else json.dumps(name)


def _show(value: Any, limit: int = 60) -> str:
    text = json.dumps(value, allow_nan=False) if value is not None else "null"
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _kind_of(value: Any) -> str:
    names = {dict: "an object", list: "an array", str: "a string", bool: "a boolean", type(None): "null"}
    shown = "" if isinstance(value, dict | list) or value is None else f" {_show(value)}"
    return names.get(type(value), "a number") + shown


def _suggest(word: Any, quoted_choices: str) -> str:
    """`` (did you mean 'x'?)`` for the choice in pydantic's "'a', 'b' or 'c'" closest to ``word``."""
    choices = re.findall(r"'([^']*)'", quoted_choices)
    guess = difflib.get_close_matches(str(word), choices, 1)
    return f" (did you mean {guess[0]!r}?)" if guess else ""


def _describe(err: dict[str, Any], node: Any) -> tuple[str, str]:
    kind, ctx, value = err["type"], err.get("ctx") or {}, err.get("input")
    msg = err["msg"]
    if kind == "missing" and err["loc"] and isinstance(err["loc"][-1], int):
        return f"an item at index {err['loc'][-1]} (too few items)", "nothing"
    if kind == "missing":
        return "a value (required field)", "nothing"
    if kind == "extra_forbidden":
        return "only the fields the schema defines", f"unknown field {_show(err['loc'][-1])}"
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        tags = ctx.get("expected_tags", "")
        if not (isinstance(value, dict) and "kind" in value):
            return f"'kind' one of {tags}", "no 'kind'"
        return f"'kind' one of {tags}", _show(value["kind"]) + _suggest(value["kind"], tags)
    if kind == "literal_error":
        expected = ctx.get("expected", "")
        return f"one of {expected}", _show(value) + _suggest(value, expected)
    if kind in ("too_short", "too_long"):
        # "List should have at least 3 items after validation, not 2" -> "at least 3 items"
        bound = msg.split(" should have ", 1)[-1].split(" after validation")[0]
        return bound, f"{ctx.get('actual_length')} items"
    if kind in ("model_type", "model_attributes_type", "dict_type"):
        return "an object", _kind_of(value)
    if kind in ("tuple_type", "list_type"):
        return "an array", _kind_of(value)
    expected = msg.removeprefix("Input should be ").removeprefix("Value error, ")
    if kind == "string_pattern_mismatch" and err["loc"] and err["loc"][-1] == "asset":
        expected = "a catalog id like 'bench/0012' or a relative mesh path like 'meshes/kiosk.obj'"
    return expected, _show(value) if node is not None or value is not None else "nothing"


# --- writing --------------------------------------------------------------------


def dumps(model: BaseModel) -> str:
    """Canonical JSON text of a model: ``id`` and ``kind`` first, then fields in model order;
    floats as quantised; arrays of numbers (and of number arrays) on one line; a final newline."""
    return _format(to_jsonable(model), "") + "\n"


def _is_flat(value: Any) -> bool:
    return isinstance(value, list) and all(
        not isinstance(v, dict | list)
        or (isinstance(v, list) and all(not isinstance(w, dict | list) for w in v))
        for v in value
    )


_LEADING_KEYS = ("id", "kind")


def _format(value: Any, indent: str) -> str:
    if isinstance(value, dict):
        if not value:
            return "{}"
        # A reader looks for what a thing is first: `id` and `kind` lead every object.
        lead = {k: value[k] for k in _LEADING_KEYS if k in value}
        value = {**lead, **{k: v for k, v in value.items() if k not in lead}}
        inner = indent + "  "
        items = ",\n".join(f"{inner}{json.dumps(k)}: {_format(v, inner)}" for k, v in value.items())
        return "{\n" + items + "\n" + indent + "}"
    if isinstance(value, list):
        if _is_flat(value):
            return json.dumps(value, allow_nan=False, separators=(", ", ": "))
        inner = indent + "  "
        return "[\n" + ",\n".join(inner + _format(v, inner) for v in value) + "\n" + indent + "]"
    return json.dumps(value, allow_nan=False)


def write_atomic(path: str | Path, data: bytes, *, durable: bool = False) -> None:
    """Write ``data`` to ``path`` through a temporary file in the same folder and a rename,
    so a reader (or a killed writer) never sees half a file. What the operating system
    refuses (a file where a folder goes, a read-only or full disk) is a one-line
    :class:`~citygen.errors.OutputError` naming ``path``; the temporary file is gone.

    The rename is atomic for every process on the machine whether or not the bytes have
    reached the disk, so a Ctrl-C or a kill never leaves a partial file. Only a power cut
    could; ``durable=True`` guards against that too by ``fsync``-ing before the rename, at
    3 ms or so a file (it was 60 % of exporting a 15 m scene to MJCF, 28 files). Nothing
    citygen writes needs it: every file can be made again, and ``citygen dataset --resume``
    re-checks the files it keeps."""
    path = Path(path)
    try:
        path.parent.mkdir(parents=True, exist_ok=True)
        fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    except OSError as exc:
        raise output_error(exc, path) from None
    try:
        with os.fdopen(fd, "wb") as f:
            os.fchmod(f.fileno(), 0o666 & ~_UMASK)
            f.write(data)
            if durable:
                f.flush()
                os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException as exc:
        Path(tmp).unlink(missing_ok=True)
        if isinstance(exc, OSError) and exc.errno in OUTPUT_ERRNOS:
            raise output_error(exc, path) from None
        raise


def save_scene(scene: Scene, path: str | Path) -> Path:
    """Write a scene atomically as canonical JSON; returns the path written."""
    write_atomic(path, dumps(scene).encode("utf-8"))
    return Path(path)
