"""``wolfpack train``: the native trainer's command line (registered by :mod:`wolfpack.cli`)."""

from __future__ import annotations

import argparse
import json
import os
import shlex
import sys
from pathlib import Path
from typing import Any, Sequence

from wolfpack._checks import is_int
from wolfpack.evaluation import TRAIN_SEED_BASE
from wolfpack.learn.recipes import ALGOS, LEARNERS, recipe, recipes_params_overrides
from wolfpack.learn.tasks import TASK_WEIGHTS, VARIANTS, parse_vary, task_list, world_groups
from wolfpack.task import TASK_ORDER

DEVICES = ("auto", "cpu", "cuda")
#: ``--seed`` is below this: the training worlds take ``TRAIN_SEED_BASE·(S+1) + e`` (and a
#: resumed run ``num_envs`` more per resume), which must stay below 2**64 (≈ 1.8e19); 10**13
#: leaves room for a billion worlds' worth of resumes.
SEED_END = 10**13

TRAIN_DESCRIPTION = """\
Train wolves, targets or both sides at once with PPO on the native batch.

--algo ippo: every agent of a side shares one actor and one critic that both read the agent's
own observation (independent PPO with parameter sharing). --algo mappo (default): the same
actor, and a centralised critic that reads the world's global state (BatchEnv.state()) with
the agent's own observation. --side both: wolves and targets learn together in the same
worlds, each side with its own networks and optimiser; otherwise the other side follows
--opponent (a law's name or a saved model; default: its law in params). --opponent given
more than once makes a pool: before every rollout one of them is drawn uniformly (give one
twice to draw it twice as often) and takes over the other side in every world; the first is the
one the held-out evaluations play.

--imitate MINUTES first clones each learning side's scripted law (params policies.<side>, the
laws' actions from BatchEnv.expert_actions()) into the same actor with DAgger, then trains it
with PPO (the critic alone for the first 3 updates); its minutes count in the time limit.

Hyperparameters: the packaged recipes (wolfpack/learn/recipes.yaml; one per side and
algorithm, the defaults measured best), each key changed with --hp KEY=VALUE. Observations
and returns are normalised by running statistics saved with the model; the policy is a Gaussian
whose draws the environment clips to the action box.

A budget is needed: --time-limit MINUTES (wall clock of this invocation) and/or --timesteps
(agent-steps in all; one batch step of E worlds with N learning wolves is E*N agent-steps);
training stops at whichever comes first, and the learning rate anneals over it. Held-out
evaluations (deterministic, episodes 500000 + k, never trained on) run at every tenth of the
budget (--evaluations) and at the end; checkpoints at every fifth. A --timesteps run is bit-identical when
rerun on the CPU with the same seed and thread counts; a --time-limit run stops where the clock
says.

Writes into --out DIR (a new or empty folder; --resume continues the run there):
  config.yaml                  the run: sides, algorithm, opponent, params, recipes, command
  wolves/, targets/            each learning side's model: policy.pt + config.yaml; any
                               model path takes it (opponent=DIR, wolfpack.load_policy(DIR),
                               training/evaluate.py DIR)
  progress.csv                 one row per update: wall_s, agent_steps, agent_steps_per_s,
                               outcome rates, per side return, losses, entropy, KL, and the
                               held-out evaluations; TensorBoard events beside it
  evaluations.json             every held-out evaluation (after imitation too: phase)
  imitation.json               with --imitate: each DAgger round (beta, samples, loss)
  checkpoints/<agent steps>/   models and resume state; trainer.pt the latest state
  summary.json                 agent steps, wall time, throughput, the final evaluation
Ctrl-C saves the models as they are and exits with status 130."""

TRAIN_EPILOG = """\
examples:
  wolfpack train --side wolves --time-limit 15 --out runs/wolves
  wolfpack train --side targets --algo ippo --opponent bvc --time-limit 10 --out runs/escape
  wolfpack train --side wolves --opponent escape --opponent results/models/escape_ppo --time-limit 15 --out runs/pool
  wolfpack train --side both --timesteps 20000000 --seed 3 --out runs/both
  wolfpack train --side wolves --out runs/wolves --resume --time-limit 15
  wolfpack train --side wolves --task all --hp network=entities --time-limit 60 --out runs/generalist"""


