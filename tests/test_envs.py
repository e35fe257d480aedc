"""The runner's Gymnasium environments: the API checker, seeded replay, the paper's reward,
pedestrians every step, the vector environment, the baselines, and the CLI commands."""

from __future__ import annotations

import json
import math
import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import citygen
import citygen.runner
from citygen.exporters import ExportWarning
from citygen.runner import ENV_IDS
from citygen.runner.bench import run_episode
from citygen.runner.envs import NAV_HORIZON
from citygen.runner.make import make_env, make_vector_env
from citygen.runner.policies import make_policy

pytestmark = pytest.mark.filterwarnings("ignore::citygen.exporters.ExportWarning")


@pytest.fixture(scope="module")
def nav2():
    return [citygen.generate("urban-nav-2-test", index=i) for i in range(4)]


@pytest.mark.slow
@pytest.mark.parametrize("env_id", sorted(ENV_IDS))
def test_check_env_passes_for_every_registered_id(env_id):
    kwargs = {"max_steps": 50} if "Traverse" in env_id else {}
    env = gymnasium.make(env_id, **kwargs)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ExportWarning)
        check_env(env.unwrapped, skip_render_check=True)
    env.close()


def _rollout(env, seed, actions):
    obs, _ = env.reset(seed=seed)
    trace = [obs]
    rewards = []
    for a in actions:
        obs, r, term, trunc, _ = env.step(a)
        trace.append(obs)
        rewards.append(r)
        if term or trunc:
            break
    return trace, rewards


def test_a_seeded_episode_replays_identically():
    actions = np.random.default_rng(3).uniform(-1, 1, (40, 2)).astype(np.float32)
    a = make_env("nav-dynamic", split="urban-nav-3-test")
    b = make_env("nav-dynamic", split="urban-nav-3-test")
    ta, ra = _rollout(a, 11, actions)
    tb, rb = _rollout(b, 11, actions)
    assert ra == rb
    assert len(ta) == len(tb)
    for x, y in zip(ta, tb, strict=True):
        for key in x:
            np.testing.assert_array_equal(x[key], y[key])
    # another seed draws another scene or another crowd
    _, rc = _rollout(a, 12, actions)
    assert rc != ra


@pytest.mark.parametrize(
    ("task", "robot", "keys"),
    [
        ("nav-static", "wheeled", ["goal", "velocity", "local_map", "local_map_crossable"]),
        ("nav-dynamic", "quadruped", ["goal", "local_map_motion", "local_map_inside"]),
        ("nav-static", "wheeled", ["height_map"]),
        ("loco-rough", "quadruped", ["command", "joint_pos"]),
    ],
)
def test_observing_some_keys_gives_those_keys_bit_for_bit(task, robot, keys):
    """observations=[...] computes only those pieces; each is what the full observation
    holds, every step, and rewards and endings do not change."""
    full = make_env(task, robot=robot)
    some = make_env(task, robot=robot, observations=keys)
    assert set(some.observation_space.spaces) == set(keys)
    actions = np.random.default_rng(1).uniform(-1, 1, (60, *full.action_space.shape)).astype(np.float32)
    ta, ra = _rollout(full, 4, actions)
    tb, rb = _rollout(some, 4, actions)
    assert ra == rb and len(ta) == len(tb) > 1
    for x, y in zip(ta, tb, strict=True):
        assert set(y) == set(keys) and some.observation_space.contains(y)
        for key in keys:
            assert x[key].dtype == y[key].dtype
            np.testing.assert_array_equal(x[key], y[key])


def test_observing_an_unknown_key_is_a_one_line_error():
    from citygen.errors import SpecError

    with pytest.raises(SpecError) as err:
        make_env("nav-static", observations=["goal", "depth"])  # depth only with depth=True
    assert "observations" in str(err.value) and "'depth'" in str(err.value) and "local_map" in str(err.value)
    assert "\n" not in str(err.value)


