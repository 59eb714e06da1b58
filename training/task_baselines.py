#!/usr/bin/env python3
"""The benchmark's learned baselines: IPPO and MAPPO wolves and a learned escaper on every task.

For every task T of the suite (docs/tasks.md), every learner L and training seed s, one run of
the native trainer from scratch with the packaged recipe and a fixed budget of agent-steps::

    wolfpack train --side wolves  --algo ippo  --task T --timesteps WOLF_BUDGET   --seed s
    wolfpack train --side wolves  --algo mappo --task T --timesteps WOLF_BUDGET   --seed s
    wolfpack train --side targets --algo mappo --task T --timesteps TARGET_BUDGET --seed s

against the task's scripted other side (``escape`` targets, ``seed000`` wolves). Each final model
then plays its task deterministically on the held-out episodes (seeds 500000 + k, the episodes of
``wolfpack benchmark`` and of the analytic baselines), scored as a scorecard scores it: captured
for wolves, survived for targets.

Usage::

    python training/task_baselines.py --keep runs/task_baselines          # hours on 2 cores, see --help
    python training/task_baselines.py --keep runs/task_baselines --tasks hunt-v1 --seeds 5

Runs go one after another (each has the machine to itself), task by task; a rerun with the same
--keep skips the runs that finished and the evaluations already made (--reevaluate redoes them,
after a change to the core). The results (every run's held-out score, and per task and learner the
interquartile mean over seeds with its 95 % percentile bootstrap interval; see
training/benchmark_report.py for the tables and figures) go to --out, default the package's
``learned.json`` (``results/benchmark/learned.json`` links to it; ``wolfpack benchmark`` ranks
scorecards among these learners), rewritten after every run so that an interrupted sweep keeps
what it measured.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from wolfpack.evaluation import HELD_OUT_SEED
from wolfpack.learn.runs import held_out, train
from wolfpack.scorecard import DEFAULT_EPISODES, LEARNED_FILE, as_policy, score_task
from wolfpack.stats import iqm_interval
from wolfpack.task import TASK_ORDER

#: (name, side, algorithm) of each learner.
LEARNERS = (("ippo-wolves", "wolves", "ippo"), ("mappo-wolves", "wolves", "mappo"), ("mappo-escaper", "targets", "mappo"))
#: The budgets, in agent-steps: about 2 minutes of 2-core time per run at the trainer's rates
#: (wolves ~100 k agent-steps/s, the escaper ~15 k; BENCHMARKS.md, "Learning").
DEFAULT_BUDGETS = {"wolves": 10_000_000, "targets": 2_000_000}
#: What the held-out row keeps.
KEPT = ("score", "score_ci95", "collision_rate", "target_collision_rate", "timeout_rate", "median_capture_steps")
DEFAULT_OUT = LEARNED_FILE


def run_folder(keep: Path, task: str, learner: str, seed: int) -> Path:
    return keep / task / f"{learner}_s{seed}"


def held_out_row(folder: Path, side: str, task: str, episodes: int, reevaluate: bool) -> dict:
    """The final model's scorecard row on its task."""

    def evaluate() -> dict:
        full = score_task(as_policy(str(folder / side), side), side, task, episodes=episodes, seed=HELD_OUT_SEED)
        return {k: full[k] for k in KEPT if k in full}

    return held_out(folder, episodes, evaluate, reevaluate)


def summarise(runs: list[dict]) -> dict:
    """Per task and learner: IQM of the held-out scores over seeds, its interval, and the IQM of
    the collision rates."""
    out: dict[str, dict] = {}
    for task in dict.fromkeys(r["task"] for r in runs):
        out[task] = {}
        for learner in dict.fromkeys(r["learner"] for r in runs if r["task"] == task):
            rows = [r for r in runs if r["task"] == task and r["learner"] == learner]
            out[task][learner] = {**iqm_interval([r["score"] for r in rows]), "collision_rate_iqm": iqm_interval([r["collision_rate"] for r in rows])["iqm"], "seeds": [r["seed"] for r in rows]}
    return out


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--tasks", nargs="+", choices=TASK_ORDER, default=list(TASK_ORDER))
    p.add_argument("--learners", nargs="+", choices=[name for name, _, _ in LEARNERS], default=[name for name, _, _ in LEARNERS])
    p.add_argument("--seeds", type=int, default=5, help="training seeds per task and learner (default 5)")
    p.add_argument("--wolf-timesteps", type=int, default=DEFAULT_BUDGETS["wolves"], help="each wolf run's budget in agent-steps")
    p.add_argument("--target-timesteps", type=int, default=DEFAULT_BUDGETS["targets"], help="each escaper run's budget in agent-steps")
    p.add_argument("--episodes", type=int, default=DEFAULT_EPISODES, help="held-out episodes per evaluation")
    p.add_argument("--keep", type=Path, required=True, help="folder for the training runs")
    p.add_argument("--reevaluate", action="store_true", help="evaluate every finished run again")
    p.add_argument("--out", type=Path, default=DEFAULT_OUT)
    args = p.parse_args(argv)
    budgets = {"wolves": args.wolf_timesteps, "targets": args.target_timesteps}
    learners = [entry for entry in LEARNERS if entry[0] in args.learners]
    previous = json.loads(args.out.read_text()) if args.out.exists() else {}
    same_budget = previous.get("budgets") == budgets and previous.get("episodes") == args.episodes
    # Runs this invocation does not visit (other tasks, a partial sweep) stay in the file.
    runs = [r for r in previous.get("runs", []) if same_budget and not (r["task"] in args.tasks and r["learner"] in args.learners)]
    started = time.time()
    for task in args.tasks:
        for name, side, algo in learners:
            for seed in range(args.seeds):
                folder = run_folder(args.keep, task, name, seed)
                print(f"[{time.strftime('%H:%M:%S')}] {task} {name} seed {seed}", file=sys.stderr, flush=True)
                options = ["--side", side, "--algo", algo, "--task", task, "--timesteps", str(budgets[side]), "--seed", str(seed), "--evaluations", "2"]
                summary = train(folder, options, log=folder.with_name(folder.name + ".log"))
                row = held_out_row(folder, side, task, args.episodes, args.reevaluate)
                runs.append(
                    {
                        "task": task,
                        "learner": name,
                        "side": side,
                        "algo": algo,
                        "seed": seed,
                        "agent_steps": summary["agent_steps"],
                        "train_s": round(summary["train_s"], 1),
                        **{k: row[k] for k in KEPT if k in row},
                        "run": str(folder),
                    }
                )
                doc = {
                    "what": "learned baselines: the native trainer's final models on each task, deterministic, on the held-out episodes",
                    "budgets": budgets,
                    "episodes": args.episodes,
                    "first_seed": HELD_OUT_SEED,
                    "learners": {n: {"side": s, "algo": a} for n, s, a in LEARNERS},
                    # --reevaluate only recomputes what the runs' models score: not part of how the results were made
                    "command": "python training/task_baselines.py " + " ".join(a for a in (sys.argv[1:] if argv is None else argv) if a != "--reevaluate"),
                    "bootstrap": "scipy.stats.bootstrap, percentile, 10,000 resamples, over the training seeds",
                    "summary": summarise(runs),
                    "runs": sorted(runs, key=lambda r: (TASK_ORDER.index(r["task"]), r["learner"], r["seed"])),
                }
                args.out.parent.mkdir(parents=True, exist_ok=True)
                args.out.write_text(json.dumps(doc, indent=1) + "\n")
    print(f"{len(runs)} runs in {args.out} ({(time.time() - started) / 60:.1f} min)", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
