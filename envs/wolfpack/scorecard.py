"""The scorecard of ``wolfpack benchmark``: one policy on every task of the suite, on held-out
episodes, ranked against the committed baselines (docs/tasks.md, "Scorecards").

A policy plays one side — wolves or targets — against the other side's scripted law of each
task (``policies.*`` in the task's params: ``escape`` targets, ``seed000`` wolves). Its score on
a task is the rate that side is after: **captured** for wolves, **survived** for targets, over
episodes ``seed .. seed + episodes − 1`` (default: the trainer's held-out episodes, 500000 + k,
which no training run meets), with a 95 % Wilson interval. Deterministic policies (a model's
Gaussian mean) meet identical episodes, so two scorecards with the same episodes compare
policies, not luck.

A policy built for another observation size than a task's (a 5-wolf model on ``small-pack-v1``,
one target's on ``two-targets-v1``) cannot play that task: the task is marked skipped with the
one-line reason, and a policy that fits no task is an error.

The baselines a scorecard is ranked among come from two files beside this module (linked from
``results/benchmark/`` in the repository):

- ``baselines.json``: per side, the analytic laws' scores on the same episodes, written by
  ``python benchmarks/benchmark_baselines.py``;
- ``learned.json``: the learned baselines (IPPO and MAPPO wolves, a MAPPO escaper, 5 training
  seeds each), written by ``python training/task_baselines.py``; a learner enters a task's
  ranking with the interquartile mean of its seeds' scores on the same episodes.

A scorecard's rank on a task is 1 + the number of baselines of its side that scored higher.

``overrides`` (dotted params keys, ``--set`` on the command line) apply to every task. Keys that
change the world or its rules make each task a *modified task* (docs/tasks.md), and the
scorecard says so in its header; any override — even a learner's observation (``env.*``) or
the other side's law — leaves the committed baselines' episodes behind, so a scorecard with
overrides is not ranked.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any, Callable, Mapping, Sequence

from wolfpack.batch import ObservationSizeError
from wolfpack.evaluation import HELD_OUT_SEED, report, rollout, wilson_interval
from wolfpack.generalisation import VARIATION_ORDER, check_variation, variation_params
from wolfpack.opponents import Opponent
from wolfpack.sides import OTHER_SIDE, SCRIPTED_LAWS, SIDES
from wolfpack.task import TASK_ORDER, check_task, outcome_changes, task_params

#: The committed baselines: the analytic laws, and the learners' IQMs over training seeds.
BASELINES_FILE = Path(__file__).with_name("baselines.json")
LEARNED_FILE = Path(__file__).with_name("learned.json")
#: Episodes per task unless told otherwise.
DEFAULT_EPISODES = 200
#: What each side is scored on: the report's key and how tables name it.
SKILL = {"wolves": ("capture_rate", "captured"), "targets": ("survival_rate", "survived")}


def as_policy(policy: Any, side: str) -> Opponent:
    """``policy`` (a law's name, a saved model's path, an SB3 model or a callable
    ``obs [n, D] -> actions [n, 2]``) as the deterministic driver of ``side``; a ValueError
    naming the problem (a law of the other side, a model of the other side, no such file)."""
    if side not in SIDES:
        raise ValueError(f"side must be 'wolves' or 'targets', got {side!r}")
    if isinstance(policy, Opponent):
        if policy.side not in (None, side):
            raise ValueError(f"{policy.name!r} drives the {policy.side}, not the {side}")
        return policy
    return Opponent(policy, side=side, deterministic=True, role="policy")


def score_task(
    policy: Opponent,
    side: str,
    task: str,
    *,
    episodes: int = DEFAULT_EPISODES,
    seed: int = HELD_OUT_SEED,
    threads: int | None = None,
    progress: Callable[[int], None] | None = None,
    overrides: Mapping[str, Any] | None = None,
    params: dict | None = None,
) -> dict:
    """``policy`` driving ``side`` on ``task`` (with ``overrides`` on top; or on ``params``, a
    world no task file holds, ``task`` then naming it): the evaluation report
    (:func:`wolfpack.evaluation.report`) with ``score`` and ``score_ci95`` added, or
    ``{"skipped": reason}`` when its observation does not fit the task."""
    params = task_params(check_task(task), overrides) if params is None else params
    other_law = params["policies"][OTHER_SIDE[side]]
    try:
        results = rollout(params, episodes=episodes, seed=seed, threads=threads, opponent=policy, progress=progress)
    except ObservationSizeError as error:
        if progress is not None:
            progress(episodes)
        return {"skipped": error.reason or f"it takes {error.wanted} observations, the {side} of {task} have {error.here}"}
    names = {side: policy.name, OTHER_SIDE[side]: other_law}
    row = report(results, names["wolves"], names["targets"])
    row.pop("capture_steps")
    key = SKILL[side][0]
    hits = round(row[key] * row["episodes"])
    row["score"] = row[key]
    row["score_ci95"] = list(wilson_interval(hits, row["episodes"]))
    row["target_count"] = params["world"]["targets"]
    return row


def load_baselines(path: str | Path | None = None, learned: str | Path | None = None) -> dict:
    """The committed baselines: ``{"episodes", "first_seed", "wolves": {name: entry},
    "targets": {name: entry}}``, each entry ``{"kind", "tasks": {task: {"score", "score_ci95",
    ...}}}``: the laws of ``path`` (default ``baselines.json``) with ``kind: "law"``, and the
    learners of ``learned`` (default ``learned.json``) that were scored on the same episodes, with
    ``kind: "learned"`` and the IQM over their training seeds as the score. An empty set when the
    laws' file is absent."""
    path = Path(path) if path is not None else BASELINES_FILE
    if not path.exists():
        return {"episodes": None, "first_seed": None, "wolves": {}, "targets": {}}
    base = json.loads(path.read_text(encoding="utf-8"))
    learned = Path(learned) if learned is not None else LEARNED_FILE
    if learned.exists():
        _add_learned(base, json.loads(learned.read_text(encoding="utf-8")))
    return base


