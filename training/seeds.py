"""Learned results over training seeds, reported as the field expects.

    python training/seeds.py --out results/learned/wolves_mappo runs/ls/native_wolves_mappo_s*
    python training/seeds.py --against results/models/escape_ppo --against results/league --out DIR RUN ...

Each RUN is one training seed's run folder of ``wolfpack train`` (one side learning). Every
final model is evaluated deterministically on the same episodes (``--seed S``: worlds S, S+1,
..., the episodes of ``wolfpack hunt --seed S``) against the opponent it trained with, and
against every ``--against`` policy (a law's name, a model path, or a selfplay.py league folder:
its learned members of the other side). Over the seeds: the interquartile mean (IQM, the mean of
the middle half; ``scipy.stats.trim_mean`` with 25 % cut at each end, as rliable computes it)
with a 95 % percentile bootstrap interval over seeds (``scipy.stats.bootstrap``, 10,000
resamples), the median and the range. Per seed and opponent the per-episode 95 % Wilson
interval stays in the JSON.

Writes into --out: seeds.json (every row), seeds.md (the table) and curves.png (the held-out
evaluations during training against training minutes: median over seeds with the range
shaded, capture or survival and wolf collisions; ``--curves-by steps``: against agent-steps,
for runs whose wall time another load shared).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

import numpy as np  # noqa: E402
import yaml  # noqa: E402
from common import UsageError, load_model, play, positive_int, prepare_out, report, seed_int  # noqa: E402
from evaluate import expand_models  # noqa: E402
from wolfpack.stats import iqm_interval  # noqa: E402, F401  (the scripts take it from here)

OTHER = {"wolves": "targets", "targets": "wolves"}


def iqm_cell(summary: dict) -> str:
    """``95.5 % [95.0, 96.8]``: an ``iqm_interval`` as seeds.md and RESULTS.md print it."""
    return f"{100 * summary['iqm']:.1f} % [{100 * summary['ci95'][0]:.1f}, {100 * summary['ci95'][1]:.1f}]"


def range_cell(summary: dict) -> str:
    """``95.0 % (95.0–97.0)``: the median over seeds and their range."""
    return f"{100 * summary['median']:.1f} % ({100 * summary['min']:.1f}–{100 * summary['max']:.1f})"


def median_capture_step(rows: list[dict]) -> float | None:
    """The median over seeds of each seed's median capture step (None: no seed captured)."""
    steps = [r["median_capture_steps"] for r in rows if r["median_capture_steps"] is not None]
    return float(np.median(steps)) if steps else None


def opponents_of(side: str, specs: list[str]) -> list:
    """The --against policies of the other side: laws by name, models loaded, leagues expanded."""
    from wolfpack.sides import SCRIPTED_LAWS

    out = []
    for spec in specs:
        if not Path(spec).exists():
            if spec not in SCRIPTED_LAWS[OTHER[side]]:
                raise UsageError(f"--against {spec}: not a law of the {OTHER[side]} ({', '.join(SCRIPTED_LAWS[OTHER[side]])}) nor a model or league folder")
            out.append(spec)
            continue
        for path in expand_models([spec]):
            m = load_model(path)
            if m.side == OTHER[side]:
                out.append(m)
    return out


def skill(side: str, row: dict) -> float:
    return row["capture_rate"] if side == "wolves" else row["survival_rate"]


