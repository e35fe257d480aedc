"""The stages in order: one scene from a generator config and a seed.

Each stage draws only from its own generator (:func:`citygen.seeding.stage_rng`), so
changing how a later stage samples never changes what an earlier one produced. The
task stage (6) picks its start and goal right after the ground, so that the terrain
keeps them flat and placement keeps them clear and connected; it still draws from its
own generator, so its numbering is the order of the spec, not of the calls.
"""

from __future__ import annotations

from citygen._version import __version__
from citygen.generate.agents import place_agents
from citygen.generate.blocks import connect_blocks
from citygen.generate.ground import ground_margin, plan_ground, plan_region
from citygen.generate.placement import place_objects
from citygen.generate.space import walkable_ground
from citygen.generate.task import choose_endpoints, make_task, robot_clearance
from citygen.generate.terrain import build_terrain
from citygen.seeding import child, stage_rng
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
    """Every stage: :func:`layout` (blocks, ground), the task's endpoints, the terrain grid
    (WFC inside the zones, or the locomotion curriculum), objects, agents and the task.

    ``index`` (the scene's place in its split) picks the density levels of objects and
    agents: level ``index % len(levels)``.
    """
    scene = layout(config, seed, split=split, index=index)
    # The walkable ground, shared by the task, placement and agent stages.
    walkable = walkable_ground(scene.zones, (*scene.bounds.min, *scene.bounds.max))
    ends = choose_endpoints(
        scene.bounds, scene.zones, config.task, stage_rng(seed, "task"), seed=seed, walkable=walkable
    )
    terrain = build_terrain(
        scene.bounds,
        scene.zones,
        config.terrain,
        stage_rng(seed, "terrain"),
        seed=seed,
        flat_at=ends.points if ends is not None else (),
    )
    k = index or 0
    placements = place_objects(
        scene.bounds,
        scene.zones,
        terrain,
        config.placement,
        stage_rng(seed, "placement"),
        level=_level(config.placement.density_levels, k),
        ends=ends,
        seed=seed,
        walkable=walkable,
    )
    agents = place_agents(
        scene.bounds,
        scene.zones,
        scene.blocks,
        placements,
        config.agents,
        stage_rng(seed, "agents"),
        level=_level(config.agents.density_levels, k),
        ends=ends,
        robot_radius=robot_clearance(config.task),
        seed=seed,
        walkable=walkable,
    )
    task = make_task(config.task, ends, terrain, child(stage_rng(seed, "task"), 1))
    return scene.model_copy(
        update={"terrain": terrain, "placements": placements, "agents": agents, "task": task}
    )


def _level(levels: tuple[float, ...], index: int) -> float:
    return levels[index % len(levels)]
