"""benchmarks/run_all.py: it runs the scripts it finds, collects their last-line JSON, keeps
going past a failing one, and writes results.json, REPORT.md and the plots; the targets
table says which targets hold. The figures here are made up: the suite's timing is its own
business (benchmarks/, never tests)."""

from __future__ import annotations

import datetime as dt
import json
import subprocess
import sys
from pathlib import Path

import pytest

RUN_ALL = Path(__file__).resolve().parent.parent / "benchmarks" / "run_all.py"
PNG = b"\x89PNG\r\n\x1a\n"


def run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, str(RUN_ALL), *args], capture_output=True, text=True, timeout=300)


def ok(figures: dict) -> dict:
    return {"args": [], "wall_s": 1.0, "returncode": 0, "figures": figures}


def fake_results() -> dict:
    """Results shaped like a real run's, with every series the plots draw."""
    figures = {
        "bench_layout": {
            "layout7_vs_metadrive_cpu_ratio": 0.18,
            "layout7_cpu_ms": 60.0,
            "metadrive7_cpu_ms": 340.0,
            "city1200_wall_s": 2.7,
            "city1200_peak_mib": 209.0,
            "city_time_area_exponent": 0.98,
            "city_sides_m": [300.0, 600.0, 900.0, 1200.0],
            "city_cpu_s": [0.17, 0.7, 1.43, 2.66],
        },
        "bench_generate": {
            "generate_sides_m": [300.0, 600.0, 900.0, 1200.0],
            "generate_cpu_s": [1.0, 4.1, 9.0, 16.5],
            "generate_json_s": [0.01, 0.04, 0.09, 0.16],
            "generate_over_json": [100.0, 102.5, 100.0, 103.1],
        },
        "bench_wfc": {
            "wfc_variants": 22,
            "wfc_16x16_ms": 1.0,
            "wfc_32x32_ms": 3.0,
            "wfc_64x64_ms": 75.0,  # past the 50 ms target: the table must say so
            "wfc_128x128_ms": 80.0,
            "wfc_64x64_cpu_ms": 70.0,
            "naive_16x16_ms": 58.0,
            "naive_64x64_ms": 20000.0,
            "terrain_unresolved_contradictions": 0,
        },
        "bench_dataset": {
            "dataset_jobs1_scenes_per_s": 37.0,
            "dataset_jobs2_scenes_per_s": 68.7,
            "dataset_jobs2_s": 22.4,
            "dataset_scenes": 1536,
            "json_floor_scenes_per_s": 900.0,
            "rss_start_mb": [228.8, 223.6],
        },
        "bench_runner": {
            "mj_step_per_s": 54000.0,
            "substeps_per_env_step": 50,
            "runner_envs": [1, 2, 4],
            "runner_envs_steps_per_s": [240.0, 400.0, 410.0],
            "runner_obs": ["state + height map", "+ rays", "+ depth 64x64", "+ RGB 64x64"],
            "runner_obs_steps_per_s": [240.0, 230.0, 130.0, None],
            "runner_obs_physics_floor_ratio": [4.5, 4.7, 8.3, None],
            "metadrive_steps_per_s": 1463.0,
        },
        "profile_generate": {
            "nav-train_cpu_ms_per_scene": 20.4,
            "nav-train_placement_share": 0.731,
            "nav-train_agents_share": 0.102,
            "nav-train_slowest_stage": "placement",
            "nav-train_top_function": "citygen/assets/catalog.py:124(resolve)",
            "nav-train_top_function_share": 0.531,
        },
        "bench_orca": {
            f"orca_{scene}_{n}_{who}_us_per_agent_step": value
            for scene in ("circle", "random")
            for n in (10, 100, 1000)
            for who, value in (("citygen", 23.0), ("citygen_batch8", 7.0), ("rvo2", 3.2), ("rvo2_core", 2.0))
        },
    }
    return {
        "started": "2026-11-21T08:00:00+00:00",
        "machine": {"cpu_model": "test CPU", "cores_usable": 2, "packages": {"numpy": "2.0"}},
        "suite_wall_s": 600.0,
        "benches": {
            **{name: ok(f) for name, f in figures.items()},
            "bench_export": {"args": [], "wall_s": 3.0, "returncode": 1, "error": "exit code 1: boom"},
            "run_all": {"figures": {"suite_wall_min": 10.0}},
        },
    }