def add_parser(sub, parser_class) -> argparse.ArgumentParser:
    """Registers ``train`` on the ``wolfpack`` command's subparsers."""
    from wolfpack.cli import _folder, _int_at_least, _positive_minutes

    p = sub.add_parser(
        "train",
        help="train wolves, targets or both with PPO (IPPO or MAPPO) on the native batch",
        description=TRAIN_DESCRIPTION,
        epilog=TRAIN_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--side", required=True, choices=LEARNERS, help="which side learns (both: both sides at once)")
    p.add_argument("--algo", choices=ALGOS, default="mappo", help="ippo (decentralised critic) or mappo (centralised critic on the global state; default)")
    p.add_argument("--out", required=True, metavar="DIR", type=_folder, help="run folder (new or empty, or the run to --resume)")
    p.add_argument("--time-limit", metavar="MIN", type=_positive_minutes, default=None, help="stop after this many minutes of this invocation")
    p.add_argument("--timesteps", metavar="N", type=_int_at_least(1), default=None, help="stop after this many agent-steps in all")
    p.add_argument("--seed", metavar="S", type=_int_at_least(0), default=0, help="seed of the networks, the sampling and the training worlds 1000000*(S+1)+e; 0 <= S < 10^13 (default 0)")
    p.add_argument(
        "--opponent",
        metavar="LAW_OR_MODEL",
        action="append",
        default=None,
        help="what drives the other side: a law (seed000, bvc, formation / escape, random, still) or a saved model (default: its law in params); repeated: a pool, one drawn per rollout, the first evaluated",
    )
    scenario = p.add_mutually_exclusive_group()
    scenario.add_argument("--params", metavar="P", default=None, help="scenario YAML (default: the packaged params.yaml)")
    scenario.add_argument(
        "--task",
        metavar="NAME",
        action="append",
        default=None,
        help=f"train on a task of the benchmark suite (docs/tasks.md): {', '.join(TASK_ORDER)}; repeated, or 'all': one model over several tasks, each with its share of the worlds",
    )
    p.add_argument(
        "--vary",
        metavar="KEY=LO:HI",
        action="append",
        default=[],
        help=f"with --task: draw a params key within a range, e.g. world.wolves=3:8 (repeatable; {VARIANTS} groups of worlds per task, each with its own draw)",
    )
    p.add_argument(
        "--task-weights",
        choices=TASK_WEIGHTS,
        default="uniform",
        help="how the tasks weigh in the update: uniform (default); or after each held-out evaluation, adaptive (by how often the learner fails on each) or shortfall (by how far it is below each task's best law)",
    )
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], dest="overrides", help="params override, e.g. --set world.wolves=8 (repeatable)")
    p.add_argument("--hp", metavar="KEY=VALUE", action="append", default=[], dest="hp", help="hyperparameter override, e.g. --hp learning_rate=1e-4 (repeatable; keys: wolfpack/learn/recipes.yaml)")
    p.add_argument("--device", choices=DEVICES, default="auto", help="where the networks run: auto (CUDA when present), cpu or cuda; the worlds always step on the CPU")
    p.add_argument("--threads", metavar="T", type=_int_at_least(1, 256), default=None, help="the batch's worker threads (default: the recipe's choice for this machine, see --help's text)")
    p.add_argument(
        "--torch-threads",
        metavar="T",
        type=_int_at_least(1, 256),
        default=None,
        help="torch's threads (default: all cores; the batch and torch take turns, never run together; on the CPU the rollout uses one, and with two or more the update learns the actor and the critic side by side, each with half)",
    )
    p.add_argument("--eval-episodes", metavar="K", type=_int_at_least(1), default=100, help="episodes per held-out evaluation (default 100)")
    p.add_argument(
        "--imitate",
        metavar="MIN",
        type=_positive_minutes,
        default=None,
        help="first clone each learning side's scripted law (params policies.<side>) for this many minutes with DAgger, then PPO; part of the time limit",
    )
    p.add_argument("--evaluations", metavar="K", type=_int_at_least(1), default=10, help="held-out evaluations per budget, evenly spread (default 10), and one at the end")
    p.add_argument("--resume", action="store_true", help="continue the run in --out from its latest state (its configuration must match)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_train)
    return p


def cmd_train(args: argparse.Namespace, argv: Sequence[str]) -> None:
    from wolfpack import config

    overrides = dict(config.parse_override(text) for text in args.overrides)
    hp = dict(config.parse_override(text, "--hp") for text in args.hp)
    summary = run_training(
        learners=args.side,
        algo=args.algo,
        out=args.out,
        time_limit_min=args.time_limit,
        timesteps=args.timesteps,
        seed=args.seed,
        params=args.params,
        task=args.task,
        vary=parse_vary(args.vary),
        task_weights=args.task_weights,
        overrides=overrides,
        hp=hp,
        opponent=args.opponent,
        device=args.device,
        threads=args.threads,
        torch_threads=args.torch_threads,
        eval_episodes=args.eval_episodes,
        evaluations=args.evaluations,
        imitate_min=args.imitate,
        resume=args.resume,
        progress=not args.no_progress,
        command=" ".join(shlex.quote(a) for a in ["wolfpack", *argv]),
    )
    final = summary.get("final_evaluation") or {}
    rate = summary["this_invocation"]["agent_steps_per_s"] or 0
    line = f"{summary['learners']} {summary['algo']}: {summary['agent_steps']:,} agent-steps, {summary['train_s'] / 60:.1f} min, {rate / 1000:.0f}k agent-steps/s"
    for side in ("wolves", "targets"):
        if side in final:
            r = final[side]
            shown = "capture" if side == "wolves" else "survival"
            value = r["capture_rate"] if side == "wolves" else r["survival_rate"]
            line += f"; held-out {side} {shown} {100 * value:.1f} % (collisions {100 * r['collision_rate']:.1f} %)"
    print(line + f"; models in {args.out}")


def default_threads() -> tuple[int, int]:
    """(batch threads, torch threads) when not given: every usable core for both. The batch and
    torch take turns (a rollout step, then a forward pass on one thread; the update alone, the
    actor and the critic side by side), so they never compete for the cores (BENCHMARKS.md,
    "Learning", measured the alternatives)."""
    cores = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    return cores, cores


def prefer_passive_omp() -> None:
    """Asks torch's OpenMP threads to sleep, not spin, while they wait (``OMP_WAIT_POLICY=PASSIVE``)
    unless the user chose otherwise; only possible before torch is first imported, so it is the
    first thing a training run does.

    Spinning OpenMP workers wait for one another at the end of every parallel region; beside
    another busy process (the usual case on a small machine: a second run, an evaluation) a
    descheduled worker holds the others for a scheduler slice per region. On the 2-core VM,
    `wolfpack train --side wolves`, 2 M agent-steps, twice each: beside one busy process 22–23 k
    agent-steps/s spinning, 49–51 k passive; beside two, 2.9 k against 41.5 k; quiet, 73–77 k
    against 67–79 k (no difference beyond noise). BENCHMARKS.md, "Threads beside a busy
    process"."""
    if "torch" not in sys.modules:
        os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")


#: glibc's mallopt parameters (malloc.h) and the values training asks for.
_M_TRIM_THRESHOLD, _M_MMAP_THRESHOLD = -1, -3
_KEEP_HEAP = {"MALLOC_TRIM_THRESHOLD_": (_M_TRIM_THRESHOLD, 1 << 30), "MALLOC_MMAP_THRESHOLD_": (_M_MMAP_THRESHOLD, 32 << 20)}


def keep_freed_memory() -> bool:
    """Asks glibc's malloc to keep freed memory for the next allocation instead of returning it to
    the system: blocks under 32 MiB come from the heap, and the heap is not trimmed below 1 GiB.
    A parameter the user set through its ``MALLOC_*_`` variable is left as it is. Returns whether
    malloc was changed (False where the C library is not glibc).

    Why: every gradient step allocates a dozen fresh tensors of 0.5–5 MB (the minibatch's gathered
    rows, each layer's activations and gradients); above glibc's mmap threshold each one is a fresh
    mapping whose pages the kernel must fault in and zero, and a freed one goes back to the kernel
    at once. Kept in the heap, they are reused warm. Measured on the 2-core VM, one PPO update of
    the wolves' default recipe (327,680 samples, 40 minibatches of 8,192) in alternated processes:
    a third fewer page faults (256 k against 370 k for setup and 13 updates), system time 0.8–0.9
    against 1.1–1.3 s, median update 0.70–0.76 s against 0.79–0.84 s (of the same order as the
    VM's noise: other pairs differed by less). The price is a process that keeps its peak heap
    until it exits."""
    import ctypes
    import ctypes.util

    name = ctypes.util.find_library("c")
    try:
        libc = ctypes.CDLL(name) if name else None
        mallopt = libc.mallopt if libc is not None else None
    except (OSError, AttributeError):
        return False
    if mallopt is None or not hasattr(libc, "gnu_get_libc_version"):
        return False
    changed = False
    for variable, (parameter, value) in _KEEP_HEAP.items():
        if variable not in os.environ:
            changed = bool(mallopt(parameter, value)) or changed
    return changed


def resolve_device(device: str):
    import torch

    if device not in DEVICES:
        raise ValueError(f"--device must be one of {', '.join(DEVICES)}, got {device!r}")
    if device == "cuda" and not torch.cuda.is_available():
        raise ValueError("--device cuda: no CUDA device here (torch.cuda.is_available() is False); use --device cpu or auto")
    if device == "auto":
        device = "cuda" if torch.cuda.is_available() else "cpu"
    return device


def prepare_out(out: Path, resume: bool, identity: dict) -> bool:
    """A new or empty ``out``, or one holding a run that stopped before its first update
    (:func:`without_progress`: it starts afresh there); with ``resume``, a run folder of the
    same configuration. Nothing is written before this passes. Returns whether the run goes on
    from a saved state (False: it starts afresh)."""
    from wolfpack.models import CONFIG_FILE, read_config

    config_path = out / CONFIG_FILE
    if resume:
        if not config_path.is_file():
            raise ValueError(f"--resume: {out} holds no run of 'wolfpack train' (no {CONFIG_FILE})")
        theirs = read_config(config_path)
        mine = json.loads(json.dumps(identity))
        for key, value in mine.items():
            if theirs.get(key) != value:
                raise ValueError(f"--resume: {out} is a run with another {key} ({_short(theirs.get(key))} there, {_short(value)} here); resume it with the same arguments, or use another --out")
        # Stopped before its first update (Ctrl-C during start-up): nothing to go on from, and
        # nothing lost by starting afresh.
        return not without_progress(out)
    if out.exists() and (not out.is_dir() or any(out.iterdir())) and not without_progress(out):
        raise ValueError(f"--out {out}: not a new or empty folder (continue a run there with --resume)")
    return False


#: What a run writes before its first update: its configuration, the header of progress.csv and
#: TensorBoard's first (empty) event file.
START_UP_FILES = ("config.yaml", "progress.csv", "events.out.tfevents.*")


def without_progress(out: Path) -> bool:
    """Whether ``out`` holds a run of ``wolfpack train`` stopped before its first update
    (Ctrl-C during start-up, or a failure then): its ``config.yaml``, a ``progress.csv`` of at
    most its header, TensorBoard's event files, and nothing else. A rerun may start afresh
    there, with or without ``--resume``: no model, row or evaluation is lost."""
    from wolfpack.models import CONFIG_FILE, read_config

    if not (out / CONFIG_FILE).is_file():
        return False
    for path in out.iterdir():
        if not path.is_file() or not any(path.match(pattern) for pattern in START_UP_FILES):
            return False
        if path.name == "progress.csv" and len(path.read_bytes().splitlines()) > 1:
            return False
    try:
        return read_config(out / CONFIG_FILE).get("trainer") == "wolfpack train"
    except ValueError:
        return False  # not a config this command wrote: someone else's file


def _clear_start_up(out: Path) -> None:
    """Removes what a run stopped before its first update left (:func:`without_progress`), so
    that progress.csv starts with its header again."""
    if out.is_dir():
        for pattern in START_UP_FILES[1:]:
            for path in out.glob(pattern):
                path.unlink()


def check_rollout_memory(worlds: list[dict], learners: str, algo: str, recipes: dict) -> None:
    """The rollout buffers of every learning side against the memory available
    (:func:`wolfpack.learn.recipes.check_memory`), sized on a one-world batch of each of
    ``worlds`` (the params of every group of worlds; the largest counts for all of them)."""
    from wolfpack.batch import BatchEnv
    from wolfpack.learn.recipes import check_memory, rollout_bytes

    batch = recipes["wolves" if learners == "both" else learners]  # the batch's keys are the first side's
    sides = ("wolves", "targets") if learners == "both" else (learners,)
    needed = 0
    for params in worlds:
        probe = BatchEnv(params, num_envs=1, learners="all" if learners == "both" else learners)
        sized = (
            rollout_bytes(
                batch,
                agents=probe.n_wolves if side == "wolves" else probe.n_targets,
                obs_dim=probe.wolf_obs_dim if side == "wolves" else probe.target_obs_dim,
                state_dim=probe.state_dim,
                centralised=algo == "mappo",
            )
            for side in sides
        )
        needed = max(needed, sum(sized))
    check_memory(batch, needed)


def _short(v: Any) -> str:
    text = json.dumps(v)
    return text if len(text) <= 40 else "different values"


def run_training(
    *,
    learners: str,
    algo: str,
    out,
    time_limit_min,
    timesteps,
    seed: int,
    params,
    overrides: dict,
    hp: dict,
    task: str | Sequence[str] | None = None,
    vary: dict | None = None,
    task_weights: str = "uniform",
    opponent,
    device: str,
    threads,
    torch_threads,
    eval_episodes: int,
    resume: bool,
    evaluations: int = 10,
    imitate_min: float | None = None,
    progress: bool,
    command: str,
) -> dict:
    """Checks every input (ValueError naming it, nothing written), then trains."""
    prefer_passive_omp()
    keep_freed_memory()
    if learners not in LEARNERS:
        raise ValueError(f"--side must be one of {', '.join(LEARNERS)}, got {learners!r}")
    if algo not in ALGOS:
        raise ValueError(f"--algo must be one of {', '.join(ALGOS)}, got {algo!r}")
    if not is_int(seed) or not 0 <= seed < SEED_END:
        raise ValueError(f"--seed must be an integer in [0, 10^13), got {seed!r}: the training worlds are seeded {TRAIN_SEED_BASE}*(S+1)+e, and every world's seed must stay below 2^64")
    if time_limit_min is None and timesteps is None:
        raise ValueError("give a budget: --time-limit MINUTES and/or --timesteps N")
    if time_limit_min is not None and not (time_limit_min > 0):
        raise ValueError(f"--time-limit must be > 0 minutes, got {time_limit_min}")
    if imitate_min is not None and not (imitate_min > 0):
        raise ValueError(f"--imitate must be > 0 minutes, got {imitate_min}")
    if imitate_min is not None and time_limit_min is not None and imitate_min >= time_limit_min:
        raise ValueError(f"--imitate {imitate_min:g} must be shorter than --time-limit {time_limit_min:g}: imitation is part of the time limit")
    pool = [str(o) for o in ([opponent] if isinstance(opponent, (str, os.PathLike)) else (opponent or []))]
    if pool and learners == "both":
        raise ValueError("--opponent: with --side both there is no other side for it to drive")
    opponent = pool[0] if pool else None
    try:
        import torch
    except ImportError:
        raise ValueError("wolfpack train needs torch: pip install 'wolfpack[train]'") from None
    from wolfpack.batch import resolve_params
    from wolfpack.learn.trainer import Trainer, TrainSpec
    from wolfpack.sides import SCRIPTED_LAWS

    device = resolve_device(device)
    sides = ("wolves", "targets") if learners == "both" else (learners,)
    recipes = {side: recipe(side, algo, hp) for side in sides}
    # The recipes' params overrides first (reward weights, observation keys), the run's own
    # --set after them (they win).
    overrides = {**recipes_params_overrides(recipes), **overrides}
    other = {"wolves": "targets", "targets": "wolves"}.get(learners)
    if opponent is not None and other and opponent in SCRIPTED_LAWS[other]:
        # A law opponent is the params' law of that side: the saved models then say in their
        # params what they were trained against.
        overrides[f"policies.{other}"] = opponent
    tasks = task_list([task] if isinstance(task, str) else task)
    if task_weights not in TASK_WEIGHTS:
        raise ValueError(f"--task-weights must be one of {', '.join(TASK_WEIGHTS)}, got {task_weights!r}")
    if vary and not tasks:
        raise ValueError("--vary needs --task: it varies the tasks' worlds")
    groups: list = []
    eval_tasks: list = []
    if len(tasks) > 1 or vary:
        if params is not None:
            raise ValueError("--params and --task are exclusive: the tasks are the scenarios")
        groups, eval_tasks = world_groups(tasks, vary or {}, seed, lambda name, extra: resolve_params(None, {**overrides, **extra}, name))
        resolved = eval_tasks[0][1]
    else:
        resolved = resolve_params(params, overrides, tasks[0] if tasks else None)
    cores_env, cores_torch = default_threads()
    spec = TrainSpec(
        learners=learners,
        algo=algo,
        params=resolved,
        recipes=recipes,
        seed=seed,
        opponent=opponent,
        opponent_pool=tuple(pool),
        timesteps=timesteps,
        time_limit_min=time_limit_min,
        threads=threads or cores_env,
        torch_threads=torch_threads or cores_torch,
        device=device,
        eval_episodes=eval_episodes,
        evaluations=evaluations,
        imitate_min=imitate_min,
        command=command,
        groups=tuple(groups),
        eval_tasks=tuple(eval_tasks),
        task_weights=task_weights,
    )
    check_rollout_memory([params for _, _, params in groups] or [resolved], learners, algo, recipes)
    out = Path(out)
    resume = prepare_out(out, resume, spec.identity())
    torch.set_num_threads(spec.torch_threads)
    # Building the trainer builds the batch and loads the opponent: a model of the wrong side or
    # observation size fails here, before anything is written.
    trainer = Trainer(spec, out, resume=resume, progress=progress)
    if not resume:
        import yaml

        from wolfpack.learn.trainer import _plain, versions
        from wolfpack.models import CONFIG_FILE

        out.mkdir(parents=True, exist_ok=True)
        _clear_start_up(out)
        config = {
            **spec.identity(),
            "task": tasks[0] if len(tasks) == 1 else (tasks or None),
            "vary": {key: list(span) for key, span in (vary or {}).items()} or None,
            "trainer": "wolfpack train",
            "timesteps": timesteps,
            "time_limit_min": time_limit_min,
            "threads": spec.threads,
            "torch_threads": spec.torch_threads,
            "device": device,
            "eval_episodes": eval_episodes,
            "evaluations": evaluations,
            "imitate_min": imitate_min,
            "command": command,
            "versions": versions(),
        }
        (out / CONFIG_FILE).write_text(yaml.safe_dump(_plain(config), sort_keys=False))
    try:
        return trainer.run()
    except KeyboardInterrupt:
        # The exit-status table promises one line saying what --out holds.
        from wolfpack.cli import Interrupted
        from wolfpack.learn.trainer import TRAINER_FILE

        if (out / TRAINER_FILE).is_file():
            raise Interrupted(f"; {out} holds the models and the resume state at {trainer.agent_steps:,} agent-steps: continue with --resume") from None
        raise Interrupted(f"; {out} holds no progress yet: the same command starts afresh there") from None
