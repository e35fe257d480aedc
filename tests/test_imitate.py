"""Imitating an expert before PPO (``expert``, :mod:`citygen.runner.learn.imitate`): DAgger's
rounds fit the actor to the planner's actions, PPO goes on from its checkpoint, the cloning
term (``bc_coef``) pulls the actor towards the planner in PPO's updates; the terrain expert
acts as the traverse's Human-AI-Mode-1 walks, and a locomotion run distils it; the mistakes a
user can make are one line.

These tests need the ``train`` extra (Stable-Baselines3 and PyTorch); CI installs it."""

from __future__ import annotations

import pickle
import subprocess
import sys

import numpy as np
import pytest

from tests.conftest import ROOT
from tests.test_learn import TINY as PPO_TINY
from tests.test_learn import TRAIN, _train

pytestmark = pytest.mark.filterwarnings("ignore::citygen.exporters.ExportWarning")

#: test_learn's tiny PPO after two DAgger rounds of two short episodes, fitted hard.
TINY = (
    PPO_TINY
    + """
expert = "planner"
dagger_iterations = 2
dagger_episodes = 2
dagger_epochs = 30
dagger_lr = 1e-3
bc_coef = 0.5
keep_checkpoints = 1
"""
)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    folder = tmp_path_factory.mktemp("imitate")
    config = folder / "tiny.toml"
    config.write_text(TINY)
    out = folder / "run"
    done = _train("--steps", 100, "--max-steps", 60, "--config", config, "--out", out)
    assert done.returncode == 0, done.stderr[-2000:]
    return out, config, done


def _policy_and_stats(out, steps: int):
    from stable_baselines3 import PPO

    model = PPO.load(out / "checkpoints" / f"model_{steps}.zip", device="cpu")
    with open(out / "checkpoints" / f"vecnormalize_{steps}.pkl", "rb") as f:
        venv = pickle.load(f)
    return model, venv


