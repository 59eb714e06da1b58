"""``wolfpack view``: runs, episodes or policies as one self-contained HTML page."""

from __future__ import annotations

import argparse
import sys
from collections import defaultdict
from pathlib import Path
from typing import Sequence

from wolfpack import _core, config
from wolfpack._checks import MAX_THREADS, check_seed
from wolfpack.cli.args import PROG, folder, int_at_least
from wolfpack.opponents import Opponent
from wolfpack.scorecard import as_policy
from wolfpack.task import TASK_ORDER, task_params
from wolfpack.viewer import tables as pages
from wolfpack.viewer.encode import encode_episode
from wolfpack.viewer.page import is_page, page_data, write_page
from wolfpack.viewer.play import pairing_params, play
from wolfpack.viewer.sources import collect, scenario_key

VIEW_DESCRIPTION = """\
Write one self-contained HTML page that plays hunts in the browser: the data, the script and
the styles are inside the file (no server, no network; it opens offline from disk or as a CI
artefact). The page draws the arena, the obstacles (static and moving circles, rotating and
drifting polygons), wolves and targets with their headings and trails, sensing radii, the
capture ring, collisions and bvc's hunting points; it plays, pauses, steps, scrubs along a
timeline of the outcome's events (first sighting, cornered, capture, collision), zooms and
pans; clicking an agent shows its state at that step and its lidar rays. Keys: Space play/pause, Left/Right step (Shift: 10), Home/End, + - 0
zoom, [ ] previous/next episode, < > speed.

Five ways:
  wolfpack view RUN_OR_NPZ... --out FILE.html
      the episodes of run folders of 'wolfpack hunt --out' (their episode_NNN/trajectory.npz;
      the first --episodes K of each), episode folders or trajectory.npz files, as a list
  wolfpack view RUN_A RUN_B ... --compare --out FILE.html
      recorded runs side by side, episode by episode (matched by seed: the same start played by
      other policies); they must be of the same scenario
  wolfpack view --compare POLICY POLICY ... [--task T | --params P] [--set K=V] --out FILE.html
      plays each POLICY as the wolves (a law: seed000, bvc, formation; or a saved model: a
      'wolfpack train' run or model folder, an SB3 .zip) on the same --episodes K episodes
      (world seeds --seed S + k, the starts 'wolfpack hunt --seed S' plays), side by side,
      scrubbing together
  wolfpack view --matrix MATRIX.json --out FILE.html
      the cross-play matrix of 'training/evaluate.py --matrix' (its matrix.json, or the folder)
      as a table of capture rates whose cells open an example episode of that pairing, played
      again on the matrix's first seed
  wolfpack view --scorecard SCORECARD.json [--policy POLICY] --out FILE.html
      a scorecard of 'wolfpack benchmark --out' as a table whose rows open an example episode
      of the policy on that task (its first seed); --policy names the model a scorecard of a
      model was made with (a law's is played by name)

Positions are stored to 1 mm and angles to 0.001 rad (a 300-step episode of the documented
scenario takes about 50 KB). Clicking an agent lists its state at that step, with the mode its
law was in. The page's script interface, window.wolfpack.state(step), gives {step, wolves:
[[x, y, heading], ...], targets: [...], wolf_modes: [...], target_modes: [...]} in metres and
radians.

FILE.html must not exist, unless --force, which replaces only a page 'wolfpack view' wrote.
Bad input (a folder with no trajectories, a truncated or foreign npz, runs of different
scenarios to compare, FILE.html present without --force) exits with status 2 and one line
naming the problem; nothing is written."""

VIEW_EPILOG = """\
examples:
  wolfpack hunt --episodes 10 --out runs/demo       # also writes runs/demo/index.html
  wolfpack view runs/demo --out demo.html
  wolfpack view runs/demo/episode_003/trajectory.npz --out ep3.html
  wolfpack view runs/bvc runs/seed000 --compare --out laws.html
  wolfpack view --compare bvc results/learned/wolves_mappo/native_wolves_mappo_s0 --episodes 5 --out cmp.html
  wolfpack view --matrix results/matrix/matrix.json --out matrix.html
  wolfpack benchmark --wolves bvc --out runs/card && wolfpack view --scorecard runs/card --out card.html"""

#: Episodes that --compare plays without --episodes.
COMPARE_EPISODES = 5
#: Past this many episodes in one page, say so (the page grows by ~50 KB an episode).
LARGE_PAGE_EPISODES = 100


