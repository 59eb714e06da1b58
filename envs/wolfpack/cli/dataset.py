"""``wolfpack dataset``: offline datasets of expert play."""

from __future__ import annotations

import argparse
import json
import shlex
import sys
from typing import Sequence

from wolfpack import dataset
from wolfpack._checks import MAX_THREADS
from wolfpack.cli.args import folder, int_at_least
from wolfpack.sides import SIDES
from wolfpack.task import TASK_ORDER

DATASET_DESCRIPTION = """\
Record a policy's play on a task as an offline dataset (docs/tasks.md, "Datasets").

--policy is a law (seed000, bvc, formation / escape, random, still) or a saved model (a
'wolfpack train' run or model folder, an SB3 model .zip; run deterministically); the side it
plays is the law's or the model's (--side for a model that does not say). The other side
follows the task's scripted law. Episode k is world S + k's first episode (--seed S), the
episodes of 'wolfpack hunt --seed S'.

A target policy on a task with one target is written in Minari's format (Farama's offline-RL
standard; needs the [dataset] extra, Python >= 3.11): the dataset wolfpack/<task>/<policy>-v0
under DIR; read it with MINARI_DATASETS_PATH=DIR and minari.load_dataset(ID). Anything else
(wolves; two targets; or --format npz) is written as the whole multi-agent trajectories in
DIR/trajectories.npz (read with wolfpack.dataset.load_npz). Either way DIR/dataset.json says
what is there (written last). The dataset is written into a staging folder inside DIR and moved
in only once it is complete. An occupied DIR is refused unless --force, which replaces an
earlier dataset there: only the files 'wolfpack dataset' wrote (listed in
DIR/.wolfpack-outputs.json); a DIR holding other files is refused."""

DATASET_EPILOG = """\
examples:
  wolfpack dataset --task hunt-v1 --policy escape --episodes 1000 --out data/escape
  wolfpack dataset --task fast-target-v1 --policy bvc --episodes 200 --out data/bvc-fast
  wolfpack dataset --task hunt-v1 --policy runs/wolves --episodes 500 --out data/learned"""


def add_parser(sub) -> argparse.ArgumentParser:
    """Registers ``dataset`` on the ``wolfpack`` command's subparsers."""

    p = sub.add_parser(
        "dataset",
        help="record a law's or a model's play on a task as an offline dataset (Minari or npz)",
        description=DATASET_DESCRIPTION,
        epilog=DATASET_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--task", required=True, metavar="NAME", choices=TASK_ORDER, help=f"the task: {', '.join(TASK_ORDER)}")
    p.add_argument("--policy", required=True, metavar="LAW_OR_MODEL", help="a law's name or a saved model")
    p.add_argument("--side", choices=SIDES, default=None, help="the side the policy plays (default: the law's or the model's)")
    p.add_argument("--episodes", required=True, metavar="N", type=int_at_least(1, 1_000_000), help="episodes to record")
    p.add_argument("--seed", metavar="S", type=int_at_least(0), default=0, help="episode k is world S + k (default 0)")
    p.add_argument("--format", dest="fmt", choices=("auto", "minari", "npz"), default="auto", help="auto (default): Minari for a target on a one-target task, else npz")
    p.add_argument("--threads", metavar="T", type=int_at_least(1, MAX_THREADS), default=None, help="worker threads (default: all cores); results do not depend on it")
    p.add_argument("--out", required=True, metavar="DIR", type=folder, help="a new or empty folder (or --force)")
    p.add_argument(
        "--force",
        action="store_true",
        help="replace an earlier dataset in DIR once the new one is complete (a failed run leaves the old one; a DIR holding files 'wolfpack dataset' did not write is refused)",
    )
    p.add_argument("--json", action="store_true", help="print dataset.json's content as one JSON object")
    p.set_defaults(func=cmd_dataset)
    return p


def cmd_dataset(args: argparse.Namespace, argv: Sequence[str]) -> None:
    from tqdm import tqdm

    command = " ".join(shlex.quote(a) for a in ["wolfpack", *argv])
    most = dataset.upper_bound_bytes(args.task, args.episodes)
    if most > 1e9:
        print(f"wolfpack: note: {args.episodes:,} episodes of {args.task} take up to {most / 1e9:.1f} GB (all of it in memory while recording; episodes that end sooner take less)", file=sys.stderr)
    with tqdm(total=args.episodes, unit="ep", file=sys.stderr, disable=not sys.stderr.isatty(), leave=False, desc=f"{args.policy} on {args.task}") as bar:
        meta = dataset.make(
            args.task, args.policy, args.out, side=args.side, episodes=args.episodes, seed=args.seed, fmt=args.fmt, threads=args.threads, command=command, progress=bar.update, force=args.force
        )
    if args.json:
        print(json.dumps(meta))
        return
    where = f"Minari dataset {meta['minari_id']} under {args.out} (MINARI_DATASETS_PATH={args.out})" if meta["format"] == "minari" else f"{args.out}/trajectories.npz"
    outcomes = ", ".join(f"{n} {c}" for n, c in meta["outcomes"].items())
    print(
        f"{meta['episodes']} episodes ({meta['steps']:,} steps; {outcomes}) of {meta['policy']} as the {meta['side']} on {meta['task']}: "
        f"{where}, {meta['bytes'] / 1e6:.1f} MB; collected in {meta['collect_s']:.1f} s, written in {meta['write_s']:.1f} s"
    )
