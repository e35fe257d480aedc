"""Learned locomotion: what the policy observes and drives, the training wrapper (commands,
terrain curriculum, gait shaping; training only), and a tiny run that ``citygen bench`` loads."""

from __future__ import annotations

import contextlib
import json
import math

import numpy as np
import pytest

from citygen.runner.learn.loco import LocoTraining
from citygen.runner.make import make_env
from citygen.runner.policies import make_policy
from tests.conftest import TINY_LOCO, loco_grid, tiny_loco_run

pytest.importorskip("stable_baselines3")  # the train extra: the README's test command installs it


@pytest.fixture(scope="module")
def flat():
    env = make_env("loco-flat", robot="quadruped")
    yield env
    env.close()


def test_projected_gravity_is_the_tilt_of_the_base(flat):
    obs, _ = flat.reset(seed=0)
    assert np.allclose(obs["projected_gravity"], (0, 0, -1), atol=1e-6)
    u = flat.unwrapped
    q = u.handle.qadr
    # pitch the base nose-down by 0.3 rad about its own y axis: gravity leans to +x in its frame
    yaw = math.atan2(2 * u.data.qpos[q + 3] * u.data.qpos[q + 6], 1 - 2 * u.data.qpos[q + 6] ** 2)
    cy, sy, cp, sp = math.cos(yaw / 2), math.sin(yaw / 2), math.cos(0.15), math.sin(0.15)
    u.data.qpos[q + 3 : q + 7] = (cy * cp, -sy * sp, cy * sp, sy * cp)  # yaw then pitch
    import mujoco

    mujoco.mj_forward(u.model, u.data)
    g = u._observation()["projected_gravity"]
    assert g[0] == pytest.approx(math.sin(0.3), abs=1e-5) and g[1] == pytest.approx(0, abs=1e-5)
    assert g[2] == pytest.approx(-math.cos(0.3), abs=1e-5)


def test_walking_off_the_grid_upright_ends_the_episode_without_a_fall(flat):
    """Balance counts falls: a robot that leaves the terrain grid standing is truncated there
    (its X-displacement the distance walked), not counted as fallen."""
    import mujoco

    flat.reset(seed=0)
    u = flat.unwrapped
    (_, _), (x1, _) = u.scene.bounds.min, u.scene.bounds.max
    u.data.qpos[u.handle.qadr] = x1 + 0.05  # standing just past the edge
    mujoco.mj_forward(u.model, u.data)
    _, reward, terminated, truncated, info = flat.step(np.zeros(flat.action_space.shape))
    assert truncated and not terminated and info["out_of_bounds"] and not info["fallen"]
    assert info["is_success"] and info["metrics"]["balance"] == 100.0 and reward > -100.0


def test_the_wheeled_legged_robot_drives_its_wheels_after_its_joints():
    env = make_env("loco-flat", robot="wheeled_legged")
    try:
        assert env.action_space.shape == (16,)
        obs, _ = env.reset(seed=0, options={"region": (0, 0)})
        assert obs["joint_vel"].shape == (16,) and obs["last_action"].shape == (16,)
        a = np.zeros(16)
        a[12:] = 0.5  # every wheel forward at half its top speed: rolls ahead, legs in their stance
        for _ in range(100):
            obs, _, fallen, _, _ = env.step(a)
        assert not fallen and obs["base_lin_vel"][0] > 0.5
        assert np.all(obs["joint_vel"][12:] > 5.0)  # rad/s, the wheels' own speeds
        # the scripted gaits give twelve numbers and leave the wheels still
        policy = make_policy("stand")
        policy.reset(env.unwrapped)
        assert policy.act(obs).shape == (16,) and not policy.act(obs)[12:].any()
    finally:
        env.close()


