"""The dependency rule of DESIGN.md section 3, and the packaging of citygen.exporters.

spec <- geometry (height_at, tile meshes: pure functions of the spec);
spec <- assets <- generate; spec, geometry, assets <- exporters; spec, exporters, generate <- runner
(the runner samples scenes of a named split);
everything <- cli. Nothing imports cli; exporters never import generate or runner;
the generator, the spec and the assets never import mujoco or pxr.

No import circles anywhere in the package (citygen and citygen.exporters), function-local
imports included, and no module over 800 lines but the asset builders' tables (DESIGN.md
section 3; docs/architecture.md).
"""

from __future__ import annotations

import ast
import itertools
import subprocess
import sys
import zipfile
from pathlib import Path

import networkx as nx
import pytest

from tests.conftest import ROOT

# Layer of each module prefix (longest prefix wins) and the layers it may import.
LAYERS = {
    "citygen._version": "base",
    "citygen.errors": "base",
    "citygen.seeding": "base",
    "citygen.outputs": "base",
    "citygen.workers": "base",
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


def source_modules(folders=((ROOT / "citygen", "citygen"), (ROOT / "exporters", "citygen.exporters"))):
    """``{dotted module name: file}`` of every module under ``folders`` (``(folder, package)`` pairs)."""
    modules = {}
    for folder, package in folders:
        for path in folder.rglob("*.py"):
            rel = path.relative_to(folder).with_suffix("")
            parts = [p for p in rel.parts if p != "__init__"]
            modules[".".join([package, *parts])] = path
    return modules


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING"
    )


def import_nodes(tree: ast.AST, type_checking: bool = True):
    """Every import statement anywhere in ``tree`` (in functions and branches too), with those
    under ``if TYPE_CHECKING:`` only when ``type_checking``."""
    stack = [tree]
    while stack:
        node = stack.pop()
        if isinstance(node, ast.Import | ast.ImportFrom):
            yield node
        elif isinstance(node, ast.If) and not type_checking and _is_type_checking(node.test):
            stack.extend(node.orelse)  # never run: only the else branch imports
            continue
        stack.extend(ast.iter_child_nodes(node))


def imports_with_lines(module: str, path: Path, modules=None, type_checking: bool = True):
    """``{imported name: first line}`` of the imports in ``module``'s source at ``path``;
    a name is a module of ``modules`` where the import names one (default: the package's)."""
    modules = MODULES if modules is None else modules
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if path.name == "__init__.py" else module.rpartition(".")[0]
    found: dict[str, int] = {}
    for node in sorted(import_nodes(tree, type_checking), key=lambda n: n.lineno):
        if isinstance(node, ast.Import):
            names = [alias.name for alias in node.names]
        else:
            if node.level:
                base = package.split(".")[: len(package.split(".")) - node.level + 1]
                target = ".".join(base + ([node.module] if node.module else []))
            else:
                target = node.module or ""
            names = []
            for alias in node.names:
                sub = f"{target}.{alias.name}"
                # `from citygen import assets` imports the module citygen.assets;
                # `from citygen import load_scene` imports from the package itself.
                names.append(sub if any(m == sub or m.startswith(sub + ".") for m in modules) else target)
        for name in names:
            found.setdefault(name, node.lineno)
    return found


def imports_of(module: str, path: Path, modules=None) -> set[str]:
    return set(imports_with_lines(module, path, modules))


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


def import_graph(modules: dict[str, Path]) -> nx.DiGraph:
    """Module -> module it imports, for every import statement anywhere in a module (a function's
    own imports too: they run when it is called), but those under ``if TYPE_CHECKING:``; each
    edge keeps the line of its import. A name is the longest module of ``modules`` it starts with."""
    graph = nx.DiGraph()
    graph.add_nodes_from(modules)
    for module, path in modules.items():
        for name, line in imports_with_lines(module, path, modules, type_checking=False).items():
            target = max((m for m in modules if name == m or name.startswith(m + ".")), key=len, default=None)
            if target is not None and target != module:
                graph.add_edge(module, target, line=line)
    return graph


