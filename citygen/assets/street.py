"""Builders of street equipment: mailboxes, recycling bins, newspaper boxes, parking meters,
telephone booths, advertising boards, street signs and traffic lights.

Same conventions as :mod:`citygen.assets.furniture`.
"""

from __future__ import annotations

from citygen.assets.category import Category

#: The categories built here, registered by :mod:`citygen.assets.catalog`.
CATEGORIES: dict[str, Category] = {}
