#!/usr/bin/env python3
"""Two batches stepped in turn against one batch alone, on the same threads.

Training loops often keep more than one batch: a training and an evaluation batch, or one
batch per side of a league. Each batch has threads of its own that wait awake for its next
step for a short while; this measures whether two batches stepped in turn get in each other's
way (before the batch had a crew of its own: on 2 cores, two E = 64 batches ran at
≈ 0.2 M env-steps/s in turn against ≈ 0.6 M for one). See BENCHMARKS.md.

    python benchmarks/alternating.py                     # E = 64 and 1024, 2 threads
    python benchmarks/alternating.py --sizes 64 --threads 2 --repeats 3

Prints one line per E and round: one batch's env-steps/s, then two batches' in turn (each
env-step of either counts).
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from wolfpack import BatchEnv


def rate(step, env_steps_per_call: int, calls: int) -> float:
    start = time.perf_counter()
    for _ in range(calls):
        step()
    return calls * env_steps_per_call / (time.perf_counter() - start)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--sizes", default="64,1024", help="batch sizes E, comma list (default 64,1024)")
    ap.add_argument("--threads", type=int, default=2, help="threads of each batch (default 2)")
    ap.add_argument("--repeats", type=int, default=2, help="rounds per E (default 2)")
    ap.add_argument("--env-steps", type=int, default=200_000, help="env-steps per measurement (default 200000)")
    args = ap.parse_args()
    for e in (int(s) for s in args.sizes.split(",")):
        actions = np.zeros((e, 5, 2), np.float32)
        a = BatchEnv(num_envs=e, learners="wolves", seed=0, threads=args.threads)
        b = BatchEnv(num_envs=e, learners="wolves", seed=1_000_000, threads=args.threads)
        a.reset(seed=0)
        b.reset(seed=1_000_000)
        for _ in range(20):
            a.step(actions)
            b.step(actions)
        calls = max(100, args.env_steps // e)
        for r in range(args.repeats):
            one = rate(lambda: a.step(actions), e, calls)
            both = rate(lambda: (a.step(actions), b.step(actions)), 2 * e, calls // 2)
            print(f"E={e} threads={args.threads} round {r + 1}: one batch {one / 1e3:.0f} k, two in turn {both / 1e3:.0f} k env-steps/s", flush=True)


if __name__ == "__main__":
    main()
