"""Long jobs made of many ``wolfpack train`` runs (``wolfpack exploit``, ``wolfpack league``): the
folder that holds them and each training run in a child process.

A job's folder holds ``plan.json`` (its configuration, written first), the runs, and its
result file (written last): a folder without the result is unfinished, and ``resume``
continues it only with the same plan. Each run is a ``wolfpack train`` run folder: one whose
``summary.json`` exists is finished and read back; one cut short after its first saved state
continues with the trainer's own ``--resume``; one cut short before it starts again.

The runs of a step are independent, and :func:`train_all` trains them where the job says:
here, several at once in child processes (the default), or as tasks of Ray (``cluster``), the
distributed engine the RLlib path already uses: a Ray started on this machine for the job
(``"local"``), or a running cluster (``"auto"`` or its address) whose nodes see the job's
folder, and the working folder the job was started from, at the same paths (a shared file
system) and have wolfpack installed. Where a run trains
does not change what it learns: a run is bit-identical given its seed and its thread counts
(docs/interface.md, "wolfpack train"), and each run gets this machine's cores / ``jobs``
wherever it trains.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor, as_completed
from pathlib import Path
from typing import Callable, NamedTuple, Sequence

from wolfpack._optional import require
from wolfpack.learn.run import default_threads
from wolfpack.logs import write_json_atomic
from wolfpack.opponents import Opponent

PLAN_FILE = "plan.json"


class RunError(ValueError):
    """Bad input to a job, or a job folder that does not fit it, said in one line."""


def check_player(policy: str, side: str, error: type[RunError] = RunError) -> Opponent:
    """``policy`` (a law's name or a saved model) as the driver of ``side``; ``error`` in one
    line naming it when it is neither, or plays the other side."""

    try:
        driver = Opponent(policy)
    except (ValueError, FileNotFoundError, OSError) as err:
        raise error(f"--{side} {policy}: {err}") from None
    if driver.side is not None and driver.side != side:
        raise error(f"--{side} {policy}: it plays the {driver.side}, not the {side}")
    return driver


def threads_per_run(jobs: int) -> int:
    """Each of ``jobs`` training runs at once gets its share of the cores (at least one)."""

    return max(1, default_threads()[0] // jobs)


def prepare(out: Path, plan: dict, resume: bool, result_file: str, what: str) -> None:
    """Checks ``out`` before anything runs: new or empty (or, with ``resume``, an unfinished job
    of the same plan), and writes the plan there. ``what`` names the job in messages (an
    exploitability run, a league)."""
    plan_path = out / PLAN_FILE
    if resume:
        if not plan_path.is_file():
            raise RunError(f"--resume: {out} holds no {what} ({PLAN_FILE} missing)")
        earlier = json.loads(plan_path.read_text(encoding="utf-8"))
        changed = [k for k in plan if earlier.get(k) != plan[k]]
        if changed:
            raise RunError(f"--resume: {out} is {'an' if what[0] in 'aeiou' else 'a'} {what} of another configuration ({', '.join(f'{k}: {earlier.get(k)!r} there' for k in changed)})")
        if (out / result_file).is_file():
            raise RunError(f"--resume: {out} is finished ({result_file} is there); choose another --out to run it again")
        return
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        hint = "; --resume continues it" if plan_path.is_file() and not (out / result_file).is_file() else ""
        raise RunError(f"--out {out}: not a new or empty folder{hint}")
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(plan_path, plan)


def train(folder: Path, options: Sequence[str], log: Path, cwd: str | None = None) -> dict:
    """The summary of the ``wolfpack train OPTIONS --out folder`` run: read back when finished,
    else trained (or continued) now in a child process whose output goes to ``log``, started in
    ``cwd`` (default: this process's working folder; the options' paths are relative to it).
    KeyboardInterrupt when the child was interrupted; RuntimeError naming the log when it
    failed."""
    summary_path = folder / "summary.json"
    if not summary_path.is_file():
        resumable = (folder / "trainer.pt").is_file() or any((folder / "checkpoints").glob("*/trainer.pt"))
        if folder.exists() and not resumable:
            shutil.rmtree(folder)  # stopped before its first state: start it again
        folder.parent.mkdir(parents=True, exist_ok=True)
        log.parent.mkdir(parents=True, exist_ok=True)
        cmd = [sys.executable, "-m", "wolfpack", "train", *options, "--no-progress", "--out", str(folder), *(["--resume"] if resumable else [])]
        with log.open("a", encoding="utf-8") as f:
            code = subprocess.run(cmd, stdout=f, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, cwd=cwd).returncode
        if code == 130:
            raise KeyboardInterrupt
        if code != 0 or not summary_path.is_file():
            lines = log.read_text(encoding="utf-8", errors="replace").strip().splitlines()
            raise RuntimeError(f"the training run {folder} failed (exit {code}): {lines[-1] if lines else 'no output'} (log: {log})")
    return json.loads(summary_path.read_text(encoding="utf-8"))


class TrainRun(NamedTuple):
    """One ``wolfpack train`` run of a job: its folder, its options and its log."""

    folder: Path
    options: Sequence[str]
    log: Path


#: ``cluster`` values that are not an address: Ray started on this machine for the job.
LOCAL_RAY = "local"


def check_cluster(cluster: str | None, error: type[RunError] = RunError) -> None:
    """``cluster`` is None (child processes here), ``"local"`` or a Ray address; with Ray, Ray
    must be installed (the ``[rllib]`` extra). ``error`` in one line otherwise."""
    if cluster is None:
        return
    if not isinstance(cluster, str) or not cluster.strip():
        raise error(f"--cluster {cluster!r}: 'local', 'auto' or a Ray address such as ray://head:10001")
    try:
        require("ray", "--cluster")
    except ImportError as err:
        raise error(str(err)) from None


def train_all(runs: Sequence[TrainRun], jobs: int, cluster: str | None = None, done: Callable[[int, dict], None] | None = None) -> list[dict]:
    """The summaries of ``runs`` (:func:`train` each), in their order; ``done(k, summary)`` is
    called as run k finishes. ``cluster`` None: ``jobs`` at once here, each in a child process;
    else as Ray tasks of ``cores / jobs`` CPUs each (:func:`check_cluster`). Ctrl-C stops every
    run (each child process is killed; its folder continues with the trainer's ``--resume``)."""
    results: list[dict | None] = [None] * len(runs)

    def finished(k: int, summary: dict) -> None:
        results[k] = summary
        if done is not None:
            done(k, summary)

    if cluster is not None:
        _train_on_ray(runs, jobs, cluster, finished)
    elif jobs == 1:
        for k, run in enumerate(runs):
            finished(k, train(*run))
    else:
        with ThreadPoolExecutor(max_workers=jobs) as pool:
            futures = {pool.submit(train, *run): k for k, run in enumerate(runs)}
            for future in as_completed(futures):
                finished(futures[future], future.result())
    return results  # type: ignore[return-value]


def _train_on_ray(runs: Sequence[TrainRun], jobs: int, cluster: str, finished: Callable[[int, dict], None]) -> None:
    """:func:`train` of each run as a Ray task (the worker starts the same child process as a
    run here does). Ray started for the job is stopped after it; a cluster is left running."""
    ray = require("ray", "--cluster")
    started_here = not ray.is_initialized()
    if started_here:
        if cluster == LOCAL_RAY:
            ray.init(num_cpus=default_threads()[0], include_dashboard=False, log_to_driver=False, configure_logging=False)
        else:
            ray.init(address=cluster, log_to_driver=False, configure_logging=False)
    try:
        task = ray.remote(num_cpus=threads_per_run(jobs), max_retries=0)(train)
        # A worker starts in a folder of Ray's: the run starts where this process works, so that
        # the paths the options name (a model to play against or start from) are found.
        here = os.getcwd()
        pending = {task.remote(run.folder.resolve(), list(run.options), run.log.resolve(), here): k for k, run in enumerate(runs)}
        try:
            while pending:
                ready, _ = ray.wait(list(pending), num_returns=1)
                k = pending.pop(ready[0])
                finished(k, ray.get(ready[0]))
        except BaseException:
            # Ctrl-C (or a failed run): stop the others. A cancelled task gets KeyboardInterrupt,
            # on which subprocess.run kills its child.
            for ref in pending:
                ray.cancel(ref)
            raise
    finally:
        if started_here:
            ray.shutdown()


#: The file in a run folder that holds its held-out evaluation.
HELD_OUT_FILE = "held_out.json"


def held_out(folder: Path, episodes: int, evaluate: Callable[[], dict], reevaluate: bool = False) -> dict:
    """``evaluate()``'s row for the run in ``folder``, cached in its ``held_out.json`` with the
    episode count; recomputed when the count differs or ``reevaluate`` (after a change to the
    core, which moves every trajectory)."""
    cache = folder / HELD_OUT_FILE
    if cache.exists() and not reevaluate:
        row = json.loads(cache.read_text())
        if row.get("episodes") == episodes:
            return row
    row = {"episodes": episodes, **evaluate()}
    cache.write_text(json.dumps(row, indent=1) + "\n")
    return row
