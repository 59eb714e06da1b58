#!/usr/bin/env python3
"""The TorchRL view's rate beside the batch it wraps: what a TorchRL or BenchMARL user gets from
``wolfpack.torchrl_env.WolfpackEnv`` against ``wolfpack.BatchEnv`` itself.

For each batch size E, on the same worlds (wolves learning, scripted target, fixed random
actions):

- **batch**: ``BatchEnv(num_envs=E).step(actions)`` (numpy in, a dict of numpy arrays out);
- **torchrl**: ``WolfpackEnv(num_envs=E).step_and_maybe_reset(td)`` — the call TorchRL's
  collectors make every step: the step, its ``"next"`` entries, and the reset of the worlds
  whose episode ended.

The two alternate ``--repeats`` times; the table gives the median env-steps/s of each and their
ratio (the view's aim: at least half the batch's rate from E = 256 up). Results in
BENCHMARKS.md, "The TorchRL view".

    python benchmarks/torchrl_view.py                       # E = 256, 1,024; 5 repeats of 2 s
    python benchmarks/torchrl_view.py --sizes 64 256 1024 4096 --json
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time

import numpy as np
import torch
from machine import machine_info
from under_load import rate as batch_rate  #  (the same timing of BatchEnv.step)
from wolfpack import BatchEnv
from wolfpack.torchrl_env import WolfpackEnv


def view_rate(env: WolfpackEnv, td, actions: torch.Tensor, seconds: float):
    """env-steps/s of the collectors' step (``step_and_maybe_reset``) over about ``seconds``;
    returns the rate and the root tensordict to go on from."""
    for _ in range(3):
        td["wolves", "action"] = actions
        _, td = env.step_and_maybe_reset(td)
    calls, start = 0, time.perf_counter()
    while (elapsed := time.perf_counter() - start) < seconds:
        td["wolves", "action"] = actions
        _, td = env.step_and_maybe_reset(td)
        calls += 1
    return calls * env.batch_size[0] / elapsed, td


def measure(sizes: list[int], repeats: int, seconds: float, threads: int | None) -> dict:
    out: dict = {}
    for e in sizes:
        batch = BatchEnv(num_envs=e, learners="wolves", seed=0, threads=threads)
        view = WolfpackEnv(num_envs=e, learners="wolves", seed=0, threads=threads)
        actions = np.random.default_rng(0).uniform(-1, 1, (e, batch.n_wolves, 2)).astype(np.float32)
        batch.reset(seed=0)
        td = view.reset()
        out[e] = {"batch": [], "torchrl": []}
        for _ in range(repeats):
            out[e]["batch"].append(batch_rate(batch, actions, seconds))
            r, td = view_rate(view, td, torch.from_numpy(actions), seconds)
            out[e]["torchrl"].append(r)
        del batch, view
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--sizes", type=int, nargs="+", default=[256, 1024], help="batch sizes E (default 256 1024)")
    p.add_argument("--repeats", type=int, default=5)
    p.add_argument("--seconds", type=float, default=2.0, help="seconds per timing (default 2)")
    p.add_argument("--threads", type=int, default=None, help="the batch's threads (default: all cores)")
    p.add_argument("--json", action="store_true", help="print the JSON document instead of the table")
    args = p.parse_args(argv)
    if any(e < 1 for e in args.sizes) or args.repeats < 1 or not args.seconds > 0:
        p.error("--sizes, --repeats must be >= 1 and --seconds > 0")
    torch.set_num_threads(1)  # the view's own tensor work is small; the batch has the cores
    rates = measure(args.sizes, args.repeats, args.seconds, args.threads)
    doc = {
        "machine": machine_info(),
        "threads": args.threads,
        "repeats": args.repeats,
        "seconds": args.seconds,
        "torchrl": __import__("torchrl").__version__,
        "sizes": {str(e): {k: {"median": statistics.median(v), "runs": v} for k, v in r.items()} for e, r in rates.items()},
    }
    if args.json:
        print(json.dumps(doc, indent=1))
        return 0
    print("| E | BatchEnv.step, env-steps/s | WolfpackEnv (TorchRL), env-steps/s | view / batch |")
    print("|---|---|---|---|")
    for e, r in doc["sizes"].items():
        b, v = r["batch"]["median"], r["torchrl"]["median"]
        print(f"| {int(e):,} | {b / 1e3:.0f} k | {v / 1e3:.0f} k | {v / b:.2f} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
