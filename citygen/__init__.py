"""citygen: seeded hierarchical generation of urban scenes for robot learning.

The public API at the top level:

- :func:`load_scene` / :func:`save_scene`: a scene file to a :class:`~citygen.spec.Scene`
  and back, canonically (the same scene always gives the same bytes);
- :func:`validate`: the semantic problems of a scene, as a list;
- :func:`height_at`: the ground's height at any points of a scene, vectorised;
- :mod:`citygen.spec`: the scene spec and generator-config models;
- :mod:`citygen.exporters`: MJCF, USD, URDF, occupancy maps (importable on their own);
- :func:`generate` ``(split, seed=..., index=...)``: one scene of a named split (or of a
  config); :func:`splits`: the named splits of ``seeds/*.toml``. Both load the generator on
  first use, so ``import citygen`` stays light (``citygen.generate`` is the callable
  generator package, see :mod:`citygen.generate`).
"""

from citygen._version import __version__
from citygen.geometry.terrain import height_at
from citygen.io import load_scene, save_scene
from citygen.spec import Scene
from citygen.validate import validate

__all__ = [
    "Scene",
    "__version__",
    "generate",
    "height_at",
    "load_scene",
    "save_scene",
    "splits",
    "validate",
]


def __getattr__(name: str):
    # The generator is imported on first use: `import citygen` must not load it.
    import importlib

    if name == "generate":
        return importlib.import_module("citygen.generate")  # a callable module
    if name == "splits":
        return importlib.import_module("citygen.generate.splits").splits
    raise AttributeError(f"module 'citygen' has no attribute {name!r}")
