"""Learned policies: ``citygen train`` (interrupted and resumed), the exported numpy policy
against PyTorch, ``citygen bench --policy FILE|ppo`` and its one-line errors, scene sampling.

These tests need the ``train`` extra (Stable-Baselines3 and PyTorch); CI installs it."""

from __future__ import annotations

import csv
import json
import pickle
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from citygen.runner.learn.export import clip_goal
from citygen.runner.learn.policy import resolve_policy, shipped
from citygen.runner.learn.train import latest_checkpoint
from citygen.runner.policies import POLICIES
from tests.conftest import ROOT

pytestmark = pytest.mark.filterwarnings("ignore::citygen.exporters.ExportWarning")

#: A tiny PPO: 2 sub-environments of 50 steps per rollout, a checkpoint every 100 steps.
TINY = """
n_steps = 50
minibatches = 2
n_epochs = 2
net_arch = [32, 32]
checkpoint_every = 100
"""


#: ``citygen train`` on NavClear with 2 sub-environments in this process.
TRAIN = [sys.executable, "-m", "citygen", "train", "--task", "nav-clear", "--envs", "2", "--processes", "0"]


def _train(*args, timeout: float = 300):
    cmd = [*TRAIN, *map(str, args)]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=timeout)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    """A tiny run stopped (SIGTERM, as ``kill`` or a scheduler does) after its first
    checkpoint, then resumed to 400 steps."""
    folder = tmp_path_factory.mktemp("train")
    config = folder / "tiny.toml"
    config.write_text(TINY)
    out = folder / "run"
    cmd = [
        *TRAIN,
        "--steps",
        "100000",
        "--config",
        str(config),
        "--out",
        str(out),
        "--seed",
        "3",
    ]
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 300
    try:
        while latest_checkpoint(out) is None:
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < deadline, "no checkpoint within 300 s"
            time.sleep(0.2)
    finally:
        proc.send_signal(signal.SIGTERM)
        try:
            _, stopped = proc.communicate(timeout=120)
        except subprocess.TimeoutExpired:
            proc.kill()
            _, stopped = proc.communicate()
    killed_at = latest_checkpoint(out)[0]
    resumed = _train("--steps", 400, "--config", config, "--out", out, "--seed", 3, "--resume")
    return {
        "out": out,
        "killed_at": killed_at,
        "resumed": resumed,
        "config": config,
        "stopped": (proc.returncode, stopped),
    }


@pytest.mark.slow
def test_an_interrupted_run_resumes_from_its_last_checkpoint(run):
    out, r = run["out"], run["resumed"]
    code, stopped = run["stopped"]
    # SIGTERM saved a checkpoint where the run was and said how to go on, in one line
    assert code == 130 and stopped.count("\n") == 1 and f"--resume --out {out}" in stopped, stopped
    assert r.returncode == 0, r.stderr
    last = run["killed_at"]
    assert last < 400
    assert f"resuming from {out / 'checkpoints' / f'model_{last}.zip'} ({last:,} steps)" in r.stdout
    from stable_baselines3 import PPO

    # SIGTERM may land mid-rollout: the run then ends with the first rollout (2 x 50 steps) past 400
    done = PPO.load(out / "model.zip").num_timesteps
    assert 400 <= done < 500 and (done - last) % 100 == 0
    with open(out / "curve.csv", newline="") as f:
        steps = [int(row["steps"]) for row in csv.DictReader(f)]
    assert steps == sorted(set(steps)) and steps[-1] == done  # continued, no row twice
    assert (out / "curve.png").stat().st_size > 1000
    meta = json.loads((out / "policy.json").read_text())
    assert meta["task"] == "nav-clear" and meta["robot"] == "wheeled" and meta["train"]["steps"] == done


@pytest.mark.slow
def test_the_trained_model_is_evaluated_by_citygen_bench(run, cli):
    for model in ("policy.npz", "model.zip"):
        r = cli(
            "bench", "--task", "nav-clear", "--policy", run["out"] / model, "--episodes", "1", "--jobs", "1"
        )
        assert r.code == 0, r.err
        assert "Success Rate" in r.out and model in r.out


@pytest.mark.slow
@pytest.mark.parametrize("jobs", [1, 2])
def test_a_benchmark_runs_the_model_of_its_start_when_the_file_goes_or_changes(run, tmp_path, jobs):
    """A checkpoint benchmarked while its run trains on is rotated away or overwritten between
    episodes: every episode still runs the model the benchmark started with."""
    import shutil

    from citygen.runner.bench import run_bench

    folder = tmp_path / "run"
    shutil.copytree(run["out"], folder)
    zips = sorted((folder / "checkpoints").glob("model_*.zip"), key=lambda p: int(p.stem[6:]))
    baseline = ROOT / "citygen" / "runner" / "learn" / "baselines" / "nav-clear-wheeled.npz"
    kw = {"robot": "wheeled", "episodes": 4, "jobs": jobs, "seed": 3, "max_steps": 20}
    for path, other in ((folder / "policy.npz", baseline), (zips[-1], zips[0])):
        whole = run_bench("nav-clear", "urban-nav-1-test", policy=str(path), **kw)

        def meddle(done: int, total: int, row: dict, path=path, other=other) -> None:
            if done == 1:
                path.unlink()
            elif done == 2:  # another model under its name
                shutil.copy(other, path)

        assert run_bench("nav-clear", "urban-nav-1-test", policy=str(path), progress=meddle, **kw) == whole


