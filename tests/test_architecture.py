"""The dependency rule of DESIGN.md section 3, and the packaging of citygen.exporters.

spec <- geometry (height_at, tile meshes: pure functions of the spec);
spec <- assets <- generate; spec, geometry, assets <- exporters; spec, exporters, generate <- runner
(the runner samples scenes of a named split);
everything <- cli. Nothing imports cli; exporters never import generate or runner;
the generator, the spec and the assets never import mujoco or pxr.
"""

from __future__ import annotations

import ast
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from tests.conftest import ROOT

# Layer of each module prefix (longest prefix wins) and the layers it may import.
LAYERS = {
    "citygen._version": "base",
    "citygen.errors": "base",
    "citygen.seeding": "base",
    "citygen.spec": "spec",
    "citygen.geometry": "geometry",
    "citygen.io": "spec",
    "citygen.schema": "spec",
    "citygen.assets": "assets",
    "citygen.validate": "validate",
    "citygen.generate": "generate",
    "citygen.exporters": "exporters",
    "citygen.runner": "runner",
    "citygen.cli": "cli",
    "citygen.cli_runner": "cli",
    "citygen.cli_train": "cli",
    "citygen.__main__": "cli",
    "citygen": "package",
}
ALLOWED = {
    "base": {"base"},
    "spec": {"base", "spec"},
    "geometry": {"base", "spec", "geometry"},
    "assets": {"base", "spec", "assets"},
    "validate": {"base", "spec", "geometry", "assets", "validate"},
    "generate": {"base", "spec", "geometry", "assets", "validate", "generate"},
    "exporters": {"base", "spec", "geometry", "assets", "exporters"},
    "runner": {"base", "spec", "geometry", "assets", "validate", "generate", "exporters", "runner"},
    "package": {"base", "spec", "geometry", "validate", "package"},
    "cli": set(LAYERS.values()),
}
# Third-party packages that tie code to a simulator; only these layers may import them.
ENGINES = {"mujoco": {"exporters", "runner", "cli"}, "pxr": {"exporters", "cli"}}


def layer_of(module: str) -> str:
    best = max((p for p in LAYERS if module == p or module.startswith(p + ".")), key=len)
    return LAYERS[best]


