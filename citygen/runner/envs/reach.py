"""Collision detection near the robot only, for scenes of city scale (issue 45).

Every physics step MuJoCo's broadphase goes over every body that may collide, by the bits
(``body_contype``, ``body_conaffinity``) each body's geoms gave it at compile time. On
urban-tra-city (118,000 geoms, 7,900 static object bodies) that was more than half of the
physics' time (235 of 426 ms a control step, on the shared 2-core machine), though the
static world (ground, objects, buildings: bodies welded to the world, which never move and
only ever touch the robot) cannot touch the robot where it is farther from it than the robot
can travel in a control step. :class:`Reach` takes those static geoms, and the static bodies
all of whose geoms they are, out of collision detection (``contype`` and ``conaffinity`` 0 on
both) for the duration of an environment's physics call and puts them back after it, so the
model is whole whenever anything else reads it: a spawn's contacts, another environment of
the process stepping the same compiled scene, a pickle for the on-disk store. The city's
broadphase then costs 30 ms a control step; MuJoCo's kinematics of every body and geom, which
no flag skips, is what remains of the physics. (A town's and a city's static bodies are now
fused into the world at compile time, :func:`citygen.runner.robots.handle.compose`, and
there :func:`reach_of` leaves the model whole: the world's bounding-volume tree already
tests only the geoms near the robot, and the bits' copies cost more than they saved; the
reach applies to models compiled otherwise.)

What changes: nothing MuJoCo computes. The geoms left out are those whose bounding sphere
(grown by its margin) lies more than :data:`SLACK` m beyond the robot's own bounding sphere
(grown by its margins and :data:`LIMB_SLACK`), and the kept set is re-centred when the robot
has moved :data:`SLACK` / 2 from its centre (checked before every control step: a robot would
have to cover 5 m in one 0.1 s step to reach a geom left out), so the broadphase finds the
same pairs, the same contacts follow and every step's state is the same to the bit
(``tests/test_reach.py``). Moving agents (mocap bodies), the world body itself and planes are
never left out. Scenes with fewer than :data:`FROM_GEOMS` static geoms (the Urban-Nav squares,
the locomotion grids) are left as they are: there the copies would cost more than they save.
"""

from __future__ import annotations

import contextlib
import math
from typing import Any

import numpy as np

#: Metres of travel the kept geoms allow beyond the robot's reach; re-centred after half of it.
SLACK = 10.0
#: Static collidable geoms from which a scene's collisions are restricted to the robot's reach.
FROM_GEOMS = 2000
#: Metres added to the robot's bounding radius measured in its default pose (legs swing).
LIMB_SLACK = 0.5


class Reach:
    """The static geoms near a robot, in and out of MuJoCo's collision detection.

    ``with reach.near(data): mj_step(...)`` steps with only the static geoms near the robot's
    base (body ``base_id``) collidable; outside the ``with`` the model is untouched. Build one
    with :func:`reach_of`, which says None for a scene too small to gain from it."""

    def __init__(self, model: Any, static: np.ndarray, centres: np.ndarray, reach: float, base_id: int):
        self.model = model
        self.base_id = int(base_id)
        self.static = np.flatnonzero(static)
        self.centres = centres[self.static, :2].copy()
        grown = model.geom_rbound[self.static] + model.geom_margin[self.static]
        self.reach = float(reach)
        self.radius = grown + self.reach + SLACK
        """Per static geom: the base's farthest distance (m) at which it must stay collidable."""
        self.contype = np.array(model.geom_contype)
        self.conaffinity = np.array(model.geom_conaffinity)
        self._near_contype = self.contype.copy()
        self._near_conaffinity = self.conaffinity.copy()
        # MuJoCo's broadphase filters body pairs by the bodies' own contype and conaffinity
        # (each its geoms' bits or-ed at compile time): a static body whose geoms are all
        # left out is left out too, or the broadphase still sorts it. Never the world body.
        self.bodies = np.unique(model.geom_bodyid[self.static])
        self.bodies = self.bodies[self.bodies != 0]
        self._geom_body = np.searchsorted(self.bodies, model.geom_bodyid[self.static])
        self._in_bodies = model.geom_bodyid[self.static] != 0
        self.body_contype = np.array(model.body_contype)
        self.body_conaffinity = np.array(model.body_conaffinity)
        self._near_body_contype = self.body_contype.copy()
        self._near_body_conaffinity = self.body_conaffinity.copy()
        self.centre: tuple[float, float] | None = None
        self.kept = 0
        """Static geoms kept collidable around :attr:`centre`."""
        self.kept_bodies = 0
        """Static bodies (other than the world) kept collidable around :attr:`centre`."""

    def centre_on(self, x: float, y: float) -> None:
        """Keep collidable the static geoms within the robot's reach plus :data:`SLACK` of ``(x, y)``."""
        away = np.hypot(self.centres[:, 0] - x, self.centres[:, 1] - y) > self.radius
        far = self.static[away]
        self._near_contype[:] = self.contype
        self._near_conaffinity[:] = self.conaffinity
        self._near_contype[far] = 0
        self._near_conaffinity[far] = 0
        kept = np.bincount(self._geom_body[self._in_bodies & ~away], minlength=len(self.bodies))
        far_bodies = self.bodies[kept == 0]
        self._near_body_contype[:] = self.body_contype
        self._near_body_conaffinity[:] = self.body_conaffinity
        self._near_body_contype[far_bodies] = 0
        self._near_body_conaffinity[far_bodies] = 0
        self.centre = (x, y)
        self.kept = len(self.static) - len(far)
        self.kept_bodies = len(self.bodies) - len(far_bodies)

    def near(self, data: Any) -> _Near:
        """A context for one control step's physics from ``data``'s state (re-centred if due)."""
        x, y = data.xpos[self.base_id, :2].tolist()
        c = self.centre
        if c is None or math.hypot(x - c[0], y - c[1]) > SLACK / 2:
            self.centre_on(x, y)
        return _Near(self)


