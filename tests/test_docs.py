"""Docs that run and hold: the ``>>>`` examples in the library's docstrings, the README as a
front page, the links of the pages in ``docs/``, and the documentation site's strict build."""

from __future__ import annotations

import ast
import doctest
import importlib
import importlib.util
import re
import subprocess
import sys

import pytest

from tests.conftest import ROOT
from tests.test_architecture import MODULES

WITH_EXAMPLES = sorted(
    m for m, path in MODULES.items() if ">>>" in path.read_text() and m != "citygen.__main__"
)


def test_some_modules_have_examples():
    assert {"citygen.errors", "citygen.seeding", "citygen.io", "citygen.validate"} <= set(WITH_EXAMPLES)


@pytest.mark.parametrize("module", WITH_EXAMPLES)
def test_docstring_examples(module, monkeypatch):
    monkeypatch.chdir(ROOT)  # examples name files relative to the repository
    result = doctest.testmod(importlib.import_module(module), optionflags=doctest.ELLIPSIS)
    assert result.attempted > 0
    assert result.failed == 0


# The documentation: a README that is a front page, pages in docs/ that a newcomer walks
# through, built by MkDocs into a site whose strict build fails on a broken link or reference.

README = ROOT / "README.md"
PAGES = sorted((ROOT / "docs").rglob("*.md"))
# A Markdown link or image target, or an HTML src/href (the robots' table), up to its anchor.
LINK = re.compile(r"(?:\]\(|src=\"|href=\")([^)\"\s#]+)")


def test_the_readme_is_a_front_page_with_the_two_commands():
    text = README.read_text()
    assert len(text.splitlines()) < 250
    for marker in ("<!-- main-command -->", "<!-- test-command -->"):
        # .ci/run runs the fenced block right after the test-command marker.
        after = text.split(marker, 1)[1].lstrip("\n").splitlines()
        assert after[0] == "```bash" and after[1].startswith("python3 -m venv .venv") and after[2] == "```"


@pytest.mark.parametrize("page", [README, *PAGES], ids=lambda p: str(p.relative_to(ROOT)))
def test_relative_links_point_at_files(page):
    """Every relative link resolves as a repository browser reads it (raw HTML too, which
    MkDocs does not check)."""
    urls = {url for url in LINK.findall(page.read_text()) if "://" not in url and url[0] != "/"}
    assert sorted(url for url in urls if not (page.parent / url).exists()) == []


def test_the_layer_picture_is_drawn_from_the_rule():
    spec = importlib.util.spec_from_file_location("make_layers", ROOT / "docs" / "make_layers.py")
    make_layers = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(make_layers)
    assert (ROOT / "docs" / "layers.svg").read_text() == make_layers.render(), (
        "the layers changed: python docs/make_layers.py"
    )


def test_the_api_reference_covers_every_exporter():
    """A new exporter module gets its API page the day it is added."""
    documented = set(re.findall(r"^::: (\S+)", (ROOT / "docs" / "api" / "exporters.md").read_text(), re.M))
    exporters = {m for m in MODULES if m.count(".") == 2 and m.startswith("citygen.exporters.")}
    assert exporters - documented == set()


@pytest.mark.slow
def test_the_site_builds_strictly(tmp_path):
    """``mkdocs build --strict``: a broken link, a page missing from the navigation or an API
    reference that does not resolve fails the build."""
    proc = subprocess.run(
        [sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(tmp_path)],
        capture_output=True,
        text=True,
        cwd=ROOT,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    home = (tmp_path / "index.html").read_text()
    assert "main-command" in home and 'href="training.html"' in home  # the README, links rebased
    assert 'id="citygen.exporters.mjcf.export"' in (tmp_path / "api" / "exporters.html").read_text()
    assert 'id="citygen.runner.make.make_env"' in (tmp_path / "api" / "runner.html").read_text()
    assert (tmp_path / "repo" / "examples" / "EDITING.html").exists()  # linked from outside docs/


# A dotted name of the package as the pages write it (not `citygen.scene/1`, not a file name).
DOTTED = re.compile(r"(?<![\w/.(-])citygen(?:\.[A-Za-z_]\w*)+(?![\w/-]|\.\w)")


def _module_names(path) -> tuple[set[str], bool, bool]:
    """Top-level names a module defines or imports, whether it has a module ``__getattr__``,
    and whether it warns of its own deprecation when imported."""
    tree = ast.parse(path.read_text())
    names, lazy, shim = set(), False, False
    for node in tree.body:
        if isinstance(node, ast.FunctionDef | ast.ClassDef):
            names.add(node.name)
            lazy |= node.name == "__getattr__"
        elif isinstance(node, ast.Import | ast.ImportFrom):
            names |= {(a.asname or a.name).split(".")[0] for a in node.names}
        elif isinstance(node, ast.Assign | ast.AnnAssign):
            targets = node.targets if isinstance(node, ast.Assign) else [node.target]
            names |= {n.id for t in targets for n in ast.walk(t) if isinstance(n, ast.Name)}
        elif isinstance(node, ast.Expr) and "DeprecationWarning" in ast.unparse(node):
            shim = True
    return names, lazy, shim


@pytest.mark.parametrize("page", [README, *PAGES], ids=lambda p: str(p.relative_to(ROOT)))
def test_the_pages_name_modules_and_functions_that_exist(page):
    """As modules move, the pages follow: each ``citygen.x.y`` they name is a module of the
    package (not an old path kept for a release) or a name one defines."""
    problems = []
    for dotted in sorted(set(DOTTED.findall(page.read_text()))):
        module = max((m for m in MODULES if dotted == m or dotted.startswith(m + ".")), key=len)
        names, lazy, shim = _module_names(MODULES[module])
        rest = dotted.removeprefix(module).lstrip(".").split(".")[0]
        source = MODULES[module].read_text()
        if shim or (rest and rest not in names and "DeprecationWarning" in source):
            problems.append(f"{dotted}: an old path kept for one release")
        elif rest and rest not in names and not (lazy and f'"{rest}"' in source):
            problems.append(f"{dotted}: {module} has no {rest}")
    assert problems == []


# A path in the repository as the pages write it: `citygen/runner/envs/`, `seeds/*.toml`.
REPO_PATH = re.compile(
    r"(?<![\w./-])((?:citygen|exporters|seeds|schemas|examples|benchmarks|docs|tests)/[\w./*<>-]*)"
)


@pytest.mark.parametrize("page", [README, *PAGES], ids=lambda p: str(p.relative_to(ROOT)))
def test_the_pages_name_paths_that_exist(page):
    """Each repository path a page names (a folder, a file, a glob) is there."""
    named = {path.rstrip(".") for path in REPO_PATH.findall(page.read_text())}
    # Patterns (benchmarks/bench_<topic>.py) and Gymnasium ids (citygen/NavClear-v0) are no paths.
    named = {path for path in named if "<" not in path and not re.search(r"-v\d+$", path)}
    assert sorted(p for p in named if not any(ROOT.glob(p.rstrip("/")))) == []
