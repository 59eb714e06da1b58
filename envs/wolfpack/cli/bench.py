"""``wolfpack bench``: the throughput of scripted stepping, whole episodes and the native batch."""

from __future__ import annotations

import argparse
import json
import time
from typing import Sequence

from wolfpack import _core
from wolfpack._checks import MAX_THREADS, check_seed, usable_cores
from wolfpack.batch import BatchEnv
from wolfpack.cli.args import int_at_least
from wolfpack.episodes import run_episodes
from wolfpack.interrupt import CtrlC

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


def add_parser(sub) -> argparse.ArgumentParser:
    """Adds ``wolfpack bench`` to the subcommands ``sub``."""
    bench = sub.add_parser("bench", help="throughput of scripted stepping (env-steps/s)", description=BENCH_DESCRIPTION, epilog=BENCH_EPILOG, formatter_class=argparse.RawDescriptionHelpFormatter)
    bench.add_argument("--episodes", metavar="K", type=int_at_least(1), default=64, help="episodes per measurement (default: 64)")
    bench.add_argument("--threads", metavar="T", type=int_at_least(1, MAX_THREADS), default=None, help=f"the parallel measurement's thread count, 1 to {MAX_THREADS} (default: all cores)")
    bench.add_argument("--seed", metavar="S", type=int_at_least(0), default=0, help="first episode seed (default: 0)")
    bench.add_argument("--num-envs", metavar="E", type=int_at_least(1), default=64, help="worlds in the native batch measurement (default: 64)")
    bench.add_argument("--batch-steps", metavar="T", type=int_at_least(1), default=300, help="steps of the native batch per measurement (default: 300)")
    bench.add_argument("--json", action="store_true", help="print one JSON object on stdout instead of a table")
    bench.set_defaults(func=cmd_bench)
    return bench


def cmd_bench(args: argparse.Namespace, argv: Sequence[str]) -> None:
    check_seed(args.seed, "--seed", span=args.episodes)  # episode seeds S + k are u64
    params = _core.default_params()
    run_episodes(params, 1, args.seed, threads=1)  # warm-up: page in the code, start a pool
    rows = []
    for threads in dict.fromkeys((1, args.threads or usable_cores())):
        t0 = time.perf_counter()
        results = run_episodes(params, args.episodes, args.seed, threads=threads)
        seconds = time.perf_counter() - t0
        steps = sum(int(r["steps"]) for r in results)
        rows.append({"threads": threads, "episodes": args.episodes, "env_steps": steps, "seconds": seconds, "env_steps_per_second": steps / seconds, "episodes_per_second": args.episodes / seconds})
    batch = [_bench_batch(args.num_envs, args.batch_steps, threads, args.seed) for threads in dict.fromkeys((1, args.threads or usable_cores()))]
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

    env = BatchEnv(num_envs=num_envs, learners="wolves", seed=seed, threads=threads)
    plan = np.random.default_rng(seed).uniform(-1, 1, (steps, num_envs, env.n_wolves, 2)).astype(np.float32)
    env.reset(seed)
    t0 = time.perf_counter()
    for actions in CtrlC.checked(plan):
        env.step(actions)
    seconds = time.perf_counter() - t0
    return {"threads": threads, "num_envs": num_envs, "steps": steps, "env_steps": steps * num_envs, "seconds": seconds, "env_steps_per_second": steps * num_envs / seconds}
