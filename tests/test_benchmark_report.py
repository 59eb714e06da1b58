"""training/benchmark_report.py: the benchmark's tables and figures from the results' JSON."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import training_script
from wolfpack.report import benchmark as benchmark_figures

benchmark_report = training_script("benchmark_report")

pytest.importorskip("scipy")


def _law(score: float) -> dict:
    return {"score": score, "score_ci95": [score - 0.05, min(1.0, score + 0.05)]}


def _write(folder: Path) -> None:
    baselines = {
        "episodes": 200,
        "first_seed": 500000,
        "command": "python benchmarks/benchmark_baselines.py",
        "wolves": {"bvc": {"kind": "law", "tasks": {"hunt-v1": _law(0.97), "open-v1": _law(0.98)}}},
        "targets": {"escape": {"kind": "law", "tasks": {"hunt-v1": _law(0.03), "open-v1": _law(0.01)}}},
    }
    scores = {"hunt-v1": [0.80, 0.85, 0.90, 0.95, 0.10], "open-v1": [0.90, 0.92, 0.94]}
    runs = [{"task": t, "learner": "mappo-wolves", "seed": s, "score": x} for t, xs in scores.items() for s, x in enumerate(xs)]
    summary = {t: {"mappo-wolves": {"iqm": float(np.mean(sorted(xs)[1:-1])) if len(xs) == 5 else 0.92, "ci95": [0.8, 0.95]}} for t, xs in scores.items()}
    learned = {
        "budgets": {"wolves": 10_000_000, "targets": 2_000_000},
        "command": "python training/task_baselines.py",
        "learners": {"mappo-wolves": {"side": "wolves", "algo": "mappo"}, "mappo-escaper": {"side": "targets", "algo": "mappo"}},
        "summary": summary,
        "runs": runs,
    }
    (folder / "baselines.json").write_text(json.dumps(baselines))
    (folder / "learned.json").write_text(json.dumps(learned))


def test_the_report_tables_every_baseline_per_task_and_the_learners_over_tasks(tmp_path):
    _write(tmp_path)
    assert benchmark_report.main(["--results", str(tmp_path)]) == 0
    text = (tmp_path / "benchmark.md").read_text()
    assert "| `hunt-v1` | 97.0 % [92.0, 100.0] | 85.0 % [80.0, 95.0] (n=5) |" in text
    assert "| `cluttered-v1` | — | — |" in text  # not measured: a dash, never a number
    # The IQM over both tasks' eight runs: the middle four of
    # [0.10, 0.80, 0.85, 0.90, 0.90, 0.92, 0.94, 0.95]: 0.85, 0.90, 0.90, 0.92 -> 0.8925.
    assert "`mappo-wolves`: **89.2 %**" in text and "on 2 tasks" in text
    assert "mappo-escaper" not in text  # a learner with no runs gets no column
    for figure in ("tasks.png", "profiles.png"):
        assert (tmp_path / figure).stat().st_size > 10_000


def test_the_stratified_interval_contains_the_iqm_and_resamples_within_tasks():
    steady = [np.array([0.5, 0.5, 0.5]), np.array([0.9, 0.9])]
    point, ci = benchmark_figures.stratified_iqm(steady)
    assert ci == [point, point]  # nothing varies within a task: no spread to resample
    spread = [np.array([0.1, 0.5, 0.9, 0.3, 0.7]), np.array([0.2, 0.8, 0.6])]
    point, (lo, hi) = benchmark_figures.stratified_iqm(spread)
    assert lo < point < hi


def test_the_performance_profile_counts_runs_above_each_threshold():
    prof = benchmark_figures.profile([np.array([0.2, 0.6]), np.array([0.8])])
    at = {round(float(t), 3): p for t, p in zip(benchmark_figures.TAUS, prof)}
    assert at[0.0] == 1.0 and at[0.5] == pytest.approx(2 / 3) and at[0.7] == pytest.approx(1 / 3) and at[0.9] == 0.0


def test_a_task_with_one_seed_so_far_is_tabled_but_left_out_of_the_aggregate(tmp_path):
    _write(tmp_path)
    learned = json.loads((tmp_path / "learned.json").read_text())
    learned["runs"].append({"task": "cluttered-v1", "learner": "mappo-wolves", "seed": 0, "score": 0.5})
    learned["summary"]["cluttered-v1"] = {"mappo-wolves": {"iqm": 0.5, "ci95": [0.5, 0.5]}}
    (tmp_path / "learned.json").write_text(json.dumps(learned))
    assert benchmark_report.main(["--results", str(tmp_path)]) == 0  # a sweep in progress still reports
    text = (tmp_path / "benchmark.md").read_text()
    assert "| `cluttered-v1` | — | 50.0 % [50.0, 50.0] (n=1) |" in text
    assert "`mappo-wolves`: **89.2 %**" in text and "on 2 tasks" in text  # as before: one seed is no stratum
