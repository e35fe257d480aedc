"""Generator configs: what to *sample* (ranges, weights, densities, counts).

A :class:`GeneratorConfig` plus a seed determines a scene; a scene spec records
what was sampled. Defaults reproduce the paper's Urban-Nav training setting
(10 m x 10 m regions, mixed terrain of all four tile kinds, 4 static objects, 2
pedestrians). A :class:`SplitManifest` (``seeds/*.toml``) names splits, each a
config with a scene count and a master seed.

Ranges are ``[low, high]``; that ``low <= high`` and that weights do not all vanish
is checked by :func:`check_config`, like every rule a JSON Schema cannot express.
"""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import BaseModel, BeforeValidator, Field, WithJsonSchema

from citygen.errors import Problem
from citygen.spec.base import Float, Identifier, Int, SpecModel, Vec2, bounded_float, bounded_int
from citygen.spec.osm import OsmArea
from citygen.spec.task import Robot

Range = tuple[Float, Float]
"""``[low, high]``, sampled uniformly."""
IntRange = tuple[Int, Int]
"""``[low, high]`` inclusive, sampled uniformly."""
Weight = bounded_float(0.0, 1e6)
LotRange = tuple[bounded_float(2.0, 10_000.0), bounded_float(2.0, 10_000.0)]
"""``[low, high]`` side of a lot in metres."""
Span = tuple[bounded_float(5.0, 1_000.0), bounded_float(5.0, 1_000.0)]
"""``[low, high]`` length of a street plan's part in metres."""


class RegionShapes(SpecModel):
    """Weights of the walkable-region shapes of small (roadless) scenes, as in NavClear."""

    straight: Weight = 1.0
    """A straight path across the scene."""
    l_turn: Weight = 1.0
    """A path turning by 90 degrees."""
    crossing: Weight = 1.0
    """Two paths crossing."""
    plaza: Weight = 1.0
    """An open plaza with non-walkable islands."""


class RegionConfig(SpecModel):
    """Layout of small scenes without roads: walkable ground against non-walkable ground."""

    shapes: RegionShapes = RegionShapes()
    path_width: Range = (2.0, 4.0)
    """Width of a walkable path, in metres."""
    walkable: tuple[Literal["sidewalk", "trail", "plaza"], ...] = Field(
        default=("sidewalk", "trail", "plaza"), min_length=1
    )
    """Zone kinds the walkable region is drawn from."""
    non_walkable: tuple[Literal["vegetation", "roadway", "water"], ...] = Field(
        default=("vegetation", "roadway"), min_length=1
    )
    """Zone kinds the rest of the ground is drawn from (shrubs and lawns, roadway)."""


class BlockWeights(SpecModel):
    """Relative frequency of each road block type."""

    straight: Weight = 1.0
    curve: Weight = 1.0
    roundabout: Weight = 1.0
    diverge: Weight = 1.0
    merge: Weight = 1.0
    intersection: Weight = 1.0
    t_intersection: Weight = 1.0


class BlocksConfig(SpecModel):
    """Stage 1: the road network, as a sequence of connected blocks."""

    count: bounded_int(1, 10_000) = 7
    """Blocks in the network (ignored by layouts without roads)."""
    weights: BlockWeights = BlockWeights()
    sequence: tuple[
        Literal["straight", "curve", "roundabout", "diverge", "merge", "intersection", "t_intersection"], ...
    ] = ()
    """An explicit block sequence; when given it replaces ``count`` and ``weights``."""
    lanes: IntRange = (1, 2)
    """Lanes per direction."""
    lane_width: Range = (3.0, 3.75)
    """Width of one lane, in metres."""
    straight_length: Range = (30.0, 80.0)
    """Length of straight blocks, in metres."""
    curve_radius: Range = (25.0, 60.0)
    """Centre-line radius of curves, in metres."""
    curve_angle_deg: Range = (45.0, 135.0)
    """Angle turned by a curve, in degrees."""
    roundabout_radius: Range = (12.0, 25.0)
    """Ring radius of roundabouts, in metres."""
    arm_length: Range = (20.0, 40.0)
    """Arm length of intersections, in metres."""
    clearance: bounded_float(0.0, 100.0) = 2.0
    """Minimum gap between roads that do not connect, in metres."""
    max_tries: bounded_int(1, 100_000) = 200
    """Candidate blocks sampled before the generator gives up with a clear error."""


