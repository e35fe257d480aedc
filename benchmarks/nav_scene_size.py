r"""Navigation difficulty against scene size (the paper's "Necessity of Foundational Tasks",
task size): NavStatic success of wheeled policies trained and tested on square scenes of 5 m to
50 m side, against the scene's area, with least-squares lines against the area and its logarithm.

The paper (URBAN-SIM appendix, "Necessity of Foundational Tasks"): "We train navigation
models with varying sizes of the scene, from 5m x 5m to 50m x 50m, to analyze changes in
learning difficulty" and "performance declines linearly as the training area size
increases". It gives the result as a figure only, and the figure is absent from the paper's
source (an empty ``\includegraphics``): there are no numbers to set beside ours, only that
statement, which the plot quotes.

Scenes. Each side ``L`` is urban-nav-2-train's config (citygen's NavStatic training split,
``seeds/urban-nav.toml``) scaled to ``L`` x ``L`` m at its own density and time per metre:

- objects: citygen's default density, 4 per 100 m^2 of the ground that suits them
  (``placement.count = "density"``; 2.9 on average on a 10 m scene, where urban-nav-2-train
  places exactly 4), at its density levels 50 %, 100 % and 150 %. An exact count in
  proportion to the area (4 per 100 m^2 of scene) asks a 50 m scene for up to 150 objects
  where its layout may have room for 50: a quarter of those scenes failed to generate;
- goals at least ``L / 2`` away (the test split's 7.5 m on 15 m), on walkable ground;
- episodes of ``2 L`` seconds, ``20 L`` control steps (the 10 m split's 200 steps): a 50 m
  scene's 25-40 m routes do not fit in the paper's 200 steps at the wheeled robot's 1.5 m/s.
  ``citygen train --max-steps`` and ``citygen bench --max-steps`` take it.

Every size has a training split and a held-out test split of 256 scenes (the same config;
their names, hence their scenes' seeds, differ), written as split manifests to
``<results>/splits/nav-static-<L>m-{train,test}.json``: ``citygen train --split FILE`` and
``citygen bench --split FILE`` read them as they read a named split.

Training. For each size one ``citygen train`` run (bench_learning.py's :func:`train_run`)
of ``--steps`` on 8 sub-environments sampling the size's training scenes asynchronously,
fine-tuned from the shipped NavClear file (``--init``,
``citygen/runner/learn/baselines/nav-clear-wheeled.npz``) with
``examples/train/nav-finetune.toml``, as the shipped NavStatic chain starts from NavClear (the
paper trains from scratch; its PPO budget per size is not given). Test: the first
``--episodes`` scenes of the size's test split, deterministic actions
(bench_learning.py's :func:`evaluate`); success's standard error is the sample's over
episodes, ``sqrt(p (1 - p) / (n - 1))``. The NavClear file itself, untrained on NavStatic, is
tested the same way at every size (``start``), unless ``--no-start``.

    python benchmarks/nav_scene_size.py                 # 5, 10, 20, 35, 50 m; 50k steps; 128 episodes
    python benchmarks/nav_scene_size.py --quick         # 5 and 10 m, 2,400 steps, 8 episodes

Run folders (models, checkpoints) go to ``--runs`` (default ``benchmarks/logs/nav-scene-size``,
not kept): a finished size is not trained or tested again, an interrupted one resumes. The
results (``results.json``; ``quick.json`` with ``--quick``), the plot (``nav_scene_size.png``;
``quick.png``) and the split manifests go to ``--out`` (default
``benchmarks/results/nav-scene-size``). Prints a table and, as its last line, one JSON object
of figures.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import sys
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import bench_learning  # benchmarks/bench_learning.py: one training run, one test

from citygen.errors import GenerationError
from citygen.io import write_atomic

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
#: The scene sides (m) of the full experiment and of ``--quick``.
SIDES = (5.0, 10.0, 20.0, 35.0, 50.0)
QUICK_SIDES = (5.0, 10.0)
#: The split every size's config is scaled from.
BASE_SPLIT = "urban-nav-2-train"
#: Episode length per metre of side (control steps): the 10 m split's 200.
STEPS_PER_M = 20
#: Scenes in each size's training and test split.
SPLIT_SCENES = 256
START = ROOT / "citygen" / "runner" / "learn" / "baselines" / "nav-clear-wheeled.npz"
CONFIG = ROOT / "examples" / "train" / "nav-finetune.toml"
#: The paper's finding, in its words (its figure gives no numbers).
PAPER = "performance declines linearly as the training area size increases"


def side_name(side: float) -> str:
    return f"{side:g}m"


def side_config(side: float) -> dict:
    """urban-nav-2-train's generator config (its fields that differ from the defaults) on
    ``side`` x ``side`` m: objects at citygen's default density of the ground that suits
    them, goals at least ``side / 2`` away."""
    from citygen.generate.splits import splits

    config = splits()[BASE_SPLIT].config.model_dump(mode="json", exclude_defaults=True)
    config["size"] = [side, side]
    config["placement"] = {**config.get("placement", {}), "count": "density"}
    config["task"] = {**config.get("task", {}), "min_distance": side / 2}
    return config


def _density() -> float:
    from citygen.spec.config import PlacementConfig

    return PlacementConfig().density_per_100m2


def horizon(side: float) -> int:
    """Control steps (0.1 s) an episode on a ``side`` m scene lasts: 200 on 10 m."""
    return max(1, round(STEPS_PER_M * side))


def write_splits(side: float, folder: Path) -> tuple[Path, Path]:
    """The size's training and test split manifests (``citygen train/bench --split FILE``),
    checked by the split loader; written only when their content changes."""
    from citygen.generate.splits import resolve

    paths = []
    for part in ("train", "test"):
        name = f"nav-static-{side_name(side)}-{part}"
        doc = {
            "format": "citygen.splits/1",
            "splits": [
                {
                    "name": name,
                    "description": f"NavStatic on {side:g} m x {side:g} m: {BASE_SPLIT} scaled by "
                    f"benchmarks/nav_scene_size.py ({part}).",
                    "scenes": SPLIT_SCENES,
                    "seed": 2025,
                    "config": side_config(side),
                }
            ],
        }
        path = folder / "splits" / f"{name}.json"
        text = json.dumps(doc, indent=1) + "\n"
        if not path.exists() or path.read_text() != text:
            write_atomic(path, text.encode())
        resolve(path)  # a bad config is the split loader's one-line error, before any run
        paths.append(path)
    return paths[0], paths[1]


def _curve(run: Path) -> list[dict]:
    """The rows of the run's learning curve (its curve.csv), none when it has none."""
    curve = run / "curve.csv"
    if not curve.exists():
        return []
    with open(curve, newline="") as f:
        return list(csv.DictReader(f))


