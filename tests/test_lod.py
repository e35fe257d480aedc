"""The shared level of detail (citygen.exporters.lod): rougher tiles get finer cells within a
budget, the error model stays above what is measured, and every mesh and heightfield format
(GLB, HTML, USD, MJCF; URDF in test_export_urdf and the city tests) samples through it."""

from __future__ import annotations

import warnings
from types import MappingProxyType

import numpy as np
import pytest

from citygen.exporters import ExportWarning, glb, lod, mjcf, usd
from citygen.exporters.usd import terrain as usd_terrain
from citygen.geometry.terrain import height_at, terrain_mesh
from citygen.spec.scene import Scene

S = 10.0  # m, tile side
#: Rough tiles from smooth to rough (amplitude m, noise scale m), then a flat one.
ROUGH = [(0.02, 1.0), (0.05, 0.6), (0.08, 0.4), (0.09, 0.25)]


def rough_scene(tiles=ROUGH) -> Scene:
    specs = [{"kind": "rough", "amplitude": a, "scale": sc, "seed": 7 + k} for k, (a, sc) in enumerate(tiles)]
    specs.append({"kind": "flat"})
    return Scene.model_validate(
        {
            "format": "citygen.scene/1",
            "bounds": {"min": [0, 0], "max": [S * len(specs), S]},
            "terrain": {"origin": [0, 0], "tile_size": S, "rows": 1, "cols": len(specs), "tiles": specs},
        }
    )


def default_cells(scene: Scene, resolution: float | None = None) -> np.ndarray:
    t = scene.terrain
    return np.array([glb.rough_cells(x, S, resolution) if x.kind == "rough" else 0 for x in t.tiles])


def uniform_error(scene: Scene, budget: int) -> float:
    """The error at the finest uniform sampling within ``budget`` triangles (what the
    exporters did before they allocated)."""
    n = sum(x.kind == "rough" for x in scene.terrain.tiles)
    cap = lod.cells_within(budget, n, lambda c: 2 * c * c + 12 * c)
    return lod.max_error(scene, lambda x: cap if x.kind == "rough" else None)


def test_fit_keeps_the_default_where_it_fits_and_else_samples_rougher_tiles_finer():
    scene = rough_scene()
    default = default_cells(scene)
    assert lod.fit(scene, default, int(lod.triangles(default).sum())) is None
    budget = 40_000
    cells = lod.fit(scene, default, budget)
    assert cells is not None and cells[-1] == 0  # the flat tile is not sampled
    assert int(lod.triangles(cells).sum()) <= budget
    rough = cells[:-1]
    assert rough.tolist() == sorted(rough.tolist()) and rough[0] < rough[-1]
    assert (rough >= lod.MIN_CELLS).all() and (rough <= default[:-1]).all()
    # Closer to height_at than a uniform sampling of the same budget.
    assert lod.max_error(scene, cells) < uniform_error(scene, budget)


def test_fit_counts_a_shared_mesh_once_and_keeps_each_file_within_its_budget():
    scene = rough_scene([(0.05, 0.5)] * 4)
    default = default_cells(scene)
    one = int(lod.triangles(default[:1]).sum())
    same = np.zeros(len(default), dtype=np.int64)  # all four share tile 0's mesh
    assert lod.fit(scene, default, one, share=same) is None
    assert lod.fit(scene, default, one) is not None
    # Two files of two tiles each, 30,000 triangles in all but 10,000 a file.
    groups = [np.array([0, 1]), np.array([2, 3, 4])]
    cells = lod.fit(scene, default, 30_000, groups=groups, group_budget=10_000)
    for g in groups:
        assert int(lod.triangles(cells[g]).sum()) <= 10_000


def test_the_error_model_stays_above_the_measured_error():
    """allocate() relies on the model not promising less error than the mesh has."""
    scene = rough_scene()
    for k, tile in enumerate(scene.terrain.tiles[:-1]):
        for c in (4, 8, 16, 32, 64, 128):
            cells = np.zeros(len(scene.terrain.tiles), dtype=np.int64)
            cells[k] = c
            measured = lod.max_error(scene, cells)
            assert measured <= lod.predicted_error(tile, S, c) * 1.05 + 1e-4, (k, c, measured)


def test_terrain_mesh_samples_each_tile_at_its_own_resolution():
    scene = rough_scene()
    res = np.array([S / 4, S / 10, S / 20, S / 40, np.nan])
    mesh = terrain_mesh(scene, resolution=res)
    per_tile = np.bincount(mesh.metadata["face_tile"], minlength=5)
    # A closed rough tile of c cells a side: 2 c^2 on top, 12 c in its walls and floor.
    assert per_tile[:4].tolist() == [int(lod.triangles(np.int64(c))) for c in (4, 10, 20, 40)]
    assert per_tile[4] == 12  # the flat tile: a box
    # One resolution for all is the same mesh as that resolution everywhere.
    same = terrain_mesh(scene, resolution=np.full(5, 0.5))
    assert np.array_equal(same.faces, terrain_mesh(scene, resolution=0.5).faces)


def coarsening(caught, fmt: str) -> list[str]:
    return [
        str(w.message)
        for w in caught
        if issubclass(w.category, ExportWarning) and f"{fmt} samples" in str(w.message)
    ]


@pytest.mark.parametrize("fmt", ["glb", "html"])
def test_glb_and_html_sample_rougher_tiles_finer_within_their_budget(monkeypatch, fmt):
    scene = rough_scene()
    budget = 40_000
    monkeypatch.setattr(lod, "BUDGETS", MappingProxyType({**lod.BUDGETS, fmt: budget}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        graph = glb.build(scene, fmt=fmt, y_up=False)
    (line,) = coarsening(caught, fmt.upper())
    assert "finer where rougher" in line
    error = float(line.split("(up to ")[1].split(" cm")[0]) / 100
    assert error < uniform_error(scene, budget - 12)  # the flat tile's box takes 12
    terrain = graph.geometry["terrain"]
    assert len(terrain.faces) <= budget
    # Its rough tiles' tops lie on height_at: the mesh's vertices are samples of the ground.
    top = np.asarray(terrain.vertices)
    top = top[(top[:, 2] > -0.5) & (top[:, 0] > 0.01) & (top[:, 0] < 4 * S - 0.01)]
    np.testing.assert_allclose(top[:, 2], height_at(scene, top[:, 0], top[:, 1]), atol=1e-5)


def test_usd_samples_rougher_tiles_finer_within_its_budget(tmp_path, monkeypatch):
    scene = rough_scene()
    monkeypatch.setattr(usd_terrain, "DEFAULT_TERRAIN_TRIANGLES", 20_000)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        files = usd.export(scene, tmp_path)
    (line,) = coarsening(caught, "USD")
    assert "finer where rougher" in line
    assert usd.check(files[0]) == []


def test_mjcf_heightfields_are_finer_where_rougher_and_compile(monkeypatch):
    mujoco = pytest.importorskip("mujoco")
    scene = rough_scene()
    budget = 20_000
    monkeypatch.setattr(lod, "BUDGETS", MappingProxyType({**lod.BUDGETS, "mjcf": budget}))
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        model = mjcf.build(scene)
    (line,) = coarsening(caught, "MJCF")
    assert "finer where rougher" in line
    assert int(model.hfield_nrow @ model.hfield_ncol) <= budget
    sides = model.hfield_nrow.tolist()
    assert sides == sorted(sides) and sides[0] < sides[-1]  # tiles in order, smooth to rough
    data = mujoco.MjData(model)
    mujoco.mj_step(model, data)
