r"""The paper's scaling experiment: NavStatic success on urban-nav-2-test after the same number of
PPO steps on 1, 8, 64, 256 and 1,024 distinct training scenes, with asynchronous scene sampling
(each sub-environment its own scene) against synchronous (all sub-environments the same scene).

    python benchmarks/bench_learning.py            # the full experiment (hours: see below)
    python benchmarks/bench_learning.py --quick    # run_all.py's variant (1, 8, 64 scenes; minutes)

Each (scenes, sampling) pair is one ``citygen train`` run (the same config, seed and steps;
scenes beyond the split's 256 continue urban-nav-2-train's seed derivation) into
``--out/<sampling>-<scenes>/``, evaluated deterministically on the first ``--episodes``
scenes of urban-nav-2-test. One scene is the same run under both samplings, so it is trained
once. The paper (URBAN-SIM, section "Evaluation of Scalability") reports 5.1 % success with
1 scene and 83.2 % with 1,024, async ahead of sync from 8 scenes on; its figure gives no
other numbers, so those two points stand beside ours in the plot.

Full size: 9 runs of ``--steps`` (default 300,000) on 8 sub-environments: about 9 x 300k /
(steps/s of the machine) -- 2.5 hours at 300 steps/s. ``--quick``: 1, 8 and 64 scenes,
6,400 steps each (4 rollouts of 8 x 200), 16 test episodes: about 10 minutes on 2 idle cores;
it checks the pipeline end to end, the steps are far too few to learn. Prints a table, and
as its last line one JSON object of figures.

With ``--init`` the policy every run starts from is tested too, before any training
(``start``: a line in the plot, ``success_start_pct`` in the JSON). Each run's test result is
kept in its folder (``test-<episodes>.json``), so a sweep stopped part way goes on where it
stopped and a finished one prints its table again at once.

docs/training.md's figures come from shorter protocols than the paper's (from scratch, NavStatic
with the crossable layer had 1-2 % training success after 92,800 steps on 1,024 scenes):
every run starts from a wheeled NavClear policy, with ``--config`` giving its observation
(``keys`` and ``stack``), the rate decaying linearly and ``target_kl`` 0.03, tested on 256
episodes. From the first NavClear run (the one the shipped NavStatic baseline starts from,
``citygen train --task nav-clear --robot wheeled --steps 400000 --envs 8 --config ST --out
runs/w-clear-st``; 37.5 % at the start) success grows with the scenes (asynchronous: 21.9 %
on one, 24.6 % on 8, 47.7 % on 64, 54.7 % on 256, 47.7 % on 1,024) and asynchronous sampling
leads synchronous at 64 and 256 scenes (by 10.2 and 7.4 points); synchronous leads at 8
(40.6 %) and the two are level at 1,024 (49.2 % synchronous)::

    python benchmarks/bench_learning.py --init runs/w-clear-st --steps 300000 \
        --scenes 1,8,64,256,1024 --episodes 256 --config STS.toml \
        --plot benchmarks/plots/learning_300k_first_navclear.png

From the shipped NavClear file (``--init citygen/runner/learn/baselines/nav-clear-wheeled.npz
--config STSW.toml``: ``STS`` with ``critic_warmup = 20000``, since an npz holds no critic)
the start already succeeds in 48.8 % of the test episodes, and no run ended above it.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent
#: The paper's points: training scenes -> success rate (%), asynchronous sampling.
PAPER = {1: 5.1, 1024: 83.2}


def _ints(text: str) -> list[int]:
    return [int(x) for x in text.split(",") if x]


def _start_policy(init: Path) -> Path | None:
    """The file ``citygen bench`` tests for ``--init``: the file itself (an npz or a
    ``model.zip``), else a run folder's ``policy.npz`` or ``model.zip``; None if it has neither."""
    if init.is_file():
        return init
    return next((p for p in (init / "policy.npz", init / "model.zip") if p.exists()), None)