def test_reward_is_the_papers_formula(nav2):
    env = make_env("nav-static", nav2[0])
    env.reset(seed=0)
    obs, reward, term, trunc, info = env.step(np.zeros(2, np.float32))
    d = info["distance"]
    expected = 2.0 * ((1 - math.tanh(d / 1.0)) + 0.2 * (1 - math.tanh(d / 0.2)))
    expected -= 0.5 * (not info["walkable"]) + 1.0 * info["collision"]
    assert not term and not trunc
    assert reward == pytest.approx(expected)
    # the goal vector is in the robot's frame: turn the world offset by the yaw (the step's,
    # not the reset's: a robot settling on its tyres turns a little in its first step)
    x, y, yaw = info["pose"]
    gx, gy = nav2[0].task.goal
    u = math.cos(yaw) * (gx - x) + math.sin(yaw) * (gy - y)
    assert obs["goal"][0] == pytest.approx(u, abs=1e-4)
    assert obs["height_map"].shape == (17, 11)


def test_an_episode_ends_at_the_horizon_with_the_metrics(nav2):
    env = make_env("nav-static", nav2[1])
    result = run_episode(env, make_policy("random", seed=1), seed=1)
    assert 1 <= result["steps"] <= NAV_HORIZON
    for key in ("success_rate", "route_completion", "spl", "on_walkable", "collision"):
        assert key in result
    assert 0.0 <= result["route_completion"] <= 100.0


def test_an_episode_lasts_the_scenes_time_limit_unless_max_steps_cuts_it(nav2):
    scene = nav2[1].model_copy(update={"task": nav2[1].task.model_copy(update={"time_limit": 1.5})})
    for options, steps in (({}, 15), ({"max_steps": 7}, 7)):
        env = make_env("nav-static", scene, **options)
        env.reset(seed=0)
        n, term, trunc = 0, False, False
        while not (term or trunc) and n < 100:
            _, _, term, trunc, _ = env.step(np.zeros(2, np.float32))
            n += 1
        assert (n, trunc, term) == (steps, True, False)
        env.close()


def test_planner_reaches_goals_random_does_not(nav2):
    planner = [run_episode(make_env("nav-static", s), make_policy("planner"), seed=0) for s in nav2]
    random = [run_episode(make_env("nav-static", s), make_policy("random", seed=0), seed=0) for s in nav2]
    assert sum(r["success_rate"] == 100.0 for r in planner) >= 3
    assert sum(r["success_rate"] == 100.0 for r in random) <= 1
    assert np.mean([r["spl"] for r in planner]) > 0.5


@pytest.mark.slow
def test_pedestrians_never_overlap_and_stay_on_walkable_ground_every_step():
    tol = 0.05
    for index in range(3):
        env = make_env("nav-dynamic", citygen.generate("urban-nav-3-test", index=index))
        obs, _ = env.reset(seed=index)
        policy = make_policy("planner")
        policy.reset(env)
        u = env.unwrapped
        for _ in range(NAV_HORIZON):
            obs, _, term, trunc, _ = env.step(policy.act(obs))
            c = u.crowd
            if c is not None and len(c.ids):
                d = np.hypot(*(c.pos[:, None, :] - c.pos[None, :, :]).transpose(2, 0, 1))
                np.fill_diagonal(d, np.inf)
                assert np.all(d >= (c.radius[:, None] + c.radius[None, :]) - tol)
                x, y, _, _ = u.handle.pose(u.data)
                gap = np.hypot(c.pos[:, 0] - x, c.pos[:, 1] - y) - c.radius - u.robot.radius
                assert np.all(gap >= -tol - 0.1)  # the robot is not ORCA's to steer: it may push in
                cells = [u.prepared.occupancy.cell(px, py) for px, py in c.pos]
                assert all(u.prepared.walkable[cell] for cell in cells)
            if term or trunc:
                break


def test_vector_env_runs_a_different_scene_in_each_sub_env():
    venv = make_vector_env("nav-static", split="urban-nav-2-train", num_envs=2, asynchronous=False)
    _, infos = venv.reset(seed=5)
    first = tuple(infos["index"])
    assert first[0] != first[1]
    seen = set(first)
    for _ in range(3):
        _, infos = venv.reset()
        seen |= set(infos["index"])
    assert len(seen) >= 4  # every reset draws new scenes
    venv.close()


def test_loco_stand_controller_keeps_balance():
    env = make_env("loco-flat", split="urban-loc-1-test", max_steps=150)
    result = run_episode(env, make_policy("stand"), seed=0)
    assert result["balance"] == 100.0
    assert result["steps"] == 150


