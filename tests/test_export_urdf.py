"""The URDF exporter, checked by its real consumers: PyBullet and yourdfpy.

Rays cast in PyBullet from above must hit each object where the spec puts it (at the top
of the asset's parts there, on the placement's own link), the terrain at ``height_at``
(pits included: its convex pieces keep them; rough tiles within their tolerance) and the
flat zones at z = 0 with their friction. The scene builders here are shared with the GLB and HTML tests.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import pybullet
import pytest
import shapely
import trimesh
import yourdfpy
from shapely.geometry import Polygon

from citygen import validate
from citygen.assets import resolve
from citygen.errors import ExportError
from citygen.exporters import ExportWarning, glb, urdf
from citygen.geometry.pieces import ROUGH_TOLERANCE
from citygen.geometry.terrain import height_at
from citygen.io import load_scene, save_scene
from citygen.spec import Scene
from citygen.spec.agents import Person
from citygen.spec.placements import Placement
from citygen.spec.surfaces import FRICTION
from citygen.spec.task import NavTask
from tests.conftest import ROOT

# --- scenes shared by the exporter tests ---------------------------------------------------

R1 = 0.2007  # top of the 0.1 rad slope flight over a 2 m tile (2 tan 0.1, to 1e-4)
R2 = R1 + 0.3  # top of the stair flight
TILE_ROW = [
    {"kind": "flat", "height": 0.0},
    {"kind": "slope", "angle": 0.1, "ascent": "+x"},
    {"kind": "flat", "height": R1},
    {"kind": "stair", "height": R1, "step_height": 0.1, "step_count": 3},
    {"kind": "flat", "height": R2, "friction": 0.3},
    {"kind": "rough", "height": R2, "amplitude": 0.08, "scale": 0.8, "seed": 5},
    {"kind": "slope", "height": R2, "angle": 0.3, "shape": "pit"},
    {"kind": "stair", "height": R2, "step_height": 0.1, "step_count": 2, "shape": "pyramid"},
    {"kind": "flat", "height": R2, "material": "rubber"},
]
ORIGIN, TILE = (2.0, 2.0), 2.0
KIOSK_OBJ = """\
v 0 0 0
v 2 0 0
v 2 1 0
v 1 1 0
v 1 2 0
v 0 2 0
v 0 0 2
v 2 0 2
v 2 1 2
v 1 1 2
v 1 2 2
v 0 2 2
f 1 3 2
f 1 4 3
f 1 6 4
f 4 6 5
f 7 8 9
f 7 9 10
f 7 10 12
f 10 11 12
f 1 2 8
f 1 8 7
f 2 3 9
f 2 9 8
f 3 4 10
f 3 10 9
f 4 5 11
f 4 11 10
f 5 6 12
f 5 12 11
f 6 1 7
f 6 7 12
"""
"""An L-shaped kiosk, 2 m tall, its notch at x, y in [1, 2]: a concave mesh."""


def _rect(x0, y0, x1, y1):
    return [[x0, y0], [x1, y0], [x1, y1], [x0, y1]]


def terrain_scene(**changes) -> Scene:
    """A 24 x 10 m street with a 2 x 9 grid of every tile kind (a slope and a stair flight,
    a rough tile, a slope pit, a stair pyramid), zones around and over it, an uncovered
    corner, objects of every part type (one scaled, one turned, one on a step, one a mesh
    file), two agents and a task."""
    scene = {
        "format": "citygen.scene/1",
        "bounds": {"min": [0.0, 0.0], "max": [24.0, 10.0]},
        "zones": [
            {"id": "road", "kind": "roadway", "polygon": _rect(0, 0, 24, 1.5)},
            {"id": "curb", "kind": "curb", "polygon": _rect(0, 1.5, 24, 1.7)},
            {
                "id": "walk",
                "kind": "sidewalk",
                "polygon": _rect(0, 1.7, 24, 8),
                "holes": [_rect(20.5, 6.2, 21.5, 7.2)],
            },
            {"id": "pit", "kind": "vegetation", "polygon": _rect(20.5, 6.2, 21.5, 7.2)},
            {"id": "plaza", "kind": "plaza", "polygon": _rect(0, 8, 23, 10)},
        ],
        "terrain": {
            "origin": list(ORIGIN),
            "tile_size": TILE,
            "rows": 2,
            "cols": len(TILE_ROW),
            "tiles": TILE_ROW + TILE_ROW,
        },
        "placements": [
            {"id": "bench-1", "asset": "bench/0003", "position": [4.0, 9.0, 0.0], "yaw": 0.3},
            {"id": "lamp-1", "asset": "lamp_post/0002", "position": [12.0, 7.0, 0.0], "yaw": 2.0},
            {"id": "bollard-1", "asset": "bollard/0001", "position": [1.0, 3.0, 0.0]},
            {"id": "booth-1", "asset": "telephone_booth/0001", "position": [16.0, 7.2, 0.0], "yaw": -0.5},
            {"id": "bin-1", "asset": "trash_bin/0011", "position": [8.0, 7.0, 0.0], "scale": 1.5},
            {"id": "bin-on-step", "asset": "trash_bin/0004", "position": [11.0, 3.0, R2]},
            {"id": "kiosk", "asset": "meshes/kiosk.obj", "position": [22.0, 3.0, 0.0], "yaw": 0.4},
        ],
        "agents": [
            {"id": "ped-1", "kind": "pedestrian", "start": [3.0, 7.0], "goal": [19.0, 7.5]},
            {"id": "car-1", "kind": "vehicle", "start": [3.0, 0.75], "goal": [21.0, 0.75], "width": 1.2},
        ],
        "task": {
            "kind": "nav-static",
            "start": {"position": [1.0, 5.0], "yaw": 0.0},
            "goal": [22.5, 9.0],
            "time_limit": 60.0,
        },
    }
    scene.update(changes)
    return Scene.model_validate(scene)


def write_terrain_scene(folder: Path, **changes) -> Path:
    """The terrain scene saved as ``folder/street.json`` with its kiosk mesh beside it."""
    (folder / "meshes").mkdir(parents=True, exist_ok=True)
    (folder / "meshes" / "kiosk.obj").write_text(KIOSK_OBJ)
    return save_scene(terrain_scene(**changes), folder / "street.json")


def generated_scene(seed: int) -> Scene:
    """A 60 x 60 m street scene from the generator's stages 1 to 3 (roads, zones, terrain),
    with hand-built placements, agents and a task (those stages are still being built)."""
    from citygen.generate.pipeline import layout
    from citygen.generate.terrain import build_terrain
    from citygen.seeding import stage_rng
    from citygen.spec.config import BlocksConfig, GeneratorConfig

    config = GeneratorConfig(size=(60.0, 60.0), layout="blocks", blocks=BlocksConfig(count=1))
    scene = layout(config, seed)
    terrain = build_terrain(scene.bounds, scene.zones, config.terrain, stage_rng(seed, "terrain"), seed=seed)
    walk = next(z for z in scene.zones if z.kind == "sidewalk")
    x, y = Polygon(walk.polygon, walk.holes).representative_point().coords[0]
    bench = Placement(id="bench-x", asset="bench/0001", position=(x, y, float(height_at(terrain, x, y))))
    people = (Person(id="ped-x", kind="pedestrian", start=(x, y), goal=(x + 1.0, y)),)
    task = NavTask(
        kind="nav-clear", start={"position": (x, y), "yaw": 0.0}, goal=(x + 2.0, y), time_limit=30.0
    )
    return scene.model_copy(
        update={"terrain": terrain, "placements": (bench,), "agents": people, "task": task}
    )


# --- helpers ----------------------------------------------------------------------------------


def export_quiet(scene, out, **options) -> list[Path]:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportWarning)
        return urdf.export(scene, out, **options)


class Bullet:
    """A PyBullet DIRECT client with one URDF loaded as a fixed base."""

    def __init__(self, path: Path) -> None:
        self.client = pybullet.connect(pybullet.DIRECT)
        self.body = pybullet.loadURDF(str(path), useFixedBase=True, physicsClientId=self.client)
        n = pybullet.getNumJoints(self.body, physicsClientId=self.client)
        self.links = {-1: pybullet.getBodyInfo(self.body, physicsClientId=self.client)[0].decode()}
        for j in range(n):
            self.links[j] = pybullet.getJointInfo(self.body, j, physicsClientId=self.client)[12].decode()
        self.index = {name: j for j, name in self.links.items()}

    def ray(self, xy) -> tuple[str | None, float]:
        """The link a vertical ray from above hits first at ``xy``, and the height it hits."""
        x, y = xy
        hit = pybullet.rayTest([x, y, 100.0], [x, y, -100.0], physicsClientId=self.client)[0]
        if hit[0] < 0:
            return None, math.nan
        return self.links[hit[1]], hit[3][2]

    def friction(self, link: str) -> float:
        return pybullet.getDynamicsInfo(self.body, self.index[link], physicsClientId=self.client)[1]

    def close(self) -> None:
        pybullet.disconnect(self.client)


@pytest.fixture
def bullet():
    opened = []

    def load(path: Path) -> Bullet:
        opened.append(Bullet(path))
        return opened[-1]

    yield load
    for b in opened:
        b.close()


def placed_parts(scene: Scene, index: int, folder: Path | None = None) -> trimesh.Trimesh:
    """The placement's parts (or mesh) as one mesh in the world (m)."""
    pl = scene.placements[index]
    if pl.is_mesh:
        mesh = trimesh.load(folder / pl.asset, force="mesh")
    else:
        mesh = trimesh.util.concatenate([p.to_trimesh() for p in resolve(pl.asset).parts])
    return mesh.copy().apply_transform(glb.placement_matrix(pl))