@pytest.mark.slow
def test_numpy_policy_gives_the_actions_of_torch(run):
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import VecNormalize

    from citygen.runner.learn import read_policy
    from citygen.runner.make import make_env

    out = run["out"]
    model = PPO.load(out / "model.zip", device="cpu")
    with open(out / "vecnormalize.pkl", "rb") as f:
        stats = pickle.load(f)
    policy = read_policy(out / "policy.npz")
    env = make_env("nav-clear", split="urban-nav-1-test")
    obs, _ = env.reset(seed=1)
    batch = []
    for k in range(30):
        batch.append({key: obs[key] for key in policy.keys})
        obs, *_ = env.step(np.array([0.8, 0.3 * np.sin(k)], dtype=np.float32))
    stacked = {key: np.stack([o[key] for o in batch]) for key in policy.keys}
    assert isinstance(stats, VecNormalize)
    # Training clipped far goals to the run's goal_range before normalising; so does the export.
    assert policy.meta["goal_range"] == 5.0
    assert np.linalg.norm(stacked["goal"], axis=1).max() > 5.0  # the test goal is further
    clipped = clip_goal(stacked, 5.0)
    torch_actions, _ = model.predict(stats.normalize_obs(clipped), deterministic=True)
    numpy_actions = policy.predict(stacked)
    assert np.abs(numpy_actions).max() > 1e-3  # a real network, not zeros
    np.testing.assert_allclose(numpy_actions, torch_actions, atol=1e-5)
    # Sampled: the trained Gaussian around the same mean, reproducible with the generator's seed.
    std = np.exp(model.policy.log_std.detach().numpy())
    draws = [policy.predict(stacked, np.random.default_rng(seed)) for seed in (0, 0, 1)]
    np.testing.assert_array_equal(draws[0], draws[1])
    assert not np.allclose(draws[0], draws[2])
    mean = policy.mean(stacked)
    inside = (np.abs(mean) < 0.5).all(axis=1)  # where clipping to [-1, 1] cannot hide a draw
    assert inside.sum() >= 5
    noise = (draws[2] - mean)[inside]
    assert np.abs(noise).max() < 5 * std.max() and noise.std() > 0.3 * std.min()


def test_clip_goal_shortens_far_goals_to_the_range_and_keeps_their_direction():
    goals = np.array([[3.0, 4.0], [12.0, -5.0], [0.0, 0.0]], dtype=np.float32)
    out = clip_goal({"goal": goals, "velocity": np.ones(3)}, 5.0)
    np.testing.assert_allclose(out["goal"][0], [3.0, 4.0])  # at the range: unchanged
    np.testing.assert_allclose(out["goal"][1], np.array([12.0, -5.0]) * 5.0 / 13.0, rtol=1e-6)
    np.testing.assert_allclose(out["goal"][2], [0.0, 0.0])
    np.testing.assert_allclose(clip_goal({"goal": goals[1]}, 5.0)["goal"], out["goal"][1])
    assert clip_goal({"goal": goals}, None)["goal"] is goals
    assert out["velocity"] is not None and "goal" in clip_goal({"goal": goals}, 5.0)


def test_the_training_env_gives_the_policy_clipped_goals():
    from citygen.runner.learn.config import TrainConfig
    from citygen.runner.learn.vecenv import make_training_env

    venv = make_training_env(TrainConfig(task="nav-clear", envs=2, processes=0, goal_range=2.0))
    try:
        obs = venv.reset()
        # The sub-environments compute only the keys the policy reads.
        assert set(venv.venv.single_observation_space.spaces) == set(TrainConfig(task="nav-clear").obs_keys)
        assert np.linalg.norm(obs["goal"], axis=1).max() == pytest.approx(2.0, abs=1e-5)
        obs, _, _, _ = venv.step(np.zeros((2, 2), dtype=np.float32))
        assert np.linalg.norm(obs["goal"], axis=1).max() <= 2.0 + 1e-5
    finally:
        venv.close()


def test_max_steps_cuts_training_episodes():
    """``max_steps`` is the sub-environments' horizon: a robot standing still is cut after 3
    steps with it, not within 3 without it (the task's 200)."""
    from citygen.runner.learn.config import TrainConfig
    from citygen.runner.learn.vecenv import make_training_env

    for max_steps in (None, 3):
        venv = make_training_env(TrainConfig(task="nav-clear", envs=1, processes=0, max_steps=max_steps))
        try:
            venv.reset()
            ends = [bool(venv.step(np.zeros((1, 2), dtype=np.float32))[2][0]) for _ in range(3)]
        finally:
            venv.close()
        assert ends == ([False, False, True] if max_steps == 3 else [False, False, False])


def _numpy_policy_of(encoder, space, encoders: dict):
    """A :class:`NumpyPolicy` whose features are ``encoder``'s: its ``local_map`` CNN's
    weights, the meta's ``encoders`` as given, an all-zero 3-action head."""
    import torch

    from citygen.runner.learn.export import NumpyPolicy

    seq = encoder.encoders["local_map"]
    convs = [m for m in seq if isinstance(m, torch.nn.Conv2d)]
    arrays = {"w0": np.zeros((3, encoder.features_dim), np.float32), "b0": np.zeros(3, np.float32)}
    for i, c in enumerate(convs):
        arrays[f"enc/local_map/conv{i}/w"] = c.weight.detach().numpy()
        arrays[f"enc/local_map/conv{i}/b"] = c.bias.detach().numpy()
    arrays["enc/local_map/fc/w"] = seq[-2].weight.detach().numpy()
    arrays["enc/local_map/fc/b"] = seq[-2].bias.detach().numpy()
    meta = {
        "keys": list(space.spaces),
        "shapes": [list(s.shape) for s in space.spaces.values()],
        "encoders": encoders,
        "activation": "tanh",
        "action_low": [-1.0] * 3,
        "action_high": [1.0] * 3,
        "action_shape": [3],
        "clip_obs": 10.0,
        "epsilon": 1e-8,
    }
    return NumpyPolicy(meta, arrays)


