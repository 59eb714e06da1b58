"""``wolfpack hunt``: scripted episodes, summarised on stdout, written with ``--out`` (logs,
plots, the viewer's index.html)."""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any, Callable, Sequence

from wolfpack import _core, config, logs
from wolfpack._checks import MAX_THREADS, check_seed, usable_cores
from wolfpack.cli.args import PROG, count_or_all, folder, int_at_least
from wolfpack.cli.run_files import INDEX_EPISODES, TRAJECTORY_BYTES, RunDir, RunWriter, default_trajectories
from wolfpack.episodes import RunningSummary, run_episodes
from wolfpack.interrupt import CtrlC, Interrupted, sigint_held
from wolfpack.task import TASK_ORDER, outcome_changes, task_params

JSON_KEYS = (
    "episodes",
    "capture_rate",
    "collision_rate",
    "timeout_rate",
    "cornered_rate",
    "success_rate",
    "cornered_episodes",
    "median_capture_steps",
    "mean_energy",
    "env_steps_per_second",
    "total_steps",
)

HUNT_DESCRIPTION = """\
Run scripted episodes of the wolf-pack hunt and report how they ended.

The scenario (params.yaml; docs/world-and-laws.md in the repository): N unicycle wolves hunt M targets in a rectangular
arena with static and moving circles and rotating, drifting irregular polygons. Default: a
20 m x 20 m arena, Ts = 0.1 s, at most 300 steps, 5 wolves, 1 target, 12 obstacles.
Wolf laws (--wolves): seed000 (attraction + tangential repulsion + heading-based avoidance,
world-and-laws §3-4), bvc (buffered Voronoi cells + Hungarian assignment of hunting points, world-and-laws §6;
parameters bvc.*) or formation (obstacle graph, virtual leader on the shortest path,
potential-field formation, world-and-laws §7; parameters formation.*). Target laws (--targets):
escape, random, still. Each episode ends as
  captured   every target has capture.count wolves (default 4) within capture.distance (0.8 m)
             (capture.rule: count; encircle also asks that it lie inside their convex hull;
             hunting_points asks every wolf to be within capture.arrive_tolerance of its
             hunting point on the bvc.radius ring, assigned as bvc assigns them)
  cornered   only with capture.cornered=true: the target lies within capture.distance of a
             wall, 2+ wolves are within capture.distance of it, and it lies inside the convex
             hull of those wolves and its closest points on the near walls
  collision  a wolf touched an obstacle or another wolf
  timeout    world.max_steps steps passed.
Whether or not cornering ends an episode, every summary counts the episodes in which the
target was ever cornered (cornered_episodes).
Episode k uses seed S + k and its own random generator: results do not depend on --threads,
and episode k of a run with seed S equals episode 0 of a run with seed S + k.

Output on stdout: a short table, or with --json one JSON object with the keys
  episodes, capture_rate, collision_rate, timeout_rate, cornered_rate, success_rate (captured
  + cornered), cornered_episodes (episodes in which a target was ever cornered),
  median_capture_steps (over captured episodes; null if none), mean_energy (J, total of sum 1/2 m v^2 over all agents per
  episode), env_steps_per_second (simulated steps / wall time spent simulating), total_steps.

With --out DIR (created after the input has been checked; a new or empty folder, or --force to
replace an earlier run's files there). Into a new or empty DIR the run writes a marker file
DIR/INCOMPLETE first and removes it once summary.json is written: Ctrl-C leaves the episodes
finished so far, the marker and no summary.json; another failure removes what the run wrote.
With --force the run is written into a staging folder inside DIR and replaces the earlier
run's files only once it has finished: a run that fails or is interrupted leaves the earlier
run as it was. --force replaces only what 'wolfpack hunt' wrote (listed in DIR/.wolfpack-outputs.json);
a DIR holding other files is refused. Every file is written under a temporary name and renamed,
so every file present is complete.
  DIR/summary.json                    the --json summary plus params (resolved), seed, command,
                                      and episodes_detail (per episode: seed, outcome, steps,
                                      capture_step, cornered_step, energy and collisions per
                                      agent); written
                                      last, so a failed run never leaves one behind
  DIR/summary.png                     outcome counts and the histogram of capture steps
  DIR/index.html                      (unless --no-html) the recorded episodes (the first 100
                                      at most) with their outcomes, in one self-contained page
                                      that plays them in the browser ('wolfpack view --help')
  DIR/episode_KKK/trajectory.npz      (first --trajectories episodes: 20 by default, or --plots
                                      when larger; 'all' for every one, ~80 KB each)
                                      float64 wolves [T+1,N,5] and targets [T+1,M,5]
                                      (x, y, theta, v, omega; row 0 = initial state, row t =
                                      after step t), energy [T+1,N+M] (accumulated), uint8
                                      interaction [T,N+M,N+M], uint32 collisions [N+M] (steps
                                      in contact), outcome, capture_step (-1: none),
                                      target_capture_step [M], cornered_step, seed, obstacle_poses [T+1,K,3], obstacle_kind,
                                      obstacle_radius, obstacle_vertices [K,V,2] (NaN-padded,
                                      relative to the centre at angle 0), border, ts,
                                      capture_distance
  DIR/episode_KKK/trajectory.png      (first --plots episodes) arena, obstacles at their
                                      initial (light) and final pose, paths, capture ring
  DIR/episode_KKK/curves.png          (first --plots episodes) speed, turn rate,
                                      wolf-target distance and energy over time
  DIR/episode_KKK/interaction.png     (first --plots episodes) the interaction graph over
                                      time as a heat map (observer -> observed per step)
  DIR/episode_KKK/episode.mp4         (--video; first --plots episodes) the hunt, one frame
                                      per state at 10 fps (real time); 'wolfpack replay'
                                      re-renders it from trajectory.npz

Invalid input (unknown key, wrong type, value out of range, an infeasible layout or spawn)
exits with status 2 and one line on stderr naming the problem."""