def best_law(baselines: dict, side: str, task: str) -> tuple[str, float] | None:
    """The committed law of ``side`` that scores most on ``task`` (:func:`load_baselines`), as
    (its name, its score: the capture rate for wolves, the survival rate for targets); None
    where no law was scored on it."""
    laws = {name: entry["tasks"][task]["score"] for name, entry in baselines.get(side, {}).items() if entry["kind"] == "law" and task in entry.get("tasks", {})}
    return max(laws.items(), key=lambda kv: kv[1]) if laws else None


def _add_learned(base: dict, learned: dict) -> None:
    """Adds ``learned``'s learners (task_baselines.py's summary) to ``base`` as baselines of their
    side, where they were scored on ``base``'s episodes: a learner's score on a task is the IQM
    of its seeds' scores, its interval the bootstrap interval over seeds."""
    if (learned.get("episodes"), learned.get("first_seed")) != (base.get("episodes"), base.get("first_seed")):
        return
    for name, spec in learned.get("learners", {}).items():
        tasks = {task: {"score": row[name]["iqm"], "score_ci95": row[name]["ci95"], "seeds": row[name]["n"]} for task, row in learned.get("summary", {}).items() if name in row}
        if tasks:
            base.setdefault(spec["side"], {})[name] = {"kind": "learned", "tasks": tasks}


