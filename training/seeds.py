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

from wolfpack.cli.args import int_at_least
from wolfpack.evaluation import report
from wolfpack.learn.matches import opponents_of, play
from wolfpack.learn.sb3 import load_model, prepare_out
from wolfpack.report.seeds import curves, median_capture_step, skill
from wolfpack.sides import OTHER_SIDE
from wolfpack.stats import iqm_cell, iqm_interval, range_cell


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="seeds.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("runs", nargs="+", metavar="RUN", help="run folders of wolfpack train, one per training seed")
    p.add_argument("--episodes", type=int_at_least(1), default=200, help="episodes per evaluation (default 200)")
    p.add_argument("--seed", type=int_at_least(0), default=0, help="first episode seed (default 0: wolfpack hunt's episodes)")
    p.add_argument("--against", action="append", default=[], metavar="POLICY", help="also evaluate against this law, model or league (repeatable)")
    p.add_argument("--curves-by", choices=("minutes", "steps"), default="minutes", help="the curves' x axis: training wall time (default) or agent-steps (runs that shared the machine)")
    p.add_argument("--out", required=True, help="output folder")
    args = p.parse_args(argv)
    try:
        models = [load_model(r) for r in args.runs]
        sides = {m.side for m in models}
        if len(sides) != 1:
            raise ValueError(f"the runs are of different sides ({', '.join(sorted(sides))}); give one side's runs")
        side = sides.pop()
        against = opponents_of(side, args.against)
        out = prepare_out(args.out)
    except ValueError as e:
        print(f"seeds.py: error: {e}", file=sys.stderr)
        return 2
    per_opponent: dict[str, list[dict]] = {}
    for m in models:
        trained_against = m.params["policies"][OTHER_SIDE[side]]
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
