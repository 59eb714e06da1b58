"""wolfpack: multi-agent pursuit–evasion (wolf-pack hunting) with a Rust core.

Public entry points (docs/interface.md in the repository has the whole interface):

- :func:`load_params` — read and validate a scenario (``params.yaml`` plus dotted overrides).
- :func:`run_episodes` — run scripted episodes in parallel (the engine behind ``wolfpack hunt``).
- :func:`parallel_env` — PettingZoo ``ParallelEnv`` (either side learning); :func:`env`, the
  same as an ``AECEnv``.
- :func:`tasks` — the benchmark's named, versioned tasks (``task=NAME`` on every env,
  ``wolfpack hunt --task NAME``; docs/tasks.md).
- ``gymnasium.make("wolfpack/Escape-v0")`` — one learning target (registered on import), and
  ``wolfpack/Escape-<task>`` for every task with one target.
- :func:`make_vec_env` — SB3 ``VecEnv`` over the native batch (needs stable-baselines3).
- :class:`BatchEnv` — the native batch itself.
- :class:`Opponent` — what drives the side that does not learn: a law, an SB3 model or a
  callable (``opponent=`` of every env; :mod:`wolfpack.opponents`).
- :func:`load_policy` — any saved model (``wolfpack train``'s or SB3's) as a batched callable
  ``obs [n, D] -> actions [n, 2]`` (:mod:`wolfpack.models`).
- :mod:`wolfpack.learn` — the native PPO trainer (IPPO, MAPPO) behind ``wolfpack train``.
- ``wolfpack`` command line: ``wolfpack hunt --help``, ``wolfpack train --help``.
"""

from wolfpack._core import __version__
from wolfpack.batch import ENTITY_FIELDS, ENTITY_STATE_FIELDS, OUTCOMES, BatchEnv, observation_layout
from wolfpack.config import DEFAULT_PARAMS_PATH, load_layout, load_params
from wolfpack.episodes import run_episodes, summarize
from wolfpack.models import load_policy
from wolfpack.opponents import Opponent
from wolfpack.parallel_env import env, parallel_env
from wolfpack.task import gym_id, single_target_tasks, tasks


def make_vec_env(params=None, *, task=None, num_envs, learners="wolves", seed=0, threads=None, shared_space=False, opponent=None, **overrides):
    """An SB3 ``VecEnv`` over the native batch: one slot per learning agent per world (see
    :mod:`wolfpack.vec_env`); ``learners="both"`` needs ``shared_space=True``. Imports
    stable-baselines3 on first use (an ImportError naming the ``[train]`` extra without it)."""
    from wolfpack._optional import require

    require("stable_baselines3", "make_vec_env (an SB3 VecEnv)")
    from wolfpack.vec_env import make_vec_env as _make

    return _make(params, task=task, num_envs=num_envs, learners=learners, seed=seed, threads=threads, shared_space=shared_space, opponent=opponent, **overrides)


def _vec_env_docstring() -> str:
    """The docstring of :mod:`wolfpack.vec_env`, read without importing it (that would import
    stable-baselines3 and torch)."""
    import ast
    from pathlib import Path

    source = Path(__file__).with_name("vec_env.py").read_text(encoding="utf-8")
    return ast.get_docstring(ast.parse(source)) or ""


make_vec_env.__doc__ = f"{make_vec_env.__doc__}\n\n{_vec_env_docstring()}"


def _register_gymnasium() -> None:
    import gymnasium

    if "wolfpack/Escape-v0" not in gymnasium.registry:
        gymnasium.register(id="wolfpack/Escape-v0", entry_point="wolfpack.gym_env:EscapeEnv")
    for name in single_target_tasks():
        if gym_id(name) not in gymnasium.registry:
            gymnasium.register(id=gym_id(name), entry_point="wolfpack.gym_env:EscapeEnv", kwargs={"task": name})


_register_gymnasium()

__all__ = [
    "__version__",
    "DEFAULT_PARAMS_PATH",
    "load_params",
    "load_layout",
    "run_episodes",
    "summarize",
    "BatchEnv",
    "Opponent",
    "load_policy",
    "OUTCOMES",
    "observation_layout",
    "ENTITY_FIELDS",
    "ENTITY_STATE_FIELDS",
    "parallel_env",
    "env",
    "make_vec_env",
    "tasks",
]