def exploitability_entry(folder: str | Path, driver: Opponent, side: str) -> dict:
    """The summary a scorecard carries of a finished ``wolfpack exploit`` run in ``folder``
    (its ``exploit.json``), which must be of the scored policy and side: ``{"source", "task",
    "measure", "budgets": [{"agent_steps", "seeds", "iqm", "ci95"}]}``. ValueError in one line
    when there is none or it exploited another policy."""
    path = Path(folder) / "exploit.json"
    if not path.is_file():
        raise ValueError(f"--exploit {folder}: no finished exploitability run there (exploit.json missing; 'wolfpack exploit --{side} {driver.name} --out {folder}' makes one)")
    doc = json.loads(path.read_text(encoding="utf-8"))
    if doc.get("side") != side or as_policy(doc.get("policy"), side).name != driver.name:
        raise ValueError(f"--exploit {folder}: it exploited {doc.get('policy')!r} ({doc.get('side')}), not {driver.name!r} ({side})")
    budgets = [{k: b[k] for k in ("agent_steps", "seeds", "iqm", "ci95")} for b in doc["budgets"]]
    return {"source": str(folder), "task": doc["task"], "measure": doc["measure"], "budgets": budgets}


def rank(score: float, others: Sequence[float]) -> int:
    """1 + how many of ``others`` scored strictly higher."""
    return 1 + sum(1 for s in others if s > score)


def scorecard(
    policy: Any,
    side: str,
    *,
    tasks: Sequence[str] | None = None,
    episodes: int = DEFAULT_EPISODES,
    seed: int = HELD_OUT_SEED,
    threads: int | None = None,
    baselines: dict | None = None,
    progress: Callable[[int], None] | None = None,
    overrides: Mapping[str, Any] | None = None,
    track: str = "tasks",
) -> dict:
    """Plays ``policy`` as ``side`` on ``tasks`` (default: every task), each with ``overrides``
    on top, and ranks it against ``baselines`` (default: the committed ones) where they were
    measured on the same episodes of the same tasks (never with overrides). Returns the
    scorecard (what ``scorecard.json`` holds).

    ``track="generalisation"``: the variations of :mod:`wolfpack.generalisation` instead of the
    tasks (``tasks`` then names variations), ranked against the side's three laws played on
    the same episodes of each variation (:func:`generalisation_scorecard`)."""
    if track == "generalisation":
        return generalisation_scorecard(policy, side, variations=tasks, episodes=episodes, seed=seed, threads=threads, progress=progress, overrides=overrides)
    if track != "tasks":
        raise ValueError(f"track must be 'tasks' or 'generalisation', got {track!r}")
    overrides = dict(overrides or {})
    driver = as_policy(policy, side)
    tasks = list(TASK_ORDER if tasks is None else tasks)
    for task in tasks:
        check_task(task)
    if not tasks:
        raise ValueError("no tasks to play")
    baselines = load_baselines() if baselines is None else baselines
    for task in tasks:
        task_params(task, overrides)  # a bad key or value fails here, before any episode
    comparable = baselines.get("episodes") == episodes and baselines.get("first_seed") == seed and not overrides
    rows: dict[str, dict] = {}
    for task in tasks:
        row = score_task(driver, side, task, episodes=episodes, seed=seed, threads=threads, progress=progress, overrides=overrides)
        if "score" in row:
            theirs = {name: entry["tasks"][task]["score"] for name, entry in baselines.get(side, {}).items() if comparable and task in entry.get("tasks", {}) and "score" in entry["tasks"][task]}
            theirs.pop(driver.name, None)  # a baseline is not ranked against itself
            row["baselines"] = theirs
            row["rank"] = rank(row["score"], list(theirs.values())) if theirs else None
            row["ranked_among"] = len(theirs) + 1 if theirs else None
        rows[task] = row
    return _card(driver, side, rows, episodes, seed, overrides, "committed baselines" if comparable else None, {name: entry["kind"] for name, entry in baselines.get(side, {}).items()})


