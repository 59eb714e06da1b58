#!/usr/bin/env python3
"""The batch's thread scaling beside other busy processes: what a user who steps the env next to
a learner gets from ``threads=2`` instead of ``threads=1``.

For each competing load K (processes that spin on a core each, for the whole measurement) and
each batch size E, ``BatchEnv(num_envs=E, threads=T).step`` (wolves learning, observations,
autoreset, zero actions) is timed for T = 1 and T = 2, the two interleaved ``--repeats`` times;
the table gives the median env-steps/s of each and their ratio. The batch's aim: two threads
never more than 10 % slower than one at any E and any load, and at least 1.8× one on a quiet
machine from E = 64 up. Results in BENCHMARKS.md, "Threads beside a busy process".

    python benchmarks/under_load.py                                   # K = 0, 1, 2; E = 1 .. 8192
    python benchmarks/under_load.py --loads 1 --sizes 64 --repeats 5 --json
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time

import numpy as np
from machine import busy_processes, emit, machine_info
from wolfpack import BatchEnv


def rate(env: BatchEnv, actions: np.ndarray, seconds: float) -> float:
    """env-steps/s of ``env.step(actions)`` over about ``seconds`` (after a few warm-up steps)."""
    for _ in range(3):
        env.step(actions)
    calls, start = 0, time.perf_counter()
    while (elapsed := time.perf_counter() - start) < seconds:
        env.step(actions)
        calls += 1
    return calls * env.num_envs / elapsed


def measure(sizes: list[int], threads: list[int], repeats: int, seconds: float) -> dict:
    """{E: {T: [env-steps/s of each repeat]}}, the thread counts interleaved within each repeat."""
    out: dict = {}
    for e in sizes:
        envs = {t: BatchEnv(num_envs=e, learners="wolves", seed=0, threads=t) for t in threads}
        actions = np.zeros((e, envs[threads[0]].n_wolves, 2), np.float32)
        for env in envs.values():
            env.reset(seed=0)
        out[e] = {t: [] for t in threads}
        for _ in range(repeats):
            for t in threads:
                out[e][t].append(rate(envs[t], actions, seconds))
        del envs  # their crews stop before the next E's start
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--loads", default="0,1,2", help="competing busy processes K, comma list (default 0,1,2)")
    ap.add_argument("--sizes", default="1,8,64,1024,8192", help="batch sizes E, comma list (default 1,8,64,1024,8192)")
    ap.add_argument("--repeats", type=int, default=3, help="interleaved repeats of each measurement (default 3)")
    ap.add_argument("--seconds", type=float, default=1.0, help="seconds per measurement (default 1)")
    ap.add_argument("--json", action="store_true", help="print the JSON document instead of the table")
    ap.add_argument("--out", default=None, help="also write the JSON document here")
    args = ap.parse_args(argv)
    try:
        loads = [int(k) for k in args.loads.split(",")]
        sizes = [int(e) for e in args.sizes.split(",")]
    except ValueError:
        ap.error("--loads and --sizes take comma-separated integers")
    if min(loads) < 0 or min(sizes) < 1 or args.repeats < 1 or args.seconds <= 0:
        ap.error("loads ≥ 0, sizes ≥ 1, repeats ≥ 1 and seconds > 0")
    threads = [1, 2]
    doc = {"machine": machine_info(), "started": time.strftime("%Y-%m-%d %H:%M:%S"), "repeats": args.repeats, "seconds": args.seconds, "loads": {}}
    for k in loads:
        with busy_processes(k):
            runs = measure(sizes, threads, args.repeats, args.seconds)
        doc["loads"][k] = {e: {"rates": {t: r for t, r in by_t.items()}, "median": {t: statistics.median(r) for t, r in by_t.items()}} for e, by_t in runs.items()}
        if not args.json:
            for e, row in doc["loads"][k].items():
                m = row["median"]
                print(f"K={k} E={e:<5} 1 thread {m[1] / 1e3:7.0f} k  2 threads {m[2] / 1e3:7.0f} k  2/1 = {m[2] / m[1]:.2f}", flush=True)
    emit(doc, args.out, args.json)
    return 0


if __name__ == "__main__":
    sys.exit(main())
