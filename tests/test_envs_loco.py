"""Locomotion episodes as the paper's test: a seed draws the region of the Urban-Loc grid,
the start pose in it and the command; the robot starts standing on the ground under every
part of it (rough bumps, stair edges), and only its body touching down is a fall."""

from __future__ import annotations

import numpy as np
import pytest

from citygen.runner.bench import make_env
from citygen.runner.robots import lowest_point
from citygen.runner.tasks import robots_for


@pytest.fixture(scope="module")
def rough():
    env = make_env("loco-rough", robot="quadruped")
    yield env
    env.close()


def test_seeds_draw_region_start_and_command(rough):
    starts = []
    for seed in range(6):
        _, info = rough.reset(seed=seed)
        x, y, _, yaw = rough.handle.pose(rough.data)
        starts.append((info["region"], round(x, 3), round(y, 3), round(yaw, 3), info["command"]))
        speed = np.hypot(*rough.scene.task.command[:2])
        assert np.hypot(*info["command"][:2]) == pytest.approx(speed)  # fixed magnitude
        assert info["command"][2] == rough.scene.task.command[2]
    assert len({s[0] for s in starts}) > 1, starts  # regions
    assert len({s[1:4] for s in starts}) == len(starts), starts  # poses
    assert len({s[4] for s in starts}) == len(starts), starts  # commands
    _, again = rough.reset(seed=3)
    assert (again["region"], again["command"]) == (starts[3][0], starts[3][4])


def test_options_pick_region_and_command(rough):
    obs, info = rough.reset(seed=0, options={"region": (15, 2), "command": (0.5, 0.0, 0.2)})
    assert info["region"] == (15, 2)
    np.testing.assert_allclose(obs["command"], (0.5, 0.0, 0.2))
    x, y, _, _ = rough.handle.pose(rough.data)
    assert (int(y // 8), int(x // 8)) == (15, 2)


def test_without_randomize_the_scene_start_and_command_hold():
    env = make_env("loco-flat", robot="quadruped", randomize=False)
    try:
        for seed in (0, 1):
            obs, _ = env.reset(seed=seed)
            np.testing.assert_allclose(obs["command"], env.scene.task.command)
            np.testing.assert_allclose(env.handle.pose(env.data)[:2], env.scene.task.start.position)
    finally:
        env.close()


@pytest.mark.slow
@pytest.mark.parametrize("task", ["loco-rough", "loco-stair"])
@pytest.mark.parametrize("robot", robots_for("loco-rough"))
def test_spawn_clears_the_ground_and_standing_still_is_no_fall(task, robot):
    """The LocoRough regression: a robot put down on the hardest rows stands, any seed."""
    from citygen.geometry.terrain import height_at

    env = make_env(task, robot=robot, max_steps=25)
    try:
        m, d = env.model, env.data
        for seed in range(6):
            env.reset(seed=seed, options={"region": (15 - seed % 2, seed)})  # the hardest rows
            ids = env.handle.geom_ids
            low = np.array([lowest_point(m, d, int(g)) for g in ids])
            ground = height_at(env.scene, d.geom_xpos[ids, 0], d.geom_xpos[ids, 1])
            assert np.all(low >= ground - 1e-6), (seed, low - ground)
            assert not np.any(
                env._fall_geoms[d.contact.geom1[: d.ncon]] | env._fall_geoms[d.contact.geom2[: d.ncon]]
            )
            for t in range(25):
                _, _, terminated, _, info = env.step(np.zeros(env.n_joints))
                assert not terminated, (task, robot, seed, t, info)
    finally:
        env.close()


def test_a_fall_is_the_body_not_the_legs(rough):
    rough.reset(seed=0)
    names = {rough.model.geom(int(g)).name.removeprefix("robot/") for g in np.flatnonzero(rough._fall_geoms)}
    assert {"trunk", "head"} <= names
    assert not any(n.startswith(("FR_", "FL_", "RR_", "RL_")) for n in names), names
