#!/usr/bin/env python3
"""wolfpack inside other training stacks: env-steps/s each reaches, in one run (BENCHMARKS.md).

The documented scenario (5 wolves, 1 target, 12 obstacles), random actions drawn by the stack's
own action spaces or before the clock, one core for the simulator (``threads=1``). An env-step is
one world advancing one step. Rows:

1. native: ``make_vec_env(num_envs=8, threads=1)`` (SB3 VecEnv, wolves learning) — the baseline;
   and the single-world ``parallel_env``.
2. Gymnasium: ``gymnasium.make_vec("wolfpack/Escape-v0", num_envs=8)``, sync and async (one
   subprocess per world).
3. TorchRL: ``PettingZooWrapper(parallel_env(learners="both")).rollout`` and
   ``GymEnv("wolfpack/Escape-v0").rollout`` (random policy, auto-reset).
4. SuperSuit: ``concat_vec_envs_v1(pettingzoo_env_to_vec_env_v1(parallel_env(learners="both",
   shared_space=True)), 8, base_class="stable_baselines3")``.

RLlib is measured by ``training/rllib_train.py`` itself (its ``progress.csv``; it needs its own
virtualenv), see BENCHMARKS.md. Each row also reports where the time goes, by timing the
wolfpack call the stack makes (``_core.BatchEnv.step``, the Rust step with the GIL released)
inside the stack's own step.

Usage::

    python benchmarks/stacks.py              # table, about a minute on 2 cores
    python benchmarks/stacks.py --json
    python benchmarks/stacks.py --quick      # smoke run
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
import warnings
from contextlib import contextmanager
from typing import Callable

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

import numpy as np
import wolfpack
from machine import machine_info
from wolfpack import _core


@contextmanager
def native_clock():
    """Times every call of the native batch step made inside the block (in this process)."""
    spent = [0.0]
    original = _core.BatchEnv.step

    def timed(self, *args, **kwargs):
        t0 = time.perf_counter()
        try:
            return original(self, *args, **kwargs)
        finally:
            spent[0] += time.perf_counter() - t0

    _core.BatchEnv.step = timed
    try:
        yield spent
    finally:
        _core.BatchEnv.step = original


def measure(name: str, run: Callable[[float], int], seconds: float, in_process: bool = True) -> dict:
    """``run(seconds)`` steps for about ``seconds`` and returns env-steps taken."""
    run(min(0.5, seconds / 4))  # warm-up
    with native_clock() as native:
        t0 = time.perf_counter()
        steps = run(seconds)
        wall = time.perf_counter() - t0
    row = {"stack": name, "env_steps": steps, "seconds": round(wall, 3), "env_steps_per_second": steps / wall}
    row["native_share"] = native[0] / wall if in_process else None
    return row


def vector_runner(step: Callable[[np.ndarray], object], slots: int, worlds: int) -> Callable[[float], int]:
    """``run(seconds)`` for a vector env: ``step`` with 64 pre-drawn random action batches of
    ``slots`` × 2, in turn; each call advances ``worlds`` worlds one step."""
    plan = np.random.default_rng(0).uniform(-1, 1, (64, slots, 2)).astype(np.float32)

    def run(seconds: float) -> int:
        calls, t_end = 0, time.perf_counter() + seconds
        while time.perf_counter() < t_end:
            step(plan[calls % 64])
            calls += 1
        return calls * worlds

    return run


def rollout_runner(env, length: int = 100) -> Callable[[float], int]:
    """``run(seconds)`` for a TorchRL env: random-policy rollouts of ``length`` steps that reset
    finished episodes and go on."""

    def run(seconds: float) -> int:
        steps, t_end = 0, time.perf_counter() + seconds
        while time.perf_counter() < t_end:
            env.rollout(length, break_when_any_done=False)
            steps += length
        return steps

    return run


def run_vec_env(num_envs: int) -> Callable[[float], int]:
    venv = wolfpack.make_vec_env(num_envs=num_envs, learners="wolves", seed=0, threads=1)
    venv.reset()
    return vector_runner(venv.step, venv.num_envs, num_envs)


def run_parallel_env() -> Callable[[float], int]:
    env = wolfpack.parallel_env(learners="wolves")
    env.reset(seed=0)
    acts = np.random.default_rng(0).uniform(-1, 1, (64, 5, 2)).astype(np.float32)

    def run(seconds: float) -> int:
        steps, t_end = 0, time.perf_counter() + seconds
        while time.perf_counter() < t_end:
            if not env.agents:
                env.reset()
            a = acts[steps % 64]
            env.step({agent: a[i] for i, agent in enumerate(env.agents)})
            steps += 1
        return steps

    return run


def run_gymnasium(mode: str, num_envs: int):
    import gymnasium

    envs = gymnasium.make_vec("wolfpack/Escape-v0", num_envs=num_envs, vectorization_mode=mode)
    envs.reset(seed=0)
    return vector_runner(envs.step, num_envs, num_envs), envs


def run_torchrl_pettingzoo():
    from torchrl.envs.libs.pettingzoo import PettingZooWrapper

    return rollout_runner(PettingZooWrapper(wolfpack.parallel_env(learners="both"), use_mask=True))


def run_torchrl_gym():
    from torchrl.envs.libs.gym import GymEnv

    return rollout_runner(GymEnv("wolfpack/Escape-v0"))


def run_supersuit(copies: int):
    import supersuit as ss

    venv = ss.pettingzoo_env_to_vec_env_v1(wolfpack.parallel_env(learners="both", shared_space=True))
    venv = ss.concat_vec_envs_v1(venv, copies, num_cpus=0, base_class="stable_baselines3")
    venv.reset()
    return vector_runner(venv.step, venv.num_envs, copies)


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--seconds", type=float, default=4.0, help="timed seconds per row (default 4)")
    p.add_argument("--num-envs", type=int, default=8, help="worlds of the vectorised rows (default 8)")
    p.add_argument("--quick", action="store_true", help="0.3 s per row (smoke run)")
    p.add_argument("--json", action="store_true")
    args = p.parse_args(argv)
    seconds = 0.3 if args.quick else args.seconds
    warnings.filterwarnings("ignore")
    e = args.num_envs
    rows = [
        measure(f"native make_vec_env(num_envs={e}, threads=1)", run_vec_env(e), seconds),
        measure("native parallel_env (one world)", run_parallel_env(), seconds),
    ]
    for mode in ("sync", "async"):
        run, envs = run_gymnasium(mode, e)
        try:
            rows.append(measure(f"gymnasium.make_vec(Escape-v0, {e}, {mode})", run, seconds, in_process=(mode == "sync")))
        finally:
            envs.close()
    for name, make in (("TorchRL PettingZooWrapper(parallel_env(learners='both')).rollout", run_torchrl_pettingzoo), ("TorchRL GymEnv(Escape-v0).rollout", run_torchrl_gym)):
        try:
            rows.append(measure(name, make(), seconds))
        except ImportError as err:
            rows.append({"stack": name, "skipped": str(err)})
    try:
        rows.append(measure(f"SuperSuit concat_vec_envs_v1({e} x parallel_env(all, shared_space))", run_supersuit(e), seconds))
    except ImportError as err:
        rows.append({"stack": "SuperSuit", "skipped": str(err)})
    report = {"machine": machine_info(), "load_1min": os.getloadavg()[0], "seconds_per_row": seconds, "rows": rows}
    if args.json:
        print(json.dumps(report))
        return 0
    base = rows[0]["env_steps_per_second"]
    print(f"{'stack':<72} {'env-steps/s':>12} {'vs native':>10} {'in the Rust step':>17}")
    for r in rows:
        if "skipped" in r:
            print(f"{r['stack']:<72} skipped: {r['skipped']}")
            continue
        share = "-" if r["native_share"] is None else f"{100 * r['native_share']:.0f} %"
        print(f"{r['stack']:<72} {r['env_steps_per_second']:>12,.0f} {r['env_steps_per_second'] / base:>9.3f}x {share:>17}")
    print(f"load (1 min) {report['load_1min']:.2f}; {seconds:g} s per row")
    return 0


if __name__ == "__main__":
    sys.exit(main())
