#!/usr/bin/env python3
"""The set network's cost against the flat MLP: one PPO rollout and one update of the wolves'
default recipe (256 worlds of hunt-v1 × 64 steps, MAPPO), timed part by part in one process.

For each network — the flat MLP on the flat observation, and the set network on entity
observations with each pooling (``mean_max``, ``attention``) — this times, after a warm-up
rollout: the batch's steps, the learner's forward passes in the rollout (``act``), and one
update (4 epochs of minibatches of 8,192). Agent-steps/s is the rollout's agent-steps over the
three together: what ``wolfpack train`` reaches end to end, evaluations excluded.

    python benchmarks/set_network.py                  # a table
    python benchmarks/set_network.py --json --out benchmarks/results/set-network-2core.json

Nothing here asserts a speed; the numbers are what the machine gave (note its load).
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from pathlib import Path

from wolfpack.learn.run import keep_freed_memory, prefer_passive_omp

# As `wolfpack train` sets up its process, before torch loads: OpenMP threads that sleep while
# they wait, and freed tensors kept in the heap (without it every minibatch faults its tensors'
# pages in afresh, and the set network's update took half as long again).
prefer_passive_omp()
keep_freed_memory()

import numpy as np  # noqa: E402
import torch  # noqa: E402
import wolfpack  # noqa: E402
from machine import machine_info  # noqa: E402
from wolfpack.batch import entity_shape  # noqa: E402
from wolfpack.learn.ppo import SideLearner  # noqa: E402
from wolfpack.learn.recipes import params_overrides, recipe  # noqa: E402

VARIANTS = {"flat MLP": {}, "set network, mean_max": {"network": "entities", "pool": "mean_max"}, "set network, attention": {"network": "entities", "pool": "attention"}}


def measure(name: str, hp: dict, threads: int, task: str, updates: int) -> dict:
    r = recipe("wolves", "mappo", hp)
    batch = wolfpack.BatchEnv(task=task, num_envs=int(r["num_envs"]), learners="wolves", seed=0, threads=threads, with_state=True, **params_overrides("wolves", r))
    shape = entity_shape("wolves", batch.params)
    torch.manual_seed(0)
    learner = SideLearner(
        "wolves",
        "mappo",
        r,
        obs_dim=batch.wolf_obs_dim,
        state_dim=batch.state_dim,
        agents=batch.n_wolves,
        num_envs=batch.num_envs,
        entity_shape=(*shape, len(wolfpack.ENTITY_STATE_FIELDS)) if shape else None,
        device=torch.device("cpu"),
        generator=torch.Generator().manual_seed(0),
        side_by_side=threads >= 2,
    )
    out, buffers = batch.reset(), batch.new_outputs()
    times = {"step_s": [], "act_s": [], "update_s": []}
    for k in range(updates + 1):  # the first is a warm-up
        torch.set_num_threads(1)
        step_s = act_s = 0.0
        for t in range(learner.n_steps):
            t0 = time.perf_counter()
            actions = learner.act(t, out["obs_wolves"], out["state"])
            t1 = time.perf_counter()
            out = batch.step(actions, out=buffers)
            t2 = time.perf_counter()
            learner.record(t, out["rewards_wolves"], torch.from_numpy(out["terminated"] | out["truncated"]))
            act_s, step_s = act_s + t1 - t0, step_s + t2 - t1
        learner.finish_rollout(out["obs_wolves"], out["state"])
        torch.set_num_threads(threads // 2 if threads >= 2 else 1)
        t0 = time.perf_counter()
        learner.update()
        if k:
            times["step_s"].append(step_s)
            times["act_s"].append(act_s)
            times["update_s"].append(time.perf_counter() - t0)
    med = {k: float(np.median(v)) for k, v in times.items()}
    samples = learner.n_steps * batch.num_envs * batch.n_wolves
    return {"network": name, "hp": hp, "obs_dim": batch.wolf_obs_dim, **med, "agent_steps_per_s": samples / sum(med.values())}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="set_network.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--threads", type=int, default=2, help="the batch's threads; the update's actor and critic side by side on one each (default 2)")
    p.add_argument("--task", default="hunt-v1")
    p.add_argument("--updates", type=int, default=3, help="timed updates per network, the median kept (default 3)")
    p.add_argument("--json", action="store_true")
    p.add_argument("--out", default=None, help="also write the JSON here")
    args = p.parse_args(argv)
    rows = [measure(name, hp, args.threads, args.task, args.updates) for name, hp in VARIANTS.items()]
    doc = {"task": args.task, "threads": args.threads, "updates": args.updates, "machine": machine_info(), "load_before": os.getloadavg()[0], "rows": rows}
    if args.out:
        Path(args.out).write_text(json.dumps(doc, indent=1) + "\n")
    if args.json:
        print(json.dumps(doc))
        return 0
    print(f"{args.task}, 256 worlds x 64 steps, MAPPO wolves, {args.threads} threads; {doc['machine'].get('cpu', '')}")
    print("| network | D | batch steps s | forward passes s | update s | agent-steps/s |")
    print("|---|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['network']} | {r['obs_dim']} | {r['step_s']:.2f} | {r['act_s']:.2f} | {r['update_s']:.2f} | {r['agent_steps_per_s'] / 1000:.1f} k |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
