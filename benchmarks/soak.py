#!/usr/bin/env python3
"""Soak benchmark (BENCHMARKS.md "Soak"): many native steps per wolf law, through the CLI and
through the batch, watching memory, finiteness and bounds. A benchmark, not a test: it takes
minutes and reports numbers.

For each law (seed000, bvc, formation):

* **cli** — ``wolfpack hunt --episodes K --wolves LAW --json`` in a subprocess, K chosen so that
  the run takes about ``--steps`` env-steps (from a 100-episode pilot); its RSS is sampled from
  ``/proc/PID/status`` every 0.25 s. The summary must be finite.
* **batch** — a subprocess steps ``_core.BatchEnv(num_envs=64, learners="none")`` with autoreset
  until ``--steps`` env-steps, checking every output array for non-finite values at every step and
  every agent's position against the arena every 500 steps, and reporting its own RSS.

RSS growth is the last sample minus the sample at 20 % of the run (after warm-up: pools,
allocator arenas, code pages). Usage::

    python benchmarks/soak.py                      # 10^7 steps per law and path (~15 min, 2 cores)
    python benchmarks/soak.py --steps 200000       # smoke run
    python benchmarks/soak.py --json
"""

from __future__ import annotations

import argparse
import inspect
import json
import os
import subprocess
import sys
import textwrap
import time

from wolfpack import _core

#: Every scripted wolf law, as the core names them.
LAWS = tuple(_core.WOLF_LAWS)


def rss_mb(pid: int | str = "self") -> float | None:
    try:
        with open(f"/proc/{pid}/status", encoding="ascii") as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024
    except OSError:
        return None
    return None


def growth(samples: list[float]) -> dict:
    """Warm RSS (at 20 % of the run), last and peak, and the growth after warm-up (MB)."""
    warm = samples[len(samples) // 5]
    return {"rss_warm_mb": round(warm, 1), "rss_last_mb": round(samples[-1], 1), "rss_peak_mb": round(max(samples), 1), "growth_mb": round(samples[-1] - warm, 1)}


def mean_episode_steps(law: str) -> float:
    from wolfpack import _core

    params = _core.validate_params({"policies": {"wolves": law}})
    results = _core.run_episodes(params, 10**6, 0, 100, None, False, None)
    return sum(r["steps"] for r in results) / len(results)


def soak_cli(law: str, steps: int, threads: int | None) -> dict:
    episodes = max(1, round(steps / mean_episode_steps(law)))
    cmd = [sys.executable, "-m", "wolfpack", "hunt", "--episodes", str(episodes), "--seed", "0", "--wolves", law, "--json"]
    if threads:
        cmd += ["--threads", str(threads)]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    samples = []
    while proc.poll() is None:
        r = rss_mb(proc.pid)
        if r is not None:
            samples.append(r)
        time.sleep(0.25)
    out, err = proc.communicate()
    seconds = time.perf_counter() - t0
    if proc.returncode != 0:
        raise SystemExit(f"soak cli {law}: exit {proc.returncode}: {err.strip()}")
    summary = json.loads(out)
    finite = all(v is None or isinstance(v, (int, str)) or v == v and abs(v) != float("inf") for v in summary.values())
    return {
        "law": law,
        "path": "cli",
        "episodes": episodes,
        "env_steps": summary["total_steps"],
        "seconds": round(seconds, 1),
        "env_steps_per_second": round(summary["total_steps"] / seconds),
        "finite": finite,
        "samples": len(samples),
        "capture_rate": summary["capture_rate"],
        **growth(samples or [0.0]),
    }


BATCH_CHILD = textwrap.dedent("""
    import json, sys, time
    import numpy as np
    from wolfpack import _core
    {rss_mb}
    law, steps, threads = {law!r}, {steps}, {threads}
    params = _core.validate_params({{"policies": {{"wolves": law}}}})
    num_envs = 64
    env = _core.BatchEnv(params, num_envs, "none", 0, True, threads)
    x0, y0, x1, y1 = params["world"]["border"]
    env.reset(0)
    samples, done, bad, outside, t0 = [], 0, 0, 0, time.perf_counter()
    k = 0
    while done < steps:
        out = env.step(None, None)
        for value in out.values():
            if value.dtype.kind == "f" and not np.isfinite(value).all():
                bad += 1
        if k % 500 == 0:
            for i in range(num_envs):
                w = env.world_state(i)
                for side in ("wolves", "targets"):
                    p = w[side][:, :2]
                    outside += int((~((p[:, 0] > x0) & (p[:, 0] < x1) & (p[:, 1] > y0) & (p[:, 1] < y1))).sum())
            samples.append(rss_mb())
        done += num_envs
        k += 1
    seconds = time.perf_counter() - t0
    samples.append(rss_mb())
    print(json.dumps({{"env_steps": done, "seconds": seconds, "non_finite_outputs": bad, "agents_outside": outside, "samples": samples}}))
""")


def soak_batch(law: str, steps: int, threads: int | None) -> dict:
    # The child measures its own memory with the same function (its source, not an import: the
    # child runs without this folder on its path).
    code = BATCH_CHILD.format(rss_mb=inspect.getsource(rss_mb), law=law, steps=steps, threads=threads)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    if proc.returncode != 0:
        raise SystemExit(f"soak batch {law}: exit {proc.returncode}: {proc.stderr.strip()[-2000:]}")
    r = json.loads(proc.stdout)
    return {
        "law": law,
        "path": "batch",
        "env_steps": r["env_steps"],
        "seconds": round(r["seconds"], 1),
        "env_steps_per_second": round(r["env_steps"] / r["seconds"]),
        "finite": r["non_finite_outputs"] == 0,
        "agents_outside": r["agents_outside"],
        "samples": len(r["samples"]),
        **growth(r["samples"]),
    }


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--steps", type=int, default=10_000_000, help="env-steps per law and path (default 10^7)")
    ap.add_argument("--laws", nargs="+", choices=LAWS, default=list(LAWS))
    ap.add_argument("--paths", nargs="+", choices=("cli", "batch"), default=["cli", "batch"])
    ap.add_argument("--threads", type=int, default=None, help="threads of the simulator (default: all cores)")
    ap.add_argument("--json", action="store_true", help="one JSON object instead of a table")
    args = ap.parse_args()
    rows = []
    for law in args.laws:
        for path in args.paths:
            row = (soak_cli if path == "cli" else soak_batch)(law, args.steps, args.threads)
            rows.append(row)
            if not args.json:
                print(
                    f"{law:<10} {path:<6} {row['env_steps']:>10} steps {row['seconds']:>7.1f} s {row['env_steps_per_second']:>8} /s  "
                    f"RSS warm {row['rss_warm_mb']:>6.1f} MB last {row['rss_last_mb']:>6.1f} peak {row['rss_peak_mb']:>6.1f} "
                    f"growth {row['growth_mb']:+.1f} MB  finite {row['finite']}  outside {row.get('agents_outside', '-')}",
                    flush=True,
                )
    load = os.getloadavg()
    report = {"rows": rows, "load_average": [round(x, 2) for x in load], "cpus": os.cpu_count()}
    if args.json:
        print(json.dumps(report))
    else:
        print(f"load average {load[0]:.2f} {load[1]:.2f} {load[2]:.2f}, {os.cpu_count()} CPUs")


if __name__ == "__main__":
    main()
