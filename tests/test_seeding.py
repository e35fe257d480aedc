"""Reproducibility of seeds: stages independent, children order-free, split seeds stable."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from citygen.seeding import STAGES, child, scene_seed, stage_rng


def test_each_stage_has_its_own_stream():
    draws = {stage: stage_rng(7, stage).integers(1 << 62) for stage in STAGES}
    assert len(set(draws.values())) == len(STAGES)
    assert draws == {stage: stage_rng(7, stage).integers(1 << 62) for stage in STAGES}


def test_drawing_more_in_one_stage_leaves_the_others_alone():
    before = stage_rng(3, "agents").random(5)
    stage_rng(3, "terrain").random(10_000)
    assert np.array_equal(before, stage_rng(3, "agents").random(5))


def test_children_do_not_depend_on_order():
    a = child(stage_rng(1, "blocks"), 5).random(3)
    rng = stage_rng(1, "blocks")
    for k in range(5):
        child(rng, k).random(100)
    assert np.array_equal(a, child(rng, 5).random(3))
    assert not np.array_equal(a, child(rng, 6).random(3))


def test_scene_seeds_differ_by_split_and_index():
    seeds = {
        scene_seed(2025, split, i) for split in ("urban-nav-1-train", "urban-nav-1-test") for i in range(100)
    }
    assert len(seeds) == 200
    assert all(0 <= s < 2**64 for s in seeds)


def test_scene_seed_is_the_same_in_any_process():
    code = "from citygen.seeding import scene_seed; print(scene_seed(2025, 'urban-nav-2-train', 17))"
    outs = {
        subprocess.run(
            [sys.executable, "-c", code],
            capture_output=True,
            text=True,
            check=True,
            env={**os.environ, "PYTHONHASHSEED": h},
        ).stdout
        for h in ("0", "1", "12345")
    }
    assert outs == {f"{scene_seed(2025, 'urban-nav-2-train', 17)}\n"}


@pytest.mark.parametrize("bad", [-1, 2**64, 1.5, True, "7"])
def test_bad_seeds_are_rejected(bad):
    with pytest.raises(ValueError, match="seed"):
        stage_rng(bad, "blocks")


def test_unknown_stage_is_rejected():
    with pytest.raises(ValueError, match="unknown stage"):
        stage_rng(1, "weather")
