#!/usr/bin/env python3
"""The learning interface against its peers, in one run on one machine (see BENCHMARKS.md).

Same counts everywhere: 5 pursuers, 1 evader, 12 obstacles; random actions drawn before the
clock starts, so the envs, not the samplers, are timed. An env-step is one world advancing one
step (a batch of 64 worlds stepping once is 64 env-steps).

1. **wolfpack** ``make_vec_env(num_envs=64)`` (SB3 VecEnv, wolves learning, scripted escape
   target), with 1 thread and with all cores; the same through ``BatchEnv`` directly (no SB3
   layer); and the single-world PettingZoo ``parallel_env``.
2. **mpe2** ``simple_tag_v3.parallel_env`` (one world, PettingZoo parallel API).
3. **VMAS** ``simple_tag`` on CPU with 64 vectorised worlds, if ``vmas`` is importable.
4. Where the VecEnv's time goes: the native ``step`` call (Rust, GIL released) vs the Python
   around it (argument checks, reshapes, the SB3 ``infos`` dicts).

Usage::

    python benchmarks/learning.py            # table (about 1 min on 2 cores)
    python benchmarks/learning.py --json
    python benchmarks/learning.py --quick    # smoke run
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from typing import Any

# numpy's OpenBLAS worker threads busy-wait on a 2-core machine and steal time from the
# simulators' own threads (12% of the samples in a perf profile); nothing here uses BLAS.
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
from machine import machine_info, usable_cores
from peer_contenders import attempt, bench_mpe2, bench_vmas, median_rate, note
from peer_scenarios import COUNTS


def bench_vec_env(num_envs: int, steps: int, threads: int | None, repeats: int) -> dict:
    import wolfpack

    venv = wolfpack.make_vec_env(num_envs=num_envs, learners="wolves", seed=0, threads=threads)
    rng = np.random.default_rng(0)
    plan = rng.uniform(-1, 1, (steps, venv.num_envs, 2)).astype(np.float32)
    venv.reset()
    for a in plan[:20]:
        venv.step(a)
    runs, native = [], []
    core = venv.batch._core
    for _ in range(repeats):
        venv.reset()
        t0 = time.perf_counter()
        for a in plan:
            venv.step(a)
        runs.append((steps * num_envs, time.perf_counter() - t0))
        # The native call alone on the same actions (the Rust share of the VecEnv step).
        core.reset(0)
        shaped = [np.ascontiguousarray(a.reshape(num_envs, -1, 2)) for a in plan]
        t0 = time.perf_counter()
        for a in shaped:
            core.step(a, None)
        native.append((steps * num_envs, time.perf_counter() - t0))
    rate, native_rate = median_rate(runs), median_rate(native)
    return {
        "num_envs": num_envs,
        "slots": venv.num_envs,
        "threads": threads or usable_cores(),
        "steps": steps * num_envs,
        "env_steps_per_second": rate,
        "batch_env_steps_per_second": native_rate,
        "native_share_of_step": rate / native_rate,
    }


def bench_parallel_env(steps: int, repeats: int) -> dict:
    import wolfpack

    env = wolfpack.parallel_env(learners="wolves", **{"world.max_steps": steps + 10})
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    agents = list(env.agents)
    table = rng.uniform(-1, 1, (steps, len(agents), 2)).astype(np.float32)
    plan = [dict(zip(agents, row)) for row in table]
    runs = []
    for _ in range(repeats):
        env.reset(seed=0)
        t0 = time.perf_counter()
        done = 0
        for actions in plan:
            if not env.agents:  # a collision ended the episode: start another, untimed cost is tiny
                env.reset()
            env.step(actions)
            done += 1
        runs.append((done, time.perf_counter() - t0))
    return {"steps": steps, "env_steps_per_second": median_rate(runs)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smoke run: few steps, one repeat")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    ap.add_argument("--num-envs", type=int, default=64, help="worlds in the batch (default 64)")
    ap.add_argument("--skip", default="", help="comma list of peers to skip: mpe2,vmas")
    args = ap.parse_args(argv)
    quick = args.quick
    repeats = 1 if quick else 3
    vec_steps = 20 if quick else 300
    par_steps = 100 if quick else 3000
    mpe2_steps = 50 if quick else 3000
    vmas_steps = 5 if quick else 200
    skip = {s.strip() for s in args.skip.split(",") if s.strip()}
    e = args.num_envs

    report: dict[str, Any] = {"machine": machine_info(), "quick": quick, "counts": COUNTS}
    note(f"[wolfpack] make_vec_env({e}) 1 thread ...")
    report["vec_env_1_thread"] = bench_vec_env(e, vec_steps, 1, repeats)
    note(f"[wolfpack] make_vec_env({e}) all cores ...")
    report["vec_env_all_cores"] = bench_vec_env(e, vec_steps, None, repeats)
    note("[wolfpack] parallel_env (1 world) ...")
    report["parallel_env"] = bench_parallel_env(par_steps, repeats)
    report["mpe2"] = {"skipped": "--skip mpe2"} if "mpe2" in skip else attempt("mpe2", lambda: bench_mpe2(mpe2_steps, repeats))
    if "vmas" in skip:
        report["vmas"] = {"skipped": "--skip vmas"}
    else:
        note(f"[vmas] simple_tag num_envs={e} ...")
        report["vmas"] = attempt("vmas", lambda: bench_vmas(vmas_steps, e, repeats), optional=True)

    mpe = report["mpe2"].get("env_steps_per_second")
    vm = report["vmas"].get("env_steps_per_second")
    ratio = lambda a, b: a / b if b else None  # noqa: E731
    report["ratios"] = {
        f"make_vec_env({e}), 1 thread / mpe2": ratio(report["vec_env_1_thread"]["env_steps_per_second"], mpe),
        f"make_vec_env({e}), all cores / mpe2": ratio(report["vec_env_all_cores"]["env_steps_per_second"], mpe),
        "parallel_env / mpe2": ratio(report["parallel_env"]["env_steps_per_second"], mpe),
        f"make_vec_env({e}), all cores / VMAS({e})": ratio(report["vec_env_all_cores"]["env_steps_per_second"], vm),
    }
    if args.json:
        print(json.dumps(report, indent=2))
        return 0
    m = report["machine"]
    print(f"machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, load {m['load_average']}")
    print(f"scenario: {COUNTS['wolves']} pursuers, {COUNTS['targets']} evader, {COUNTS['obstacles']} obstacles; random actions\n")
    rows = [
        (f"wolfpack make_vec_env({e}), 1 thread", report["vec_env_1_thread"]),
        (f"wolfpack make_vec_env({e}), {report['vec_env_all_cores']['threads']} threads", report["vec_env_all_cores"]),
    ]
    print(f"{'simulator':<44} {'env-steps/s':>12}  notes")
    for label, r in rows:
        print(f"{label:<44} {r['env_steps_per_second']:>12,.0f}  native BatchEnv.step alone {r['batch_env_steps_per_second']:,.0f}; native share {r['native_share_of_step']:.0%}")
    print(f"{'wolfpack parallel_env (1 world)':<44} {report['parallel_env']['env_steps_per_second']:>12,.0f}")
    for key, label in (("mpe2", "mpe2 simple_tag parallel_env (1 world)"), ("vmas", f"VMAS simple_tag cpu, {e} worlds")):
        r = report[key]
        print(f"{label:<44} {'-' if 'skipped' in r else format(r['env_steps_per_second'], ',.0f'):>12}  {r.get('skipped', '')}")
    print()
    for k, v in report["ratios"].items():
        print(f"{k}: {'-' if v is None else f'{v:,.0f}x'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