def train_run(out: Path, args: argparse.Namespace, **fields) -> float:
    """Train one NavStatic run into ``out`` with the options every run of a sweep shares
    (``args``: config, robot, steps, envs, seed, init) and ``fields`` (split, scenes, sampling,
    max_steps...) on top; seconds spent. A finished run (its ``policy.npz`` there) is not
    trained again, an interrupted one resumes from its last checkpoint."""
    from citygen.runner.learn.config import load_config
    from citygen.runner.learn.train import train

    cfg = load_config(
        args.config,
        task="nav-static",
        robot=args.robot,
        steps=args.steps,
        envs=args.envs,
        seed=args.seed,
        checkpoint_every=max(args.steps // 4, 1),
        **({"init": str(args.init)} if args.init is not None else {}),
        **fields,
    )
    t0 = time.perf_counter()
    resume = (out / "checkpoints").exists() and not (out / "policy.npz").exists()
    if not (out / "policy.npz").exists():
        train(cfg, out, resume=resume, progress=sys.stderr.isatty())
    return time.perf_counter() - t0


def run_one(scenes: int, sampling: str, args: argparse.Namespace) -> dict:
    out = args.out / f"{sampling}-{scenes}"
    train_s = train_run(out, args, split="urban-nav-2-train", scenes=scenes, sampling=sampling)
    result = evaluate(out / "policy.npz", out, args)
    return {**result, "scenes": scenes, "sampling": sampling, "train_s": train_s}


def evaluate(
    policy: Path,
    folder: Path,
    args: argparse.Namespace,
    split: str = "urban-nav-2-test",
    max_steps: int | None = None,
) -> dict:
    """Success (%), its standard error and route completion of ``policy`` on the first
    ``args.episodes`` scenes of ``split`` (NavStatic; episodes cut at ``max_steps``, default the
    task's horizon), kept in ``folder/test-<episodes>.json`` (the test is deterministic: a
    policy evaluated once is not evaluated again)."""
    from citygen.runner.bench import run_bench
    from citygen.runner.metrics import summarise

    cached = folder / f"test-{args.episodes}.json"
    if cached.exists() and cached.stat().st_mtime >= policy.stat().st_mtime:
        return json.loads(cached.read_text())
    t0 = time.perf_counter()
    rows = run_bench(
        "nav-static",
        str(split),
        robot=args.robot,
        policy=str(policy),
        episodes=args.episodes,
        jobs=args.jobs,
        seed=args.seed,
        **({} if max_steps is None else {"max_steps": max_steps}),
    )
    summary = summarise([{k: r[k] for k in ("success_rate", "route_completion")} for r in rows])
    result = {
        "success_rate": summary["success_rate"]["mean"],
        "success_se": summary["success_rate"]["sem"],
        "route_completion": summary["route_completion"]["mean"],
        "eval_s": time.perf_counter() - t0,
    }
    folder.mkdir(parents=True, exist_ok=True)
    cached.write_text(json.dumps(result))
    return result


def plot(
    results: list[dict],
    path: Path,
    steps: int,
    init: Path | None = None,
    start: float | None = None,
    imitation: str = "",
) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6.5, 4), dpi=110)
    for sampling, colour in (("async", "tab:green"), ("sync", "tab:orange")):
        pts = sorted(
            (r["scenes"], r["success_rate"], r.get("success_se", 0.0))
            for r in results
            if r["sampling"] == sampling
        )
        if pts:
            x, y, se = zip(*pts, strict=True)
            ax.errorbar(
                x, y, yerr=se, fmt="o-", color=colour, capsize=3, label=f"citygen, {sampling} sampling"
            )
    ax.plot(list(PAPER), list(PAPER.values()), "k*", markersize=12, label="URBAN-SIM paper (async)")
    if start is not None:
        ax.axhline(start, color="grey", linestyle="--", linewidth=1, label=f"start: {init.name}, untrained")
    ax.set_xscale("log", base=2)
    ax.set_xlabel("distinct training scenes")
    ax.set_ylabel("NavStatic success on urban-nav-2-test (%)")
    ax.set_ylim(0, 100)
    start = "from scratch" if init is None else f"from {init.name}"
    ax.set_title(f"{imitation}PPO, {steps:,} steps per run {start}, wheeled robot")
    ax.legend(loc="upper left")
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path)
    plt.close(fig)


def _imitation(config: Path | None) -> str:
    """The plot title's words for runs that imitate an expert first (``expert`` in the config)."""
    if config is None:
        return ""
    from citygen.runner.learn.config import load_config

    cfg = load_config(config, task="nav-static")
    if cfg.expert is None:
        return ""
    return f"DAgger from the {cfg.expert} ({cfg.dagger_iterations} x {cfg.dagger_episodes} episodes), then\n"


