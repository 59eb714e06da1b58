#!/usr/bin/env python3
"""Whole scripted episodes on the two engines that can run them, side by side: the episode engine
behind ``wolfpack hunt`` (``wolfpack.run_episodes``: one episode per task on a rayon pool) and
the native batch (``wolfpack.evaluation.rollout``: ``BatchEnv`` with no learner and no
autoreset, a chunk of worlds stepped together on the batch's own threads), on 1 and 2 threads.

Both run the very same episodes (episode k is world ``seed + k``'s first); the script checks
that their outcomes and lengths agree before it reports a rate. The figure is env-steps/s:
the episodes' steps summed over the wall time of the whole call, the median of ``--repeats``
interleaved repeats. ``--loads`` adds busy processes that spin on a core each (a learner
beside the env). Whether ``wolfpack hunt`` may move onto the batch (and the rayon pool go)
turns on this table: within 5 % of the episode engine on 1 and 2 threads. Results in
BENCHMARKS.md, "One episode engine or two".

    python benchmarks/episode_engines.py                     # 1024 episodes, loads 0 and 1
    python benchmarks/episode_engines.py --episodes 256 --loads 0 --repeats 1 --json
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from typing import Callable

import wolfpack
from machine import busy_processes, emit, machine_info
from wolfpack.evaluation import rollout
from wolfpack.task import task_params

THREADS = (1, 2)


def episode_engine(params: dict, episodes: int, threads: int) -> list[tuple[str, int]]:
    return [(r["outcome"], r["steps"]) for r in wolfpack.run_episodes(params, episodes, seed=0, threads=threads)]


def batch_engine(params: dict, episodes: int, threads: int) -> list[tuple[str, int]]:
    return [(r["outcome"], r["steps"]) for r in rollout(params, episodes=episodes, seed=0, threads=threads)]


ENGINES: dict[str, Callable[[dict, int, int], list[tuple[str, int]]]] = {"episodes (rayon)": episode_engine, "batch": batch_engine}


def measure(params: dict, episodes: int, repeats: int) -> dict:
    """{engine: {threads: [env-steps/s of each repeat]}}, engines and threads interleaved."""
    rates: dict = {name: {t: [] for t in THREADS} for name in ENGINES}
    reference = None
    for _ in range(repeats):
        for t in THREADS:
            for name, run in ENGINES.items():
                start = time.perf_counter()
                played = run(params, episodes, t)
                wall = time.perf_counter() - start
                if reference is None:
                    reference = played
                elif played != reference:
                    raise SystemExit(f"{name} on {t} thread(s) played other episodes than the first run: the comparison would be unfair")
                rates[name][t].append(sum(steps for _, steps in played) / wall)
    return rates


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--task", default="hunt-v1", help="the task whose scenario is played (default hunt-v1)")
    ap.add_argument("--episodes", type=int, default=1024, help="episodes per run (default 1024)")
    ap.add_argument("--loads", default="0,1", help="competing busy processes K, comma list (default 0,1)")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved repeats (default 3)")
    ap.add_argument("--json", action="store_true", help="print the JSON document instead of the table")
    ap.add_argument("--out", default=None, help="also write the JSON document here")
    args = ap.parse_args(argv)
    try:
        loads = [int(k) for k in args.loads.split(",")]
    except ValueError:
        ap.error("--loads takes comma-separated integers")
    if min(loads) < 0 or args.episodes < 1 or args.repeats < 1:
        ap.error("loads >= 0, episodes >= 1 and repeats >= 1")
    params = task_params(args.task)
    doc = {"machine": machine_info(), "started": time.strftime("%Y-%m-%d %H:%M:%S"), "task": args.task, "episodes": args.episodes, "repeats": args.repeats, "loads": {}}
    for k in loads:
        with busy_processes(k):
            rates = measure(params, args.episodes, args.repeats)
        medians = {name: {t: statistics.median(r) for t, r in by_t.items()} for name, by_t in rates.items()}
        doc["loads"][k] = {"rates": rates, "median": medians}
        if not args.json:
            for t in THREADS:
                e, b = medians["episodes (rayon)"][t], medians["batch"][t]
                print(f"K={k} {t} thread(s): episodes (rayon) {e / 1e3:6.0f} k  batch {b / 1e3:6.0f} k env-steps/s  batch/episodes = {b / e:.2f}", flush=True)
    emit(doc, args.out, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