def test_report_only_draws_every_plot_and_marks_missed_targets(tmp_path: Path) -> None:
    (tmp_path / "results.json").write_text(json.dumps(fake_results()))
    proc = run("--report-only", "--out", str(tmp_path))
    assert proc.returncode == 1, proc.stderr  # bench_export failed in the results
    assert "bench_export" in proc.stderr
    for name in ("generation_vs_area", "wfc_vs_grid", "dataset_vs_jobs", "runner", "orca_vs_agents"):
        png = tmp_path / "plots" / f"{name}.png"
        assert png.read_bytes()[:8] == PNG, name
        assert f"plots/{name}.png" in (tmp_path / "REPORT.md").read_text()
    report = (tmp_path / "REPORT.md").read_text()
    rows = {line.split("|")[2].strip(): line for line in report.splitlines() if line.startswith("| 4 ")}
    assert rows["WFC 64 x 64, 22 tile variants, median"].rstrip().endswith("**NO** |")
    assert rows["terrain over 10,000 seeds: unresolved contradictions"].rstrip().endswith("yes |")
    assert "not measured" in rows["terrain mix, largest deviation from the weights"]
    assert "`bench_export`: exit code 1: boom" in report
    assert (
        "| nav-train | 20.4 | placement 73 %, agents 10 % | placement | "
        "`citygen/assets/catalog.py:124(resolve)` | 53.1 % |" in report
    )
    assert "MISS issue 4: WFC 64 x 64" in proc.stdout


def test_report_only_without_results_is_a_one_line_error(tmp_path: Path) -> None:
    proc = run("--report-only", "--out", str(tmp_path))
    assert proc.returncode == 2
    assert proc.stderr.count("\n") == 1 and "results.json" in proc.stderr and "Traceback" not in proc.stderr


def test_runs_scripts_collects_json_and_survives_a_failure(tmp_path: Path) -> None:
    bench = tmp_path / "benches"
    bench.mkdir()
    (bench / "bench_wfc.py").write_text(
        "import json\nprint('a table for people')\nprint(json.dumps({'wfc_64x64_ms': 12.5, 'x': [1, 2]}))\n"
    )
    (bench / "bench_bad.py").write_text("import sys\nprint('partial')\nsys.exit('bad input: $.x')\n")
    (bench / "bench_nojson.py").write_text("print('no figures here')\n")
    (bench / "helper.py").write_text("raise SystemExit('not a benchmark: never run')\n")
    out = tmp_path / "out"
    proc = run("--bench-dir", str(bench), "--out", str(out))
    assert proc.returncode == 1
    results = json.loads((out / "results.json").read_text())
    benches = results["benches"]
    assert set(benches) == {"bench_bad", "bench_wfc", "bench_nojson", "run_all"}
    assert benches["bench_wfc"]["figures"] == {"wfc_64x64_ms": 12.5, "x": [1, 2]}
    assert benches["bench_wfc"]["returncode"] == 0 and "error" not in benches["bench_wfc"]
    assert benches["bench_bad"]["error"] == "exit code 1: bad input: $.x"
    assert "no JSON figures" in benches["bench_nojson"]["error"]
    assert "a table for people" in (out / "logs" / "bench_wfc.log").read_text()
    machine = results["machine"]
    assert machine["cores_usable"] >= 1 and machine["python"] == ".".join(map(str, sys.version_info[:3]))
    assert machine["packages"]["numpy"]
    report = (out / "REPORT.md").read_text()
    assert "| wfc_64x64_ms | 12.5 |" in report
    assert "| 4 | WFC 64 x 64, 22 tile variants, median | 12.5 ms | <= 50 ms | 0.250 | yes |" in report


