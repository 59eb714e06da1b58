"""The benchmark's tables and figures (``training/benchmark_report.py``): per task every
baseline's score, the stratified IQM over tasks with its bootstrap interval, and performance
profiles, the way rliable aggregates."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from wolfpack.scorecard import SKILL
from wolfpack.sides import SIDES
from wolfpack.task import TASK_ORDER

RESAMPLES = 10_000


#: Thresholds of the performance profiles.
TAUS = np.linspace(0.0, 1.0, 201)


def stratified_iqm(per_task: list[np.ndarray]) -> tuple[float, list[float]]:
    """IQM over every score of every task, and its 95 % percentile interval when the scores of
    each task are resampled within the task (scipy's multi-sample bootstrap)."""
    from scipy import stats

    def iqm(*samples, axis=-1):
        return stats.trim_mean(np.concatenate(samples, axis=axis), 0.25, axis=axis)

    point = float(iqm(*per_task))
    if all(len(s) < 2 or np.ptp(s) == 0 for s in per_task):
        return point, [point, point]
    boot = stats.bootstrap(tuple(per_task), iqm, confidence_level=0.95, n_resamples=RESAMPLES, method="percentile", rng=np.random.default_rng(0))
    return point, [float(boot.confidence_interval.low), float(boot.confidence_interval.high)]


def profile(per_task: list[np.ndarray]) -> np.ndarray:
    """Fraction of all runs scoring above each τ."""
    runs = np.concatenate(per_task)
    return (runs[None, :] > TAUS[:, None]).mean(axis=1)


def profile_band(per_task: list[np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(0)
    draws = np.empty((1000, len(TAUS)))
    for b in range(len(draws)):
        draws[b] = profile([s[rng.integers(0, len(s), len(s))] for s in per_task])
    return np.percentile(draws, 2.5, axis=0), np.percentile(draws, 97.5, axis=0)


def collect(baselines: dict, learned: dict) -> dict:
    """Per side, per baseline: {"kind", "tasks": {task: {"score", "ci95", "runs"}}}."""
    out: dict[str, dict] = {"wolves": {}, "targets": {}}
    for side in out:
        for name, entry in baselines.get(side, {}).items():
            out[side][name] = {"kind": "law", "tasks": {t: {"score": row["score"], "ci95": row["score_ci95"], "runs": [row["score"]]} for t, row in entry["tasks"].items()}}
    for name, spec in learned.get("learners", {}).items():
        tasks = {}
        for task, per in learned.get("summary", {}).items():
            if name in per:
                s = per[name]
                tasks[task] = {"score": s["iqm"], "ci95": s["ci95"], "runs": [r["score"] for r in learned["runs"] if r["task"] == task and r["learner"] == name]}
        if tasks:
            out[spec["side"]][name] = {"kind": "learned", "tasks": tasks}
    return out


def markdown(table: dict, learned: dict, baselines: dict) -> str:
    """benchmark.md: what the scores are and where they come from, then ``tables_markdown``."""
    budgets = learned.get("budgets", {})
    lines = [
        "# The benchmark's baselines",
        "",
        f"Written by `python training/benchmark_report.py` from `baselines.json` ({baselines.get('command', '')}) and `learned.json` "
        f"({learned.get('command', '')}). Every score is on the held-out episodes (seeds {baselines.get('first_seed')} + k, "
        f"{baselines.get('episodes')} per task), deterministic. Laws: the rate with its 95 % Wilson interval. Learned "
        f"(the native trainer from scratch, the packaged recipes; wolves {budgets.get('wolves', 0):,} agent-steps, the escaper "
        f"{budgets.get('targets', 0):,}): the interquartile mean over training seeds with its 95 % percentile bootstrap interval, "
        "and the number of seeds. A task without a learner's column has not been trained yet.",
    ]
    return "\n".join(lines) + "\n" + tables_markdown(table)


def tables_markdown(table: dict, heading: str = "##") -> str:
    """Per side, the per-task table of every baseline and each learner's IQM over the tasks;
    sections start with ``heading`` so that RESULTS.md can nest them a level deeper."""
    lines: list[str] = []
    for side in SIDES:
        names = list(table[side])
        if not names:
            continue
        opponent = "the task's `escape` target" if side == "wolves" else "the task's `seed000` wolves"
        lines += ["", f"{heading} {side.capitalize()}: {SKILL[side][1]} against {opponent}", "", "| task | " + " | ".join(f"`{n}`" for n in names) + " |", "|---|" + "---|" * len(names)]
        for task in TASK_ORDER:
            cells = []
            for n in names:
                row = table[side][n]["tasks"].get(task)
                if row is None:
                    cells.append("—")
                    continue
                runs = len(row["runs"])
                seeds = f" (n={runs})" if table[side][n]["kind"] == "learned" else ""
                cells.append(f"{100 * row['score']:.1f} % [{100 * row['ci95'][0]:.1f}, {100 * row['ci95'][1]:.1f}]{seeds}")
            lines.append(f"| `{task}` | " + " | ".join(cells) + " |")
        learners = [n for n in names if table[side][n]["kind"] == "learned"]
        if learners:
            lines += [
                "",
                "Over the tasks trained so far (IQM over every task × seed, 95 % stratified bootstrap interval; a task enters once it has two seeds, the fewest a stratum can be resampled from):",
                "",
            ]
            for n in learners:
                per_task = [np.asarray(r["runs"]) for r in table[side][n]["tasks"].values() if len(r["runs"]) >= 2]
                if not per_task:
                    continue
                point, ci = stratified_iqm(per_task)
                lines.append(f"- `{n}`: **{100 * point:.1f} %** [{100 * ci[0]:.1f}, {100 * ci[1]:.1f}] on {len(per_task)} task{'s' if len(per_task) != 1 else ''}")
    return "\n".join(lines) + "\n" if lines else ""


def front_page_markdown(table: dict) -> str:
    """README's benchmark table: per task the best law and the best learner of each side (a
    learner by its IQM over seeds), then how often the best law leads."""

    def best(side: str, kind: str, task: str) -> tuple[str, dict] | None:
        rows = [(name, entry["tasks"][task]) for name, entry in table[side].items() if entry["kind"] == kind and task in entry["tasks"]]
        return max(rows, key=lambda row: row[1]["score"]) if rows else None

    def cell(found: tuple[str, dict] | None, seeds: bool) -> str:
        if found is None:
            return "not trained yet"
        name, row = found
        return f"`{name}` {100 * row['score']:.1f} %" + (f" (n={len(row['runs'])})" if seeds else "")

    lines = ["| task | wolves, best law: captured | wolves, best learned: captured (IQM over seeds) | targets, best law: survived | targets, best learned: survived (IQM) |", "|---|---|---|---|---|"]
    law_leads, compared = 0, 0
    for task in TASK_ORDER:
        law, learner = best("wolves", "law", task), best("wolves", "learned", task)
        if law and learner:
            compared += 1
            law_leads += law[1]["score"] > learner[1]["score"]
        lines.append(f"| `{task}` | {cell(law, False)} | {cell(learner, True)} | {cell(best('targets', 'law', task), False)} | {cell(best('targets', 'learned', task), True)} |")
    if compared:
        lines += ["", f"The best analytic law captures more than the best learned pack on **{law_leads} of the {compared} tasks** trained so far."]
    return "\n".join(lines) + "\n"


def task_figure(table: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 6.0), sharey=True)
    y_of = {t: i for i, t in enumerate(TASK_ORDER)}
    for ax, side in zip(axes, SIDES):
        names = list(table[side])
        width = 0.8 / max(1, len(names))
        for k, name in enumerate(names):
            entry = table[side][name]
            tasks = [t for t in TASK_ORDER if t in entry["tasks"]]
            ys = np.array([y_of[t] for t in tasks]) - 0.4 + (k + 0.5) * width
            xs = np.array([100 * entry["tasks"][t]["score"] for t in tasks])
            # (clipped: a Wilson bound at 0 % or 100 % can sit a rounding error inside the rate)
            lo = np.clip(xs - np.array([100 * entry["tasks"][t]["ci95"][0] for t in tasks]), 0, None)
            hi = np.clip(np.array([100 * entry["tasks"][t]["ci95"][1] for t in tasks]) - xs, 0, None)
            learned = entry["kind"] == "learned"
            ax.errorbar(xs, ys, xerr=[lo, hi], fmt="D" if learned else "o", ms=6 if learned else 5, capsize=2, label=f"{name} (IQM, seeds)" if learned else name)
            if learned:
                for t, y in zip(tasks, ys):
                    runs = 100 * np.asarray(entry["tasks"][t]["runs"])
                    ax.plot(runs, np.full(len(runs), y), "|", color=ax.lines[-1].get_color(), ms=7, alpha=0.7)
        ax.set_title(f"{side}: {SKILL[side][1]} (%)")
        ax.set_xlim(-2, 102)
        ax.grid(axis="x", alpha=0.3)
        ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.06), ncol=3, frameon=False)
    axes[0].set_yticks(range(len(TASK_ORDER)), TASK_ORDER)
    axes[0].invert_yaxis()
    fig.suptitle("Baselines on every task: held-out episodes, 95 % intervals (Wilson for laws, bootstrap over seeds for learners; ticks: each seed)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def profile_figure(table: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(12, 4.6), sharey=True)
    for ax, side in zip(axes, SIDES):
        for name, entry in table[side].items():
            per_task = [np.asarray(r["runs"]) for r in entry["tasks"].values()]
            learned = entry["kind"] == "learned"
            line = ax.plot(100 * TAUS, profile(per_task), lw=2 if learned else 1.2, ls="-" if learned else "--", label=f"{name} ({len(per_task)} task{'s' if len(per_task) != 1 else ''})")[0]
            if learned:
                lo, hi = profile_band(per_task)
                ax.fill_between(100 * TAUS, lo, hi, color=line.get_color(), alpha=0.2)
        ax.set_xlabel(f"threshold τ: {SKILL[side][1]} (%)")
        ax.set_title(f"{side}")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc="upper right")
    axes[0].set_ylabel("fraction of runs scoring above τ")
    fig.suptitle("Performance profiles over the tasks (learners: every task × seed, 95 % stratified bootstrap band)", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
