"""A scene's maps for the runner (:class:`Maps`): its occupancy map, the cells a robot can
cross (:func:`crossable_cells`) and those its centre may occupy (:func:`free_cells`), and,
for a scene with people, their crowd's path tables
(:meth:`~citygen.runner.agents.crowd.Crowd.tables`), made in this process
(:func:`build_maps`, the plain reference) or, for a scene of :data:`PROCESS_FROM_CELLS` map
cells or more, in a second process while this one builds and compiles the scene's MuJoCo
model (:class:`MapsProcess`).

They are numpy and shapely work that needs nothing of the model, where the model is
MuJoCo's parser and compiler, which hold the GIL (threads would not overlap them): on a
1.2 km city the maps are some 12 s of CPU of a first reset's 40, the model the rest, so on
two cores the maps cost a first reset nothing but the time to send them back (the same
arrays, to the bit: ``tests/test_scene_maps.py``). The second process starts a fresh
interpreter (``spawn``) and runs nothing of the main script; an error in it is raised here,
the same exception with the second process's traceback as a note.
"""

from __future__ import annotations

import contextlib
import dataclasses
import math
import multiprocessing as mp
import pickle
import sys
import threading
import traceback
from dataclasses import dataclass
from typing import Any

import numpy as np

from citygen.spec import Scene
from citygen.spec.agents import Person
from citygen.spec.task import ROBOTS, Mobility
from citygen.spec.terrain import Terrain

#: Map cells (rows x cols) from which a scene's maps are made in a second process: a town's
#: (16 M cells at 0.1 m: 4 s of CPU) and a city's (9 M at 0.4 m, with 200 people's path
#: tables: 12 s); starting the process costs about a second of the other core (its imports),
#: more than an Urban-Nav square's maps (40,000 cells) take.
PROCESS_FROM_CELLS = 1 << 22


@dataclass(frozen=True)
class Mover:
    """What the maps need of a robot (:func:`mobility_of` and :func:`free_cells`): its name,
    radius (m) and highest step (m); a robot itself, with its model and assets, need not
    travel to the second process."""

    name: str
    radius: float
    max_step: float

    @classmethod
    def of(cls, robot: Any) -> Mover:
        return cls(str(robot.name), float(robot.radius), float(robot.max_step))


@dataclass(eq=False)
class Maps:
    """A scene's maps for one robot (see the module docstring); ``tables`` None for a scene
    without people or when they were not asked for."""

    occupancy: Any  # citygen.exporters.occupancy.OccupancyMap
    crossable: np.ndarray
    free: np.ndarray
    walkable: np.ndarray
    tables: dict[str, np.ndarray] | None = None


def has_people(scene: Scene) -> bool:
    return any(isinstance(a, Person) for a in scene.agents)


def build_maps(scene: Scene, robot: Any, resolution: float, people: bool = False) -> Maps:
    """The maps of ``scene`` for ``robot`` (a robot or a :class:`Mover`) with cells of
    ``resolution`` m (:func:`~citygen.runner.scenes.map_resolution`), in this process;
    ``people``: the crowd's path tables too, when the scene has people."""
    from citygen.exporters.occupancy import occupancy

    occ = occupancy(scene, resolution)
    crossable = crossable_cells(occ, robot, scene.terrain)
    maps = Maps(
        occupancy=occ,
        crossable=crossable,
        free=free_cells(occ, robot, crossable=crossable),
        walkable=occ.walkable_mask(),
    )
    if people and has_people(scene):
        from citygen.runner.agents.crowd import Crowd

        # What the constructor computes from the scene and its map alone; the rng and the
        # step only start an episode, which crowd_of does again on the tables.
        maps.tables = dict(Crowd(scene, occ, rng=np.random.default_rng(0), dt=0.1).tables())
    return maps


def worth_a_process(scene: Scene, resolution: float) -> bool:
    """Whether ``scene``'s map of ``resolution`` m cells has :data:`PROCESS_FROM_CELLS` cells
    or more and this process may start one (a daemonic process may not: a vector
    environment's worker)."""
    if mp.current_process().daemon:
        return False
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    return (x1 - x0) * (y1 - y0) / (resolution * resolution) >= PROCESS_FROM_CELLS


def step_edges(heights: np.ndarray, max_step: float) -> np.ndarray:
    """Cells next to a rise of more than ``max_step`` (m) to a 4-neighbour: stair risers,
    curbs, terrain a robot cannot drive or walk over."""
    out = np.zeros(heights.shape, dtype=bool)
    dy = np.abs(np.diff(heights, axis=0)) > max_step
    dx = np.abs(np.diff(heights, axis=1)) > max_step
    out[1:] |= dy
    out[:-1] |= dy
    out[:, 1:] |= dx
    out[:, :-1] |= dx
    return out


def mobility_of(robot: Any) -> Mobility:
    """What ground ``robot`` crosses: a built-in embodiment's :data:`~citygen.spec.task.ROBOTS`
    entry (with the robot's own radius and highest step); a user's robot climbs whatever its
    ``max_step`` allows (stairs and slopes limited only by the edges they make)."""
    base = ROBOTS.get(robot.name)
    if base is None:
        return Mobility(radius=robot.radius, max_step=robot.max_step, max_slope=math.pi / 2, stairs=True)
    return dataclasses.replace(base, radius=robot.radius, max_step=robot.max_step)


def crossable_cells(occ: Any, robot: Any, terrain: Terrain | None = None) -> np.ndarray:
    """The ground ``robot`` can cross: walkable cells off every edge higher than its
    :attr:`~citygen.runner.robots.Robot.max_step` and off the tiles of ``terrain`` it cannot
    cross (stairs for wheels, slopes steeper than it climbs, rough ground too bumpy:
    :func:`citygen.geometry.traversable.tile_crossable`)."""
    from citygen.geometry.traversable import blocked_cells

    ok = occ.walkable_mask() & ~step_edges(occ.heights, robot.max_step)
    if terrain is not None:
        ok &= ~blocked_cells(terrain, mobility_of(robot), occ.grid.xs(), occ.grid.ys())
    return ok


