"""Terrain (stage 3): a grid of tiles, each flat, slope, stair or rough.

The grid starts at ``origin`` (its minimum x, y corner); tile ``(row, col)`` is
``tiles[row * cols + col]`` and covers ``x`` in ``origin.x + [col, col + 1] * tile_size``
and ``y`` in ``origin.y + [row, row + 1] * tile_size``.

A tile is described by its parameters only; its edge heights follow from them
(:func:`edge_profile`) rather than being stored beside them, so raising a step by
hand can never leave a stale copy behind. Neighbouring tiles must agree on the
profile of their shared edge, which :func:`citygen.validate` checks: there are
no accidental cliffs.

Shapes, with ``h`` the tile's ``height`` and ``s`` the grid's ``tile_size``:

- **flat**: level at ``h``.
- **slope**: a plane rising from ``h`` at its low edge towards ``ascent``, at ``angle``
  radians, reaching ``h + s * tan(angle)`` at the opposite edge.
- **stair**: ``step_count`` risers of ``step_height`` dividing the tile into
  ``step_count + 1`` treads of depth ``s / (step_count + 1)``; the first tread is
  at ``h``, the last at ``h + step_count * step_height``.

A slope or stair with ``shape`` set is not a flight but a **pyramid** (or, inverted, a
**pit**), as in Isaac Lab's locomotion curricula: every edge is level at ``h`` and the
ground rises (a pit: falls) towards a central square platform; ``ascent`` is ignored.
With ``e = min(u, v, s - u, s - v)`` the distance of a point from the tile's nearest
edge and ``sign`` +1 for a pyramid, -1 for a pit:

- slope: ``h + sign * tan(angle) * min(e, s / 3)`` (the platform's side is ``s / 3``);
- stair: ``h + sign * step_height * min(floor(e / d), step_count)`` with treads of depth
  ``d = s / (2 * step_count + 2)`` (the platform's side is ``2 * d``).

Because their edges are level, pyramids and pits stand side by side in any order.
- **rough**: noise of peak ``amplitude`` and wavelength ``scale`` around ``h``,
  tapered to zero at the edges, reproducible from ``seed``.

**Features** (``features``, optional) are local level changes a tile grid is too coarse for:
front steps at a building's entrance, a ramp and a flight of steps up to a raised plaza.
Each stands in an oriented rectangle (``center``, ``length`` along its ``yaw``, ``width``
across it) on the ground; inside it the ground is the higher of the tiles' and the
feature's surface, so a feature only ever raises the ground. With ``a`` the distance from
the rectangle's low edge along ``yaw`` (``0 .. length``) and ``h`` the feature's ``height``:

- **landing**: level at ``h + rise`` (a raised plaza, a terrace);
- **steps**: ``h + step_height * min(floor(a / d) + 1, step_count)`` with treads of depth
  ``d = (length - landing) / step_count``: the first riser stands on the low edge and the
  top tread is ``landing`` metres deeper than the others (front steps end at a door);
- **ramp**: ``h + rise * a / length``.

A feature lies on the tile grid (:func:`citygen.validate` checks it). Its sides are
vertical (a wall, a building's facade or a retaining wall stands
there, or the robot meets a riser): it is crossed along its ``yaw``.
"""

from __future__ import annotations

import math
from typing import Annotated, Literal

from pydantic import Field

from citygen.spec import limits
from citygen.spec.base import Identifier, SpecModel, Vec2, Yaw, bounded_float, bounded_int
from citygen.spec.surfaces import Material

Direction = Literal["+x", "+y", "-x", "-y"]
Side = Literal["north", "east", "south", "west"]
"""Tile sides: north is +y, east is +x."""
SIDES: tuple[Side, ...] = ("north", "east", "south", "west")
Shape = Literal["pyramid", "pit"]
"""A slope or stair rising (``pyramid``) or falling (``pit``) from level edges to its centre."""

Height = bounded_float(-1_000.0, 1_000.0)


class _Tile(SpecModel):
    height: Height = 0.0
    """Base height in metres: the level of a flat tile, the low edge of a slope or stair."""
    material: Material | None = None
    """Surface material; when left out, the zone's (or concrete where no zone is)."""
    friction: bounded_float(0.0, 2.0) | None = None
    """Sliding friction coefficient; when left out, the material's default."""