HUNT_EPILOG = """\
examples:
  wolfpack hunt --episodes 20 --json
  wolfpack hunt --episodes 200 --seed 7 --out runs/hunt --plots 5
  wolfpack hunt --targets still --set world.wolves=8 --set capture.count=6
  wolfpack hunt --task fast-target-v1 --wolves bvc --episodes 200
  wolfpack hunt --params my_scenario.yaml --layout start.json --episodes 10 --out runs/layout

layout file (JSON; vertices in world coordinates):
  {"wolves":  [[x, y, theta], ...], "targets": [[x, y, theta], ...],
   "obstacles": [{"kind": "circle", "center": [x, y], "radius": r, "moving": false},
                 {"kind": "polygon", "center": [x, y], "vertices": [[x, y], ...],
                  "moving": true}]}"""


def add_parser(sub) -> argparse.ArgumentParser:
    """Adds ``wolfpack hunt`` to the subcommands ``sub``."""
    hunt = sub.add_parser(
        "hunt", help="run scripted episodes; print a summary, write logs and plots", description=HUNT_DESCRIPTION, epilog=HUNT_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    scenario = hunt.add_mutually_exclusive_group()
    scenario.add_argument("--params", metavar="P", help="scenario YAML (default: the packaged params.yaml); missing keys take their defaults")
    scenario.add_argument("--task", metavar="NAME", choices=TASK_ORDER, help=f"a task of the benchmark suite (docs/tasks.md): {', '.join(TASK_ORDER)}; --set changes it (a modified task)")
    hunt.add_argument("--wolves", choices=_core.WOLF_LAWS, help="wolf law; sets policies.wolves (wins over --set)")
    hunt.add_argument("--targets", choices=_core.TARGET_LAWS, help="target law; sets policies.targets (wins over --set)")
    hunt.add_argument("--episodes", metavar="K", type=int_at_least(1), default=20, help="number of episodes (default: 20)")
    hunt.add_argument("--seed", metavar="S", type=int_at_least(0), default=0, help="episode k uses seed S + k (default: 0)")
    hunt.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        dest="overrides",
        help="override a parameter by its dotted key, value read as YAML, e.g. --set world.wolves=8 --set world.border=[-5,-5,5,5]; repeatable",
    )
    hunt.add_argument("--layout", metavar="FILE", help="start every episode from this explicit state (JSON, schema below); agent counts come from the layout")
    hunt.add_argument("--out", metavar="DIR", type=folder, help="write summary.json, per-episode trajectory.npz and plots under DIR (a new or empty folder, unless --force)")
    hunt.add_argument(
        "--force",
        action="store_true",
        help="with --out DIR holding an earlier run: replace that run's files "
        "(summary.json, summary.png, index.html, episode_*/) once this run has finished; "
        "a DIR holding files 'wolfpack hunt' did not write is refused, and a run that fails or is interrupted leaves the earlier one as it was",
    )
    hunt.add_argument(
        "--plots",
        metavar="N",
        type=int_at_least(0),
        default=20,
        help="with --out, draw trajectory.png, curves.png and interaction.png (and with --video episode.mp4) for the first N episodes only (default: 20; 0: none); summary.png is always written",
    )
    hunt.add_argument(
        "--trajectories",
        metavar="N|all",
        type=count_or_all,
        default=None,
        help="with --out, save trajectory.npz (what 'wolfpack replay' re-renders) for the first N episodes only (default: 20, or --plots when larger; "
        "'all': every episode, about 80 KB each in the documented scenario); summary.json covers every episode either way",
    )
    hunt.add_argument(
        "--no-html",
        action="store_true",
        help=f"with --out, no index.html (by default the run's recorded episodes, the first {INDEX_EPISODES} at most, in one page that plays them in the browser: 'wolfpack view --help')",
    )
    hunt.add_argument("--video", action="store_true", help="with --out, also write episode.mp4 (one frame per state, 10 fps = real time) for the episodes that get plots (--plots)")
    hunt.add_argument("--json", action="store_true", help="print one JSON object (the summary) on stdout instead of a table")
    hunt.add_argument("--threads", metavar="T", type=int_at_least(1, MAX_THREADS), default=None, help=f"worker threads, 1 to {MAX_THREADS} (default: all cores); results do not depend on it")
    hunt.set_defaults(func=cmd_hunt)
    return hunt


