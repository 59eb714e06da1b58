"""The batch as a TorchRL environment: ``WolfpackEnv``, an ``EnvBase`` of batch size [E] over one
:class:`wolfpack.BatchEnv`, for TorchRL's collectors, losses and BenchMARL.

Layout (the way VMAS ships its TorchRL env): one group per learning side, ``"wolves"`` and/or
``"targets"``, each with per-agent entries [E, K, ·]:

- ``observation`` float32 [E, K, D] (docs/interface.md, "Observations");
- ``action`` float32 [E, K, 2] in [−1, 1] (the batch clips);
- ``reward`` float32 [E, K, 1] (in ``"next"``);
- ``done`` / ``terminated`` / ``truncated`` bool [E, K, 1] (the world's, for every agent);
- ``mask`` bool [E, K]: the agent still plays (a target whose hunt ended, captured or cornered,
  no longer does; wolves always do).

and at the root: ``state`` float32 [E, S] (``BatchEnv.state()``, for centralised critics),
``outcome`` int64 [E, 1] (a code of ``wolfpack.OUTCOMES``: 0 while running, the episode's
outcome on the step it ended), ``done`` / ``terminated`` / ``truncated`` bool [E, 1].

The worlds reset themselves within the step that ends them (the batch's ``autoreset``). A
step's ``"next"`` entries hold what the episode ended in: its last observations and, for the
critic, its last state (``final_state``), so that a truncated episode bootstraps from where it
stopped. The fresh first observations wait for the ``reset`` that TorchRL's collectors and
``rollout`` call for the worlds that ended (``"_reset"``), which returns them without stepping
anything. Resetting a world that did not just end starts it afresh (``reset_world``).

Seeding: ``set_seed(s)`` makes the next full ``reset()`` seed world i with ``s + i``; the same
seed gives bit-identical rollouts for any ``threads``.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from wolfpack._checks import check_seed
from wolfpack._optional import require
from wolfpack.batch import OUTCOMES, BatchEnv
from wolfpack.sides import SIDES

require("torchrl", "the TorchRL view (wolfpack.torchrl_env)")  # brings torch and tensordict
import torch  # noqa: E402
from tensordict import TensorDict, TensorDictBase  # noqa: E402
from torchrl.data import Bounded, Categorical, Composite, Unbounded  # noqa: E402
from torchrl.envs import EnvBase  # noqa: E402

#: The groups, in the batch's agent order, and what one agent of each is called.
AGENT = {"wolves": "wolf", "targets": "target"}


class WolfpackEnv(EnvBase):
    """``num_envs`` worlds of wolfpack as one TorchRL environment of batch size [num_envs].

    Args:
        params, task, num_envs, learners, seed, threads, opponent, **overrides: as
            :class:`wolfpack.BatchEnv` (``learners`` must name at least one side: ``"wolves"``,
            ``"targets"`` or ``"both"``; the other side follows its law or ``opponent``).
        device: where the tensors are put (the worlds always step on the CPU threads).

    The module docstring has the layout. Unknown keywords are a TypeError; a bad value a
    ValueError naming it, as for :class:`wolfpack.BatchEnv`.
    """

    batch_locked = True

    def __init__(
        self,
        params: Any = None,
        *,
        task: str | None = None,
        num_envs: int = 1,
        learners: str = "wolves",
        seed: int = 0,
        threads: int | None = None,
        opponent: Any = None,
        device: Any = "cpu",
        **overrides: Any,
    ) -> None:
        try:
            where = torch.device(device)
        except (RuntimeError, TypeError):
            raise ValueError(f"device: {device!r} is not a torch device (e.g. 'cpu', 'cuda', 'cuda:0')") from None
        if where.type == "cuda" and not torch.cuda.is_available():
            raise ValueError(f"device: {device!r}, but there is no CUDA device here (torch.cuda.is_available() is False)")
        if learners == "none":
            raise ValueError("learners: the TorchRL view needs a learning side ('wolves', 'targets' or 'both'); to watch the laws play, use wolfpack.BatchEnv or wolfpack hunt")
        self.batch = BatchEnv(params, task=task, num_envs=num_envs, learners=learners, seed=seed, threads=threads, opponent=opponent, with_state=True, **overrides)
        b = self.batch
        super().__init__(device=device, batch_size=torch.Size([b.num_envs]))
        self.groups = tuple(side for side in SIDES if (b.learns_wolves if side == "wolves" else b.learns_targets))
        self._agents = {"wolves": b.n_wolves, "targets": b.n_targets}
        self._dims = {"wolves": b.wolf_obs_dim, "targets": b.target_obs_dim}
        #: Each group's agents by the names the PettingZoo view gives them (BenchMARL asks).
        self.group_map = {side: [f"{AGENT[side]}_{i}" for i in range(self._agents[side])] for side in self.groups}
        self._seed: int | None = seed
        self._make_specs()
        # What the worlds are at now (after the last step's autoresets), for reset() to return.
        self._current: dict[str, torch.Tensor] | None = None
        self._just_ended = np.zeros(b.num_envs, dtype=bool)

    # --- specs ---------------------------------------------------------------------------------

    def _make_specs(self) -> None:
        e, dev = self.batch.num_envs, self.device
        obs, act, rew, done = Composite(shape=(e,), device=dev), Composite(shape=(e,), device=dev), Composite(shape=(e,), device=dev), Composite(shape=(e,), device=dev)
        flag = lambda *shape: Categorical(n=2, shape=shape, dtype=torch.bool, device=dev)  # noqa: E731
        for side in self.groups:
            k, d = self._agents[side], self._dims[side]
            obs[side] = Composite(observation=Unbounded(shape=(e, k, d), dtype=torch.float32, device=dev), mask=flag(e, k), shape=(e, k), device=dev)
            act[side] = Composite(action=Bounded(low=-1.0, high=1.0, shape=(e, k, 2), dtype=torch.float32, device=dev), shape=(e, k), device=dev)
            rew[side] = Composite(reward=Unbounded(shape=(e, k, 1), dtype=torch.float32, device=dev), shape=(e, k), device=dev)
            done[side] = Composite(done=flag(e, k, 1), terminated=flag(e, k, 1), truncated=flag(e, k, 1), shape=(e, k), device=dev)
        obs["state"] = Unbounded(shape=(e, self.batch.state_dim), dtype=torch.float32, device=dev)
        obs["outcome"] = Categorical(n=len(OUTCOMES), shape=(e, 1), dtype=torch.int64, device=dev)
        done["done"], done["terminated"], done["truncated"] = flag(e, 1), flag(e, 1), flag(e, 1)
        self.full_observation_spec = obs
        self.full_action_spec = act
        self.full_reward_spec = rew
        self.full_done_spec = done

    # --- TorchRL's hooks -----------------------------------------------------------------------

    def _set_seed(self, seed: int | None) -> None:
        # Checked before it is stored: a bad seed must not make every later reset() fail.
        # World i takes seed + i, so seed + num_envs - 1 must be a seed too.
        self._seed = check_seed(seed, "seed", span=self.batch.num_envs, optional=True)

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDictBase:
        which = self._reset_mask(tensordict)
        if which is None or self._current is None or which.all() and not self._just_ended.all():
            out = self.batch.reset(self._seed)
            self._seed = None  # a later full reset starts each world's next episode
            self._just_ended[:] = False
            self._current = self._view(out, fresh=self._just_ended)
            return self._td(self._current)
        # The worlds that just ended were reset within their step: their first observations are
        # in self._current. A world asked to reset in the middle of an episode starts afresh;
        # the output of its reset_world holds every world as it is now.
        afresh = np.flatnonzero(which & ~self._just_ended)
        for i in afresh:
            out = self.batch.reset_world(int(i))
        if len(afresh):
            self._current = self._view(out, fresh=np.zeros(self.batch.num_envs, dtype=bool))
        self._just_ended &= ~which
        return self._td(self._current)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        actions = {side: self._actions(tensordict, side) for side in self.groups}
        out = self.batch.step(actions.get("wolves"), actions.get("targets"))
        ended = np.logical_or(out["terminated"], out["truncated"])
        self._just_ended = ended
        current = self._view(out, fresh=ended)
        self._current = current
        if not ended.any():
            return self._td(current, out)
        # "next" holds what each ended episode ended in; self._current keeps the fresh starts.
        last = dict(current)
        for side in self.groups:
            obs = out[f"obs_{side}"].copy()
            obs[ended] = out[f"final_obs_{side}"][ended]
            last[f"{side}.observation"] = torch.from_numpy(obs)
        state = out["state"].copy()
        state[ended] = out["final_state"][ended]
        last["state"] = torch.from_numpy(state)
        if "targets" in self.groups:
            last["targets.mask"] = torch.from_numpy(out["capture_step"] < 0)
        return self._td(last, out)

    def step_and_maybe_reset(self, tensordict: TensorDictBase) -> tuple[TensorDictBase, TensorDictBase]:
        """TorchRL's step-then-reset (what its collectors and ``rollout`` call), made cheap: the
        worlds that ended are already reset, so the next root is the step's ``"next"`` moved up
        with every world's current entries written over it — the same tensordict TorchRL's
        generic partial reset builds (a test compares them), without its per-entry masked merge
        (in a profile at E = 256, a sixth of the whole step)."""
        if tensordict.device is not None and tensordict.device != self.device:
            tensordict = tensordict.to(self.device)
        tensordict = self.step(tensordict)
        tensordict_ = self._step_mdp(tensordict)
        hooks = getattr(self, "_post_step_mdp_hooks", None)  # TorchRL >= 0.13
        if hooks is not None:
            tensordict, tensordict_ = hooks(tensordict, tensordict_)
        if self._just_ended.any():
            tensordict_.update(self._fresh_entries(self._current))
            self._just_ended[:] = False
        return tensordict, tensordict_

    # --- helpers -------------------------------------------------------------------------------

    def _actions(self, tensordict: TensorDictBase, side: str) -> np.ndarray:
        a = tensordict.get((side, "action"), None)
        if a is None:  # TorchRL defines no error of its own for this; a missing key is a KeyError
            e, k = self.batch.num_envs, self._agents[side]
            raise KeyError(f"step: the tensordict has no ({side!r}, 'action') entry: the {side}' actions, float32 [{e}, {k}, 2] in [-1, 1] (env.full_action_spec)")
        return np.ascontiguousarray(a.detach().to("cpu", torch.float32).numpy())

    @staticmethod
    def _reset_mask(tensordict: TensorDictBase | None) -> np.ndarray | None:
        """The worlds a ``reset`` asks for, from the root ``"_reset"`` [E, 1] or a group's
        [E, K, 1] (any agent of a world asks for its world); None: every world."""
        if tensordict is None:
            return None
        masks = [tensordict.get(key) for key in tensordict.keys(True, True) if (key == "_reset" or isinstance(key, tuple) and key[-1] == "_reset")]
        if not masks:
            return None
        which = torch.zeros(tensordict.batch_size[0], dtype=torch.bool)
        for m in masks:
            which |= m.reshape(m.shape[0], -1).any(-1).cpu()
        return which.numpy()

    def _view(self, out: dict, fresh: np.ndarray) -> dict[str, torch.Tensor]:
        """The worlds as they are after a reset or a step's autoresets, from its output ``out``:
        CPU tensors on the batch's arrays (no copies), keyed ``side.entry`` and by root name.
        ``fresh`` [E]: the worlds whose episode just started (every target plays)."""
        view: dict[str, torch.Tensor] = {"state": torch.from_numpy(out["state"])}
        for side in self.groups:
            view[f"{side}.observation"] = torch.from_numpy(out[f"obs_{side}"])
            if side == "wolves":
                view["wolves.mask"] = torch.ones(self.batch.num_envs, self._agents[side], dtype=torch.bool)
            else:
                view["targets.mask"] = torch.from_numpy((out["capture_step"] < 0) | fresh[:, None])
        return view

    def _fresh_entries(self, view: dict[str, torch.Tensor]) -> dict:
        """Every entry a reset sets, by nested key, for the worlds as ``view`` has them (no episode
        ended: every done flag False, outcome 0): what a reset writes over a step's next root."""
        e = self.batch.num_envs
        entries: dict = {"state": view["state"], "outcome": torch.zeros(e, 1, dtype=torch.int64)}
        for flag in ("done", "terminated", "truncated"):
            entries[flag] = torch.zeros(e, 1, dtype=torch.bool)
        for side in self.groups:
            entries[side, "observation"], entries[side, "mask"] = view[f"{side}.observation"], view[f"{side}.mask"]
            for flag in ("done", "terminated", "truncated"):
                entries[side, flag] = torch.zeros(e, self._agents[side], 1, dtype=torch.bool)
        return entries

    def _td(self, view: dict[str, torch.Tensor], out: dict | None = None) -> TensorDictBase:
        """The tensordict of ``view``: after a step with its output ``out`` (rewards, done flags,
        outcomes), else after a reset (no episode ended, no rewards)."""
        e = self.batch.num_envs
        if out is None:
            terminated = truncated = torch.zeros(e, 1, dtype=torch.bool)
            outcome = torch.zeros(e, 1, dtype=torch.int64)
        else:
            terminated = torch.from_numpy(out["terminated"]).unsqueeze(-1)
            truncated = torch.from_numpy(out["truncated"]).unsqueeze(-1)
            outcome = torch.from_numpy(out["outcome"].astype(np.int64)).unsqueeze(-1)
        done = terminated | truncated
        source: dict[str, Any] = {"state": view["state"], "outcome": outcome, "done": done, "terminated": terminated, "truncated": truncated}
        for side in self.groups:
            k = self._agents[side]
            group = {
                "observation": view[f"{side}.observation"],
                "mask": view[f"{side}.mask"],
                "done": done.unsqueeze(1).expand(e, k, 1),
                "terminated": terminated.unsqueeze(1).expand(e, k, 1),
                "truncated": truncated.unsqueeze(1).expand(e, k, 1),
            }
            if out is not None:
                group["reward"] = torch.from_numpy(out[f"rewards_{side}"]).unsqueeze(-1)
            source[side] = TensorDict._new_unsafe(group, batch_size=(e, k))
        # Without the per-entry checks of TensorDict(...): every entry is a CPU tensor of the
        # spec's shape and dtype (check_env_specs in the tests), and at E = 256 the checks cost
        # a few per cent of a step (BENCHMARKS.md, "The TorchRL view"). TorchRL's own envs
        # (gym_like, brax) build outputs this way.
        td = TensorDict._new_unsafe(source, batch_size=(e,))
        return td if self.device == torch.device("cpu") else td.to(self.device)
