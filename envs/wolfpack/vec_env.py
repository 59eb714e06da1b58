"""A Stable-Baselines3 ``VecEnv`` over the native batch: one slot per learning agent per world.

``make_vec_env(params=None, *, num_envs, learners="wolves", seed=0, threads=None)`` builds
``num_envs`` worlds; with ``learners="wolves"`` there are ``num_envs × N`` slots (slot
``e·N + i`` is wolf i of world e), with ``"targets"`` ``num_envs × M``. All slots share one
policy (parameter sharing). Observations, actions and rewards are those of
:mod:`wolfpack.parallel_env`.

SB3 semantics, exactly: ``step`` returns fresh arrays; a world that finishes is reset in the
same step, its slots report ``done`` with ``infos[k]["terminal_observation"]`` (the last
observation of the finished episode) and ``infos[k]["TimeLimit.truncated"]`` (True when the
episode hit ``world.max_steps`` without terminating). A target captured while others still
run (M > 1) keeps its slot with reward 0 until its world ends. Every ``infos[k]`` carries
``outcome``, ``capture_step``, ``cornered_step``, ``energy``, ``collisions``, ``distance`` (see
the ParallelEnv).

``seed(s)`` re-seeds world e with ``s + e`` at the next ``reset``; results never depend on
``threads``. ``get_attr``/``set_attr``/``env_method`` act on per-slot views that know their
world and agent (attributes ``world_index``, ``agent``, ``render_mode``; methods
``world_state()`` and ``expert_action()``); nothing is wrapped, so ``env_is_wrapped`` is False.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Mapping, Sequence

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from wolfpack.batch import BatchEnv, agent_infos, rebuild
from wolfpack.parallel_env import action_box, observation_box


class _SlotView:
    """What ``get_attr``/``env_method`` see for one slot."""

    def __init__(self, vec: "WolfpackVecEnv", world_index: int, agent: str) -> None:
        self._vec = vec
        self.world_index = world_index
        self.agent = agent
        self.render_mode = None

    def world_state(self) -> dict:
        return self._vec.batch.world_state(self.world_index)

    def expert_action(self) -> np.ndarray:
        return self._vec.expert_actions()[self._vec.slot_of(self.world_index, self.agent)]


class WolfpackVecEnv(VecEnv):
    """See the module docstring. Build it with :func:`wolfpack.make_vec_env`."""

    def __init__(
        self,
        params: str | Path | Mapping[str, Any] | None = None,
        *,
        num_envs: int,
        learners: str = "wolves",
        seed: int = 0,
        threads: int | None = None,
        **overrides: Any,
    ) -> None:
        self._init_kwargs = dict(params=params, num_envs=num_envs, learners=learners, seed=seed, threads=threads, **overrides)
        if learners not in ("wolves", "targets"):
            raise ValueError(
                f"make_vec_env learners must be 'wolves' or 'targets', got {learners!r} "
                "(the two sides have different observation spaces; train them with two VecEnvs or use parallel_env)"
            )
        self.batch = BatchEnv(params, num_envs=num_envs, learners=learners, seed=seed, autoreset=True, threads=threads, **overrides)
        self.learners = learners
        self.worlds = self.batch.num_envs
        self.per_world = self.batch.n_wolves if learners == "wolves" else self.batch.n_targets
        self._side = "wolves" if learners == "wolves" else "targets"
        self._offset = 0 if learners == "wolves" else self.batch.n_wolves
        prefix = "wolf" if learners == "wolves" else "target"
        self._agents = [f"{prefix}_{i}" for i in range(self.per_world)]
        self._views = [_SlotView(self, e, a) for e in range(self.worlds) for a in self._agents]
        dim = self.batch.wolf_obs_dim if learners == "wolves" else self.batch.target_obs_dim
        self._next_seed: int | None = seed
        self._actions: np.ndarray | None = None
        super().__init__(self.worlds * self.per_world, observation_box(dim), action_box())

    def __reduce__(self):
        return (rebuild, (type(self), self._init_kwargs))

    def slot_of(self, world_index: int, agent: str) -> int:
        return world_index * self.per_world + self._agents.index(agent)

    # --- VecEnv API -------------------------------------------------------------------------

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        if seed is None:
            seed = int(np.random.randint(0, 2**31 - 1))
        self._next_seed = int(seed)
        return [self._next_seed + e for e in range(self.worlds) for _ in range(self.per_world)]

    def reset(self) -> np.ndarray:
        out = self.batch.reset(self._next_seed)
        self._next_seed = None
        self.reset_infos = self._infos(out, final=False)
        return self._flat(out[f"obs_{self._side}"])

    def step_async(self, actions: np.ndarray) -> None:
        a = np.asarray(actions)
        if a.dtype.kind != "f":
            raise ValueError(f"actions must be floating point, got dtype {a.dtype}")
        if a.shape != (self.num_envs, 2):
            raise ValueError(f"actions: expected shape ({self.num_envs}, 2), got {a.shape}")
        bad = ~np.isfinite(a).all(axis=1)
        if bad.any():
            k = int(np.argmax(bad))
            raise ValueError(f"action of slot {k} ({self._views[k].agent} in world {self._views[k].world_index}) is not finite: {a[k].tolist()}")
        self._actions = a.reshape(self.worlds, self.per_world, 2)

    def step_wait(self):
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        actions, self._actions = self._actions, None
        out = self.batch.step(actions, None) if self._side == "wolves" else self.batch.step(None, actions)
        obs = self._flat(out[f"obs_{self._side}"])
        rewards = out[f"rewards_{self._side}"].reshape(-1).astype(np.float32, copy=False)
        done_world = out["terminated"] | out["truncated"]
        dones = np.repeat(done_world, self.per_world)
        infos = self._infos(out, final=True)
        return obs, rewards, dones, infos

    def close(self) -> None:
        pass

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return [getattr(self._views[i], attr_name) for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        for i in self._get_indices(indices):
            setattr(self._views[i], attr_name, value)

    def env_method(self, method_name: str, *method_args, indices=None, **method_kwargs) -> list[Any]:
        return [getattr(self._views[i], method_name)(*method_args, **method_kwargs) for i in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type, indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]

    # --- extras -----------------------------------------------------------------------------

    def expert_actions(self) -> np.ndarray:
        """The scripted law's actions for every slot, [num_envs, 2] float32 (for imitation)."""
        wa, ta = self.batch.expert_actions()
        return self._flat(wa if self._side == "wolves" else ta)

    def _flat(self, a: np.ndarray) -> np.ndarray:
        return a.reshape(self.worlds * self.per_world, *a.shape[2:])

    def _infos(self, out: dict, final: bool) -> list[dict]:
        infos = agent_infos(out, self.batch.n_wolves, self._offset, self._offset + self.per_world)
        if final:
            done = out["terminated"] | out["truncated"]
            if done.any():
                final_obs = out[f"final_obs_{self._side}"]
                for e in np.flatnonzero(done).tolist():
                    truncated = bool(out["truncated"][e] and not out["terminated"][e])
                    for i in range(self.per_world):
                        info = infos[e * self.per_world + i]
                        info["terminal_observation"] = final_obs[e, i]
                        info["TimeLimit.truncated"] = truncated
        return infos



def make_vec_env(
    params: str | Path | Mapping[str, Any] | None = None,
    *,
    num_envs: int,
    learners: str = "wolves",
    seed: int = 0,
    threads: int | None = None,
    **overrides: Any,
) -> WolfpackVecEnv:
    """An SB3 ``VecEnv`` of ``num_envs`` worlds (see this module's docstring)."""
    return WolfpackVecEnv(params, num_envs=num_envs, learners=learners, seed=seed, threads=threads, **overrides)