def probe_point(scene: Scene, index: int) -> np.ndarray:
    """A point (x, y in m, world) above the highest part of a catalog placement."""
    pl = scene.placements[index]
    parts = resolve(pl.asset).parts
    top = max(parts, key=lambda p: p.hull_points()[:, 2].max())
    local = np.r_[top.hull_points().mean(axis=0)[:2], 0.0, 1.0]
    return (glb.placement_matrix(pl) @ local)[:2]


def top_at(mesh: trimesh.Trimesh, xy) -> float:
    """Height (m) where a vertical ray from above first meets ``mesh`` at ``xy``."""
    locations, _, _ = mesh.ray.intersects_location([[xy[0], xy[1], 100.0]], [[0.0, 0.0, -1.0]])
    return float(locations[:, 2].max()) if len(locations) else math.nan


# --- tests ----------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def street(tmp_path_factory) -> tuple[Path, Scene]:
    folder = tmp_path_factory.mktemp("street")
    path = write_terrain_scene(folder)
    return path, load_scene(path)


def test_the_test_scene_is_valid(street):
    path, scene = street
    assert validate(scene, path.parent) == []


def test_every_thing_is_a_link_fixed_to_the_root(street, tmp_path, bullet):
    path, scene = street
    files = export_quiet(path, tmp_path)
    assert files[0] == tmp_path / "street.urdf"
    assert all(f.is_file() and f.parent == tmp_path / "assets" for f in files[1:])
    b = bullet(files[0])
    expected = {"scene/world", "ground/plane", "ground/apron", *(f"zone/{z.id}" for z in scene.zones)}
    expected |= {p.id for p in scene.placements}
    # one terrain link per friction coefficient: 0.3, rubber's and the sidewalk's
    expected |= {"ground/terrain/0", "ground/terrain/1", "ground/terrain/2"}
    assert set(b.links.values()) == expected
    assert b.friction("ground/terrain/1") == pytest.approx(0.3)
    assert b.friction("ground/terrain/2") == pytest.approx(FRICTION["rubber"])
    assert b.friction("ground/terrain/0") == pytest.approx(scene.zones[2].mu)


