"""benchmarks/loco_cross.py, the cross-evaluation of locomotion models: its table, JSON and
heatmap have one row per model (a row without a shipped model says so) and one column per
terrain, each figure with its standard error; bad options are argparse's one-line error."""

from __future__ import annotations

import json
import math
import struct

import pytest

from benchmarks import loco_cross


def _png_size(path) -> tuple[int, int]:
    data = path.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n"
    return struct.unpack(">II", data[16:24])


def test_quadruped_episodes_on_stairs(tmp_path, capsys):
    """The script itself on one test episode per cell (LocoStair only, where falls end the
    episodes early): each shipped model a row, the others marked, the files written."""
    out = tmp_path / "cross"
    loco_cross.main(["--episodes", "1", "--tasks", "loco-stair", "--out", str(out)])
    doc = json.loads(out.joinpath("quadruped.json").read_text())
    assert doc["tasks"] == ["loco-stair"] and list(doc["models"]) == list(loco_cross.MODELS)
    measured = [m for m, row in doc["models"].items() if row["file"]]
    assert measured == list(loco_cross.MODELS)  # every quadruped row ships (stairs: 2026-12-02)
    assert sorted(doc["cells"]) == sorted(f"{m}/loco-stair" for m in measured)
    for cell in doc["cells"].values():
        assert cell["episodes"] == 1 and cell["figures"]["balance"][2] == 1
    table = out.joinpath("quadruped.md").read_text()
    assert table.count("\n| ") == len(loco_cross.MODELS) + 2  # the head, the models, the paper
    assert "| LocoStair |" in table and "91.89 ± 2.07 / 9.20 ± 0.36" in table
    width, height = _png_size(out.joinpath("quadruped.png"))
    assert width > height > 300
    last = json.loads(capsys.readouterr().out.strip().splitlines()[-1])
    assert set(last) == {
        f"{m}_model_loco-stair_{k}" for m in measured for k in ("balance_pct", "x_displacement_m")
    }


def test_table_shape_and_standard_errors(tmp_path, monkeypatch):
    """The whole 5 x 4 table from made-up cells (no episode run): balance's standard error is
    the proportion's, X-displacement's the sample's; the paper's figures on the diagonal."""

    def fake(robot, task, policy, episodes, jobs, file=None):
        b = {"loco-flat": 100.0, "loco-slope": 75.0, "loco-stair": 25.0, "loco-rough": 50.0}[task]
        summary = {
            "balance": {"mean": b, "sem": 99.0, "n": episodes},
            "x_displacement": {"mean": 2.0, "sem": 0.5, "n": episodes},
        }
        return {"summary": summary, "episodes": episodes, "seconds": 0.0, "digest": "d", "file": file.name}

    shipped = loco_cross.models
    monkeypatch.setattr(
        loco_cross, "models", lambda robot: {**shipped(robot), "stair": None}
    )  # one unshipped
    monkeypatch.setattr(loco_cross.loco_table, "measure", fake)
    monkeypatch.setattr(loco_cross.loco_table, "RESULTS", tmp_path / "none.json")
    doc = loco_cross.run("quadruped", 16, 1, tmp_path)
    measured = [m for m, row in doc["models"].items() if row["file"]]
    assert "stair" not in measured
    assert doc["models"]["stair"]["note"] == "not trained: the general model is shipped for this task"
    assert (
        "| not trained: the general model is shipped for this task | - | - | - |"
        in (tmp_path / "quadruped.md").read_text()
    )
    assert len(doc["cells"]) == 4 * len(measured)
    balance, sem, n = doc["cells"]["general/loco-slope"]["figures"]["balance"]
    assert (balance, n) == (75.0, 16) and sem == pytest.approx(100 * math.sqrt(0.75 * 0.25 / 16))
    assert doc["cells"]["general/loco-slope"]["figures"]["x_displacement"] == [2.0, 0.5, 16]
    assert doc["paper_diagonal"]["loco-slope"] == {"balance": [90.56, 3.13], "x_displacement": [4.63, 0.23]}
    lines = [line for line in (tmp_path / "quadruped.md").read_text().splitlines() if line.startswith("| ")]
    assert [line.count(" | ") for line in lines] == [4] * (len(loco_cross.MODELS) + 2)
    assert (tmp_path / "quadruped.png").stat().st_size > 10_000


@pytest.mark.parametrize(
    ("args", "says"),
    [(["--robot", "wheelchair"], "invalid choice: 'wheelchair'"), (["--episodes", "0"], "at least 1")],
)
def test_bad_options_exit_2(args, says, capsys):
    with pytest.raises(SystemExit) as exc:
        loco_cross.main(args)
    assert exc.value.code == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert says in err[-1] and err[-1].startswith("usage:") is False
