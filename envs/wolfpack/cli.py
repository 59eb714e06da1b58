"""The ``wolfpack`` command line: ``wolfpack hunt`` (scripted episodes, logs, plots), ``wolfpack
replay`` (a saved episode re-rendered to video and plots) and ``wolfpack bench`` (throughput of
scripted stepping). ``wolfpack hunt --help`` explains it all.

Every failure is one line on stderr and an exit status, never a traceback:

====== ==========================================================================================
status cause
====== ==========================================================================================
2      bad input: params, overrides, layouts, an infeasible spawn, arguments —
       ``wolfpack: error: world.ts: must be a finite number > 0, got 0``
1      the file system (``--out`` not writable, disk full)
3      a bug in the core (a panic caught at the binding) — ``wolfpack: internal error ...``
130    interrupted (Ctrl-C)
====== ==========================================================================================

Nothing is printed on stdout and no ``summary.json`` exists unless the run completed.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path
from typing import Any, Callable, Sequence

from wolfpack import _core, config, logs
from wolfpack.episodes import run_episodes, summarize

PROG = "wolfpack"
EXIT_INPUT, EXIT_INTERNAL, EXIT_IO, EXIT_INTERRUPTED = 2, 3, 1, 130

JSON_KEYS = ("episodes", "capture_rate", "collision_rate", "timeout_rate", "cornered_rate", "success_rate", "cornered_episodes", "median_capture_steps", "mean_energy", "env_steps_per_second", "total_steps")

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
replace an earlier run's files there; a run stopped early leaves no summary.json):
  DIR/summary.json                    the --json summary plus params (resolved), seed, command,
                                      and episodes_detail (per episode: seed, outcome, steps,
                                      capture_step, cornered_step, energy and collisions per
                                      agent); written
                                      last, so a failed run never leaves one behind
  DIR/summary.png                     outcome counts and the histogram of capture steps
  DIR/episode_KKK/trajectory.npz      float64 wolves [T+1,N,5] and targets [T+1,M,5]
                                      (x, y, theta, v, omega; row 0 = initial state, row t =
                                      after step t), energy [T+1,N+M] (accumulated), uint8
                                      interaction [T,N+M,N+M], outcome, capture_step (-1: none),
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
  wolfpack hunt --params my_scenario.yaml --layout start.json --episodes 10 --out runs/layout

layout file (JSON; vertices in world coordinates):
  {"wolves":  [[x, y, theta], ...], "targets": [[x, y, theta], ...],
   "obstacles": [{"kind": "circle", "center": [x, y], "radius": r, "moving": false},
                 {"kind": "polygon", "center": [x, y], "vertices": [[x, y], ...],
                  "moving": true}]}"""

BENCH_DESCRIPTION = """\
Throughput of scripted stepping: runs K episodes of the documented scenario (params.yaml:
5 seed000 wolves vs 1 escape target, 12 obstacles, at most 300 steps) with threads = 1 and
with all cores (or --threads T), and reports env-steps/s and episodes/s of each. Nothing is
recorded or written. Then the native RL batch (wolfpack.BatchEnv, the engine under
make_vec_env): E worlds (--num-envs) with learning wolves driven by random actions drawn
before the clock starts, stepped --batch-steps times; an env-step is one world advancing one
step. Peers (mpe2, VMAS) are compared in benchmarks/ (see BENCHMARKS.md)."""

BENCH_EPILOG = """\
examples:
  wolfpack bench
  wolfpack bench --episodes 200 --json"""


class _Parser(argparse.ArgumentParser):
    """argparse, but a usage error is one line on stderr (like every other error here)."""

    def error(self, message: str) -> None:  # type: ignore[override]
        self.exit(EXIT_INPUT, f"{PROG}: error: {self.prog.removeprefix(PROG).strip() or 'usage'}: {message} (see --help)\n")