@pytest.mark.parametrize("capsules", ["mesh", "pybullet"])
def test_rays_hit_each_object_at_the_top_of_its_parts(street, tmp_path, bullet, capsules):
    path, scene = street
    b = bullet(export_quiet(path, tmp_path, capsules=capsules)[0])
    checked = 0
    for i, pl in enumerate(scene.placements):
        if pl.is_mesh:
            continue
        xy = probe_point(scene, i)
        expected = top_at(placed_parts(scene, i), xy)
        link, z = b.ray(xy)
        assert link == pl.id, (pl.id, xy)
        assert z == pytest.approx(expected, abs=2e-3), pl.id
        checked += 1
    assert checked == len(scene.placements) - 1
    # The capsule of the telephone booth: its top at the centre of the capsule.
    booth = next(i for i, p in enumerate(scene.placements) if p.id == "booth-1")
    (capsule,) = [p for p in resolve(scene.placements[booth].asset).parts if type(p).__name__ == "Capsule"]
    xy = (glb.placement_matrix(scene.placements[booth]) @ np.r_[capsule.pos[:2], 0.0, 1.0])[:2]
    assert b.ray(xy) == (
        "booth-1",
        pytest.approx(capsule.pos[2] + capsule.length / 2 + capsule.radius, abs=2e-3),
    )