def free_cells(
    occ: Any, robot: Any, terrain: Terrain | None = None, crossable: np.ndarray | None = None
) -> np.ndarray:
    """Where the robot's centre may be: :func:`crossable_cells` (given, or computed) at
    least its radius from anything else."""
    from citygen.geometry.raster import erode

    ok = crossable_cells(occ, robot, terrain) if crossable is None else crossable
    return erode(ok, robot.radius / occ.resolution)


class MapsProcess:
    """:func:`build_maps` in a second process, started at once; :meth:`result` waits for its
    :class:`Maps` (the same arrays as :func:`build_maps` in this process) or raises its error.
    ``store``: the on-disk store's folder and the scene's entry key there
    (:mod:`citygen.runner.scene_store`), where the second process keeps the crowd's tables
    (0.6 GB on a city) for :func:`~citygen.runner.agents.crowd.crowd_of` to read, instead of
    sending them here to be written there (a second of this process's time); they are sent
    only when it cannot write them."""

    def __init__(
        self,
        scene: Scene,
        robot: Any,
        resolution: float,
        people: bool = False,
        store: tuple[Any, str] | None = None,
    ):
        ctx = mp.get_context("spawn")
        self._conn, child = ctx.Pipe(duplex=True)
        self._proc = ctx.Process(target=_child, args=(child,), daemon=True, name="citygen-maps")
        with _no_main():
            self._proc.start()
        child.close()
        # The request after the start, by a thread: the pipe takes it as the new interpreter
        # reads it, a second or more after its start, which this process does not wait for.
        request = (scene, Mover.of(robot), resolution, people, store)
        blob = pickle.dumps(request, protocol=pickle.HIGHEST_PROTOCOL)
        self._sender = threading.Thread(target=_send, args=(self._conn, blob), daemon=True)
        self._sender.start()

    def result(self) -> Maps:
        try:
            try:
                kind, header, sizes = self._conn.recv()
                buffers = [_receive(self._conn, n) for n in sizes]
            except (EOFError, OSError):
                self._proc.join(5.0)
                raise RuntimeError(
                    f"prepare: the process making the scene's maps (pid {self._proc.pid}) ended with exit "
                    f"code {self._proc.exitcode} before sending them (killed, or out of memory?)"
                ) from None
            if kind == "error":
                exc, text = header
                exc.add_note(f"In the process making the scene's maps (pid {self._proc.pid}):\n{text}")
                raise exc
            return pickle.loads(header, buffers=buffers)
        finally:
            self.close()

    def close(self) -> None:
        """Stop the process if it still runs (a result not waited for)."""
        if self._proc.is_alive():
            self._proc.terminate()
        self._proc.join(5.0)
        self._sender.join(5.0)
        self._conn.close()


def _receive(conn: Any, size: int) -> memoryview:
    """One out-of-band buffer of ``size`` bytes, read straight into its array's memory."""
    out = np.empty(size, dtype=np.uint8)
    if size:
        conn.recv_bytes_into(out)
    return memoryview(out)


def _send(conn: Any, blob: bytes) -> None:
    with contextlib.suppress(OSError):  # the process ended: result() says how
        conn.send_bytes(blob)


def _child(conn: Any) -> None:
    """The second process: the maps, sent as a pickle whose arrays follow it as raw bytes
    (protocol 5's out-of-band buffers: no copy of a city's path tables into a pickle on
    either side); or the error, with its traceback's text."""
    try:
        scene, robot, resolution, people, store = pickle.loads(conn.recv_bytes())
        maps = build_maps(scene, robot, resolution, people)
        if maps.tables is not None and store is not None:
            from citygen.runner.agents.crowd import save_tables
            from citygen.runner.scene_store import SceneStore

            disk = SceneStore(store[0])
            save_tables(disk, store[1], maps.tables)
            if not disk._unwritable:  # kept there: crowd_of reads them
                maps.tables = None
        buffers: list[pickle.PickleBuffer] = []
        header = pickle.dumps(maps, protocol=5, buffer_callback=buffers.append)
        raws = [b.raw() for b in buffers]
        conn.send(("maps", header, [r.nbytes for r in raws]))
        for raw in raws:
            conn.send_bytes(raw)
    except BaseException as exc:  # every failure goes back to the parent
        text = traceback.format_exc()
        try:
            pickle.loads(pickle.dumps(exc))
        except Exception:  # an exception that does not survive pickling: its text
            exc = RuntimeError(f"{type(exc).__name__}: {exc}")
        with contextlib.suppress(OSError):
            conn.send(("error", (exc, text), []))
    finally:
        conn.close()


@contextlib.contextmanager
def _no_main():
    """Start a process without running the main script again: ``spawn`` imports the main
    module's file (or module) in the child, which would run a script's unguarded code (a
    reset in it, starting this process again); the maps need nothing from it."""
    main = sys.modules.get("__main__")
    if main is None:
        yield
        return
    spec, file = getattr(main, "__spec__", None), getattr(main, "__file__", None)
    main.__spec__ = None  # multiprocessing reads it unguarded
    if file is not None:
        del main.__file__
    try:
        yield
    finally:
        main.__spec__ = spec
        if file is not None:
            main.__file__ = file


__all__ = [
    "PROCESS_FROM_CELLS", "Maps", "MapsProcess", "Mover", "build_maps", "crossable_cells", "free_cells",
    "has_people", "mobility_of", "step_edges", "worth_a_process",
]  # fmt: skip
