"""The hierarchical generator: one module per stage (blocks, ground, terrain, placement,
agents, task), each a pure function ``stage(previous_outputs, cfg, rng) -> outputs``; one
module (or folder) per layout in :mod:`citygen.generate.layouts`; the stage loop in
:mod:`citygen.generate.pipeline`.

>>> from citygen.spec.config import GeneratorConfig
>>> scene = generate(GeneratorConfig(size=(10.0, 10.0)), seed=7)
>>> scene.bounds.max, len(scene.zones) > 1, scene.terrain.rows
((10.0, 10.0), True, 4)

The package itself is callable: ``citygen.generate(split, seed=..., index=...)`` makes one
scene of a named split (see :mod:`citygen.generate.splits`). ``citygen.generate`` is both the
name of this subpackage and the top-level generation function; making the module callable
keeps the two the same object, whichever import happened first.

>>> import citygen
>>> citygen.generate("urban-nav-2-train", seed=7, index=3).meta.split
'urban-nav-2-train'

``rebuild(scene, from_stage, config=None)`` keeps a hand-edited scene's stages up to
``from_stage`` (one of :data:`STAGES`) and makes every later one again
(:mod:`citygen.generate.pipeline`).
"""

import sys
import types

from citygen.generate.pipeline import STAGES, generate, layout, rebuild
from citygen.generate.splits import generate_split
from citygen.spec.config import GeneratorConfig


class _CallableModule(types.ModuleType):
    def __call__(self, split, seed=None, index=0):
        """One scene of ``split``: a split or family name, a manifest or config file, a
        :class:`~citygen.spec.config.SplitConfig` or a :class:`~citygen.spec.config.GeneratorConfig`
        (then ``seed`` is the scene's own seed, default 0)."""
        if isinstance(split, GeneratorConfig):
            return generate(split, 0 if seed is None else seed, index=index)
        return generate_split(split, seed=seed, index=index)


sys.modules[__name__].__class__ = _CallableModule

__all__ = ["STAGES", "generate", "layout", "rebuild"]
