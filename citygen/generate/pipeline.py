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
are in the file (an object left floating or buried by an edit is seated on the ground
under it) and makes its agents and task again, each stage from the generator it
had when the scene was generated, so rebuilding an unedited scene from any stage gives
its bytes back. The task's *endpoints* (start pose, goal, route; a locomotion task's
start) are chosen with the layout, before the terrain: rebuilding from ``layout`` chooses
them again, rebuilding from any later stage keeps the scene's (a start or goal moved by
hand survives, the terrain and objects made again respect it). The rest of the task
(robot, time limit, tolerances) comes from the config whenever the task stage runs.

**Layouts.** What differs between the kinds of scene (``config.layout``: a region, road
blocks, a locomotion curriculum, a track, a city) lives in its layout
(:mod:`citygen.generate.layouts`): its ground plan (stages 1 and 2) and any stage it runs
its own way. This module runs the stages in order for every layout.
"""

from __future__ import annotations

import warnings
from collections.abc import Callable
from contextvars import ContextVar

from citygen._version import __version__
from citygen.errors import GenerationError, Problem, SpecError
from citygen.generate.layouts import LAYOUTS
from citygen.generate.manifests import config_for
from citygen.generate.space import passable_ground, walkable_ground
from citygen.generate.task import Endpoints, make_task, robot_clearance
from citygen.seeding import child, stage_rng
from citygen.spec.config import GeneratorConfig, TaskConfig
from citygen.spec.scene import SCENE_FORMAT, Bounds, Meta, Scene
from citygen.spec.task import ROBOTS, LocoTask, NavTask, Task, TraverseTask
from citygen.spec.terrain import Terrain
from citygen.validate import reseated

GENERATOR = f"citygen {__version__}"

#: The stages :func:`rebuild` can keep up to, in order.
STAGES = ("layout", "terrain", "placement", "agents", "task")

#: Called with a stage's name as it starts, in this context (``citygen generate``'s progress on
#: one large scene: a city takes half a minute); None: nothing is said.
on_stage: ContextVar[Callable[[str], None] | None] = ContextVar("citygen_on_stage", default=None)


def _starting(stage: str) -> None:
    hook = on_stage.get()
    if hook is not None:
        hook(stage)


def layout(
    config: GeneratorConfig, seed: int, *, split: str | None = None, index: int | None = None
) -> Scene:
    """Stages 1 and 2: the road blocks (for ``layout="blocks"`` and ``"city"``) and the zones of a
    scene, as its layout (:data:`~citygen.generate.layouts.LAYOUTS`) plans them."""
    bounds = Bounds(min=(0.0, 0.0), max=config.size)
    _starting("layout")
    plan = LAYOUTS[config.layout].plan(bounds, config, seed)
    meta = Meta(generator=GENERATOR, split=split, index=index, seed=seed, source=plan.source)
    return Scene(
        format=SCENE_FORMAT,
        meta=meta,
        bounds=plan.bounds or bounds,
        blocks=plan.blocks,
        zones=plan.zones,
        signals=plan.signals,
    )


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
    stages = LAYOUTS[config.layout](scene, config, seed)
    ends = endpoints_of(kept_task, config.task) if kept_task is not None else stages.endpoints(walkable)
    crossed = None  # the ground the task's robot crosses on the terrain, when found on the way
    if keep >= 1:
        terrain = scene.terrain
    else:
        _starting("terrain")
        terrain, crossed = stages.terrain(ends, walkable)
    # The ground the task's robot can cross: walkable zones less the tiles it cannot cross.
    passable = walkable
    if ends is not None and ends.needs_path:
        passable = (
            crossed if crossed is not None else passable_ground(walkable, terrain, ROBOTS[config.task.robot])
        )
    if keep >= 2:  # kept, each object seated on the (perhaps edited) ground under it
        placements = reseated(scene)
    else:
        _starting("placement")
        placements = stages.objects(terrain, ends, passable, _level(config.placement.density_levels, k))
    if keep >= 3:
        agents = scene.agents
    else:
        _starting("agents")
        agents = stages.people(placements, ends, walkable, _level(config.agents.density_levels, k))
    _starting("task")
    task = _task(config.task, ends, terrain, seed, kept_task)
    return scene.model_copy(
        update={"terrain": terrain, "placements": placements, "agents": agents, "task": task}
    )


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


def __getattr__(name: str):
    """``keep_crossable`` and ``track_zones``, moved to :mod:`citygen.generate.layouts` (the old
    names warn, for one release)."""
    from citygen.generate.layouts import base, track

    moved = {"keep_crossable": base, "track_zones": track}
    if name in moved:
        module = moved[name]
        warnings.warn(
            f"citygen.generate.pipeline.{name} moved to {module.__name__}.{name}; "
            "the old name goes in the next release",
            DeprecationWarning,
            stacklevel=2,
        )
        return getattr(module, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
