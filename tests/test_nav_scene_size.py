"""benchmarks/nav_scene_size.py, navigation difficulty against scene size: each size's split
manifests make scenes of that size, its runs train on them with the size's horizon, its tests
give success with a standard error, and the fit, plot, results file and last JSON line come out;
bad options are argparse's one-line error."""

from __future__ import annotations

import json
import math
import struct

import pytest

from benchmarks import nav_scene_size


def test_two_tiny_sizes_end_to_end(tmp_path, capsys):
    """The --quick path cut to its smallest: two sizes, one rollout of one sub-environment
    each, two test episodes, no start test."""
    out, runs = tmp_path / "out", tmp_path / "runs"
    args = ["--quick", "--sides", "5,8", "--steps", "100", "--envs", "1", "--episodes", "2", "--jobs", "1"]
    doc = nav_scene_size.main([*args, "--no-start", "--out", str(out), "--runs", str(runs)])

    assert [r["side_m"] for r in doc["sizes"]] == [5.0, 8.0]
    for row, side in zip(doc["sizes"], (5, 8), strict=True):
        assert row["area_m2"] == side * side and row["horizon_steps"] == 20 * side
        assert 0 <= row["success_rate"] <= 100 and row["success_se"] >= 0 and "start" not in row
        config = json.loads((runs / f"{side}m" / "config.json").read_text())
        assert config["max_steps"] == 20 * side and config["split"].endswith(f"nav-static-{side}m-train.json")
        assert config["init"].endswith("nav-clear-wheeled.npz")
    fit = doc["fit"]
    a, b = (r["success_rate"] for r in doc["sizes"])
    assert fit["slope_pct_per_m2"] == pytest.approx((b - a) / (64 - 25))
    logfit = doc["fit_log_area"]
    assert logfit["slope_pct_per_ln_m2"] == pytest.approx((b - a) / math.log(64 / 25))
    assert json.loads((out / "quick.json").read_text())["sizes"] == doc["sizes"]
    data = (out / "quick.png").read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and struct.unpack(">II", data[16:24])[0] > 500
    last = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert {"success_5m_pct", "success_se_8m_pct", "slope_pct_per_1000_m2", "r2"} <= set(last)


def test_a_sizes_splits_make_scenes_of_that_size(tmp_path):
    """Train and test manifests: the side, objects at citygen's default density of the ground
    that suits them, goals at least half the side away, and different scenes in the two."""
    from citygen.generate.splits import generate_scene, resolve

    train, test = nav_scene_size.write_splits(20.0, tmp_path)
    (train_split,), (test_split,) = resolve(train), resolve(test)
    assert train_split.config == test_split.config and train_split.name != test_split.name
    placement = train_split.config.placement
    assert placement.count is None and placement.density_per_100m2 == 4.0 and train_split.scenes == 256
    assert placement.density_levels == (0.5, 1.0, 1.5)
    scene = generate_scene(test_split, 1)  # density level 1.0
    assert (scene.bounds.max[0] - scene.bounds.min[0], scene.bounds.max[1] - scene.bounds.min[1]) == (20, 20)
    assert scene.placements
    assert math.dist(scene.task.start.position, scene.task.goal) >= 10.0
    assert generate_scene(train_split, 1).task.goal != scene.task.goal


@pytest.mark.parametrize(
    ("args", "says"),
    [(["--sides", "2,10"], "expected sides from 4 to 200 m"), (["--episodes", "0"], "expected at least 1")],
)
def test_bad_options_exit_2(args, says, capsys):
    with pytest.raises(SystemExit) as exc:
        nav_scene_size.main(args)
    assert exc.value.code == 2
    assert says in capsys.readouterr().err.strip().splitlines()[-1]


def test_a_scene_that_does_not_generate_is_one_line_and_exit_2(tmp_path, monkeypatch, capsys):
    from citygen.errors import GenerationError

    def fails(side, args):
        raise GenerationError("placement", 7, "placed 50 of the 74 objects asked for")

    monkeypatch.setattr(nav_scene_size, "run_side", fails)
    with pytest.raises(SystemExit) as exc:
        nav_scene_size.main(["--sides", "35", "--out", str(tmp_path), "--runs", str(tmp_path)])
    err = capsys.readouterr().err.strip().splitlines()
    assert exc.value.code == 2 and len(err) == 1
    assert err[0].startswith("nav_scene_size.py: --sides 35: ") and "placed 50 of the 74" in err[0]
