"""The native multi-agent PPO trainer behind ``wolfpack train`` (IPPO and MAPPO on the batch).

Written for the batch rather than on a general library because the learner, not the simulator,
is what users wait for: SB3's PPO spends 87 % of its time in its own bookkeeping and updates
around one policy per VecEnv slot, and has no centralised critic; here every side is one
parameter-shared policy over preallocated rollout buffers filled straight from
:class:`wolfpack.BatchEnv` (BENCHMARKS.md, "Learning"). Modules: :mod:`~wolfpack.learn.ppo`
(one side's rollout and update), :mod:`~wolfpack.learn.trainer` (the loop, logs, checkpoints),
:mod:`~wolfpack.learn.recipes` (the hyperparameters), :mod:`~wolfpack.learn.run` (a run as
``wolfpack train`` starts it). The networks (normaliser, actor, critic, set networks) are
:mod:`wolfpack.networks`, which playing a saved model needs too; saved models load with
:func:`wolfpack.load_policy`.

Importing this package does not import torch; :func:`train` does.
"""

from wolfpack.learn.recipes import ALGOS, LEARNERS, recipe
from wolfpack.learn.run import run_training


def train(
    learners: str = "wolves",
    algo: str = "mappo",
    *,
    out,
    time_limit_min=None,
    timesteps=None,
    seed: int = 0,
    params=None,
    task=None,
    vary=None,
    task_weights: str = "uniform",
    overrides=None,
    hp=None,
    opponent=None,
    device: str = "auto",
    threads=None,
    torch_threads=None,
    eval_episodes: int = 100,
    evaluations: int = 10,
    imitate_min=None,
    imitate_rounds=None,
    resume: bool = False,
    progress: bool = True,
) -> dict:
    """Trains as ``wolfpack train`` does (``wolfpack train --help``) and returns the run's
    summary; ``overrides`` and ``hp`` are dicts of dotted keys; ``opponent`` is one driver or a
    list of them (a pool, one drawn per rollout, the first evaluated); ``task`` a task's name or
    a list of them (``"all"``: the suite; several: one model over them, multi-task), ``vary``
    ``{key: (lo, hi)}`` as ``--vary`` takes them."""
    return run_training(
        learners=learners,
        algo=algo,
        out=out,
        time_limit_min=time_limit_min,
        timesteps=timesteps,
        seed=seed,
        params=params,
        task=task,
        vary=dict(vary or {}),
        task_weights=task_weights,
        overrides=overrides or {},
        hp=hp or {},
        opponent=opponent,
        device=device,
        threads=threads,
        torch_threads=torch_threads,
        eval_episodes=eval_episodes,
        evaluations=evaluations,
        imitate_min=imitate_min,
        imitate_rounds=imitate_rounds,
        resume=resume,
        progress=progress,
        command="",
    )


__all__ = ["ALGOS", "LEARNERS", "recipe", "train"]
