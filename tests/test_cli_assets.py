"""`citygen assets list` and `citygen assets render`, run as a user runs them."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from citygen.assets import categories

ROOT = Path(__file__).resolve().parents[1]


def run(*args: str, cwd: Path = ROOT) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "citygen", *args], capture_output=True, text=True, cwd=cwd)


def test_assets_list_names_every_category_with_its_ranges() -> None:
    out = run("assets", "list")
    assert out.returncode == 0, out.stderr
    lines = out.stdout.splitlines()
    assert lines[-1] == f"{len(categories())} categories"
    rows = {line.split()[0]: line for line in lines[1:-1]}
    assert set(rows) == set(categories()) and len(categories()) >= 22
    assert "10000" in rows["bench"] and "sidewalk" in rows["bench"]


def test_assets_render_writes_a_png_and_rejects_unknown_categories(tmp_path: Path) -> None:
    out = run("assets", "render", "bench", "--out", str(tmp_path / "b.png"), "--count", "4", "--size", "400")
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "b.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    bad = run("assets", "render", "benchh", "--out", str(tmp_path / "x.png"))
    assert bad.returncode == 2 and len(bad.stderr.strip().splitlines()) == 1
    assert "benchh" in bad.stderr and "bench" in bad.stderr and "Traceback" not in bad.stderr
    assert not (tmp_path / "x.png").exists()
