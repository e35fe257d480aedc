"""benchmarks/loco_switching.py, locomotion models under changing commands: one row per file,
the same episodes for every file (the same file twice gives the same figures), figures in
their ranges, the last line one JSON object."""

from __future__ import annotations

import json

from benchmarks import loco_switching
from citygen.runner.learn.policy import baseline


def test_the_same_file_twice_walks_the_same_episodes(capsys):
    path = str(baseline("loco-slope", "quadruped"))
    loco_switching.main([path, path, "--episodes", "2", "--period", "0.2", "--rows", "0.2"])
    doc = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    first, second = doc["models"]
    assert first == second  # the same episodes
    row = first
    assert row["episodes"] == 2 and row["falls"] in (0.0, 50.0, 100.0)
    assert 0.0 <= row["sits"] <= 100.0 and -1.0 <= row["progress"] <= 1.0
