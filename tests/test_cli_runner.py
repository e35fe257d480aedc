"""``citygen run`` and ``citygen bench`` refuse every combination of task, robot, policy and
split that does not fit with one line naming what does, exit code 2 and no traceback, before
any episode runs (the checks live in :mod:`citygen.runner.tasks`)."""

from __future__ import annotations

import json

import pytest

from citygen.runner.robots import BUILTIN
from citygen.runner.tasks import policies_for, robots_for
from tests.conftest import EXAMPLES

NAV = next(p for p in EXAMPLES if p.name == "nav_static_10m.json")


@pytest.fixture
def no_task(tmp_path):
    doc = json.loads(NAV.read_text())
    doc["task"] = None
    path = tmp_path / "no_task.json"
    path.write_text(json.dumps(doc))
    return path


def _legless() -> str:
    return next(r for r in BUILTIN if r not in robots_for("loco-flat"))


# name -> (arguments, words the one line must hold: the option and what fits)
CASES = {
    "run: no task in the scene": (["run", "{no_task}"], ["$.task", "--task", "nav-static"]),
    "run: no task, --task nav-static": (
        ["run", "{no_task}", "--task", "nav-static"],
        ["$.task", "nav-static"],
    ),
    "run: trot on a navigation scene": (["run", str(NAV), "--policy", "trot"], ["--policy", "planner"]),
    "run: stand on a navigation scene": (["run", str(NAV), "--policy", "stand"], ["--policy", "random"]),
    "run: traverse mode on a navigation scene": (
        ["run", str(NAV), "--policy", "ai"],
        ["--policy", "planner"],
    ),
    "run: unknown policy": (["run", str(NAV), "--policy", "dance"], ["--policy", "planner"]),
    "run: unknown robot": (["run", str(NAV), "--robot", "robbie"], ["--robot", "wheeled"]),
    "run: a locomotion task on a navigation scene": (
        ["run", str(NAV), "--task", "loco-flat"],
        ["$.task", "loco"],
    ),
    "run: unknown task": (["run", str(NAV), "--task", "fly"], ["--task", "nav-static"]),
    "bench: unknown task": (["bench", "--task", "fly"], ["--task", "loco-rough"]),
    "bench: planner on locomotion": (
        ["bench", "--task", "loco-rough", "--policy", "planner"],
        ["--policy", "trot"],
    ),
    "bench: trot on navigation": (
        ["bench", "--task", "nav-static", "--policy", "trot"],
        ["--policy", "planner"],
    ),
    "bench: unknown robot": (
        ["bench", "--task", "nav-static", "--robot", "robbie"],
        ["--robot", "quadruped"],
    ),
    "bench: legless robot on locomotion": (
        ["bench", "--task", "loco-flat", "--robot", "{legless}"],
        ["--robot", "quadruped"],
    ),
    "bench: navigation split for locomotion": (
        ["bench", "--task", "loco-rough", "--split", "urban-nav-2-test"],
        ["--split", "urban-loc-4-test"],
    ),
    "bench: locomotion split for navigation": (
        ["bench", "--task", "nav-static", "--split", "urban-loc-1-test"],
        ["--split", "urban-nav-2-test"],
    ),
    "bench: navigation split for the traverse": (
        ["bench", "--task", "traverse", "--split", "urban-nav-1-test"],
        ["--split", "urban-tra-standard"],
    ),
    "bench: unknown split": (["bench", "--task", "nav-static", "--split", "urban-nav-9"], ["--split"]),
}


@pytest.mark.parametrize("name", list(CASES))
def test_wrong_combination_is_one_line_and_exit_2(cli, no_task, name):
    args, words = CASES[name]
    args = [a.format(no_task=no_task, legless=_legless()) for a in args]
    result = cli(*args)
    assert result.code == 2, (name, result)
    lines = result.err.strip().splitlines()
    assert len(lines) == 1, lines
    assert "Traceback" not in result.err and "Error" not in lines[0].split(":")[0], lines
    for word in words:
        assert word in lines[0], (word, lines[0])
    assert result.out == ""


@pytest.mark.parametrize("task", ["nav-static", "loco-rough", "traverse"])
def test_every_policy_the_checks_refuse_is_named_by_none_of_the_robots(task):
    """The checks and the lists agree: a policy is offered for a robot exactly when it fits."""
    from citygen.runner.policies import POLICIES
    from citygen.runner.tasks import check_policy

    for robot in robots_for(task):
        fits = policies_for(task, robot)
        assert "random" in fits
        for policy in POLICIES:
            if policy in fits:
                assert check_policy(task, robot, policy) == policy
            else:
                with pytest.raises(Exception, match=r"^--policy: .*expected one of random"):
                    check_policy(task, robot, policy)


@pytest.mark.slow
def test_run_prints_the_bench_table(cli):
    result = cli("run", NAV, "--policy", "random", "--seed", "1")
    assert result.code == 0, result.err
    head = result.out.splitlines()
    assert head[0].startswith(f"nav-static on {NAV}: wheeled robot, random policy, 1 episode")
    assert head[1].split()[:3] == ["Metric", "Mean", "±"]
    assert any(line.startswith("Success Rate (%)") for line in head)
