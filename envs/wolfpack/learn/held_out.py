"""A training run's held-out evaluations (``evaluations.json``): each learning side, deterministic,
on episodes no training world uses, against the opponent it trains against; in multi-task
training on each task, whose results move the tasks' weights in the update
(``--task-weights``)."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np

from wolfpack.evaluation import HELD_OUT_SEED, report, rollout
from wolfpack.learn.progress import EVAL_COLUMNS
from wolfpack.scorecard import best_law, load_baselines

#: The run folder's file of every held-out evaluation.
EVALUATIONS_FILE = "evaluations.json"
#: Adaptive and shortfall task weights: a task's weight is its failure rate (or its shortfall)
#: plus this floor, so that a solved task keeps some weight; the weights are scaled to mean 1
#: over the groups.
WEIGHT_FLOOR = 0.05


class HeldOut:
    """The held-out evaluations of the run in ``out`` (a resumed run goes on with its earlier
    ones); ``group_tasks``: the task of each group of training worlds, in the learners' order."""

    def __init__(self, spec: Any, out: Path, group_tasks: Sequence[str], resume: bool) -> None:
        self.spec, self.out, self.group_tasks = spec, out, list(group_tasks)
        path = out / EVALUATIONS_FILE
        self.records: list[dict] = json.loads(path.read_text()) if resume and path.is_file() else []
        self._baselines = load_baselines() if spec.task_weights == "shortfall" else {}

    def evaluate(self, learners: Mapping[str, Any], agent_steps: int, updates: int, train_s: float, phase: str = "ppo") -> dict:
        """Each learning side, deterministic, on the held-out episodes HELD_OUT_SEED + k against
        the opponent it trains against (both sides learning: the other side's law in params);
        multi-task, on each task's held-out episodes, the rates averaged over the tasks and each
        task's kept under ``tasks``. ``train_s``: the run's training seconds so far (evaluations
        excluded). Appends the record to ``evaluations.json`` and returns its entries of
        progress.csv's row."""
        row = {}
        record: dict[str, Any] = {"agent_steps": agent_steps, "update": updates, "train_s": train_s, "phase": phase}
        tasks = self.spec.eval_tasks or (("", self.spec.params),)
        for side, learner in learners.items():
            policy = learner.policy()
            reports = {task: self._report(side, policy, params) for task, params in tasks}
            if self.spec.eval_tasks:
                r = {k: _mean_of(rep[k] for rep in reports.values()) for k in EVAL_COLUMNS}
                record.setdefault("tasks", {})
                for task, rep in reports.items():
                    record["tasks"].setdefault(task, {})[side] = rep
                    for k in EVAL_COLUMNS[:2]:
                        row[f"eval_{task}_{side}_{k}"] = rep[k]
            else:
                r = reports[""]
            record[side] = r
            for k in EVAL_COLUMNS:
                row[f"eval_{side}_{k}"] = r[k]
        if self.spec.eval_tasks and self.spec.task_weights != "uniform":
            self.reweigh(learners, record["tasks"])
        self.records.append(record)
        (self.out / EVALUATIONS_FILE).write_text(json.dumps(self.records, indent=1) + "\n")
        return row

    def _report(self, side: str, policy, params: dict) -> dict:
        """The report of ``side``'s ``policy`` on the held-out episodes of ``params``."""
        opponent = self.spec.opponent if self.spec.learners != "both" else None
        results = rollout(params, episodes=self.spec.eval_episodes, seed=HELD_OUT_SEED, threads=self.spec.threads, opponent=opponent, **{side: policy})
        wolves = params["policies"]["wolves"] if side == "targets" else side
        targets = params["policies"]["targets"] if side == "wolves" else side
        if opponent is not None:
            wolves, targets = (wolves, str(opponent)) if side == "wolves" else (str(opponent), targets)
        r = report(results, wolves, targets)
        r.pop("capture_steps")
        return r

    def reweigh(self, learners: Mapping[str, Any], per_task: dict[str, dict]) -> None:
        """Moves each side's group weights towards the tasks it does worst on, from the held-out
        rates (the side's score: the capture rate for wolves, the survival rate for targets).
        ``adaptive``: a task's weight is 1 − the score. ``shortfall``: how far the score is below
        the task's best committed law (0 at or above it; 1 − the score for a task no law was
        scored on): a task that no policy can solve, such as taking two targets, does not take
        the loss from those a law shows can be solved."""
        for side, learner in learners.items():
            score = {task: reps[side]["capture_rate"] if side == "wolves" else 1.0 - reps[side]["capture_rate"] for task, reps in per_task.items()}
            if self.spec.task_weights == "shortfall":
                laws = {task: best_law(self._baselines, side, task) for task in score}
                need = {task: max(0.0, laws[task][1] - score[task]) if laws[task] else 1.0 - score[task] for task in score}
            else:
                need = {task: 1.0 - score[task] for task in score}
            raw = [need[task] + WEIGHT_FLOOR for task in self.group_tasks]
            mean = sum(raw) / len(raw)
            learner.group_weights = [w / mean for w in raw]


def _mean_of(values) -> float | None:
    """The mean of the values that are numbers (a median capture step is None where nothing was
    captured); None when none is."""
    numbers = [float(v) for v in values if v is not None]
    return float(np.mean(numbers)) if numbers else None
