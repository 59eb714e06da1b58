"""A self-play league: wolves and targets trained against each other, alternating, each against a
pool of the other side's members drawn by prioritised fictitious self-play (the method and its
files: :mod:`wolfpack.learn.selfplay`; the package's recommended population method is
``wolfpack league``).

    python training/selfplay.py --out runs/league --generations 6 --time-limit 60
    python training/selfplay.py --out runs/league --resume --generations 8 --time-limit 30

Writes into --out (refused if it holds a league, unless --resume):
  league.json        members (name, side, kind, generation, timesteps, wall time, path),
                     generations (side, timesteps, wall time, opponents drawn and how often),
                     evaluations (every pair measured: capture rate with 95 % interval,
                     collisions, median capture step), the arguments and the scenario
  members/<name>/    policy.pt + config.yaml of every learned member (evaluate.py, opponent=
                     and wolfpack.load_policy read them)
  generations/<k>/   the trainer's run folder of generation k (progress.csv, TensorBoard,
                     evaluations.json, trainer.pt: the state the side's next generation
                     starts from)
  league.md          the league table (each member's win rate against each opposing member)
  league_curves.png  win rates of each generation's member against the fixed laws and the
                     learned opponents, and the training return of every generation
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from pathlib import Path

from wolfpack.cli.args import int_at_least, positive_number
from wolfpack.learn.recipes import ALGOS
from wolfpack.learn.selfplay import LEAGUE_FILE, SAMPLING, SelfPlayOptions, selfplay
from wolfpack.report.league import league_curves, league_table
from wolfpack.sides import SCRIPTED_LAWS, SIDES

#: The library's defaults, which the options' defaults are.
DEFAULTS = SelfPlayOptions(out="")


def laws_arg(side: str):
    allowed = SCRIPTED_LAWS["wolves"] if side == "wolves" else SCRIPTED_LAWS["targets"]

    def parse(text: str) -> list[str]:
        laws = [t for t in text.split(",") if t]
        bad = [t for t in laws if t not in allowed]
        if bad:
            raise argparse.ArgumentTypeError(f"unknown {side} law {bad[0]!r} (one of {', '.join(allowed)})")
        return laws

    return parse


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="selfplay.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="the league folder")
    p.add_argument("--resume", action="store_true", help="go on with the league in --out (its scenario and fixed members)")
    p.add_argument("--generations", type=int_at_least(1), default=DEFAULTS.generations, help=f"generations in the league in all (default {DEFAULTS.generations}; with --resume: the new total)")
    p.add_argument("--time-limit", type=positive_number, default=None, metavar="MIN", help="wall-clock minutes for this invocation, shared over the generations still to run")
    p.add_argument(
        "--timesteps", type=int_at_least(1), default=DEFAULTS.timesteps, help=f"most agent-steps per generation (default {DEFAULTS.timesteps:,}; the time limit usually ends a generation first)"
    )
    p.add_argument("--algo", choices=ALGOS, default=DEFAULTS.algo, help=f"the trainer's algorithm for both sides (default {DEFAULTS.algo}; a new league only)")
    p.add_argument("--first", choices=SIDES, default=DEFAULTS.first, help=f"the side of generation 1 (default {DEFAULTS.first})")
    p.add_argument("--pool-sampling", choices=SAMPLING, default=DEFAULTS.pool_sampling, help=f"how each rollout's opponent is drawn (default {DEFAULTS.pool_sampling})")
    p.add_argument("--fixed-wolves", type=laws_arg("wolves"), default=DEFAULTS.fixed_wolves, metavar="LAWS", help="comma-separated wolf laws in the pool (default all three)")
    p.add_argument(
        "--fixed-targets",
        type=laws_arg("targets"),
        default=DEFAULTS.fixed_targets,
        metavar="LAWS",
        help="comma-separated target laws in the pool (default escape; random and still teach wolves little)",
    )
    p.add_argument("--member", dest="members", action="append", default=[], metavar="RUN", help="an existing model (run folder) as a fixed member of its side's pool (repeatable)")
    p.add_argument("--init-wolves", default=None, metavar="RUN", help="the wolves' first learner starts from this run of wolfpack train (its trainer.pt: actor, critic, normalisers)")
    p.add_argument("--init-targets", default=None, metavar="RUN", help="the targets' first learner starts from this run of wolfpack train")
    p.add_argument("--eval-episodes", type=int_at_least(1), default=DEFAULTS.eval_episodes, help=f"held-out episodes per evaluated pair (default {DEFAULTS.eval_episodes})")
    p.add_argument("--num-envs-wolves", type=int_at_least(1), default=None, help="worlds while wolves learn (default: the recipe's)")
    p.add_argument("--num-envs-targets", type=int_at_least(1), default=None, help="worlds while targets learn (default: the recipe's)")
    p.add_argument("--params", default=None, help="params YAML of the league's scenario (default: the documented scenario)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="params override (repeatable)")
    p.add_argument("--hp", dest="hps", action="append", default=[], metavar="KEY=VALUE", help="recipe override for both sides (repeatable; keys: wolfpack/learn/recipes.yaml; a new league only)")
    p.add_argument("--seed", type=int_at_least(0), default=DEFAULTS.seed, help=f"seed of the league (training worlds, PPO, sampling; default {DEFAULTS.seed})")
    p.add_argument("--threads", type=int_at_least(1), default=None, help="the batch's threads (default: all cores; the batch and torch take turns)")
    p.add_argument("--torch-threads", type=int_at_least(1), default=None, help="torch threads (default: all cores)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    options = SelfPlayOptions(**vars(args))
    out = Path(args.out)
    command = " ".join(shlex.quote(a) for a in ["python", "training/selfplay.py", *(sys.argv[1:] if argv is None else argv)])

    def drawn(league: dict) -> None:
        (out / "league.md").write_text(league_table(league))
        league_curves(out, league)

    try:
        league = selfplay(options, command=command, log=lambda line: print(line, file=sys.stderr), on_generation=drawn)
    except ValueError as e:
        print(f"selfplay.py: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        finished = len(json.loads((out / LEAGUE_FILE).read_text())["generations"]) if (out / LEAGUE_FILE).is_file() else 0
        print(f"selfplay.py: interrupted; {LEAGUE_FILE} holds the {finished} finished generations (--resume goes on)", file=sys.stderr)
        return 130
    print(f"league: {len(league['generations'])} generations, {len(league['members'])} members; {out / LEAGUE_FILE}, {out / 'league.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