def test_loco_trot_walks_forward():
    env = make_env("loco-flat", split="urban-loc-1-test", max_steps=300, randomize=False)  # forward
    result = run_episode(env, make_policy("trot"), seed=0)
    assert result["x_displacement"] > 0.5


@pytest.mark.slow
def test_traverse_modes_count_interventions():
    rows = {}
    for mode in ("human", "ai", "shared-cautious"):
        env = make_env("traverse", split="urban-tra-standard", max_steps=300)
        rows[mode] = run_episode(env, make_policy(mode), seed=0)
    assert rows["ai"]["labor_cost"] == 0.0
    assert rows["ai"]["interventions"] == 0
    assert rows["human"]["labor_cost"] == pytest.approx(rows["human"]["steps"] * 0.1, rel=1e-6)
    assert rows["human"]["interventions"] == 1
    assert 0.0 <= rows["shared-cautious"]["labor_cost"] <= rows["human"]["labor_cost"]


def test_cli_bench_prints_the_table_and_writes_json(cli, tmp_path):
    out = tmp_path / "bench.json"
    r = cli("bench", "--task", "nav-static", "--split", "urban-nav-2-test", "--policy", "planner",
            "--episodes", "2", "--jobs", "1", "--output", out)  # fmt: skip
    assert r.code == 0, r.err
    assert "Success Rate" in r.out
    doc = json.loads(out.read_text())
    assert doc["episodes"] == 2 and doc["policy"] == "planner"
    assert set(doc["summary"]) >= {"success_rate", "spl", "route_completion"}
    assert doc["summary"]["success_rate"]["n"] == 2


def test_cli_bench_max_steps_cuts_every_episode(cli, tmp_path):
    out = tmp_path / "bench.json"
    r = cli("bench", "--task", "nav-static", "--split", "urban-nav-2-test", "--policy", "random",
            "--episodes", "2", "--jobs", "1", "--max-steps", "7", "--output", out)  # fmt: skip
    assert r.code == 0, r.err
    rows = json.loads(out.read_text())["rows"]
    assert len(rows) == 2 and all(1 <= row["steps"] <= 7 for row in rows)
    bad = cli("bench", "--task", "nav-static", "--max-steps", "0")
    assert bad.code == 2 and "--max-steps" in bad.err and "Traceback" not in bad.err


def test_cli_run_saves_frames(cli, tmp_path):
    scene = tmp_path / "s.json"
    citygen.save_scene(citygen.generate("urban-nav-2-train", index=1), scene)
    r = cli("run", scene, "--policy", "planner", "--frames", tmp_path / "frames", "--every", "10")
    assert r.code == 0, r.err
    assert "Success Rate (%)" in r.out  # the table of `citygen bench`
    assert len(list((tmp_path / "frames").glob("*.png"))) >= 1


def test_cli_bad_policy_is_one_line_exit_2(cli, tmp_path):
    r = cli("bench", "--task", "nav-static", "--policy", "telepathy", "--episodes", "1")
    assert r.code == 2
    assert "telepathy" in r.err
    assert "Traceback" not in r.err


def test_cli_run_with_a_users_own_robot_and_adapter(cli, tmp_path):
    from tests.test_robots import MJCF_ROBOT

    robot = tmp_path / "cart.xml"
    robot.write_text(MJCF_ROBOT)
    adapter = tmp_path / "cart.toml"
    adapter.write_text(
        'radius = 0.35\nmax_speed = 1.2\nmax_yaw_rate = 1.5\ncasters = ["caster"]\n'
        '[nav]\nmode = "wheels"\nleft = ["left_axle"]\nright = ["right_axle"]\n'
        "wheel_radius = 0.08\ntrack_width = 0.42\n"
    )
    scene = tmp_path / "s.json"
    citygen.save_scene(citygen.generate("urban-nav-2-train", index=3), scene)
    r = cli("run", scene, "--robot", robot, "--adapter", adapter, "--policy", "planner")
    assert r.code == 0, r.err
    moved = float(r.out.split("Route Completion (%)")[1].split()[0])
    assert moved > 10.0  # the cart drove toward the goal (percent of the route)
    bad = tmp_path / "bad.toml"
    bad.write_text('radius = "wide"\n')
    r = cli("run", scene, "--robot", robot, "--adapter", bad)
    assert r.code == 2 and len(r.err.strip().splitlines()) == 1 and "bad.toml" in r.err
