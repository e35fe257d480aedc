"""Render docs/terrain_tiles.png: one solid of each terrain tile kind, as the exporters get it.

Run from the repository: ``python docs/make_gallery.py [out.png]``. Each panel draws
:func:`citygen.geometry.terrain.tile_mesh` of one tile (flat, slope, stair, rough; then the
pyramids and pits of the locomotion curriculum) with flat shading; axes are in metres at
true scale.
"""

from __future__ import annotations

import io
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt
import numpy as np
import trimesh
from mpl_toolkits.mplot3d.art3d import Poly3DCollection
from PIL import Image

from citygen.geometry.terrain import tile_mesh
from citygen.spec import FlatTile, RoughTile, SlopeTile, StairTile

TILE_SIZE = 2.5
FLOOR = -0.25
ELEV, AZIM = 28.0, -125.0  # degrees; the camera looks at the risers (they face -x)
EYE = np.array(
    [
        np.cos(np.radians(ELEV)) * np.cos(np.radians(AZIM)),
        np.cos(np.radians(ELEV)) * np.sin(np.radians(AZIM)),
        np.sin(np.radians(ELEV)),
    ]
)
OUT = Path(__file__).resolve().parent / "terrain_tiles.png"

TILES = [
    ("flat, height 0.2 m", FlatTile(kind="flat", height=0.2)),
    ("slope, 0.2 rad towards +x", SlopeTile(kind="slope", angle=0.2, ascent="+x")),
    ("stair, 4 risers of 0.12 m towards +x", StairTile(kind="stair", step_height=0.12, step_count=4)),
    (
        "rough, amplitude 0.1 m, scale 0.6 m",
        RoughTile(kind="rough", height=0.2, amplitude=0.1, scale=0.6, seed=3),
    ),
    # The locomotion curriculum's slopes and stairs: level edges, a central platform.
    ("slope pyramid, 0.3 rad", SlopeTile(kind="slope", angle=0.3, shape="pyramid")),
    ("slope pit, 0.3 rad", SlopeTile(kind="slope", height=0.3, angle=0.3, shape="pit")),
    ("stair pyramid, 3 x 0.1 m", StairTile(kind="stair", step_height=0.1, step_count=3, shape="pyramid")),
    ("stair pit, 3 x 0.1 m", StairTile(kind="stair", height=0.3, step_height=0.1, step_count=3, shape="pit")),
]
COLUMNS = 4


def _colours(mesh, low: float, high: float) -> np.ndarray:
    """Face colours: grey walls; tops from dark (``low``, m) to light sand (``high``), lit
    from a low sun so that relief shows."""
    sun = np.array([-0.5, -0.35, 0.6])
    sun /= np.linalg.norm(sun)
    light = 0.2 + 0.8 * np.clip(mesh.face_normals @ sun, 0.0, 1.0)
    t = np.clip((mesh.triangles_center[:, 2:] - low) / (high - low), 0.0, 1.0)
    sand = (1 - t) * np.array([0.55, 0.45, 0.3]) + t * np.array([0.95, 0.87, 0.66])
    base = np.where(mesh.face_normals[:, 2:] > 0.3, sand, [0.55, 0.57, 0.62])
    return np.c_[base * light[:, None], np.ones(len(light))]


def render(path: Path = OUT) -> Path:
    """Draw the tiles, four to a row, into ``path`` (PNG) and return it."""
    rows = -(-len(TILES) // COLUMNS)
    fig = plt.figure(figsize=(14, 3.6 * rows), dpi=80)
    top = max(float(tile_mesh(t, TILE_SIZE, floor=FLOOR).bounds[1, 2]) for _, t in TILES)
    for k, (title, tile) in enumerate(TILES):
        mesh = tile_mesh(tile, TILE_SIZE, floor=FLOOR)
        # matplotlib sorts whole polygons by the depth of their centres: small triangles,
        # and only those facing the camera, keep far faces from being drawn over near ones.
        mesh = trimesh.Trimesh(*trimesh.remesh.subdivide_to_size(mesh.vertices, mesh.faces, 0.2))
        front = mesh.face_normals @ EYE > 1e-9
        ax = fig.add_subplot(rows, COLUMNS, k + 1, projection="3d")
        colours = _colours(mesh, -0.3, top)[front]
        # Edges in the faces' colours hide the seams antialiasing leaves between them.
        polys = Poly3DCollection(
            mesh.triangles[front], facecolors=colours, edgecolors=colours, linewidths=0.3
        )
        ax.add_collection3d(polys)
        ax.set(xlim=(0, TILE_SIZE), ylim=(0, TILE_SIZE), zlim=(FLOOR, top))
        ax.set_box_aspect((TILE_SIZE, TILE_SIZE, top - FLOOR))
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("x (m)", fontsize=7, labelpad=-6)
        ax.set_ylabel("y (m)", fontsize=7, labelpad=-6)
        ax.tick_params(labelsize=6, pad=-2)
        ax.set_zticks([])
        ax.view_init(elev=ELEV, azim=AZIM)
    fig.subplots_adjust(left=0.0, right=0.98, bottom=0.02, top=0.93, wspace=0.0, hspace=0.1)
    buffer = io.BytesIO()
    fig.savefig(buffer, format="png")
    plt.close(fig)
    # 256 colours are plenty for flat-shaded solids and keep the file small.
    Image.open(buffer).convert("RGB").quantize(256).save(path, optimize=True)
    return path


if __name__ == "__main__":
    print(render(Path(sys.argv[1]) if len(sys.argv) > 1 else OUT))
