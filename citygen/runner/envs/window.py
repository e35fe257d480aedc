"""Locomotion grids compiled a window at a time: the regions a robot can reach in an episode.

An Urban-Loc training grid is 30 x 30 regions of 8 m, its stairs 29,700 box geoms, and MuJoCo's
collision detection costs with the number of geoms in the world wherever the robot is: its
broadphase goes over every geom twice a physics step to skip the world's, and its midphase
descends the world's bounding-volume tree for every robot body (116 of the 159 microseconds of
a physics step on the stair grid, seven times a flat grid's). A locomotion episode walks at most
its command's speed times its horizon (20 m in 20 s at 1 m/s) from its start, so
:class:`Windows` compiles the grid's terrain only within that reach plus :data:`MARGIN` and
:data:`GUARD` of the block of :data:`BLOCK` x :data:`BLOCK` regions the start lies in (the
other geoms left out by their names, ``terrain:<kind>:<row>_<col>:<k>``; every other geom,
the apron and the zones, kept), one model per block, shared by the process's environments,
on grids of :data:`FROM_GEOMS` terrain geoms or more (the stair training grids).

What changes: nothing MuJoCo computes. The robot's contacts are with the geoms under and
around it, all in the window; MuJoCo orders contacts by geom id, and leaving geoms out keeps
the order of those left, so every step's state is the whole grid's to the bit
(``tests/test_window.py``). Should a robot come within :data:`GUARD` of the window's edge (it
would have to walk some 8 m farther than its command's speed takes it in an episode), the
environment moves it to the whole grid's model, state and all, before its next step
(:meth:`LocoEnv._leave_window`), and carries on bit for bit.
"""

from __future__ import annotations

import math
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass, replace
from typing import Any

#: Regions per side of the blocks the windows are made for (one model per block).
BLOCK = 4
#: Metres of terrain a window keeps beyond the episode's reach on each side of its block.
MARGIN = 4.0
#: Metres from a window's edge at which the robot's base is moved to the whole grid's model.
GUARD = 3.0
#: Terrain geoms from which a grid is windowed: below, the whole model costs little more than
#: compiling the windows (LocoStair's 16 x 16 test grid, 8,400 geoms, stepped no faster in a
#: window: 1,544-1,674 against 1,666-1,680 steps/s; its 16 windows took 8 s to compile).
FROM_GEOMS = 10_000
#: A terrain geom's name: its tile's row and column.
TERRAIN_NAME = re.compile(r"terrain:[^:]+:(\d+)_(\d+):")


@dataclass(frozen=True)
class Window:
    """A block's window: regions ``rows[0] <= row < rows[1]``, ``cols[0] <= col < cols[1]``,
    and the world box ``(x0, y0, x1, y1)`` (m) they cover."""

    rows: tuple[int, int]
    cols: tuple[int, int]
    box: tuple[float, float, float, float]

    def holds(self, x: float, y: float) -> bool:
        """Whether ``(x, y)`` lies at least :data:`GUARD` inside the window's edges (or on a
        side where the window reaches the grid's own edge, anywhere past it)."""
        x0, y0, x1, y1 = self.box
        return x0 + GUARD <= x <= x1 - GUARD and y0 + GUARD <= y <= y1 - GUARD


