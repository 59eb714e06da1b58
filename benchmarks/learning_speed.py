#!/usr/bin/env python3
"""Learning speed: the SB3 PPO path against the native trainer, in one run on one machine.

For each trainer and training seed, one time-limited run from scratch on the documented
scenario (see BENCHMARKS.md, "Learning"):

- **native**: ``wolfpack train --side SIDE --algo ALGO`` with its default recipe, or with the
  ``--hp KEY=VALUE`` changes given here (recorded in the JSON as ``native_hp``);
- **native-entities**: the same with entity observations and the set network
  (``--hp network=entities``, docs/learning.md "One model for every task");
- **sb3**: ``training/train.py --side SIDE --algo ppo`` (SB3's PPO on ``make_vec_env``, the
  hyperparameters of ``wolfpack/learn/sb3_hyperparams.yaml``).

Both evaluate the deterministic policy on the same held-out episodes (seeds 500000 + k) at
regular points of the run. Reported per trainer: agent-steps/s end to end (training wall time,
evaluations excluded), and for each skill level the training wall time and agent-steps at the
first evaluation that reached it (median and range over seeds; a seed that never reached it
counts as not reached). Skill: the capture rate against ``escape`` for wolves, the survival
rate against ``seed000`` for targets.

Usage::

    python benchmarks/learning_speed.py --side wolves --minutes 15 --seeds 5              # 2 x 5 x 15 min
    python benchmarks/learning_speed.py --side wolves --minutes 2 --seeds 1 --json        # throughput only
    python benchmarks/learning_speed.py --trainers native --minutes 15 --seeds 5 --out benchmarks/results/learning-x.json
    python benchmarks/learning_speed.py --trainers native native-entities --minutes 3 --seeds 1   # flat MLP against the set network

Runs go one after another (never side by side: each has the machine to itself), seed by seed with
the trainers in turn. On a machine with many cores, ``--parallel N`` runs N at once instead, each
pinned to its own two cores with two batch and two torch threads: a 2-core figure per run, N of
them at a time (the runs still share the memory bus and the last-level cache, so it is not the
same as a 2-core machine); alternating, both trainers see the same neighbours. Nothing here
asserts a speed; the numbers are what the machine gave.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
from machine import machine_info  # noqa: E402

LEVELS = (0.80, 0.90, 0.95)
TRAINERS = ("native", "native-entities", "sb3")
#: The recipe changes each native trainer runs with (before the run's own --hp).
NATIVE_HP = {"native": [], "native-entities": ["network=entities"]}


#: Cores, batch threads and torch threads of each run under --parallel.
PINNED_CORES = 2


def command(trainer: str, args: argparse.Namespace, seed: int, out: Path, pinned: bool = False) -> list[str]:
    """The command line of one run: ``trainer`` on ``args``' side and budget, training seed
    ``seed``, its folder ``out``; ``pinned``: two batch and two torch threads (``--parallel``)."""
    side, minutes, evaluations, eval_episodes = args.side, args.minutes, args.evaluations, args.eval_episodes
    if trainer in NATIVE_HP:
        threads = ["--threads", str(PINNED_CORES), "--torch-threads", str(PINNED_CORES)] if pinned else []
        overrides = [part for hp in NATIVE_HP[trainer] + args.hp for part in ("--hp", hp)]
        return [
            sys.executable,
            "-m",
            "wolfpack.cli",
            "train",
            "--side",
            side,
            "--algo",
            args.algo,
            "--seed",
            str(seed),
            "--time-limit",
            str(minutes),
            "--evaluations",
            str(evaluations),
            "--eval-episodes",
            str(eval_episodes),
            "--device",
            args.device,
            "--out",
            str(out),
            "--no-progress",
            *threads,
            *overrides,
        ]
    # SB3's budget is in timesteps: a ceiling it never reaches in the time limit, and held-out
    # evaluations at the same count per run as the native trainer's, from its measured rate.
    ceiling = 10**10
    return [
        sys.executable,
        str(ROOT / "training" / "train.py"),
        "--side",
        side,
        "--algo",
        "ppo",
        "--seed",
        str(seed),
        "--timesteps",
        str(ceiling),
        "--time-limit",
        str(minutes),
        "--eval-freq",
        str(max(1, int(7_000 * 60 * minutes / evaluations))),
        "--eval-episodes",
        str(eval_episodes),
        "--checkpoint-freq",
        str(ceiling),
        "--threads",
        "2",
        "--torch-threads",
        "2",
        "--out",
        str(out),
        "--no-progress",
    ]


def skill(side: str, row: dict) -> float:
    return row["capture_rate"] if side == "wolves" else 1.0 - row["capture_rate"]


def read_run(trainer: str, side: str, out: Path) -> dict:
    """(evaluation points [(train_s, agent_steps, skill, collision_rate)], agent-steps/s)."""
    evals = json.loads((out / "evaluations.json").read_text())
    if trainer in NATIVE_HP:
        points = [(e["train_s"], e["agent_steps"], skill(side, e[side]), e[side]["collision_rate"]) for e in evals]
        summary = json.loads((out / "summary.json").read_text())
        rate = summary["this_invocation"]["agent_steps_per_s"]
    else:
        points = [(e["train_s"], e["timesteps"], skill(side, e), e["collision_rate"]) for e in evals]
        summary = json.loads((out / "train_summary.json").read_text())
        rate = summary["timesteps_per_s"]
    return {"points": points, "agent_steps_per_s": rate}


def first_reaching(points: list, level: float) -> dict | None:
    for train_s, steps, value, collisions in points:
        if value >= level:
            return {"train_s": train_s, "agent_steps": steps, "collision_rate": collisions}
    return None


def spread(values: list[float]) -> dict | None:
    return {"median": statistics.median(values), "min": min(values), "max": max(values)} if values else None


def summarise(runs: list[dict]) -> dict:
    out = {
        "seeds": len(runs),
        "agent_steps_per_s": spread([r["agent_steps_per_s"] for r in runs]),
        "final_skill": spread([r["points"][-1][2] for r in runs]),
        "final_collision_rate": spread([r["points"][-1][3] for r in runs]),
    }
    for level in LEVELS:
        hits = [first_reaching(r["points"], level) for r in runs]
        reached = [h for h in hits if h is not None]
        out[f"reach_{int(level * 100)}"] = {
            "reached": f"{len(reached)}/{len(runs)}",
            "minutes": spread([h["train_s"] / 60 for h in reached]),
            "agent_steps": spread([h["agent_steps"] for h in reached]),
        }
    return out


def table(doc: dict) -> str:
    what = "capture vs escape" if doc["side"] == "wolves" else "survival vs seed000"
    lines = [
        f"{doc['side']}, {what}; {doc['minutes']} min per run, seeds {doc['seed_list']}; {doc['machine'].get('cpu', '')}",
        "| trainer | agent-steps/s | final skill | " + " | ".join(f"to {int(100 * level)} % (min; reached)" for level in LEVELS) + " |",
        "|---|---|---|" + "---|" * len(LEVELS),
    ]
    for trainer, s in doc["trainers"].items():
        rate = s["agent_steps_per_s"]
        cells = [
            trainer,
            f"{rate['median'] / 1000:.1f}k ({rate['min'] / 1000:.1f}–{rate['max'] / 1000:.1f}k)",
            f"{100 * s['final_skill']['median']:.1f} % ({100 * s['final_skill']['min']:.1f}–{100 * s['final_skill']['max']:.1f})",
        ]
        for level in LEVELS:
            r = s[f"reach_{int(level * 100)}"]
            m = r["minutes"]
            cells.append(f"{m['median']:.1f} ({m['min']:.1f}–{m['max']:.1f}); {r['reached']}" if m else f"—; {r['reached']}")
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def run_jobs(jobs: list[tuple[str, int]], folders: dict, args: argparse.Namespace, cores: list[int]) -> int:
    """Runs every (trainer, seed) job, ``args.parallel`` at a time (each on its own pinned cores
    when more than one); the exit status of the first that failed (its stderr printed), else 0."""
    pinned = args.parallel > 1
    free = [cores[PINNED_CORES * k : PINNED_CORES * (k + 1)] for k in range(args.parallel)]
    running: list[tuple[subprocess.Popen, list[int], object]] = []
    pending = list(jobs)
    failed = 0
    try:
        while (pending and not failed) or running:
            while pending and free and not failed:
                trainer, seed = pending.pop(0)
                out = folders[(trainer, seed)]
                slot = free.pop(0)
                cmd = command(trainer, args, seed, out, pinned)
                where = f" on cores {slot}" if pinned else ""
                print(f"[{time.strftime('%H:%M:%S')}] {trainer} seed {seed}{where}: {' '.join(cmd[1:])}", file=sys.stderr, flush=True)
                log = tempfile.TemporaryFile(mode="w+")
                pin = (lambda s=slot: os.sched_setaffinity(0, s)) if pinned else None
                running.append((subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.DEVNULL, stderr=log, text=True, preexec_fn=pin), slot, log))
            time.sleep(0.5)
            for entry in list(running):
                proc, slot, log = entry
                if proc.poll() is None:
                    continue
                running.remove(entry)
                free.append(slot)
                if proc.returncode != 0 and not failed:
                    log.seek(0)
                    print(log.read()[-2000:], file=sys.stderr)
                    failed = proc.returncode
                    for other, _, _ in running:  # the table would be incomplete
                        other.kill()
                log.close()
    finally:
        for proc, _, _ in running:
            proc.kill()
    return failed


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--side", choices=("wolves", "targets"), default="wolves")
    p.add_argument("--algo", choices=("ippo", "mappo"), default="mappo", help="the native trainer's algorithm (default mappo)")
    p.add_argument("--trainers", nargs="+", choices=TRAINERS, default=["native", "sb3"], help="default: native sb3")
    p.add_argument("--minutes", type=float, default=15.0, help="time limit of every run (default 15)")
    p.add_argument("--seeds", type=int, default=5, help="training seeds 0 .. N-1 (default 5)")
    p.add_argument("--first-seed", type=int, default=0)
    p.add_argument("--evaluations", type=int, default=30, help="held-out evaluations per run (default 30)")
    p.add_argument("--eval-episodes", type=int, default=200, help="episodes per held-out evaluation (default 200)")
    p.add_argument("--device", default="cpu", help="the native trainer's --device (default cpu)")
    p.add_argument("--hp", metavar="KEY=VALUE", action="append", default=[], help="a change to the native trainer's recipe, passed on to wolfpack train (repeatable)")
    p.add_argument("--keep", default=None, metavar="DIR", help="keep every run's folder under DIR (default: a temporary folder)")
    p.add_argument("--json", action="store_true", help="print the JSON document instead of the table")
    p.add_argument("--out", default=None, help="also write the JSON document here")
    p.add_argument("--parallel", type=int, default=1, metavar="N", help=f"runs at once, each pinned to its own {PINNED_CORES} cores (default 1: one after another, unpinned)")
    args = p.parse_args(argv)
    cores = sorted(os.sched_getaffinity(0))
    if args.parallel < 1 or (args.parallel > 1 and args.parallel * PINNED_CORES > len(cores)):
        p.error(f"--parallel {args.parallel}: needs {PINNED_CORES} cores a run, and this process may use {len(cores)}")
    os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    doc = {
        "side": args.side,
        "algo": args.algo,
        "native_hp": args.hp,
        "minutes": args.minutes,
        "seed_list": seeds,
        "evaluations": args.evaluations,
        "parallel": args.parallel,
        "eval_episodes": args.eval_episodes,
        "machine": machine_info(),
        "started": time.strftime("%Y-%m-%d %H:%M:%S"),
        "trainers": {},
        "runs": {},
    }
    with tempfile.TemporaryDirectory() as scratch:
        base = Path(args.keep) if args.keep else Path(scratch)
        base.mkdir(parents=True, exist_ok=True)
        # Seed by seed, the trainers in turn: a machine whose speed drifts over the hour (a VM's
        # neighbours) weighs on both trainers alike.
        jobs = [(trainer, seed) for seed in seeds for trainer in args.trainers]
        folders = {job: base / f"{job[0]}_{args.side}_{args.algo if job[0] in NATIVE_HP else 'ppo'}_s{job[1]}" for job in jobs}
        failed = run_jobs(jobs, folders, args, cores)
        if failed:
            return failed
        for trainer in args.trainers:
            runs = [read_run(trainer, args.side, folders[(trainer, seed)]) for seed in seeds]
            doc["runs"][trainer] = runs
            doc["trainers"][trainer] = summarise(runs)
    text = json.dumps(doc, indent=1)
    if args.out:
        Path(args.out).write_text(text + "\n")
    print(text if args.json else table(doc))
    return 0


if __name__ == "__main__":
    sys.exit(main())