def _overrides(args: argparse.Namespace) -> dict[str, Any]:
    """``--set`` pairs in order, then ``--wolves`` / ``--targets`` (which win)."""
    overrides = dict(config.parse_override(text) for text in args.overrides)
    if args.wolves:
        overrides["policies.wolves"] = args.wolves
    if args.targets:
        overrides["policies.targets"] = args.targets
    return overrides


def resolve_scenario(args: argparse.Namespace) -> tuple[dict, dict, dict | None]:
    """Reads and validates everything the run needs before anything is written.

    Returns ``(params, resolved, layout)``: the params to run with, the complete resolved params
    of the episodes (with a layout: its agent counts), and the layout or ``None``. Raises
    ValueError naming the problem.
    """
    overrides = _overrides(args)
    if getattr(args, "task", None) is not None:
        params = task_params(args.task, overrides)
    else:
        params = config.load_params(args.params, overrides)
    if args.layout is None:
        return params, _core.validate_params(params, resolve=True), None
    layout = config.load_layout(args.layout)
    resolved = _core.check_layout(params, layout, args.seed)
    return params, resolved, layout


def _chunk_size(episodes: int, threads: int | None, streaming: bool) -> int:
    """Episodes per native call: a few per thread when results are shown or written as they
    come (every core busy, memory bounded), else a few hundred per thread — always bounded, so
    that memory stays flat over any number of episodes."""
    per_thread = 8 if streaming else 256
    return max(1, min(episodes, per_thread * (threads or usable_cores())))


def kept_trajectories(args) -> int:
    """How many episodes' trajectory.npz ``hunt --out`` writes (``--trajectories``)."""
    if args.trajectories == "all":
        return args.episodes
    return min(args.episodes, default_trajectories(args.plots) if args.trajectories is None else args.trajectories)


def _warn_if_large(args, resolved: dict) -> None:
    """One line on stderr before a run whose files would pass ~1 GB: what it will write."""
    w = resolved["world"]
    each = TRAJECTORY_BYTES * w["max_steps"] / 300 * (w["wolves"] + w["targets"]) / 6
    files = kept_trajectories(args)
    total = files * each
    if total > 1e9:
        print(f"{PROG}: note: --out keeps {files:,} trajectory.npz files, about {total / 1e9:.1f} GB (~{each / 1e3:.0f} KB each); --trajectories N keeps fewer", file=sys.stderr)