def test_gait_shaping_rewards_walking_and_is_training_only(flat):
    train = LocoTraining(make_env("loco-flat", robot="quadruped"), seed=0, rank=0, curriculum=False)
    try:
        train.reset(seed=0, options={"command": (1.0, 0.0, 0.0)})
        flat.reset(seed=0, options={"command": (1.0, 0.0, 0.0)})
        zero = np.zeros(12)
        shaped = [train.step(zero)[1] for _ in range(20)]
        paper = [flat.step(zero)[1] for _ in range(20)]
        # standing still 1 m/s short of the command: the paper's 0.25 m/s kernel pays nothing for
        # the forward speed, the broad kernel a little; the environment's own reward is the paper's
        assert all(s != p for s, p in zip(shaped, paper, strict=True))
        u = train.unwrapped
        u.data.qvel[u.handle.dadr] = 0.0
        assert train._shaping() > 0.5  # yaw tracked, the tilt zero: a standing robot is paid to stay up
    finally:
        train.close()


def test_only_positive_rewards_clip_a_step_at_zero_and_keep_the_fall():
    """The wheeled-legged robot under its starting noise pays more in penalties each step than
    a fall costs over an episode; ``only_positive`` makes each step worth at least nothing and
    keeps the fall's -100, so falling is never the better choice."""
    env = make_env("loco-flat", robot="wheeled_legged")
    clipped = LocoTraining(env, seed=0, rank=0, curriculum=False, only_positive=True)
    raw = LocoTraining(make_env("loco-flat", robot="wheeled_legged"), seed=0, rank=0, curriculum=False)
    try:
        rng = np.random.default_rng(0)
        actions = np.clip(0.6 * rng.standard_normal((400, env.action_space.shape[0])), -1, 1)
        pairs, fell = [], False
        for e in (clipped, raw):
            e.reset(seed=3)
        for a in actions:
            (_, r1, t1, _, i1), (_, r2, _, _, _) = clipped.step(a), raw.step(a)
            pairs.append((r1, r2))
            if t1:
                fell = i1["fallen"]
                assert r1 == max(r2 + 100.0, 0.0) - 100.0  # the fall's penalty kept
                break
            assert r1 == max(r2, 0.0)
        assert min(r for _, r in pairs) < 0.0 <= min(r for r, _ in pairs[:-1] or [(0.0, 0)])
        assert fell  # this much noise topples it
    finally:
        clipped.close()
        raw.close()


@contextlib.contextmanager
def _trainings(robot: str, kws, seed: int, command, **common):
    """One training wrapper of a LocoFlat environment per option set of ``kws`` (each with
    ``common``), all reset with ``seed`` and ``command``; closed on the way out."""
    envs = [LocoTraining(make_env("loco-flat", robot=robot), seed=0, rank=0, **common, **kw) for kw in kws]
    try:
        for e in envs:
            e.reset(seed=seed, options={"command": command})
        yield envs
    finally:
        for e in envs:
            e.close()


def test_the_survival_bonus_and_the_effort_scale_shift_only_their_terms():
    """``alive`` adds its value to every step; ``effort_scale`` scales the torque and joint
    acceleration penalties (never positive), nothing else."""
    kws = ({}, {"alive": 1.0}, {"effort_scale": 0.1}, {"effort_scale": 0.0})
    with _trainings("wheeled_legged", kws, 2, (1.0, 0.0, 0.0), curriculum=False) as envs:
        rng = np.random.default_rng(1)
        for a in np.clip(0.2 * rng.standard_normal((30, 16)), -1, 1):
            plain, alive, tenth, none = (e.step(a)[1] for e in envs)
            assert alive == pytest.approx(plain + 1.0, abs=1e-9)
            assert none >= tenth >= plain and tenth - plain == pytest.approx(0.9 * (none - plain))


def test_the_fall_share_the_foot_clearance_and_the_turn_progress_change_only_their_terms():
    """``fall_penalty=0.25`` gives 75 of a fall's 100 back and nothing on any other step,
    ``fall_penalty=3`` takes 200 more;
    ``foot_clearance`` never pays and costs where feet swing low (action noise on flat
    ground); ``turn_progress`` adds its weight times the share of the commanded turn made
    good; an episode's end tells its curriculum row (``terrain_level``, the training log's)."""
    kws = ({}, {"fall_penalty": 0.25}, {"foot_clearance": 1.0}, {"turn_progress": 2.0}, {"fall_penalty": 3.0})
    with _trainings("quadruped", kws, 4, (0.5, 0.0, 0.8)) as envs:
        rng = np.random.default_rng(2)
        low, turned, fell = [], [], False
        for a in np.clip(0.8 * rng.standard_normal((600, 12)), -1, 1):
            steps = [e.step(a) for e in envs]
            (_, plain, end, _, info), (_, share, *_), (_, clear, *_), (_, turn, *_), (_, dear, *_) = steps
            if end:
                fell = info["fallen"]
                assert share == pytest.approx(plain + 75.0) and info["terrain_level"] == envs[0].level
                assert dear == pytest.approx(plain - 200.0)
                break
            assert share == plain == dear and clear <= plain
            wz = envs[3].unwrapped.base_velocity[3]
            assert turn == pytest.approx(plain + 2.0 * min(max(wz / 0.8, -1.0), 1.0), abs=1e-9)
            low.append(clear < plain)
            turned.append(turn != plain)
        assert fell and any(low) and any(turned)