def generalisation_scorecard(
    policy: Any,
    side: str,
    *,
    variations: Sequence[str] | None = None,
    episodes: int = DEFAULT_EPISODES,
    seed: int = HELD_OUT_SEED,
    threads: int | None = None,
    progress: Callable[[int], None] | None = None,
    overrides: Mapping[str, Any] | None = None,
) -> dict:
    """``policy`` as ``side`` on the generalisation track's variations (default: all), each row
    ranked against the side's scripted laws played on the same episodes of the same variation
    (``progress`` counts the laws' episodes too). The same scorecard format, with
    ``track: generalisation``."""
    overrides = dict(overrides or {})
    driver = as_policy(policy, side)
    names = list(VARIATION_ORDER if variations is None else variations)
    if not names:
        raise ValueError("no variations to play")
    worlds = {name: variation_params(check_variation(name), overrides) for name in names}  # bad keys fail before any episode
    laws = track_rivals(driver, side)
    rows: dict[str, dict] = {}
    for name, params in worlds.items():
        row = score_task(driver, side, name, episodes=episodes, seed=seed, threads=threads, progress=progress, params=params)
        if "score" not in row:  # a variation the policy cannot play: no laws to rank it among
            if progress is not None:
                progress(episodes * len(laws))
            rows[name] = row
            continue
        theirs = {law: score_task(as_policy(law, side), side, name, episodes=episodes, seed=seed, threads=threads, progress=progress, params=params)["score"] for law in laws}
        row["baselines"] = theirs
        row["rank"] = rank(row["score"], list(theirs.values())) if theirs else None
        row["ranked_among"] = len(theirs) + 1 if theirs else None
        rows[name] = row
    card = _card(driver, side, rows, episodes, seed, overrides, "the laws on the same episodes", {law: "law" for law in TRACK_LAWS[side]})
    card["track"] = "generalisation"
    return card


#: The laws each side is ranked against on the generalisation track: every pursuit law, and the
#: one target law that evades (random and still are not opponents worth a rank).
TRACK_LAWS = {"wolves": SCRIPTED_LAWS["wolves"], "targets": ("escape",)}


def track_rivals(driver: Opponent, side: str) -> list[str]:
    """The laws ``driver`` is ranked among on the generalisation track (itself left out)."""
    return [law for law in TRACK_LAWS[side] if law != driver.law]


def _card(driver: Opponent, side: str, rows: dict[str, dict], episodes: int, seed: int, overrides: dict, ranked_against: str | None, baseline_kinds: dict) -> dict:
    """The scorecard of ``rows`` (ValueError when ``driver`` played none of them)."""
    tasks = list(rows)
    played = [t for t in tasks if "score" in rows[t]]
    if not played:
        reasons = {rows[t]["skipped"] for t in tasks}
        raise ValueError(f"{driver.name!r} fits none of the tasks: {'; '.join(sorted(reasons))}")
    return {
        "policy": driver.name,
        "kind": driver.kind,
        "side": side,
        "skill": SKILL[side][0],
        "episodes": episodes,
        "first_seed": seed,
        "deterministic": True,
        "overrides": overrides,
        "modified_task": bool(outcome_changes(overrides)),
        "ranked_against": ranked_against,
        "baseline_kinds": baseline_kinds,
        "tasks": rows,
        "tasks_played": played,
        "mean_score": sum(rows[t]["score"] for t in played) / len(played),
        "date": time.strftime("%Y-%m-%d %H:%M:%S %Z"),
        "versions": _versions(),
    }


def _versions() -> dict:
    import platform
    import sys
    from importlib import metadata

    import numpy

    out = {"wolfpack": metadata.version("wolfpack"), "numpy": numpy.__version__, "python": sys.version.split()[0], "machine": platform.machine()}
    try:
        out["torch"] = metadata.version("torch")
    except metadata.PackageNotFoundError:
        pass
    return out


