"""The ``blocks`` layout: road scenes, a network grown block by block as in MetaDrive.

Stage 1 connects ``blocks.count`` road blocks (or ``blocks.sequence``) inside the scene,
each ``ground_margin`` metres from its edge (:func:`~citygen.generate.blocks.connect_blocks`,
from the ``blocks`` stage's generator); stage 2 divides the ground around them into
crosswalks, roadway, curbs, sidewalks and lots (:func:`~citygen.generate.ground.plan_ground`,
from the ``ground`` stage's). The later stages run as :class:`~.base.BaseLayout` runs them.
"""

from __future__ import annotations

from typing import ClassVar

from citygen.generate.blocks import connect_blocks
from citygen.generate.ground import ground_margin, plan_ground
from citygen.generate.layouts.base import BaseLayout, Plan
from citygen.seeding import stage_rng
from citygen.spec.config import GeneratorConfig
from citygen.spec.scene import Bounds


class Blocks(BaseLayout):
    """A road network and the ground around it."""

    kind: ClassVar[str] = "blocks"

    @staticmethod
    def plan(bounds: Bounds, config: GeneratorConfig, seed: int) -> Plan:
        blocks = connect_blocks(
            bounds, config.blocks, stage_rng(seed, "blocks"), seed=seed, margin=ground_margin(config.ground)
        )
        zones = plan_ground(bounds, blocks, config.ground, stage_rng(seed, "ground"), seed=seed)
        return Plan(zones=zones, blocks=blocks)