def test_leg_collisions_cost_each_leg_link_on_the_ground_and_a_higher_clearance_costs_more():
    """``leg_collision`` subtracts its weight per leg link (not a foot) touching the ground, so a
    robot stumbling under action noise pays it on some steps and never gains; the foot clearance
    term asking for 0.20 m costs at least what it costs at 0.12 m, and more where feet swing."""
    kws = (
        {},
        {"leg_collision": 2.0},
        {"foot_clearance": 1.0},
        {"foot_clearance": 1.0, "clearance_height": 0.2},
    )
    with _trainings("quadruped", kws, 4, (0.5, 0.0, 0.0)) as envs:
        rng = np.random.default_rng(5)
        hits, higher = [], []
        for a in np.clip(0.8 * rng.standard_normal((600, 12)), -1, 1):
            (_, plain, end, *_), (_, coll, *_), (_, low, *_), (_, high, *_) = [e.step(a) for e in envs]
            n = envs[1]._leg_hits()
            assert coll == pytest.approx(plain - 2.0 * n, abs=1e-9)
            assert high <= low + 1e-12
            hits.append(n)
            higher.append(high < low)
            if end:
                break
        assert any(hits) and any(higher)
        assert envs[1]._leg_ids and not envs[1]._leg_ids & {
            int(g) for g in envs[1].unwrapped.handle.foot_geom_ids
        }


def test_base_height_costs_only_a_base_lower_than_standing():
    """``base_height`` pays its weight times the squared shortfall of the base's height under
    the robot's standing height, as a share of it: nothing standing, the most sitting down."""
    with _trainings("quadruped", ({}, {"base_height": 3.0}), 4, (0.0, 0.0, 0.0)) as envs:
        u = envs[1].unwrapped
        stand = u.robot.stand_height
        crouch = np.array([0.0, 0.6, -1.0] * 4)  # knees folded: it sits down
        costs = []
        for a in [np.zeros(12)] * 5 + [crouch] * 40:
            (_, plain, end, *_), (_, height, *_) = [e.step(a) for e in envs]
            assert not end
            x, y, z = u.data.qpos[u.handle.qadr : u.handle.qadr + 3].tolist()
            short = max(stand - (z - u.prepared.ground_at(x, y)), 0.0)
            assert height == pytest.approx(plain - 3.0 * (short / stand) ** 2, abs=1e-9)
            costs.append(plain - height)
        assert costs[0] < 1e-3 and costs[-1] > 0.1, costs


def test_orientation_costs_the_base_s_tilt_from_level():
    """``orientation`` subtracts its weight times ``|g_xy|^2`` (gravity's share in the base's
    plane): nothing while the robot stands level, more once action noise tips it."""
    with _trainings("quadruped", ({}, {"orientation": 4.0}), 4, (0.5, 0.0, 0.0)) as envs:
        u = envs[1].unwrapped
        rng = np.random.default_rng(3)
        tilts = []
        for a in [np.zeros(12)] * 3 + list(np.clip(0.8 * rng.standard_normal((300, 12)), -1, 1)):
            (_, plain, end, *_), (_, level, *_) = [e.step(a) for e in envs]
            g = u.data.xmat[u.handle.base_id][6:8]
            assert level == pytest.approx(plain - 4.0 * float(g @ g), abs=1e-9)
            tilts.append(float(g @ g))
            if end:
                break
        assert tilts[0] < 1e-3 and max(tilts) > 0.05, (tilts[0], max(tilts))