def markdown(card: dict) -> str:
    """The scorecard as a Markdown table, one row per task."""
    side, (_, verb) = card["side"], SKILL[card["side"]]
    other = OTHER_SIDE[side]
    track = card.get("track") == "generalisation"
    lines = [
        f"# Scorecard: {card['policy']} ({side}){' on modified tasks' if card.get('modified_task') else ''}{', generalisation track' if track else ''}",
        "",
        *_overrides_lines(card.get("overrides") or {}),
        *(['Variations of `hunt-v1` that no task file holds (docs/tasks.md, "The generalisation track").', ""] if track else []),
        f"{card['episodes']} deterministic episodes per task (seeds {card['first_seed']}..{card['first_seed'] + card['episodes'] - 1}), "
        f"against each task's scripted {other}; score = {verb}, with its 95 % Wilson interval. "
        + (
            "Rank among the laws of the same side, played on the same episodes of each variation."
            if track
            else "Rank among the committed baselines of the same episodes (the analytic laws, and the learned baselines by the interquartile mean of their training seeds)."
            if card["ranked_against"]
            else "No ranks: the committed baselines played other tasks."
            if card.get("overrides")
            else "No committed baselines for these episodes: no ranks."
        ),
        "",
        f"| task | {verb} (95 % interval) | {COLLISIONS_HEADER[side]} | timeouts | rank | best baseline |",
        "|---|---|---:|---:|---:|---|",
    ]
    for task, row in card["tasks"].items():
        if "skipped" in row:
            lines.append(f"| `{task}` | skipped: {row['skipped']} | | | | |")
            continue
        lo, hi = row["score_ci95"]
        best = max(row["baselines"].items(), key=lambda kv: kv[1]) if row.get("baselines") else None
        rank_text = f"{row['rank']} of {row['ranked_among']}" if row.get("rank") else "—"
        best_text = f"{best[0]} {100 * best[1]:.1f} %" if best else "—"
        collisions = row["collision_rate"] if side == "wolves" else row["target_collision_rate"]
        lines.append(f"| `{task}` | **{100 * row['score']:.1f} %** ({100 * lo:.1f}–{100 * hi:.1f}) | {100 * collisions:.1f} % | {100 * row['timeout_rate']:.1f} % | {rank_text} | {best_text} |")
    played = len(card["tasks_played"])
    lines += ["", f"Mean over the {played} task{'s' if played != 1 else ''} played: {100 * card['mean_score']:.1f} %.", ""]
    lines += _partial_captures_lines(card) if side == "wolves" else []
    if card.get("exploitability"):
        ex = card["exploitability"]
        what = "survival of escapers" if side == "wolves" else "capture rate of packs"
        lines += [
            f"Exploitability on `{ex['task']}` (the {what} trained from scratch against it, IQM over seeds [95 % CI]; `{ex['source']}`): "
            + "; ".join(f"{b['agent_steps']:,} agent-steps: **{100 * b['iqm']:.1f} %** [{100 * b['ci95'][0]:.1f}, {100 * b['ci95'][1]:.1f}] ({b['seeds']} seeds)" for b in ex["budgets"])
            + ".",
            "",
        ]
    return "\n".join(lines)


def _partial_captures_lines(card: dict) -> list[str]:
    """With several targets a capture counts only when every target is taken; how far the pack
    got beside it (at least one target, and how many on average), for every such task."""
    lines = []
    for task, row in card["tasks"].items():
        if row.get("target_count", 1) > 1 and "any_capture_rate" in row:
            lines.append(
                f"`{task}` ({row['target_count']} targets): at least one taken in {100 * row['any_capture_rate']:.1f} % of episodes, "
                f"{row['mean_targets_captured']:.2f} of {row['target_count']} on average."
            )
    return [*lines, ""] if lines else []


def _overrides_lines(overrides: Mapping[str, Any]) -> list[str]:
    """The header's account of ``overrides``: which keys made the tasks modified ones."""
    if not overrides:
        return []
    given = ", ".join(f"`{k}={v}`" for k, v in overrides.items())
    changed = outcome_changes(overrides)
    what = (
        f"**Modified tasks**: {', '.join(f'`{k}`' for k in changed)} change{'s' if len(changed) == 1 else ''} the world or its rules"
        if changed
        else "None of them changes the world or its rules (they set what a learner observes or is paid, or who plays)"
    )
    return [f"Every task played with {given}. {what}.", ""]