def curves(out: Path, runs: list[Path], side: str, axis: str = "minutes", opponent: str = "") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    series = []
    for run in runs:
        evals = [e for e in json.loads((run / "evaluations.json").read_text()) if e.get("phase", "ppo") == "ppo"]
        x = [e["train_s"] / 60 for e in evals] if axis == "minutes" else [e["agent_steps"] / 1e6 for e in evals]
        series.append((np.array(x), np.array([skill(side, e[side]) for e in evals]), np.array([e[side]["collision_rate"] for e in evals])))
    grid = np.linspace(max(s[0][0] for s in series), min(s[0][-1] for s in series), 60)
    fig, ax = plt.subplots(figsize=(7, 4), layout="constrained")
    what = "captured (held-out)" if side == "wolves" else "survived (held-out)"
    for k, (label, colour) in enumerate(((what, "tab:blue"), ("wolf collisions", "tab:red"))):
        ys = np.array([np.interp(grid, t, v, left=np.nan) for t, *vals in series for v in [vals[k]]])
        ax.plot(grid, 100 * np.nanmedian(ys, axis=0), color=colour, label=f"{label}: median of {len(series)} seeds")
        ax.fill_between(grid, 100 * np.nanmin(ys, axis=0), 100 * np.nanmax(ys, axis=0), color=colour, alpha=0.2, label=f"{label}: range")
    ax.set_xlabel("training wall time (min, evaluations excluded)" if axis == "minutes" else "agent-steps trained (millions)")
    ax.set_ylabel("% of held-out episodes")
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="center right")
    against = f" against {opponent}" if opponent else ""
    algos = sorted({str((yaml.safe_load((run / "config.yaml").read_text()) or {}).get("algo", "?")).upper() for run in runs})
    ax.set_title(f"{side} ({', '.join(algos)}){against}: {len(series)} training seeds,\n{series[0][0].size} evaluations each on held-out episodes", fontsize=10)
    fig.savefig(out / "curves.png", dpi=120)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="seeds.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+", metavar="RUN", help="run folders of wolfpack train, one per training seed")
    p.add_argument("--episodes", type=positive_int, default=200, help="episodes per evaluation (default 200)")
    p.add_argument("--seed", type=seed_int, default=0, help="first episode seed (default 0: wolfpack hunt's episodes)")
    p.add_argument("--against", action="append", default=[], metavar="POLICY", help="also evaluate against this law, model or league (repeatable)")
    p.add_argument("--curves-by", choices=("minutes", "steps"), default="minutes", help="the curves' x axis: training wall time (default) or agent-steps (runs that shared the machine)")
    p.add_argument("--out", required=True, help="output folder")
    args = p.parse_args(argv)
    try:
        models = [load_model(r) for r in args.runs]
        sides = {m.side for m in models}
        if len(sides) != 1:
            raise UsageError(f"the runs are of different sides ({', '.join(sorted(sides))}); give one side's runs")
        side = sides.pop()
        against = opponents_of(side, args.against)
        out = prepare_out(args.out)
    except (UsageError, ValueError) as e:
        print(f"seeds.py: error: {e}", file=sys.stderr)
        return 2
    per_opponent: dict[str, list[dict]] = {}
    for m in models:
        trained_against = m.params["policies"][OTHER[side]]
        for opp in [trained_against, *against]:
            pair = (m, opp) if side == "wolves" else (opp, m)
            row = report(play(m.params, *pair, episodes=args.episodes, seed=args.seed), *(x if isinstance(x, str) else x.label for x in pair))
            row.pop("capture_steps")
            name = opp if isinstance(opp, str) else opp.label
            per_opponent.setdefault(name, []).append({"run": str(m.path.parent), **row})
    doc = {"side": side, "episodes": args.episodes, "first_seed": args.seed, "runs": [str(Path(r)) for r in args.runs], "opponents": {}}
    lines = [
        f"{side}, {len(models)} training seeds, {args.episodes} episodes (seeds {args.seed}–{args.seed + args.episodes - 1}) per model and opponent, deterministic",
        "",
        f"| opponent | {'capture' if side == 'wolves' else 'survival'} IQM [95 % CI] | median (range) | wolf collisions IQM [95 % CI] | median capture step |",
        "|---|---|---|---|---|",
    ]
    for name, rows in per_opponent.items():
        s = iqm_interval([skill(side, r) for r in rows])
        c = iqm_interval([r["collision_rate"] for r in rows])
        step = median_capture_step(rows)
        doc["opponents"][name] = {"skill": s, "collision_rate": c, "rows": rows}
        lines.append(f"| {name} | {iqm_cell(s)} | {range_cell(s)} | {iqm_cell(c)} | {'—' if step is None else step} |")
    (out / "seeds.json").write_text(json.dumps(doc, indent=1) + "\n")
    (out / "seeds.md").write_text("\n".join(lines) + "\n")
    curves(out, [Path(r) for r in args.runs], side, args.curves_by, opponent=next(iter(per_opponent)))
    print("\n".join(lines))
    return 0


if __name__ == "__main__":
    sys.exit(main())