@pytest.mark.parametrize("args", [["--only", "bench_missing"], ["--skip", "nope"]])
def test_unknown_script_names_are_refused(tmp_path: Path, args: list[str]) -> None:
    (tmp_path / "bench_a.py").write_text("print('{}')\n")
    proc = run("--bench-dir", str(tmp_path), "--out", str(tmp_path / "out"), *args)
    assert proc.returncode == 2 and "no such benchmark script" in proc.stderr
    assert not (tmp_path / "out" / "results.json").exists()


def test_only_and_skip_keep_the_other_scripts_figures_dated(tmp_path: Path) -> None:
    """A run of part of the suite merges into results.json: the scripts it did not run keep
    their figures with the time, commit and load they were measured at, the report dates
    them (targets table, per-script table, every figure), and the whole suite's wall time
    stays the last full run's."""
    bench = tmp_path / "benches"
    bench.mkdir()
    for name, figures in (
        ("bench_orca", {"orca_circle_100_citygen_over_rvo2": 1.5}),
        ("bench_traverse", {"town_realtime_factor": 6.0}),
        ("bench_wfc", {"wfc_64x64_ms": 12.5}),
    ):
        (bench / f"{name}.py").write_text(f"import json\nprint(json.dumps({figures!r}))\n")
    out = tmp_path / "out"
    out.mkdir()
    earlier = {
        "started": "2026-11-29T03:10:13+00:00",
        "machine": {"commit": "19f5c5e", "load_average_start": [0.4, 1.2, 1.5]},
        "suite_wall_s": 2389.0,
        "benches": {
            "bench_orca": ok({"orca_circle_100_citygen_over_rvo2": 4.09}),
            "bench_wfc": ok({"wfc_64x64_ms": 42.6}),
            # stamped by a merge before: keeps its own time and commit
            "bench_traverse": {**ok({"town_realtime_factor": 4.19}), "started": "2026-11-30T03:00:00+00:00",
                               "commit": "d8b9e5e", "load_average": [1.0, 1.0, 1.0]},
            "bench_gone": ok({"x": 1}),  # no such script any more: dropped
            "run_all": {"figures": {"suite_wall_min": 39.8}},
        },
    }  # fmt: skip
    (out / "results.json").write_text(json.dumps(earlier))

    proc = run("--bench-dir", str(bench), "--out", str(out), "--only", "bench_orca")
    assert proc.returncode == 0, proc.stderr
    results = json.loads((out / "results.json").read_text())
    benches = results["benches"]
    assert list(benches) == ["bench_orca", "bench_traverse", "bench_wfc", "run_all"]
    assert results["ran"] == ["bench_orca"]
    assert benches["bench_orca"]["figures"] == {"orca_circle_100_citygen_over_rvo2": 1.5}
    # this run's stamp, taken when the script started: not before the suite, never the earlier run's
    run_started = dt.datetime.fromisoformat(results["started"])
    orca_started = dt.datetime.fromisoformat(benches["bench_orca"]["started"])
    assert run_started <= orca_started <= dt.datetime.now(dt.UTC)
    assert benches["bench_orca"]["commit"] == results["machine"].get("commit")
    assert len(benches["bench_orca"]["load_average"]) == 3
    wfc = benches["bench_wfc"]
    assert wfc["figures"] == {"wfc_64x64_ms": 42.6}
    assert (wfc["started"], wfc["commit"], wfc["load_average"]) == (
        "2026-11-29T03:10:13+00:00", "19f5c5e", [0.4, 1.2, 1.5]
    )  # fmt: skip
    assert (benches["bench_traverse"]["started"], benches["bench_traverse"]["commit"]) == (
        "2026-11-30T03:00:00+00:00", "d8b9e5e"
    )  # fmt: skip
    assert benches["run_all"]["figures"] == {"suite_wall_min": 39.8}

    report = (out / "REPORT.md").read_text()
    rows = {line.split("|")[2].strip(): line for line in report.splitlines() if line.startswith("| ")}
    assert "measured" not in rows["ORCA per agent-step over RVO2 (pyrvo), 100 agents, circle"]
    assert (
        "| 42.6 ms (measured 2026-11-29 03:10 UTC, commit 19f5c5e) |"
        in rows["WFC 64 x 64, 22 tile variants, median"]
    )
    assert (
        "(measured 2026-11-30 03:00 UTC, commit d8b9e5e)"
        in rows["Traverse on a town of urban-tra-city's config, quadruped, real-time factor"]
    )
    assert "(measured 2026-11-29 03:10 UTC, commit 19f5c5e)" in rows["whole suite (run_all.py), wall time"]
    assert "This run measured `bench_orca`" in report
    assert "| bench_wfc | 2026-11-29T03:10:13+00:00 | 19f5c5e | 0.400, 1.20, 1.50 | 1.00 | no |" in report
    assert "measured 2026-11-29 03:10 UTC, commit 19f5c5e (an earlier run)" in report
    assert "bench_gone" not in report

    # --skip merges too; the scripts it ran replace their entries
    proc = run("--bench-dir", str(bench), "--out", str(out), "--skip", "bench_orca")
    assert proc.returncode == 0, proc.stderr
    results = json.loads((out / "results.json").read_text())
    assert results["ran"] == ["bench_traverse", "bench_wfc"]
    assert results["benches"]["bench_wfc"]["figures"] == {"wfc_64x64_ms": 12.5}
    assert results["benches"]["bench_orca"]["figures"] == {"orca_circle_100_citygen_over_rvo2": 1.5}

    # a full run replaces the whole document, its own suite wall time included
    proc = run("--bench-dir", str(bench), "--out", str(out))
    results = json.loads((out / "results.json").read_text())
    assert "ran" not in results and results["benches"]["run_all"]["figures"]["suite_wall_min"] < 5
    assert "(measured" not in (out / "REPORT.md").read_text()