class CityConfig(SpecModel):
    """The street plan of ``layout = "city"``: a perturbed grid of arterial and local streets
    that closes into city blocks, and what each city block is built as."""

    street_spacing: Span = (100.0, 150.0)
    """Distance between the centre lines of neighbouring parallel streets, in metres (city
    blocks of 80-250 m between the sidewalks)."""
    edge_inset: Span = (30.0, 45.0)
    """Distance from the scene's edge to the centre line of the outermost streets, in metres."""
    grid_irregularity: bounded_float(0.0, 0.5) = 0.12
    """Share of the interior local street segments left out, each joining two city blocks
    into one (its junctions become T-intersections)."""
    arterial_share: bounded_float(0.0, 1.0) = 0.3
    """Share of the street lines that are arterials (``arterial_lanes`` lanes each way)."""
    arterial_lanes: bounded_int(1, 4) = 2
    """Lanes in each direction of an arterial street."""
    local_lanes: bounded_int(1, 4) = 1
    """Lanes in each direction of a local street."""
    roundabout_share: bounded_float(0.0, 1.0) = 0.08
    """Share of the four-way junctions built as roundabouts (never two side by side)."""
    corner_radius: Span = (20.0, 35.0)
    """Centre-line radius of the curves at the corners of the outer streets, in metres."""
    downtown_radius: bounded_float(0.0, 1.5) = 0.45
    """City blocks whose centre is within this share of half the scene's size from its centre
    are downtown: buildings fill the whole frontage (continuous street walls)."""
    park_share: bounded_float(0.0, 1.0) = 0.08
    """Share of the city blocks that are parks (lawn crossed by trails)."""
    plaza_share: bounded_float(0.0, 1.0) = 0.04
    """Share of the city blocks that are public plazas."""
    parking_share: bounded_float(0.0, 1.0) = 0.25
    """Share of the downtown courtyards (the lots behind the frontage lots) that are parking;
    half as many of the residential back-yard lots are."""
    lot_depth: Span = (18.0, 28.0)
    """Depth of the frontage lots behind the sidewalk, in metres."""
    lot_width: Span = (14.0, 30.0)
    """Width of the lots along the street, in metres."""
    residential_setback: Range = (2.0, 5.0)
    """Front yard between the sidewalk and the lots of residential city blocks, in metres."""


class GroundConfig(SpecModel):
    """Stage 2: functional zones around the roads, with randomised widths."""

    curb_width: Range = (0.15, 0.3)
    """Width of the curb, in metres."""
    sidewalk_width: Range = (2.5, 6.0)
    """Width of the sidewalk (frontage + clear + furnishing strips), in metres."""
    crosswalk_width: Range = (3.0, 5.0)
    """Width of a crosswalk across the road, in metres."""
    midblock_crosswalk_probability: bounded_float(0.0, 1.0) = 0.2
    """Chance that a straight block gets a mid-block crosswalk."""
    plaza_probability: bounded_float(0.0, 1.0) = 0.3
    """Chance that an open corner becomes a plaza rather than vegetation."""
    building_setback: Range = (0.0, 4.0)
    """Distance from the sidewalk to building footprints, in metres."""
    lot_size: LotRange = (20.0, 45.0)
    """Side of the lots the land between streets is divided into (a building, a plaza or
    vegetation each), in metres."""
    building_probability: bounded_float(0.0, 1.0) = 0.75
    """Chance that a compact lot facing a street gets a building."""


class TerrainMix(SpecModel):
    """Relative frequency of each tile kind."""

    flat: Weight = 1.0
    slope: Weight = 1.0
    stair: Weight = 1.0
    rough: Weight = 1.0