def test_the_map_encoder_exports_to_numpy_exactly():
    """The CNN that reads ``local_map`` (strided convolutions, then a linear layer) gives the
    same features in numpy as in PyTorch, for a batch of random maps."""
    import gymnasium
    import torch

    from citygen.runner.learn.nets import MapEncoder

    space = gymnasium.spaces.Dict(
        {
            "goal": gymnasium.spaces.Box(-np.inf, np.inf, (2,), np.float32),
            "local_map": gymnasium.spaces.Box(-np.inf, np.inf, (2, 32, 32), np.float32),
        }
    )
    torch.manual_seed(0)
    encoder = MapEncoder(space, conv=((8, 5, 2), (16, 3, 2)), map_features=24)
    assert encoder.features_dim == 2 + 24
    policy = _numpy_policy_of(encoder, space, {"local_map": {"strides": [2, 2]}})
    rng = np.random.default_rng(1)
    obs = {
        "goal": rng.normal(size=(5, 2)).astype(np.float32),
        "local_map": rng.random((5, 2, 32, 32), np.float32),
    }
    with torch.no_grad():
        expected = encoder({k: torch.as_tensor(v) for k, v in obs.items()}).numpy()
    got = policy.features(obs)
    assert np.abs(expected[:, 2:]).max() > 1e-3  # the map's features are not all zero
    np.testing.assert_allclose(got, expected, atol=1e-5)


def test_a_stacked_map_is_one_cnn_over_both_keys_and_exports_to_numpy_exactly():
    """``stack``: ``local_map`` and ``local_map_crossable`` as the input channels of one CNN
    (its first layer reads 3 channels, no second encoder, no features of the second key's own),
    the same features in numpy as in PyTorch; and each key's channels matter."""
    import gymnasium
    import torch

    from citygen.runner.learn.nets import MapEncoder

    space = gymnasium.spaces.Dict(
        {
            "goal": gymnasium.spaces.Box(-np.inf, np.inf, (2,), np.float32),
            "local_map": gymnasium.spaces.Box(-np.inf, np.inf, (2, 32, 32), np.float32),
            "local_map_crossable": gymnasium.spaces.Box(0, 1, (1, 32, 32), np.float32),
        }
    )
    torch.manual_seed(0)
    stack = (("local_map", "local_map_crossable"),)
    encoder = MapEncoder(space, conv=((8, 5, 2),), map_features=24, stack=stack)
    assert list(encoder.encoders) == ["goal", "local_map"] and encoder.features_dim == 2 + 24
    seq = encoder.encoders["local_map"]
    assert seq[0].in_channels == 3
    stacked = {"local_map": {"strides": [2], "stack": ["local_map", "local_map_crossable"]}}
    policy = _numpy_policy_of(encoder, space, stacked)
    rng = np.random.default_rng(1)
    obs = {
        "goal": rng.normal(size=(5, 2)).astype(np.float32),
        "local_map": rng.random((5, 2, 32, 32), np.float32),
        "local_map_crossable": (rng.random((5, 1, 32, 32)) > 0.5).astype(np.float32),
    }
    with torch.no_grad():
        expected = encoder({k: torch.as_tensor(v) for k, v in obs.items()}).numpy()
    got = policy.features(obs)
    assert got.shape == (5, 26)
    np.testing.assert_allclose(got, expected, atol=1e-5)
    flipped = policy.features({**obs, "local_map_crossable": 1.0 - obs["local_map_crossable"]})
    assert np.abs(flipped - got)[:, 2:].max() > 1e-3  # the stacked layer reaches the features
    with pytest.raises(ValueError, match="stack"):
        MapEncoder(space, stack=(("local_map", "goal"),))


@pytest.mark.slow
def test_a_stacked_run_trains_exports_and_is_evaluated(tmp_path, cli):
    """A tiny run reading local_map_crossable and the wide map (a key environments give only
    on request) stacked into the local map's CNN: its policy file names the stack, loads and
    drives ``citygen bench``, which asks the environment for the wide map; a stack of a key the
    run does not read is a one-line error naming the field."""
    config = tmp_path / "stack.toml"
    layers = '["local_map", "local_map_crossable", "local_map_wide"]'
    config.write_text(TINY + f'keys = ["goal", "velocity", {layers[1:]}\nstack = [{layers}]\n')
    r = _train("--steps", 100, "--config", config, "--out", tmp_path / "run")
    assert r.returncode == 0, r.stderr
    meta = json.loads((tmp_path / "run" / "policy.json").read_text())
    assert meta["encoders"] == {
        "local_map": {"strides": [2, 2], "stack": ["local_map", "local_map_crossable", "local_map_wide"]}
    }
    r = cli("bench", "--task", "nav-clear", "--policy", tmp_path / "run" / "policy.npz", "--episodes", "2")
    assert r.code == 0 and "Success Rate" in r.out, r.err
    from citygen.runner.learn.policy import PolicyError, check_fits, load_policy
    from citygen.runner.make import make_env

    env = make_env("nav-clear")  # the default keys: no wide map
    with pytest.raises(PolicyError, match=r"only when asked: make_env\(\.\.\., observations="):
        check_fits(load_policy(tmp_path / "run" / "policy.npz"), env, "policy.npz")
    with pytest.raises(KeyError, match=r"'local_map_wide'\] that the observation lacks"):
        load_policy(tmp_path / "run" / "policy.npz").act(env.reset(seed=0)[0])
    env.close()
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY + 'stack = [["local_map", "local_map_crossable"]]\n')
    r = _train("--steps", 100, "--config", bad, "--out", tmp_path / "bad")
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "stack" in r.stderr and "local_map_crossable" in r.stderr, r.stderr