def training_success(rows: list[dict]) -> tuple[float | None, float | None]:
    """Training success (%) of the first and last logged rollouts of a run's curve ``rows``."""
    rows = [r for r in rows if r.get("success_rate") not in (None, "")]
    if not rows:
        return None, None
    return float(rows[0]["success_rate"]), float(rows[-1]["success_rate"])


def training_seconds(rows: list[dict], spent: float) -> float:
    """Wall seconds a run trained (its curve ``rows``' last ``seconds``), else ``spent``."""
    rows = [r for r in rows if r.get("seconds") not in (None, "")]
    return float(rows[-1]["seconds"]) if rows else spent


def run_side(side: float, args: argparse.Namespace) -> dict:
    """Train and test one size; its row of the results."""
    train_split, test_split = write_splits(side, args.out)
    steps = horizon(side)
    run = args.runs / side_name(side)
    row = {
        "side_m": side,
        "area_m2": side * side,
        "objects_per_100m2_of_suitable_ground": _density(),
        "min_goal_distance_m": side / 2,
        "horizon_steps": steps,
        "train_split": str(_rel(train_split)),
        "test_split": str(_rel(test_split)),
    }
    if args.start:
        start = bench_learning.evaluate(args.init, run / "start", args, test_split, steps)
        row["start"] = {k: start[k] for k in ("success_rate", "success_se", "route_completion")}
    spent = bench_learning.train_run(run, args, split=str(train_split), max_steps=steps)
    curve = _curve(run)
    row["train_s"] = training_seconds(curve, spent)  # the run's own clock: a resumed size spent ~0 here
    row["train_success_first_pct"], row["train_success_last_pct"] = training_success(curve)
    test = bench_learning.evaluate(run / "policy.npz", run, args, test_split, steps)
    row.update({k: test[k] for k in ("success_rate", "success_se", "route_completion", "eval_s")})
    return row


