"""Named splits, generated scene by scene: :func:`generate_scene` and :func:`generate_split`.

The manifests themselves (names, families, files, configs, output paths) are read by
:mod:`citygen.generate.manifests`; its public functions are re-exported here, so
``from citygen.generate.splits import resolve`` keeps working. The stages live in
:mod:`citygen.generate.pipeline`, which reads a manifest only to find a scene's config for
:func:`~citygen.generate.pipeline.rebuild`: manifests <- pipeline <- splits, one way.

>>> generate_split("urban-nav-2", seed=7, index=3).meta.split
'urban-nav-2-train'
"""

from __future__ import annotations

from pathlib import Path

from citygen.errors import Problem, SpecError
from citygen.generate.manifests import (
    PARTS,
    config_for,
    families,
    indices,
    known_names,
    manifests,
    relative_path,
    resolve,
    seeds_dir,
    splits,
)
from citygen.generate.pipeline import generate
from citygen.seeding import scene_seed
from citygen.spec.config import GeneratorConfig, SplitConfig
from citygen.spec.scene import Scene

__all__ = [
    "PARTS",
    "config_for",
    "families",
    "generate_scene",
    "generate_split",
    "indices",
    "known_names",
    "manifests",
    "relative_path",
    "resolve",
    "seeds_dir",
    "splits",
    "town_config",
]


def generate_scene(split: SplitConfig, index: int) -> Scene:
    """Scene ``index`` of a split: its config and the seed ``scene_seed(split.seed, split.name, index)``."""
    seed = scene_seed(split.seed, split.name, index)
    return generate(split.config, seed, split=split.name, index=index)


def generate_split(name_or_path: str | Path | SplitConfig, seed: int | None = None, index: int = 0) -> Scene:
    """One scene of a named split (or of a config file): ``generate_split("urban-nav-2-train",
    seed=7, index=3)``. A family name (``urban-nav-2``) means its first part.

    ``seed`` is the split's master seed (default: the manifest's canonical seed).
    """
    if isinstance(name_or_path, SplitConfig):
        split = name_or_path if seed is None else name_or_path.model_copy(update={"seed": seed})
    else:
        split = resolve(name_or_path, seed=seed)[0]
    if isinstance(index, bool) or not isinstance(index, int) or index < 0:
        raise SpecError([Problem("index", "an integer >= 0", repr(index))])
    return generate_scene(split, index)


def town_config(side: float = 400.0) -> GeneratorConfig:
    """urban-tra-city's config on ``side`` x ``side`` m: its kinds of streets, signals,
    objects and agents, with objects, people and vehicles in proportion to the area and a
    traverse of at least ``0.75 side``. A town runs where the 1.2 km city would take minutes
    (tests, ``benchmarks/bench_traverse.py``); ``generate(town_config(), seed)`` makes one.

    >>> c = town_config(); c.size, c.agents.people, c.task.min_distance
    ((400.0, 400.0), 22, 300.0)
    """
    config = splits()["urban-tra-city"].config
    share = side * side / (config.size[0] * config.size[1])

    def part(count: int) -> int:
        return int(count * share + 1e-9)

    agents = config.agents
    return config.model_copy(
        update={
            "size": (float(side), float(side)),
            "placement": config.placement.model_copy(update={"count": part(config.placement.count)}),
            "agents": agents.model_copy(
                update={"people": part(agents.people), "vehicles": part(agents.vehicles)}
            ),
            "task": config.task.model_copy(update={"min_distance": 0.75 * side}),
        }
    )