@pytest.mark.slow
def test_a_seeded_run_is_reproducible(tmp_path):
    config = tmp_path / "tiny.toml"
    config.write_text(TINY)
    arrays = []
    for name in ("a", "b"):
        r = _train("--steps", 100, "--config", config, "--out", tmp_path / name, "--seed", 5)
        assert r.returncode == 0, r.stderr
        with np.load(tmp_path / name / "policy.npz") as data:
            arrays.append({k: data[k] for k in data.files if k != "meta"})
    assert arrays[0].keys() == arrays[1].keys()
    for k in arrays[0]:
        np.testing.assert_array_equal(arrays[0][k], arrays[1][k])


# --- one-line errors ------------------------------------------------------------------------


def test_missing_train_extra_is_one_line_naming_it(cli, monkeypatch):
    monkeypatch.setitem(sys.modules, "stable_baselines3", None)  # import fails as if not installed
    r = cli("train", "--task", "nav-clear", "--steps", "10")
    assert r.code == 2
    assert r.err.count("\n") == 1 and 'pip install -e ".[train]"' in r.err


def test_a_bad_config_or_a_used_run_folder_is_one_line(cli, tmp_path):
    bad = tmp_path / "bad.toml"
    bad.write_text("learning_rat = 0.1\n")
    r = cli("train", "--config", bad, "--out", tmp_path / "x")
    assert r.code == 2 and r.err.count("\n") == 1 and "learning_rate" in r.err
    used = tmp_path / "used"
    (used / "checkpoints").mkdir(parents=True)
    (used / "checkpoints" / "model_100.zip").write_bytes(b"x")
    (used / "checkpoints" / "vecnormalize_100.pkl").write_bytes(b"x")
    r = cli("train", "--task", "nav-clear", "--out", used)
    assert r.code == 2 and r.err.count("\n") == 1 and "--resume" in r.err
    r = cli("train", "--task", "nav-clear", "--out", tmp_path / "empty", "--resume")
    assert r.code == 2 and r.err.count("\n") == 1 and "no checkpoint" in r.err


@pytest.mark.parametrize("name", ["bad.npz", "bad.zip"])
def test_a_corrupt_model_file_is_one_line(cli, tmp_path, name):
    path = tmp_path / name
    path.write_bytes(b"this is not a model")
    r = cli("bench", "--task", "nav-clear", "--policy", path, "--episodes", "1", "--jobs", "1")
    assert r.code == 2, r.err
    assert r.err.count("\n") == 1 and name in r.err and "Traceback" not in r.err


def test_a_model_of_another_tasks_spaces_is_one_line(cli):
    nav = shipped()[("nav-clear", "quadruped")]
    r = cli(
        "bench",
        "--task",
        "loco-flat",
        "--robot",
        "quadruped",
        "--policy",
        nav,
        "--episodes",
        "1",
        "--jobs",
        "1",
    )
    assert r.code == 2
    assert r.err.count("\n") == 1 and "loco-flat" in r.err and "Traceback" not in r.err


def test_a_missing_shipped_baseline_names_the_robots_and_tasks_that_have_one(cli):
    r = cli("bench", "--task", "loco-slope", "--robot", "humanoid", "--policy", "ppo", "--episodes", "1")
    assert r.code == 2 and r.err.count("\n") == 1
    assert "no shipped baseline for loco-slope with robot humanoid" in r.err
    have = shipped()
    robots = ", ".join(sorted(rb for t, rb in have if t == "loco-slope"))
    tasks = ", ".join(sorted(t for t, rb in have if rb == "humanoid"))
    assert f"robots with one for loco-slope: {robots}; tasks with one for humanoid: {tasks}" in r.err
    assert "quadruped" in robots and "loco-flat" in tasks


# --- shipped baselines ----------------------------------------------------------------------

SHIPPED = sorted(shipped())


def test_at_least_one_baseline_ships():
    assert SHIPPED


@pytest.mark.parametrize(("task", "robot"), SHIPPED)
def test_policy_ppo_resolves_and_runs_for_every_shipped_baseline(cli, task, robot):
    path = resolve_policy("ppo", task, robot, POLICIES)
    # the task's own model, or for locomotion the robot's general model
    assert Path(path).name in (f"{task}-{robot}.npz", f"loco-general-{robot}.npz"), path
    meta = json.loads(Path(path).with_suffix(".json").read_text())
    assert meta["train"]["command"].startswith("citygen train")  # each made by a documented command
    r = cli("bench", "--task", task, "--robot", robot, "--policy", "ppo", "--episodes", "1", "--jobs", "1")
    assert r.code == 0, r.err
    assert ("Balance" if task.startswith("loco") else "Success Rate") in r.out