def add_parser(sub) -> argparse.ArgumentParser:
    """Registers ``view`` on the ``wolfpack`` command's subparsers."""

    p = sub.add_parser(
        "view", help="write a self-contained HTML page that plays hunts in the browser", description=VIEW_DESCRIPTION, epilog=VIEW_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    p.add_argument("inputs", metavar="RUN_OR_NPZ", nargs="*", help="run folders of 'wolfpack hunt --out', episode folders or trajectory.npz files")
    p.add_argument("--out", metavar="FILE.html", type=folder, required=True, help="the page to write (a new file, unless --force)")
    p.add_argument("--force", action="store_true", help="replace FILE.html if it is a page 'wolfpack view' wrote (any other file is refused)")
    p.add_argument(
        "--compare", metavar="POLICY", nargs="*", default=None, help="with policies: play them on the same episodes, side by side; with none: lay the given runs side by side, episode by episode"
    )
    p.add_argument(
        "--episodes", metavar="K", type=int_at_least(1), default=None, help=f"the first K episodes of each run (default: all), or K episodes played by --compare (default: {COMPARE_EPISODES})"
    )
    p.add_argument("--title", metavar="TEXT", default=None, help="the page's title")
    tables = p.add_argument_group("pages of tables whose cells open episodes")
    tables.add_argument("--matrix", metavar="MATRIX.json", help="a cross-play matrix (training/evaluate.py --matrix --out DIR: DIR/matrix.json, or DIR)")
    tables.add_argument("--scorecard", metavar="SCORECARD.json", help="a scorecard (wolfpack benchmark --out DIR: DIR/scorecard.json, or DIR)")
    tables.add_argument("--policy", metavar="POLICY", help="with --scorecard: the model it scored (default: the scorecard's law)")
    played = p.add_argument_group("the scenario --compare POLICY plays (as 'wolfpack hunt' takes it)")
    scenario = played.add_mutually_exclusive_group()
    scenario.add_argument("--params", metavar="P", help="scenario YAML (default: the packaged params.yaml)")
    scenario.add_argument("--task", metavar="NAME", choices=TASK_ORDER, help=f"a task of the benchmark suite: {', '.join(TASK_ORDER)}")
    played.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], dest="overrides", help="override a parameter by its dotted key; repeatable")
    played.add_argument("--targets", metavar="LAW", help="the targets' law (sets policies.targets)")
    played.add_argument("--seed", metavar="S", type=int_at_least(0), default=0, help="episode k is world seed S + k (default: 0)")
    played.add_argument("--threads", metavar="T", type=int_at_least(1, MAX_THREADS), default=None, help="worker threads")
    p.set_defaults(func=cmd_view)
    return p


def check_out(out: Path, force: bool) -> None:
    """Refuses an output path that is a folder, or that exists without ``force``, or that is a
    file ``wolfpack view`` did not write (``--force`` replaces only its own pages)."""

    if out.is_dir():
        raise ValueError(f"--out {out}: is a folder; name the page to write (FILE.html)")
    if out.exists() or out.is_symlink():
        if not force:
            raise ValueError(f"--out {out}: exists; choose another name, or add --force to replace it (a page 'wolfpack view' wrote)")
        if not is_page(out):
            raise ValueError(f"--out {out}: not a page 'wolfpack view' wrote; --force replaces only those: choose another name")


def _name(path: str) -> str:
    return Path(path).name or str(path)


def recorded_side_by_side(inputs: Sequence[str], episodes: int | None) -> tuple[list[dict], list[dict], list[str]]:
    """Runs laid side by side: one pane per input, one item per seed they all hold; a
    ValueError when two inputs hold the same seed from different scenarios or share no seed."""

    if len(inputs) < 2:
        raise ValueError("--compare without policies lays runs side by side: name two or more runs (or give --compare the policies to play)")
    by_input = []
    for where in inputs:
        seeds: dict[int, object] = {}
        for rec in collect([where], episodes):
            seeds.setdefault(int(rec.arrays["seed"]) if "seed" in rec.arrays else len(seeds), rec)
        by_input.append(seeds)
    common = [s for s in by_input[0] if all(s in other for other in by_input[1:])]
    if not common:
        raise ValueError(f"{', '.join(inputs)}: no episode seed in common, so no episode to compare (record them with the same 'wolfpack hunt --seed')")
    encoded: list[dict] = []
    items = []
    for seed in common:
        recs = [seeds[seed] for seeds in by_input]
        key = scenario_key(recs[0].arrays)
        for rec in recs[1:]:
            if scenario_key(rec.arrays) != key:
                raise ValueError(f"{recs[0].path} and {rec.path}: episodes of different scenarios (seed {seed} starts differently: arena, agents or obstacles); only runs of the same scenario compare")
        items.append({"label": f"seed {seed}", "episodes": list(range(len(encoded), len(encoded) + len(recs)))})
        encoded += [encode_episode(rec.arrays, rec.params, rec.label) for rec in recs]
    names = [_name(w) for w in inputs]
    if len(set(names)) < len(names):  # runs/a/run and runs/b/run: the whole paths tell them apart
        names = [str(w) for w in inputs]
    return encoded, items, names