class Windows:
    """The windows of one prepared locomotion grid (the whole model's
    :class:`~citygen.runner.scenes.Prepared`), compiled when first asked for."""

    def __init__(self, prepared: Any, terrain: str):
        from citygen.runner.robots.handle import STILL_BODY

        self.prepared = prepared
        self.terrain = terrain
        self._tree = None  # the scene's MJCF tree, made at the first window
        self._regions: list[tuple[int, int] | None] = []
        self.models: dict[Window, Any] = {}
        # compiled as the whole grid was: a town's or a city's treatment (fused, sleeping)
        self._big = any(prepared.model.body(b).name == STILL_BODY for b in range(prepared.model.nbody))

    def window(self, x: float, y: float, reach: float) -> Window | None:
        """The window for an episode starting at ``(x, y)`` that walks at most ``reach`` m;
        None where the window would hold all of the grid."""
        grid = self.prepared.scene.terrain
        size = grid.tile_size
        ox, oy = grid.origin
        row = min(max(int((y - oy) // size), 0), grid.rows - 1)
        col = min(max(int((x - ox) // size), 0), grid.cols - 1)
        margin = math.ceil((reach + MARGIN + GUARD) / size)
        r0, c0 = (row // BLOCK) * BLOCK, (col // BLOCK) * BLOCK
        rows = (max(r0 - margin, 0), min(r0 + BLOCK + margin, grid.rows))
        cols = (max(c0 - margin, 0), min(c0 + BLOCK + margin, grid.cols))
        if rows == (0, grid.rows) and cols == (0, grid.cols):
            return None
        # the grid's own edges: the scene (its apron) goes on past them, as in the whole model
        inf = math.inf
        box = (
            ox + cols[0] * size if cols[0] > 0 else -inf,
            oy + rows[0] * size if rows[0] > 0 else -inf,
            ox + cols[1] * size if cols[1] < grid.cols else inf,
            oy + rows[1] * size if rows[1] < grid.rows else inf,
        )
        return Window(rows, cols, box)

    def prepared_for(self, window: Window) -> Any:
        """The :class:`~citygen.runner.scenes.Prepared` of ``window``: the whole grid's maps
        and scene, the window's model."""
        hit = self.models.get(window)
        if hit is None:
            hit = self.models[window] = self._compile(window)
        return hit

    def _compile(self, window: Window) -> Any:
        from citygen.exporters import mjcf
        from citygen.exporters.mjcf.contract import MJCFTree
        from citygen.runner.robots import compose
        from citygen.runner.scenes import _scene_mjcf, geom_kinds, start_pose

        parent = self.prepared
        scene = parent.scene
        if self._tree is None:
            self._tree = _scene_mjcf(scene, self.terrain)
            world = self._tree.root.find("worldbody")
            for el in world:
                m = TERRAIN_NAME.match(el.get("name") or "") if el.tag == "geom" else None
                self._regions.append((int(m.group(1)), int(m.group(2))) if m else None)
        tree = self._tree
        (r0, r1), (c0, c1) = window.rows, window.cols
        root = ET.Element(tree.root.tag, dict(tree.root.attrib))
        used: set[str] = set()  # the meshes and heightfields of the geoms kept
        for child in tree.root:
            if child.tag == "worldbody":
                world = ET.SubElement(root, child.tag, dict(child.attrib))
                for el, region in zip(child, self._regions, strict=True):
                    if region is None or (r0 <= region[0] < r1 and c0 <= region[1] < c1):
                        world.append(el)
                        used.update(v for g in el.iter("geom") for k in ("mesh", "hfield") if (v := g.get(k)))
            else:
                root.append(child)
        for k, child in enumerate(root):
            if child.tag == "asset":  # elements are shared with the whole tree: a new one
                asset = ET.Element(child.tag, dict(child.attrib))
                asset.extend(a for a in child if a.tag not in ("mesh", "hfield") or a.get("name") in used)
                root[k] = asset
        hfields = {k: v for k, v in tree.hfields.items() if k in used}
        model = compose(MJCFTree(root, tree.assets, hfields), parent.robot, start_pose(scene), big=self._big)
        obstacle, ground = geom_kinds(mjcf.geom_labels(model))
        out = replace(
            parent, model=model, obstacle_geoms=obstacle, ground_geoms=ground, store_key=None, _fields={},
            _routes={}, _windows={},
        )  # fmt: skip
        # the whole grid's rasters, made once and shared (cached properties of the parent)
        for name in ("_raster", "_map_tiles", "fine_tiles", "ground_at"):
            out.__dict__[name] = getattr(parent, name)
        return out


def terrain_geoms(model: Any) -> int:
    """How many of ``model``'s geoms are a terrain grid's tiles' (by their names)."""
    return sum(1 for i in range(model.ngeom) if TERRAIN_NAME.match(model.geom(i).name or ""))


def windows_of(prepared: Any, terrain: str) -> Windows | None:
    """The :class:`Windows` of ``prepared`` (kept on it), or None for a scene too small to
    gain from them (fewer than :data:`FROM_GEOMS` terrain geoms) or without a grid."""
    cached = prepared._windows.get(terrain)
    if cached is None:
        big = prepared.scene.terrain is not None and prepared.model.ngeom >= FROM_GEOMS
        cached = Windows(prepared, terrain) if big and terrain_geoms(prepared.model) >= FROM_GEOMS else False
        prepared._windows[terrain] = cached
    return cached or None
