"""Griffe extensions for the API pages: where ``citygen.exporters`` lives, how docstrings read.

``ExportersPackage``: pyproject maps the top-level ``exporters/`` folder to the
``citygen.exporters`` package, which griffe (the API reader behind mkdocstrings) does not
follow from ``citygen/``. When griffe has read ``citygen``, this extension reads every module
under ``exporters/`` into it, with griffe's public visitor, so the API pages name them
``citygen.exporters.*`` as users import them.

``SphinxDocstrings``: the docstrings are written for Python's own tools (``>>>`` examples that
the tests run as doctests, Sphinx roles such as ``:func:`height_at```); in Markdown a ``>>>``
line is a quote, so the examples become code blocks, the roles plain code and reST's simple
tables Markdown tables.
"""

from __future__ import annotations

import re
from pathlib import Path

import griffe

ROLE = re.compile(r":(?:py:)?[a-z]+:`~?([^`]+)`")
BORDER = re.compile(r"^\s*=+(?:\s+=+)+\s*$")  # a reST simple table's top or bottom
EXPORTERS = Path(__file__).resolve().parent.parent / "exporters"


class ExportersPackage(griffe.Extension):
    def on_package(self, *, pkg: griffe.Module, loader: griffe.GriffeLoader, **kwargs) -> None:
        if pkg.name != "citygen" or "exporters" in pkg.members:
            return
        # Parents before children: a package's __init__ before the modules in its folder.
        paths = sorted(EXPORTERS.rglob("*.py"), key=lambda p: (len(p.parts), p.name != "__init__.py", p))
        for path in paths:
            parts = [*path.relative_to(EXPORTERS).with_suffix("").parts]
            if parts[-1] == "__init__":
                parts.pop()
            parent = pkg.get_member(["exporters", *parts[:-1]]) if parts else pkg
            code = path.read_text(encoding="utf-8")
            loader.lines_collection[path] = code.splitlines()
            module = griffe.visit(
                parts[-1] if parts else "exporters",
                filepath=path,
                code=code,
                parent=parent,
                extensions=loader.extensions,
                docstring_parser=loader.docstring_parser,
                docstring_options=loader.docstring_options,
                lines_collection=loader.lines_collection,
                modules_collection=loader.modules_collection,
            )
            parent.set_member(module.name, module)
        loader.expand_exports(pkg.get_member("exporters"))


def markdown_tables(lines: list[str]) -> list[str]:
    """``lines`` with each reST simple table (a border of ``=`` runs, rows, a border) as a
    Markdown table, its columns where the border's runs start."""
    out: list[str] = []
    i = 0
    while i < len(lines):
        end = next((j for j in range(i + 1, len(lines)) if BORDER.match(lines[j])), None)
        if not BORDER.match(lines[i]) or end is None:
            out.append(lines[i])
            i += 1
            continue
        starts = [m.start() for m in re.finditer("=+", lines[i])]
        cells = [
            [row[a:b].strip() for a, b in zip(starts, [*starts[1:], None], strict=True)]
            for row in lines[i + 1 : end]
        ]
        out += ["", "|" + " |" * len(starts), "|" + "---|" * len(starts)]
        out += ["| " + " | ".join(row) + " |" for row in cells]
        out.append("")
        i = end + 1
    return out


def markdown_docstring(text: str) -> str:
    """``text`` with each run of ``>>>`` lines (and their output, to the next blank line) fenced
    as code at the left margin, each Sphinx role as code and each reST simple table as a
    Markdown table."""
    out: list[str] = []
    indent = None  # of the example being fenced
    for line in markdown_tables(ROLE.sub(r"`\1`", text).split("\n")):
        stripped = line.lstrip()
        if indent is None and stripped.startswith(">>>"):
            indent = len(line) - len(stripped)
            out += ["", "```pycon"]
        elif indent is not None and (not stripped or len(line) - len(stripped) < indent):
            out += ["```", ""]
            indent = None
        out.append(line[indent:] if indent is not None else line)
    if indent is not None:
        out += ["```"]
    return "\n".join(out)


class SphinxDocstrings(griffe.Extension):
    def on_instance(self, *, obj: griffe.Object, **kwargs) -> None:
        if obj.docstring is not None:
            obj.docstring.value = markdown_docstring(obj.docstring.value)
