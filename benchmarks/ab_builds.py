#!/usr/bin/env python3
"""Two builds of wolfpack side by side: is a change to the step path faster or slower?

Each build is a folder that holds an importable ``wolfpack`` package with its compiled
``_core`` (a clone's ``envs/`` after ``pip install -e .``, copied aside so that the next build
does not overwrite it). For ``--rounds`` rounds, alternating which build goes first, one
subprocess per build times ``BatchEnv.step`` (zero wolf actions, fresh arrays; and into the
caller's buffers with ``out=`` where the build has ``new_outputs``) and the SB3 VecEnv's step
for each (E, threads) in ``--configs``: the best of 7 chunks of ``--chunk`` seconds, which
drops the chunks a busy host disturbed. The table gives the median over rounds and the ratio
after / before. On a VM with CPU steal a ratio within ±10 % is noise unless the rounds agree
(``--json`` keeps every round). Counting instructions under callgrind instead was tried: the
difference between runs of 500 and 2,500 Python-driven steps moved by 10–15 % between two
harnesses of the same build, more than the changes it was meant to weigh.

    python benchmarks/ab_builds.py --before /tmp/old/envs --after envs --rounds 8
    python benchmarks/ab_builds.py --before /tmp/old/envs --after envs --configs 1:1,64:2 --json
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path

import numpy as np


def measure(configs: list[tuple[int, int]], chunk: float) -> dict[str, float]:
    """This process's build: env-steps/s of every mode and config (the best of 7 chunks)."""
    import wolfpack

    res: dict[str, float] = {}

    def best(key: str, step, e: int) -> None:
        for _ in range(20):
            step()
        rates = []
        for _ in range(7):
            n, t0 = 0, time.perf_counter()
            while time.perf_counter() - t0 < chunk:
                for _ in range(10):
                    step()
                n += 10
            rates.append(n * e / (time.perf_counter() - t0))
        res[key] = max(rates)

    for e, t in configs:
        b = wolfpack.BatchEnv(num_envs=e, learners="wolves", seed=0, threads=t)
        b.reset()
        a = np.zeros((e, b.n_wolves, 2), np.float32)
        best(f"batch E={e} t={t}", lambda: b.step(a), e)
        if hasattr(b, "new_outputs"):
            out = b.new_outputs()
            best(f"batch_out E={e} t={t}", lambda: b.step(a, out=out), e)
        v = wolfpack.make_vec_env(num_envs=e, learners="wolves", seed=0, threads=t)
        v.reset()
        va = np.zeros((v.num_envs, 2), np.float32)
        best(f"vec E={e} t={t}", lambda: v.step(va), e)
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--before", help="folder holding the old build's wolfpack package")
    ap.add_argument("--after", help="folder holding the new build's wolfpack package")
    ap.add_argument("--rounds", type=int, default=8)
    ap.add_argument("--chunk", type=float, default=0.15, help="seconds per timed chunk")
    ap.add_argument("--configs", default="1:1,64:2,1024:2,8192:2", help="E:threads pairs")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of tables")
    ap.add_argument("--measure", help=argparse.SUPPRESS)  # the worker: configs as JSON
    args = ap.parse_args()
    if args.measure:
        print(json.dumps(measure([tuple(c) for c in json.loads(args.measure)], args.chunk)))
        return
    if not (args.before and args.after):
        ap.error("--before and --after are required")
    builds = {"before": str(Path(args.before).resolve()), "after": str(Path(args.after).resolve())}
    configs = [tuple(int(x) for x in c.split(":")) for c in args.configs.split(",")]
    got: dict[str, list[dict]] = {k: [] for k in builds}
    for r in range(args.rounds):
        for name in list(builds) if r % 2 == 0 else list(builds)[::-1]:
            cmd = [sys.executable, __file__, "--measure", json.dumps(configs), "--chunk", str(args.chunk)]
            out = subprocess.run(cmd, env=dict(os.environ, PYTHONPATH=builds[name]), capture_output=True, text=True, check=True).stdout
            got[name].append(json.loads(out))
        print(f"round {r + 1}/{args.rounds}", file=sys.stderr, flush=True)
    keys = list(got["after"][0])
    table = {}
    for k in keys:
        after = statistics.median(x[k] for x in got["after"])
        before = statistics.median(x[k] for x in got["before"]) if k in got["before"][0] else None
        table[k] = {"before": before, "after": after, "ratio": after / before if before else None}
    result = {"builds": builds, "rounds": args.rounds, "chunk_s": args.chunk, "load_after": os.getloadavg()[0], "median_env_steps_per_s": table, "rounds_raw": got}
    if args.json:
        print(json.dumps(result, indent=1))
        return
    print(f"{'':24} {'before':>10} {'after':>10} {'ratio':>6}")
    for k, row in table.items():
        before = f"{row['before'] / 1e3:9.0f}k" if row["before"] else f"{'-':>10}"
        ratio = f"{row['ratio']:6.2f}" if row["ratio"] else f"{'-':>6}"
        print(f"{k:24} {before} {row['after'] / 1e3:9.0f}k {ratio}")


if __name__ == "__main__":
    main()