def test_the_mesh_object_keeps_its_notch(street, tmp_path, bullet):
    """The kiosk mesh is concave: rays hit its roof on the L and the ground in the notch."""
    path, scene = street
    b = bullet(export_quiet(path, tmp_path)[0])
    m = glb.placement_matrix(scene.placements[-1])
    for local, link, z in (
        ((0.5, 0.5), "kiosk", 2.0),
        ((1.5, 0.5), "kiosk", 2.0),
        ((1.6, 1.6), "zone/walk", 0.0),
    ):
        xy = (m @ np.r_[local, 0.0, 1.0])[:2]
        assert b.ray(xy) == (link, pytest.approx(z, abs=1e-3)), local


def _terrain_probes() -> list[tuple[float, float]]:
    pts = []
    for col in range(len(TILE_ROW)):
        for row in range(2):
            for du, dv in ((0.5, 0.5), (0.2, 0.3), (0.85, 0.7), (0.35, 0.9)):
                pts.append((ORIGIN[0] + (col + du) * TILE, ORIGIN[1] + (row + dv) * TILE))
    return pts


#: How far (m) PyBullet's rays may meet the ground from height_at: rough tiles' pieces lie
#: within their tolerance; convex meshes (slopes' prisms) carry PyBullet's 1 mm margin.
ROUGH_OFF, MESH_OFF = ROUGH_TOLERANCE + 2e-3, 1.5e-3


