"""A scene's maps made in a second process (citygen.runner.scene_maps, what a town's or a
city's first reset does while it builds the model): the same arrays as in this process, the
crowd's tables kept in the on-disk store when there is one, the second process's errors
raised here, and small scenes made in this process."""

from __future__ import annotations

import functools
import os
import signal

import numpy as np
import pytest

import citygen
from citygen.runner.agents.crowd import TABLES_ENTRY, crowd_of
from citygen.runner.robots import load_robot
from citygen.runner.scene_maps import MapsProcess, Mover, build_maps, worth_a_process
from citygen.runner.scene_store import SceneStore
from citygen.runner.scenes import map_resolution, prepare


@pytest.fixture(scope="module")
def scene():
    return citygen.generate("urban-nav-3-test", index=2)  # people on it


@pytest.fixture(scope="module")
def robot():
    return load_robot("quadruped")


@pytest.fixture(scope="module")
def res(scene):
    return map_resolution(scene)


@pytest.fixture(scope="module")
def serial(scene, robot, res):
    return build_maps(scene, robot, res, people=True)


def _same_maps(a, b) -> None:
    for name in ("crossable", "free", "walkable"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and np.array_equal(x, y), name
    for name in ("labels", "heights", "terrain"):
        x, y = getattr(a.occupancy, name), getattr(b.occupancy, name)
        assert x.dtype == y.dtype and np.array_equal(x, y), name
    assert a.occupancy.grid == b.occupancy.grid
    assert a.occupancy.classes == b.occupancy.classes


def _same_tables(a: dict, b: dict) -> None:
    assert set(a) == set(b) == {"paths", "clearance", "blocked"}
    for name in a:
        assert a[name].dtype == b[name].dtype and np.array_equal(a[name], b[name]), name


def test_maps_made_in_a_second_process_are_the_same(scene, robot, res, serial):
    assert serial.tables is not None and len(serial.tables["paths"]) > 0
    apart = MapsProcess(scene, robot, res, people=True).result()
    _same_maps(serial, apart)
    _same_tables(serial.tables, apart.tables)
    assert build_maps(scene, Mover.of(robot), res).tables is None  # no people asked for


def test_the_second_process_keeps_the_crowd_tables_in_the_store(scene, robot, res, serial, tmp_path):
    key = "ab" * 32
    apart = MapsProcess(scene, robot, res, people=True, store=(tmp_path, key)).result()
    _same_maps(serial, apart)
    assert apart.tables is None  # not sent: kept in the store
    disk = SceneStore(tmp_path)
    _same_tables(serial.tables, {n: disk.load_array(key, f"{TABLES_ENTRY}-{n}") for n in serial.tables})


def test_a_prepared_scene_is_the_same_either_way_and_its_crowd_too(scene, robot, monkeypatch):
    """prepare(process=True) against prepare(process=False): the same maps and model; the
    crowd made from the second process's tables moves as the one made here."""
    monkeypatch.setenv("CITYGEN_CACHE_DIR", "off")
    here = prepare(scene, robot, people=True, process=False)
    apart = prepare(scene, robot, people=True, process=True)
    for name in ("free", "crossable", "walkable", "obstacle_geoms", "ground_geoms"):
        assert np.array_equal(getattr(here, name), getattr(apart, name)), name
    assert here.agent_bodies == apart.agent_bodies and here.model.ngeom == apart.model.ngeom
    assert not hasattr(here, "_crowd_tables") and hasattr(apart, "_crowd_tables")
    crowds = [crowd_of(p, scene, rng=np.random.default_rng(3), dt=0.1) for p in (here, apart)]
    assert not hasattr(apart, "_crowd_tables")  # taken by the crowd
    robot_xy = np.array(scene.task.start.position, dtype=float)
    for _ in range(20):
        for c in crowds:
            c.step(robot_xy, np.zeros(2), 0.3)
    assert np.array_equal(crowds[0].pos, crowds[1].pos) and np.array_equal(crowds[0].vel, crowds[1].vel)


def test_an_error_in_the_second_process_is_raised_here(scene, res):
    """The same exception, with the second process's traceback as a note."""
    bad = Mover("quadruped", float("inf"), 0.1)  # erode cannot take an infinite radius
    with pytest.raises(OverflowError) as info:
        MapsProcess(scene, bad, res).result()
    notes = "\n".join(getattr(info.value, "__notes__", []))
    assert "In the process making the scene's maps" in notes and "erode" in notes
    with pytest.raises(OverflowError):
        build_maps(scene, bad, res)  # as here


def test_a_second_process_that_dies_is_a_clear_error(scene, robot, res):
    maps = MapsProcess(scene, robot, res, people=True)
    os.kill(maps._proc.pid, signal.SIGKILL)
    with pytest.raises(RuntimeError, match=r"ended with exit code -9 before sending them"):
        maps.result()


def test_only_a_town_or_a_city_is_worth_a_second_process(scene):
    assert not worth_a_process(scene, map_resolution(scene))  # an Urban-Nav square: 200 x 200 cells
    town = _town()
    assert worth_a_process(town, map_resolution(town))


@functools.cache
def _town():
    from citygen.generate import generate
    from citygen.generate.splits import town_config
    from citygen.seeding import scene_seed

    return generate(town_config(), scene_seed(2025, "urban-tra-city", 0))


def test_a_daemonic_process_makes_its_maps_itself(monkeypatch):
    """A vector environment's worker (daemonic: it may not start processes) on a town."""
    from citygen.runner import scene_maps

    town = _town()
    assert worth_a_process(town, map_resolution(town))

    class Daemon:
        daemon = True

    monkeypatch.setattr(scene_maps.mp, "current_process", lambda: Daemon())
    assert not worth_a_process(town, map_resolution(town))


def test_the_second_process_does_not_run_the_main_script_again(tmp_path):
    """A script without a ``__main__`` guard: spawn would import it again in the second
    process (and start it again there); it runs once."""
    import subprocess
    import sys

    script = tmp_path / "script.py"
    runs = tmp_path / "runs.txt"
    script.write_text(
        "import citygen\n"
        "from citygen.runner.robots import load_robot\n"
        "from citygen.runner.scene_maps import MapsProcess\n"
        f"open({str(runs)!r}, 'a').write('run\\n')\n"
        "scene = citygen.generate('urban-nav-3-test', index=2)\n"
        "MapsProcess(scene, load_robot('quadruped'), 0.05).result()\n"
    )
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    subprocess.run([sys.executable, str(script)], check=True, env=env, timeout=300)
    assert runs.read_text() == "run\n"
