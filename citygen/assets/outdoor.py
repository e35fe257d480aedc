"""Builders of larger outdoor things: bus stop shelters, trees, bushes, bike racks, traffic
cones, parked scooters, cafe tables with chairs and building massing.

Same conventions as :mod:`citygen.assets.furniture`.
"""

from __future__ import annotations

from citygen.assets.category import Category

#: The categories built here, registered by :mod:`citygen.assets.catalog`.
CATEGORIES: dict[str, Category] = {}
