"""The hierarchical generator: one module per stage (blocks, ground, terrain, placement,
agents, task), each a pure function ``stage(previous_outputs, cfg, rng) -> outputs``."""
