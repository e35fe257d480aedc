"""Docs that run and hold: the ``>>>`` examples in the library's docstrings, the README as a
front page, the links of the pages in ``docs/``, and the documentation site's strict build."""

from __future__ import annotations

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
    for url in LINK.findall(page.read_text()):
        if "://" not in url and not url.startswith(("/", "mailto:")):
            assert (page.parent / url).exists(), f"{page.name} links to {url}, which does not exist"


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
