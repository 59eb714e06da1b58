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

Nothing is printed on stdout and no ``summary.json`` exists unless the run completed; an
interrupted ``hunt --out DIR`` leaves the marker ``DIR/INCOMPLETE`` (see ``wolfpack hunt --help``).
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import shutil
import signal
import sys
import threading
import time
from contextlib import contextmanager
from pathlib import Path
from typing import Any, Callable, Iterator, Sequence

from wolfpack import _core, config, logs
from wolfpack._checks import MAX_THREADS, check_seed
from wolfpack.episodes import RunningSummary, run_episodes
from wolfpack.outputs import Outputs
from wolfpack.task import TASK_ORDER, outcome_changes, task_params

PROG = "wolfpack"
EXIT_INPUT, EXIT_INTERNAL, EXIT_IO, EXIT_INTERRUPTED = 2, 3, 1, 130

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


#: Episodes that `hunt --out DIR` puts in DIR/index.html at most (about 50 KB each in the
#: documented scenario); `wolfpack view DIR --episodes K` writes a page of more.
INDEX_EPISODES = 100
#: Episodes whose trajectory.npz `hunt --out` keeps unless told (--trajectories).
TRAJECTORIES_DEFAULT = 20
#: Bytes of one compressed trajectory.npz of the documented scenario (300 steps, 6 agents,
#: 12 obstacles), for the size estimate of --trajectories all.
TRAJECTORY_BYTES = 80_000


def _count_or_all(text: str) -> int | str:
    """``--trajectories``: an integer >= 0 or ``all``."""
    if text == "all":
        return "all"
    try:
        return _int_at_least(0)(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"expected an integer >= 0 or 'all', got {text!r}") from None


def _int_at_least(lo: int, hi: int | None = None) -> Callable[[str], int]:
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < lo:
            raise argparse.ArgumentTypeError(f"must be >= {lo}, got {value}")
        if hi is not None and value > hi:
            raise argparse.ArgumentTypeError(f"must be <= {hi}, got {value}")
        return value

    return parse