def _rel(path: Path) -> Path:
    try:
        return path.resolve().relative_to(ROOT)
    except ValueError:
        return path


def linear_fit(xs: list[float], ys: list[float]) -> dict:
    """Least squares ``y = intercept + slope x`` (scipy's ``linregress``), the slope's standard
    error (None for two points) and R^2."""
    from scipy.stats import linregress

    if len(xs) < 2:  # one size: no slope to fit
        return {"intercept_pct": ys[0], "slope_pct_per_m2": 0.0, "slope_se_pct_per_m2": None, "r2": 1.0}
    fit = linregress(xs, ys)
    return {
        "intercept_pct": float(fit.intercept),
        "slope_pct_per_m2": float(fit.slope),
        "slope_se_pct_per_m2": float(fit.stderr) if len(xs) > 2 else None,
        "r2": float(fit.rvalue**2),
    }


def log_fit(xs: list[float], ys: list[float]) -> dict:
    """Least squares ``y = intercept + slope ln(x)`` (:func:`linear_fit` on ``ln x``) and its
    R^2: the shape to set beside the paper's straight line, where success falls fastest on
    small scenes."""
    fit = linear_fit([math.log(x) for x in xs], ys)
    slope = fit["slope_pct_per_m2"]
    return {"intercept_pct": fit["intercept_pct"], "slope_pct_per_ln_m2": slope, "r2": fit["r2"]}


