#!/usr/bin/env python3
"""The benchmark's tables and figures, from the committed results alone.

Reads ``results/benchmark/baselines.json`` (the analytic laws; benchmarks/benchmark_baselines.py)
and ``results/benchmark/learned.json`` (the learned baselines; training/task_baselines.py) and
writes, beside them:

- ``benchmark.md``: per task, every baseline's score on the held-out episodes — a law's rate
  with its 95 % Wilson interval, a learner's interquartile mean over its training seeds with a
  95 % percentile bootstrap interval — and, per learner, the IQM over all tasks and seeds with a
  95 % *stratified* bootstrap interval (seeds resampled within each task: scipy.stats.bootstrap
  with one sample per task), the way rliable aggregates;
- ``tasks.png``: the same per task, one panel per side;
- ``profiles.png``: performance profiles (rliable's): for every threshold τ, the fraction of a
  baseline's runs (task × seed; one per task for a law) that score above τ, with the 95 %
  stratified bootstrap band of the learners.

Usage::

    python training/benchmark_report.py            # a few seconds
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from wolfpack.report.benchmark import collect, markdown, profile_figure, task_figure

RESULTS = Path("results/benchmark")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--results", type=Path, default=RESULTS, help="folder of baselines.json and learned.json, and of the outputs")
    args = p.parse_args(argv)
    baselines = json.loads((args.results / "baselines.json").read_text())
    learned_file = args.results / "learned.json"
    learned = json.loads(learned_file.read_text()) if learned_file.exists() else {}
    table = collect(baselines, learned)
    (args.results / "benchmark.md").write_text(markdown(table, learned, baselines))
    task_figure(table, args.results / "tasks.png")
    profile_figure(table, args.results / "profiles.png")
    print(f"wrote {args.results / 'benchmark.md'}, tasks.png, profiles.png", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
