"""Navigation on learned legs (``locomotion="learned"``, :mod:`citygen.runner.envs.legs`):
every legged robot with a general locomotion model walks a navigation task on it, seeing
what LocoEnv would show it; a fall ends the episode as a failure; everything else is one
line and exit 2.

The shipped files are copied; a robot whose general model does not ship gets the shipped
LocoFlat model as a stand-in only for the quadruped (a copy whose metadata says it was trained
on the general split).
"""

from __future__ import annotations

import json
import math
import shutil

import mujoco
import numpy as np
import pytest

from citygen.io import load_scene
from citygen.runner.envs.legs import BACK_AND_TURN, TIPPED, UNWEDGE, WEDGE, free_damping
from citygen.runner.learn import shipped_models
from citygen.runner.learn.export import write_policy
from citygen.runner.learn.loco import COMMANDS
from citygen.runner.make import make_env
from citygen.runner.robots import BUILTIN, load_robot
from citygen.spec.task import LocoTask
from tests.conftest import EXAMPLES

NAV = next(p for p in EXAMPLES if p.name == "nav_static_10m.json")
LEGGED = [name for name in BUILTIN if load_robot(name).leg_joints]


@pytest.fixture
def general(tmp_path, monkeypatch) -> dict[str, object]:
    """The shipped files, and the LocoFlat model as the quadruped's general model if it has
    none; ``robot -> file`` of the general models navigation walks on (the one trained on
    navigation's commands where it ships)."""
    for path in shipped_models.BASELINES.glob("*.npz"):
        shutil.copy(path, tmp_path / path.name)
    if "quadruped" not in shipped_models._shipped_files().general:
        with np.load(shipped_models.BASELINES / "loco-flat-quadruped.npz") as data:
            arrays = {k: data[k] for k in data.files}
        meta = json.loads(str(arrays.pop("meta")))
        meta["train"] = {**meta["train"], "split": shipped_models.GENERAL_LOCO_SPLIT}
        write_policy(tmp_path / "loco-general-quadruped.npz", meta, arrays)
    monkeypatch.setattr(shipped_models, "BASELINES", tmp_path)
    robots = shipped_models._shipped_files().general
    return {r: shipped_models.general_locomotion(r, "navigation") for r in robots}


@pytest.mark.parametrize("robot", LEGGED)
def test_every_legged_robot_with_a_general_model_walks_a_nav_task_on_it(general, robot):
    if robot not in general:
        with pytest.raises(
            shipped_models.PolicyError, match=f"no general locomotion model shipped for robot {robot}"
        ):
            make_env("nav-static", NAV, robot=robot, locomotion="learned")
        return
    env = make_env("nav-static", NAV, robot=robot, locomotion="learned")
    servo = make_env("nav-static", NAV, robot=robot)
    assert env.observation_space == servo.observation_space  # navigation sees the same keys
    env.reset(seed=0)
    servo.reset(seed=0)
    servo.step(np.array([1.0, 0.0]))
    # the ideal servo damps its robot's free joint; the wheeled-legged robot drives on its
    # wheels in its drive pose instead (Robot.nav_mode)
    assert servo.handle._damped == (env.robot.nav_mode == "base")
    # Feet get the slopes as prisms, the servo heightfields: two compiled scenes, never one.
    assert (env.terrain, servo.terrain) == ("hybrid", "heightfield") and servo.model is not env.model
    assert env.legs.path == general[robot] and env.legs.repeats == 5  # 0.1 s nav step, 50 Hz legs
    for episode in range(2):
        obs, _ = env.reset(seed=episode)
        assert env.legs.command.tolist() == [0.0, 0.0, 0.0] and not env.legs.last_action.any()
        x0, y0, _, yaw = env.handle.pose(env.data)
        for _ in range(10):
            obs, _, terminated, truncated, _ = env.step(np.array([1.0, 0.0]))
            assert not (terminated or truncated)
        x, y, _, _ = env.handle.pose(env.data)
        ahead = (x - x0) * math.cos(yaw) + (y - y0) * math.sin(yaw)
        assert ahead > 0.3, ahead  # 1 s of a 1 m/s command: it walked forward
        assert not env.handle._damped  # the servo never ran: the legs carried it
        free = env.model.dof_damping[env.handle.dadr : env.handle.dadr + 6]
        assert free.tolist() == free_damping(env.robot).tolist()  # the servo's damping is gone
        # the action's full speed, clipped into the model's training range (COMMANDS)
        assert env.legs.command.tolist() == [min(env.robot.max_speed, COMMANDS[0][1]), 0.0, 0.0]
        targets = env.data.ctrl[env.handle.leg_act]
        assert not np.allclose(targets, env.handle.default)  # the model sets the joints' targets
        assert set(obs) == set(servo.observation_space.spaces)