def plot(
    rows: list[dict], fit: dict, path: Path, args: argparse.Namespace, logfit: dict | None = None
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    area = [r["area_m2"] for r in rows]
    fig, ax = plt.subplots(figsize=(6.5, 4.2), dpi=110)
    ax.errorbar(
        area,
        [r["success_rate"] for r in rows],
        yerr=[r["success_se"] for r in rows],
        fmt="o",
        color="tab:blue",
        capsize=3,
        label=f"citygen: trained and tested on each size ({args.episodes} episodes)",
    )
    for r in rows:
        ax.annotate(
            f"{r['side_m']:g} m", (r["area_m2"], r["success_rate"]), textcoords="offset points", xytext=(6, 6)
        )
    line_x = [0.0, max(area)]
    ax.plot(
        line_x,
        [fit["intercept_pct"] + fit["slope_pct_per_m2"] * x for x in line_x],
        "-",
        color="tab:blue",
        alpha=0.6,
        label=f"least squares: {fit['intercept_pct']:.1f} % {fit['slope_pct_per_m2'] * 1000:+.1f} "
        f"points per 1,000 m² (R² {fit['r2']:.2f})",
    )
    if logfit is not None and len(rows) > 1:
        curve_x = [min(area) * (max(area) / min(area)) ** (k / 100) for k in range(101)]
        ax.plot(
            curve_x,
            [logfit["intercept_pct"] + logfit["slope_pct_per_ln_m2"] * math.log(x) for x in curve_x],
            ":",
            color="tab:orange",
            label=f"against ln(area): {logfit['slope_pct_per_ln_m2'] * math.log(2):+.1f} points per "
            f"doubling of the area (R² {logfit['r2']:.2f})",
        )
    starts = [r for r in rows if "start" in r]
    if starts:
        ax.errorbar(
            [r["area_m2"] for r in starts],
            [r["start"]["success_rate"] for r in starts],
            yerr=[r["start"]["success_se"] for r in starts],
            fmt="s--",
            color="grey",
            capsize=3,
            markersize=4,
            label=f"start: {args.init.name}, before NavStatic training",
        )
    ax.set_xlabel("scene area (m²)")
    ax.set_ylabel("NavStatic success on the size's test scenes (%)")
    ax.set_ylim(0, 105)
    ax.set_xlim(left=0)
    ax.set_title(f"Wheeled robot, {args.steps:,} PPO steps per size from NavClear", fontsize=10)
    ax.text(
        0.98,
        0.04,
        f'URBAN-SIM paper (figure only, no numbers):\n"{PAPER}"',
        transform=ax.transAxes,
        ha="right",
        va="bottom",
        fontsize=7.5,
        style="italic",
    )
    ax.legend(loc="upper right", fontsize=7.5)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def _sides(text: str) -> list[float]:
    try:
        sides = [float(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected comma-separated sides in metres, got {text!r}") from None
    if not sides or any(not 4.0 <= s <= 200.0 for s in sides):
        raise argparse.ArgumentTypeError(f"expected sides from 4 to 200 m, got {text!r}")
    return sorted(set(sides))


def _positive(text: str) -> int:
    value = int(text)
    if value < 1:
        raise argparse.ArgumentTypeError(f"expected at least 1, got {text}")
    return value


def parse(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="5 and 10 m, 2,400 steps, 8 episodes")
    p.add_argument("--sides", type=_sides, default=None, help="comma-separated scene sides (m)")
    p.add_argument("--steps", type=_positive, default=None, help="PPO steps per size (default 50,000)")
    p.add_argument("--envs", type=_positive, default=8, help="sub-environments")
    p.add_argument("--episodes", type=_positive, default=None, help="test episodes per size (default 128)")
    p.add_argument("--jobs", type=_positive, default=None, help="test processes (default: every core)")
    p.add_argument("--seed", type=int, default=0, help="training seed; test episode i runs seed + i")
    p.add_argument("--robot", default="wheeled")
    p.add_argument("--config", type=Path, default=CONFIG, help="the TrainConfig file of every run")
    p.add_argument("--init", type=Path, default=START, help="the policy every run starts from")
    p.add_argument("--no-start", dest="start", action="store_false", help="do not test the --init policy")
    p.add_argument("--out", type=Path, default=HERE / "results" / "nav-scene-size", help="results folder")
    p.add_argument(
        "--runs", type=Path, default=None, help="run folders (default benchmarks/logs/nav-scene-size)"
    )
    args = p.parse_args(argv)
    args.sides = args.sides or list(QUICK_SIDES if args.quick else SIDES)
    args.steps = args.steps or (2_400 if args.quick else 50_000)
    args.episodes = args.episodes or (8 if args.quick else 128)
    args.runs = args.runs or HERE / "logs" / ("nav-scene-size-quick" if args.quick else "nav-scene-size")
    return args


def main(argv: list[str] | None = None) -> dict:
    args = parse(argv)
    t0 = time.perf_counter()
    rows = []
    for side in args.sides:
        try:
            rows.append(run_side(side, args))
        except GenerationError as err:  # a scene of the size's splits: one line, exit 2
            print(f"nav_scene_size.py: --sides {side:g}: {err}", file=sys.stderr)
            raise SystemExit(2) from None
        r = rows[-1]
        print(
            f"{r['side_m']:>4g} m ({r['area_m2']:>6g} m², "
            f"{r['horizon_steps']} steps): success {r['success_rate']:5.1f} ± {r['success_se']:.1f} %, "
            "route completion "
            f"{r['route_completion']:5.1f} % ({r['train_s']:.0f} s training)",
            flush=True,
        )
    fit = linear_fit([r["area_m2"] for r in rows], [r["success_rate"] for r in rows])
    logfit = log_fit([r["area_m2"] for r in rows], [r["success_rate"] for r in rows])
    name = "quick" if args.quick else "results"
    plot_path = args.out / ("quick.png" if args.quick else "nav_scene_size.png")
    plot(rows, fit, plot_path, args, logfit)
    doc = {
        "experiment": "NavStatic success against scene size (URBAN-SIM, Necessity of Foundational Tasks)",
        "paper": PAPER + " (figure only; no numbers in the paper)",
        "robot": args.robot,
        "init": str(_rel(args.init.resolve())),
        "config": str(_rel(args.config.resolve())),
        "steps_per_size": args.steps,
        "envs": args.envs,
        "test_episodes": args.episodes,
        "seed": args.seed,
        "command": "python benchmarks/nav_scene_size.py "
        + " ".join(argv if argv is not None else sys.argv[1:]),
        "sizes": rows,
        "fit": fit,
        "fit_log_area": logfit,
        "plot": str(_rel(plot_path.resolve())),
    }
    write_atomic(args.out / f"{name}.json", (json.dumps(doc, indent=1) + "\n").encode())

    print()
    print(
        f"NavStatic success (%) on each size's test scenes ({args.episodes} episodes), "
        f"{args.steps:,} steps per size"
    )
    print(f"{'side':>6} {'area':>7} {'success':>14} {'start':>14} {'train first/last':>17}")
    for r in rows:
        start = (
            f"{r['start']['success_rate']:5.1f} ± {r['start']['success_se']:4.1f}" if "start" in r else "-"
        )
        first, last = r["train_success_first_pct"], r["train_success_last_pct"]
        train = "-" if first is None else f"{first:5.1f} / {last:5.1f}"
        print(
            f"{r['side_m']:>5g}m {r['area_m2']:>7g} {r['success_rate']:6.1f} ± {r['success_se']:4.1f} "
            f"{start:>14} {train:>17}"
        )
    slope_se = fit["slope_se_pct_per_m2"]
    print(
        f"fit: success = {fit['intercept_pct']:.1f} % "
        f"{fit['slope_pct_per_m2'] * 1000:+.2f} points per 1,000 m²"
        + ("" if slope_se is None else f" (± {slope_se * 1000:.2f})")
        + f", R² {fit['r2']:.3f}; the paper: {PAPER}"
    )
    print(
        f"against ln(area): success = {logfit['intercept_pct']:.1f} % "
        f"{logfit['slope_pct_per_ln_m2'] * math.log(2):+.2f} points per doubling of the area, "
        f"R² {logfit['r2']:.3f}"
    )
    print(f"wrote {args.out / f'{name}.json'} and {plot_path}")
    figures = {f"success_{side_name(r['side_m'])}_pct": round(r["success_rate"], 2) for r in rows}
    figures.update({f"success_se_{side_name(r['side_m'])}_pct": round(r["success_se"], 2) for r in rows})
    figures.update(
        {
            "slope_pct_per_1000_m2": round(fit["slope_pct_per_m2"] * 1000, 3),
            "intercept_pct": round(fit["intercept_pct"], 2),
            "r2": round(fit["r2"], 4),
            "points_per_area_doubling": round(logfit["slope_pct_per_ln_m2"] * math.log(2), 3),
            "r2_log_area": round(logfit["r2"], 4),
            "steps_per_size": args.steps,
            "test_episodes": args.episodes,
            "wall_s": round(time.perf_counter() - t0, 1),
        }
    )
    print(json.dumps(figures))
    return doc


if __name__ == "__main__":
    main()
