"""The batched vector environment (citygen.runner.vector) behind make_vector_env."""

from __future__ import annotations

import functools

import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

from citygen.runner.make import make_env, make_vector_env
from citygen.runner.vector import VectorEnv

SPLIT = "urban-nav-2-train"


def _actions(n: int, steps: int) -> np.ndarray:
    return np.random.default_rng(3).uniform(-1, 1, (steps, n, 2)).astype(np.float32)


def _rollout(venv, actions):
    obs, infos = venv.reset(seed=11)
    trace = [(obs, None, None, None, infos)]
    for a in actions:
        trace.append(venv.step(a))
    return trace


@pytest.mark.slow
def test_worker_processes_give_the_same_batches_as_one_process():
    """Every sub-environment in this process, each in a worker, the first here with the
    others in workers (what ``make_vector_env`` does when each process has a core), and
    workers stepping groups of them (what it does with more sub-environments than cores)."""
    actions = _actions(3, 8)
    fns = [functools.partial(make_env, "nav-static", split=SPLIT, max_steps=3) for _ in range(3)]
    runs = []
    layouts = ((False, None, None), (True, 0, 3), (True, 1, 2), (True, 2, 1), (True, 0, 1), (True, 1, 1))
    for processes, local, workers in layouts:
        venv = VectorEnv(fns, processes=processes, local=local, workers=workers)
        assert venv.metadata["autoreset_mode"] == AutoresetMode.NEXT_STEP
        assert len(venv._slots) == (3 if not processes else local)
        if processes:
            assert venv._counts == ([3 - local] if workers == 1 else [1] * workers)
        runs.append(_rollout(venv, actions))
        # Per-sub-environment attributes reach the right one, in order, in any layout.
        venv.set_attr("probe", [10, 11, 12])
        assert venv.get_attr("probe") == (10, 11, 12)
        venv.close()
    for other in runs[1:]:
        for (o1, r1, t1, u1, _), (o2, r2, t2, u2, _) in zip(runs[0], other, strict=True):
            for key in o1:
                np.testing.assert_array_equal(o1[key], o2[key])
            if r1 is not None:
                np.testing.assert_array_equal(r1, r2)
                np.testing.assert_array_equal(t1 | u1, t2 | u2)


@pytest.mark.slow
def test_batches_fit_the_spaces_and_finished_sub_envs_reset_on_the_next_step():
    venv = make_vector_env("nav-static", split=SPLIT, num_envs=2, max_steps=3)
    obs, infos = venv.reset(seed=5)
    assert venv.observation_space.contains(obs)
    assert obs["height_map"].shape == (2, *venv.single_observation_space["height_map"].shape)
    first = tuple(infos["index"])
    assert first[0] != first[1]  # each sub-environment runs its own scene
    seen = set(first)
    ended = 0
    for a in _actions(2, 12):
        obs, reward, term, trunc, infos = venv.step(a)
        assert venv.observation_space.contains(obs)
        assert reward.shape == term.shape == trunc.shape == (2,)
        done = term | trunc
        if done.any():
            ended += int(done.sum())
            assert infos["_metrics"].tolist() == done.tolist()  # the episode's metrics with its end
            after = venv.step(a)
            assert not (after[2] | after[3])[done].any() and (after[1][done] == 0).all()
    assert ended >= 4  # three-step episodes: every sub-environment finished several
    indices = venv.get_attr("_index")
    assert len(indices) == 2
    seen |= set(indices)
    assert len(seen) >= 3  # new scenes drawn on the resets
    venv.close()


def test_worker_errors_reach_the_caller():
    venv = make_vector_env("nav-static", split=SPLIT, num_envs=2)
    venv.reset(seed=0)
    with pytest.raises(AttributeError):
        venv.call("no_such_method")
    with pytest.raises(ValueError):
        venv.step(np.zeros((3, 2), dtype=np.float32))  # three actions for two environments
    # the pipes stay in step after an error here or in a worker
    assert venv.step(np.zeros((2, 2), dtype=np.float32))[0]["goal"].shape == (2, 2)
    assert venv.call("task_kind") == ("nav-static", "nav-static")
    venv.close()
    assert venv.closed


def test_scene_pool_limits_the_scenes_drawn():
    from citygen.errors import SpecError
    from citygen.runner.make import make_env

    with pytest.raises(SpecError, match="scene_pool"):
        make_env("nav-static", split=SPLIT, scene_pool=0)
    env = make_env("nav-static", split=SPLIT, scene_pool=2)
    seen = {env.reset(seed=s)[1]["index"] for s in range(6)}
    assert seen == {0, 1}
    env.close()