def import_circles(modules: dict[str, Path]) -> list[str]:
    """One line per circle of imports among ``modules``: for each strongly connected component,
    its shortest cycle through its first module, each step with the importing line."""
    graph = import_graph(modules)
    circles = []
    for component in sorted(sorted(c) for c in nx.strongly_connected_components(graph) if len(c) > 1):
        sub = graph.subgraph(component)
        start = component[0]
        back = min((nx.shortest_path(sub, target, start) for target in sub.successors(start)), key=len)
        cycle = [start, *back]
        steps = [f"{a} (line {graph.edges[a, b]['line']})" for a, b in itertools.pairwise(cycle)]
        circles.append(" -> ".join([*steps, start]) + f"  [{len(component)} modules in the circle]")
    return circles


MAX_LINES = 800
# The asset builders' tables: long lists of parameterised parts, one builder each, read as tables.
LONG_TABLES = {"citygen.assets.outdoor", "citygen.assets.street"}


def oversized_modules(modules: dict[str, Path], exempt=frozenset()) -> list[str]:
    """``module: N lines`` for each module longer than MAX_LINES, but those in ``exempt``."""
    sizes = {m: len(path.read_text().splitlines()) for m, path in modules.items() if m not in exempt}
    return [f"{m}: {n} lines" for m, n in sorted(sizes.items()) if n > MAX_LINES]


def test_no_import_circles():
    circles = import_circles(MODULES)
    assert circles == [], "import circles (function-local imports count):\n" + "\n".join(circles)


def test_no_module_over_800_lines():
    assert set(MODULES) >= LONG_TABLES, sorted(LONG_TABLES - set(MODULES))  # no stale exemption
    oversized = oversized_modules(MODULES, LONG_TABLES)
    assert oversized == [], f"modules over {MAX_LINES} lines (split them by idea):\n" + "\n".join(oversized)


def test_the_checks_catch_a_circle_and_an_oversized_module(tmp_path):
    pkg = tmp_path / "pkg"
    (pkg / "sub").mkdir(parents=True)
    (pkg / "__init__.py").write_text("")
    (pkg / "sub" / "__init__.py").write_text("from pkg.sub.a import run\n")
    (pkg / "sub" / "a.py").write_text("from pkg import b\n\n\ndef run():\n    return b.helper()\n")
    # The circle closes through a function-local import, as the hidden ones did.
    (pkg / "b.py").write_text("def helper():\n    from pkg.sub.a import run\n\n    return run\n")
    # A TYPE_CHECKING import is no edge: c <-> d is not a circle.
    (pkg / "c.py").write_text("from pkg import d\n")
    (pkg / "d.py").write_text(
        "from typing import TYPE_CHECKING\n\nif TYPE_CHECKING:\n    from pkg.c import x\n"
    )
    (pkg / "big.py").write_text("x = 1\n" * (MAX_LINES + 1))
    (pkg / "table.py").write_text("x = 1\n" * (MAX_LINES + 1))
    modules = source_modules([(pkg, "pkg")])
    assert import_circles(modules) == [
        "pkg.b (line 2) -> pkg.sub.a (line 1) -> pkg.b  [2 modules in the circle]"
    ]
    assert oversized_modules(modules, {"pkg.table"}) == [f"pkg.big: {MAX_LINES + 1} lines"]
    # Without the function-local import, and with the big module split, both checks pass.
    (pkg / "b.py").write_text("def helper():\n    return None\n")
    (pkg / "big.py").write_text("x = 1\n" * MAX_LINES)
    assert import_circles(modules) == []
    assert oversized_modules(modules, {"pkg.table"}) == []


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
    exporter = module.split(".")[2] if module.startswith("citygen.exporters.") else ""  # its package too
    allowed_engines = {"mujoco"} if exporter == "mjcf" else {"pxr"} if exporter == "usd" else set()
    assert [m for m in loaded if m.split(".")[0] not in allowed_engines] == []


def test_an_environment_process_never_loads_mesh_plotting_or_graph_libraries(tmp_path):
    """Every sub-environment process pays for what a reset imports: the runner builds a
    scene's MJCF and occupancy map and never draws or meshes it, so trimesh and matplotlib
    (about 1.2 s of imports together) stay out of it; networkx (0.17 s) comes in only with a
    road graph, which a scene without vehicles never makes."""
    code = (
        "import sys\n"
        "from citygen.runner.make import make_env\n"
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