class TerrainConfig(SpecModel):
    """Stage 3: terrain tiles by Wave Function Collapse, or a locomotion difficulty grid."""

    layout: Literal["wfc", "curriculum"] = "wfc"
    """WFC for mixed urban terrain; a difficulty grid (rows of rising difficulty) for locomotion."""
    tile_size: bounded_float(0.25, 100.0) = 2.5
    """Side of a square tile, in metres."""
    mix: TerrainMix = TerrainMix()
    slope_angle: Range = (0.0, 0.4)
    """Slope inclination in radians (paper, Urban-Loc train)."""
    step_height: Range = (0.05, 0.23)
    """Stair riser height in metres (paper, Urban-Loc train)."""
    step_count: IntRange = (2, 6)
    """Risers per stair tile."""
    roughness_amplitude: Range = (0.02, 0.10)
    """Peak bump height of rough tiles in metres (paper, Urban-Loc train)."""
    roughness_scale: Range = (0.2, 1.0)
    """Wavelength of the bumps in metres."""
    grid: tuple[Int, Int] | None = None
    """``[rows, cols]`` of a curriculum grid (paper: 30 x 30 train, 16 x 16 test)."""
    max_restarts: bounded_int(0, 10_000) = 20
    """WFC restarts after a contradiction before generation fails with a clear error."""


MAX_COUNT = 1_000_000
#: Smallest side of a region scene whose walkable region may be a plaza: its islands are
#: 0.5 m to 12 % of the smaller side across (citygen.generate.layouts.region).
MIN_PLAZA_SIDE_M = 4.2


def _density_is_none(value: object) -> object:
    """``"density"`` means what ``null`` means (TOML has no null); any other text is an error."""
    if value == "density":
        return None
    if isinstance(value, str):
        raise ValueError("an object count (a whole number >= 0), 'density' or null")
    return value


Count = Annotated[
    bounded_int(0, MAX_COUNT) | None,
    BeforeValidator(_density_is_none),
    WithJsonSchema(
        {
            "anyOf": [
                {"type": "integer", "minimum": 0, "maximum": MAX_COUNT},
                {"const": "density"},
                {"type": "null"},
            ]
        }
    ),
]
"""A number of objects, or ``"density"`` / ``None`` for a density per area instead; loaded as an
``int`` or ``None``."""


class PlacementConfig(SpecModel):
    """Stage 4: static objects from the asset catalog."""

    count: Count = 4
    """Exact number of objects (paper: 4 in train scenes, 8 in test), or ``"density"`` (or
    ``null`` in JSON) to place ``density_per_100m2`` instead. TOML has no null, so a manifest
    writes ``count = "density"``; either way the loaded config holds ``None``."""
    density_per_100m2: bounded_float(0.0, 1_000.0) = 4.0
    """Objects per 100 square metres of suitable zone area, when ``count`` is ``"density"``."""
    density_levels: tuple[bounded_float(0.0, 10.0), ...] = Field(default=(1.0,), min_length=1, max_length=64)
    """Multipliers of the count or density; scene ``i`` of a split uses level
    ``i % len(levels)`` (paper, Urban-Nav-2: 0.5, 1.0, 1.5)."""
    categories: tuple[Annotated[str, Field(pattern=r"^[a-z][a-z0-9_]*$")], ...] = ()
    """Asset categories to draw from; empty means every category suited to the zone."""
    clearance: bounded_float(0.0, 20.0) = 0.5
    """Minimum free gap between objects, in metres."""


class PeopleMix(SpecModel):
    """Relative frequency of each kind of person moving on walkable ground."""

    pedestrian: Weight = 1.0
    cyclist: Weight = 0.0
    scooter: Weight = 0.0


class AgentsConfig(SpecModel):
    """Stage 5: pedestrians, cyclists, scooter riders and vehicles."""

    people: bounded_int(0, 100_000) = 2
    """Pedestrians, cyclists and scooter riders in all (paper: 2 in train scenes, 3 in test)."""
    mix: PeopleMix = PeopleMix()
    vehicles: bounded_int(0, 100_000) = 0
    """Vehicles on the roadway (layouts with roads only)."""
    density_levels: tuple[bounded_float(0.0, 10.0), ...] = Field(default=(1.0,), min_length=1, max_length=64)
    """Multipliers of the counts; scene ``i`` of a split uses level ``i % len(levels)``
    (paper, Urban-Nav-3: 0.5, 1.0, 1.5)."""
    pedestrian_speed: Range = (1.0, 1.6)
    """Preferred walking speed, in metres per second."""
    pedestrian_radius: Range = (0.25, 0.35)
    """Radius of a pedestrian's disc, in metres."""
    cyclist_speed: Range = (3.0, 6.0)
    """Preferred cycling speed, in metres per second."""
    scooter_speed: Range = (2.0, 5.0)
    """Preferred scooter speed, in metres per second."""
    cyclist_radius: Range = (0.5, 0.8)
    """Radius of the disc a cyclist and bicycle occupy, in metres."""
    scooter_radius: Range = (0.35, 0.5)
    """Radius of the disc a scooter rider occupies, in metres."""
    vehicle_speed: Range = (8.0, 14.0)
    """Desired vehicle speed (IDM's v0), in metres per second."""


