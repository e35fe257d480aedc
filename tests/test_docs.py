"""The ``>>>`` examples in the library's docstrings run and hold (docs that run)."""

from __future__ import annotations

import doctest
import importlib

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