def test_scripts_run_on_request_run_only_when_named_and_later_runs_keep_them(tmp_path: Path) -> None:
    """``traverse_modes`` (ON_REQUEST) stays out of a full run until ``--only`` names it;
    then its figures and issue 47's targets join the report, and a full run after keeps
    them while its own wall time becomes the suite's."""
    bench = tmp_path / "benches"
    bench.mkdir()
    ran = tmp_path / "ran"
    (bench / "bench_wfc.py").write_text('import json\nprint(json.dumps({"wfc_64x64_ms": 12.5}))\n')
    figures = {f"{m}_route_completion": 100.0 for m in ("human", "human_ai_mode_1", "human_ai_mode_2", "ai")}
    (bench / "traverse_modes.py").write_text(
        f"import json, pathlib\npathlib.Path({str(ran)!r}).touch()\nprint(json.dumps({figures!r}))\n"
    )
    out = tmp_path / "out"
    assert run("--bench-dir", str(bench), "--out", str(out)).returncode == 0
    results = json.loads((out / "results.json").read_text())
    assert not ran.exists() and "traverse_modes" not in results["benches"]

    proc = run("--bench-dir", str(bench), "--out", str(out), "--only", "traverse_modes")
    assert proc.returncode == 0, proc.stderr
    assert ran.exists()
    results = json.loads((out / "results.json").read_text())
    assert results["benches"]["traverse_modes"]["figures"] == figures
    assert results["benches"]["traverse_modes"]["args"] == ["--jobs", "2"]
    report = (out / "REPORT.md").read_text()
    assert "| 47 | urban-tra-standard on learned legs, quadruped, AI: route completed | 100 %" in report

    ran.unlink()
    results["benches"]["run_all"]["figures"]["suite_wall_min"] = 39.8  # an earlier full run's
    (out / "results.json").write_text(json.dumps(results))
    assert run("--bench-dir", str(bench), "--out", str(out)).returncode == 0
    results = json.loads((out / "results.json").read_text())
    assert not ran.exists() and results["benches"]["traverse_modes"]["figures"] == figures
    assert results["ran"] == ["bench_wfc"] and results["benches"]["run_all"]["figures"]["suite_wall_min"] < 5