def test_heading_progress_pays_the_speed_along_the_held_heading_in_the_world():
    """``heading_progress`` adds its weight times the share of the commanded speed made good
    along the held heading in the world (a robot driving in circles earns it on one half of the
    circle and pays it on the other), and nothing where the command turns (no held heading)."""
    with _trainings("quadruped", ({}, {"heading_progress": 1.5}), 4, (0.8, 0.0, 0.0)) as envs:
        u = envs[1].unwrapped
        held = u.held_heading
        assert held is not None
        rng = np.random.default_rng(5)
        paid = []
        for a in np.clip(0.6 * rng.standard_normal((40, 12)), -1, 1):
            (_, plain, end, *_), (_, heading, *_) = [e.step(a) for e in envs]
            if end:
                break
            vx, vy, _, _ = u.base_velocity  # in the robot's frame
            yaw = u.handle.pose(u.data)[3] - held  # the robot's heading against the held one
            along = (vx * math.cos(yaw) - vy * math.sin(yaw)) / 0.8
            assert heading == pytest.approx(plain + 1.5 * min(max(along, -1.0), 1.0), abs=1e-6)
            paid.append(heading - plain)
        assert len(paid) > 20 and min(paid) < 0 < max(paid)  # both ways under noise
        for e in envs:
            e.reset(seed=4, options={"command": (0.8, 0.0, 0.5)})  # a turning command
        a = np.zeros(12)
        (_, plain, *_), (_, heading, *_) = [e.step(a) for e in envs]
        assert heading == plain


def test_the_edge_stop_pays_for_standing_only_at_a_riser_too_high_to_climb(tmp_path):
    """``edge_stop`` measures the highest riser up (and down) within reach ahead along the held
    heading; where one up is higher than ``edge_height`` the shaping pays a robot standing still
    for standing (the command's tracking, paid against a zero command); below it it changes
    nothing, to the bit, nor at the top of risers going down however deep, unless they are
    deeper than ``edge_drop``."""
    split = tmp_path / "stairs.toml"  # row 0: 5 cm risers, row 1: 30 cm; column 0 a pyramid, 1 a pit
    split.write_text(
        loco_grid("stair", "quadruped") + "terrain.step_height = [0.05, 0.3]\nterrain.step_count = [8, 8]\n"
    )
    edge = {"heading_progress": 1.0, "edge_stop": 1.0}
    kws = ({"heading_progress": 1.0}, edge, {**edge, "edge_drop": 0.2})
    envs = [
        LocoTraining(make_env("loco-stair", robot="quadruped", split=str(split)), seed=0, rank=0, **kw)
        for kw in kws
    ]
    try:
        for region, risers, stops in (
            ((0, 1), (0.05, 0), ()),
            ((1, 0), (0, 0.3), (2,)),
            ((1, 1), (0.3, 0), (1, 2)),
        ):
            for e in envs:
                e.reset(seed=1, options={"region": region, "command": (1.0, 0.0, 0.0)})
            assert envs[1]._risers_ahead(1.0, 0.0) == pytest.approx(risers, abs=0.01)
            for _ in range(10):
                plain, *edged = [e.step(np.zeros(12))[1] for e in envs]
                for k, r in enumerate(edged, 1):
                    assert r > plain + 0.5 if k in stops else r == plain
    finally:
        for e in envs:
            e.close()


