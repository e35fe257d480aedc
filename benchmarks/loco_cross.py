"""Cross-evaluation of locomotion models (the paper's "Necessity of Foundational Tasks", task
conditions): each terrain model and the general model of a robot on each terrain's test split,
Balance (%) and X-displacement (m), as a table, a JSON file and a two-panel heatmap.

Rows are the shipped models of the robot (``citygen/runner/learn/baselines``): the terrain
models ``loco-<terrain>-<robot>.npz`` and the general model trained on the mixed grid; a row
with no shipped model says so and is not measured (a terrain model is picked up the day its
file ships). Columns are the LocoFlat, LocoSlope, LocoStair and LocoRough test splits; each
cell is ``citygen bench --task T --robot R --policy FILE --episodes N`` run by
:func:`loco_table.measure`. Balance's standard error is the proportion's,
``sqrt(p (1 - p) / n)``; X-displacement's is ``std / sqrt(n)``.

The paper gives its cross-evaluation as a figure only, and the figure is absent from the
paper's source (an empty ``\\includegraphics``): there are no off-diagonal numbers to set
beside ours. Beside each terrain model on its own terrain (the diagonal) stands the paper's
locomotion table (its Table "Urban Locomotion benchmark", whose cells are the terrain models on
their own terrain). The paper's finding, in words: the terrain models win on their own terrain
(the diagonal), and the general model falls short except on slopes.

Cells are kept in ``<out>/<robot>.json`` keyed by the model file's digest (and cells that
``benchmarks/loco_table.py`` measured on the same file, physics and episodes are taken from
its results: the same episodes and seeds), so a rerun measures only what changed; ``--tasks``
picks the columns. Writes ``<out>/<robot>.json``, ``.md`` and ``.png`` (one robot's run leaves
another's files alone).

    python benchmarks/loco_cross.py --robot quadruped --episodes 64 --jobs 1 \\
        --out benchmarks/results/loco-cross
"""

from __future__ import annotations

import argparse
import json
import math
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import loco_table  # benchmarks/loco_table.py: the cells' evaluation

from citygen.io import write_atomic
from citygen.runner.envs import DEFAULT_SPLIT
from citygen.runner.learn.shipped_models import PolicyError, general_locomotion, shipped

TASKS = loco_table.TASKS
ROBOTS = loco_table.ROBOTS
#: The rows: the terrain models (by the task they were trained for) and the general model.
MODELS = ("flat", "slope", "stair", "rough", "general")
#: Where the paper's cross-evaluation numbers would come from, and why there are none.
PAPER_NOTE = (
    "The paper gives its cross-evaluation as a figure only (Fig. 'Necessity of foundational "
    "tasks', left; absent from its source): beside the diagonal stands its locomotion table "
    "(each terrain model on its own terrain)."
)


def models(robot: str) -> dict[str, Path | None]:
    """The shipped model of each row for ``robot``: ``None`` where none ships (the general
    model serves a terrain without a model of its own)."""
    try:
        general: Path | None = general_locomotion(robot)
    except PolicyError:
        general = None
    have = shipped()
    out: dict[str, Path | None] = {}
    for name, task in zip(MODELS[:-1], TASKS, strict=True):
        path = have.get((task, robot))
        out[name] = path if path is not None and path != general else None
    out["general"] = general
    return out


def _missing(name: str, general: Path | None) -> str:
    """Why a row is not measured."""
    if name == "general":
        return "not trained: no general model shipped for this robot"
    if general is not None:
        return "not trained: the general model is shipped for this task"
    return "not trained"


def figures(entry: dict) -> dict[str, tuple[float, float, int]]:
    """A cell's (mean, standard error, n) of balance (%, the proportion's error) and
    X-displacement (m)."""
    b, x = entry["summary"]["balance"], entry["summary"]["x_displacement"]
    n = int(b["n"])
    p = b["mean"] / 100.0
    sem = 100.0 * math.sqrt(max(p * (1.0 - p), 0.0) / n) if n else math.nan
    return {"balance": (b["mean"], sem, n), "x_displacement": (x["mean"], x["sem"], int(x["n"]))}


