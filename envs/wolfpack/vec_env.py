"""A Stable-Baselines3 ``VecEnv`` over the native batch: one slot per learning agent per world.

``make_vec_env(params=None, *, task=None, num_envs, learners="wolves", seed=0, threads=None,
shared_space=False, opponent=None)`` builds ``num_envs`` worlds; with ``learners="wolves"`` there are
``num_envs × N`` slots (slot ``e·N + i`` is wolf i of world e), with ``"targets"`` ``num_envs ×
M``, and with ``learners="both", shared_space=True`` ``num_envs × (N+M)`` (slot ``e·(N+M) + k``:
wolves first, then targets) in the shared observation layout of :mod:`wolfpack.parallel_env`
(side flag, agent one-hot, padded observation). All slots share one policy (parameter
sharing). Observations, actions and rewards are those of :mod:`wolfpack.parallel_env`.
``state()`` gives one global-state row per world (for centralised critics).

``opponent`` drives the other side (:mod:`wolfpack.opponents`): a scripted law's name, a saved
SB3 model (path or object), a batched callable ``obs [n, D] -> actions [n, 2]``, or a
``wolfpack.Opponent``; one batched call per step for all its agents in all worlds.
``venv.set_opponent(x)`` swaps it from the next step on and keeps every world (a league's
callback swaps it between rollouts; SB3's ``VecMonitor`` forwards the call).

Sizing PPO for a batch: SB3's ``n_steps`` counts vector steps, so one rollout is ``n_steps ×
num_envs`` slots long — with SB3's default 2048 and 64 worlds × 5 wolves that is 655,360
agent-steps before the first update. Choose ``n_steps`` so that ``n_steps × slots`` is a few
thousand to a few tens of thousands (``n_steps=64`` for 320 slots: 20,480), and a
``batch_size`` that divides it.

SB3 semantics, exactly: ``step`` returns fresh arrays; a world that finishes is reset in the
same step, its slots report ``done`` with ``infos[k]["terminal_observation"]`` (the last
observation of the finished episode) and ``infos[k]["TimeLimit.truncated"]`` (True when the
episode hit ``world.max_steps`` without terminating). A target captured while others still
run (M > 1) keeps its slot with reward 0 until its world ends. Actions are [slots, 2] of a
floating dtype: a wrong dtype or shape is a ``ValueError`` from ``step_async``, a NaN or inf
one from ``step_wait`` naming the slot (``slot k (wolf_i in world e)``), and nothing moves.

A step is one call into the core (``step_wait``): observations, rewards and dones come back
from Rust as they are returned; only a learned opponent, which acts from Python, takes the
path through :meth:`wolfpack.BatchEnv.step`.

Infos cost nothing while episodes run: the slot of a running world gets
:data:`RUNNING_INFO`, one shared, empty, read-only mapping (SB3 and its wrappers only read a
running slot's info, with ``.get``; they copy a done slot's before adding to it). Building a
dict per slot per step was up to half of this VecEnv's time (at 1,024 worlds). The slots of a
world that ended get a dict of their own with the finished episode's numeric infos — those of the
ParallelEnv: ``outcome`` (int code, ``wolfpack.OUTCOMES``), ``capture_step``,
``cornered_step``, ``energy``, ``collisions``, ``distance`` — plus ``outcome_name`` (the code's
name, e.g. ``"captured"``), ``terminal_observation`` and ``TimeLimit.truncated``. The numeric
infos of every slot at every step are in :attr:`WolfpackVecEnv.step_infos` (arrays, one row per
world) and, after ``reset()``, in ``reset_infos`` (one dict per slot).

``seed(s)`` re-seeds world e with ``s + e`` at the next ``reset``; results never depend on
``threads``. ``get_attr``/``set_attr``/``env_method`` act on per-slot views that know their
world and agent (attributes ``world_index``, ``agent``, ``render_mode``; methods
``world_state()`` and ``expert_action()``); nothing is wrapped, so ``env_is_wrapped`` is False.
"""

from __future__ import annotations

from pathlib import Path
from types import MappingProxyType
from typing import Any, Mapping, Sequence

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from wolfpack._checks import check_seed
from wolfpack.batch import OUTCOMES, BatchEnv, rebuild
from wolfpack.parallel_env import action_box, observation_box
from wolfpack.sides import learners_name
from wolfpack.views import SharedObservation, agent_infos, check_shared_space, world_agent_infos

#: The info of every slot whose world is still running after a step: empty and read-only
#: (``RUNNING_INFO["x"] = 1`` raises ``TypeError``), shared by all such slots.
RUNNING_INFO: Mapping[str, Any] = MappingProxyType({})

#: The BatchEnv outputs that make up the numeric infos.
_INFO_KEYS = ("outcome", "capture_step", "cornered_step", "energy", "collisions", "distance", "terminated", "truncated")