def test_the_descent_speed_pays_for_walking_down_slowly_only_where_the_ground_drops(tmp_path):
    """``descent_speed`` pays the tracking terms against the command cut to that speed at the
    top of a riser down deeper than ``descent_drop``: a robot driven down at 0.4 m/s under a
    1 m/s command earns more than without it, one driven at 1 m/s less; at the foot of risers
    up it changes nothing, to the bit."""
    split = tmp_path / "stairs.toml"  # 15 cm risers; column 0 a pyramid (risers down), 1 a pit
    split.write_text(
        loco_grid("stair", "quadruped") + "terrain.step_height = [0.15, 0.15]\nterrain.step_count = [8, 8]\n"
    )
    envs = [
        LocoTraining(make_env("loco-stair", robot="quadruped", split=str(split)), seed=0, rank=0, **kw)
        for kw in ({"heading_progress": 1.0}, {"heading_progress": 1.0, "descent_speed": 0.4})
    ]
    try:
        for region, speed, sign in (((0, 0), 0.4, 1), ((0, 0), 1.0, -1), ((0, 1), 0.4, 0)):
            for e in envs:
                e.reset(seed=1, options={"region": region, "command": (1.0, 0.0, 0.0)})
            rise, drop = envs[1]._risers_ahead(1.0, 0.0)
            assert (drop > 0.1, rise > 0.1) == (sign != 0, sign == 0)
            for _ in range(5):
                paid = []
                for e in envs:  # the base driven forward at `speed` along the held heading
                    u = e.unwrapped
                    yaw = u.handle.pose(u.data)[3]
                    v = (speed * math.cos(yaw), speed * math.sin(yaw))
                    u.data.qvel[u.handle.dadr : u.handle.dadr + 2] = v
                    paid.append(e.step(np.zeros(12))[1])
                plain, slow = paid
                assert slow == plain if sign == 0 else (slow - plain) * sign > 0.1
    finally:
        for e in envs:
            e.close()


@pytest.fixture(scope="module")
def grid(tmp_path_factory):
    path = tmp_path_factory.mktemp("grid") / "grid.toml"
    path.write_text(GRID)
    return path


def test_the_curriculum_moves_up_after_a_long_walk_and_down_after_a_fall(grid):
    env = LocoTraining(make_env("loco-rough", robot="quadruped", split=str(grid)), seed=0, rank=0)
    try:
        _, info = env.reset(seed=0)
        assert env.level in (0, 1) and info["region"][0] == env.level  # it starts on an easy row
        env.level = 0
        u = env.unwrapped
        u.data.qpos[u.handle.qadr] += 5.0  # 5 m from the start: more than half a region
        env._move_level(fell=False)
        assert env.level == 1
        _, info = env.reset()
        assert info["region"][0] == 1
        env._move_level(fell=True)
        assert env.level == 0
        env.level = 1
        u.data.qpos[u.handle.qadr] += 5.0
        env._move_level(fell=False)  # past the hardest row: a random one
        assert env.level in (0, 1)
    finally:
        env.close()


def test_start_rows_sets_the_rows_a_curriculum_level_starts_on(grid):
    """``start_rows`` (legged_gym's max_init_terrain_level + 1) bounds the first level a
    sub-environment draws: 1 keeps every start on the easiest row, 2 reaches the grid's
    second; the training config hands it to the wrapper."""
    from citygen.runner.learn.config import TrainConfig
    from citygen.runner.learn.vecenv import _sub_env_args

    starts = {}
    for n in (1, 2):
        env = LocoTraining(
            make_env("loco-rough", robot="quadruped", split=str(grid)), seed=0, rank=0, start_rows=n
        )
        try:
            starts[n] = set()
            for k in range(16):
                env.level = None  # a fresh sub-environment's first episode
                _, info = env.reset(seed=k)
                starts[n].add(info["region"][0])
        finally:
            env.close()
    assert starts == {1: {0}, 2: {0, 1}}
    args = _sub_env_args(TrainConfig(task="loco-rough", start_rows=7), rank=0)
    assert next(a for a in args if isinstance(a, dict))["start_rows"] == 7


def test_random_rows_start_episodes_anywhere_on_the_grid_and_leave_the_level(grid):
    """With ``random_rows = 1`` every episode starts on a row drawn from the whole grid, past
    the level too, and its end (a fall here: standing still on bumps) leaves the level as it
    was; without it, episodes start on the level and the same seed draws the same regions."""
    env = LocoTraining(
        make_env("loco-rough", robot="quadruped", split=str(grid)), seed=0, rank=0, random_rows=1.0
    )
    plain = [
        LocoTraining(make_env("loco-rough", robot="quadruped", split=str(grid)), seed=0, rank=0)
        for _ in range(2)
    ]
    try:
        env.reset(seed=0)
        env.level, rows = 0, set()
        for k in range(12):
            _, info = env.reset(seed=k)
            rows.add(info["region"][0])
        assert rows == {0, 1}
        ended = None
        for _ in range(1000):
            *_, terminated, truncated, info = env.step(np.zeros(12))
            if terminated or truncated:
                ended = info
                break
        assert ended is not None and ended["terrain_level"] == 0 == env.level
        regions = [[e.reset(seed=k)[1]["region"] for k in range(6)] for e in plain]
        assert regions[0] == regions[1] and {r[0] for r in regions[0]} == {plain[0].level}
    finally:
        for e in (env, *plain):
            e.close()


