"""Population training of both sides (``wolfpack league``): policy-space response oracles (PSRO)
with a Nash meta-solver (or, to measure that choice against, a uniform one: fictitious play).

Each side has a population, started from laws or models (by default each side's law of the
task). An iteration:

1. plays every wolf member against every target member on the meta-game's episodes (seeds
   :data:`META_SEED` + k: neither the training worlds nor the held-out episodes), the capture
   rate being the payoff, cached pair by pair;
2. solves the empirical game for each side's Nash mixture (:func:`wolfpack.learn.meta.nash`;
   with ``meta_solver="uniform"`` each population's members weigh alike);
3. trains a best response of each side against the other side's mixture (``wolfpack train
   --opponent A --opponent A --opponent B …``: the trainer's pool draws one member per rollout,
   so a member's copies stand for its weight, in twentieths): from scratch, or with
   ``fine_tune`` from the side's newest saved model (``--init``) — both sides', or one side's
   while the other's best responses start from scratch every iteration;
4. adds both to the populations and logs each mixture's exploitability: what the best
   response the league has achieves against it — the new one, or the population's best member
   (which gets the game's value against a Nash mixture) — the targets' survival against the
   wolves' mixture, the wolves' capture rate against the targets' mixture, and how far both
   go beyond the mixtures' payoff against each other (NashConv).

After the last iteration one final policy per side is trained against the other side's final
mixture: the product, because users play one policy, not a mixture.

Every step is a file: the plan first, each training run a ``wolfpack train`` run folder
(``iter<k>/<side>/``, ``final/<side>/``), the payoffs in ``payoffs.json`` as they are measured,
``progress.json`` after each iteration (with the wall time so far), ``league.json`` last. The
loop reads back whatever is finished, so a league stopped anywhere continues where it stopped
(``resume``) and ends as an uninterrupted one would.
"""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from wolfpack.evaluation import report, rollout
from wolfpack.learn.meta import META_SOLVERS, mixtures
from wolfpack.learn.runs import RunError, TrainRun, check_cluster, check_player, prepare, threads_per_run, train_all
from wolfpack.logs import write_json_atomic
from wolfpack.models import load_policy, native_model_folders
from wolfpack.opponents import Opponent
from wolfpack.sides import SIDES, bring_observation, mode_key
from wolfpack.task import check_task, task_params

#: The first seed of the meta-game's episodes (episode k is world META_SEED + k's first).
META_SEED = 700_000
#: What the league's folder holds besides the plan and the runs.
RESULT_FILE, PROGRESS_FILE, PAYOFFS_FILE, LOGS_DIR = "league.json", "progress.json", "payoffs.json", "logs"
#: A mixture is handed to the trainer's pool in steps of 1/POOL_STEPS.
POOL_STEPS = 20
#: Held-out evaluations during each training run (its own progress; the payoffs are the league's).
EVALUATIONS = 2


class LeagueError(RunError):
    """Bad input to a league, said in one line."""


def plan(
    iterations: int,
    budget: int,
    task: str,
    episodes: int,
    seed: int,
    wolves: Sequence[str] | None,
    targets: Sequence[str] | None,
    fine_tune: bool | str = False,
    meta_solver: str = "nash",
) -> dict:
    """What a league is: what must match for ``resume`` to continue one."""
    for name, value, low in (("--iterations", iterations, 1), ("--budget", budget, 1), ("--episodes", episodes, 1), ("--seed", seed, 0)):
        if not isinstance(value, int) or isinstance(value, bool) or value < low:
            raise LeagueError(f"{name} {value}: a whole number of at least {low}")
    try:
        params = task_params(check_task(task))
    except (ValueError, TypeError) as err:
        raise LeagueError(f"--task: {err}") from None
    start = {"wolves": list(wolves or [params["policies"]["wolves"]]), "targets": list(targets or [params["policies"]["targets"]])}
    for side, members in start.items():
        for member in members:
            check_player(member, side, LeagueError)
    tuned = fine_tuned_sides(fine_tune)
    if meta_solver not in META_SOLVERS:
        raise LeagueError(f"--meta-solver {meta_solver!r}: one of {', '.join(META_SOLVERS)}")
    doc = {"iterations": iterations, "budget": budget, "task": task, "episodes": episodes, "seed": seed, "meta_solver": meta_solver, "meta_seed": META_SEED, **start}
    # Only when asked, so that the plan of a league from scratch reads as it always did: true
    # for both sides, else the one side's name.
    if tuned:
        doc["fine_tune"] = True if tuned == SIDES else tuned[0]
    return doc


def fine_tuned_sides(fine_tune: bool | str) -> tuple[str, ...]:
    """The sides whose runs start from their newest saved model: ``fine_tune`` is True or
    ``"both"`` (both sides), a side's name, or False (none)."""
    if fine_tune is True or fine_tune == "both":
        return SIDES
    if fine_tune is False:
        return ()
    if fine_tune in SIDES:
        return (fine_tune,)
    raise LeagueError(f"--fine-tune {fine_tune!r}: both, {' or '.join(SIDES)}")