def _reuse(key: str, digest: str, episodes: int, *stores: dict) -> dict | None:
    """A cell already measured with the same inputs and episodes in one of ``stores``."""
    for store in stores:
        old = store.get(key)
        if old and (old.get("digest"), old.get("episodes")) == (digest, episodes):
            return old
    return None


def run(
    robot: str, episodes: int, jobs: int, out: Path, tasks: tuple[str, ...] = TASKS, force: bool = False
) -> dict:
    """Measure (or reuse) every cell of ``robot``'s cross-evaluation on ``tasks`` and write
    ``out/<robot>.json``, ``.md`` and ``.png``; the JSON document."""
    json_path = out / f"{robot}.json"
    mine = json.loads(json_path.read_text()) if json_path.exists() and not force else {}
    old_cells = mine.get("cells", {}) if mine.get("robot") == robot else {}
    table_cells = {}
    if not force and loco_table.RESULTS.exists():
        table_cells = json.loads(loco_table.RESULTS.read_text())
    files = models(robot)
    cells: dict[str, dict] = {}
    for name, file in files.items():
        if file is None:
            continue
        for task in tasks:
            key = f"{name}/{task}"
            digest = loco_table._digest(robot, task, "ppo", file)
            reused = _reuse(key, digest, episodes, old_cells) or _reuse(
                f"{robot}/{task}/ppo", digest, episodes, table_cells
            )
            if reused is not None:
                cells[key] = reused
                continue
            cells[key] = loco_table.measure(robot, task, "ppo", episodes, jobs, file=file)
            f = figures(cells[key])
            print(
                f"{name} model on {task}: balance {f['balance'][0]:.2f} ± {f['balance'][1]:.2f} %, "
                f"X {f['x_displacement'][0]:.2f} ± {f['x_displacement'][1]:.2f} m "
                f"({cells[key]['seconds']} s)",
                flush=True,
            )
            doc = _document(robot, episodes, tasks, files, cells)
            _write(json_path, json.dumps(doc, indent=1) + "\n")
    doc = _document(robot, episodes, tasks, files, cells)
    _write(json_path, json.dumps(doc, indent=1) + "\n")
    _write(out / f"{robot}.md", markdown(doc) + "\n")
    heatmap(doc, out / f"{robot}.png")
    return doc


def _document(
    robot: str, episodes: int, tasks: tuple[str, ...], files: dict[str, Path | None], cells: dict
) -> dict:
    general = files["general"]
    rows = {
        name: {"file": file.name if file else None, "note": None if file else _missing(name, general)}
        for name, file in files.items()
    }
    for entry in cells.values():
        entry["figures"] = {k: list(v) for k, v in figures(entry).items()}
    paper = {}
    for task in tasks:
        (balance, x_displacement, _, _) = loco_table.PAPER[robot][task]
        paper[task] = {"balance": list(balance), "x_displacement": list(x_displacement)}
    return {
        "robot": robot, "episodes": episodes, "tasks": list(tasks), "models": rows, "cells": cells,
        "paper_diagonal": paper, "paper_note": PAPER_NOTE,
    }  # fmt: skip


def _write(path: Path, text: str) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    write_atomic(path, text.encode())


def _column(task: str) -> str:
    return "Loco" + task.removeprefix("loco-").title()


def _label(name: str) -> str:
    return f"{name.title()} model"