def test_depth_images_from_workers_match_one_process_and_survive_scene_swaps():
    from citygen.runner.make import make_env

    kw = {"depth": True, "image_size": 32, "scene_pool": 2}
    env = make_env("nav-static", split=SPLIT, **kw)
    first = env.reset(seed=0, options={"index": 0})[0]["depth"]
    env.reset(seed=0, options={"index": 1})  # another scene, another model to render
    again = env.reset(seed=0, options={"index": 0})[0]["depth"]
    np.testing.assert_array_equal(first, again)  # the kept renderer draws the scene it is given
    assert np.isfinite(first).all() and first.min() > 0 and np.ptp(first) > 0
    env.close()
    venv = make_vector_env("nav-static", split=SPLIT, num_envs=2, **kw)
    obs, _ = venv.reset(seed=0, options={"index": 0})
    np.testing.assert_array_equal(obs["depth"][0], first)
    np.testing.assert_array_equal(obs["depth"][1], first)
    venv.close()


@pytest.mark.slow
def test_same_step_autoreset_matches_gymnasiums():
    """``autoreset_mode=SAME_STEP`` (what SB3 needs): worker processes give Gymnasium's own
    ``SyncVectorEnv`` batches, the new episode's first observation on the step that ended
    the last one and that episode's last observation and info under ``final_obs`` and
    ``final_info``."""
    import functools

    from gymnasium.vector import SyncVectorEnv

    from citygen.runner.make import make_env
    from citygen.runner.vector import VectorEnv

    fns = [functools.partial(make_env, "nav-static", split=SPLIT, max_steps=3) for _ in range(2)]
    ours = VectorEnv(fns, autoreset_mode=AutoresetMode.SAME_STEP)
    theirs = SyncVectorEnv(fns, autoreset_mode=AutoresetMode.SAME_STEP)
    assert ours.metadata["autoreset_mode"] == AutoresetMode.SAME_STEP
    o1, _ = ours.reset(seed=4)
    o2, _ = theirs.reset(seed=4)
    ended = 0
    for a in _actions(2, 8):
        (o1, r1, t1, u1, i1), (o2, r2, t2, u2, i2) = ours.step(a), theirs.step(a)
        for key in o2:
            np.testing.assert_array_equal(o1[key], o2[key])
        np.testing.assert_array_equal(r1, r2)
        np.testing.assert_array_equal(t1 | u1, t2 | u2)
        for i in np.flatnonzero(t2 | u2):
            ended += 1
            assert i1["_final_obs"][i] and not i1["_final_obs"][~(t1 | u1)].any()
            for key in o2:
                np.testing.assert_array_equal(i1["final_obs"][i][key], i2["final_obs"][i][key])
            assert i1["_final_info"][i] and i1["final_info"]["_metrics"][i]
            m1, m2 = i1["final_info"]["metrics"], i2["final_info"]["metrics"]
            assert m1.keys() == m2.keys() and all(m1[k][i] == m2[k][i] for k in m2)
    assert ended >= 4
    ours.close()
    theirs.close()


def test_more_sub_envs_than_cores_step_in_one_process_per_core():
    """Beyond the cores, each process (this one and a worker per other core) steps a group:
    no more processes than cores, the groups as even as can be, and the pipes stay in step
    when a group's sub-environment fails."""
    from citygen.generate.dataset import default_jobs

    cores = default_jobs()
    n = 2 * cores + 1
    venv = make_vector_env("nav-static", split=SPLIT, num_envs=n, max_steps=3)
    sizes = [len(venv._slots), *venv._counts]
    assert len(sizes) == cores if cores > 1 else sizes == [n]
    assert sum(sizes) == n and max(sizes) - min(sizes) <= 1
    obs, _ = venv.reset(seed=2)
    assert len(set(venv.get_attr("_index"))) > 1  # each sub-environment its own scene
    ended = np.zeros(n, dtype=int)
    for a in _actions(n, 8):
        obs, reward, term, trunc, _ = venv.step(a)
        assert venv.observation_space.contains(obs) and reward.shape == (n,)
        ended += term | trunc
    assert (ended >= 2).all()  # three-step episodes: every group's members ended and reset
    with pytest.raises(AttributeError):
        venv.call("no_such_method")
    assert venv.call("task_kind") == ("nav-static",) * n
    venv.close()
