"""``wolfpack league``: population training of both sides (the
work is :mod:`wolfpack.learn.league`)."""

from __future__ import annotations

import argparse
import json
import sys
from typing import Sequence

from wolfpack.cli.args import folder, int_at_least
from wolfpack.learn.league import league
from wolfpack.learn.meta import META_SOLVERS
from wolfpack.report.psro import markdown
from wolfpack.sides import SIDES
from wolfpack.task import TASK_ORDER

LEAGUE_DESCRIPTION = """\
Trains wolves and targets against each other as two growing populations (PSRO with a Nash
meta-solver). Each iteration plays every wolf member against every target member on the
meta-game's episodes (seeds 700000 + k), solves the empirical zero-sum game for each side's
Nash mixture (a linear program), trains one best response per side against the other side's
mixture ('wolfpack train --opponent …', --budget agent-steps each; from scratch, or with
--fine-tune [SIDE] from the side's newest saved model), adds both to the populations, and logs
each mixture's exploitability: what the other side's new best response achieves against it.
After the last iteration one final policy per side is trained against the other side's final
mixture: the league's product.

The populations start from --wolves / --targets (laws or saved models; default: each side's law
of the task). --meta-solver uniform weighs every member alike instead (fictitious play: what the
Nash mixture is measured against). --jobs 2 trains both sides' runs of a step at once, on half the cores each.

Writes into --out DIR (a new or empty folder): plan.json first; iter<k>/<side>/ and final/<side>/
(each a 'wolfpack train' run folder; the model is its <side>/ folder: final/wolves/wolves is the
final pack); payoffs.json (every pairing measured), progress.json after each iteration, logs/,
and last league.json (the plan, history: per iteration the mixtures, the game's value, each
mixture's exploitability and NashConv, the best responses; final: the final mixtures and
policies; the payoff matrix). A folder without league.json is unfinished: --resume continues
it where it stopped and ends as an uninterrupted league would. The defaults (5 iterations of
2 M agent-steps per side) take about an hour on 2 cores."""

LEAGUE_EPILOG = """\
examples:
  wolfpack league --out runs/league
  wolfpack league --out runs/league --iterations 8 --budget 4000000 --wolves bvc seed000 --targets escape
  wolfpack league --out runs/tuned --wolves results/learned/generalist/imitation-seed2 --fine-tune wolves --iterations 3
  wolfpack league --out runs/league --resume"""


def add_parser(sub) -> argparse.ArgumentParser:
    """Registers ``league`` on the ``wolfpack`` command's subparsers."""

    p = sub.add_parser(
        "league",
        help="population training of both sides (PSRO, Nash meta-solver), exploitability logged every iteration",
        description=LEAGUE_DESCRIPTION,
        epilog=LEAGUE_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--out", metavar="DIR", type=folder, required=True, help="the league's folder (new or empty, or with --resume an unfinished league)")
    p.add_argument("--iterations", metavar="N", type=int_at_least(1), default=5, help="iterations: a best response per side each (default 5)")
    p.add_argument("--budget", metavar="N", type=int_at_least(1), default=2_000_000, help="agent-steps of each training run (default 2000000)")
    p.add_argument("--task", choices=TASK_ORDER, default="hunt-v1", help="the task played (default hunt-v1)")
    p.add_argument("--episodes", metavar="K", type=int_at_least(1), default=100, help="episodes per pairing of the payoff matrix, and of each run's evaluations (default 100)")
    p.add_argument("--seed", metavar="S", type=int_at_least(0), default=0, help="seed of the league: each run's is 1000*S + its iteration (default 0)")
    p.add_argument("--wolves", metavar="POLICY", nargs="+", default=None, help="the wolves' first members: laws or saved wolf models (default: the task's wolf law)")
    p.add_argument("--targets", metavar="POLICY", nargs="+", default=None, help="the targets' first members: laws or saved target models (default: the task's target law)")
    p.add_argument("--jobs", metavar="J", type=int_at_least(1, 2), default=1, help="1, or 2: both sides' runs of a step at once (default 1)")
    p.add_argument(
        "--cluster",
        metavar="RAY",
        default=None,
        help="train the runs as Ray tasks (the [rllib] extra's ray): 'local' (a Ray started on this machine for the job), 'auto' (the cluster this machine joined with 'ray start') or a Ray address; on a cluster every node must see --out at the same path and have wolfpack installed (default: child processes here)",
    )
    p.add_argument(
        "--fine-tune",
        nargs="?",
        const="both",
        default=False,
        choices=("both", *SIDES),
        metavar="SIDE",
        help="each run of SIDE (both, wolves or targets; alone: both) starts from the side's newest saved model (wolfpack train --init) instead of from scratch: e.g. --wolves <a trained pack> --fine-tune wolves improves that pack against best responses trained afresh every iteration",
    )
    p.add_argument(
        "--meta-solver",
        choices=META_SOLVERS,
        default="nash",
        help="the mixture each best response trains against: nash (the minimax mixture of the empirical game) or uniform (every member alike: fictitious play) (default nash)",
    )
    p.add_argument("--resume", action="store_true", help="continue the unfinished league in --out")
    p.add_argument("--json", action="store_true", help="print league.json on stdout instead of the table")
    p.set_defaults(func=cmd_league)
    return p


def cmd_league(args: argparse.Namespace, argv: Sequence[str]) -> None:
    from tqdm import tqdm

    with tqdm(total=args.iterations, unit="iteration", file=sys.stderr, disable=not sys.stderr.isatty(), desc="league") as bar:

        def done(record: dict) -> None:
            ex = record["exploitability"]
            bar.set_postfix_str(f"exploitability: wolves {100 * ex['wolves']:.1f} %, targets {100 * ex['targets']:.1f} %")
            bar.update()

        doc = league(
            args.out,
            iterations=args.iterations,
            budget=args.budget,
            task=args.task,
            episodes=args.episodes,
            seed=args.seed,
            wolves=args.wolves,
            targets=args.targets,
            jobs=args.jobs,
            cluster=args.cluster,
            fine_tune=args.fine_tune,
            meta_solver=args.meta_solver,
            resume=args.resume,
            progress=done,
        )
    if args.json:
        print(json.dumps(doc))
        return
    print(markdown(doc))
    print(f"wrote {args.out}/league.json; the final policies: {args.out}/final/wolves/wolves and {args.out}/final/targets/targets")