def markdown(doc: dict) -> str:
    """Balance % / X-displacement m, each ± its standard error, rows = models, columns = the
    terrains' test splits; the paper's locomotion table as the last row (its diagonal)."""
    robot, tasks = doc["robot"], doc["tasks"]
    lines = [
        f"{loco_table.NAMES[robot]}, {doc['episodes']} test episodes per cell: Balance (%) / "
        "X-displacement (m), each ± its standard error.",
        "",
        "| model (file) | " + " | ".join(_column(t) for t in tasks) + " |",
        "|---|" + "---|" * len(tasks),
    ]
    for name, row in doc["models"].items():
        head = f"{_label(name)} (`{row['file']}`)" if row["file"] else _label(name)
        if row["file"] is None:
            lines.append(f"| {head} | " + " | ".join([row["note"]] + ["-"] * (len(tasks) - 1)) + " |")
            continue
        cells = []
        for task in tasks:
            f = doc["cells"][f"{name}/{task}"]["figures"]
            (b, bs, _), (x, xs, _) = f["balance"], f["x_displacement"]
            balance, x_displacement = f"{b:.2f} ± {bs:.2f}", f"{x:.2f} ± {xs:.2f}"
            if _best(doc, task, name, "balance"):
                balance = f"**{balance}**"
            if _best(doc, task, name, "x_displacement"):
                x_displacement = f"**{x_displacement}**"
            cells.append(f"{balance} / {x_displacement}")
        lines.append(f"| {head} | " + " | ".join(cells) + " |")
    paper = [
        f"{p['balance'][0]:.2f} ± {p['balance'][1]:.2f} / {p['x_displacement'][0]:.2f} ± "
        f"{p['x_displacement'][1]:.2f}"
        for p in (doc["paper_diagonal"][t] for t in tasks)
    ]
    lines.append("| paper: each terrain model on its own terrain | " + " | ".join(paper) + " |")
    lines += [
        "",
        "Bold: a column's best balance and its longest X-displacement. " + doc["paper_note"],
    ]
    return "\n".join(lines)


def _best(doc: dict, task: str, name: str, metric: str) -> bool:
    """Whether ``name`` has the highest ``metric`` on ``task`` (of equal ones, the first row).
    Each metric alone: a model that stands still keeps its balance and goes nowhere."""
    measured = {
        m: doc["cells"][f"{m}/{task}"]["figures"] for m in doc["models"] if f"{m}/{task}" in doc["cells"]
    }
    top = max(measured, key=lambda m: measured[m][metric][0])
    return top == name


