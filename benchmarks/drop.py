"""The sphere drop: does a simulator, loading citygen's exports as its docs show, hold a
ball where ``citygen.height_at`` says the ground is?

A grid of :data:`RADIUS` spheres (5 cm across) is dropped from 1 m above the ground,
simulated for 2 s with the simulator's default time step, and each sphere's bottom is
compared with :func:`~citygen.geometry.terrain.height_at` under its centre: **through**
when it ended more than :data:`TOLERANCE` below the ground (it sank in or fell), **resting**
when within :data:`TOLERANCE` of it. Spheres that start or end over an object (its
footprint grown by 10 cm) or an agent are left out: they rest on the object, not the ground.

One function a simulator, each returning the spheres' final centres ``(n, 3)``:
:func:`mujoco_drop` (MJCF), :func:`pybullet_drop` (URDF), :func:`sapien_drop` (URDF, SAPIEN
without a renderer) and :func:`genesis_drop` (URDF or MJCF morph, CPU). The recipes of
``docs/simulators/`` load the scenes the same way; ``benchmarks/bench_simulators.py`` and
``tests/test_simulators.py`` run these.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import shapely

from citygen.assets import resolve
from citygen.exporters.meshes import placement_matrix
from citygen.geometry.terrain import height_at
from citygen.spec.scene import Scene

#: Sphere radius (m): a ball 5 cm across.
RADIUS = 0.05
#: Height (m) above the ground the spheres start at, and seconds simulated.
DROP_HEIGHT, SECONDS = 1.0, 2.0
#: How far (m) from ``height_at`` a sphere's bottom may end and still be resting.
TOLERANCE = 0.03


def drop_points(scene: Scene, per_side: int = 10, inset: float = 0.4) -> np.ndarray:
    """About ``per_side`` squared points on a grid over the scene's bounds (``inset`` m from their
    edges), each point :data:`DROP_HEIGHT` above the ground plus the radius: ``(n, 3)``."""
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    w, h = x1 - x0, y1 - y0
    nx = max(2, round(per_side * math.sqrt(w / h)))
    ny = max(2, round(per_side * per_side / nx))
    xs, ys = np.meshgrid(np.linspace(x0 + inset, x1 - inset, nx), np.linspace(y0 + inset, y1 - inset, ny))
    xy = np.c_[xs.ravel(), ys.ravel()]
    z = height_at(scene, xy[:, 0], xy[:, 1]) + DROP_HEIGHT + RADIUS
    return np.c_[xy, z]


def _objects(scene: Scene, near: np.ndarray) -> shapely.Geometry:
    """Where the spheres may rest on an object or an agent: footprints grown by 10 cm (of
    those within 10 m of the points ``near``, so a city's are not all drawn)."""
    (x0, y0), (x1, y1) = near[:, :2].min(axis=0) - 10.0, near[:, :2].max(axis=0) + 10.0
    shapes = []
    for pl in scene.placements:
        if not (x0 <= pl.position[0] <= x1 and y0 <= pl.position[1] <= y1):
            continue
        if pl.is_mesh:
            shapes.append(shapely.Point(pl.position[:2]).buffer(1.0))
            continue
        outline = np.asarray(resolve(pl.asset).footprint.exterior.coords)
        m = placement_matrix(pl)
        xy = (m[:2, :2] @ outline.T).T + m[:2, 3]
        shapes.append(shapely.Polygon(xy))
    for agent in scene.agents:
        if not (x0 <= agent.start[0] <= x1 and y0 <= agent.start[1] <= y1):
            continue
        shapes.append(shapely.Point(agent.start[:2]).buffer(getattr(agent, "radius", 0.5) + 2.5))
    return shapely.union_all(shapes).buffer(0.1) if shapes else shapely.GeometryCollection()


def score(scene: Scene, start: np.ndarray, final: np.ndarray) -> dict[str, float]:
    """The drop's figures: spheres counted, left out (objects), through the ground and
    resting (each as a count and, for the last two, a percentage of those counted)."""
    final = np.asarray(final, dtype=np.float64)
    objects = _objects(scene, np.r_[start, final[np.isfinite(final).all(axis=1)]])
    near = shapely.intersects(objects, shapely.points(start[:, :2])) | shapely.intersects(
        objects, shapely.points(final[:, :2])
    )
    ok = np.isfinite(final).all(axis=1)
    ground = np.full(len(final), np.nan)
    ground[ok] = height_at(scene, final[ok, 0], final[ok, 1])
    gap = np.where(ok, final[:, 2] - RADIUS - ground, -np.inf)
    counted = ~near
    n = int(counted.sum())
    through = int((counted & (gap < -TOLERANCE)).sum())
    resting = int((counted & (np.abs(gap) <= TOLERANCE)).sum())
    return {
        "spheres": n,
        "objects": int(near.sum()),
        "through": through,
        "resting": resting,
        "through_pct": 100.0 * through / max(n, 1),
        "resting_pct": 100.0 * resting / max(n, 1),
        "worst_m": float(np.abs(gap[counted]).max()) if n else 0.0,
    }


# --- MuJoCo --------------------------------------------------------------------------------


def mujoco_drop(xml: str | Path, points: np.ndarray) -> np.ndarray:
    """The spheres dropped on an MJCF scene in MuJoCo (its time step), final centres."""
    import mujoco

    from citygen.exporters.mjcf import ROBOT_BIT, STATIC_BIT

    spec = mujoco.MjSpec.from_file(str(xml))
    for i, p in enumerate(points):
        body = spec.worldbody.add_body(name=f"drop:{i}", pos=p)
        body.add_freejoint()
        body.add_geom(type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[RADIUS, 0, 0], contype=ROBOT_BIT,
                      conaffinity=STATIC_BIT, mass=0.05)  # fmt: skip
    model = spec.compile()
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data, nstep=round(SECONDS / model.opt.timestep))
    return np.array([data.body(f"drop:{i}").xpos.copy() for i in range(len(points))])