def source_modules() -> dict[str, Path]:
    modules = {}
    for folder, package in ((ROOT / "citygen", "citygen"), (ROOT / "exporters", "citygen.exporters")):
        for path in folder.rglob("*.py"):
            rel = path.relative_to(folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            modules[".".join([package, *parts])] = path
    return modules


def imports_of(module: str, path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                # `from citygen import assets` imports the module citygen.assets;
                # `from citygen import load_scene` imports from the package itself.
                found.add(sub if any(m == sub or m.startswith(sub + ".") for m in MODULES) else target)
    return found


MODULES = source_modules()


@pytest.mark.parametrize("module", sorted(MODULES))
def test_module_respects_the_dependency_rule(module):
    mine = layer_of(module)
    for target in sorted(imports_of(module, MODULES[module])):
        if target.startswith("citygen"):
            theirs = layer_of(target)
            assert theirs in ALLOWED[mine], f"{module} ({mine}) imports {target} ({theirs})"
            assert theirs != "cli" or mine == "cli", f"{module} imports the CLI"
        root = target.split(".")[0]
        if root in ENGINES:
            assert mine in ENGINES[root], f"{module} ({mine}) imports {root}"


def test_the_rule_catches_a_violation(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("from citygen.generate import blocks\nimport mujoco\n")
    found = imports_of("citygen.exporters.bad", bad)
    assert {"citygen.generate.blocks", "mujoco"} <= found  # the module, now that it exists
    assert layer_of("citygen.generate.blocks") not in ALLOWED["exporters"]
    assert layer_of("citygen.geometry.roads") in ALLOWED["exporters"]


EXPORTER_MODULES = sorted(m for m in MODULES if m.startswith("citygen.exporters"))


def python_stdout(code: str, cwd: Path, timeout: float = 60, env: dict | None = None) -> str:
    """What a fresh interpreter started in ``cwd`` prints running ``code`` (it must succeed)."""
    proc = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, cwd=cwd, timeout=timeout, env=env
    )
    assert proc.returncode == 0, proc.stderr
    return proc.stdout


@pytest.mark.parametrize("module", [*EXPORTER_MODULES, "citygen", "citygen.spec", "citygen.validate"])
def test_importing_loads_no_generator_runner_or_engine(module, tmp_path):
    code = (
        f"import sys, {module}\n"
        "bad = sorted(m for m in sys.modules if m.split('.')[0] in ('mujoco', 'pxr')"
        " or m.startswith(('citygen.generate', 'citygen.runner', 'citygen.cli')))\n"
        "print(','.join(bad))\n"
    )
    # The engines may be imported by an exporter that needs them, never by the rest.
    loaded = [m for m in python_stdout(code, tmp_path).strip().split(",") if m]
    allowed_engines = {"mujoco"} if module.endswith("mjcf") else {"pxr"} if module.endswith("usd") else set()
    assert [m for m in loaded if m.split(".")[0] not in allowed_engines] == []


def test_an_environment_process_never_loads_mesh_plotting_or_graph_libraries(tmp_path):
    """Every sub-environment process pays for what a reset imports: the runner builds a
    scene's MJCF and occupancy map and never draws or meshes it, so trimesh and matplotlib
    (about 1.2 s of imports together) stay out of it; networkx (0.17 s) comes in only with a
    road graph, which a scene without vehicles never makes."""
    code = (
        "import sys\n"
        "from citygen.runner.bench import make_env\n"
        "HEAVY = {'trimesh', 'matplotlib', 'networkx'}\n"
        "def heavy():\n"
        "    return ','.join(sorted({m.split('.')[0] for m in sys.modules} & HEAVY))\n"
        "for task, robot in (('nav-static', 'wheeled'), ('nav-dynamic', 'quadruped')):\n"
        "    env = make_env(task, split='urban-nav-2-test', robot=robot)\n"
        "    env.reset(seed=0, options={'index': 3})\n"
        "    for _ in range(3):\n"
        "        env.step(env.action_space.sample())\n"
        "    print(task, heavy())\n"
    )
    assert python_stdout(code, tmp_path, timeout=300).split("\n")[:2] == ["nav-static ", "nav-dynamic "]


def exporters_file(cwd: Path, env: dict | None = None) -> Path:
    """Where a fresh interpreter started in ``cwd`` imports ``citygen.exporters`` from."""
    return Path(python_stdout("import citygen.exporters as e; print(e.__file__)", cwd, env=env).strip())


def test_exporters_import_from_outside_the_checkout(tmp_path):
    assert exporters_file(tmp_path).name == "__init__.py"


@pytest.mark.slow
def test_wheel_packages_every_module_and_maps_exporters(tmp_path):
    proc = subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "--no-deps",
            "--no-build-isolation",
            "-q",
            "-w",
            str(tmp_path),
            str(ROOT),
        ],
        capture_output=True,
        text=True,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr
    (wheel,) = tmp_path.glob("citygen-*.whl")
    names = set(zipfile.ZipFile(wheel).namelist())
    expected = {"citygen/" + str(p.relative_to(ROOT / "citygen")) for p in (ROOT / "citygen").rglob("*.py")}
    expected |= {
        "citygen/exporters/" + str(p.relative_to(ROOT / "exporters"))
        for p in (ROOT / "exporters").rglob("*.py")
    }
    # Data the package reads at run time: the split manifests and lock, the viewer's three.js.
    seeds = [p for p in (ROOT / "seeds").iterdir() if p.suffix in (".toml", ".json")]
    expected |= {"citygen/seeds/" + p.name for p in seeds}
    expected |= {"citygen/exporters/vendor/" + p.name for p in (ROOT / "exporters" / "vendor").iterdir()}
    assert expected <= names, sorted(expected - names)
    # Installed from the wheel (not the checkout), `citygen.exporters` is importable.
    target = tmp_path / "site"
    subprocess.run(
        [sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target), str(wheel)],
        check=True,
        capture_output=True,
        timeout=300,
    )
    assert exporters_file(tmp_path, env={"PYTHONPATH": str(target), "PATH": ""}).is_relative_to(target)
