#!/usr/bin/env python3
"""The benchmark's analytic baselines: every wolf law against every target law on every task.

Writes ``envs/wolfpack/baselines.json`` (the package reads it to rank scorecards;
``results/benchmark/baselines.json`` is a link to it):

- ``wolves``: each wolf law (seed000, bvc, formation) against each task's scripted targets
  (``escape``), scored on captures — the rows a ``wolfpack benchmark --wolves`` scorecard is
  ranked among;
- ``targets``: each target law (escape, random, still) against each task's scripted wolves
  (``seed000``), scored on survival — for ``--targets`` scorecards;
- ``pairings``: every wolf law × every target law on every task (capture and collision rates
  with Wilson intervals).

All on the held-out episodes (seeds 500000 + k) that scorecards play, deterministic laws, so the
file is reproduced exactly by rerunning::

    python benchmarks/benchmark_baselines.py                 # about a minute on 2 cores
    python benchmarks/benchmark_baselines.py --episodes 20 --out /tmp/baselines.json   # a quick look
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from tqdm import tqdm
from wolfpack.evaluation import HELD_OUT_SEED, report, rollout, wilson_interval
from wolfpack.scorecard import BASELINES_FILE, DEFAULT_EPISODES, SKILL
from wolfpack.sides import SCRIPTED_LAWS
from wolfpack.task import TASK_ORDER, task_params

WOLF_LAWS = SCRIPTED_LAWS["wolves"]
TARGET_LAWS = SCRIPTED_LAWS["targets"]
#: The keys of an evaluation report a baseline keeps.
KEPT = ("capture_rate", "capture_rate_ci95", "survival_rate", "collision_rate", "target_collision_rate", "timeout_rate", "median_capture_steps")


def play(task: str, wolves: str, targets: str, episodes: int, seed: int, threads: int | None) -> dict:
    params = task_params(task, {"policies.wolves": wolves, "policies.targets": targets})
    row = report(rollout(params, episodes=episodes, seed=seed, threads=threads), wolves, targets)
    return {k: row[k] for k in KEPT}


def scored(row: dict, side: str, episodes: int) -> dict:
    key = SKILL[side][0]
    return {"score": row[key], "score_ci95": list(wilson_interval(round(row[key] * episodes), episodes)), **row}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--episodes", type=int, default=DEFAULT_EPISODES)
    p.add_argument("--seed", type=int, default=HELD_OUT_SEED)
    p.add_argument("--threads", type=int, default=None)
    p.add_argument("--out", type=Path, default=BASELINES_FILE)
    args = p.parse_args(argv)
    started = time.time()
    pairings: dict[str, dict] = {}
    with tqdm(total=len(TASK_ORDER) * len(WOLF_LAWS) * len(TARGET_LAWS), unit="pairing", file=sys.stderr) as bar:
        for task in TASK_ORDER:
            pairings[task] = {}
            for w in WOLF_LAWS:
                pairings[task][w] = {}
                for t in TARGET_LAWS:
                    bar.set_description(f"{task}: {w} vs {t}")
                    pairings[task][w][t] = play(task, w, t, args.episodes, args.seed, args.threads)
                    bar.update()
    scripted = {task: task_params(task)["policies"] for task in TASK_ORDER}
    doc = {
        "what": "the analytic laws on every task of the suite (docs/tasks.md), deterministic, on the held-out episodes",
        "episodes": args.episodes,
        "first_seed": args.seed,
        "command": "python benchmarks/benchmark_baselines.py" + ("" if argv is None else " " + " ".join(argv)),
        "seconds": round(time.time() - started, 1),
        "wolves": {w: {"kind": "law", "tasks": {task: scored(pairings[task][w][scripted[task]["targets"]], "wolves", args.episodes) for task in TASK_ORDER}} for w in WOLF_LAWS},
        "targets": {t: {"kind": "law", "tasks": {task: scored(pairings[task][scripted[task]["wolves"]][t], "targets", args.episodes) for task in TASK_ORDER}} for t in TARGET_LAWS},
        "pairings": pairings,
    }
    args.out.write_text(json.dumps(doc, indent=1) + "\n", encoding="utf-8")
    print(f"wrote {args.out} in {doc['seconds']:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