def test_the_locomotion_model_sees_what_locoenv_would_in_the_same_state(general):
    """The observation the model reads inside the nav env is LocoEnv's, key for key and bit
    for bit, with LocoEnv put in the same MuJoCo state, command and last action."""
    env = make_env("nav-static", NAV, robot="quadruped", locomotion="learned")
    env.reset(seed=0)
    for _ in range(3):
        env.step(np.array([0.8, 0.3]))
    scene = load_scene(NAV)
    start = scene.task.start
    loco = make_env(
        "loco-flat",
        scene.model_copy(update={"task": LocoTask(kind="loco-flat", start=start, time_limit=20.0)}),
        robot="quadruped",
        randomize=False,
    )
    loco.reset(seed=0)
    assert (loco.model.nq, loco.model.ngeom) == (env.model.nq, env.model.ngeom)
    for name in ("qpos", "qvel", "act", "ctrl"):
        getattr(loco.data, name)[:] = getattr(env.data, name)
    for m, d in ((env.model, env.data), (loco.model, loco.data)):
        mujoco.mj_forward(m, d)  # both states' derived quantities (the base's rotation) from qpos
    loco.command, loco.last_action = env.legs.command.copy(), env.legs.last_action.copy()
    seen, expected = env.legs.observation(), loco._observation()
    assert set(seen) == set(env.legs.policy.keys) <= set(expected)
    for key in seen:
        assert seen[key].dtype == expected[key].dtype and np.array_equal(seen[key], expected[key]), key
    assert seen["command"].tolist() == pytest.approx(
        [0.8 * env.robot.max_speed, 0.0, 0.3 * env.robot.max_yaw_rate]
    )
    # a command past what the model was trained on is clipped into its ranges
    env.step(np.array([-1.0, 0.0]))
    (v_lo, _), _, (w_lo, _) = COMMANDS
    assert -env.robot.max_speed < v_lo and -env.robot.max_yaw_rate < w_lo
    assert env.legs.command.tolist() == [v_lo, 0.0, 0.0]
    # backing up while turning (which seats the quadruped's model) turns in place
    env.step(np.array([-1.0, -1.0]))
    assert env.legs.command.tolist() == [0.0, 0.0, w_lo]
    turn = BACK_AND_TURN["quadruped"] / env.robot.max_yaw_rate
    env.step(np.array([-0.5, 0.99 * turn]))  # a slight turn still backs up
    v, _, w = env.legs.command.tolist()
    assert v == pytest.approx(-0.5 * env.robot.max_speed) and 0 < w < BACK_AND_TURN["quadruped"]


def test_a_fall_ends_the_navigation_episode_as_a_failure(general):
    """Put upside down, the body lands on the ground: LocoEnv's fall, the end of the episode
    (reward -100, no success) with ``fall_rate`` 100."""
    env = make_env("nav-static", NAV, robot="quadruped", locomotion="learned")
    env.reset(seed=0)
    q = env.handle.qadr
    env.data.qpos[q + 2] += 0.3
    env.data.qpos[q + 3 : q + 7] = (0.0, 1.0, 0.0, 0.0)  # half a turn about x
    mujoco.mj_forward(env.model, env.data)
    for _ in range(20):
        _, reward, terminated, truncated, info = env.step(np.zeros(2))
        if terminated or truncated:
            break
    assert terminated and env.legs.fell and reward < -90
    assert info["is_success"] is False
    assert info["metrics"]["fall_rate"] == 100.0 and info["metrics"]["success_rate"] == 0.0