def test_drawn_commands_hold_the_level_but_a_fall_and_may_change_mid_episode(grid):
    """With ``level_on_commands="falls"`` an episode on a drawn command moves its level only
    down, on a fall (a turning command never covers 4 m); the task's own command still moves
    it up. ``command_resample`` draws a new command during such an episode, seen by the next
    observation and obeyed by the environment."""
    env = LocoTraining(
        make_env("loco-rough", robot="quadruped", split=str(grid)), seed=0, rank=0, command_mix=1.0,
        command_resample=0.2, level_on_commands="falls",
    )  # fmt: skip
    try:
        env.reset(seed=0)
        assert env._drawn
        u = env.unwrapped
        env.level = 0
        u.data.qpos[u.handle.qadr] += 5.0  # far enough to promote on the task's command
        env._move_level(fell=False)
        assert env.level == 0
        env.level = 1
        env._move_level(fell=True)
        assert env.level == 0
        env._drawn = False  # as on the task's own command
        env._move_level(fell=False)
        assert env.level == 1
        env.reset(seed=1)
        first, seen = tuple(u.command), set()
        for _ in range(30):  # 0.6 s at a 0.2 s mean interval
            obs, _, end, cut, _ = env.step(np.zeros(12))
            assert tuple(obs["command"]) == tuple(np.float32(u.command))
            seen.add(tuple(u.command))
            if end or cut:
                break
        assert len(seen - {first}) >= 1
    finally:
        env.close()


GRID = loco_grid("rough", "quadruped")
TINY = TINY_LOCO + "command_mix = 0.5\n"


def test_a_tiny_locomotion_run_trains_and_citygen_bench_runs_it(tmp_path, grid):
    _, printed = tiny_loco_run(tmp_path, "loco-rough", "wheeled_legged", grid, TINY)
    assert "Balance" in printed and "X-displacement" in printed


def test_the_shipped_quadruped_walks_a_flat_test_episode():
    """The shipped LocoFlat model, numpy only, walks a whole test episode: no fall in 20 s and at
    least 90 % of the paper's 19.58 m X-displacement (over 256 episodes it keeps its balance in
    97.7 %, below the paper's 100 %: the baselines README)."""
    from citygen.runner.bench import run_episode
    from citygen.runner.learn.policy import baseline, load_policy

    env = make_env("loco-flat", robot="quadruped")
    try:
        policy = load_policy(str(baseline("loco-flat", "quadruped")))
        result = run_episode(env, policy, seed=3)
    finally:
        env.close()
    assert result["balance"] == 100.0 and result["x_displacement"] >= 0.9 * 19.58