class FlatTile(_Tile):
    """Level ground (a pathway, a plaza)."""

    kind: Literal["flat"]


class SlopeTile(_Tile):
    """An inclined plane (an assistive ramp, a sloped street)."""

    kind: Literal["slope"]
    angle: bounded_float(0.0, 0.9)
    """Inclination in radians (0.0833 rad is the 1:12 ramp limit of accessibility codes)."""
    ascent: Direction = "+x"
    """The direction in which the ground rises."""
    shape: Shape | None = None
    """Left out: a flight (one plane). ``pyramid`` or ``pit``: see the module docstring."""


class StairTile(_Tile):
    """A flight of steps (front steps, steps between plaza levels)."""

    kind: Literal["stair"]
    step_height: bounded_float(0.005, 0.5)
    """Riser height in metres."""
    step_count: bounded_int(1, 64)
    """Number of risers; the tile holds ``step_count + 1`` equal treads."""
    ascent: Direction = "+x"
    """The direction in which the steps rise."""
    shape: Shape | None = None
    """Left out: a flight of steps. ``pyramid`` or ``pit``: see the module docstring."""


class RoughTile(_Tile):
    """Uneven ground (cracked or cobbled paving, a gravel trail)."""

    kind: Literal["rough"]
    amplitude: bounded_float(0.0, 0.5)
    """Peak deviation from ``height`` in metres."""
    scale: bounded_float(0.01, 20.0)
    """Spatial wavelength of the bumps in metres."""
    seed: bounded_int(0, 2**32 - 1) = 0
    """Seed of the noise pattern, so every reader builds the same surface."""


Tile = Annotated[FlatTile | SlopeTile | StairTile | RoughTile, Field(discriminator="kind")]
TILE_TYPES = (FlatTile, SlopeTile, StairTile, RoughTile)


class _Feature(SpecModel):
    id: Identifier
    """Unique among the terrain's features, for example ``steps-12``."""
    center: Vec2
    """Centre of the feature's rectangle ``[x, y]``, in metres."""
    yaw: Yaw = 0.0
    """Direction (rad, counter-clockwise from +x) in which the feature rises."""
    length: bounded_float(0.05, 100.0)
    """Side of the rectangle along ``yaw``, in metres."""
    width: bounded_float(0.05, 100.0)
    """Side of the rectangle across ``yaw``, in metres."""
    height: Height = 0.0
    """Height (m) of the ground the feature stands on (the foot of its steps or ramp)."""
    material: Material | None = None
    """Surface material; when left out, the zone's (or concrete where no zone is)."""


class LandingFeature(_Feature):
    """A level platform (a raised plaza, the landing at the top of steps)."""

    kind: Literal["landing"]
    rise: bounded_float(0.0, 10.0)
    """Height (m) of the platform above the ground it stands on."""


class StepsFeature(_Feature):
    """A flight of steps (front steps to a door, steps up to a raised plaza)."""

    kind: Literal["steps"]
    step_height: bounded_float(0.005, 0.5)
    """Riser height in metres."""
    step_count: bounded_int(1, 64)
    """Number of risers; the first stands on the feature's low edge."""
    landing: bounded_float(0.0, 100.0) = 0.0
    """Extra depth (m) of the top tread, where a door or a plaza begins."""


class RampFeature(_Feature):
    """An inclined plane (a ramp up to a raised plaza or an entrance)."""

    kind: Literal["ramp"]
    rise: bounded_float(0.0, 10.0)
    """Height (m) gained from the low edge to the high edge."""


Feature = Annotated[LandingFeature | StepsFeature | RampFeature, Field(discriminator="kind")]
FEATURE_TYPES = (LandingFeature, StepsFeature, RampFeature)


def feature_top(feature: LandingFeature | StepsFeature | RampFeature) -> float:
    """The highest point of a feature (m).

    >>> feature_top(StepsFeature(id="s", kind="steps", center=(0, 0), length=1.2, width=2,
    ...     height=0.1, step_height=0.15, step_count=3))
    0.55
    """
    if isinstance(feature, StepsFeature):
        return round(feature.height + feature.step_count * feature.step_height, 6)
    return feature.height + feature.rise