def simulate(args, params, layout, on_result: Callable[[int, dict], None], details: list | None = None, recorded: int = 0) -> tuple[RunningSummary, float]:
    """Runs the episodes in chunks; calls ``on_result(k, result)`` for each, in order, and
    appends each episode's :func:`logs.episode_detail` to ``details`` when given. Episodes
    ``0 .. recorded - 1`` (whole chunks) come with their trajectories. Returns the running
    summary and the wall time spent inside the simulator. Nothing else is kept per episode, so
    memory does not grow with the episode count (bar ``details``)."""
    from tqdm import tqdm

    show = sys.stderr.isatty()
    chunk = _chunk_size(args.episodes, args.threads, recorded > 0 or show)
    tally = RunningSummary()
    seconds = 0.0
    with tqdm(total=args.episodes, unit="ep", file=sys.stderr, disable=not show, leave=False) as bar:
        for first in range(0, args.episodes, chunk):
            count = min(chunk, args.episodes - first)
            t0 = time.perf_counter()
            # Episode k depends only on its seed S + k, so a chunk starting at `first` is a run
            # with seed S + first.
            batch = run_episodes(params, count, args.seed + first, layout=layout, record=first < recorded, threads=args.threads)
            seconds += time.perf_counter() - t0
            for i, result in enumerate(batch):
                CtrlC.check()
                on_result(first + i, result)
                tally.add(result)
                if details is not None:
                    details.append(logs.episode_detail(result))
            del batch
            bar.update(count)
            CtrlC.check()
    return tally, seconds


def _table(summary: dict, args, resolved: dict) -> str:
    n = summary["episodes"]
    pol = resolved["policies"]
    w = resolved["world"]
    task = f"task {args.task}{' (modified)' if outcome_changes(_overrides(args)) else ''}: " if getattr(args, "task", None) else ""
    lines = [
        f"{task}{n} episodes, seeds {args.seed}..{args.seed + n - 1}: {w['wolves']} {pol['wolves']} wolves vs {w['targets']} {pol['targets']} target(s), at most {w['max_steps']} steps",
    ]
    keys = ("captured", "cornered", "collision", "timeout") if resolved["capture"]["cornered"] else ("captured", "collision", "timeout")
    for key in keys:
        rate = summary[f"{'capture' if key == 'captured' else key}_rate"]
        lines.append(f"  {key:<22} {round(rate * n):>6}  ({100 * rate:.1f}%)")
    k = summary["cornered_episodes"]
    lines.append(f"  {'ever cornered':<22} {k:>6}  ({100 * k / n if n else 0:.1f}%)")
    median = summary["median_capture_steps"]
    lines.append(f"  {'median capture steps':<22} {'-' if median is None else f'{median:g}':>6}")
    lines.append(f"  {'mean energy (J)':<22} {summary['mean_energy']:>10.2f}")
    lines.append(f"  {'env steps per second':<22} {summary['env_steps_per_second'] or 0:>10.0f}")
    if args.out:
        page = "" if args.no_html or not max(kept_trajectories(args), min(args.plots, n)) else ", index.html"
        lines.append(f"wrote {args.out}/summary.json, summary.png{page} and episode_*/ (trajectory.npz for the first {kept_trajectories(args)}, plots for the first {min(args.plots, n)})")
    return "\n".join(lines)


def cmd_hunt(args: argparse.Namespace, argv: Sequence[str]) -> None:
    check_seed(args.seed, "--seed", span=args.episodes)  # episode seeds S + k are u64
    params, resolved, layout = resolve_scenario(args)
    out = Path(args.out) if args.out is not None else None
    if args.video and out is None:
        raise ValueError("--video needs --out DIR (the videos are written there, one per episode)")
    if out is None:
        tally, seconds = simulate(args, params, layout, lambda k, r: None)
        _report(tally.summary(seconds), args, resolved)
        return
    _warn_if_large(args, resolved)
    run = RunDir(out, args.force, [PROG, *argv])
    writer: RunWriter | None = None
    try:
        trajectories = kept_trajectories(args)
        writer = RunWriter(run.work, resolved, args.plots, args.video, trajectories, html=not args.no_html)
        details: list[dict] = []
        tally, seconds = simulate(args, params, layout, writer.episode, details, recorded=writer.recorded)
        summary = tally.summary(seconds)
        full = {**summary, "task": args.task, "params": resolved, "seed": args.seed, "layout": layout, "command": [PROG, *argv], "episodes_detail": details}
        writer.plot_summary(full)
        writer.write_index(full, f"{PROG} hunt: {out}")
        with sigint_held():  # summary.json and the swap into DIR: all or nothing
            writer.write_summary(full)
            run.commit()
        _report(summary, args, resolved)
    except BaseException as error:
        if not CtrlC.caused(error):
            with sigint_held(drop=True):
                run.discard()
            raise
        with sigint_held(drop=True):
            detail = run.interrupted(writer.count if writer else 0, args.episodes)
        raise Interrupted(detail) from None


def _report(summary: dict, args, resolved: dict) -> None:
    if args.json:
        print(json.dumps(summary))
    else:
        print(_table(summary, args, resolved))