def test_every_shipped_policy_pickles_and_acts_the_same_after():
    """``citygen bench`` hands the loaded policy to its workers, which a spawn or forkserver
    start (macOS's, and Python 3.14's on Linux) pickles: every shipped file must survive it."""
    from citygen.runner.learn.policy import load_policy

    rng = np.random.default_rng(0)
    for (task, robot), path in sorted(shipped().items()):
        policy = load_policy(path)
        copy = pickle.loads(pickle.dumps(policy))
        inner, inner_copy = getattr(policy, "inner", policy), getattr(copy, "inner", copy)
        obs = {k: rng.normal(size=shape).astype(np.float32) for k, shape in inner.shapes.items()}
        np.testing.assert_array_equal(inner_copy.act(obs), inner.act(obs), err_msg=f"{task} {robot}")


# --- scene sampling -------------------------------------------------------------------------


def test_sync_sampling_gives_every_sub_env_the_same_scene_and_async_does_not():
    from citygen.runner.learn.vecenv import _sub_env

    def indices(sampling):
        envs = [
            _sub_env("nav-clear", "urban-nav-1-train", "wheeled", 16, sampling, 0, rank, 3)
            for rank in range(3)
        ]
        first = [e.reset(seed=rank)[1]["index"] for rank, e in enumerate(envs)]
        for e in envs:
            for _ in range(3):
                e.step(np.zeros(2, dtype=np.float32))
        second = [e.reset()[1]["index"] for e in envs]
        return first, second

    first, second = indices("sync")
    assert len(set(first)) == 1 and len(set(second)) == 1 and first != second  # a new scene per rollout
    first, second = indices("async")
    assert len(set(first + second)) > 2
    assert all(0 <= i < 16 for i in first + second)


def test_more_scenes_than_the_split_lists_continue_its_seed_derivation():
    from citygen.runner.learn.vecenv import _sub_env

    env = _sub_env("nav-clear", "urban-nav-1-train", "wheeled", 300, "async", 0, 0, 200)
    source = env.unwrapped.source
    assert source.size == 300
    assert source.scene(280).meta.index == 280
    assert source.scene(280).model_dump() != source.scene(280 - 256).model_dump()


def test_progress_shaping_pays_for_geodesic_progress_and_only_in_training():
    """The training wrapper adds ``scale`` per metre gained along the walkable geodesic:
    driving at the goal earns more than the environment's own reward, backing away less,
    and the environment's reward itself (what bench reports) is unchanged."""
    from citygen.runner.learn.config import TrainConfig
    from citygen.runner.learn.shaping import ProgressReward
    from citygen.runner.make import make_env

    assert TrainConfig().progress > 0

    def drive(env, toward: bool) -> tuple[float, float]:
        obs, _ = env.reset(seed=3, options={"index": 0})
        u = env.unwrapped
        start = u.prepared.field(u._goal(), u.tolerance).at(*u.handle.pose(u.data)[:2])
        total = 0.0
        for _ in range(30):
            g = obs["goal"]
            heading = float(np.arctan2(g[1], g[0]))
            turn = np.clip(heading if toward else heading - np.pi * np.sign(heading), -1, 1)
            obs, r, term, trunc, _ = env.step(np.array([0.8 if abs(turn) < 0.5 else 0.0, turn]))
            total += r
            if term or trunc:
                break
        end = u.prepared.field(u._goal(), u.tolerance).at(*u.handle.pose(u.data)[:2])
        return total, start - end

    plain = make_env("nav-clear", split="urban-nav-1-train", robot="wheeled")
    shaped = ProgressReward(make_env("nav-clear", split="urban-nav-1-train", robot="wheeled"), 2.0)
    for toward in (True, False):
        base, gained = drive(plain, toward)
        total, gained2 = drive(shaped, toward)
        assert gained == pytest.approx(gained2, abs=1e-6)  # same episode, same physics
        assert (gained > 0.5) == toward and (gained < -0.5) == (not toward)
        assert total - base == pytest.approx(2.0 * gained, rel=1e-6, abs=1e-6)


def test_the_lean_term_charges_only_a_base_leaning_past_twenty_degrees():
    """``tilt``: ``tilt x ((a - TILT_FREE) / TILT_SPAN)^2`` a step for a lean ``a`` past
    TILT_FREE, nothing under it; the environment's own reward unchanged."""
    import mujoco

    from citygen.runner.learn.shaping import TILT_FREE, TILT_SPAN, ProgressReward
    from citygen.runner.make import make_env

    plain = make_env("nav-clear", split="urban-nav-1-train", robot="wheeled")
    shaped = ProgressReward(make_env("nav-clear", split="urban-nav-1-train", robot="wheeled"), 0.0, tilt=3.0)
    charged = []
    for roll in (0.1, 0.42, 0.47):
        for env in (plain, shaped):
            env.reset(seed=3, options={"index": 0})
            u = env.unwrapped
            q = u.data.qpos[u.handle.qadr + 3 : u.handle.qadr + 7]
            q[:] = (np.cos(roll / 2), np.sin(roll / 2), 0.0, 0.0)  # leaning sideways
            mujoco.mj_forward(u.model, u.data)
        lean = np.arccos(shaped.unwrapped.data.xmat[shaped.unwrapped.handle.base_id][8])
        assert lean == pytest.approx(roll, abs=1e-9)
        assert shaped.lean_cost() == pytest.approx(max(roll - TILT_FREE, 0) ** 2 / TILT_SPAN**2, abs=1e-9)
        a = np.array([0.0, 0.0])
        (_, base, *_), (_, total, *_) = plain.step(a), shaped.step(a)
        assert total == pytest.approx(base - 3.0 * shaped.lean_cost(), abs=1e-9)
        charged.append(total < base - 1e-6)
    assert not charged[0] and charged[-1]  # upright: nothing; still leaning past 20 degrees: charged