def heatmap(doc: dict, path: Path) -> None:
    """Two panels, balance and X-displacement: rows = models, columns = terrains, each cell
    its value ± standard error, the paper's figure under the diagonal's; rows without a model
    grey with their note. Balance is coloured on 0-100 %, X-displacement by the fraction of
    the column's best (a terrain's distances differ: 20 m on flat ground, 4 m on slopes)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    names, tasks = list(doc["models"]), doc["tasks"]
    fig, axes = plt.subplots(
        1,
        2,
        figsize=(2 * max(5.5, 1.6 + 1.35 * len(tasks)), 1.0 + 1.05 * len(names)),
        constrained_layout=True,
    )
    for ax, metric in zip(axes, ("balance", "x_displacement"), strict=True):
        values = np.full((len(names), len(tasks)), np.nan)
        for i, name in enumerate(names):
            for j, task in enumerate(tasks):
                cell = doc["cells"].get(f"{name}/{task}")
                if cell:
                    values[i, j] = cell["figures"][metric][0]
        if metric == "balance":
            shade = values / 100.0
            title = "Balance (%), colour from 0 to 100 %"
        else:
            best = np.nanmax(np.where(np.isnan(values), -np.inf, values), axis=0)
            shade = np.clip(values / np.where(best > 0, best, 1.0), 0.0, 1.0)
            title = "X-displacement (m), colour: fraction of the column's best"
        cmap = plt.get_cmap("viridis").with_extremes(bad="#d9d9d9")
        ax.imshow(np.ma.masked_invalid(shade), cmap=cmap, vmin=0.0, vmax=1.0, aspect="auto")
        for i, name in enumerate(names):
            row = doc["models"][name]
            if row["file"] is None:
                ax.text(
                    (len(tasks) - 1) / 2,
                    i,
                    row["note"],
                    ha="center",
                    va="center",
                    fontsize=9,
                    color="#444444",
                )
                if f"loco-{name}" in tasks:  # the paper's figure for this row's own terrain
                    j = tasks.index(f"loco-{name}")
                    p_mean, p_sem = doc["paper_diagonal"][tasks[j]][metric]
                    digits = 1 if metric == "balance" else 2
                    ax.text(j, i + 0.3, f"paper {p_mean:.{digits}f} ± {p_sem:.{digits}f}", ha="center",
                            va="center", fontsize=9, color="#444444")  # fmt: skip
                continue
            for j, task in enumerate(tasks):
                mean, sem, _ = doc["cells"][f"{name}/{task}"]["figures"][metric]
                text = f"{mean:.1f} ± {sem:.1f}" if metric == "balance" else f"{mean:.2f} ± {sem:.2f}"
                if task == f"loco-{name}":  # the diagonal: the paper's figure beside
                    p_mean, p_sem = doc["paper_diagonal"][task][metric]
                    digits = 1 if metric == "balance" else 2
                    text += f"\npaper {p_mean:.{digits}f} ± {p_sem:.{digits}f}"
                dark = shade[i, j] < 0.6
                weight = "bold" if _best(doc, task, name, metric) else "normal"
                ax.text(j, i, text, ha="center", va="center", fontsize=9, weight=weight,
                        color="white" if dark else "black")  # fmt: skip
        ax.set_xticks(range(len(tasks)), [f"{_column(t)}\n{DEFAULT_SPLIT[t]}" for t in tasks])
        ax.set_yticks(range(len(names)), [_label(n) for n in names])
        ax.set_title(title, fontsize=10)
        ax.set_xticks(np.arange(-0.5, len(tasks)), minor=True)
        ax.set_yticks(np.arange(-0.5, len(names)), minor=True)
        ax.grid(which="minor", color="white", linewidth=2)
        ax.tick_params(which="minor", length=0)
    fig.suptitle(
        f"Cross-evaluation of {loco_table.NAMES[doc['robot']].lower()} locomotion models: "
        f"{doc['episodes']} test episodes per cell, mean ± standard error (bold: a column's best)",
        fontsize=11,
    )
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".tmp")
    fig.savefig(tmp, dpi=110, format="png")
    plt.close(fig)
    tmp.replace(path)


def _positive(text: str) -> int:
    try:
        value = int(text)
    except ValueError:
        value = 0
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected a whole number of at least 1, got {text!r}")
    return value


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--robot", default="quadruped", choices=list(ROBOTS))
    ap.add_argument("--episodes", type=_positive, default=256, help="test episodes per cell")
    ap.add_argument("--jobs", type=_positive, default=1, help="processes per cell")
    ap.add_argument("--tasks", nargs="+", default=list(TASKS), choices=list(TASKS), help="the columns")
    ap.add_argument(
        "--out", type=Path, default=Path("benchmarks/results/loco-cross"),
        help="folder of the results: <out>/<robot>.json, .md, .png",
    )  # fmt: skip
    ap.add_argument("--force", action="store_true", help="measure again cells whose inputs did not change")
    args = ap.parse_args(argv)
    tasks = tuple(t for t in TASKS if t in args.tasks)
    doc = run(args.robot, args.episodes, args.jobs, args.out, tasks, force=args.force)
    print(markdown(doc))
    print(f"wrote {args.out}/{args.robot}.json, .md and .png")
    last = {}
    for key, entry in sorted(doc["cells"].items()):
        name, task = key.split("/")
        f = entry["figures"]
        last[f"{name}_model_{task}_balance_pct"] = round(f["balance"][0], 2)
        last[f"{name}_model_{task}_x_displacement_m"] = round(f["x_displacement"][0], 3)
    print(json.dumps(last))


if __name__ == "__main__":
    main()