def _int_at_least(lo: int) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"must be >= {lo}, got {value}")
        return value

    return parse


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog=PROG,
        description="wolfpack: multi-agent pursuit-evasion (wolf-pack hunting) with a Rust core.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="run 'wolfpack hunt --help', 'wolfpack replay --help' or 'wolfpack bench --help' for details.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {_core.__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="{hunt,replay,bench}", parser_class=_Parser)

    hunt = sub.add_parser("hunt", help="run scripted episodes; print a summary, write logs and plots",
                          description=HUNT_DESCRIPTION, epilog=HUNT_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    hunt.add_argument("--params", metavar="P", help="scenario YAML (default: the packaged params.yaml); missing keys take their defaults")
    hunt.add_argument("--wolves", choices=("seed000", "bvc", "formation"), help="wolf law; sets policies.wolves (wins over --set)")
    hunt.add_argument("--targets", choices=("escape", "random", "still"), help="target law; sets policies.targets (wins over --set)")
    hunt.add_argument("--episodes", metavar="K", type=_int_at_least(1), default=20, help="number of episodes (default: 20)")
    hunt.add_argument("--seed", metavar="S", type=_int_at_least(0), default=0, help="episode k uses seed S + k (default: 0)")
    hunt.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], dest="overrides",
                      help="override a parameter by its dotted key, value read as YAML, e.g. --set world.wolves=8 "
                           "--set world.border=[-5,-5,5,5]; repeatable")
    hunt.add_argument("--layout", metavar="FILE", help="start every episode from this explicit state (JSON, schema below); "
                                                       "agent counts come from the layout")
    hunt.add_argument("--out", metavar="DIR", help="write summary.json, per-episode trajectory.npz and plots under DIR "
                                                   "(a new or empty folder, unless --force)")
    hunt.add_argument("--force", action="store_true", help="with --out DIR holding an earlier run: delete that run's files "
                                                           "(summary.json, summary.png, episode_*/) first; other files are kept")
    hunt.add_argument("--plots", metavar="N", type=_int_at_least(0), default=20,
                      help="with --out, draw trajectory.png, curves.png and interaction.png (and with --video episode.mp4) for the first N episodes only (default: 20; "
                           "0: none); summary.png and every trajectory.npz are always written")
    hunt.add_argument("--video", action="store_true", help="with --out, also write episode.mp4 (one frame per state, 10 fps = real time) "
                                                           "for the episodes that get plots (--plots)")
    hunt.add_argument("--json", action="store_true", help="print one JSON object (the summary) on stdout instead of a table")
    hunt.add_argument("--threads", metavar="T", type=_int_at_least(1), default=None, help="worker threads (default: all cores); results do not depend on it")
    hunt.set_defaults(func=cmd_hunt)

    replay = sub.add_parser("replay", help="re-render a saved episode (trajectory.npz) to video and plots without re-simulating",
                            description=REPLAY_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    replay.add_argument("episode", metavar="EPISODE_DIR", help="an episode folder of 'wolfpack hunt --out' (holding trajectory.npz), or the .npz itself")
    replay.add_argument("--out", metavar="DIR", help="where to write episode.mp4, trajectory.png, curves.png and interaction.png (default: EPISODE_DIR)")
    replay.add_argument("--no-video", action="store_true", help="no episode.mp4")
    replay.add_argument("--no-plots", action="store_true", help="no trajectory.png, curves.png, interaction.png")
    replay.add_argument("--frames", metavar="T", type=_int_at_least(0), nargs="+", default=[],
                        help="also write the frames of these steps as frame_TTT.png (a step past the end: the last frame)")
    replay.add_argument("--size", metavar="PX", type=_int_at_least(16), default=512, help="video frame width and height in pixels (default: 512)")
    replay.add_argument("--trail", metavar="STEPS", type=_int_at_least(0), default=40, help="trail length in steps (default: 40)")
    replay.set_defaults(func=cmd_replay)

    bench = sub.add_parser("bench", help="throughput of scripted stepping (env-steps/s)",
                           description=BENCH_DESCRIPTION, epilog=BENCH_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    bench.add_argument("--episodes", metavar="K", type=_int_at_least(1), default=64, help="episodes per measurement (default: 64)")
    bench.add_argument("--threads", metavar="T", type=_int_at_least(1), default=None, help="the parallel measurement's thread count (default: all cores)")
    bench.add_argument("--seed", metavar="S", type=_int_at_least(0), default=0, help="first episode seed (default: 0)")
    bench.add_argument("--num-envs", metavar="E", type=_int_at_least(1), default=64, help="worlds in the native batch measurement (default: 64)")
    bench.add_argument("--batch-steps", metavar="T", type=_int_at_least(1), default=300, help="steps of the native batch per measurement (default: 300)")
    bench.add_argument("--json", action="store_true", help="print one JSON object on stdout instead of a table")
    bench.set_defaults(func=cmd_bench)
    return parser


# --- the scenario -------------------------------------------------------------------------


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
    params = config.load_params(args.params, overrides)
    if args.layout is None:
        return params, _core.validate_params(params, resolve=True), None
    layout = config.load_layout(args.layout)
    resolved = _core.check_layout(params, layout, args.seed)
    return params, resolved, layout


# --- hunt ---------------------------------------------------------------------------------


class RunWriter:
    """Writes ``--out DIR`` as episodes arrive (so a long run never holds every trajectory in
    memory). Create it once the input is valid: it removes an earlier run's ``DIR/summary.json``
    at once, so that the summary cannot outlive a failure of this run (an infeasible spawn is
    only found while running). DIR itself is created at the first episode, after the first batch
    was simulated; ``summary.json`` is written last, by :meth:`finish`."""

    def __init__(self, out: Path, resolved: dict, plots: int, video: bool = False):
        # Imported here: matplotlib is slow to import and only needed with --out.
        from wolfpack import plots as plotting

        self.plotting = plotting
        self.out, self.resolved, self.plots, self.video = out, resolved, plots, video
        (out / logs.SUMMARY_NAME).unlink(missing_ok=True)

    def episode(self, k: int, result: dict) -> None:
        """Writes ``episode_{k:03d}/trajectory.npz`` and, for k < plots, its two plots."""
        self.out.mkdir(parents=True, exist_ok=True)
        folder = logs.episode_dir(self.out, k)
        folder.mkdir(exist_ok=True)
        arrays = logs.trajectory_arrays(result, self.resolved)
        logs.write_trajectory(folder / "trajectory.npz", arrays)
        if k < self.plots:
            self.plotting.plot_trajectory(arrays, folder / "trajectory.png", label=f"episode {k}")
            self.plotting.plot_curves(arrays, folder / "curves.png", label=f"episode {k}")
            self.plotting.plot_interaction(arrays, folder / "interaction.png", label=f"episode {k}")
            if self.video:
                from wolfpack import render

                render.write_video(render.trajectory_frames(arrays, self.resolved), folder / "episode.mp4")

    def finish(self, summary: dict) -> None:
        self.plotting.plot_summary(summary["episodes_detail"], self.out / "summary.png")
        logs.write_json_atomic(self.out / logs.SUMMARY_NAME, summary)


def clear_run(out: Path) -> None:
    """``--force``: deletes what ``wolfpack hunt --out`` writes (summary.json and its temporary,
    summary.png, episode_NNN/ folders), so that no episode of an earlier run sits beside this
    run's; anything else in ``out`` is left alone."""
    import re
    import shutil

    for name in (logs.SUMMARY_NAME, f".{logs.SUMMARY_NAME}.tmp", "summary.png"):
        (out / name).unlink(missing_ok=True)
    for child in out.iterdir():
        if child.is_dir() and re.fullmatch(r"episode_\d{3,}", child.name):
            shutil.rmtree(child)


def _cores() -> int:
    """Cores this process may use (what the core's thread pool uses by default)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def _chunk_size(episodes: int, threads: int | None, streaming: bool) -> int:
    """Episodes per native call: all at once unless results are shown or written as they come;
    then a few per thread, which keeps every core busy and memory bounded."""
    if not streaming:
        return episodes
    return max(1, min(episodes, 8 * (threads or _cores())))


def simulate(args, params, layout, on_result: Callable[[int, dict], None]) -> tuple[list[dict], float]:
    """Runs the episodes in chunks; calls ``on_result(k, result)`` for each, in order. Returns
    the results (without trajectories) and the wall time spent inside the simulator."""
    from tqdm import tqdm

    record = args.out is not None
    show = sys.stderr.isatty()
    chunk = _chunk_size(args.episodes, args.threads, record or show)
    results: list[dict] = []
    seconds = 0.0
    with tqdm(total=args.episodes, unit="ep", file=sys.stderr, disable=not show, leave=False) as bar:
        for first in range(0, args.episodes, chunk):
            count = min(chunk, args.episodes - first)
            t0 = time.perf_counter()
            # Episode k depends only on its seed S + k, so a chunk starting at `first` is a run
            # with seed S + first.
            batch = run_episodes(params, count, args.seed + first, layout=layout, record=record, threads=args.threads)
            seconds += time.perf_counter() - t0
            for i, result in enumerate(batch):
                on_result(first + i, result)
                result.pop("trajectory", None)
                results.append(result)
            bar.update(count)
    return results, seconds


def _table(summary: dict, args, resolved: dict) -> str:
    n = summary["episodes"]
    pol = resolved["policies"]
    w = resolved["world"]
    lines = [
        f"{n} episodes, seeds {args.seed}..{args.seed + n - 1}: {w['wolves']} {pol['wolves']} wolves vs "
        f"{w['targets']} {pol['targets']} target(s), at most {w['max_steps']} steps",
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
        lines.append(f"wrote {args.out}/summary.json, summary.png and episode_*/ (trajectory.npz; plots for the first {min(args.plots, n)})")
    return "\n".join(lines)


def _check_seed_range(seed: int, episodes: int) -> None:
    """Episode seeds S + k are unsigned 64-bit integers."""
    if seed + episodes - 1 >= 2**64:
        raise ValueError(f"--seed: seed + episodes - 1 must be < 2**64, got {seed} + {episodes} - 1")


def cmd_hunt(args: argparse.Namespace, argv: Sequence[str]) -> None:
    _check_seed_range(args.seed, args.episodes)
    params, resolved, layout = resolve_scenario(args)
    out = Path(args.out) if args.out else None
    if args.video and out is None:
        raise ValueError("--video needs --out DIR (the videos are written there, one per episode)")
    if out is not None and out.exists() and not out.is_dir():
        raise ValueError(f"--out {out}: exists and is not a directory")
    if out is not None and out.is_dir() and any(out.iterdir()):
        if not args.force:
            raise ValueError(f"--out {out}: not empty (an earlier run?); choose a new folder, or add --force to replace the earlier run's files")
        clear_run(out)
    writer = RunWriter(out, resolved, args.plots, args.video) if out is not None else None
    results, seconds = simulate(args, params, layout, writer.episode if writer else lambda k, r: None)
    summary = summarize(results, seconds)
    if writer is not None:
        writer.finish({**summary, "params": resolved, "seed": args.seed, "layout": layout,
                       "command": [PROG, *argv], "episodes_detail": [logs.episode_detail(r) for r in results]})
    if args.json:
        print(json.dumps(summary))
    else:
        print(_table(summary, args, resolved))


# --- replay -------------------------------------------------------------------------------

REPLAY_DESCRIPTION = """\
Re-render a saved episode without re-simulating it: episode.mp4 (one frame per recorded state,
10 fps = real time), trajectory.png, curves.png and interaction.png, from the trajectory.npz that
'wolfpack hunt --out DIR' wrote into DIR/episode_{k:03d}/. The frames are exactly those of
render_mode="rgb_array" during the live run. Body size and sensing radius come from the run's
DIR/summary.json when it is there, else from the documented scenario.

examples:
  wolfpack hunt --episodes 3 --out runs/demo
  wolfpack replay runs/demo/episode_000
  wolfpack replay runs/demo/episode_001/trajectory.npz --out /tmp/ep1 --size 768
  wolfpack replay runs/demo/episode_000 --no-video --no-plots --frames 0 100 --out /tmp/pics
"""


def load_episode(where: Path) -> tuple[dict, dict, Path]:
    """(arrays, params, episode folder) of a saved episode; ValueError saying what is wrong."""
    npz = where if where.suffix == ".npz" else where / "trajectory.npz"
    if not where.exists():
        raise ValueError(f"{where}: no such episode folder or file")
    if not npz.is_file():
        raise ValueError(f"{where}: no trajectory.npz there (an episode folder of 'wolfpack hunt --out DIR' is DIR/episode_000)")
    try:
        arrays = logs.load_trajectory(npz)
    except Exception as e:  # zip/npy errors of every kind: the file is not a trajectory
        raise ValueError(f"{npz}: not a readable trajectory.npz ({type(e).__name__}: {_one_line(e)})") from None
    needed = ("wolves", "targets", "energy", "interaction", "outcome", "obstacle_poses", "obstacle_kind", "obstacle_radius", "obstacle_vertices", "border", "capture_distance")
    missing = [k for k in needed if k not in arrays]
    if missing:
        raise ValueError(f"{npz}: not a wolfpack trajectory (missing {', '.join(missing)})")
    rows = len(arrays["wolves"])
    if rows < 1 or arrays["targets"].shape[0] != rows or arrays["obstacle_poses"].shape[0] != rows or arrays["interaction"].shape[0] != rows - 1:
        raise ValueError(f"{npz}: inconsistent trajectory arrays (wolves {arrays['wolves'].shape}, targets {arrays['targets'].shape}, "
                         f"obstacle_poses {arrays['obstacle_poses'].shape}, interaction {arrays['interaction'].shape})")
    folder = npz.parent
    params = _core.validate_params(None, resolve=True)
    summary = folder.parent / logs.SUMMARY_NAME
    if summary.is_file():
        try:
            params = _core.validate_params(json.loads(summary.read_text())["params"], resolve=True)
        except (ValueError, KeyError, TypeError):
            pass  # an unreadable summary: the defaults draw the bodies and sensing circles
    return arrays, params, folder


def cmd_replay(args: argparse.Namespace, argv: Sequence[str]) -> None:
    from wolfpack import plots as plotting
    from wolfpack import render

    arrays, params, folder = load_episode(Path(args.episode))
    out = Path(args.out) if args.out else folder
    out.mkdir(parents=True, exist_ok=True)
    label = f"{folder.name} (replay)"
    written = []
    if not args.no_plots:
        plotting.plot_trajectory(arrays, out / "trajectory.png", label=label)
        plotting.plot_curves(arrays, out / "curves.png", label=label)
        plotting.plot_interaction(arrays, out / "interaction.png", label=label)
        written += ["trajectory.png", "curves.png", "interaction.png"]
    options = render.FrameOptions(width=args.size, height=args.size, trail=args.trail)
    if not args.no_video:
        frames = render.write_video(render.trajectory_frames(arrays, params, options), out / "episode.mp4")
        written.insert(0, f"episode.mp4 ({frames} frames)")
    if args.frames:
        import imageio.v3 as iio

        last = len(arrays["wolves"]) - 1
        wanted = {min(t, last) for t in args.frames}
        for t, frame in enumerate(render.trajectory_frames(arrays, params, options)):
            if t in wanted:
                iio.imwrite(out / f"frame_{t:03d}.png", frame)
                written.append(f"frame_{t:03d}.png")
    print(f"wrote {', '.join(written) or 'nothing'} to {out}")


# --- bench --------------------------------------------------------------------------------


def cmd_bench(args: argparse.Namespace, argv: Sequence[str]) -> None:
    _check_seed_range(args.seed, args.episodes)
    params = _core.default_params()
    run_episodes(params, 1, args.seed, threads=1)  # warm-up: page in the code, start a pool
    rows = []
    for threads in dict.fromkeys((1, args.threads or _cores())):
        t0 = time.perf_counter()
        results = run_episodes(params, args.episodes, args.seed, threads=threads)
        seconds = time.perf_counter() - t0
        steps = sum(int(r["steps"]) for r in results)
        rows.append({"threads": threads, "episodes": args.episodes, "env_steps": steps, "seconds": seconds,
                     "env_steps_per_second": steps / seconds, "episodes_per_second": args.episodes / seconds})
    batch = [_bench_batch(args.num_envs, args.batch_steps, threads, args.seed) for threads in dict.fromkeys((1, args.threads or _cores()))]
    report = {"scenario": "documented (params.yaml)", "what": "scripted episodes, nothing recorded", "runs": rows, "batch": batch}
    if args.json:
        print(json.dumps(report))
        return
    print(f"scripted stepping, documented scenario, {args.episodes} episodes per run")
    print(f"  {'threads':>7}  {'env-steps/s':>12}  {'episodes/s':>10}  {'seconds':>8}")
    for r in rows:
        print(f"  {r['threads']:>7}  {r['env_steps_per_second']:>12.0f}  {r['episodes_per_second']:>10.1f}  {r['seconds']:>8.2f}")
    print(f"native batch (BatchEnv), {args.num_envs} worlds, learning wolves with random actions, {args.batch_steps} steps")
    print(f"  {'threads':>7}  {'env-steps/s':>12}  {'seconds':>8}")
    for r in batch:
        print(f"  {r['threads']:>7}  {r['env_steps_per_second']:>12.0f}  {r['seconds']:>8.2f}")


def _bench_batch(num_envs: int, steps: int, threads: int, seed: int) -> dict:
    import numpy as np

    from wolfpack.batch import BatchEnv

    env = BatchEnv(num_envs=num_envs, learners="wolves", seed=seed, threads=threads)
    plan = np.random.default_rng(seed).uniform(-1, 1, (steps, num_envs, env.n_wolves, 2)).astype(np.float32)
    env.reset(seed)
    t0 = time.perf_counter()
    for actions in plan:
        env.step(actions)
    seconds = time.perf_counter() - t0
    return {"threads": threads, "num_envs": num_envs, "steps": steps, "env_steps": steps * num_envs, "seconds": seconds,
            "env_steps_per_second": steps * num_envs / seconds}


# --- entry point --------------------------------------------------------------------------


def _one_line(err: BaseException) -> str:
    return " ".join(str(err).split()) or type(err).__name__


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point of the ``wolfpack`` script; exits with 0 on success."""
    argv = list(sys.argv[1:] if argv is None else argv)
    args = build_parser().parse_args(argv)
    try:
        args.func(args, argv)
    except ValueError as e:
        sys.exit(_fail(EXIT_INPUT, f"error: {_one_line(e)}"))
    except RuntimeError as e:
        message = _one_line(e)
        sys.exit(_fail(EXIT_INTERNAL, message if message.startswith("internal error") else f"internal error: {message}"))
    except OSError as e:
        where = f" {e.filename}" if e.filename else ""
        sys.exit(_fail(EXIT_IO, f"error:{where}: {e.strerror or _one_line(e)}"))
    except KeyboardInterrupt:
        out = getattr(args, "out", None) if args.command == "hunt" else None
        where = f"; no summary.json was written, {out} holds only the episodes finished so far" if out else ""
        sys.exit(_fail(EXIT_INTERRUPTED, f"interrupted{where}"))


def _fail(status: int, message: str) -> int:
    sys.stderr.write(f"{PROG}: {message}\n")
    return status


if __name__ == "__main__":
    main()