def test_driving_backwards_costs_what_it_moves_so_reversing_to_the_goal_earns_nothing():
    """The shaping's ``reverse`` term: reversing straight at the goal (the goal behind the
    robot) gains the geodesic progress and gives the same metres back; driving forwards
    keeps it."""
    from citygen.runner.learn.config import TrainConfig
    from citygen.runner.learn.shaping import ProgressReward
    from citygen.runner.make import make_env

    assert TrainConfig().reverse == 1.0

    def drive(env, forwards: bool) -> tuple[float, float, float]:
        obs, _ = env.reset(seed=3, options={"index": 0})
        u = env.unwrapped
        start = u.prepared.field(u._goal(), u.tolerance).at(*u.handle.pose(u.data)[:2])
        total = 0.0
        for _ in range(40):
            g = obs["goal"] if forwards else -obs["goal"]  # reversing: point the tail at the goal
            heading = float(np.arctan2(g[1], g[0]))
            v = 0.8 if abs(heading) < 0.5 else 0.0
            obs, r, term, trunc, _ = env.step(np.array([v if forwards else -v, np.clip(heading, -1, 1)]))
            total += r
            if term or trunc:
                break
        end = u.prepared.field(u._goal(), u.tolerance).at(*u.handle.pose(u.data)[:2])
        return total, start - end

    for forwards in (True, False):
        plain = make_env("nav-clear", split="urban-nav-1-train", robot="wheeled")
        shaped = ProgressReward(
            make_env("nav-clear", split="urban-nav-1-train", robot="wheeled"), 1.0, 0.99, 1.0
        )
        base, gained = drive(plain, forwards)
        total, _ = drive(shaped, forwards)
        assert gained > 1.0  # both ways get closer to the goal
        extra = total - base
        if forwards:
            assert extra == pytest.approx(gained, abs=0.05)
        else:
            assert abs(extra) < 0.2 * gained  # progress in reverse is taken back


def test_backing_off_an_obstacle_is_not_charged_as_reversing():
    """A step that starts in collision is not charged for moving backwards (the way off a pole
    the robot drove into); the step after one that ended clear is."""
    from citygen.runner.learn.shaping import ProgressReward
    from citygen.runner.make import make_env

    def reverse_charges(touching: bool) -> list[float]:
        env = make_env("nav-clear", split="urban-nav-1-train", robot="wheeled")
        env.unwrapped._collision = lambda x, y: touching  # as if pressed against an object
        shaped = ProgressReward(env, 0.0, 0.99, 1.0)
        shaped.reset(seed=3, options={"index": 0})
        plain = make_env("nav-clear", split="urban-nav-1-train", robot="wheeled")
        plain.unwrapped._collision = env.unwrapped._collision
        plain.reset(seed=3, options={"index": 0})
        charges = []
        for _ in range(10):
            a = np.array([-0.8, 0.0], dtype=np.float32)
            _, r, *_ = shaped.step(a)
            _, r0, *_ = plain.step(a)
            charges.append(r0 - r)
        return charges

    pinned, clear = reverse_charges(True), reverse_charges(False)
    # The first step starts from the reset, clear of everything; every later one in contact.
    assert max(abs(c) for c in pinned[1:]) < 1e-9
    assert sum(clear) > 0.3  # 10 steps in reverse at up to 1.2 m/s: most of a metre charged


def test_a_success_earns_holding_the_goal_so_hovering_never_pays_more():
    """Reaching the goal ends the episode; the shaping pays the discounted tracking reward of
    standing on the goal until the horizon, so finishing sooner is worth more than hovering
    just outside the tolerance (where the paper's tracking term pays ~1 a step)."""
    from citygen.runner.learn.shaping import TRACK_AT_GOAL, ProgressReward
    from citygen.runner.make import make_env

    env = ProgressReward(make_env("nav-clear", split="urban-nav-1-train", robot="wheeled"), 1.0, 0.99)
    plain = make_env("nav-clear", split="urban-nav-1-train", robot="wheeled")
    outcomes = []
    for e in (env, plain):
        obs, _ = e.reset(seed=3, options={"index": 0})
        rewards = []
        for _ in range(200):
            g = obs["goal"]
            heading = float(np.arctan2(g[1], g[0]))
            obs, r, term, trunc, info = e.step(
                np.array([0.8 if abs(heading) < 0.5 else 0.0, np.clip(heading, -1, 1)])
            )
            rewards.append(r)
            if term or trunc:
                break
        outcomes.append((rewards, info, e.unwrapped.steps, e.unwrapped.horizon))
    (shaped, info, steps, horizon), (base, base_info, _, _) = outcomes
    assert info["is_success"] and base_info["is_success"] and len(shaped) == len(base)
    left = horizon - steps
    hold = TRACK_AT_GOAL * 0.99 * (1 - 0.99**left) / (1 - 0.99)
    assert hold > 50  # more than the success bonus: hovering ~1 a step for the rest cannot beat it
    # the last step: the paper's reward + the last bit of progress + holding the goal
    assert shaped[-1] - base[-1] == pytest.approx(hold, abs=1.5)
    assert shaped[-1] - base[-1] > hold


