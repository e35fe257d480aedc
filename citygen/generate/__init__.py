"""The hierarchical generator: one module per stage (blocks, ground, terrain, placement,
agents, task), each a pure function ``stage(previous_outputs, cfg, rng) -> outputs``.

>>> from citygen.spec.config import GeneratorConfig
>>> scene = generate(GeneratorConfig(size=(10.0, 10.0)), seed=7)
>>> scene.bounds.max, len(scene.zones) > 1, scene.terrain.rows
((10.0, 10.0), True, 4)
"""

from citygen.generate.pipeline import generate, layout

__all__ = ["generate", "layout"]