class Terrain(SpecModel):
    """A ``rows`` x ``cols`` grid of square tiles, and local features on it."""

    origin: Vec2
    """Minimum ``[x, y]`` corner of the grid, in metres."""
    tile_size: bounded_float(0.25, 100.0)
    """Side of one square tile, in metres."""
    rows: bounded_int(1, limits.MAX_GRID_SIDE)
    """Tiles along y."""
    cols: bounded_int(1, limits.MAX_GRID_SIDE)
    """Tiles along x."""
    tiles: tuple[Tile, ...] = Field(min_length=1, max_length=limits.MAX_TILES)
    """``rows * cols`` tiles in row-major order: ``tiles[row * cols + col]``."""
    features: tuple[Feature, ...] | None = Field(default=None, max_length=limits.MAX_FEATURES)
    """Local level changes on the tiles (see the module docstring); left out: none."""

    def tile(self, row: int, col: int) -> FlatTile | SlopeTile | StairTile | RoughTile:
        return self.tiles[row * self.cols + col]


# --- edge profiles ---------------------------------------------------------------

_OUTWARD = {"north": "+y", "east": "+x", "south": "-y", "west": "-x"}
_OPPOSITE = {"+x": "-x", "-x": "+x", "+y": "-y", "-y": "+y"}

EdgeProfile = tuple
"""``("level", h)``, ``("ramp", h_start, h_end)`` or ``("steps", h_start, h_end, n)``;
heights run along the edge in increasing x (north, south) or increasing y (east, west)."""


def rise(tile: FlatTile | SlopeTile | StairTile | RoughTile, tile_size: float) -> float:
    """Height gained across the tile in its ascent direction, in metres (0 for pyramids and
    pits, whose edges are all at ``height``)."""
    if getattr(tile, "shape", None) is not None:
        return 0.0
    if isinstance(tile, SlopeTile):
        return tile_size * math.tan(tile.angle)
    if isinstance(tile, StairTile):
        return tile.step_count * tile.step_height
    return 0.0


def peak(tile: FlatTile | SlopeTile | StairTile | RoughTile, tile_size: float) -> float:
    """Height of a pyramid's central platform above ``height`` in metres (negative for a pit,
    0 for every other tile).

    >>> peak(StairTile(kind="stair", step_height=0.125, step_count=4, shape="pit"), 2.0)
    -0.5
    """
    shape = getattr(tile, "shape", None)
    if shape is None:
        return 0.0
    sign = 1.0 if shape == "pyramid" else -1.0
    if isinstance(tile, SlopeTile):
        return sign * tile_size / 3.0 * math.tan(tile.angle)
    return sign * tile.step_count * tile.step_height


def edge_profile(
    tile: FlatTile | SlopeTile | StairTile | RoughTile, side: Side, tile_size: float
) -> EdgeProfile:
    """The height profile of one edge of a tile; neighbours must have equal profiles."""
    h = tile.height
    if not isinstance(tile, SlopeTile | StairTile) or tile.shape is not None:
        return ("level", h)
    top = h + rise(tile, tile_size)
    outward = _OUTWARD[side]
    if outward == tile.ascent:
        return ("level", top)
    if outward == _OPPOSITE[tile.ascent]:
        return ("level", h)
    # A side edge: the profile climbs along it; it runs in increasing x or y, so it
    # climbs when the ascent is positive and descends otherwise.
    start, end = (h, top) if tile.ascent.startswith("+") else (top, h)
    if isinstance(tile, SlopeTile):
        return ("ramp", start, end)
    return ("steps", start, end, tile.step_count)


def profiles_match(a: EdgeProfile, b: EdgeProfile, tol: float = 1e-3) -> bool:
    """Whether two edge profiles are the same shape at the same heights, within ``tol`` metres."""
    if (a[0] == "ramp" and b[0] == "level") or (a[0] == "level" and b[0] == "ramp"):
        # A ramp with no rise is level ground.
        a = ("level", a[1]) if a[0] == "ramp" and abs(a[1] - a[2]) <= tol else a
        b = ("level", b[1]) if b[0] == "ramp" and abs(b[1] - b[2]) <= tol else b
    if a[0] != b[0] or len(a) != len(b):
        return False
    if a[0] == "steps" and a[3] != b[3]:
        return False
    return all(abs(x - y) <= tol for x, y in zip(a[1:3], b[1:3], strict=False))
