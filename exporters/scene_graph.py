"""The whole scene as a :class:`trimesh.Scene` (:func:`build`): the GLB file is written
from it and the HTML viewer shows it. Its nodes are listed in :mod:`citygen.exporters.glb`."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from types import MappingProxyType
from typing import TYPE_CHECKING

import numpy as np
from shapely.geometry import Polygon

from citygen.errors import ExportError
from citygen.exporters.ground import (
    RESOLUTION,
    ZONE_LIFT,
    auto_terrain,
    drape,
    fit_terrain,
    ground_plane,
    terrain_solid,
    triangulate,
    zone_polygons,
)
from citygen.exporters.meshes import (
    GROUND_RGBA,
    RGBA,
    catalog_asset,
    file_mesh,
    flat_coloured,
    placement_matrix,
    rgba,
    vertex_coloured,
    zone_rgba,
)
from citygen.exporters.options import AUTO, resolution_option, scene_dir_of
from citygen.exporters.solids import solids
from citygen.geometry.terrain import height_at, terrain_mesh
from citygen.spec.agents import Vehicle
from citygen.spec.scene import Scene
from citygen.spec.task import NavTask, TraverseTask

if TYPE_CHECKING:
    import trimesh

#: Colour of each kind of agent, and of the task's start and goal.
AGENT_COLORS = MappingProxyType(
    {"pedestrian": "#e6194b", "cyclist": "#f58231", "scooter": "#911eb4", "vehicle": "#1f5fd1"}
)
START_COLOR, GOAL_COLOR = "#0b8f3a", "#d11f4a"
#: Height (m) of the cylinder or box that stands for an agent of each kind.
AGENT_HEIGHT = MappingProxyType({"pedestrian": 1.7, "cyclist": 1.8, "scooter": 1.8, "vehicle": 1.5})
#: Thickness (m) of goal discs and of the start arrow.
MARKER_THICKNESS = 0.03

ROOT = "scene/root"
#: Z-up (citygen) to Y-up (glTF): (x, y, z) -> (x, z, -y).
Z_UP_TO_Y_UP = np.array([[1.0, 0, 0, 0], [0, 0, 1.0, 0], [0, -1.0, 0, 0], [0, 0, 0, 1.0]])


def _unit_cylinder() -> trimesh.Trimesh:
    """Radius 1, height 1, base at z = 0."""
    import trimesh

    mesh = trimesh.creation.cylinder(radius=1.0, height=1.0, sections=24)
    return trimesh.Trimesh(mesh.vertices + np.array([0.0, 0.0, 0.5]), mesh.faces, process=False)


def _unit_box() -> trimesh.Trimesh:
    """1 x 1 x 1, centred on x and y, base at z = 0."""
    import trimesh

    mesh = trimesh.creation.box((1.0, 1.0, 1.0))
    return trimesh.Trimesh(mesh.vertices + np.array([0.0, 0.0, 0.5]), mesh.faces, process=False)


def _arrow() -> tuple[np.ndarray, np.ndarray]:
    """A flat arrow 1 m long pointing +x, centred on its tail half, base at z = 0."""
    outline = np.array(
        [[-0.5, -0.15], [0.1, -0.15], [0.1, -0.35], [0.5, 0.0], [0.1, 0.35], [0.1, 0.15], [-0.5, 0.15]]
    )
    xy, faces = triangulate(Polygon(outline))
    n = len(xy)
    verts = np.r_[np.c_[xy, np.zeros(n)], np.c_[xy, np.full(n, 1.0)]]
    ring = np.arange(n)
    nxt = np.roll(ring, -1)
    sides = np.r_[np.c_[ring, nxt, nxt + n], np.c_[ring, nxt + n, ring + n]]
    return verts, np.r_[faces[:, ::-1], faces + n, sides]


def _matrix(
    x: float, y: float, z: float, yaw: float = 0.0, size: Sequence[float] = (1.0, 1.0, 1.0)
) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    m = np.eye(4)
    m[:3, :3] = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.diag(size)
    m[:3, 3] = (x, y, z)
    return m


# --- the scene graph --------------------------------------------------------------------


class _Graph:
    """A trimesh scene under :data:`ROOT`, adding each geometry once however many nodes use it."""

    def __init__(self, y_up: bool) -> None:
        import trimesh

        self.scene = trimesh.Scene()
        turn = Z_UP_TO_Y_UP if y_up else np.eye(4)
        self.scene.graph.update(frame_from=self.scene.graph.base_frame, frame_to=ROOT, matrix=turn)

    def add(self, node: str, geometry: str, make, matrix: np.ndarray) -> None:
        if geometry not in self.scene.geometry:
            self.scene.geometry[geometry] = make()
        self.scene.graph.update(frame_from=ROOT, frame_to=node, matrix=matrix, geometry=geometry)


def build(
    scene: Scene | str | Path,
    *,
    scene_dir: str | Path | None = None,
    resolution: float | str | None = AUTO,
    y_up: bool = True,
    fmt: str = "glb",
) -> trimesh.Scene:
    """The scene as a :class:`trimesh.Scene` (its nodes: see :mod:`citygen.exporters.glb`).

    ``scene_dir`` is the folder mesh placements are relative to (default: the scene
    file's folder). ``resolution`` (m) is the cell size of rough terrain tiles' meshes
    (default :data:`AUTO`: :data:`RESOLUTION`, coarser where the terrain would exceed
    ``lod.BUDGETS[fmt]`` triangles, rougher tiles finer: :func:`auto_terrain`; None for
    :func:`~citygen.geometry.terrain.tile_mesh`'s, which resolves every bump). Agents and
    the task's markers stand on the ground (:func:`height_at`).
    """
    model, folder = scene_dir_of(scene, {"scene_dir": scene_dir})
    resolution = resolution_option(resolution, fmt)
    if not isinstance(y_up, bool):
        raise ExportError(f"glb export: expected true or false for 'y_up', got {y_up!r}")
    g = _Graph(y_up)
    polys = zone_polygons(model)
    tm = None
    if model.terrain is not None:
        if resolution == AUTO:
            resolution = auto_terrain(model, fmt, RESOLUTION)
        else:
            resolution = fit_terrain(model, resolution, fmt, RESOLUTION)
        tm = terrain_mesh(model, resolution=resolution)
        solid = terrain_solid(model, polys, mesh=tm)
        g.add("ground/terrain", "terrain", lambda: solid, np.eye(4))
    verts, faces = ground_plane(model)
    if len(faces):
        g.add("ground/plane", "plane", lambda: flat_coloured(verts, faces, GROUND_RGBA), np.eye(4))
    _add_zones(g, model, polys, tm)
    _add_placements(g, model, folder)
    _add_agents(g, model)
    _add_task(g, model)
    extras = {"format": model.format}
    for key in ("meta", "agents", "task"):
        value = getattr(model, key)
        if value:
            extras[key] = (
                [a.model_dump(mode="json", exclude_none=True) for a in value]
                if key == "agents"
                else value.model_dump(mode="json", exclude_none=True)
            )
    g.scene.metadata["citygen"] = extras
    return g.scene


def _coloured_mesh(mesh: trimesh.Trimesh, colour: RGBA) -> trimesh.Trimesh:
    return flat_coloured(mesh.vertices, mesh.faces, colour)


def _add_zones(g: _Graph, scene: Scene, polys: list, tm: trimesh.Trimesh | None) -> None:
    """Each zone's ground surface (``zone/<id>``) and each zone's solid (``solid/<id>``: a
    building extruded from its footprint, :mod:`citygen.exporters.solids`), in its kind's colour."""
    surfaces = drape(scene, polys, mesh=tm)
    for zone, (verts, faces) in zip(scene.zones, surfaces, strict=True):
        if len(faces):
            lifted = verts + np.array([0.0, 0.0, ZONE_LIFT])
            colour = zone_rgba(zone.kind)
            name = f"zone/{zone.id}"
            g.add(name, name, lambda v=lifted, f=faces, c=colour: flat_coloured(v, f, c), np.eye(4))
    for solid in solids(scene, polys):
        name = f"solid/{solid.zone.id}"
        make = lambda s=solid: flat_coloured(*s.mesh(), zone_rgba(s.zone.kind))  # noqa: E731
        g.add(name, name, make, np.eye(4))


def _add_placements(g: _Graph, scene: Scene, folder: Path | None) -> None:
    for i, pl in enumerate(scene.placements):
        if pl.is_mesh:
            geometry = f"mesh/{pl.asset}"
            make = lambda pl=pl, i=i: vertex_coloured(file_mesh(pl, i, folder))  # noqa: E731
        else:
            geometry = f"asset/{pl.asset}"
            make = lambda pl=pl, i=i: vertex_coloured(catalog_asset(pl, i).visual_mesh())  # noqa: E731
        g.add(pl.id, geometry, make, placement_matrix(pl))


def _add_agents(g: _Graph, scene: Scene) -> None:
    for agent in scene.agents:
        colour = rgba(AGENT_COLORS[agent.kind])
        (sx, sy), (gx, gy) = agent.start, agent.goal
        z0, z1 = (float(z) for z in height_at(scene, [sx, gx], [sy, gy]))
        h = AGENT_HEIGHT[agent.kind]
        if isinstance(agent, Vehicle):
            yaw = math.atan2(gy - sy, gx - sx) if (gx, gy) != (sx, sy) else 0.0
            m = _matrix(sx, sy, z0, yaw, (agent.length, agent.width, h))
            g.add(f"agent/{agent.id}", "agent/vehicle", lambda c=colour: _coloured_mesh(_unit_box(), c), m)
            r = agent.width / 2
        else:
            r = agent.radius
            m = _matrix(sx, sy, z0, 0.0, (r, r, h))
            person = lambda c=colour: _coloured_mesh(_unit_cylinder(), c)  # noqa: E731
            g.add(f"agent/{agent.id}", f"agent/{agent.kind}", person, m)
        disc = _matrix(gx, gy, z1, 0.0, (r, r, MARKER_THICKNESS))
        marker = "agent/vehicle/goal" if isinstance(agent, Vehicle) else f"agent/{agent.kind}"
        g.add(f"agent/{agent.id}/goal", marker, lambda c=colour: _coloured_mesh(_unit_cylinder(), c), disc)


def _add_task(g: _Graph, scene: Scene) -> None:
    task = scene.task
    if task is None:
        return
    (x, y), yaw = task.start.position, task.start.yaw
    z = float(height_at(scene, x, y))
    start = rgba(START_COLOR)
    g.add(
        "task/start",
        "task/arrow",
        lambda: flat_coloured(*_arrow(), start),
        _matrix(x, y, z, yaw, (1, 1, MARKER_THICKNESS)),
    )
    goal = rgba(GOAL_COLOR)
    make_disc = lambda: _coloured_mesh(_unit_cylinder(), goal)  # noqa: E731
    if isinstance(task, NavTask):
        (gx, gy), r = task.goal, task.goal_tolerance
        gz = float(height_at(scene, gx, gy))
        g.add("task/goal", "task/disc", make_disc, _matrix(gx, gy, gz, 0.0, (r, r, MARKER_THICKNESS)))
    elif isinstance(task, TraverseTask):
        pts = np.asarray(task.route, dtype=np.float64)
        zs = height_at(scene, pts[:, 0], pts[:, 1])
        r = task.goal_tolerance
        for k, ((px, py), pz) in enumerate(zip(pts.tolist(), zs.tolist(), strict=True)):
            name = "task/goal" if k == len(pts) - 1 else f"task/route/{k}"
            g.add(name, "task/disc", make_disc, _matrix(px, py, pz, 0.0, (r, r, MARKER_THICKNESS)))