def test_a_robot_tipped_on_its_side_for_a_second_has_fallen_though_its_body_is_clear_of_the_ground(general):
    """Rolled 85 degrees and lifted clear of the ground (7 m: a second of free fall): no part
    presses on it, yet the robot has fallen once it has lain tipped past 60 degrees (the
    servo's rule) for TIPPED[1] s, not before (a tilt it rights within that is no fall)."""
    env = make_env("nav-static", NAV, robot="quadruped", locomotion="learned")
    env.reset(seed=0)
    q = env.handle.qadr
    env.data.qpos[q + 2] += 7.0
    roll = math.radians(85.0)  # the legs' swinging turns the base a little in the air
    env.data.qpos[q + 3 : q + 7] = (math.cos(roll / 2), math.sin(roll / 2), 0.0, 0.0)
    mujoco.mj_forward(env.model, env.data)
    ground = set(np.flatnonzero(env.prepared.ground_geoms).tolist())
    robot = set(np.flatnonzero(env._robot_geoms).tolist())
    steps = round(TIPPED[1] / env.dt)
    for k in range(steps):
        _, _, terminated, _, info = env.step(np.zeros(2))
        assert terminated == (k == steps - 1)
        pairs = [{c.geom1, c.geom2} for c in env.data.contact[: env.data.ncon]]
        assert not [p for p in pairs if p & robot and p & ground]
    assert env.legs.fell and info["metrics"]["fall_rate"] == 100.0


def _still_legs(env):
    """``env``'s legs on a model whose mean is the standing pose whatever it sees: asked to
    walk, the robot stands still (a wedge), and only draws from its Gaussian move a joint."""
    n = env.legs.last_action.size
    env.legs.policy.mean = lambda obs: np.zeros((1, n), dtype=np.float32)


def test_a_robot_still_while_asked_to_walk_acts_on_its_gaussian_for_a_while(general):
    """Asked to walk and not moving for WEDGE[0] s, the model acts on draws from its trained
    Gaussian for UNWEDGE s (the same draws for the same seed), then on its mean again; a
    robot asked to stand is not wedged."""
    runs = []
    for _ in range(2):
        env = make_env("nav-static", NAV, robot="quadruped", locomotion="learned")
        env.reset(seed=3)
        _still_legs(env)
        steps = round((WEDGE[0] + 0.5 * UNWEDGE) / env.dt)
        actions = []
        for _ in range(steps):
            env.step(np.array([0.0, 0.0]))
        assert env.legs.wedges == 0 and not env.legs.last_action.any()
        for _ in range(steps):
            env.step(np.array([0.5, 0.0]))
            actions.append(env.legs.last_action.copy())
        assert env.legs.wedges == 1
        moved = [bool(a.any()) for a in actions]
        first = moved.index(True)
        # the still steps are counted whole: the draws start on the step after WEDGE[0] s
        assert not any(moved[:first]) and first == round(WEDGE[0] / env.dt)
        assert all(moved[first:])
        for _ in range(round(UNWEDGE / env.dt)):
            env.step(np.array([0.5, 0.0]))
        assert not env.legs.last_action.any() or env.legs.wedges == 2
        runs.append(np.array(actions))
    assert np.array_equal(runs[0], runs[1])


def test_learned_legs_need_a_legged_robot_and_a_navigation_task(general):
    with pytest.raises(shipped_models.PolicyError, match="humanoid"):
        make_env("nav-static", NAV, robot="humanoid", locomotion="learned")
    with pytest.raises(Exception, match="the wheeled robot has no legs"):
        make_env("nav-static", NAV, robot="wheeled", locomotion="learned")
    with pytest.raises(Exception, match="a navigation option; loco-flat"):
        make_env("loco-flat", robot="quadruped", locomotion="learned")
    with pytest.raises(Exception, match="locomotion"):
        make_env("nav-static", NAV, robot="quadruped", locomotion="walk")
    assert make_env("nav-static", NAV, robot="wheeled", locomotion="servo").legs is None


@pytest.mark.parametrize(
    ("args", "words"),
    [
        (["--robot", "humanoid"], ["--locomotion learned", "humanoid", "shipped for: quadruped"]),
        (["--robot", "wheeled"], ["--locomotion learned", "wheeled", "no legs"]),
        (["--robot", "quadruped", "--task", "loco-flat", "--policy", "stand"], ["--locomotion learned"]),
    ],
)
def test_the_cli_refuses_learned_legs_it_cannot_have_in_one_line(general, cli, args, words):
    for command in (["bench", "--task", "nav-static", "-n", "1"], ["run", str(NAV)]):
        if command[0] == "run" and "loco-flat" in args:
            continue  # the example scene holds a navigation task
        result = cli(*command, *args, "--locomotion", "learned")
        lines = result.err.strip().splitlines()
        assert result.code == 2 and len(lines) == 1 and "Traceback" not in result.err, result
        assert all(word in lines[0] for word in words), lines[0]
    result = cli("bench", "--task", "nav-static", "-n", "1", "--locomotion", "walk")
    assert result.code == 2 and "--locomotion" in result.err and "servo or learned" in result.err


