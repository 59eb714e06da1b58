"""A generalist pack over training seeds: every task of the suite and the generalisation track,
each beside the best analytic law (bvc on the variations), reported as the field expects.

    python training/generalist.py --out results/learned/generalist runs/generalist/seed*

Each RUN is one training seed's run folder of a multi-task ``wolfpack train`` (``--task all
--hp network=entities``), or of any ``wolfpack train --side wolves`` whose model plays every
task (a fine-tuning league's final pack: then there is no curve per task to draw). Each final
model is scored by ``wolfpack benchmark``'s scorecard on every task and on every variation of
the generalisation track (deterministic, the held-out episodes 500000 + k, the laws played on
the same episodes). Over the seeds: the interquartile
mean with a 95 % percentile bootstrap interval (``wolfpack.stats.iqm_interval``), per task, of the
capture rate and of the wolf collision rate, beside the best law of that task.

Writes into --out: generalist.json (every seed's scorecards and the summary), generalist.md (the
tables) and curves.png (each task's held-out capture rate during training against agent-steps:
the median over seeds, the range shaded; runs of a multi-task ``wolfpack train`` only).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np
from wolfpack.cli.args import int_at_least
from wolfpack.evaluation import HELD_OUT_SEED
from wolfpack.learn.sb3 import prepare_out
from wolfpack.scorecard import best_law, load_baselines, scorecard
from wolfpack.stats import iqm_cell, iqm_interval


def summarise(cards: list[dict], best: dict[str, tuple[str, float] | None]) -> dict:
    """Per task: the IQM over seeds of the capture and collision rates, and the best law's."""
    out = {}
    for task in cards[0]["tasks"]:
        rows = [c["tasks"][task] for c in cards if "score" in c["tasks"][task]]
        if not rows:
            out[task] = {"skipped": cards[0]["tasks"][task].get("skipped")}
            continue
        law = best.get(task)
        out[task] = {
            "captured": iqm_interval([r["score"] for r in rows]),
            "collisions": iqm_interval([r["collision_rate"] for r in rows]),
            "best_law": {"name": law[0], "captured": law[1]} if law else None,
        }
    return out


def table(title: str, summary: dict, reference: str) -> list[str]:
    lines = [f"### {title}", "", f"| task | captured, IQM [95 % CI] | wolf collisions, IQM | {reference}: captured | at or above it |", "|---|---|---|---|---|"]
    for task, s in summary.items():
        if "skipped" in s:
            lines.append(f"| `{task}` | skipped: {s['skipped']} | | | |")
            continue
        law = s["best_law"]
        verdict = "—" if law is None else ("yes" if s["captured"]["iqm"] >= law["captured"] else f"no ({100 * (s['captured']['iqm'] - law['captured']):+.1f} points)")
        law_cell = f"`{law['name']}` {100 * law['captured']:.1f} %" if law else "—"
        lines.append(f"| `{task}` | {iqm_cell(s['captured'])} | {100 * s['collisions']['iqm']:.1f} % | {law_cell} | {verdict} |")
    return lines + [""]


def curves(out: Path, runs: list[Path]) -> bool:
    """curves.png from every run's per-task held-out evaluations; False (nothing drawn) when a
    run has none (a run of one task)."""
    evals = [[e for e in json.loads((run / "evaluations.json").read_text()) if "tasks" in e] for run in runs]
    if not all(evals):
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = list(evals[0][0]["tasks"])
    fig, ax = plt.subplots(figsize=(8, 4.5), layout="constrained")
    colours = plt.get_cmap("tab10")
    for k, task in enumerate(tasks):
        series = [(np.array([e["agent_steps"] / 1e6 for e in ev]), np.array([e["tasks"][task]["wolves"]["capture_rate"] for e in ev])) for ev in evals]
        grid = np.linspace(max(s[0][0] for s in series), min(s[0][-1] for s in series), 40)
        ys = np.array([np.interp(grid, x, y) for x, y in series])
        ax.plot(grid, 100 * np.median(ys, axis=0), color=colours(k), label=task)
        if len(series) > 1:
            ax.fill_between(grid, 100 * ys.min(axis=0), 100 * ys.max(axis=0), color=colours(k), alpha=0.15)
    ax.set_xlabel("agent-steps trained (millions)")
    ax.set_ylabel("captured, % of held-out episodes")
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="best", ncol=2)
    episodes = {len(ev) and ev[0]["tasks"][tasks[0]]["wolves"]["episodes"] for ev in evals}
    spread = f"{len(runs)} training seeds: the median, the range shaded" if len(runs) > 1 else "one training seed"
    ax.set_title(f"One pack for every task: held-out capture per task during training\n({spread}; {'/'.join(map(str, sorted(episodes)))} episodes per task and point)", fontsize=10)
    fig.savefig(out / "curves.png", dpi=120)
    plt.close(fig)
    return True


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="generalist.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+", metavar="RUN", help="run folders of a multi-task wolfpack train, one per training seed")
    p.add_argument("--episodes", type=int_at_least(1), default=200, help="episodes per task and variation (default 200, the baselines' count)")
    p.add_argument("--out", required=True, help="output folder")
    args = p.parse_args(argv)
    try:
        runs = [Path(r) for r in args.runs]
        for run in runs:
            if not (run / "wolves" / "policy.pt").is_file():
                raise ValueError(f"{run}: no wolves/policy.pt (a run folder of wolfpack train --side wolves)")
        out = prepare_out(args.out)
    except ValueError as e:
        print(f"generalist.py: error: {e}", file=sys.stderr)
        return 2
    baselines = load_baselines()
    suite = [scorecard(str(run), "wolves", episodes=args.episodes, seed=HELD_OUT_SEED) for run in runs]
    track = [scorecard(str(run), "wolves", episodes=args.episodes, seed=HELD_OUT_SEED, track="generalisation") for run in runs]
    best = {task: best_law(baselines, "wolves", task) for task in suite[0]["tasks"]}
    # The track's bar is bvc's rate, the law that generalises best (docs/tasks.md).
    best_track = {name: ("bvc", row["baselines"]["bvc"]) if "bvc" in row.get("baselines", {}) else None for name, row in track[0]["tasks"].items()}
    doc = {
        "runs": [str(r) for r in runs],
        "episodes": args.episodes,
        "first_seed": HELD_OUT_SEED,
        "tasks": summarise(suite, best),
        "generalisation": summarise(track, best_track),
        "scorecards": suite,
        "generalisation_scorecards": track,
    }
    (out / "generalist.json").write_text(json.dumps(doc, indent=1) + "\n")
    n = len(runs)
    text = [
        f"# One pack for every task: {n} training seed{'s' if n > 1 else ''}",
        "",
        f"{args.episodes} deterministic held-out episodes per task (seeds {HELD_OUT_SEED}..), against each task's `escape` target; "
        "IQM over seeds with its 95 % bootstrap interval. On the tasks, the best law of the committed baselines; on the variations, bvc played live on the same episodes.",
        "",
        *table("The task suite", doc["tasks"], "best law"),
        *table("The generalisation track", doc["generalisation"], "bvc"),
    ]
    (out / "generalist.md").write_text("\n".join(text))
    if not curves(out, runs):  # runs of one task (a league's final pack, say)
        print("generalist.py: no curves.png: not every run was evaluated per task during training", file=sys.stderr)
    print("\n".join(text))
    return 0


if __name__ == "__main__":
    sys.exit(main())
