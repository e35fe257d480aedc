"""The ``curriculum`` layout: the Urban-Loc locomotion grids, bare terrain without zones.

Stages 1 and 2 lay out nothing (no blocks, no zones); with ``terrain.layout = "curriculum"``
(as the Urban-Loc splits set it) the terrain stage lays its tiles out as a difficulty grid
(:func:`~citygen.generate.terrain.build_curriculum`) and a locomotion task starts on it.
"""

from __future__ import annotations

from typing import ClassVar

from citygen.generate.layouts.base import BaseLayout, Plan
from citygen.spec.config import GeneratorConfig
from citygen.spec.scene import Bounds


class Curriculum(BaseLayout):
    """No ground plan: the terrain is the scene."""

    kind: ClassVar[str] = "curriculum"

    @staticmethod
    def plan(bounds: Bounds, config: GeneratorConfig, seed: int) -> Plan:
        return Plan()
