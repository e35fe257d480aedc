"""A locomotion policy riding on the scripted walk (citygen.runner.learn.residual): a zero
residual at the walk's own speed is the walk to the bit, a tiny run with ``gait = "walk"``
exports a policy that ``citygen bench`` runs on the walk, and the config says where a gait
does not belong."""

from __future__ import annotations

import json

import numpy as np
import pytest

from citygen.errors import SpecError
from citygen.runner.bench import run_episode
from citygen.runner.learn.config import load_config
from citygen.runner.learn.residual import PHASE_KEY
from citygen.runner.make import make_env
from tests.conftest import TINY_LOCO, loco_grid, scripted_and_zero_residual, tiny_loco_run

GRID = loco_grid("flat", "humanoid")
TINY = TINY_LOCO + 'gait = "walk"\ngait_max_speed = 0.6\n'


@pytest.fixture(scope="module")
def grid(tmp_path_factory):
    path = tmp_path_factory.mktemp("grid") / "grid.toml"
    path.write_text(GRID)
    return path


def test_a_zero_residual_at_the_walks_speed_is_the_scripted_walk(grid):
    env = make_env("loco-flat", robot="humanoid", split=str(grid))
    try:
        runs, _ = scripted_and_zero_residual(env, "walk")  # the humanoid's --policy trot is its walk
        assert runs[0].tobytes() == runs[1].tobytes()
        assert np.hypot(*(runs[0][-1, :2] - runs[0][0, :2])) > 0.3  # it walked
    finally:
        env.close()


def test_a_tiny_residual_run_exports_a_policy_that_rides_on_the_walk(tmp_path, grid):
    from citygen.runner.learn.export import read_policy, write_policy
    from citygen.runner.learn.policy import load_policy
    from citygen.runner.learn.residual import ResidualPolicy

    out, printed = tiny_loco_run(tmp_path, "loco-flat", "humanoid", grid, TINY)
    meta = json.loads((out / "policy.json").read_text())
    assert meta["gait"] == {"name": "walk", "scale": 0.2, "max_speed": 0.6} and PHASE_KEY in meta["keys"]
    assert "Balance" in printed
    # its network silenced (a zero mean), the policy is the walk at 0.4 m/s: it walks
    trained = read_policy(out / "policy.npz")
    arrays = {f"w{i}": w for i, w in enumerate(trained.weights)} | {
        f"b{i}": b for i, b in enumerate(trained.biases)
    }
    last = len(trained.weights) - 1
    arrays[f"w{last}"], arrays[f"b{last}"] = (
        np.zeros_like(arrays[f"w{last}"]),
        np.zeros_like(arrays[f"b{last}"]),
    )
    silent = write_policy(tmp_path / "silent.npz", trained.meta, arrays)
    policy = load_policy(silent)
    assert isinstance(policy, ResidualPolicy) and PHASE_KEY not in policy.shapes
    env = make_env("loco-flat", robot="humanoid", split=str(grid), max_steps=250)
    try:
        result = run_episode(env, policy, seed=1)
    finally:
        env.close()
    assert result["balance"] == 100.0 and result["x_displacement"] > 1.0, result


def test_a_gait_is_for_locomotion(tmp_path):
    config = tmp_path / "nav.toml"
    config.write_text('task = "nav-static"\ngait = "walk"\n')
    with pytest.raises(SpecError, match=r"gait.*locomotion task"):
        load_config(config)


@pytest.mark.parametrize(
    "gait, robot, message",
    [
        ("walk", "quadruped", "needs a biped, not 'quadruped'"),
        ("trot", "humanoid", "needs a four-legged robot, not 'humanoid'"),
    ],
)
def test_the_walk_is_for_a_biped_and_the_trot_for_a_four_legged_robot(grid, gait, robot, message):
    from citygen.errors import CitygenError
    from citygen.runner.learn.residual import ResidualTraining

    env = make_env("loco-flat", robot=robot, split=str(grid))
    try:
        with pytest.raises(CitygenError, match=message):
            ResidualTraining(env, gait=gait, scale=0.2)
    finally:
        env.close()


def test_the_shipped_humanoid_walks_a_flat_test_episode_on_its_walk():
    """The shipped LocoFlat humanoid (a residual over the walk, numpy only) walks a whole test
    episode: no fall in 20 s and at least 90 % of the paper's 16.61 m X-displacement, where
    the scripted walk alone makes 8.0 m."""
    from citygen.runner.learn.policy import baseline, load_policy
    from citygen.runner.learn.residual import ResidualPolicy

    policy = load_policy(baseline("loco-flat", "humanoid"))
    assert isinstance(policy, ResidualPolicy)
    env = make_env("loco-flat", robot="humanoid")
    try:
        result = run_episode(env, policy, seed=3)
    finally:
        env.close()
    assert result["balance"] == 100.0 and result["x_displacement"] >= 0.9 * 16.61, result