def _positive_minutes(text: str) -> float:
    """A time limit in minutes: a finite number > 0."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number of minutes, got {text!r}") from None
    if not (value > 0 and value != float("inf")):
        raise argparse.ArgumentTypeError(f"must be a number of minutes > 0, got {text!r}")
    return value


def _folder(text: str) -> str:
    """A path argument that must name something: ``--out ''`` is an error, not "no --out"."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path; name a folder")
    return text


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(
        prog=PROG,
        description="wolfpack: multi-agent pursuit-evasion (wolf-pack hunting) with a Rust core.",
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="run 'wolfpack hunt --help', 'wolfpack replay --help', 'wolfpack bench --help', 'wolfpack train --help', 'wolfpack benchmark --help', 'wolfpack exploit --help', 'wolfpack league --help', 'wolfpack dataset --help' or 'wolfpack view --help' for details.",
    )
    parser.add_argument("--version", action="version", version=f"{PROG} {_core.__version__}")
    sub = parser.add_subparsers(dest="command", required=True, metavar="{hunt,replay,view,bench,train,benchmark,exploit,league,dataset}", parser_class=_Parser)

    hunt = sub.add_parser(
        "hunt", help="run scripted episodes; print a summary, write logs and plots", description=HUNT_DESCRIPTION, epilog=HUNT_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    scenario = hunt.add_mutually_exclusive_group()
    scenario.add_argument("--params", metavar="P", help="scenario YAML (default: the packaged params.yaml); missing keys take their defaults")
    scenario.add_argument("--task", metavar="NAME", choices=TASK_ORDER, help=f"a task of the benchmark suite (docs/tasks.md): {', '.join(TASK_ORDER)}; --set changes it (a modified task)")
    hunt.add_argument("--wolves", choices=_core.WOLF_LAWS, help="wolf law; sets policies.wolves (wins over --set)")
    hunt.add_argument("--targets", choices=_core.TARGET_LAWS, help="target law; sets policies.targets (wins over --set)")
    hunt.add_argument("--episodes", metavar="K", type=_int_at_least(1), default=20, help="number of episodes (default: 20)")
    hunt.add_argument("--seed", metavar="S", type=_int_at_least(0), default=0, help="episode k uses seed S + k (default: 0)")
    hunt.add_argument(
        "--set",
        metavar="KEY=VALUE",
        action="append",
        default=[],
        dest="overrides",
        help="override a parameter by its dotted key, value read as YAML, e.g. --set world.wolves=8 --set world.border=[-5,-5,5,5]; repeatable",
    )
    hunt.add_argument("--layout", metavar="FILE", help="start every episode from this explicit state (JSON, schema below); agent counts come from the layout")
    hunt.add_argument("--out", metavar="DIR", type=_folder, help="write summary.json, per-episode trajectory.npz and plots under DIR (a new or empty folder, unless --force)")
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
        type=_int_at_least(0),
        default=20,
        help="with --out, draw trajectory.png, curves.png and interaction.png (and with --video episode.mp4) for the first N episodes only (default: 20; 0: none); summary.png is always written",
    )
    hunt.add_argument(
        "--trajectories",
        metavar="N|all",
        type=_count_or_all,
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
    hunt.add_argument("--threads", metavar="T", type=_int_at_least(1, MAX_THREADS), default=None, help=f"worker threads, 1 to {MAX_THREADS} (default: all cores); results do not depend on it")
    hunt.set_defaults(func=cmd_hunt)

    replay = sub.add_parser(
        "replay", help="re-render a saved episode (trajectory.npz) to video and plots without re-simulating", description=REPLAY_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    replay.add_argument("episode", metavar="EPISODE_DIR", type=_folder, help="an episode folder of 'wolfpack hunt --out' (holding trajectory.npz), or the .npz itself")
    replay.add_argument("--out", metavar="DIR", type=_folder, help="where to write episode.mp4, trajectory.png, curves.png and interaction.png (default: EPISODE_DIR)")
    replay.add_argument("--no-video", action="store_true", help="no episode.mp4")
    replay.add_argument("--no-plots", action="store_true", help="no trajectory.png, curves.png, interaction.png")
    replay.add_argument("--frames", metavar="T", type=_int_at_least(0), nargs="+", default=[], help="also write the frames of these steps as frame_TTT.png (a step past the end: the last frame)")
    replay.add_argument("--size", metavar="PX", type=_int_at_least(16), default=512, help="video frame width and height in pixels (default: 512)")
    replay.add_argument("--trail", metavar="STEPS", type=_int_at_least(0), default=40, help="trail length in steps (default: 40)")
    replay.add_argument("--html", action="store_true", help="also write episode.html, a self-contained page that plays the episode in the browser ('wolfpack view --help')")
    replay.set_defaults(func=cmd_replay)

    bench = sub.add_parser("bench", help="throughput of scripted stepping (env-steps/s)", description=BENCH_DESCRIPTION, epilog=BENCH_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    bench.add_argument("--episodes", metavar="K", type=_int_at_least(1), default=64, help="episodes per measurement (default: 64)")
    bench.add_argument("--threads", metavar="T", type=_int_at_least(1, MAX_THREADS), default=None, help=f"the parallel measurement's thread count, 1 to {MAX_THREADS} (default: all cores)")
    bench.add_argument("--seed", metavar="S", type=_int_at_least(0), default=0, help="first episode seed (default: 0)")
    bench.add_argument("--num-envs", metavar="E", type=_int_at_least(1), default=64, help="worlds in the native batch measurement (default: 64)")
    bench.add_argument("--batch-steps", metavar="T", type=_int_at_least(1), default=300, help="steps of the native batch per measurement (default: 300)")
    bench.add_argument("--json", action="store_true", help="print one JSON object on stdout instead of a table")
    bench.set_defaults(func=cmd_bench)

    from wolfpack.learn.cli import add_parser as add_train

    add_train(sub, _Parser)
    from wolfpack.scorecard_cli import add_parser as add_benchmark

    add_benchmark(sub, _Parser)
    from wolfpack.dataset_cli import add_parser as add_dataset

    add_dataset(sub, _Parser)
    from wolfpack.viewer.cli import add_parser as add_view

    add_view(sub, _Parser)
    from wolfpack.exploit_cli import add_parser as add_exploit

    add_exploit(sub, _Parser)
    from wolfpack.league_cli import add_parser as add_league

    add_league(sub, _Parser)
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
    if getattr(args, "task", None) is not None:
        params = task_params(args.task, overrides)
    else:
        params = config.load_params(args.params, overrides)
    if args.layout is None:
        return params, _core.validate_params(params, resolve=True), None
    layout = config.load_layout(args.layout)
    resolved = _core.check_layout(params, layout, args.seed)
    return params, resolved, layout


# --- hunt ---------------------------------------------------------------------------------


class _CtrlC:
    """Ctrl-C for the command line (installed by :func:`main` for the command's duration).

    Python raises KeyboardInterrupt wherever the main thread happens to be, and where that is a
    finalizer or a weakref callback (matplotlib runs many, during garbage collection) the
    exception is printed as "Exception ignored in ..." and lost, and the run goes on. So the
    handler also records the interrupt, a lost KeyboardInterrupt is recorded silently
    (``sys.unraisablehook``), and :meth:`check` raises it again at the next safe point (after
    each episode, each file, each frame). The core's signal check calls the handler too, which
    is what stops a long native call."""

    pending = False

    @classmethod
    def handler(cls, signum: int, frame: Any) -> None:
        cls.pending = True
        raise KeyboardInterrupt

    @classmethod
    def check(cls) -> None:
        if cls.pending:
            raise KeyboardInterrupt

    @classmethod
    def caused(cls, error: BaseException) -> bool:
        """Whether ``error`` is how a Ctrl-C surfaced. A KeyboardInterrupt raised inside a C
        extension's module initialisation reaches us as ``ImportError: initialization failed``
        (pybind11 wraps it; seen when Ctrl-C lands while the first savefig imports
        matplotlib's Agg backend), and other native code may wrap it likewise; any error that
        follows a recorded Ctrl-C is therefore treated as the interrupt."""
        return isinstance(error, KeyboardInterrupt) or (cls.pending and isinstance(error, Exception))

    @classmethod
    def checked(cls, items):
        """``items``, checking for a pending Ctrl-C before each."""
        for item in items:
            cls.check()
            yield item


@contextmanager
def _ctrl_c_handled() -> Iterator[None]:
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        yield  # not ours to handle (a thread), or Ctrl-C is ignored on purpose (nohup, cmd &)
        return
    _CtrlC.pending = False
    previous = signal.signal(signal.SIGINT, _CtrlC.handler)
    previous_hook = sys.unraisablehook

    def hook(unraisable) -> None:
        if isinstance(unraisable.exc_value, KeyboardInterrupt):
            _CtrlC.pending = True
        else:
            previous_hook(unraisable)

    sys.unraisablehook = hook
    try:
        yield
    except Exception as error:
        if _CtrlC.caused(error):
            raise KeyboardInterrupt from error
        raise
    finally:
        _CtrlC.pending = False  # handled now; a later command in this process starts afresh
        sys.unraisablehook = previous_hook
        signal.signal(signal.SIGINT, previous if previous is not None else signal.default_int_handler)


@contextmanager
def _sigint_held(drop: bool = False) -> Iterator[None]:
    """Holds Ctrl-C back for the block (a few renames or deletions that must not stop half
    way); a Ctrl-C that arrived meanwhile is raised when it ends, or with ``drop`` forgotten
    (the cleanup after a first Ctrl-C). Only the main thread can handle signals; elsewhere the
    block runs as it is."""
    if threading.current_thread() is not threading.main_thread() or signal.getsignal(signal.SIGINT) is signal.SIG_IGN:
        yield
        return
    caught: list[int] = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous if previous is not None else signal.default_int_handler)
    if caught and not drop:
        raise KeyboardInterrupt


class Interrupted(KeyboardInterrupt):
    """Ctrl-C during ``hunt --out``, with what it left in DIR (for the one-line message)."""

    def __init__(self, detail: str) -> None:
        super().__init__(detail)
        self.detail = detail


class RunWriter:
    """Writes a run's files into ``out`` as episodes arrive (so a long run never holds every
    trajectory in memory); ``out`` is the folder :class:`RunDir` chose. ``out`` is created at the
    first episode, and ``summary.json`` is written last, by :meth:`finish`. Every file is written
    under a temporary name and renamed: a file under its final name is complete."""

    def __init__(self, out: Path, resolved: dict, plots: int, video: bool = False, trajectories: int | None = None, html: bool = True):
        # Imported here: matplotlib is slow to import and only needed with --out.
        from wolfpack import plots as plotting

        self.plotting = plotting
        self.out, self.resolved, self.plots, self.video = out, resolved, plots, video
        self.trajectories = default_trajectories(plots) if trajectories is None else trajectories
        self.count = 0  # episodes finished
        #: The recorded episodes index.html will show, packed as they arrive (~50 KB each).
        self.pages: list[dict] | None = [] if html else None
        (out / logs.SUMMARY_NAME).unlink(missing_ok=True)

    @property
    def recorded(self) -> int:
        """Episodes whose recorded trajectory something here uses (a file or plots)."""
        return max(self.plots, self.trajectories)

    def episode(self, k: int, result: dict) -> None:
        """Writes ``episode_{k:03d}/trajectory.npz`` for k < trajectories and, for k < plots,
        its plots (and video); later episodes only count (:attr:`count`). A folder left without
        its trajectory.npz by an error or Ctrl-C is removed."""
        self.out.mkdir(parents=True, exist_ok=True)
        if k >= self.recorded:
            self.count += 1
            return
        folder = logs.episode_dir(self.out, k)
        folder.mkdir(exist_ok=True)
        arrays = logs.trajectory_arrays(result, self.resolved)
        if self.pages is not None and len(self.pages) < INDEX_EPISODES:
            from wolfpack.viewer.encode import encode_episode

            self.pages.append(encode_episode(arrays, self.resolved, f"episode_{k:03d} (seed {int(result['seed'])})"))
        if k < self.trajectories:
            try:
                logs.write_trajectory(folder / "trajectory.npz", arrays)
            except BaseException:
                shutil.rmtree(folder, ignore_errors=True)
                raise
        self.count += 1
        if k < self.plots:
            for name, plot in (("trajectory.png", self.plotting.plot_trajectory), ("curves.png", self.plotting.plot_curves), ("interaction.png", self.plotting.plot_interaction)):
                _CtrlC.check()
                with logs.atomic_path(folder / name, keep_suffix=True) as tmp:
                    plot(arrays, tmp, label=f"episode {k}")
            if self.video:
                from wolfpack import render

                with logs.atomic_path(folder / "episode.mp4", keep_suffix=True) as tmp:
                    render.write_video(_CtrlC.checked(render.trajectory_frames(arrays, self.resolved)), tmp)
        _CtrlC.check()

    def plot_summary(self, summary: dict) -> None:
        with logs.atomic_path(self.out / "summary.png", keep_suffix=True) as tmp:
            self.plotting.plot_summary(summary["episodes_detail"], tmp)

    def write_index(self, summary: dict, title: str = "wolfpack hunt") -> None:
        """``index.html``: the recorded episodes with their outcomes, played in the browser
        (:mod:`wolfpack.viewer`); none when no episode was recorded or with ``--no-html``."""
        if not self.pages:
            return
        from wolfpack.viewer.page import page_data, write_page

        pol, w = self.resolved["policies"], self.resolved["world"]
        details = summary.get("episodes_detail") or []
        n = summary.get("episodes", len(details))
        outcomes = [d["outcome"] for d in details]
        counts = ", ".join(f"{outcomes.count(o)} {o}" for o in self.plotting.OUTCOMES if o in outcomes)
        seeds = f", seeds {details[0]['seed']}..{details[-1]['seed']}" if details else ""
        shown = f"the first {len(self.pages)} of {n} episodes" if len(self.pages) < n else f"all {n} episodes"
        subtitle = f"{w['wolves']} {pol['wolves']} wolves vs {w['targets']} {pol['targets']} target(s){seeds}: {counts}; showing {shown}"
        write_page(self.out / "index.html", page_data(self.pages, subtitle=subtitle), title)

    def write_summary(self, summary: dict) -> None:
        logs.write_json_atomic(self.out / logs.SUMMARY_NAME, summary)

    def finish(self, summary: dict) -> None:
        self.plot_summary(summary)
        self.write_index(summary)
        self.write_summary(summary)


class RunDir:
    """Where ``hunt --out DIR`` writes, so that a run that does not finish never passes for one
    that did, and never costs an earlier run its files (:class:`wolfpack.outputs.Outputs`, the
    ``--out``/``--force`` rules every command shares).

    - DIR new or empty: the run writes into DIR, starting with the marker file ``INCOMPLETE``
      (:data:`logs.INCOMPLETE_NAME`), removed only once ``summary.json`` is written. Ctrl-C
      leaves the episodes finished so far (every file complete), the marker, and the manifest
      listing them (a later ``--force`` replaces them); any other failure removes what the run
      wrote.
    - DIR holding an earlier run's outputs (``--force``): the run writes into a staging folder
      inside DIR, and only once it has finished do its files replace the earlier run's; a
      failure or Ctrl-C removes the staging folder and leaves DIR as it was. A DIR holding
      files that no ``wolfpack hunt`` wrote is refused.
    """

    def __init__(self, out: Path, force: bool, command: Sequence[str]):
        self.outputs = Outputs(out, f"{PROG} hunt", force, in_place=True)
        self.out, self.command = out, list(command)
        self.replacing = self.outputs.replacing
        self.committed = False
        self.started = time.strftime("%Y-%m-%d %H:%M:%S %z")
        self.work = self.outputs.start()
        self._mark("it is still running, or it stopped before the end (interrupted or failed)")

    def _mark(self, state: str) -> None:
        text = (
            f"This wolfpack hunt run is INCOMPLETE: {state}.\n"
            f"command: {shlex.join(self.command)}\n"
            f"started: {self.started}\n"
            "summary.json is written, and this file removed, only when every episode has finished. "
            "Every trajectory.npz here is complete and readable.\n"
        )
        with logs.atomic_path(self.work / logs.INCOMPLETE_NAME) as tmp:
            tmp.write_text(text, encoding="utf-8")

    def commit(self) -> None:
        """The run has written its summary.json into :attr:`work`: make it DIR's run."""
        (self.work / logs.INCOMPLETE_NAME).unlink()
        self.outputs.commit(last=logs.SUMMARY_NAME)
        self.committed = True

    def discard(self) -> None:
        """The run failed: remove what it wrote (an earlier run in DIR is untouched)."""
        if self.committed:
            return
        if not self.replacing:
            clear_run(self.out)
        self.outputs.discard()

    def interrupted(self, done: int, total: int) -> str:
        """Ctrl-C: leave DIR as :class:`RunDir` promises; returns what to tell the user."""
        if self.committed:
            return f"; the run had finished: {self.out} holds its complete results"
        if self.replacing:
            self.outputs.discard()
            return f"; the earlier run in {self.out} is intact (this run's files were removed)"
        self._mark(f"it was interrupted (Ctrl-C) after {done} of {total} episodes")
        self.outputs.record()
        return f"; {self.out} is incomplete: {done} of {total} episodes written, marker {logs.INCOMPLETE_NAME}, no summary.json"


def clear_run(out: Path) -> None:
    """Deletes what ``wolfpack hunt --out`` writes (summary.json and its temporary,
    summary.png, index.html, the INCOMPLETE marker, episode_NNN/ folders), so that no episode of an earlier
    run sits beside a new run's; anything else in ``out`` is left alone. summary.json goes
    first, so that a run is never left looking complete with files missing."""
    import re

    for name in (logs.SUMMARY_NAME, f".{logs.SUMMARY_NAME}.tmp", "summary.png", ".summary.tmp.png", "index.html", ".index.tmp.html", logs.INCOMPLETE_NAME, f".{logs.INCOMPLETE_NAME}.tmp"):
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
    """Episodes per native call: a few per thread when results are shown or written as they
    come (every core busy, memory bounded), else a few hundred per thread — always bounded, so
    that memory stays flat over any number of episodes."""
    per_thread = 8 if streaming else 256
    return max(1, min(episodes, per_thread * (threads or _cores())))


def default_trajectories(plots: int) -> int:
    """Episodes whose trajectory.npz ``hunt --out`` keeps without ``--trajectories``: 20, or the
    plotted episodes when more."""
    return max(TRAJECTORIES_DEFAULT, plots)


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
                _CtrlC.check()
                on_result(first + i, result)
                tally.add(result)
                if details is not None:
                    details.append(logs.episode_detail(result))
            del batch
            bar.update(count)
            _CtrlC.check()
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
        with _sigint_held():  # summary.json and the swap into DIR: all or nothing
            writer.write_summary(full)
            run.commit()
        _report(summary, args, resolved)
    except BaseException as error:
        if not _CtrlC.caused(error):
            with _sigint_held(drop=True):
                run.discard()
            raise
        with _sigint_held(drop=True):
            detail = run.interrupted(writer.count if writer else 0, args.episodes)
        raise Interrupted(detail) from None


def _report(summary: dict, args, resolved: dict) -> None:
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
DIR/summary.json when it is there, else from the documented scenario. The arrays are checked
first (keys, numeric dtypes, shapes consistent with each other, finite poses and energies): a
file that fails exits with status 2 and one line naming the array.

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
    try:
        logs.check_trajectory(arrays)
    except ValueError as e:
        raise ValueError(f"{npz}: {e}") from None
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
    # Every file under a temporary name first (logs.atomic_path): Ctrl-C leaves no partial one.
    if not args.no_plots:
        for name, plot in (("trajectory.png", plotting.plot_trajectory), ("curves.png", plotting.plot_curves), ("interaction.png", plotting.plot_interaction)):
            _CtrlC.check()
            with logs.atomic_path(out / name, keep_suffix=True) as tmp:
                plot(arrays, tmp, label=label)
            written.append(name)
    options = render.FrameOptions(width=args.size, height=args.size, trail=args.trail)
    if not args.no_video:
        with logs.atomic_path(out / "episode.mp4", keep_suffix=True) as tmp:
            frames = render.write_video(_CtrlC.checked(render.trajectory_frames(arrays, params, options)), tmp)
        written.insert(0, f"episode.mp4 ({frames} frames)")
    if args.html:
        from wolfpack.viewer.encode import encode_episode
        from wolfpack.viewer.page import page_data, write_page

        label = f"{folder.name} (seed {int(arrays['seed'])})" if "seed" in arrays else folder.name
        write_page(out / "episode.html", page_data([encode_episode(arrays, params, label)]), f"wolfpack replay: {label}")
        written.append("episode.html")
    if args.frames:
        import imageio.v3 as iio

        last = len(arrays["wolves"]) - 1
        wanted = {min(t, last) for t in args.frames}
        for t, frame in enumerate(_CtrlC.checked(render.trajectory_frames(arrays, params, options))):
            if t in wanted:
                with logs.atomic_path(out / f"frame_{t:03d}.png", keep_suffix=True) as tmp:
                    iio.imwrite(tmp, frame)
                written.append(f"frame_{t:03d}.png")
    print(f"wrote {', '.join(written) or 'nothing'} to {out}")


# --- bench --------------------------------------------------------------------------------


def cmd_bench(args: argparse.Namespace, argv: Sequence[str]) -> None:
    check_seed(args.seed, "--seed", span=args.episodes)  # episode seeds S + k are u64
    params = _core.default_params()
    run_episodes(params, 1, args.seed, threads=1)  # warm-up: page in the code, start a pool
    rows = []
    for threads in dict.fromkeys((1, args.threads or _cores())):
        t0 = time.perf_counter()
        results = run_episodes(params, args.episodes, args.seed, threads=threads)
        seconds = time.perf_counter() - t0
        steps = sum(int(r["steps"]) for r in results)
        rows.append({"threads": threads, "episodes": args.episodes, "env_steps": steps, "seconds": seconds, "env_steps_per_second": steps / seconds, "episodes_per_second": args.episodes / seconds})
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
    for actions in _CtrlC.checked(plan):
        env.step(actions)
    seconds = time.perf_counter() - t0
    return {"threads": threads, "num_envs": num_envs, "steps": steps, "env_steps": steps * num_envs, "seconds": seconds, "env_steps_per_second": steps * num_envs / seconds}


# --- entry point --------------------------------------------------------------------------


def _one_line(err: BaseException) -> str:
    return " ".join(str(err).split()) or type(err).__name__


def main(argv: Sequence[str] | None = None) -> None:
    """Entry point of the ``wolfpack`` script; exits with 0 on success. Every failure, Ctrl-C
    included, is one line on stderr and a status (module docstring)."""
    entry = argv is None  # the process's own command line: it ends here
    argv = list(sys.argv[1:] if argv is None else argv)
    try:
        with _ctrl_c_handled():
            parser = build_parser()
            if not argv:  # a bare `wolfpack`: what it can do, not an error about what is missing
                parser.print_help()
                return
            args = parser.parse_args(argv)
            args.func(args, argv)
    except ValueError as e:
        sys.exit(_fail(EXIT_INPUT, f"error: {_one_line(e)}"))
    except RuntimeError as e:
        message = _one_line(e)
        sys.exit(_fail(EXIT_INTERNAL, message if message.startswith("internal error") else f"internal error: {message}"))
    except OSError as e:
        where = f"{e.filename}: " if e.filename else ""
        sys.exit(_fail(EXIT_IO, f"error: {where}{e.strerror or _one_line(e)}"))
    except KeyboardInterrupt as e:
        status = _fail(EXIT_INTERRUPTED, f"interrupted{getattr(e, 'detail', '')}")
        if entry and threading.current_thread() is threading.main_thread():
            # The process ends here, at once: a second Ctrl-C must not add a traceback to the
            # line, and every file is closed already, so skip the interpreter's teardown
            # (tearing down matplotlib alone takes a few tenths of a second).
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            for stream in (sys.stdout, sys.stderr):
                try:
                    stream.flush()
                except (OSError, ValueError):
                    pass
            os._exit(status)
        sys.exit(status)


def _fail(status: int, message: str) -> int:
    sys.stderr.write(f"{PROG}: {message}\n")
    return status


if __name__ == "__main__":
    main()
