"""Documented limits on scene size, so that loading, validating and exporting any
valid scene stays within bounded time and memory.

The list limits are part of the JSON Schema (``maxItems``); the rest are checked
by :func:`citygen.validate`. The largest scene the paper describes (Urban-Tra-City,
1,200 m x 1,200 m) sits well inside every one of them.
"""

from __future__ import annotations

MAX_FILE_BYTES = 512 * 1024**2
"""Largest scene file :func:`citygen.load_scene` reads (512 MiB)."""

MAX_EXTENT_M = 10_000.0
"""Largest side of a scene's bounds, in metres."""

MAX_ZONES = 200_000
MAX_POLYGON_VERTICES = 20_000
"""Vertices in one ring (exterior or hole) of a zone polygon."""
MAX_HOLES = 1_000
MAX_BLOCKS = 10_000
MAX_SOCKETS = 8
MAX_PLACEMENTS = 500_000
MAX_AGENTS = 20_000
MAX_ROUTE_POINTS = 10_000
MAX_GRID_SIDE = 2_048
"""Rows or columns of a terrain tile grid."""
MAX_TILES = 1_048_576
"""Tiles in a terrain grid (1024 x 1024)."""
MAX_FEATURES = 200_000
"""Local features (steps, ramps, landings) on a terrain grid."""
MAX_TEXT = 10_000
"""Characters in a free-text field."""

MAX_SCENE_INDEX = 10_000_000
"""Highest index of a scene in its split (``meta.index``; ``citygen generate --index``)."""
MAX_RUN_SCENES = 100_000
"""Most scenes one ``citygen generate`` run makes (the canonical dataset is 1,536)."""