class TaskConfig(SpecModel):
    """Stage 6: the robot's task."""

    kind: Literal[
        "nav-clear",
        "nav-static",
        "nav-dynamic",
        "loco-flat",
        "loco-slope",
        "loco-stair",
        "loco-rough",
        "traverse",
    ] = "nav-dynamic"
    robot: Robot = "wheeled"
    min_distance: bounded_float(0.0, 100_000.0) = 5.0
    """Minimum walkable (geodesic) distance from start to goal, in metres."""
    time_limit: bounded_float(0.1, 86_400.0) = 20.0
    """Episode time limit in seconds (paper: 200 steps)."""
    goal_tolerance: bounded_float(0.01, 10.0) = 0.5
    """Distance from the goal that counts as reached, in metres."""


class TrackUnit(SpecModel):
    """One unit of a track (``layout = "track"``): its ground and what stands or moves on it."""

    surface: Literal["even", "uneven"] = "even"
    """``even``: flat ground at street level; ``uneven``: terrain tiles drawn from ``terrain.mix``
    (slopes, stairs, rough ground)."""
    setting: Literal["clear", "static", "dynamic"] = "clear"
    """As the Urban-Nav subsets: ``clear`` has nothing on it; ``static`` has ``placement.count``
    objects (or the density); ``dynamic`` has ``agents.people`` moving people among as many
    objects."""
    zone: Literal["sidewalk", "plaza", "trail"] = "plaza"
    """The kind of walkable zone the unit is (it decides the surface material)."""


#: The URBAN-BENCH standard track: even ground clear, static, dynamic, then uneven ground alike.
STANDARD_TRACK = tuple(
    TrackUnit(surface=surface, setting=setting)
    for surface in ("even", "uneven")
    for setting in ("clear", "static", "dynamic")
)


class TrackConfig(SpecModel):
    """A running track (``layout = "track"``, Urban-Tra-Standard): units side by side along +x,
    each ``unit_length`` long and as deep as the scene; a traverse task runs laps of it."""

    unit_length: bounded_float(1.0, 1_000.0) = 20.0
    """Length of one unit along x, in metres; the units together span the scene's width."""
    units: tuple[TrackUnit, ...] = Field(default=STANDARD_TRACK, min_length=1, max_length=100)
    """The units from x = 0 onwards (paper: six units of 20 m x 10 m, even then uneven ground,
    each clear, static and dynamic)."""
    route_length: bounded_float(0.0, 100_000.0) = 1_200.0
    """Least length of a traverse route, in metres (paper: 1,200 m): whole laps of the track,
    out along one lane and back along the other."""


class GeneratorConfig(SpecModel):
    """Everything the generator samples a scene from."""

    format: Literal["citygen.config/1"] = "citygen.config/1"
    size: Vec2 = (10.0, 10.0)
    """Width (x) and depth (y) of the scene, in metres."""
    layout: Literal["region", "blocks", "curriculum", "track", "city", "osm"] = "region"
    """``region`` for small roadless scenes, ``blocks`` for road networks grown block by block,
    ``city`` for a city's street grid of city blocks, ``curriculum`` for locomotion grids,
    ``track`` for the Urban-Tra-Standard running track, ``osm`` for a real place from an
    OpenStreetMap extract (the ``osm`` table)."""
    region: RegionConfig = RegionConfig()
    blocks: BlocksConfig = BlocksConfig()
    city: CityConfig = CityConfig()
    """The street plan of a ``city`` layout (ignored by the other layouts)."""
    ground: GroundConfig = GroundConfig()
    terrain: TerrainConfig = TerrainConfig()
    placement: PlacementConfig = PlacementConfig()
    agents: AgentsConfig = AgentsConfig()
    task: TaskConfig = TaskConfig()
    track: TrackConfig = TrackConfig()
    """The units of a ``track`` layout (ignored by the other layouts)."""
    osm: OsmArea | None = None
    """The extract and box of an ``osm`` layout, whose scene takes the box's size (``size`` is
    then ignored); ignored by the other layouts."""


