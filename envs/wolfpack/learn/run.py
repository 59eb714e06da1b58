"""A training run as ``wolfpack train`` and :func:`wolfpack.learn.train` start it: every input
checked before anything is written, the process set up for training (threads, OpenMP, malloc),
the run folder prepared or resumed, then the :class:`~wolfpack.learn.trainer.Trainer`."""

from __future__ import annotations

import json
import os
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, ClassVar, Mapping, Sequence

from wolfpack._checks import is_int, usable_cores
from wolfpack.batch import BatchEnv, resolve_params
from wolfpack.evaluation import TRAIN_SEED_BASE
from wolfpack.interrupt import Interrupted
from wolfpack.learn.recipes import ALGOS, LEARNERS, check_memory, recipe, recipes_params_overrides, rollout_bytes
from wolfpack.learn.tasks import TASK_WEIGHTS, task_list, world_groups
from wolfpack.logs import atomic_path
from wolfpack.models import CONFIG_FILE, POLICY_FILE, load_policy, native_model_folders, read_config
from wolfpack.sides import OTHER_SIDE, SCRIPTED_LAWS, SIDES

DEVICES = ("auto", "cpu", "cuda")
#: ``--seed`` is below this: the training worlds take ``TRAIN_SEED_BASE·(S+1) + e`` (and a
#: resumed run ``num_envs`` more per resume), which must stay below 2**64 (≈ 1.8e19); 10**13
#: leaves room for a billion worlds' worth of resumes.
SEED_END = 10**13


def default_threads() -> tuple[int, int]:
    """(batch threads, torch threads) when not given: every usable core for both. The batch and
    torch take turns (a rollout step, then a forward pass on one thread; the update alone, the
    actor and the critic side by side), so they never compete for the cores (BENCHMARKS.md,
    "Learning", measured the alternatives)."""
    cores = usable_cores()
    return cores, cores


def prefer_passive_omp() -> None:
    """Asks torch's OpenMP threads to sleep, not spin, while they wait (``OMP_WAIT_POLICY=PASSIVE``)
    unless the user chose otherwise; only possible before torch is first imported, so it is the
    first thing a training run does.

    Spinning OpenMP workers wait for one another at the end of every parallel region; beside
    another busy process (the usual case on a small machine: a second run, an evaluation) a
    descheduled worker holds the others for a scheduler slice per region. On the 2-core VM,
    `wolfpack train --side wolves` with passive waits ran twice as fast beside one busy process
    and over ten times as fast beside two, and no slower quiet (BENCHMARKS.md, "Threads beside a
    busy process")."""
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

    batch = recipes["wolves" if learners == "both" else learners]  # the batch's keys are the first side's
    sides = SIDES if learners == "both" else (learners,)
    needed = 0
    for params in worlds:
        probe = BatchEnv(params, num_envs=1, learners=learners)
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


def init_models(given: Any, sides: Sequence[str]) -> dict:
    """``--init``: one saved model of ``wolfpack train`` per learning side (a model folder, or a
    run folder, which gives the model of each learning side it holds), loaded and checked:
    ``{side: NativePolicy}``. ValueError naming the folder: not such a model, a model of a side
    that does not learn in this run, two for one side."""
    paths = [given] if isinstance(given, (str, os.PathLike)) else list(given or [])
    models: dict = {}
    for path in paths:
        try:
            folders = native_model_folders(path)
        except ValueError as err:
            raise ValueError(f"--init {path}: {err}") from None
        if not folders:
            raise ValueError(f"--init {path}: not a model of 'wolfpack train' (a folder with {POLICY_FILE} and {CONFIG_FILE}, or a run folder holding one)")
        chosen = {side: folder for side, folder in folders.items() if side in sides}
        if not chosen:
            raise ValueError(f"--init {path}: a model of the {' and '.join(folders)}, and this run trains the {' and '.join(sides)}")
        for side, folder in chosen.items():
            if side in models:
                raise ValueError(f"--init {path}: a second model of the {side} (the first: {models[side].path})")
            try:
                models[side] = load_policy(folder, side)
            except ValueError as err:
                raise ValueError(f"--init {path}: {err}") from None
    return models