#: What :attr:`WolfpackVecEnv.step_infos` holds.
_STEP_INFO_KEYS = (*_INFO_KEYS, "steps")


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
        task: str | None = None,
        num_envs: int,
        learners: str = "wolves",
        seed: int = 0,
        threads: int | None = None,
        shared_space: bool = False,
        opponent: Any = None,
        **overrides: Any,
    ) -> None:
        self._init_kwargs = dict(params=params, task=task, num_envs=num_envs, learners=learners, seed=seed, threads=threads, shared_space=shared_space, opponent=opponent, **overrides)
        given = learners
        learners = learners_name(learners)
        if learners not in ("wolves", "targets", "both"):
            raise ValueError(f"make_vec_env learners must be 'wolves', 'targets' or 'both' (with shared_space=True), got {given!r}")
        if learners == "both" and shared_space is not True:
            raise ValueError(
                "make_vec_env(learners='both') needs shared_space=True: the two sides have different observation sizes, and one VecEnv has one observation space (or train them with two VecEnvs)"
            )
        check_shared_space(shared_space, learners)
        self.batch = BatchEnv(params, task=task, num_envs=num_envs, learners=learners, seed=seed, autoreset=True, threads=threads, opponent=opponent, **overrides)
        self.learners = learners
        self.worlds = self.batch.num_envs
        n, m = self.batch.n_wolves, self.batch.n_targets
        self.per_world = {"wolves": n, "targets": m, "both": n + m}[learners]
        self._side = learners
        self._rewards_key = f"rewards_{learners}"
        self._offset = n if learners == "targets" else 0
        self._agents = ([f"wolf_{i}" for i in range(n)] if learners != "targets" else []) + ([f"target_{j}" for j in range(m)] if learners != "wolves" else [])
        self._views = [_SlotView(self, e, a) for e in range(self.worlds) for a in self._agents]
        self._shared = SharedObservation(n, m, self.batch.wolf_obs_dim, self.batch.target_obs_dim) if learners == "both" else None
        dim = {"wolves": self.batch.wolf_obs_dim, "targets": self.batch.target_obs_dim, "both": self._shared.dim if self._shared else 0}[learners]
        self._next_seed: int | None = seed
        self._actions: np.ndarray | None = None
        self._last_out: Mapping[str, np.ndarray] = {}
        super().__init__(self.worlds * self.per_world, observation_box(dim), action_box())

    def __reduce__(self):
        return (rebuild, (type(self), self._init_kwargs))

    @property
    def opponent(self):
        """What drives the other side (a :class:`wolfpack.Opponent`, or None: its params law)."""
        return self.batch.opponent

    def set_opponent(self, opponent: Any) -> None:
        """Swaps the other side's driver from the next step on, keeping every world
        (:meth:`wolfpack.BatchEnv.set_opponent`)."""
        self.batch.set_opponent(opponent)

    @property
    def step_infos(self) -> dict[str, np.ndarray]:
        """The last step's (or reset's) numeric infos as the BatchEnv returns them, one row per
        world: ``outcome`` [E], ``steps`` [E], ``capture_step`` / ``cornered_step`` [E, M],
        ``energy`` / ``collisions`` / ``distance`` [E, N+M] (wolves, then targets),
        ``terminated`` / ``truncated`` [E] (for a world that ended and was reset in this step:
        its finished episode's values). Built when asked for, not every step."""
        return {k: self._last_out[k] for k in _STEP_INFO_KEYS} if self._last_out else {}

    def slot_of(self, world_index: int, agent: str) -> int:
        return world_index * self.per_world + self._agents.index(agent)

    # --- VecEnv API -------------------------------------------------------------------------

    def seed(self, seed: int | None = None) -> Sequence[int | None]:
        if seed is None:
            seed = int(np.random.randint(0, 2**31 - 1))
        self._next_seed = check_seed(seed, span=self.worlds)
        return [self._next_seed + e for e in range(self.worlds) for _ in range(self.per_world)]

    def reset(self) -> np.ndarray:
        out = self.batch.reset(self._next_seed)
        self._next_seed = None
        self._last_out = out
        self.reset_infos = self._slot_infos(out)
        return self._obs(out)

    def step_async(self, actions: np.ndarray) -> None:
        a = np.asarray(actions)
        if a.dtype.kind != "f":
            raise ValueError(f"actions must be floating point, got dtype {a.dtype}")
        if a.shape != (self.num_envs, 2):
            raise ValueError(f"actions: expected shape ({self.num_envs}, 2), got {a.shape}")
        # Non-finite actions are caught in step_wait, by the core's check before anything
        # moves (see _check_finite): a check here cost more than the rest of this method.
        self._actions = a

    def step_wait(self):
        if self._actions is None:
            raise RuntimeError("step_wait() without step_async()")
        actions, self._actions = self._actions, None
        # One BatchEnv step (which runs a learned opponent first, if any) into new arrays: SB3
        # keeps the observations, rewards and dones it is given past the next step.
        per_world = actions.reshape(self.worlds, self.per_world, 2)
        n = self.batch.n_wolves
        try:
            if self._side == "wolves":
                out = self.batch.step(per_world, None)
            elif self._side == "targets":
                out = self.batch.step(None, per_world)
            else:
                out = self.batch.step(per_world[:, :n], per_world[:, n:])
        except ValueError:
            self._check_finite(actions)
            raise
        # Views and one `|`: the SB3 layout's whole per-step cost, paid at every E (numpy's
        # dispatching functions, np.repeat and ndarray.any, cost more than the methods used).
        obs = self._obs(out)
        if self._shared is None:
            rewards = out[self._rewards_key].ravel()
        else:
            rewards = np.concatenate([out["rewards_wolves"], out["rewards_targets"]], axis=1).ravel()
        done_world = out["terminated"] | out["truncated"]
        dones = done_world if self.per_world == 1 else done_world.repeat(self.per_world)
        self._last_out = out
        infos: list[Mapping[str, Any]] = [RUNNING_INFO] * self.num_envs
        if np.count_nonzero(done_world):
            self._fill_ended_infos(infos, out, self._obs(out, "final_obs"))
        return obs, rewards, dones, infos

    def _check_finite(self, actions: np.ndarray) -> None:
        """ValueError naming the first slot whose action is not finite, if one is not."""
        if not np.isfinite(actions).all():
            k = int(np.argmax(~np.isfinite(actions).all(axis=1)))
            raise ValueError(f"action of slot {k} ({self._views[k].agent} in world {self._views[k].world_index}) is not finite: {actions[k].tolist()}") from None

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

    def state(self) -> np.ndarray:
        """Every world's global state, float32 [worlds, state_dim] — one row per world, not per
        slot (layout: :meth:`wolfpack.BatchEnv.state`); slot k belongs to world
        ``k // per_world``. For centralised critics."""
        return self.batch.state()

    def expert_actions(self) -> np.ndarray:
        """The scripted law's actions for every slot, [num_envs, 2] float32 (for imitation)."""
        wa, ta = self.batch.expert_actions()
        if self._side == "both":
            return self._flat(np.concatenate([wa, ta], axis=1))
        return self._flat(wa if self._side == "wolves" else ta)

    def _flat(self, a: np.ndarray) -> np.ndarray:
        return a.reshape(self.worlds * self.per_world, *a.shape[2:])

    def _obs(self, out: dict, prefix: str = "obs") -> np.ndarray:
        """This VecEnv's observations of ``out`` ([slots, D]); ``prefix="final_obs"`` for the
        last observations of finished episodes."""
        if self._shared is not None:
            return self._flat(self._shared.pack(out[f"{prefix}_wolves"], out[f"{prefix}_targets"]))
        return self._flat(out[f"{prefix}_{self._side}"])

    def _slot_infos(self, out: Mapping[str, np.ndarray]) -> list[dict]:
        """One numeric info dict (plus ``outcome_name``) per slot of the worlds in ``out``."""
        infos = agent_infos(out, self.batch.n_wolves, self._offset, self._offset + self.per_world)
        for info in infos:
            info["outcome_name"] = OUTCOMES[info["outcome"]]
        return infos

    def _fill_ended_infos(self, infos: list, step_infos: Mapping[str, np.ndarray], final_obs: np.ndarray) -> None:
        """Puts a dict into ``infos`` (SB3's per-slot infos of a step, :data:`RUNNING_INFO`
        elsewhere) for each slot of a world that ended (see the module docstring);
        ``final_obs`` [slots, D] holds their last observations."""
        terminated, truncated = step_infos["terminated"], step_infos["truncated"]
        ended = np.flatnonzero(terminated | truncated).tolist()
        per, lo = self.per_world, self._offset
        n = self.batch.n_wolves
        # Each ended world's own rows: converting the rows of all ended worlds together (one
        # fancy index and .tolist() per array) cost more per step, at a few ended worlds and
        # still at 100 (BENCHMARKS.md, "Optimisations").
        ended_infos = [world_agent_infos(step_infos, e, n, lo, lo + per) for e in ended]
        for e, slots in zip(ended, ended_infos):
            time_limit = bool(truncated[e] and not terminated[e])
            for i, info in enumerate(slots):
                info["outcome_name"] = OUTCOMES[info["outcome"]]
                info["terminal_observation"] = final_obs[e * per + i]
                info["TimeLimit.truncated"] = time_limit
                infos[e * per + i] = info


def make_vec_env(
    params: str | Path | Mapping[str, Any] | None = None,
    *,
    task: str | None = None,
    num_envs: int,
    learners: str = "wolves",
    seed: int = 0,
    threads: int | None = None,
    shared_space: bool = False,
    opponent: Any = None,
    **overrides: Any,
) -> WolfpackVecEnv:
    """An SB3 ``VecEnv`` of ``num_envs`` worlds (see this module's docstring)."""
    return WolfpackVecEnv(params, task=task, num_envs=num_envs, learners=learners, seed=seed, threads=threads, shared_space=shared_space, opponent=opponent, **overrides)
