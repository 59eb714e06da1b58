"""RLlib glue that Ray actors can import: the env creator and the agent → module mapping used
by ``training/rllib_train.py``. Importable without ray; ray is imported when an env is made.

Functions that RLlib ships to its env runners must live in an installed module (a function of a
script imported under another name cannot be unpickled by the actors), hence this module.
"""

from __future__ import annotations

from typing import Any, Mapping

from wolfpack.parallel_env import parallel_env

#: World seeds of env runner k's copy v: ``SEED_BASE·(seed + 1) + 1000·k + v``.
SEED_BASE = 1_000_000


def env_creator(env_config: Mapping[str, Any]):
    """RLlib env creator: RLlib's own ``ParallelPettingZooEnv`` over ``wolfpack.parallel_env``.

    ``env_config``: ``params`` (a params dict, path or None), ``learners`` ("both", "wolves" or
    "targets"), ``shared_space`` (bool), ``seed`` (run seed). Each env runner
    (``env_config.worker_index``) and vectorised copy (``vector_index``) gets its own world seed,
    so runners sample different episodes, reproducibly."""
    from ray.rllib.env.wrappers.pettingzoo_env import ParallelPettingZooEnv

    worker = int(getattr(env_config, "worker_index", 0))
    vector = int(getattr(env_config, "vector_index", 0))
    seed = SEED_BASE * (int(env_config.get("seed", 0)) + 1) + 1000 * worker + vector
    env = parallel_env(env_config.get("params"), learners=env_config.get("learners", "both"), shared_space=bool(env_config.get("shared_space", False)), seed=seed)
    return ParallelPettingZooEnv(env)


def module_for(agent_id: str, shared: bool = False) -> str:
    """The RLModule that drives an agent: ``"wolves"`` or ``"targets"`` by side, or ``"shared"``."""
    if shared:
        return "shared"
    return "wolves" if str(agent_id).startswith("wolf") else "targets"


def side_mapping(agent_id: str, *args: Any, **kwargs: Any) -> str:
    """RLlib ``policy_mapping_fn``: one module per side."""
    return module_for(agent_id)


def shared_mapping(agent_id: str, *args: Any, **kwargs: Any) -> str:
    """RLlib ``policy_mapping_fn``: one module for every agent."""
    return module_for(agent_id, shared=True)
