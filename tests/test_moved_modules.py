"""The runner's old import paths (kept for one release): each still gives the same objects
as the module they moved to, and warns (DeprecationWarning) that it moved."""

from __future__ import annotations

import importlib
import sys

import pytest

from citygen.runner import make
from tests.test_architecture import MODULES, imports_of

# Old module -> the modules its public names now live in.
MOVED = {
    "citygen.runner.crowd": ("agents.crowd", "agents.lanes", "agents.orca", "agents.traffic"),
    "citygen.runner.orca": ("agents.orca",),
    "citygen.runner.traffic": ("agents.lanes", "agents.traffic"),
    "citygen.runner.signals": ("agents.signals",),
    "citygen.runner.planning": (
        "control.fields",
        "control.grid",
        "control.planner",
        "control.pursuit",
        "control.regions",
    ),
    "citygen.runner.gaits": ("control.gaits",),
    "citygen.runner.gaits_biped": ("control.gaits_biped",),
}


@pytest.mark.parametrize("old", sorted(MOVED))
def test_an_old_module_path_warns_and_gives_the_new_objects(old):
    sys.modules.pop(old, None)
    with pytest.warns(DeprecationWarning, match=old.replace(".", r"\.") + " moved to"):
        shim = importlib.import_module(old)
    assert shim.__all__
    homes = [importlib.import_module(f"citygen.runner.{m}") for m in MOVED[old]]
    for name in shim.__all__:
        assert any(getattr(home, name, None) is getattr(shim, name) for home in homes), name


def test_nothing_in_the_package_imports_an_old_path():
    users = {m: sorted(imports_of(m, path) & set(MOVED)) for m, path in MODULES.items() if m not in MOVED}
    assert {m: old for m, old in users.items() if old} == {}


@pytest.mark.parametrize("name", ["make_env", "make_vector_env"])
def test_the_environment_factory_moved_out_of_bench(name):
    from citygen.runner import bench

    with pytest.warns(DeprecationWarning, match=f"bench.{name} moved to citygen.runner.make.{name}"):
        moved = getattr(bench, name)
    assert moved is getattr(make, name)
