"""The stages in order: one scene from a generator config and a seed, and the same stages
re-run on a hand-edited scene (:func:`rebuild`).

Each stage draws only from its own generator (:func:`citygen.seeding.stage_rng`), so
changing how a later stage samples never changes what an earlier one produced. The
task stage (6) picks its start and goal right after the ground, so that the terrain
keeps them flat and placement keeps them clear and connected; it still draws from its
own generator, so its numbering is the order of the spec, not of the calls.

**Rebuilding.** The stages a user edits and re-runs are :data:`STAGES`: ``layout``
(blocks and zones), ``terrain``, ``placement`` (objects), ``agents`` and ``task``.
``rebuild(scene, "placement")`` keeps the scene's layout, terrain and objects as they
are in the file and makes its agents and task again, each stage from the generator it
had when the scene was generated, so rebuilding an unedited scene from any stage gives
its bytes back. The task's *endpoints* (start pose, goal, route; a locomotion task's
start) are chosen with the layout, before the terrain: rebuilding from ``layout`` chooses
them again, rebuilding from any later stage keeps the scene's (a start or goal moved by
hand survives, the terrain and objects made again respect it). The rest of the task
(robot, time limit, tolerances) comes from the config whenever the task stage runs.

**Cities.** ``layout = "city"`` plans the streets (:func:`citygen.generate.city.plan_city`, from
the ``blocks`` stage's generator) and the ground of each city block
(:func:`citygen.generate.city_ground.plan_city_ground`, from the ``ground`` stage's); a traverse
task there runs along the sidewalks and crosswalks (:func:`~citygen.generate.task.street_route`),
and people walk straight lines that stay on walkable ground.

**Tracks.** ``layout = "track"`` (Urban-Tra-Standard) lays :class:`~citygen.spec.config.TrackUnit`
units side by side along +x, one walkable zone each (``unit-1`` ...). The terrain keeps the
even units flat at street level (they are handed to the terrain stage as hard ground) and
fills the uneven ones with WFC tiles of the mix; static and dynamic units get
``placement.count`` objects each, dynamic units ``agents.people`` people each, who walk
inside their unit. A traverse task on a track runs laps: out along the lane a quarter of
the depth from one side, back along the lane a quarter from the other, turning a quarter
of the depth from the ends, until the route is at least ``track.route_length`` long.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from shapely.geometry import LineString, Point
from shapely.geometry.base import BaseGeometry

from citygen._version import __version__
from citygen.errors import GenerationError, Problem, SpecError
from citygen.generate.agents import place_agents
from citygen.generate.blocks import connect_blocks
from citygen.generate.city import plan_city
from citygen.generate.city_furniture import street_furniture
from citygen.generate.city_ground import plan_city_ground
from citygen.generate.city_terrain import city_features
from citygen.generate.ground import ground_margin, plan_ground, plan_region
from citygen.generate.manifests import config_for
from citygen.generate.placement import place_objects
from citygen.generate.signals import place_lights, signalise
from citygen.generate.space import (
    connects,
    free_space,
    grid_path,
    passable_ground,
    pieces,
    walkable_ground,
    zone_polygon,
)
from citygen.generate.task import LEG, Endpoints, choose_endpoints, make_task, robot_clearance, street_route
from citygen.generate.terrain import build_terrain
from citygen.seeding import child, stage_rng
from citygen.spec.config import GeneratorConfig, TaskConfig, TrackConfig
from citygen.spec.scene import SCENE_FORMAT, Bounds, Meta, Scene
from citygen.spec.task import ROBOTS, LocoTask, NavTask, Task, TraverseTask
from citygen.spec.terrain import Terrain
from citygen.spec.zones import Zone

GENERATOR = f"citygen {__version__}"

#: The stages :func:`rebuild` can keep up to, in order.
STAGES = ("layout", "terrain", "placement", "agents", "task")


def layout(
    config: GeneratorConfig, seed: int, *, split: str | None = None, index: int | None = None
) -> Scene:
    """Stages 1 and 2: the road blocks (for ``layout="blocks"`` and ``"city"``) and the zones of a scene."""
    bounds = Bounds(min=(0.0, 0.0), max=config.size)
    blocks: tuple = ()
    signals = None
    if config.layout == "blocks":
        blocks = connect_blocks(
            bounds, config.blocks, stage_rng(seed, "blocks"), seed=seed, margin=ground_margin(config.ground)
        )
        zones = plan_ground(bounds, blocks, config.ground, stage_rng(seed, "ground"), seed=seed)
    elif config.layout == "city":
        plan = plan_city(
            bounds, config.city, config.blocks, config.ground, stage_rng(seed, "blocks"), seed=seed
        )
        blocks = plan.blocks
        zones = plan_city_ground(
            bounds, plan, config.ground, config.city, stage_rng(seed, "ground"), seed=seed
        )
        signals = signalise(blocks, zones)
    elif config.layout == "region":
        zones = plan_region(bounds, config.region, stage_rng(seed, "ground"), seed=seed)
    elif config.layout == "track":
        zones = track_zones(bounds, config.track, seed=seed)
    else:
        zones = ()
    meta = Meta(generator=GENERATOR, split=split, index=index, seed=seed)
    return Scene(format=SCENE_FORMAT, meta=meta, bounds=bounds, blocks=blocks, zones=zones, signals=signals)


def generate(
    config: GeneratorConfig, seed: int, *, split: str | None = None, index: int | None = None
) -> Scene:
    """Every stage: :func:`layout` (blocks, ground), the task's endpoints, the terrain grid
    (WFC inside the zones, or the locomotion curriculum), objects, agents and the task.

    ``index`` (the scene's place in its split) picks the density levels of objects and
    agents: level ``index % len(levels)``.
    """
    return _finish(layout(config, seed, split=split, index=index), config, seed, keep=0)


def rebuild(
    scene: Scene, from_stage: str, config: GeneratorConfig | None = None, *, seed: int | None = None
) -> Scene:
    """The scene with every stage after ``from_stage`` made again (see the module docstring).

    ``from_stage`` is the last stage kept: one of :data:`STAGES`. ``config`` is the generator
    config the scene came from; by default the config of the named split in its
    ``meta.split`` (:func:`~citygen.generate.manifests.config_for`). ``seed`` is the scene's own
    seed; by default its ``meta.seed``. The density level is that of ``meta.index``.

    Raises :class:`~citygen.errors.SpecError` when the stage is unknown or the config or seed
    cannot be found, :class:`~citygen.errors.GenerationError` when a stage fails.

    >>> import citygen
    >>> scene = citygen.generate("urban-nav-3-train", index=2)
    >>> edited = scene.model_copy(update={"placements": scene.placements[1:]})
    >>> again = rebuild(edited, "placement")
    >>> again.placements == edited.placements, rebuild(scene, "layout") == scene
    (True, True)
    """
    if from_stage not in STAGES:
        raise SpecError([Problem("--from", f"one of {', '.join(STAGES)}", repr(from_stage))])
    if config is None:
        config = config_for(scene)
    if seed is None:
        seed = scene.meta.seed
        if seed is None:
            raise SpecError([Problem("$.meta.seed", "the scene's seed (or give one: --seed S)", "none")])
    keep = STAGES.index(from_stage)
    if seed != scene.meta.seed:
        scene = scene.model_copy(update={"meta": scene.meta.model_copy(update={"seed": seed})})
    if keep == len(STAGES) - 1:
        return scene
    scene = scene.model_copy(update={"meta": scene.meta.model_copy(update={"generator": GENERATOR})})
    return _finish(scene, config, seed, keep=keep)


def _finish(scene: Scene, config: GeneratorConfig, seed: int, *, keep: int) -> Scene:
    """Stages after ``STAGES[keep]`` on ``scene``, which holds the outputs of those up to it."""
    k = scene.meta.index or 0
    bounds = scene.bounds
    # The walkable ground, shared by the task, placement and agent stages.
    walkable = walkable_ground(scene.zones, (*bounds.min, *bounds.max))
    kept_task = scene.task if keep >= 1 else None
    track = _Track(scene, config.track, seed) if config.layout == "track" else None
    if kept_task is not None:
        ends = endpoints_of(kept_task, config.task)
    elif track is not None and config.task.kind == "traverse":
        ends = track.laps(config.task)
    elif config.layout == "city" and config.task.kind == "traverse":
        ends = street_route(bounds, scene.zones, config.task, stage_rng(seed, "task"), seed=seed)
    else:
        ends = choose_endpoints(
            bounds, scene.zones, config.task, stage_rng(seed, "task"), seed=seed, walkable=walkable
        )
    crossed = None  # the ground the task's robot crosses on the terrain, when found on the way
    if keep >= 1:
        terrain = scene.terrain
    else:
        pins = ends.points if ends is not None else ()
        zones = scene.zones
        if track is not None:
            # The robot starts on flat ground; the rest of its laps cross the uneven units.
            pins = [ends.start] if ends is not None and ends.route else pins
            zones = (*track.even_ground(), *zones)
        terrain = build_terrain(
            bounds, zones, config.terrain, stage_rng(seed, "terrain"), seed=seed, flat_at=pins
        )
        if track is None and ends is not None and ends.needs_path:
            terrain, crossed = keep_crossable(bounds, zones, terrain, walkable, ends, config, seed, pins)
        if config.layout == "city":
            rng = child(stage_rng(seed, "terrain"), 3)
            terrain = city_features(zones, terrain, rng, keep_clear=_corridor(ends))
            crossed = None  # the features change what the robot crosses
    # The ground the task's robot can cross: walkable zones less the tiles it cannot cross.
    passable = walkable
    if ends is not None and ends.needs_path:
        passable = (
            crossed if crossed is not None else passable_ground(walkable, terrain, ROBOTS[config.task.robot])
        )
    if keep >= 2:
        placements = scene.placements
    elif track is not None:
        placements = track.objects(terrain, config, _level(config.placement.density_levels, k), ends)
    else:
        placements = place_objects(
            bounds,
            scene.zones,
            terrain,
            config.placement,
            stage_rng(seed, "placement"),
            level=_level(config.placement.density_levels, k),
            ends=ends,
            seed=seed,
            walkable=passable,
        )
        if config.layout == "city":
            rng = child(stage_rng(seed, "placement"), 300)
            placements = street_furniture(scene.zones, terrain, placements, rng, keep_clear=_corridor(ends))
        if scene.signals:
            placements = place_lights(scene.signals, scene.zones, placements, terrain)
    if keep >= 3:
        agents = scene.agents
    elif track is not None:
        agents = track.people(placements, config, _level(config.agents.density_levels, k), ends)
    else:
        agents = place_agents(
            bounds,
            scene.zones,
            scene.blocks,
            placements,
            config.agents,
            stage_rng(seed, "agents"),
            level=_level(config.agents.density_levels, k),
            ends=ends,
            robot_radius=robot_clearance(config.task),
            seed=seed,
            walkable=walkable,
            straight=config.layout == "city",
        )
    task = _task(config.task, ends, terrain, seed, kept_task)
    return scene.model_copy(
        update={"terrain": terrain, "placements": placements, "agents": agents, "task": task}
    )


def keep_crossable(
    bounds: Bounds,
    zones: Sequence[Zone],
    terrain: Terrain | None,
    walkable: BaseGeometry,
    ends: Endpoints,
    config: GeneratorConfig,
    seed: int,
    pins: Sequence[tuple[float, float]],
) -> tuple[Terrain | None, BaseGeometry | None]:
    """The terrain, or when it cuts the task's start from its goal for the task's robot
    (a flight of stairs across the scene for wheels, a slope steeper than it climbs, rough
    ground too bumpy), the terrain made again with a corridor of ground that robot crosses
    along a shortest walkable path between them (:func:`build_terrain`'s ``corridor``): the
    rest of the terrain keeps its stairs, slopes and rough tiles. The same seed gives the
    same corridor and terrain. Also the ground the robot can cross on the terrain returned
    (:func:`passable_ground`) where it was found on the way, else None."""
    mobility = ROBOTS[config.task.robot]
    passable = passable_ground(walkable, terrain, mobility)
    if terrain is None or connects(passable, ends.radius, ends.start, ends.goal):
        return terrain, passable
    piece = next(
        (p for p in pieces(free_space(walkable, (), ends.radius)) if p.covers(Point(ends.start))), None
    )
    path = grid_path(piece, ends.start, ends.goal) if piece is not None else None
    if path is None:  # not connected on walkable ground either: placement reports it
        return terrain, passable
    corridor = LineString(path).buffer(ends.radius, quad_segs=4)
    terrain = build_terrain(
        bounds,
        zones,
        config.terrain,
        stage_rng(seed, "terrain"),
        seed=seed,
        flat_at=pins,
        corridor=corridor,
        mobility=mobility,
    )
    return terrain, None


def _corridor(ends: Endpoints | None) -> BaseGeometry | None:
    """The ground a city's features keep clear of: the robot's corridor along the route."""
    if ends is None:
        return None
    line = LineString([ends.start, *ends.route]) if ends.route else LineString([ends.start, ends.start])
    return line.buffer(ends.radius + 0.3, quad_segs=4)


def _level(levels: tuple[float, ...], index: int) -> float:
    return levels[index % len(levels)]


# --- the task's endpoints in a scene ---------------------------------------------------------


def _family(kind: str) -> str:
    return "loco" if kind.startswith("loco-") else ("traverse" if kind == "traverse" else "nav")


def endpoints_of(task: Task, cfg: TaskConfig) -> Endpoints | None:
    """The endpoints a scene's task holds (None for locomotion tasks, whose start the task
    stage keeps itself), with the clearance of the config's robot.

    Raises :class:`~citygen.errors.SpecError` when the task is of another family (navigation,
    traverse, locomotion) than the config's: its endpoints cannot serve that task.
    """
    if _family(task.kind) != _family(cfg.kind):
        raise SpecError(
            [
                Problem(
                    "$.task.kind",
                    f"a task of the config's kind {cfg.kind!r} (rebuild from layout to choose new endpoints)",
                    repr(task.kind),
                )
            ]
        )
    radius = robot_clearance(cfg)
    start, yaw = task.start.position, task.start.yaw
    if isinstance(task, NavTask):
        return Endpoints(start, yaw, task.goal, radius=radius)
    if isinstance(task, TraverseTask):
        return Endpoints(start, yaw, None, task.route, radius=radius)
    return None


def _task(
    cfg: TaskConfig, ends: Endpoints | None, terrain: Terrain | None, seed: int, kept: Task | None
) -> Task:
    """Stage 6: the task model from the endpoints; a kept locomotion task keeps its start pose
    and command."""
    if ends is None and terrain is None:
        raise GenerationError("task", seed, f"a {cfg.kind} task needs a terrain grid to start on")
    task = make_task(cfg, ends, terrain, child(stage_rng(seed, "task"), 1))
    if isinstance(kept, LocoTask) and isinstance(task, LocoTask):
        task = task.model_copy(update={"start": kept.start, "command": kept.command})
    return task


# --- tracks -----------------------------------------------------------------------------------


def _unit_box(bounds: Bounds, cfg: TrackConfig, u: int) -> Bounds:
    x0 = bounds.min[0] + u * cfg.unit_length
    return Bounds(min=(x0, bounds.min[1]), max=(x0 + cfg.unit_length, bounds.max[1]))


def _rect(b: Bounds) -> tuple[tuple[float, float], ...]:
    (x0, y0), (x1, y1) = b.min, b.max
    return ((x0, y0), (x1, y0), (x1, y1), (x0, y1))


def track_zones(bounds: Bounds, cfg: TrackConfig, *, seed: int | None = None) -> tuple[Zone, ...]:
    """One walkable zone per unit of a track, ``unit-1`` at the minimum x onwards.

    >>> from citygen.spec.config import TrackConfig
    >>> zones = track_zones(Bounds(min=(0, 0), max=(120, 10)), TrackConfig())
    >>> [z.id for z in zones][:2], zones[5].polygon[1], zones[0].kind
    (['unit-1', 'unit-2'], (120.0, 0.0), 'plaza')
    """
    span = len(cfg.units) * cfg.unit_length
    if abs(span - bounds.size[0]) > 1e-4:
        raise GenerationError(
            "ground",
            seed,
            f"{len(cfg.units)} track units of {cfg.unit_length:g} m span {span:g} m, "
            f"not the scene's width of {bounds.size[0]:g} m",
        )
    return tuple(
        Zone(id=f"unit-{u + 1}", kind=unit.zone, polygon=_rect(_unit_box(bounds, cfg, u)))
        for u, unit in enumerate(cfg.units)
    )


class _Track:
    """The stages of a track scene that go unit by unit."""

    def __init__(self, scene: Scene, cfg: TrackConfig, seed: int):
        self.cfg, self.seed, self.bounds = cfg, seed, scene.bounds
        span = len(cfg.units) * cfg.unit_length
        if abs(span - scene.bounds.size[0]) > 1e-4:
            raise GenerationError(
                "ground",
                seed,
                f"the config's {len(cfg.units)} track units of {cfg.unit_length:g} m span {span:g} m, "
                f"not the scene's width of {scene.bounds.size[0]:g} m",
            )
        self.boxes = [_unit_box(scene.bounds, cfg, u) for u in range(len(cfg.units))]
        # A unit's zones: those whose inner point lies in it (the unit's own zone, or what a
        # hand edit divided it into).
        inner = [zone_polygon(z).representative_point() for z in scene.zones]
        self.zones = [
            tuple(
                z
                for z, p in zip(scene.zones, inner, strict=True)
                if b.min[0] <= p.x <= b.max[0] and b.min[1] <= p.y <= b.max[1]
            )
            for b in self.boxes
        ]

    def even_ground(self) -> list[Zone]:
        """The even units as hard ground for the terrain stage, which keeps it flat at 0 m
        (the kind is one of :data:`citygen.generate.terrain.HARD_ZONES`); never in the scene."""
        return [
            Zone(id=f"even-{u + 1}", kind="roadway", polygon=_rect(b))
            for u, (unit, b) in enumerate(zip(self.cfg.units, self.boxes, strict=True))
            if unit.surface == "even"
        ]

    def laps(self, task: TaskConfig) -> Endpoints:
        """The traverse route: laps of the track (see the module docstring), legs of at most
        :data:`~citygen.generate.task.LEG` metres, ending where it starts."""
        (x0, y0), (x1, y1) = self.bounds.min, self.bounds.max
        radius = robot_clearance(task)
        lane = (y1 - y0) / 4
        if lane < radius or x1 - x0 <= 2 * lane:
            raise GenerationError(
                "task",
                self.seed,
                f"a {x1 - x0:g} m x {y1 - y0:g} m track has no room for two lanes of laps for the "
                f"{task.robot} robot ({2 * radius:g} m across); make the track deeper",
            )
        corners = [
            (x0 + lane, y0 + lane),
            (x1 - lane, y0 + lane),
            (x1 - lane, y1 - lane),
            (x0 + lane, y1 - lane),
        ]
        lap = 2 * (x1 - x0 - 2 * lane) + 2 * (y1 - y0 - 2 * lane)
        laps = max(1, math.ceil(self.cfg.route_length / lap - 1e-9))
        route: list[tuple[float, float]] = []
        here = corners[0]
        for _ in range(laps):
            for there in (*corners[1:], corners[0]):
                n = max(1, math.ceil(math.dist(here, there) / LEG - 1e-9))
                route += [
                    (here[0] + (there[0] - here[0]) * j / n, here[1] + (there[1] - here[1]) * j / n)
                    for j in range(1, n + 1)
                ]
                here = there
        rounded = tuple((round(x, 3) + 0.0, round(y, 3) + 0.0) for x, y in route)
        start = (round(corners[0][0], 3) + 0.0, round(corners[0][1], 3) + 0.0)
        return Endpoints(start, 0.0, None, rounded, radius=radius)

    def _units(self, settings: Sequence[str]) -> list[int]:
        return [u for u, unit in enumerate(self.cfg.units) if unit.setting in settings]

    def _walkable(self, u: int) -> BaseGeometry:
        b = self.boxes[u]
        return walkable_ground(self.zones[u], (*b.min, *b.max))

    def objects(self, terrain: Terrain, config: GeneratorConfig, level: float, ends: Endpoints | None):
        """Stage 4 in every static and dynamic unit, each from its own child generator."""
        rng = stage_rng(self.seed, "placement")
        found = []
        for u in self._units(("static", "dynamic")):
            found += place_objects(
                self.boxes[u],
                self.zones[u],
                terrain,
                config.placement,
                child(rng, u),
                level=level,
                ends=ends,
                seed=self.seed,
                walkable=self._walkable(u),
            )
        return _renumbered(found)

    def people(self, placements, config: GeneratorConfig, level: float, ends: Endpoints | None):
        """Stage 5 in every dynamic unit: people who start and end in it."""
        rng = stage_rng(self.seed, "agents")
        found = []
        for u in self._units(("dynamic",)):
            found += place_agents(
                self.boxes[u],
                self.zones[u],
                (),
                placements,
                config.agents,
                child(rng, u),
                level=level,
                ends=ends,
                robot_radius=robot_clearance(config.task),
                seed=self.seed,
                walkable=self._walkable(u),
            )
        return _renumbered(found)


def _renumbered(items: list) -> tuple:
    """Items of several units with ids numbered across the scene (``bench-3``), in order."""
    counts: dict[str, int] = {}
    out = []
    for item in items:
        stem = item.id.rpartition("-")[0] or item.id
        counts[stem] = counts.get(stem, 0) + 1
        out.append(item.model_copy(update={"id": f"{stem}-{counts[stem]}"}))
    return tuple(out)