class SplitConfig(SpecModel):
    """A named split: how many scenes, from which master seed, sampled from which config."""

    name: Identifier
    """For example ``urban-nav-2-train``."""
    description: str = Field(default="", max_length=2_000)
    scenes: bounded_int(1, 10_000_000)
    """Number of scenes in the split."""
    seed: bounded_int(0, 2**64 - 1) = 0
    """Master seed; scene ``i``'s seed derives from (master seed, split name, i)."""
    config: GeneratorConfig = GeneratorConfig()


class SplitManifest(SpecModel):
    """A ``seeds/*.toml`` file: one family of named splits."""

    schema_: str | None = Field(default=None, alias="$schema", max_length=1_000)
    format: Literal["citygen.splits/1"]
    splits: tuple[SplitConfig, ...] = Field(min_length=1, max_length=1_000)


# --- semantic checks ---------------------------------------------------------------


def check_config(config: BaseModel, path: str = "$") -> list[Problem]:
    """Problems a JSON Schema cannot express: ranges with ``low > high``, all-zero weights,
    track units that do not span the scene's width, duplicate split names.

    >>> check_config(TerrainConfig(step_height=(0.3, 0.1)))
    [Problem(path='$.step_height', expected='[low, high] with low <= high', found='[0.3, 0.1]')]
    """
    problems: list[Problem] = []
    for name, field in type(config).model_fields.items():
        value = getattr(config, name)
        where = f"{path}.{field.alias or name}"
        if isinstance(value, BaseModel):
            problems += check_config(value, where)
        elif isinstance(value, tuple) and value and isinstance(value[0], BaseModel):
            for i, item in enumerate(value):
                problems += check_config(item, f"{where}[{i}]")
        elif _is_range(config, name, field) and value is not None and value[0] > value[1]:
            problems.append(Problem(where, "[low, high] with low <= high", f"[{value[0]}, {value[1]}]"))
    if isinstance(config, RegionShapes | BlockWeights | TerrainMix | PeopleMix) and not any(
        getattr(config, name) > 0 for name in type(config).model_fields
    ):
        problems.append(Problem(path, "at least one weight above 0", "all weights 0"))
    if isinstance(config, GeneratorConfig) and config.layout == "track":
        span = len(config.track.units) * config.track.unit_length
        if abs(span - config.size[0]) > 1e-4:
            problems.append(
                Problem(
                    f"{path}.track.units",
                    f"units spanning the scene's width size[0] = {config.size[0]:g} m",
                    f"{len(config.track.units)} units of {config.track.unit_length:g} m = {span:g} m",
                )
            )
    if isinstance(config, GeneratorConfig) and config.layout == "osm" and config.osm is None:
        problems.append(Problem(f"{path}.osm", "an osm table (file, bbox) for layout 'osm'", "none"))
    if (
        isinstance(config, GeneratorConfig)
        and config.layout == "region"
        and config.region.shapes.plaza > 0
        and min(config.size) < MIN_PLAZA_SIDE_M
    ):
        problems.append(Problem(
            f"{path}.size", f"at least {MIN_PLAZA_SIDE_M:g} m on each side for a region scene that may be a "
            "plaza (its islands need the room), or region.shapes.plaza = 0",
            f"[{config.size[0]:g}, {config.size[1]:g}]",
        ))  # fmt: skip
    if isinstance(config, SplitManifest):
        seen: set[str] = set()
        for i, split in enumerate(config.splits):
            if split.name in seen:
                problems.append(
                    Problem(f"{path}.splits[{i}].name", "a split name used once", repr(split.name))
                )
            seen.add(split.name)
    return problems


_RANGE_TYPES = (Range, IntRange, LotRange, Span)


def _is_range(config: BaseModel, name: str, field: object) -> bool:
    """A ``[low, high]`` field. ``GeneratorConfig.size`` has the same type (two floats) but is a
    width and a depth, which may come in any order."""
    if isinstance(config, GeneratorConfig) and name == "size":
        return False
    return field.annotation in _RANGE_TYPES