def test_a_general_model_serves_every_loco_task_without_a_terrain_model(tmp_path, monkeypatch):
    """A policy trained on the mixed grid is the robot's general locomotion model: `--policy
    ppo` resolves to it on each loco task that has no terrain model, and
    ``general_locomotion`` finds it; a robot without one is a one-line error."""
    from citygen.runner.learn import policy as P
    from citygen.runner.learn import shipped_models
    from citygen.runner.learn.export import write_policy

    with np.load(P.baseline("loco-flat", "quadruped")) as data:
        arrays = {k: data[k] for k in data.files}
    meta = json.loads(str(arrays.pop("meta")))
    general_meta = general = {**meta, "train": {**meta["train"], "split": P.GENERAL_LOCO_SPLIT}}
    write_policy(tmp_path / "loco-general-quadruped.npz", general, arrays)
    write_policy(tmp_path / "loco-stair-quadruped.npz", {**meta, "task": "loco-stair"}, arrays)
    # a model kept for a task it was not trained on (an earlier general model): ``serves``
    write_policy(tmp_path / "loco-rough-quadruped.npz", {**general, "serves": "loco-rough"}, arrays)
    monkeypatch.setattr(shipped_models, "BASELINES", tmp_path)
    found = P.shipped()
    general = tmp_path / "loco-general-quadruped.npz"
    assert {t: found[(t, "quadruped")].name for t in P.LOCO_TASKS} == {
        "loco-flat": general.name, "loco-slope": general.name, "loco-rough": "loco-rough-quadruped.npz",
        "loco-stair": "loco-stair-quadruped.npz",
    }  # fmt: skip
    assert P.general_locomotion("quadruped") == general
    assert sorted(shipped_models.terrain_locomotion("quadruped")) == ["rough", "stair"]
    # a terrain model trained on navigation's commands: the traverse's, not --policy ppo's
    nav = {**meta, "task": "loco-stair", "commands": "navigation"}
    write_policy(tmp_path / "loco-stair-quadruped-nav.npz", nav, arrays)
    assert P.shipped()[("loco-stair", "quadruped")].name == "loco-stair-quadruped.npz"
    assert shipped_models.terrain_locomotion("quadruped")["stair"].name == "loco-stair-quadruped-nav.npz"
    # a general model trained on navigation's commands: the legs of navigation, not the tasks'
    write_policy(
        tmp_path / "loco-general-quadruped-nav.npz", {**general_meta, "commands": "navigation"}, arrays
    )
    assert P.general_locomotion("quadruped") == general
    assert P.general_locomotion("quadruped", "navigation").name == "loco-general-quadruped-nav.npz"
    assert P.shipped()[("loco-slope", "quadruped")] == general
    assert "flat" not in shipped_models.terrain_locomotion("quadruped")
    from citygen.runner.envs.legs import general_model
    from citygen.runner.robots.registry import load_robot

    robot = load_robot("quadruped")
    assert general_model("traverse", robot).name == "loco-general-quadruped-nav.npz"
    assert general_model("nav-static", robot).name == "loco-general-quadruped-nav.npz"
    with pytest.raises(P.PolicyError, match="no general locomotion model shipped for robot humanoid"):
        P.general_locomotion("humanoid")


def test_a_gsde_run_exports_the_mean_and_the_state_dependent_std_of_torch(tmp_path, cli):
    """``use_sde``: the exported policy acts with the torch policy's mean, and samples with
    gSDE's state-dependent std (``sqrt(latent^2 @ exp(log_std)^2)``, a matrix of log stds)."""
    import pickle

    from stable_baselines3 import PPO

    from citygen.runner.learn.export import read_policy

    config = tmp_path / "sde.toml"
    config.write_text(
        'envs = 2\nn_steps = 64\nminibatches = 2\nn_epochs = 1\nnet_arch = [16, 16]\nactivation = "elu"\n'
        "use_sde = true\nsde_sample_freq = 8\n"
    )
    out = tmp_path / "run"
    args = ["train", "--task", "loco-flat", "--robot", "wheeled_legged", "--steps", "256"]
    result = cli(*args, "--config", config, "--out", out)
    assert result.code == 0, result.err
    model = PPO.load(out / "model.zip", device="cpu")
    assert model.use_sde
    with open(out / "vecnormalize.pkl", "rb") as f:
        stats = pickle.load(f)
    policy = read_policy(out / "policy.npz")
    assert policy.log_std.ndim == 2  # (hidden, actions)
    env = make_env("loco-flat", robot="wheeled_legged")
    obs, _ = env.reset(seed=0)
    batch = []
    for _ in range(8):
        batch.append({k: obs[k] for k in policy.keys})
        obs, *_ = env.step(0.1 * env.action_space.sample())
    stacked = {k: np.stack([o[k] for o in batch]) for k in policy.keys}
    torch_actions, _ = model.predict(stats.normalize_obs(stacked), deterministic=True)
    np.testing.assert_allclose(policy.predict(stacked), torch_actions, atol=1e-5)
    dist = model.policy.get_distribution(model.policy.obs_to_tensor(stats.normalize_obs(stacked))[0])
    np.testing.assert_allclose(policy.std(stacked), dist.distribution.stddev.detach().numpy(), rtol=1e-4)