def played_side_by_side(args) -> tuple[list[dict], list[dict], list[str], str]:
    """The policies of ``--compare`` played on the same episodes."""

    overrides = dict(config.parse_override(text) for text in args.overrides)
    if args.targets:
        overrides["policies.targets"] = args.targets
    params = task_params(args.task, overrides) if args.task else config.load_params(args.params, overrides)
    resolved = _core.validate_params(params, resolve=True)
    count = args.episodes or COMPARE_EPISODES
    check_seed(args.seed, "--seed", span=count)
    drivers: list[Opponent] = [as_policy(spec, "wolves") for spec in args.compare]
    names = [d.name for d in drivers]
    plays = [play(d, params, count, args.seed, args.threads) for d in drivers]
    encoded, items = [], []
    for k in range(count):
        items.append({"label": f"seed {args.seed + k}", "episodes": list(range(len(encoded), len(encoded) + len(plays)))})
        for name, d, p in zip(names, drivers, plays):
            shown, who = pairing_params(d, None, params)
            encoded.append(encode_episode(p[k], shown, f"{name}, seed {args.seed + k}", who))
    where = f"task {args.task}" if args.task else (args.params or "the documented scenario")
    return encoded, items, names, f"{', '.join(names)} as the wolves vs {resolved['policies']['targets']} targets, {where}, seeds {args.seed}..{args.seed + count - 1}"


def cmd_view(args: argparse.Namespace, argv: Sequence[str]) -> None:

    out = Path(args.out)
    check_out(out, args.force)
    scenario_options = [o for o, given in (("--task", args.task), ("--params", args.params), ("--set", args.overrides), ("--targets", args.targets)) if given]
    tables = [o for o, given in (("--matrix", args.matrix), ("--scorecard", args.scorecard)) if given]
    if args.policy and not args.scorecard:
        raise ValueError("--policy: only with --scorecard")
    if tables:
        if len(tables) > 1 or args.inputs or args.compare is not None or scenario_options:
            raise ValueError(
                f"{tables[0]}: a page of its own; not with {', '.join((tables[1:] or []) + (['runs'] if args.inputs else []) + (['--compare'] if args.compare is not None else []) + scenario_options)}"
            )

        made = pages.matrix_page(args.matrix, args.episodes or 1, args.threads) if args.matrix else pages.scorecard_page(args.scorecard, args.policy, args.episodes or 1, args.threads)
        data = page_data(made["episodes"], made["items"], None, made["subtitle"], made["table"])
        out.parent.mkdir(parents=True, exist_ok=True)
        size = write_page(out, data, args.title or made["title"])
        print(f"wrote {out} ({len(made['table']['rows'])} rows, {len(made['episodes'])} example episodes, {size / 1e3:.0f} KB)")
        return
    if args.compare:  # policies to play
        if args.inputs:
            raise ValueError(f"--compare {' '.join(args.compare)}: plays policies on a scenario; recorded runs ({', '.join(args.inputs)}) are compared with a bare --compare, not with policies")
        episodes, items, panes, subtitle = played_side_by_side(args)
        title = args.title or "wolfpack: " + " vs ".join(panes)
    else:
        if scenario_options:
            raise ValueError(f"{', '.join(scenario_options)}: only with --compare POLICY... (recorded episodes keep their own scenario)")
        if not args.inputs:
            raise ValueError("name runs (wolfpack hunt --out DIR), episode folders or trajectory.npz files to show, or --compare POLICY... to play")
        if args.compare is not None:
            episodes, items, panes = recorded_side_by_side(args.inputs, args.episodes)
            subtitle = f"{len(items)} episodes side by side: {', '.join(panes)}"
            title = args.title or "wolfpack: " + " vs ".join(panes)
        else:
            recs = collect(args.inputs, args.episodes)
            if len(recs) > LARGE_PAGE_EPISODES:
                print(f"{PROG}: note: {len(recs)} episodes in one page (~50 KB each in the documented scenario); --episodes K shows the first K of each run", file=sys.stderr)
            episodes = [encode_episode(r.arrays, r.params, r.label) for r in recs]
            items, panes = None, None
            outcomes: dict[str, int] = defaultdict(int)
            for e in episodes:
                outcomes[e["outcome"]] += 1
            subtitle = f"{len(episodes)} episode{'s' * (len(episodes) != 1)}: " + ", ".join(f"{v} {k}" for k, v in outcomes.items())
            title = args.title or "wolfpack: " + ", ".join(map(_name, args.inputs))
    data = page_data(episodes, items, panes, subtitle)
    out.parent.mkdir(parents=True, exist_ok=True)
    size = write_page(out, data, title)
    print(f"wrote {out} ({len(data['items'])} item{'s' * (len(data['items']) != 1)}, {len(episodes)} episode{'s' * (len(episodes) != 1)}, {size / 1e3:.0f} KB)")