#: The collision column of each side: episodes ended by a wolf collision, or in which a target
#: touched an obstacle.
COLLISIONS_HEADER = {"wolves": "wolf collisions", "targets": "target collisions"}

#: How the figure's legend names each kind of baseline.
_KIND_LABEL = {"law": "law", "learned": "learned, IQM of seeds"}


def figure(card: dict, path: str | Path) -> None:
    """The scorecard as a dot plot: per task, the policy's score with its interval against the
    baselines' scores."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    tasks = list(card["tasks"])
    fig, ax = plt.subplots(figsize=(7.5, 0.55 * len(tasks) + 1.6))
    markers = "sD^vP*X"
    names = sorted({n for row in card["tasks"].values() for n in row.get("baselines", {})})
    for k, name in enumerate(names):
        ys = [i for i, t in enumerate(tasks) if name in card["tasks"][t].get("baselines", {})]
        xs = [100 * card["tasks"][tasks[i]]["baselines"][name] for i in ys]
        ax.scatter(
            xs,
            [y + 0.18 for y in ys],
            marker=markers[k % len(markers)],
            s=28,
            color="0.55",
            edgecolor="0.25",
            linewidth=0.5,
            label=f"{name} ({_KIND_LABEL.get(card.get('baseline_kinds', {}).get(name), 'baseline')})",
            zorder=2,
        )
    played = [i for i, t in enumerate(tasks) if "score" in card["tasks"][t]]
    xs = [100 * card["tasks"][tasks[i]]["score"] for i in played]
    lo = [x - 100 * card["tasks"][tasks[i]]["score_ci95"][0] for x, i in zip(xs, played)]
    hi = [100 * card["tasks"][tasks[i]]["score_ci95"][1] - x for x, i in zip(xs, played)]
    ax.errorbar(xs, [y - 0.1 for y in played], xerr=[lo, hi], fmt="o", color="tab:blue", ecolor="tab:blue", capsize=3, markersize=6, label=f"{card['policy']} (95 % interval)", zorder=3)
    for i, t in enumerate(tasks):
        if "skipped" in card["tasks"][t]:
            ax.text(1, i, f"skipped: {card['tasks'][t]['skipped']}", va="center", fontsize=8, color="0.4")
    ax.set_yticks(range(len(tasks)), tasks)
    ax.invert_yaxis()
    ax.set_xlim(-1.5, 101.5)
    ax.set_xlabel(f"{SKILL[card['side']][1]} (% of {card['episodes']} held-out episodes)")
    ax.grid(axis="x", color="0.9")
    ax.set_axisbelow(True)
    scope = "every variation" if card.get("track") == "generalisation" else "every task" if tasks == list(TASK_ORDER) else ", ".join(tasks)
    fig.suptitle(f"{card['policy']} as the {card['side']}, on {scope}", fontsize=11)
    ax.legend(loc="lower center", bbox_to_anchor=(0.5, 1.0), ncol=3, fontsize=8, frameon=False)
    fig.tight_layout()
    fig.savefig(path, dpi=110, bbox_inches="tight")  # a long policy name widens the legend
    plt.close(fig)


def write(card: dict, out: str | Path) -> list[Path]:
    """``scorecard.json``, ``scorecard.md`` and ``scorecard.png`` into ``out``; the JSON last,
    so that a folder without it is visibly unfinished."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "scorecard.json", out / "scorecard.md", out / "scorecard.png"]
    figure(card, paths[2])
    paths[1].write_text(markdown(card), encoding="utf-8")
    paths[0].write_text(json.dumps(card, indent=1) + "\n", encoding="utf-8")
    return paths
