"""benchmarks/nav_bearing.py, navigation failures against the goal's bearing at the start: the
bearings are the benchmark's own episodes' (reset with its seeds and scenes), each episode
falls in one bin, a failure is counted where the episode failed, and documents of another
seed or no benchmark at all are a one-line exit."""

from __future__ import annotations

import json
import math

import pytest

from benchmarks import nav_bearing


def test_the_bins_hold_the_benchmarks_episodes_and_failures(cli, tmp_path, capsys):
    out = tmp_path / "planner.json"
    r = cli("bench", "--task", "nav-clear", "--policy", "planner", "--episodes", "4", "--jobs", "1",
            "--max-steps", "30", "-o", out)  # fmt: skip
    assert r.code == 0, r.err
    doc = json.loads(out.read_text())
    bearing = nav_bearing.bearings(doc["task"], doc["split"], doc["robot"], doc["seed"], 4)
    assert all(0.0 <= b <= 180.0 for b in bearing) and len(set(bearing)) == 4

    # the bins count the episodes that failed (30 steps, 3 s, leave most goals unreached)
    bins = nav_bearing.main([str(out)])[str(out)]
    rows = sorted(doc["rows"], key=lambda row: row["index"])
    assert sum(b["episodes"] for b in bins) == 4
    for b in bins:
        inside = [row for row, x in zip(rows, bearing, strict=True) if b["from"] <= x < b["to"]
                  or (b["to"] == 180.0 and x == 180.0)]  # fmt: skip
        assert b["episodes"] == len(inside)
        assert b["failures"] == sum(row["success_rate"] < 50 for row in inside)
    assert "failures" in capsys.readouterr().out

    # the bearing is the goal observation's angle at the reset the benchmark made
    from citygen.runner.make import make_env

    env = make_env("nav-clear", split=doc["split"], robot=doc["robot"])
    obs, _ = env.reset(seed=doc["seed"] + 2, options={"index": 2})
    assert bearing[2] == pytest.approx(abs(math.degrees(math.atan2(obs["goal"][1], obs["goal"][0]))))


def test_a_bin_counts_its_failures_and_the_last_holds_180():
    bins = nav_bearing.bins([10.0, 50.0, 170.0, 180.0, 44.9], [100.0, 0.0, 0.0, 100.0, 40.0])
    assert [(b["episodes"], b["failures"]) for b in bins] == [(2, 1), (1, 1), (0, 0), (2, 1)]


def test_documents_that_do_not_fit_are_a_one_line_exit(tmp_path):
    a, b, c = tmp_path / "a.json", tmp_path / "b.json", tmp_path / "c.json"
    head = {"task": "nav-clear", "split": "urban-nav-1-test", "robot": "wheeled", "rows": []}
    a.write_text(json.dumps({**head, "seed": 0}))
    b.write_text(json.dumps({**head, "seed": 5}))
    c.write_text("not json")
    with pytest.raises(SystemExit, match="another task, split, robot or seed"):
        nav_bearing.main([str(a), str(b)])
    with pytest.raises(SystemExit, match=r"c\.json: expected a JSON document of `citygen bench -o`"):
        nav_bearing.main([str(c)])