@pytest.mark.slow
def test_init_starts_from_another_runs_weights_and_a_misfit_is_one_line(run, tmp_path):
    """``--init`` fine-tunes: a short run started from the fixture's model stays next to its
    weights (a fresh run is far from them); a model of another network shape is one line."""
    config = run["config"]
    r = _train(
        "--steps", 100, "--config", config, "--out", tmp_path / "ft", "--seed", 4, "--init", run["out"]
    )
    assert r.returncode == 0, r.stderr
    fresh = _train("--steps", 100, "--config", config, "--out", tmp_path / "fresh", "--seed", 4)
    assert fresh.returncode == 0, fresh.stderr

    def weights(folder):
        with np.load(folder / "policy.npz") as data:
            return data["w0"]

    base = weights(run["out"])
    assert (
        np.abs(weights(tmp_path / "ft") - base).mean()
        < 0.1 * np.abs(weights(tmp_path / "fresh") - base).mean()
    )
    other = tmp_path / "other.toml"
    other.write_text(config.read_text().replace("net_arch = [32, 32]", "net_arch = [16]"))
    r = _train("--steps", 100, "--config", other, "--out", tmp_path / "bad", "--init", run["out"])
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--init" in r.stderr, r.stderr


@pytest.mark.slow
def test_init_adds_a_layer_to_a_stack_with_its_weights_at_zero(tmp_path, cli):
    """A run that reads ``local_map_motion`` at the end of the local map's stack starts from
    one that did not: the first convolution keeps the old channels' weights and gives the new
    ones 0, so it starts as the old policy (a critic warm-up holds the actor still here); a
    stack that puts the new layer first is a one-line error."""
    keys = '"goal", "velocity", "local_map", "local_map_crossable"'
    base = tmp_path / "base.toml"
    base.write_text(TINY + f"keys = [{keys}]\nstack = [[{keys.split(', ', 2)[2]}]]\n")
    r = _train("--steps", 100, "--config", base, "--out", tmp_path / "a", "--seed", 2)
    assert r.returncode == 0, r.stderr
    wide = tmp_path / "wide.toml"
    stack = '"local_map", "local_map_crossable", "local_map_motion"'
    wide.write_text(
        TINY + f'keys = [{keys}, "local_map_motion"]\nstack = [[{stack}]]\ncritic_warmup = 1000\n'
    )
    r = _train(
        "--steps", 100, "--config", wide, "--out", tmp_path / "b", "--seed", 2, "--init", tmp_path / "a"
    )
    assert r.returncode == 0, r.stderr
    # the same from the exported file (a shipped baseline has no run folder)
    r = _train(
        "--steps", 100, "--config", wide, "--out", tmp_path / "n", "--seed", 2,
        "--init", tmp_path / "a" / "policy.npz",
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    for run in ("b", "n"):
        with np.load(tmp_path / "a" / "policy.npz") as a, np.load(tmp_path / run / "policy.npz") as b:
            conv = "enc/local_map/conv0/w"
            assert a[conv].shape[1] == 3 and b[conv].shape[1] == 5
            np.testing.assert_array_equal(b[conv][:, :3], a[conv])
            assert not b[conv][:, 3:].any()
            for k in ("w0", "w1", "w2", "enc/local_map/conv1/w", "enc/local_map/fc/w"):
                np.testing.assert_array_equal(a[k], b[k])
            for k in a.files:  # the file's observation statistics, the new layer's its own
                if k.startswith("obs_mean/") and run == "n":
                    assert b[k] == pytest.approx(a[k], rel=1e-2, abs=1e-2)
    r = cli("bench", "--task", "nav-dynamic", "--policy", tmp_path / "b" / "policy.npz", "--episodes", "1")
    assert r.code == 0 and "Success Rate" in r.out, r.err
    first = tmp_path / "first.toml"
    first.write_text(
        TINY + f'keys = [{keys}, "local_map_motion"]\n'
        'stack = [["local_map_motion", "local_map", "local_map_crossable"]]\n'
    )
    for init in (tmp_path / "a", tmp_path / "a" / "policy.npz"):
        r = _train("--steps", 100, "--config", first, "--out", tmp_path / "c", "--init", init)
        assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--init" in r.stderr, r.stderr


@pytest.mark.slow
def test_init_from_an_exported_policy_keeps_its_actor_and_statistics(run, tmp_path):
    """``--init policy.npz`` (a shipped baseline's kind of file) starts from its actor, encoder
    and observation statistics; a policy for another network is one line, exit 2."""
    config = run["config"]
    npz = run["out"] / "policy.npz"
    r = _train("--steps", 100, "--config", config, "--out", tmp_path / "ft", "--seed", 5, "--init", npz)
    assert r.returncode == 0, r.stderr
    with np.load(npz) as base, np.load(tmp_path / "ft" / "policy.npz") as tuned:
        assert np.abs(tuned["w0"] - base["w0"]).mean() < 0.02 * np.abs(base["w0"]).mean()
        stats = [k for k in base.files if k.startswith("obs_mean/")]
        assert stats
        for k in stats:  # started from the file's statistics, moved little in 100 steps
            assert tuned[k] == pytest.approx(base[k], rel=1e-2, abs=1e-2)
    other = tmp_path / "other.toml"
    other.write_text(config.read_text().replace("net_arch = [32, 32]", "net_arch = [16]"))
    r = _train("--steps", 100, "--config", other, "--out", tmp_path / "bad", "--init", npz)
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--init" in r.stderr, r.stderr
    r = _train("--steps", 100, "--config", config, "--out", tmp_path / "bad2", "--init", tmp_path / "no.npz")
    assert r.returncode == 2 and r.stderr.count("\n") == 1 and "--init" in r.stderr, r.stderr


@pytest.mark.slow
def test_a_critic_warmup_moves_the_critic_alone(run, tmp_path):
    """``critic_warmup``: started from an exported policy (no critic), the updates of the
    first steps train the fresh value head alone; after the warm-up the actor learns again.
    SB3's approximate KL is the mean over an update's minibatches of how far the actor moved
    from the rollout's: exactly 0 only if no minibatch moved it."""
    npz = run["out"] / "policy.npz"
    config = tmp_path / "warm.toml"
    config.write_text(run["config"].read_text() + "critic_warmup = 200\n")
    out = tmp_path / "warm"
    # 4 rollouts of 100 steps; SB3 writes an update's losses with the next rollout's row
    r = _train("--steps", 400, "--config", config, "--out", out, "--seed", 6, "--init", npz)
    assert r.returncode == 0, r.stderr
    (log,) = (out / "logs").glob("run-*/progress.csv")
    with open(log, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r.get("train/value_loss")]
    kl = [float(r["train/approx_kl"]) for r in rows]
    assert len(kl) == 3 and kl[0] == kl[1] == 0.0 and kl[2] > 0.0, kl
    assert all(float(r["train/value_loss"]) > 0.0 for r in rows)
    with np.load(npz) as base, np.load(out / "policy.npz") as tuned:
        assert not np.array_equal(tuned["w0"], base["w0"])


THREADS_PROBE = """
import json, sys, torch
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecNormalize
from citygen.runner.learn.config import TrainConfig
from citygen.runner.learn.train import train
seen = {"update": set(), "rollout": set()}
update, step = PPO.train, VecNormalize.step_wait
def probe_update(self):
    seen["update"].add(torch.get_num_threads())
    return update(self)
def probe_step(self):
    seen["rollout"].add(torch.get_num_threads())
    return step(self)
PPO.train, VecNormalize.step_wait = probe_update, probe_step
default = torch.get_num_threads()
cfg = TrainConfig(task="nav-clear", steps=200, envs=2, processes=0, n_steps=50, minibatches=2,
                  n_epochs=1, net_arch=(16,), torch_threads=int(sys.argv[1]),
                  update_threads=int(sys.argv[2]))
train(cfg, sys.argv[3], progress=False)
print(json.dumps({"default": default, **{k: sorted(v) for k, v in seen.items()}}))
"""


@pytest.mark.slow
@pytest.mark.parametrize("torch_threads, update_threads", [(1, 2), (1, 3), (0, 3)])
def test_the_update_gets_update_threads_and_the_rollout_torch_threads(
    tmp_path, torch_threads, update_threads
):
    """PPO's update runs while the sub-environments wait, so it takes ``update_threads`` of
    PyTorch's threads; the rollout, sharing the cores with them, ``torch_threads`` (0:
    PyTorch's own number), every rollout after an update too."""
    r = subprocess.run(
        [sys.executable, "-c", THREADS_PROBE, str(torch_threads), str(update_threads), str(tmp_path / "run")],
        capture_output=True, text=True, cwd=ROOT, timeout=300,
    )  # fmt: skip
    assert r.returncode == 0, r.stderr
    seen = json.loads(r.stdout.strip().splitlines()[-1])
    rollout = torch_threads or seen["default"]
    assert rollout != update_threads, seen  # else the test could not tell them apart
    assert seen["update"] == [update_threads] and seen["rollout"] == [rollout], seen


@pytest.mark.slow
def test_log_std_final_narrows_the_noise_on_a_schedule(run, tmp_path):
    """``log_std_final`` lowers a ceiling on the log std linearly over the run: the second
    of two rollouts samples under half the way down, and the saved policy ends on it."""
    from citygen.runner.learn.config import TrainConfig
    from citygen.runner.learn.train import log_std_cap

    cfg = TrainConfig(steps=200, log_std_init=0.5, log_std_final=-2.0)
    assert [log_std_cap(cfg, n) for n in (0, 100, 200, 400)] == [0.5, -0.75, -2.0, -2.0]
    assert log_std_cap(TrainConfig(steps=200), 100) is None
    config = tmp_path / "anneal.toml"
    config.write_text(run["config"].read_text() + "log_std_final = -2.0\n")
    r = _train("--steps", 200, "--config", config, "--out", tmp_path / "anneal", "--seed", 4)
    assert r.returncode == 0, r.stderr
    with np.load(tmp_path / "anneal" / "policy.npz") as annealed:
        assert np.all(annealed["log_std"] <= -2.0 + 1e-6), annealed["log_std"]
    with np.load(run["out"] / "policy.npz") as default:
        assert np.all(default["log_std"] > -0.5), default["log_std"]


def test_log_std_init_sets_the_starting_exploration_noise(run, tmp_path):
    """``log_std_init`` reaches SB3's Gaussian: one rollout's update moves it by a few
    hundredths at most, so the exported policy still carries the configured noise, where the
    default run's starts at std 1."""
    config = tmp_path / "narrow.toml"
    config.write_text(run["config"].read_text() + "log_std_init = -1.5\n")
    r = _train("--steps", 100, "--config", config, "--out", tmp_path / "narrow", "--seed", 4)
    assert r.returncode == 0, r.stderr
    with np.load(tmp_path / "narrow" / "policy.npz") as narrow, np.load(run["out"] / "policy.npz") as default:
        assert np.allclose(narrow["log_std"], -1.5, atol=0.1), narrow["log_std"]
        assert np.allclose(default["log_std"], 0.0, atol=0.3), default["log_std"]