def _samplings(text: str) -> list[str]:
    """``--sampling``: ``async``, ``sync``, ``both`` or a comma-separated list of them."""
    names = [s.strip() for s in text.split(",") if s.strip()]
    unknown = [s for s in names if s not in ("async", "sync", "both")]
    if unknown or not names:
        raise argparse.ArgumentTypeError(f"expected async, sync or both, got {text!r}")
    return ["async", "sync"] if "both" in names else list(dict.fromkeys(names))


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--quick", action="store_true", help="1, 8, 64 scenes, 6,400 steps, 16 episodes")
    p.add_argument("--scenes", type=_ints, default=None, help="comma-separated scene counts")
    p.add_argument(
        "--sampling", type=_samplings, default="async,sync", help="async, sync or both (comma-separated)"
    )
    p.add_argument("--steps", type=int, default=None, help="PPO steps per run (default 300,000)")
    p.add_argument("--envs", type=int, default=8, help="sub-environments")
    p.add_argument("--episodes", type=int, default=None, help="test episodes (default 256)")
    p.add_argument("--jobs", type=int, default=None, help="evaluation processes (default: every core)")
    p.add_argument("--robot", default="wheeled")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--config", type=Path, default=None, help="a TrainConfig file (TOML/JSON) for every run")
    p.add_argument(
        "--init",
        type=Path,
        default=None,
        help="start every run from this run folder's weights and statistics (a curriculum, e.g. the "
        "NavClear run behind the shipped baseline; the paper trains from scratch)",
    )
    p.add_argument(
        "--out",
        type=Path,
        default=HERE / "logs" / "learning",
        help="run folders (reused: a finished run is evaluated again, an interrupted one resumed)",
    )
    p.add_argument(
        "--plot",
        type=Path,
        default=None,
        help="the plot's file (default benchmarks/plots/learning.png, learning_quick.png with --quick)",
    )
    args = p.parse_args()
    args.scenes = args.scenes or ([1, 8, 64] if args.quick else [1, 8, 64, 256, 1024])
    args.steps = args.steps or (6_400 if args.quick else 300_000)
    args.episodes = args.episodes or (16 if args.quick else 256)
    samplings = args.sampling
    if args.quick and args.out == HERE / "logs" / "learning":
        args.out = HERE / "logs" / "learning-quick"

    t0 = time.perf_counter()
    start = None
    if args.init is not None:
        # Where every run starts: the policy itself, before any NavStatic training.
        policy = _start_policy(args.init)
        if policy is not None:
            start = evaluate(policy, args.out / "start", args)
            print(
                f"start: success {start['success_rate']:5.1f} ± {start['success_se']:.1f} %, route "
                f"completion {start['route_completion']:5.1f} % ({policy}, before any training)",
                flush=True,
            )
    results = []
    for scenes in args.scenes:
        for sampling in samplings:
            if sampling == "sync" and scenes == 1 and "async" in samplings:
                continue  # one scene: both samplings are the same run
            results.append(run_one(scenes, sampling, args))
            r = results[-1]
            print(
                f"{sampling:>5} {scenes:>5} scenes: success {r['success_rate']:5.1f} "
                f"± {r['success_se']:.1f} %, "
                f"route completion {r['route_completion']:5.1f} % ({r['train_s']:.0f} s training)",
                flush=True,
            )
    one = next((r for r in results if r["scenes"] == 1), None)
    if one is not None and "sync" in samplings and "async" in samplings:
        results.append({**one, "sampling": "sync"})
    plot(
        results,
        args.plot or HERE / "plots" / ("learning_quick.png" if args.quick else "learning.png"),
        args.steps,
        args.init,
        None if start is None else start["success_rate"],
        _imitation(args.config),
    )

    print()
    print(
        f"NavStatic success (%) on urban-nav-2-test ({args.episodes} episodes) after {args.steps:,} PPO steps"
    )
    print(f"{'scenes':>7} {'async':>7} {'sync':>7} {'paper':>7}")
    by = {(r["scenes"], r["sampling"]): r["success_rate"] for r in results}
    for scenes in args.scenes:
        cells = [by.get((scenes, s)) for s in ("async", "sync")]
        paper = PAPER.get(scenes)
        print(
            f"{scenes:>7} "
            + " ".join("      -" if c is None else f"{c:7.1f}" for c in cells)
            + ("       -" if paper is None else f" {paper:7.1f}")
        )
    if start is not None:
        print(f"{'start':>7} {start['success_rate']:7.1f} (the --init policy before any training)")
    figures = {
        f"success_{r['sampling']}_{r['scenes']}_scenes_pct": round(r["success_rate"], 2) for r in results
    }
    if start is not None:
        figures["success_start_pct"] = round(start["success_rate"], 2)
    figures.update(
        {
            "steps_per_run": args.steps,
            "test_episodes": args.episodes,
            "wall_s": round(time.perf_counter() - t0, 1),
        }
    )
    print(json.dumps(figures))


if __name__ == "__main__":
    main()
