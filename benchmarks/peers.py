#!/usr/bin/env python3
"""wolfpack against its peers, measured interleaved in one run on one machine (see BENCHMARKS.md).

Every contender is prepared first (built, warmed up, its step count sized), then measured once
per round, round-robin, for ``--repeats`` rounds (the order rotates between rounds), so that
whatever else loads the machine hits every contender alike; the median over rounds is reported,
with the load average before and after each round. An env-step is one world advanced one step:
one call on a batch of E worlds is E env-steps. Same counts everywhere: 5 pursuers (wolves,
adversaries), 1 evader (target, good agent), 12 obstacles (landmarks).

Per batch size E (``--sizes``, default 1,64,1024,8192):

1. **wolfpack BatchEnv**: ``BatchEnv(num_envs=E, learners="wolves", seed=0, threads=t)``
   (autoreset on, its default), ``step`` with zero wolf actions [E, 5, 2] float32; observations,
   rewards and infos for every world each step; t in ``--threads`` (default 1,2).
2. **wolfpack make_vec_env**: ``make_vec_env(num_envs=E, learners="wolves", threads=t)``, the
   SB3 VecEnv over the same batch, ``step`` with zero actions [E*5, 2] (its 5E slots).
3. **VMAS** ``simple_tag`` on CPU, ``num_envs=E`` (torch's default threads).
4. **JaxMARL** MPE ``SimpleTagMPE`` on CPU: (a) a Python loop over ``jax.jit(jax.vmap(env.step))``
   with ``block_until_ready`` every step; (b) a ``jax.lax.scan`` of T steps of the vmapped step
   under one ``jax.jit`` (E*T env-steps / wall time; compile time excluded, reported apart).

VMAS and JaxMARL run in ``.venv-peers`` (``benchmarks/peers_venv.sh``) through
``benchmarks/peer_worker.py``, one worker process per peer that this script drives over a pipe;
without that venv their rows are skipped (``--make-venv`` builds it first). Random actions for
both, drawn before the clock starts.

Once per run (no batch size):

5. **wolfpack scripted** episodes of the documented scenario through ``wolfpack.run_episodes``
   (what ``wolfpack hunt`` runs), 200 episodes, 1 thread and all cores.
6. **mpe2 simple_tag** (PettingZoo parallel API, one world: E = 1 only), 5000 ``env.step``
   calls with random actions drawn up-front; and its ``world.step()`` alone (physics only).
7. The **published Python reference implementation**'s figure, quoted, not measured.

Steps per measurement are sized during the warm-up so that each takes about ``--seconds``
(default 1.5 s; fewer steps at large E). Usage::

    python benchmarks/peers.py                 # full run (~5 min on 2 cores), tables on stdout
    python benchmarks/peers.py --json          # the same as one JSON object on stdout
    python benchmarks/peers.py --quick         # smoke run (E = 1, 64; short measurements)
    python benchmarks/peers.py --make-venv     # build .venv-peers first if missing

Progress notes go to stderr, so ``--json`` output is clean. This file is the command line; the
contenders and how each is run are in ``peer_contenders.py``, the tables in ``peer_tables.py``,
what describes the machine and its load in ``machine.py``.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import sys
import time
from typing import Any

from machine import cpu_ticks, loadavg, machine_info, others_share
from peer_contenders import ROOT, Batch, Contender, Mpe2, Mpe2Physics, Remote, Scripted, note, peers_python, start_workers
from peer_scenarios import COUNTS
from peer_tables import rate, ratio, size_ratios, tables

# docs/world-and-laws.md §1.7: the published Python reference implementation on the source scenario.
REFERENCE = {
    "name": "published Python reference implementation (docs/world-and-laws.md §1.7, quoted, not measured)",
    "env_steps_per_second": 42.0,
    "first_snapshot_range": [40.0, 45.0],
    "latest_snapshot_range": [115.0, 155.0],
    "note": "latest snapshot removed the feasibility checks (captured 14 of 20 runs)",
}

DEFAULT_SIZES = "1,64,1024,8192"


def parse_ints(text: str, what: str) -> list[int]:
    try:
        vals = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise SystemExit(f"{what}: expected a comma list of integers, got {text!r}") from None
    if not vals or min(vals) < 1:
        raise SystemExit(f"{what}: expected positive integers, got {text!r}")
    return vals


SKIPPABLE = ("scripted", "batch", "vec", "mpe2", "vmas", "jaxmarl", "jaxmarl_loop", "jaxmarl_scan")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smoke run: E = 1,64 (VMAS, JaxMARL at the first only), short measurements, one round")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of the tables")
    ap.add_argument("--sizes", default=None, help=f"batch sizes E, comma list (default {DEFAULT_SIZES}; quick 1,64)")
    ap.add_argument("--threads", default="1,2", help="wolfpack batch threads, comma list (default 1,2)")
    ap.add_argument("--seconds", type=float, default=None, help="target seconds per measurement (default 1.5; quick 0.05)")
    ap.add_argument("--episodes", type=int, default=None, help="wolfpack scripted episodes per run (default 200; quick 10)")
    ap.add_argument("--mpe2-steps", type=int, default=None, help="mpe2 env-steps per run (default 5000; quick 300)")
    ap.add_argument("--vmas-steps", type=int, default=None, help="VMAS steps per run at every E (default: sized like the others)")
    ap.add_argument("--repeats", type=int, default=None, help="interleaved rounds, median reported (default 3; quick 1)")
    ap.add_argument("--skip", default="", help=f"comma list of contenders to skip: {','.join(SKIPPABLE)}")
    ap.add_argument("--make-venv", action="store_true", help="build .venv-peers (benchmarks/peers_venv.sh) first if it is missing")
    ap.add_argument("--peers-python", default=None, help="python of the peers venv (default .venv-peers/bin/python)")
    ap.add_argument("--note", default=None, help="a line kept in the report (e.g. which build of wolfpack this is)")
    args = ap.parse_args(argv)

    sizes = parse_ints(args.sizes or ("1,64" if args.quick else DEFAULT_SIZES), "--sizes")
    threads = parse_ints(args.threads, "--threads")
    target_s = args.seconds or (0.05 if args.quick else 1.5)
    episodes = args.episodes or (10 if args.quick else 200)
    mpe2_steps = args.mpe2_steps or (300 if args.quick else 5000)
    repeats = args.repeats or (1 if args.quick else 3)
    skip = {s.strip() for s in args.skip.split(",") if s.strip()}
    unknown = skip - set(SKIPPABLE)
    if unknown:
        ap.error(f"--skip: unknown {', '.join(sorted(unknown))} (choose from {', '.join(SKIPPABLE)})")
    if "jaxmarl" in skip:
        skip |= {"jaxmarl_loop", "jaxmarl_scan"}

    report: dict[str, Any] = {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "command": " ".join(
            ([f"PYTHONPATH={os.environ['PYTHONPATH']}"] if os.environ.get("PYTHONPATH") else []) + ["python", os.path.relpath(__file__, ROOT)] + (sys.argv[1:] if argv is None else list(argv))
        ),
        "note": args.note,
        "machine": machine_info(),
        "quick": args.quick,
        "counts": COUNTS,
        "sizes": sizes,
        "threads": threads,
        "target_seconds": target_s,
        "repeats": repeats,
    }
    t_start = time.perf_counter()

    want = set()
    if "vmas" not in skip:
        want.add("vmas")
    if not {"jaxmarl_loop", "jaxmarl_scan"} <= skip:
        want.add("jaxmarl")
    workers, why_not, about = start_workers(args, want)
    report["peers_venv"] = {
        "python": peers_python(args.peers_python),
        "versions": about,
        "skipped": why_not,
    }

    # The contenders, in measuring order (rotated between rounds).
    scripted = [] if "scripted" in skip else [Scripted(1, episodes), Scripted(None, episodes)]
    once: list[Contender] = list(scripted)
    mpe2 = None
    if "mpe2" not in skip:
        mpe2 = Mpe2(mpe2_steps)
        once += [mpe2, Mpe2Physics(mpe2)]
    per_size: list[Contender] = []
    for E in sizes:
        for vec in (False, True):
            if ("vec" if vec else "batch") in skip:
                continue
            per_size += [Batch(vec, E, t, target_s) for t in threads]
        # --quick: the peer workers at the smallest E only (their start and JAX's compiles are
        # most of a quick run's time; one size exercises the whole path).
        peers_here = not args.quick or E == sizes[0]
        if "vmas" not in skip and peers_here:
            per_size.append(Remote(workers.get("vmas"), "vmas", E, target_s, args.vmas_steps, why_not.get("vmas")))
        for kind in ("jaxmarl_loop", "jaxmarl_scan"):
            if kind not in skip and peers_here:
                # --quick: a fixed, short scan (one compile instead of the sizing probes').
                fixed = 16 if (kind == "jaxmarl_scan" and args.quick) else None
                per_size.append(Remote(workers.get("jaxmarl"), kind, E, target_s, fixed, why_not.get("jaxmarl")))
    contenders = once + per_size

    # Prepare: build, warm up, size. A peer that fails is skipped, wolfpack must not fail.
    for c in contenders:
        if c.skipped is not None:
            continue
        t_prep = time.perf_counter()
        try:
            c.prepare()
            note(f"[prepare] {c.label}" + (f", E={c.num_envs}" if c.num_envs else "") + f": {time.perf_counter() - t_prep:.1f} s")
        except ImportError as e:
            c.skipped = f"not importable: {e}"
            note(f"[{c.key}] skipped: {c.skipped}")
        except Exception as e:  # noqa: BLE001 - an optional peer must not sink the run
            if isinstance(c, (Scripted, Batch)):
                raise
            c.skipped = f"failed: {type(e).__name__}: {e}"
            note(f"[{c.key}] skipped: {c.skipped}")
    live = [c for c in contenders if c.skipped is None]

    # Rounds: each live contender once per round, the order rotated.
    rounds = []
    shift = max(1, math.ceil(len(live) / max(repeats, 1)))
    for r in range(repeats):
        order = live[(r * shift) % len(live) :] + live[: (r * shift) % len(live)] if live else []
        pids = [os.getpid()] + [w.proc.pid for w in workers.values()]
        before, ticks, t0 = loadavg(), cpu_ticks(pids), time.perf_counter()
        note(f"[round {r + 1}/{repeats}] {len(order)} measurements, load {before}")
        for c in order:
            if c.skipped is not None:
                continue
            try:
                c.runs.append(c.measure())
            except Exception as e:  # noqa: BLE001
                if isinstance(c, (Scripted, Batch)):
                    raise
                c.skipped = f"failed: {type(e).__name__}: {e}"
                note(f"[{c.key}] skipped: {c.skipped}")
        secs = time.perf_counter() - t0
        rounds.append(
            {
                "round": r + 1,
                "load_before": before,
                "load_after": loadavg(),
                "seconds": secs,
                # CPU used by every other process on the machine during the round, in cores (0 = the
                # benchmark had the machine to itself; the load average counts the benchmark too).
                "others_cores": others_share(ticks, cpu_ticks(pids), secs),
            }
        )
    report["rounds"] = rounds
    for c in contenders:
        c.close()
    for w in workers.values():
        w.close()

    # Once-per-run results, under the keys earlier versions of this script used.
    res = {c.group: c.result() for c in once}
    report["wolfpack"] = {
        "scenario": "params.yaml (documented scenario)",
        "threads_1": res.get("scripted_1t", {"skipped": "--skip scripted"}),
        "threads_all": res.get("scripted_all", {"skipped": "--skip scripted"}),
    }
    if mpe2 is None:
        report["mpe2"] = {"skipped": "--skip mpe2"}
    else:
        report["mpe2"] = res["mpe2"]
        if "skipped" not in res["mpe2"]:
            report["mpe2"]["physics_only_env_steps_per_second"] = res["mpe2_physics"].get("env_steps_per_second")
    report["batch"] = {}
    for c in per_size:
        report["batch"].setdefault(str(c.num_envs), {})[c.group] = c.result()
    for E in map(str, sizes):
        report["batch"].setdefault(E, {})
    report["vmas"] = report["batch"].get("1", {}).get("vmas", {"skipped": "--skip vmas" if "vmas" in skip else "E = 1 not in --sizes"})
    report["reference"] = REFERENCE
    report["ratios_by_size"] = {E: size_ratios(row, threads) for E, row in report["batch"].items()}

    one, all_ = rate(report["wolfpack"]["threads_1"]), rate(report["wolfpack"]["threads_all"])
    mpe, phys = rate(report["mpe2"]), report["mpe2"].get("physics_only_env_steps_per_second")
    ref = REFERENCE["env_steps_per_second"]
    report["ratios"] = {
        "wolfpack(1 thread) / mpe2": ratio(one, mpe),
        "wolfpack(all cores) / mpe2": ratio(all_, mpe),
        "wolfpack(1 thread) / mpe2 world.step() only": ratio(one, phys),
        "wolfpack(1 thread) / reference": ratio(one, ref),
        "wolfpack(all cores) / reference": ratio(all_, ref),
    }
    if "1" in report["batch"]:
        report["ratios"]["BatchEnv(1t), E=1 / mpe2"] = ratio(rate(report["batch"]["1"].get("batch_env_1t")), mpe)
    report["machine"]["load_average_after"] = loadavg()
    report["wall_seconds"] = time.perf_counter() - t_start

    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(tables(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
