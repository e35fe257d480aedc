"""The stages in order: one scene from a generator config and a seed.

Each stage draws only from its own generator (:func:`citygen.seeding.stage_rng`), so
changing how a later stage samples never changes what an earlier one produced.
"""

from __future__ import annotations

from citygen._version import __version__
from citygen.generate.blocks import connect_blocks
from citygen.generate.ground import ground_margin, plan_ground, plan_region
from citygen.generate.terrain import build_terrain
from citygen.seeding import stage_rng
from citygen.spec.config import GeneratorConfig
from citygen.spec.scene import SCENE_FORMAT, Bounds, Meta, Scene

GENERATOR = f"citygen {__version__}"


def layout(
    config: GeneratorConfig, seed: int, *, split: str | None = None, index: int | None = None
) -> Scene:
    """Stages 1 and 2: the road blocks (for ``layout="blocks"``) and the zones of a scene."""
    bounds = Bounds(min=(0.0, 0.0), max=config.size)
    blocks: tuple = ()
    if config.layout == "blocks":
        blocks = connect_blocks(
            bounds, config.blocks, stage_rng(seed, "blocks"), seed=seed, margin=ground_margin(config.ground)
        )
        zones = plan_ground(bounds, blocks, config.ground, stage_rng(seed, "ground"), seed=seed)
    elif config.layout == "region":
        zones = plan_region(bounds, config.region, stage_rng(seed, "ground"), seed=seed)
    else:
        zones = ()
    meta = Meta(generator=GENERATOR, split=split, index=index, seed=seed)
    return Scene(format=SCENE_FORMAT, meta=meta, bounds=bounds, blocks=blocks, zones=zones)


def generate(
    config: GeneratorConfig, seed: int, *, split: str | None = None, index: int | None = None
) -> Scene:
    """Stages 1 to 3: :func:`layout`, then the terrain grid over it (WFC inside the zones,
    or the locomotion curriculum)."""
    scene = layout(config, seed, split=split, index=index)
    terrain = build_terrain(scene.bounds, scene.zones, config.terrain, stage_rng(seed, "terrain"), seed=seed)
    return scene.model_copy(update={"terrain": terrain})