def newest_model(members: Sequence[str]) -> str | None:
    """The newest member that is a saved model of ``wolfpack train`` (what a fine-tuned run
    starts from); None while the population holds laws and other kinds of model only."""
    return next((m for m in reversed(members) if native_model_folders(m)), None)


def pool(members: Sequence[str], mixture: np.ndarray) -> list[str]:
    """The trainer's ``--opponent`` list for ``mixture`` over ``members``: each member repeated
    by its weight in twentieths (at least the heaviest once)."""
    counts = np.rint(np.asarray(mixture) * POOL_STEPS).astype(int)
    if counts.sum() == 0:
        counts[int(np.argmax(mixture))] = 1
    return [m for m, c in zip(members, counts) for _ in range(c)]


class Payoffs:
    """The capture rates of wolf members against target members on the meta-game's episodes,
    measured once per pair and kept in ``payoffs.json``."""

    def __init__(self, out: Path, task: str, episodes: int) -> None:
        self.path, self.task, self.episodes = out / PAYOFFS_FILE, task, episodes
        self.table: dict[str, float] = json.loads(self.path.read_text(encoding="utf-8")) if self.path.is_file() else {}
        self._drivers: dict[str, Opponent] = {}
        self._models: dict[str, Callable] = {}

    def _driver(self, member: str) -> Opponent:
        if member not in self._drivers:
            self._drivers[member] = Opponent(member)
        return self._drivers[member]

    def _model(self, member: str, side: str) -> Callable:
        if member not in self._models:
            self._models[member] = load_policy(member, side)
        return self._models[member]

    def rate(self, wolves: str, targets: str) -> float:
        key = f"{wolves} | {targets}"
        if key not in self.table:
            # Each member plays in its own observation and action mode (what it was trained
            # on); a law is its side's scripted law.
            params = task_params(self.task)
            players = {}
            for side, member in (("wolves", wolves), ("targets", targets)):
                driver = self._driver(member)
                if driver.kind == "scripted":
                    params["policies"][side] = driver.law
                    continue
                bring_observation(params, driver.observation)
                if driver.action_mode is not None:
                    params["env"][mode_key(side)] = driver.action_mode
                players[side] = self._model(member, side)
            results = rollout(params, episodes=self.episodes, seed=META_SEED, threads=None, **players)
            self.table[key] = float(report(results, wolves, targets)["capture_rate"])
            write_json_atomic(self.path, self.table)
        return self.table[key]

    def matrix(self, wolves: Sequence[str], targets: Sequence[str]) -> np.ndarray:
        return np.array([[self.rate(w, t) for t in targets] for w in wolves])


