"""Layouts: how a scene's ground is laid out, one module (or folder) each.

======================  =====================================================================
``region``              :mod:`.region`: the 10 m and 15 m Urban-Nav squares, without roads
``blocks``              :mod:`.blocks`: road scenes, a network grown block by block
``curriculum``          :mod:`.curriculum`: the Urban-Loc locomotion grids, terrain only
``track``               :mod:`.track`: the Urban-Tra-Standard track, units run in laps
``city``                :mod:`.city`: a city's street grid, city blocks, curbs and signals
``osm``                 :mod:`.osm`: a real place from an OpenStreetMap extract on disk
======================  =====================================================================

Each follows :class:`~.base.Layout`: a class with the layout's ``kind``, a ``plan`` for
stages 1 and 2, and the later stages' steps (:class:`~.base.BaseLayout` unless it overrides
them). :data:`LAYOUTS` maps ``GeneratorConfig.layout`` to it; a new layout is one module
and its line here.

>>> sorted(LAYOUTS)
['blocks', 'city', 'curriculum', 'osm', 'region', 'track']
"""

from __future__ import annotations

from citygen.generate.layouts.base import BaseLayout, Layout, Plan
from citygen.generate.layouts.blocks import Blocks
from citygen.generate.layouts.city import City
from citygen.generate.layouts.curriculum import Curriculum
from citygen.generate.layouts.osm import Osm
from citygen.generate.layouts.region import Region
from citygen.generate.layouts.track import Track

#: Every layout by its kind (a value of ``GeneratorConfig.layout``).
LAYOUTS: dict[str, type[Layout]] = {
    layout.kind: layout for layout in (Region, Blocks, Curriculum, Track, City, Osm)
}

__all__ = ["LAYOUTS", "BaseLayout", "Layout", "Plan"]
