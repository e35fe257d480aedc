"""Generate a 7-block street network: zones, terrain, objects, people, traffic and a traverse.

    python examples/street_network.py [OUT_DIR] [--seed N]

Writes ``OUT_DIR/street_network.json`` (a scene you can edit, validate and export) and
``OUT_DIR/street_network.png`` (the top-down map in docs/generating.md).
"""

from __future__ import annotations

import argparse
from pathlib import Path

from citygen import save_scene, validate
from citygen.exporters import picture
from citygen.generate import generate
from citygen.spec.config import (
    AgentsConfig,
    BlocksConfig,
    GeneratorConfig,
    PeopleMix,
    PlacementConfig,
    TaskConfig,
)

CONFIG = GeneratorConfig(
    size=(250.0, 250.0),
    layout="blocks",
    blocks=BlocksConfig(count=7),
    placement=PlacementConfig(count=None, density_per_100m2=2.0),
    agents=AgentsConfig(people=40, mix=PeopleMix(pedestrian=6, cyclist=1, scooter=1), vehicles=8),
    task=TaskConfig(kind="traverse", min_distance=120.0, time_limit=600.0),
)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("out_dir", nargs="?", default=".", type=Path)
    parser.add_argument("--seed", type=int, default=7)
    args = parser.parse_args()
    scene = generate(CONFIG, args.seed)
    assert validate(scene) == [], validate(scene)[:3]
    args.out_dir.mkdir(parents=True, exist_ok=True)
    save_scene(scene, args.out_dir / "street_network.json")
    picture.render(scene, args.out_dir / "street_network.png", size_px=1000)
    kinds = sorted({z.kind for z in scene.zones})
    print(
        f"{len(scene.blocks)} blocks, {len(scene.zones)} zones ({', '.join(kinds)}), "
        f"{scene.terrain.rows} x {scene.terrain.cols} terrain tiles, {len(scene.placements)} objects, "
        f"{len(scene.agents)} agents, a {len(scene.task.route)}-waypoint traverse -> {args.out_dir}"
    )


if __name__ == "__main__":
    main()
