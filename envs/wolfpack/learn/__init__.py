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
from wolfpack.learn.run import TrainOptions, run_training


def train(learners: str = "wolves", algo: str = "mappo", **options) -> dict:
    """Trains as ``wolfpack train`` does (``wolfpack train --help``) and returns the run's
    summary. The keywords are :class:`~wolfpack.learn.run.TrainOptions`' fields (``out`` and a
    budget, ``timesteps`` or ``time_limit_min``, are needed); an unknown one is a TypeError."""
    return run_training(TrainOptions(learners=learners, algo=algo, **options))


__all__ = ["ALGOS", "LEARNERS", "TrainOptions", "recipe", "train"]