@pytest.mark.parametrize(("robot", "word"), [("humanoid", "shipped for: quadruped"), ("wheeled", "no legs")])
def test_train_refuses_learned_legs_it_cannot_have_before_it_starts(general, cli, tmp_path, robot, word):
    args = ["--task", "nav-static", "--robot", robot, "--locomotion", "learned", "--out", tmp_path]
    result = cli("train", *args)
    lines = result.err.strip().splitlines()
    assert result.code == 2 and len(lines) == 1 and word in lines[0], result
    assert "training PPO" not in result.out


def test_policy_ppo_on_learned_legs_runs_the_model_fine_tuned_on_them(general, cli, tmp_path, monkeypatch):
    """A navigation file trained with ``locomotion="learned"`` (its metadata says so) is
    ``--policy ppo`` on learned legs only, in the library and on ``citygen bench``'s command
    line (which once resolved ``ppo`` before reading ``--locomotion``, running the servo's
    file on the legs); the servo keeps its own file."""
    from citygen.runner.learn.policy import resolve_policy

    for (task, robot), path in shipped_models._shipped_files().legs.items():  # the files that ship
        assert resolve_policy("ppo", task, robot, (), locomotion="learned") == str(path)
    servo = shipped_models.BASELINES / "nav-static-quadruped.npz"
    with np.load(servo) as data:
        arrays = {k: data[k] for k in data.files}
    meta = {**json.loads(str(arrays.pop("meta"))), "locomotion": "learned"}
    legs = write_policy(shipped_models.BASELINES / "nav-static-quadruped-legs.npz", meta, arrays)
    assert shipped_models.baseline("nav-static", "quadruped") == servo
    assert shipped_models.baseline("nav-static", "quadruped", "learned") == legs
    for task in shipped_models.LEGS_STAND_IN:  # none of their own on the legs: NavStatic's stands in
        assert shipped_models.baseline(task, "quadruped", "learned") == legs
        servo_file = shipped_models.BASELINES / f"{task}-quadruped.npz"
        assert shipped_models.baseline(task, "quadruped") == servo_file
    clear = {**meta, "task": "nav-clear"}
    own = write_policy(shipped_models.BASELINES / "nav-clear-quadruped-legs.npz", clear, arrays)
    assert shipped_models.baseline("nav-clear", "quadruped", "learned") == own
    own.unlink()
    found = resolve_policy("ppo", "nav-static", "quadruped", (), locomotion="learned")
    assert found == str(legs)
    assert resolve_policy("ppo", "nav-static", "quadruped", ()) == str(servo)
    out = tmp_path / "bench.json"
    args = ["--task", "nav-static", "--robot", "quadruped", "--policy", "ppo", "-n", "1", "--max-steps", "5"]
    result = cli("bench", *args, "--locomotion", "learned", "--output", out)
    assert result.code == 0, result
    assert json.loads(out.read_text())["policy"] == str(legs)
    assert cli("bench", *args, "--output", out).code == 0
    assert json.loads(out.read_text())["policy"] == str(servo)
    # The traverse's AI on learned legs navigates with it too.
    from citygen.runner.policies import foundational_navigator, traverse_ai

    assert traverse_ai("quadruped", "learned").path == str(legs)
    assert traverse_ai("quadruped").path == str(servo)
    # Human-AI-Mode-1 and -2's foundational models: NavStatic's legs file stands in for the
    # tasks without one of their own on the legs (LEGS_STAND_IN), the servo's on the servo.
    paths = foundational_navigator("quadruped", "learned").paths
    assert paths == dict.fromkeys(("nav-clear", "nav-static", "nav-dynamic"), str(legs))
    assert foundational_navigator("quadruped").paths["nav-clear"] == str(
        shipped_models.BASELINES / "nav-clear-quadruped.npz"
    )
    # A task no legs file stands in for keeps the servo's on learned legs too.
    monkeypatch.delitem(shipped_models.LEGS_STAND_IN, "nav-dynamic")
    dynamic = shipped_models.baseline("nav-dynamic", "quadruped", "learned")
    assert dynamic == shipped_models.BASELINES / "nav-dynamic-quadruped.npz"