@pytest.mark.slow
def test_dagger_fits_the_actor_to_the_planner_and_ppo_starts_from_it(run):
    import csv

    import torch

    from citygen.runner.learn.imitate import Demonstrations, _mean_action, _normalized

    out, _, done = run
    assert "DAgger round 2/2" in done.stdout
    with open(out / "imitation.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    assert [int(r["iteration"]) for r in rows] == [1, 2]
    assert 0 < int(rows[0]["samples"]) < int(rows[1]["samples"])  # the rounds aggregate
    # The checkpoint at 0 steps is the policy DAgger left (kept past keep_checkpoints = 1); on
    # its data set it acts as the planner does, far better than the labels' mean would.
    model, venv = _policy_and_stats(out, 0)
    data = Demonstrations.load(out / "imitation.npz", tuple(model.observation_space.spaces))
    assert len(data) == int(rows[1]["samples"])
    obs, labels = data.arrays()
    with torch.no_grad():
        mean = _mean_action(model.policy, _normalized(venv, obs)).numpy()
    mse = float(((mean - labels) ** 2).mean())
    assert mse < 0.5 * float(labels.var(axis=0).mean()), (mse, labels.var(axis=0))
    # The observation statistics followed the states DAgger visited.
    assert venv.obs_rms["goal"].count > len(data) * 0.5
    # PPO went on to its 100 steps and exported a policy citygen bench runs.
    assert (out / "policy.npz").is_file() and (out / "checkpoints" / "model_100.zip").is_file()
    bench = subprocess.run(
        [sys.executable, "-m", "citygen", "bench", "--task", "nav-clear", "--robot", "wheeled",
         "--policy", str(out / "policy.npz"), "--episodes", "1", "--jobs", "1"],
        capture_output=True, text=True, cwd=ROOT, timeout=300,
    )  # fmt: skip
    assert bench.returncode == 0, bench.stderr[-2000:]


@pytest.mark.slow
def test_the_cloning_term_pulls_the_actor_towards_the_planner_in_ppos_steps(run):
    from citygen.runner.learn.imitate import Demonstrations, bc_loss, keep_cloning

    out, _, _ = run
    model, venv = _policy_and_stats(out, 100)
    data = Demonstrations.load(out / "imitation.npz", tuple(model.observation_space.spaces))
    # Perturb the actor so that there is something to pull back.
    import torch

    with torch.no_grad():
        for p in model.policy.action_net.parameters():
            p.add_(0.5)
    rng = np.random.default_rng(0)
    with torch.no_grad():
        before = bc_loss(model.policy, venv, data, rng, batch=len(data)).item()
    keep_cloning(model, venv, data, coef=1.0, seed=0)
    for _ in range(60):  # PPO's own loss contributes nothing here: only the cloning term moves
        model.policy.optimizer.zero_grad()
        model.policy.optimizer.step()
    with torch.no_grad():
        after = bc_loss(model.policy, venv, data, rng, batch=len(data)).item()
    assert after < 0.5 * before, (before, after)


@pytest.mark.slow
def test_resume_goes_on_with_ppo_and_needs_the_data_set_it_clones(run, tmp_path):
    import shutil

    out, config, _ = run
    copy = tmp_path / "run"
    shutil.copytree(out, copy)
    more = _train("--steps", 200, "--max-steps", 60, "--config", config, "--out", copy, "--resume")
    assert more.returncode == 0, more.stderr[-2000:]
    assert "DAgger" not in more.stdout  # the rounds are not run again
    assert (copy / "checkpoints" / "model_200.zip").is_file()
    (copy / "imitation.npz").unlink()
    lost = _train("--steps", 300, "--max-steps", 60, "--config", config, "--out", copy, "--resume")
    assert lost.returncode == 2
    assert lost.stderr.strip().count("\n") == 0 and "imitation.npz" in lost.stderr, lost.stderr


@pytest.mark.parametrize(
    ("task", "extra", "says"),
    [
        ("loco-flat", 'expert = "planner"', "expert"),
        ("nav-clear", "bc_coef = 1.0", "bc_coef"),
        ("nav-clear", 'expert = "oracle"', "expert"),
        ("nav-clear", 'expert = "terrain"', "expert"),
        ("loco-flat", 'gait = "trot"\nexpert = "terrain"', "gait"),
    ],
)
def test_an_expert_the_run_cannot_use_is_one_line(cli, tmp_path, task, extra, says):
    config = tmp_path / "c.toml"
    config.write_text(extra + "\n")
    result = cli("train", "--task", task, "--config", str(config), "--out", str(tmp_path / "r"))
    assert result.code == 2
    assert says in result.err and "Traceback" not in result.err + result.out
    assert not (tmp_path / "r").exists()


@pytest.mark.slow
def test_a_run_stopped_in_its_imitation_rounds_starts_over_with_the_same_command(tmp_path):
    """SIGTERM in the rounds leaves no checkpoint (nothing half-imitated to resume) and says
    so in one line; the same command then runs the rounds from the start."""
    import signal
    import time

    config = tmp_path / "c.toml"
    config.write_text(TINY.replace("dagger_episodes = 2", "dagger_episodes = 40"))
    out = tmp_path / "run"
    args = ["--steps", "100", "--max-steps", "40", "--config", str(config), "--out", str(out)]
    proc = subprocess.Popen(
        [*TRAIN, *args], cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    deadline = time.monotonic() + 300
    try:
        while not (out / "imitation.csv").exists():  # written as the rounds begin
            assert proc.poll() is None, proc.stderr.read()
            assert time.monotonic() < deadline
            time.sleep(0.1)
    finally:
        proc.send_signal(signal.SIGTERM)
        _, err = proc.communicate(timeout=120)
    assert proc.returncode != 0 and "imitation rounds" in err and "Traceback" not in err, err
    assert err.strip().count("\n") == 0
    assert not (out / "checkpoints").exists()
    config.write_text(TINY)  # the same run, shorter rounds: it starts, it is not refused
    again = _train(*args)
    assert again.returncode == 0, again.stderr[-2000:]
    assert "DAgger round 2/2" in again.stdout


def test_the_terrain_expert_acts_as_mode_1_walks():
    """On each kind of tile of the mixed grid the terrain expert acts with the model
    Human-AI-Mode-1 dispatches there: the terrain's shipped model, the general one on flat
    ground; its action is that model's, to the bit."""
    from citygen.runner.learn.imitate import TerrainExpert
    from citygen.runner.learn.policy import load_policy
    from citygen.runner.learn.shipped_models import general_locomotion, terrain_locomotion
    from citygen.runner.make import make_env
    from citygen.runner.policies import ground_ahead

    env = make_env("loco-flat", robot="quadruped", split="urban-loc-mixed-train")
    expert = TerrainExpert("quadruped")
    expert.reset(env.unwrapped)
    grid = env.unwrapped.source.scene(0).terrain
    files = {"general": general_locomotion("quadruped"), **terrain_locomotion("quadruped")}
    seen = set()
    try:
        for col in range(4):  # the grid's columns cycle flat, slope, stair, rough
            options = {"region": (grid.rows // 2, col), "command": (0.0, 0.0, 0.0)}
            obs, _ = env.reset(seed=col, options=options)
            action = expert.act(obs)
            kind = ground_ahead(env.unwrapped)
            want = "general" if kind == "flat" else kind
            assert expert.model == want
            np.testing.assert_array_equal(action, load_policy(str(files[want])).act(obs).astype(np.float32))
            seen.add(want)
    finally:
        env.close()
    assert seen == {"general", "slope", "stair", "rough"}


@pytest.mark.slow
def test_a_locomotion_run_distils_the_terrain_models(tmp_path):
    """Two DAgger rounds from the general model on the mixed grid, labelled by the terrain
    expert: the rounds aggregate, the loss is logged, and the exported policy walks in
    citygen bench."""
    import csv

    config = tmp_path / "c.toml"
    config.write_text(
        'envs = 2\nn_steps = 32\nnet_arch = [256, 128]\nactivation = "elu"\nlog_std_init = -1.2\n'
        'expert = "terrain"\ndagger_iterations = 2\ndagger_episodes = 1\ndagger_epochs = 2\n'
        "critic_warmup = 1000\n"
    )
    out = tmp_path / "run"
    done = subprocess.run(
        [sys.executable, "-m", "citygen", "train", "--envs", "2", "--processes", "0",
         "--task", "loco-flat", "--robot", "quadruped", "--split", "urban-loc-mixed-train",
         "--init", "citygen/runner/learn/baselines/loco-general-quadruped.npz", "--seed", "0",
         "--steps", "64", "--max-steps", "50", "--config", str(config), "--out", str(out)],
        capture_output=True, text=True, cwd=ROOT, timeout=600,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr[-2000:]
    with open(out / "imitation.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    samples = [int(r["samples"]) for r in rows]
    assert 0 < samples[0] < samples[1] <= 100  # one episode of at most 50 steps a round
    assert all(float(r["loss"]) > 0 for r in rows)
    bench = subprocess.run(
        [sys.executable, "-m", "citygen", "bench", "--task", "loco-stair", "--robot", "quadruped",
         "--policy", str(out / "policy.npz"), "--episodes", "1", "--jobs", "1", "--max-steps", "50"],
        capture_output=True, text=True, cwd=ROOT, timeout=300,
    )  # fmt: skip
    assert bench.returncode == 0, bench.stderr[-2000:]