def test_rays_hit_the_terrain_at_height_at(street, tmp_path, bullet):
    path, scene = street
    b = bullet(export_quiet(path, tmp_path, resolution=0.05)[0])
    footprints = [placed_parts(scene, i, path.parent).convex_hull for i in range(len(scene.placements))]
    checked = 0
    for xy in _terrain_probes():
        if any(not math.isnan(top_at(f, xy)) for f in footprints):
            continue  # an object stands there
        link, z = b.ray(xy)
        expected = float(height_at(scene, *xy))
        kind = TILE_ROW[min(int((xy[0] - ORIGIN[0]) // TILE), len(TILE_ROW) - 1)]["kind"]
        assert link is not None and link.startswith("ground/terrain/"), xy
        off = {"rough": ROUGH_OFF, "slope": MESH_OFF}.get(kind, 1e-4)
        assert z == pytest.approx(expected, abs=off), xy
        checked += 1
    assert checked >= 60
    # The pit's floor is below its rim: its five convex pieces keep it a pit.
    pit = (ORIGIN[0] + 6.5 * TILE, ORIGIN[1] + 0.5 * TILE)
    assert b.ray(pit) == ("ground/terrain/0", pytest.approx(R2 - math.tan(0.3) * TILE / 3, abs=MESH_OFF))


def test_rays_hit_flat_zones_at_ground_level_with_their_friction(street, tmp_path, bullet):
    path, scene = street
    b = bullet(export_quiet(path, tmp_path)[0])
    for xy, link in (
        ((6.0, 0.7), "zone/road"),
        ((6.0, 1.6), "zone/curb"),
        ((1.0, 6.0), "zone/walk"),
        ((21.0, 6.7), "zone/pit"),
        ((6.0, 9.5), "zone/plaza"),
        ((23.5, 9.5), "ground/plane"),
    ):
        assert b.ray(xy) == (link, pytest.approx(0.0, abs=1e-6)), xy
    for zone in scene.zones:
        assert b.friction(f"zone/{zone.id}") == pytest.approx(zone.mu)
    assert b.friction("ground/plane") == pytest.approx(FRICTION["concrete"])


def test_yourdfpy_reads_links_transforms_and_meshes(street, tmp_path):
    path, scene = street
    files = export_quiet(path, tmp_path)
    model = yourdfpy.URDF.load(str(files[0]), build_collision_scene_graph=True, load_collision_meshes=True)
    assert model.validate()
    for pl in scene.placements:
        expected = glb.placement_matrix(pl.model_copy(update={"scale": 1.0}))
        np.testing.assert_allclose(model.get_transform(pl.id, "scene/world"), expected, atol=1e-6)
    lamp = scene.placements[1]
    assert len(model.link_map[lamp.id].collisions) == len(resolve(lamp.asset).parts)
    # Everything it loads lies within the scene's bounds and the apron around them.
    lo, hi = model.collision_scene.bounds
    assert lo[:2] == pytest.approx(np.asarray(scene.bounds.min) - urdf.APRON, abs=1e-6)
    assert hi[:2] == pytest.approx(np.asarray(scene.bounds.max) + urdf.APRON, abs=1e-6)
    visual = model.scene.bounds
    assert visual[1][2] == pytest.approx(
        max(resolve(p.asset).height for p in scene.placements[:-1]), abs=0.05
    )


def test_agents_and_task_are_reported_not_dropped(street, tmp_path):
    path, scene = street
    with pytest.warns(ExportWarning) as caught:
        urdf.export(path, tmp_path)
    messages = sorted(str(w.message) for w in caught)
    assert messages[0].startswith("$.agents: ") and "2 left out" in messages[0]
    assert messages[1].startswith("$.task: ") and "nav-static" in messages[1]
    quiet = scene.model_copy(update={"agents": (), "task": None, "placements": scene.placements[:-1]})
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        urdf.export(quiet, tmp_path / "quiet")


def test_same_scene_same_bytes_and_shared_meshes(street, tmp_path):
    path, _ = street
    a = export_quiet(path, tmp_path / "a")
    b = export_quiet(path, tmp_path / "b")
    assert [f.name for f in a] == [f.name for f in b]
    assert all(x.read_bytes() == y.read_bytes() for x, y in zip(a, b, strict=True))
    # A second scene in the same folder reuses the meshes it shares with the first.
    c = export_quiet(path, tmp_path / "a", name="again")
    assert c[0].name == "again.urdf" and c[1:] == a[1:]
    assert len(list((tmp_path / "a" / "assets").iterdir())) == len(a) - 1


@pytest.mark.parametrize("example", ["street_corner.json", "nav_static_10m.json"])
def test_examples_load_and_stand_on_their_ground(example, tmp_path, bullet):
    scene = load_scene(ROOT / "examples" / example)
    b = bullet(export_quiet(ROOT / "examples" / example, tmp_path)[0])
    for i, pl in enumerate(scene.placements):
        xy = probe_point(scene, i)
        assert b.ray(xy) == (pl.id, pytest.approx(top_at(placed_parts(scene, i), xy), abs=2e-3))
    (x0, y0), (x1, y1) = scene.bounds.min, scene.bounds.max
    xs, ys = np.meshgrid(np.linspace(x0 + 0.13, x1 - 0.17, 9), np.linspace(y0 + 0.11, y1 - 0.19, 9))
    for xy in zip(xs.ravel(), ys.ravel(), strict=True):
        link, z = b.ray(xy)
        if link in {p.id for p in scene.placements}:
            continue
        assert z == pytest.approx(float(height_at(scene, *xy)), abs=1e-4), xy


@pytest.mark.slow
def test_a_generated_street_loads_and_matches_height_at(tmp_path, bullet):
    scene = generated_scene(0)
    b = bullet(export_quiet(scene, tmp_path, resolution=0.05)[0])
    rng = np.random.default_rng(0)
    t = scene.terrain
    for xy in rng.uniform((1.0, 1.0), (59.0, 59.0), size=(200, 2)):
        link, z = b.ray(xy)
        if link == "bench-x":
            continue
        col = int((xy[0] - t.origin[0]) // t.tile_size)
        row = int((xy[1] - t.origin[1]) // t.tile_size)
        inside = 0 <= col < t.cols and 0 <= row < t.rows
        tol = ROUGH_OFF if inside and t.tile(row, col).kind == "rough" else MESH_OFF
        if inside and t.tile(row, col).kind == "stair":
            continue  # a probe may fall within a riser's rounding
        assert link is not None, xy
        assert z == pytest.approx(float(height_at(scene, *xy)), abs=tol), (xy, link)


def test_bad_options_and_assets_are_clear_errors(street, tmp_path):
    path, scene = street
    with pytest.raises(ExportError, match="unknown option 'colour'"):
        urdf.export(path, tmp_path, colour="red")
    with pytest.raises(ExportError, match="capsules"):
        urdf.export(path, tmp_path, capsules="sdf")
    with pytest.raises(ExportError, match="'resolution'"):
        urdf.export(path, tmp_path, resolution=-1.0)
    with pytest.raises(ExportError, match=r"\$\.placements\[6\]\.asset: .*scene_dir"):
        export_quiet(scene, tmp_path)
    outside = scene.model_copy(
        update={"placements": (scene.placements[-1].model_copy(update={"asset": "../kiosk.obj"}),)}
    )
    with pytest.raises(ExportError, match=r"\$\.placements\[0\]\.asset: expected a path inside"):
        export_quiet(outside, tmp_path, scene_dir=path.parent)
    unknown = scene.model_copy(
        update={"placements": (scene.placements[0].model_copy(update={"asset": "sofa/0001"}),)}
    )
    with pytest.raises(ExportError, match=r"\$\.placements\[0\]\.asset: expected a catalog id"):
        export_quiet(unknown, tmp_path)
    # Given the folder, a scene model exports its mesh placements too.
    assert export_quiet(scene, tmp_path, scene_dir=path.parent)[0].is_file()


def test_flat_terrain_keeps_each_zone_friction_where_the_zone_changes(tmp_path, bullet):
    """A zone edge across flat tiles cuts them: each side keeps its own zone's friction, so
    only sloped, stepped and rough tiles get an average (and the report says only those)."""
    zones = [
        {"id": "walk", "kind": "sidewalk", "polygon": _rect(0, 0, 24, 5)},
        {"id": "square", "kind": "vegetation", "polygon": _rect(0, 5, 24, 10)},
    ]
    scene = terrain_scene(zones=zones, placements=[], agents=[], task=None)
    walk, square = scene.zones
    assert walk.mu != square.mu
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ExportWarning)
        files = urdf.export(scene, tmp_path, name="cut")
    b = bullet(files[0])
    checked = 0
    for col, tile in enumerate(TILE_ROW):
        if tile["kind"] != "flat" or "friction" in tile or "material" in tile:
            continue
        for y, zone in ((4.6, walk), (5.4, square)):
            xy = (ORIGIN[0] + (col + 0.4) * TILE, y)
            link, z = b.ray(xy)
            assert link.startswith("ground/terrain/") and z == pytest.approx(height_at(scene, *xy), abs=1e-6)
            assert b.friction(link) == pytest.approx(zone.mu), (xy, link)
            checked += 1
    assert checked == 4
    (report,) = [str(w.message) for w in caught if "friction" in str(w.message)]
    assert "sloped, stepped or rough tile(s)" in report


def test_a_scene_cut_into_tiles_loads_tile_by_tile_and_fits_together(street, tmp_path, bullet, monkeypatch):
    path, scene = street
    assert urdf.tile_side(scene) == 0  # small scenes stay one file
    monkeypatch.setattr(urdf, "MAX_LINKS", 5)  # as if it were a city: cut by default
    monkeypatch.setattr(urdf, "TILE_LINKS", 6)
    files = export_quiet(path, tmp_path)
    index = json.loads(files[0].read_text())
    assert files[0].name == "street-urdf-tiles.json" and index["format"] == "citygen.tiles/1"
    entries = index["tiles"]
    assert len(entries) > 1 and [tmp_path / e["file"] for e in entries] == files[1 : 1 + len(entries)]
    boxes = [shapely.box(*e["min"], *e["max"]) for e in entries]
    # The tiles cover the scene's bounds without overlapping, their edges on the terrain's grid.
    assert shapely.union_all(boxes).equals(shapely.box(*scene.bounds.min, *scene.bounds.max))
    assert sum(b.area for b in boxes) == pytest.approx(24.0 * 10.0)
    owner = {}
    for e, box in zip(entries, boxes, strict=True):
        assert e["file"] == f"street-tile-{e['row']:02d}-{e['col']:02d}.urdf"
        b = bullet(tmp_path / e["file"])
        assert len(b.links) == e["links"]
        for i, pl in enumerate(scene.placements):
            if pl.id in b.index:
                owner.setdefault(pl.id, []).append(e["file"])
                assert box.covers(shapely.Point(pl.position[:2]))
                if not pl.is_mesh:
                    xy = probe_point(scene, i)
                    assert b.ray(xy) == (pl.id, pytest.approx(top_at(placed_parts(scene, i), xy), abs=2e-3))
        for xy in _terrain_probes():
            inside = box.buffer(-1e-6).contains(shapely.Point(xy))
            if inside and not any(
                not math.isnan(top_at(placed_parts(scene, i, path.parent), xy))
                for i in range(len(scene.placements))
            ):
                link, z = b.ray(xy)
                assert link.startswith("ground/terrain/"), xy
                assert z == pytest.approx(height_at(scene, *xy), abs=0.05), xy
    assert sorted(owner) == sorted(p.id for p in scene.placements)
    assert all(len(tiles) == 1 for tiles in owner.values())  # every object in exactly one tile


def test_each_terrain_feature_is_in_the_tiles_it_reaches_into_only(tmp_path, monkeypatch):
    """A tiled export writes each feature in the tiles its footprint reaches into (a tile
    loaded alone has all of its ground; a curb across an edge is in both), not in every tile
    (as it once did: the city's 25 tiles each held all 15,000 curb slabs)."""
    import xml.etree.ElementTree as ET

    from citygen.geometry.features import feature_boxes

    features = [
        {"id": "landing-1", "kind": "landing", "center": [3.0, 3.0], "length": 1.0, "width": 1.0,
         "rise": 0.2},
        {"id": "steps-1", "kind": "steps", "center": [7.0, 5.0], "length": 1.2, "width": 1.0,
         "height": R1, "step_height": 0.15, "step_count": 3},
        {"id": "ramp-1", "kind": "ramp", "center": [13.9, 3.0], "length": 1.0, "width": 0.8, "rise": 0.1},
    ]  # fmt: skip
    terrain = {
        "origin": list(ORIGIN), "tile_size": TILE, "rows": 2, "cols": len(TILE_ROW),
        "tiles": TILE_ROW + TILE_ROW, "features": features,
    }  # fmt: skip
    path = write_terrain_scene(tmp_path / "scene", terrain=terrain)
    scene = load_scene(path)
    monkeypatch.setattr(urdf, "MAX_LINKS", 5)
    monkeypatch.setattr(urdf, "TILE_LINKS", 6)
    files = export_quiet(path, tmp_path / "out")
    entries = json.loads(files[0].read_text())["tiles"]
    assert len(entries) > 1
    where: dict[str, list[str]] = {}
    boxes = expected = 0
    for e in entries:
        root = ET.parse(tmp_path / "out" / e["file"]).getroot()
        for link in root.iter("link"):
            if link.get("name").startswith("ground/features/"):
                boxes += len(link.findall("collision"))
                where.setdefault(e["file"], []).append(link.get("name"))
        box = shapely.box(*e["min"], *e["max"])
        reaching = [f for f in scene.terrain.features if _footprint(f).intersection(box).area > 1e-9]
        assert (e["file"] in where) == bool(reaching)
        expected += sum(len(feature_boxes(f)) for f in reaching)
    assert boxes == expected
    crossing = _footprint(features_by_id(scene)["ramp-1"])  # 13.4-14.4 m: across the edge at 14 m
    assert sum(shapely.box(*e["min"], *e["max"]).intersection(crossing).area > 0 for e in entries) == 2


def _footprint(feature):
    """A terrain feature's footprint (its rotated rectangle), a shapely polygon."""
    import shapely.affinity

    x, y = feature.center
    rect = shapely.box(
        x - feature.length / 2, y - feature.width / 2, x + feature.length / 2, y + feature.width / 2
    )
    return shapely.affinity.rotate(rect, feature.yaw, origin=(x, y), use_radians=True)


def features_by_id(scene):
    return {f.id: f for f in scene.terrain.features}
