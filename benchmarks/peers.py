#!/usr/bin/env python3
"""wolfpack against its peers, measured in one run on one machine (see BENCHMARKS.md).

Measures, in this order:

1. **wolfpack** scripted stepping of the documented scenario (``params.yaml``: 5 seed000 wolves,
   1 escaping target, 12 obstacles) through ``wolfpack.run_episodes``: env-steps/s = summed
   episode steps / wall time, with 1 thread and with all cores.
2. **mpe2 simple_tag** (PettingZoo parallel API) at the same counts: 5 adversaries, 1 good
   agent, 12 obstacles, ``max_cycles`` larger than the run (no resets inside the timed loop),
   random continuous actions drawn up-front so the env, not the sampler, is timed; single
   process. An env-step is one ``env.step(actions)`` call moving every agent. Also timed: the
   same world's ``world.step()`` alone (physics without observations, rewards or wrappers).
3. **VMAS** ``simple_tag`` with the same counts, only if ``vmas`` (and torch) is importable.
4. The **published Python reference implementation**'s figure (docs/world-and-laws.md §1.7), quoted, not measured.

Usage::

    python benchmarks/peers.py            # full run (~2 min on 2 cores), table on stdout
    python benchmarks/peers.py --json     # the same as one JSON object on stdout
    python benchmarks/peers.py --quick    # smoke run (a few seconds)

Progress notes go to stderr, so ``--json`` output is clean.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
from importlib import metadata
from typing import Any, Callable

# mpe2 imports pygame, which otherwise prints a banner on stdout.
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

# docs/world-and-laws.md §1.7: the published Python reference implementation on the source scenario.
REFERENCE = {
    "name": "published Python reference implementation (docs/world-and-laws.md §1.7, quoted, not measured)",
    "env_steps_per_second": 42.0,
    "first_snapshot_range": [40.0, 45.0],
    "latest_snapshot_range": [115.0, 155.0],
    "note": "latest snapshot removed the feasibility checks (captured 14 of 20 runs)",
}

COUNTS = {"wolves": 5, "targets": 1, "obstacles": 12}


def note(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def version(pkg: str) -> str | None:
    try:
        return metadata.version(pkg)
    except metadata.PackageNotFoundError:
        return None


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def machine_info() -> dict:
    try:
        load = [round(x, 2) for x in os.getloadavg()]
    except OSError:
        load = None
    return {
        "cpu": cpu_model(),
        "cores": usable_cores(),
        "os": platform.platform(),
        "python": platform.python_version(),
        "load_average": load,
        "packages": {
            p: version(p) for p in ("wolfpack", "numpy", "mpe2", "pettingzoo", "gymnasium", "vmas", "torch")
        },
    }


def median_rate(runs: list[tuple[int, float]]) -> float:
    return statistics.median(steps / secs for steps, secs in runs)


# ---------------------------------------------------------------------------------------------
# wolfpack


def bench_wolfpack(episodes: int, threads: int | None, repeats: int, seed: int = 0) -> dict:
    import wolfpack

    params = wolfpack.load_params()
    wolfpack.run_episodes(params, min(episodes, 4), seed=seed, threads=threads)  # warm-up
    runs = []
    outcomes: dict[str, int] = {}
    for _ in range(repeats):
        t0 = time.perf_counter()
        results = wolfpack.run_episodes(params, episodes, seed=seed, threads=threads)
        secs = time.perf_counter() - t0
        runs.append((sum(int(r["steps"]) for r in results), secs))
    for r in results:
        outcomes[r["outcome"]] = outcomes.get(r["outcome"], 0) + 1
    return {
        "episodes": episodes,
        "threads": threads if threads is not None else usable_cores(),
        "total_steps": runs[-1][0],
        "seconds": [s for _, s in runs],
        "env_steps_per_second": median_rate(runs),
        "outcomes": outcomes,
    }


# ---------------------------------------------------------------------------------------------
# mpe2


def bench_mpe2(steps: int, repeats: int, seed: int = 0) -> dict:
    import numpy as np
    from mpe2 import simple_tag_v3

    env = simple_tag_v3.parallel_env(
        num_good=COUNTS["targets"],
        num_adversaries=COUNTS["wolves"],
        num_obstacles=COUNTS["obstacles"],
        max_cycles=steps + 10,
        continuous_actions=True,
        render_mode=None,
    )
    env.reset(seed=seed)
    rng = np.random.default_rng(seed)
    agents = list(env.agents)
    # All actions drawn before the clock starts: [steps, agents, 5] in the Box(0, 1, (5,)).
    table = {a: rng.random((steps, env.action_space(a).shape[0]), dtype=np.float32) for a in agents}
    plan = [{a: table[a][t] for a in agents} for t in range(steps)]
    for t in range(min(steps, 50)):  # warm-up
        env.step(plan[t])
    runs = []
    for _ in range(repeats):
        env.reset(seed=seed)
        t0 = time.perf_counter()
        done = 0
        for actions in plan:
            env.step(actions)
            done += 1
        runs.append((done, time.perf_counter() - t0))
    # The same world's physics alone (world.step(): forces, collisions, integration; no
    # observations, rewards or PettingZoo wrappers), holding the last actions: an upper
    # bound on what any API over this engine could reach.
    world = env.unwrapped.world
    physics = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        for _ in range(steps):
            world.step()
        physics.append((steps, time.perf_counter() - t0))
    env.close()
    return {
        "scenario": (
            f"simple_tag_v3.parallel_env(num_adversaries={COUNTS['wolves']}, num_good={COUNTS['targets']}, "
            f"num_obstacles={COUNTS['obstacles']}, continuous_actions=True)"
        ),
        "steps": steps,
        "seconds": [s for _, s in runs],
        "env_steps_per_second": median_rate(runs),
        "physics_only_env_steps_per_second": median_rate(physics),
    }


# ---------------------------------------------------------------------------------------------
# VMAS (optional: needs torch)


def bench_vmas(steps: int, num_envs: int, repeats: int, seed: int = 0) -> dict:
    import torch
    import vmas

    env = vmas.make_env(
        scenario="simple_tag",
        num_envs=num_envs,
        device="cpu",
        continuous_actions=True,
        seed=seed,
        max_steps=None,
        num_good_agents=COUNTS["targets"],
        num_adversaries=COUNTS["wolves"],
        num_landmarks=COUNTS["obstacles"],
    )
    env.reset()
    torch.manual_seed(seed)
    # Drawn up-front, within each agent's action range (VMAS's own sampler).
    plan = [[env.get_random_action(a) for a in env.agents] for _ in range(steps)]
    for actions in plan[: min(steps, 20)]:  # warm-up
        env.step(actions)
    runs = []
    for _ in range(repeats):
        env.reset()
        t0 = time.perf_counter()
        for actions in plan:
            env.step(actions)
        runs.append((steps * num_envs, time.perf_counter() - t0))
    return {
        "scenario": f"vmas simple_tag, num_envs={num_envs}, cpu, torch threads={torch.get_num_threads()}",
        "steps": steps * num_envs,
        "num_envs": num_envs,
        "seconds": [s for _, s in runs],
        "env_steps_per_second": median_rate(runs),
    }


# ---------------------------------------------------------------------------------------------


def attempt(name: str, fn: Callable[[], dict], optional: bool = False) -> dict:
    """Runs one peer benchmark; a missing package becomes a ``skipped`` entry, not a failure.
    For an ``optional`` peer (VMAS, untested here) any error is reported and skipped too."""
    try:
        return fn()
    except ImportError as e:
        note(f"[{name}] skipped: {e}")
        return {"skipped": f"not importable: {e}"}
    except Exception as e:  # noqa: BLE001 - an optional peer must not sink the run
        if not optional:
            raise
        note(f"[{name}] skipped after an error: {type(e).__name__}: {e}")
        return {"skipped": f"failed: {type(e).__name__}: {e}"}


def fmt_rate(x: float | None) -> str:
    return "-" if x is None else f"{x:,.0f}"


def table(report: dict) -> str:
    m = report["machine"]
    rows: list[tuple[str, str, str]] = []
    wp = report["wolfpack"]
    for key, label in (("threads_1", "wolfpack scripted, 1 thread"), ("threads_all", f"wolfpack scripted, {wp['threads_all']['threads']} threads")):
        r = wp[key]
        rows.append((label, fmt_rate(r["env_steps_per_second"]), f"{r['episodes']} episodes, {r['total_steps']} steps"))
    for key, label in (("mpe2", "mpe2 simple_tag (1 process)"), ("vmas", "VMAS simple_tag (cpu)")):
        r = report[key]
        if "skipped" in r:
            rows.append((label, "-", "skipped: " + r["skipped"]))
        else:
            rows.append((label, fmt_rate(r["env_steps_per_second"]), f"{r['steps']} steps"))
            if "physics_only_env_steps_per_second" in r:
                rows.append(("  mpe2 world.step() only", fmt_rate(r["physics_only_env_steps_per_second"]), "physics alone: no obs, rewards, wrappers"))
    ref = report["reference"]
    rows.append((
        "Python reference impl. (quoted)",
        f"~{ref['env_steps_per_second']:.0f}",
        f"first snapshot {ref['first_snapshot_range'][0]:.0f}-{ref['first_snapshot_range'][1]:.0f}, "
        f"latest {ref['latest_snapshot_range'][0]:.0f}-{ref['latest_snapshot_range'][1]:.0f}",
    ))
    w0 = max(len(r[0]) for r in rows)
    w1 = max(len("env-steps/s"), *(len(r[1]) for r in rows))
    out = [
        f"machine: {m['cpu']}, {m['cores']} cores, Python {m['python']}, load {m['load_average']}",
        "packages: " + ", ".join(f"{k} {v}" for k, v in m["packages"].items() if v),
        f"scenario: {COUNTS['wolves']} pursuers, {COUNTS['targets']} evader, {COUNTS['obstacles']} obstacles",
        "",
        f"{'simulator':<{w0}}  {'env-steps/s':>{w1}}  notes",
        f"{'-' * w0}  {'-' * w1}  -----",
    ]
    out += [f"{a:<{w0}}  {b:>{w1}}  {c}" for a, b, c in rows]
    out.append("")
    for k, v in report["ratios"].items():
        out.append(f"{k}: {'-' if v is None else f'{v:,.0f}x'}")
    return "\n".join(out)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smoke run: few episodes and steps, one repeat")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    ap.add_argument("--episodes", type=int, default=None, help="wolfpack episodes per run (default 200; quick 10)")
    ap.add_argument("--mpe2-steps", type=int, default=None, help="mpe2 env-steps per run (default 5000; quick 300)")
    ap.add_argument("--vmas-steps", type=int, default=None, help="VMAS steps per run (default 500; quick 20)")
    ap.add_argument("--vmas-envs", type=int, default=1, help="VMAS vectorised envs (default 1)")
    ap.add_argument("--repeats", type=int, default=None, help="timed repeats, median reported (default 3; quick 1)")
    ap.add_argument("--skip", default="", help="comma list of peers to skip: mpe2,vmas")
    args = ap.parse_args(argv)

    episodes = args.episodes or (10 if args.quick else 200)
    mpe2_steps = args.mpe2_steps or (300 if args.quick else 5000)
    vmas_steps = args.vmas_steps or (20 if args.quick else 500)
    repeats = args.repeats or (1 if args.quick else 3)
    skip = {s.strip() for s in args.skip.split(",") if s.strip()}

    report: dict[str, Any] = {"machine": machine_info(), "quick": args.quick}
    note(f"[wolfpack] {episodes} episodes x {repeats}, 1 thread ...")
    one = bench_wolfpack(episodes, 1, repeats)
    note(f"[wolfpack] {episodes} episodes x {repeats}, all cores ...")
    all_ = bench_wolfpack(episodes, None, repeats)
    report["wolfpack"] = {"scenario": "params.yaml (documented scenario)", "threads_1": one, "threads_all": all_}

    if "mpe2" in skip:
        report["mpe2"] = {"skipped": "--skip mpe2"}
    else:
        note(f"[mpe2] {mpe2_steps} steps x {repeats} ...")
        report["mpe2"] = attempt("mpe2", lambda: bench_mpe2(mpe2_steps, repeats))
    if "vmas" in skip:
        report["vmas"] = {"skipped": "--skip vmas"}
    else:
        note(f"[vmas] {vmas_steps} steps x {args.vmas_envs} envs x {repeats} ...")
        report["vmas"] = attempt("vmas", lambda: bench_vmas(vmas_steps, args.vmas_envs, repeats), optional=True)
    report["reference"] = REFERENCE

    mpe = report["mpe2"].get("env_steps_per_second")
    ref = REFERENCE["env_steps_per_second"]
    report["ratios"] = {
        "wolfpack(1 thread) / mpe2": one["env_steps_per_second"] / mpe if mpe else None,
        "wolfpack(all cores) / mpe2": all_["env_steps_per_second"] / mpe if mpe else None,
        "wolfpack(1 thread) / mpe2 world.step() only": (
            one["env_steps_per_second"] / report["mpe2"]["physics_only_env_steps_per_second"] if mpe else None
        ),
        "wolfpack(1 thread) / reference": one["env_steps_per_second"] / ref,
        "wolfpack(all cores) / reference": all_["env_steps_per_second"] / ref,
    }
    report["machine"]["load_average_after"] = [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else None

    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(table(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