# --- PyBullet ------------------------------------------------------------------------------


def pybullet_drop(urdf: str | Path, points: np.ndarray) -> np.ndarray:
    """The spheres dropped on a URDF scene in PyBullet (1/240 s steps), final centres."""
    import pybullet

    client = pybullet.connect(pybullet.DIRECT)
    try:
        pybullet.setGravity(0, 0, -9.81, physicsClientId=client)
        pybullet.loadURDF(str(urdf), useFixedBase=True, physicsClientId=client)
        shape = pybullet.createCollisionShape(pybullet.GEOM_SPHERE, radius=RADIUS, physicsClientId=client)
        ids = [
            pybullet.createMultiBody(0.05, shape, basePosition=p.tolist(), physicsClientId=client)
            for p in points
        ]
        for _ in range(round(SECONDS * 240)):
            pybullet.stepSimulation(physicsClientId=client)
        return np.array([pybullet.getBasePositionAndOrientation(i, physicsClientId=client)[0] for i in ids])
    finally:
        pybullet.disconnect(client)


# --- SAPIEN --------------------------------------------------------------------------------


def sapien_drop(urdfs: list[str | Path], points: np.ndarray, static: bool = False) -> np.ndarray:
    """The spheres dropped on URDF files (a scene, or a city's tiles) in SAPIEN on the CPU
    (its 1/100 s steps), each loaded with ``create_urdf_loader`` as a fixed body with each
    link's friction (:func:`citygen.exporters.urdf.frictions`), as docs/simulators/sapien.md
    does; with ``static``, each link a static actor, as its recipe for large scenes does."""
    import sapien

    from citygen.exporters.urdf import frictions

    scene = sapien.Scene([sapien.physx.PhysxCpuSystem()])  # no renderer: no rendering device needed
    for urdf in urdfs:
        loader = scene.create_urdf_loader()
        loader.fix_root_link = True
        for link, mu in frictions(urdf).items():
            loader.set_link_material(link, mu, mu, 0.0)
        if not static:
            loader.load_multiple(str(urdf))
            continue
        for builder in loader.parse(str(urdf))[0]:
            for link in builder.link_builders:
                link.set_scene(scene)
                link.initial_pose = link.joint_record.pose_in_parent * link.joint_record.pose_in_child.inv()
                link.build_static(link.name)
    balls = []
    for p in points:
        builder = scene.create_actor_builder()
        builder.add_sphere_collision(radius=RADIUS)
        builder.set_initial_pose(sapien.Pose(p.tolist()))
        balls.append(builder.build())
    for _ in range(round(SECONDS / scene.timestep)):
        scene.step()
    return np.array([b.pose.p for b in balls], dtype=np.float64)


# --- Genesis -------------------------------------------------------------------------------


def genesis_init() -> object:
    """Genesis on the CPU, once per process (quiet)."""
    import genesis as gs

    if not getattr(gs, "_initialized", False):
        gs.init(backend=gs.cpu, logging_level="warning")
    return gs


def genesis_drop(files: list[str | Path], points: np.ndarray) -> np.ndarray:
    """The spheres dropped in Genesis on the CPU (its 0.01 s steps): each file an MJCF
    (``gs.morphs.MJCF``) or URDF (``gs.morphs.URDF(fixed=True)``) morph with its defaults."""
    gs = genesis_init()
    scene = gs.Scene(show_viewer=False)
    ground = gs.materials.Rigid(sdf_max_res=32)  # as docs/simulators/genesis.md: coarse SDF grids
    for f in files:
        if str(f).endswith(".xml"):
            scene.add_entity(gs.morphs.MJCF(file=str(f)), material=ground)
        else:
            scene.add_entity(gs.morphs.URDF(file=str(f), fixed=True), material=ground)
    balls = [scene.add_entity(gs.morphs.Sphere(radius=RADIUS, pos=tuple(p.tolist()))) for p in points]
    scene.build()
    for _ in range(round(SECONDS / scene.dt)):
        scene.step()
    out = np.array([np.asarray(b.get_pos()).reshape(-1)[:3] for b in balls], dtype=np.float64)
    scene.destroy() if hasattr(scene, "destroy") else None
    return out