def league(
    out: str | Path,
    *,
    iterations: int = 5,
    budget: int = 2_000_000,
    task: str = "hunt-v1",
    episodes: int = 100,
    seed: int = 0,
    wolves: Sequence[str] | None = None,
    targets: Sequence[str] | None = None,
    jobs: int = 1,
    cluster: str | None = None,
    fine_tune: bool | str = False,
    meta_solver: str = "nash",
    resume: bool = False,
    progress: Callable[[dict], None] | None = None,
) -> dict:
    """Runs (or with ``resume`` continues) a league in ``out`` and returns ``league.json``:
    the plan, ``history`` (per iteration: the populations' sizes, both Nash mixtures, the game's
    value, each mixture's exploitability and NashConv, the best responses' models and training
    times), ``final`` (the final mixtures and the final policy of each side), the payoff matrix
    and ``wall_s``. ``jobs`` = 2 trains both sides' runs of a step at once, on half the cores
    each (here, or on Ray: ``cluster``, see :func:`wolfpack.learn.runs.train_all`);
    ``fine_tune`` (True or ``"both"``, or one side's name): each run of that side starts from
    the side's newest saved model of ``wolfpack train`` (``--init``: a pack improved against the
    best responses it met, rather than a new one from scratch every iteration); fine-tuning the
    wolves alone keeps the targets' best responses fresh, which search away from the escapers
    the population already holds; ``meta_solver``: ``nash`` or ``uniform``
    (:data:`~wolfpack.learn.meta.META_SOLVERS`); ``progress`` is called with each iteration's
    record."""
    out = Path(out).resolve()  # the members' paths: the same from any working folder
    the_plan = plan(iterations, budget, task, episodes, seed, wolves, targets, fine_tune, meta_solver)
    if not isinstance(jobs, int) or isinstance(jobs, bool) or jobs not in (1, 2):
        raise LeagueError(f"--jobs {jobs}: 1 or 2 (the two sides' runs of a step)")
    check_cluster(cluster, LeagueError)
    prepare(out, the_plan, resume, RESULT_FILE, "league")
    tuned = fine_tuned_sides(fine_tune)
    threads = threads_per_run(jobs)
    payoffs = Payoffs(out, task, episodes)
    pops = {side: list(the_plan[side]) for side in SIDES}
    # Wall time over invocations: a resumed league adds what the earlier ones recorded up to
    # their last finished iteration (the part of an interrupted one after it is not counted).
    progress_path = out / PROGRESS_FILE
    earlier_s = float(json.loads(progress_path.read_text(encoding="utf-8")).get("wall_s", 0.0)) if resume and progress_path.is_file() else 0.0
    started = time.perf_counter() - earlier_s
    records = []

    def train_both(folder: Path, opponents: dict[str, list[str]], run_seed: int) -> dict[str, dict]:
        def run(side: str) -> TrainRun:
            options = ["--side", side, "--task", task, "--timesteps", str(budget), "--seed", str(run_seed), "--eval-episodes", str(episodes), "--evaluations", str(EVALUATIONS)]
            options += [a for o in opponents[side] for a in ("--opponent", o)]
            options += ["--threads", str(threads), "--torch-threads", str(threads)]
            start = newest_model(pops[side]) if side in tuned else None
            if start is not None:
                options += ["--init", start]
            return TrainRun(folder / side, options, out / LOGS_DIR / f"{folder.name}_{side}.log")

        return dict(zip(SIDES, train_all([run(side) for side in SIDES], jobs, cluster)))

    for it in range(1, iterations + 1):
        m = payoffs.matrix(pops["wolves"], pops["targets"])
        x, y, value = mixtures(m, meta_solver)
        folder = out / f"iter{it}"
        summaries = train_both(folder, {"wolves": pool(pops["targets"], y), "targets": pool(pops["wolves"], x)}, seed * 1000 + it)
        new = {side: str(folder / side / side) for side in SIDES}
        # What each new best response achieves against the mixture it was trained against.
        wolves_br = float(sum(y[j] * payoffs.rate(new["wolves"], t) for j, t in enumerate(pops["targets"])))
        targets_br = float(sum(x[i] * payoffs.rate(w, new["targets"]) for i, w in enumerate(pops["wolves"])))
        best_wolves = max(wolves_br, float((m @ y).max()))  # the best capture rate against y
        best_targets = min(targets_br, float((x @ m).min()))  # the best survival against x, as 1 - capture
        record = {
            "iteration": it,
            "population": {side: len(pops[side]) for side in SIDES},
            "mixtures": {"wolves": _weights(out, pops["wolves"], x), "targets": _weights(out, pops["targets"], y)},
            "value": value,
            # A wolf mixture's exploitability: the survival of the best response the league has
            # against it (the new one, or the population's best member, which gets exactly the
            # game's value against a Nash mixture); a target mixture's: the capture rate of the
            # wolves' best. A best response trained briefly may do worse than the population.
            "best_response_rates": {"wolves": wolves_br, "targets": targets_br},
            "exploitability": {"wolves": 1.0 - best_targets, "targets": best_wolves},
            # Each side's best gain over the mixtures' payoff (for Nash mixtures the excess over
            # the game's value).
            "nash_conv": best_wolves - best_targets,
            "best_responses": {side: {"model": str(Path(new[side]).relative_to(out)), "agent_steps": summaries[side]["agent_steps"], "train_s": summaries[side]["train_s"]} for side in SIDES},
        }
        records.append(record)
        for side in SIDES:
            pops[side].append(new[side])
        write_json_atomic(progress_path, {"finished": False, "history": records, "wall_s": time.perf_counter() - started})
        if progress is not None:
            progress(record)

    m = payoffs.matrix(pops["wolves"], pops["targets"])
    x, y, value = mixtures(m, meta_solver)
    final_dir = out / "final"
    finals = train_both(final_dir, {"wolves": pool(pops["targets"], y), "targets": pool(pops["wolves"], x)}, seed * 1000 + iterations + 1)
    doc = {
        **the_plan,
        "history": records,
        "final": {
            "mixtures": {"wolves": _weights(out, pops["wolves"], x), "targets": _weights(out, pops["targets"], y)},
            "value": value,
            "policies": {side: {"model": f"final/{side}/{side}", "agent_steps": finals[side]["agent_steps"], "train_s": finals[side]["train_s"]} for side in SIDES},
        },
        "payoffs": {"wolves": [_label(out, w) for w in pops["wolves"]], "targets": [_label(out, t) for t in pops["targets"]], "capture_rate": m.tolist()},
        "wall_s": time.perf_counter() - started,
    }
    write_json_atomic(out / RESULT_FILE, doc)  # last: a folder with league.json is finished
    return doc


def _label(out: Path, member: str) -> str:
    """A member as league.json names it: a law by its name, a model of the league by its path
    in the league's folder."""
    path = Path(member)
    return str(path.relative_to(out)) if path.is_absolute() and path.is_relative_to(out) else member


def _weights(out: Path, members: Sequence[str], mixture: np.ndarray) -> dict[str, float]:
    return {_label(out, m): float(w) for m, w in zip(members, mixture) if w > 0}
