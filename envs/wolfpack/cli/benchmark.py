"""``wolfpack benchmark``: a policy's scorecard over every task."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path
from typing import Sequence

from wolfpack import config, scorecard
from wolfpack._checks import MAX_THREADS
from wolfpack.cli.args import folder, int_at_least
from wolfpack.evaluation import HELD_OUT_SEED
from wolfpack.generalisation import VARIATION_ORDER, check_variation
from wolfpack.outputs import Outputs
from wolfpack.task import TASK_ORDER, check_task

BENCHMARK_DESCRIPTION = """\
Score one policy on every task of the benchmark suite (docs/tasks.md) and rank it against the
committed baselines (the analytic laws, on the same episodes).

--wolves POLICY plays the wolves against each task's scripted targets (score: captured);
--targets POLICY plays the targets against each task's scripted wolves (score: survived).
POLICY is a law's name (seed000, bvc, formation / escape, random, still) or a saved model (a
'wolfpack train' run or model folder, or an SB3 model .zip), run deterministically. Each task
plays the same held-out episodes (seeds 500000 + k, never met in training), reported with 95 %
Wilson intervals. A model built for another observation size than a task's (another agent
count, another observation layout) skips that task, saying why; one that fits no task is an
error. From Python, wolfpack.scorecard.scorecard() also takes a callable obs [n, D] -> actions [n, 2].

--set KEY=VALUE (repeatable) changes every task: a key outside env.*, rewards.* and policies.*
makes them modified tasks, which the scorecard's header says; a scorecard with --set is not
ranked (the baselines played the tasks as they are).

Without --out the scorecard is printed as a Markdown table; with --out DIR (a new or empty
folder) DIR gets scorecard.json (every task's report, the ranks and the baselines compared
with), scorecard.md and scorecard.png. --force replaces an earlier scorecard there (only the
files 'wolfpack benchmark' wrote, listed in DIR/.wolfpack-outputs.json; a DIR holding other
files is refused).

--exploit DIR adds the policy's exploitability (a finished 'wolfpack exploit' run of the same
policy: the best responses' survival against wolves, their capture rate against targets, at
each budget) to scorecard.json and scorecard.md."""

BENCHMARK_EPILOG = """\
examples:
  wolfpack benchmark --wolves bvc
  wolfpack benchmark --wolves results/learned/generalist/seed0 --track generalisation --episodes 100
  wolfpack benchmark --wolves runs/wolves --out runs/wolves/scorecard
  wolfpack benchmark --wolves bvc --exploit runs/exploit-bvc
  wolfpack benchmark --targets results/models/escape_ppo --tasks hunt-v1 fast-target-v1 --episodes 100"""


def add_parser(sub) -> argparse.ArgumentParser:
    """Registers ``benchmark`` on the ``wolfpack`` command's subparsers."""

    p = sub.add_parser(
        "benchmark",
        help="score a policy on every task of the benchmark suite against the baselines",
        description=BENCHMARK_DESCRIPTION,
        epilog=BENCHMARK_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    who = p.add_mutually_exclusive_group(required=True)
    who.add_argument("--wolves", metavar="POLICY", help="the policy plays the wolves: a wolf law or a saved wolf model")
    who.add_argument("--targets", metavar="POLICY", help="the policy plays the targets: a target law or a saved target model")
    p.add_argument(
        "--track",
        choices=("tasks", "generalisation"),
        default="tasks",
        help="tasks: the task suite (default); generalisation: variations of hunt-v1 no task file holds (other team sizes, target counts, obstacle counts, arena, target speeds), beside the laws played on the same episodes",
    )
    p.add_argument("--tasks", metavar="NAME", nargs="+", default=None, help=f"only these tasks (default: every task: {', '.join(TASK_ORDER)}; with --track generalisation, its variations)")
    p.add_argument("--episodes", metavar="K", type=int_at_least(1), default=200, help="episodes per task (default: 200, the baselines' count: ranks need it)")
    p.add_argument("--seed", metavar="S", type=int_at_least(0), default=None, help="first episode seed (default: 500000, the held-out episodes: ranks need it)")
    p.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        dest="overrides",
        help="override a parameter of every task by its dotted key (value read as YAML); repeatable; the scorecard is then not ranked",
    )
    p.add_argument(
        "--exploit",
        metavar="DIR",
        default=None,
        help="add the policy's exploitability to the scorecard: DIR is a finished 'wolfpack exploit' run of the same policy (its exploit.json; 'wolfpack exploit --help')",
    )
    p.add_argument("--threads", metavar="T", type=int_at_least(1, MAX_THREADS), default=None, help="worker threads (default: all cores); results do not depend on it")
    p.add_argument("--out", metavar="DIR", type=folder, default=None, help="write scorecard.json, scorecard.md and scorecard.png into DIR (new or empty, or --force)")
    p.add_argument("--force", action="store_true", help="with --out DIR holding an earlier scorecard: replace its files once the new one is written (a DIR holding other files is refused)")
    p.add_argument("--json", action="store_true", help="print the scorecard as one JSON object instead of the table")
    p.set_defaults(func=cmd_benchmark)
    return p


def cmd_benchmark(args: argparse.Namespace, argv: Sequence[str]) -> None:
    from tqdm import tqdm

    side = "wolves" if args.wolves is not None else "targets"
    policy = args.wolves if side == "wolves" else args.targets
    seed = HELD_OUT_SEED if args.seed is None else args.seed
    if args.track == "generalisation":
        tasks = [check_variation(t) for t in args.tasks] if args.tasks else list(VARIATION_ORDER)
    else:
        tasks = [check_task(t) for t in args.tasks] if args.tasks else list(TASK_ORDER)
    out = Path(args.out) if args.out is not None else None
    # Checked before any episode; nothing is written until the scorecard is complete.
    outputs = Outputs(out, "wolfpack benchmark", args.force) if out is not None else None
    # A bad key or value fails in scorecard(), before any episode and before anything is written.
    overrides = dict(config.parse_override(text) for text in args.overrides)
    driver = scorecard.as_policy(policy, side)  # a bad policy fails here, before any episode
    exploited = scorecard.exploitability_entry(args.exploit, driver, side) if args.exploit is not None else None
    # The generalisation track plays the side's laws too, on the same episodes.
    players = 1 + (len(scorecard.track_rivals(driver, side)) if args.track == "generalisation" else 0)
    with tqdm(total=args.episodes * len(tasks) * players, unit="ep", file=sys.stderr, disable=not sys.stderr.isatty(), leave=False, desc=f"{driver.name} on {len(tasks)} tasks") as bar:
        card = scorecard.scorecard(driver, side, tasks=tasks, episodes=args.episodes, seed=seed, threads=args.threads, progress=bar.update, overrides=overrides, track=args.track)
    if exploited is not None:
        card["exploitability"] = exploited
    card["command"] = " ".join(shlex.quote(a) for a in ["wolfpack", *argv])
    if outputs is not None:
        try:
            paths = [out / p.name for p in scorecard.write(card, outputs.start())]
            outputs.commit(last="scorecard.json")
        finally:
            outputs.discard()
    if args.json:
        print(json.dumps(card))
    else:
        print(scorecard.markdown(card))
        if out is not None:
            print(f"wrote {', '.join(str(p) for p in paths)}")