_WHOLE = contextlib.nullcontext()


def near(reach: Reach | None, data: Any) -> Any:
    """``reach.near(data)``, or a context that changes nothing when ``reach`` is None."""
    return _WHOLE if reach is None else reach.near(data)


class _Near:
    __slots__ = ("reach",)

    def __init__(self, reach: Reach):
        self.reach = reach

    def __enter__(self) -> None:
        r, m = self.reach, self.reach.model
        m.geom_contype[:] = r._near_contype
        m.geom_conaffinity[:] = r._near_conaffinity
        m.body_contype[:] = r._near_body_contype
        m.body_conaffinity[:] = r._near_body_conaffinity

    def __exit__(self, *exc: object) -> None:
        r, m = self.reach, self.reach.model
        m.geom_contype[:] = r.contype
        m.geom_conaffinity[:] = r.conaffinity
        m.body_contype[:] = r.body_contype
        m.body_conaffinity[:] = r.body_conaffinity


def static_geoms(model: Any) -> np.ndarray:
    """bool per geom: collidable, not a plane, of a body welded to the world and not mocap."""
    import mujoco

    body = model.geom_bodyid
    return (
        (model.body_weldid[body] == 0)
        & (model.body_mocapid[body] < 0)
        & ((model.geom_contype != 0) | (model.geom_conaffinity != 0))
        & (model.geom_type != int(mujoco.mjtGeom.mjGEOM_PLANE))  # int: an enum compares per element
    )


def reach_of(model: Any, data: Any, robot_geom_ids: np.ndarray, base_id: int) -> Reach | None:
    """The :class:`Reach` of a robot (its geoms ``robot_geom_ids``, its base body ``base_id``)
    in ``model``, or None when the scene has fewer than :data:`FROM_GEOMS` static geoms or
    all of them are the world body's (a town's or a city's model, its static bodies fused
    into the world: MuJoCo pairs the world with a moving body once and descends the world's
    bounding-volume tree, testing only the geoms near that body, so leaving far geoms out
    saved nothing, and copying their bits in and out cost a city's control step 1.1 ms, 11.3
    against 10.2 ms of CPU). ``data`` is a fresh MjData of ``model`` (its kinematics are
    computed in the default pose, where static geoms are where they always are)."""
    import mujoco

    static = static_geoms(model)
    static[np.asarray(robot_geom_ids, dtype=np.int64)] = False
    if int(static.sum()) < FROM_GEOMS or not (model.geom_bodyid[static] != 0).any():
        return None
    mujoco.mj_kinematics(model, data)
    ids = np.asarray(robot_geom_ids, dtype=np.int64)
    offsets = np.linalg.norm(data.geom_xpos[ids] - data.xpos[base_id], axis=1)
    reach = float(np.max(offsets + model.geom_rbound[ids] + model.geom_margin[ids], initial=0.0))
    return Reach(model, static, np.array(data.geom_xpos), reach + LIMB_SLACK, base_id)