@dataclass(frozen=True, kw_only=True)
class TrainOptions:
    """What a training run is asked for: ``wolfpack train``'s options (``--help`` says what each
    does) and :func:`wolfpack.learn.train`'s keywords, one field each, checked by
    :func:`run_training`. ``overrides`` and ``hp`` are dicts of dotted keys (``--set``, ``--hp``);
    ``opponent`` is one driver or a list of them (a pool: one drawn per rollout, the first
    evaluated); ``task`` a task's name or a list of them (``"all"``: the suite); ``vary``
    ``{key: (lo, hi)}`` as ``--vary`` takes them; ``init`` one saved model (or run folder) per
    learning side to start from; ``command`` the command line that started the run, kept in its
    configuration."""

    learners: str = "wolves"
    algo: str = "mappo"
    out: str | os.PathLike
    time_limit_min: float | None = None
    timesteps: int | None = None
    seed: int = 0
    params: Any = None
    task: str | Sequence[str] | None = None
    vary: Mapping[str, tuple] | None = None
    task_weights: str = "uniform"
    overrides: Mapping[str, Any] | None = None
    hp: Mapping[str, Any] | None = None
    opponent: Any = None
    device: str = "auto"
    threads: int | None = None
    torch_threads: int | None = None
    eval_episodes: int = 100
    evaluations: int = 10
    imitate_min: float | None = None
    imitate_rounds: int | None = None
    init: str | os.PathLike | Sequence[str | os.PathLike] | None = None
    resume: bool = False
    progress: bool = True
    command: str = ""

    #: The options a run's configuration (config.yaml) records as given, beside the trainer's
    #: identity and what they resolved to (the device, the thread counts).
    RECORDED: ClassVar[tuple[str, ...]] = ("timesteps", "time_limit_min", "eval_episodes", "evaluations", "imitate_min", "imitate_rounds", "command")


def run_training(options: TrainOptions) -> dict:
    """Checks every input (ValueError naming it, nothing written), then trains."""
    o = options
    learners, algo, seed, opponent, device, task, params = o.learners, o.algo, o.seed, o.opponent, o.device, o.task, o.params
    time_limit_min, timesteps, imitate_min, imitate_rounds = o.time_limit_min, o.timesteps, o.imitate_min, o.imitate_rounds
    task_weights, vary, overrides, hp = o.task_weights, dict(o.vary or {}), dict(o.overrides or {}), dict(o.hp or {})
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
    if imitate_rounds is not None and (not is_int(imitate_rounds) or imitate_rounds < 1):
        raise ValueError(f"--imitate-rounds must be an integer >= 1, got {imitate_rounds!r}")
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
    from wolfpack.learn.trainer import Trainer, TrainSpec

    device = resolve_device(device)
    sides = SIDES if learners == "both" else (learners,)
    init = init_models(o.init, sides)
    if init and (imitate_min is not None or imitate_rounds is not None):
        raise ValueError("--init and --imitate both give the learner its first policy: choose one")
    recipes = {side: recipe(side, algo, hp, base=init[side].config["recipe"] if side in init else None) for side in sides}
    # The recipes' params overrides first (reward weights, observation keys), the run's own
    # --set after them (they win).
    overrides = {**recipes_params_overrides(recipes), **overrides}
    other = OTHER_SIDE.get(learners)
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
        threads=o.threads or cores_env,
        torch_threads=o.torch_threads or cores_torch,
        device=device,
        eval_episodes=o.eval_episodes,
        evaluations=o.evaluations,
        imitate_min=imitate_min,
        imitate_rounds=imitate_rounds,
        command=o.command,
        groups=tuple(groups),
        eval_tasks=tuple(eval_tasks),
        task_weights=task_weights,
        init={side: str(model.path) for side, model in init.items()},
    )
    check_rollout_memory([params for _, _, params in groups] or [resolved], learners, algo, recipes)
    out = Path(o.out)
    resume = prepare_out(out, o.resume, spec.identity())
    torch.set_num_threads(spec.torch_threads)
    # Building the trainer builds the batch and loads the opponent: a model of the wrong side or
    # observation size fails here, before anything is written.
    trainer = Trainer(spec, out, resume=resume, progress=o.progress, init_models=init)
    # From here on a Ctrl-C, wherever it lands (the configuration half written, the trainer
    # opening its logs), ends with the one line that says what --out holds.
    try:
        if not resume:
            import yaml

            from wolfpack.learn.checkpoints import plain, versions

            out.mkdir(parents=True, exist_ok=True)
            _clear_start_up(out)
            config = {
                **spec.identity(),
                "task": tasks[0] if len(tasks) == 1 else (tasks or None),
                "vary": {key: list(span) for key, span in (vary or {}).items()} or None,
                "trainer": "wolfpack train",
                **{name: getattr(o, name) for name in TrainOptions.RECORDED},
                "device": device,
                "threads": spec.threads,
                "torch_threads": spec.torch_threads,
                "versions": versions(),
            }
            # Whole or not at all: a Ctrl-C landing in the write must not leave a configuration
            # that a rerun or --resume cannot read.
            with atomic_path(out / CONFIG_FILE) as tmp:
                tmp.write_text(yaml.safe_dump(plain(config), sort_keys=False))
        return trainer.run()
    except KeyboardInterrupt:
        # The exit-status table promises one line saying what --out holds.
        from wolfpack.learn.checkpoints import TRAINER_FILE

        if (out / TRAINER_FILE).is_file():
            raise Interrupted(f"; {out} holds the models and the resume state at {trainer.agent_steps:,} agent-steps: continue with --resume") from None
        raise Interrupted(f"; {out} holds no progress yet: the same command starts afresh there") from None
