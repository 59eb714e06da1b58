"""PPO for one side of the batch: parameter-shared actor and critic, a preallocated rollout,
GAE and the clipped update.

One :class:`SideLearner` per learning side; when both sides learn, each has its own networks,
optimiser and statistics and they share only the batch. All agents of a side share the
networks (IPPO with parameter sharing; MAPPO when the critic reads the global state).

Episodes end on capture, collision (both terminal) or at ``world.max_steps`` (truncated). The
observation and the state both carry the clock (t / max_steps), so the task is time-aware and
the truncation is a true end of the episode for the critic as well: no value is bootstrapped
across it (Pardo et al., "Time limits in reinforcement learning", 2018). That also spares the
learner the final observations of autoreset worlds.
"""

from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from typing import Any

import numpy as np
import torch
from torch import nn

from wolfpack import _core
from wolfpack.networks.mlp import LOG_2PI, Critic, RunningNorm
from wolfpack.networks.sets import EntityCritic, build_actor

#: The wall rows that close every entity observation (the core's wall_rows block).
WALL_ROWS = int(_core.ENTITY_WALLS)


class Rollout:
    """The rollout buffers of one group of worlds (``num_envs`` worlds of ``agents`` agents of
    the learning side, all of one task): normalised observations [T, E, K, D], normalised
    states [T, E, S] (MAPPO), raw actions [T, E, K, 2], their log-probabilities, values and
    rewards [T, E, K], episode ends [T, E]; on ``device``, allocated once."""

    def __init__(self, n_steps: int, num_envs: int, agents: int, obs_dim: int, state_dim: int, centralised: bool, device: torch.device) -> None:
        self.num_envs, self.agents = num_envs, agents
        T, E, K = n_steps, num_envs, agents
        zeros = lambda *shape: torch.zeros(*shape, device=device)  # noqa: E731
        self.obs = zeros(T, E, K, obs_dim)
        self.state = zeros(T, E, state_dim) if centralised else None
        self.actions = zeros(T, E, K, 2)
        self.logp = zeros(T, E, K)
        self.values = zeros(T, E, K)
        self.rewards = zeros(T, E, K)
        self.dones = zeros(T, E)
        self.advantages = zeros(T, E, K)
        self.returns = zeros(T, E, K)
        self.noise = zeros(E, K, 2)
        self.actions_out = torch.zeros(E, K, 2)  # on the CPU, what the batch reads
        # Each agent's discounted return so far, for the return normaliser.
        self.discounted = torch.zeros(E, K, dtype=torch.float64)


class SideLearner:
    """The learner of one side (``"wolves"`` or ``"targets"``) on one or more groups of worlds
    (``groups``: ``(num_envs, agents)`` each; one group per task in multi-task training, as a
    batch holds worlds of one params), collecting ``n_steps`` steps per update. The networks,
    the optimiser and the normalisers are shared by every group; each group has its own
    :class:`Rollout`. ``num_envs`` / ``agents`` give a single group.

    ``side_by_side``: the update's actor and critic learn at once, each minibatch's critic
    forward and backward on a thread of its own while the calling thread does the actor's. The
    two share no parameter (only the gradient clip's joint norm and Adam's step, which follow
    both), so the weights are those of one thread, bit for bit. Why threads of our own rather
    than torch's: torch's intra-op threads meet at the end of every operation, thousands per
    update, and each meeting wakes a sleeping thread (or keeps it spinning, which beside another
    busy process stalls a worker for a scheduler slice); two coarse tasks meet once per
    minibatch (BENCHMARKS.md, "Learning")."""

    def __init__(
        self,
        side: str,
        algo: str,
        recipe: dict,
        *,
        obs_dim: int,
        state_dim: int,
        agents: int = 0,
        num_envs: int = 0,
        groups: list[tuple[int, int]] | None = None,
        entity_shape: tuple[int, int, int] | None = None,
        device: torch.device,
        generator: torch.Generator,
        side_by_side: bool = False,
    ) -> None:
        self.side, self.algo, self.recipe, self.device, self.gen = side, algo, recipe, device, generator
        groups = list(groups) if groups else [(num_envs, agents)]
        self.n_steps = int(recipe["n_steps"])
        # The first group's team size: what a flat actor with agent ids is built for (every
        # group's, as checked below).
        self.agents = groups[0][1]
        if recipe["network"] != "entities" and bool(recipe["agent_id"]) and len({k for _, k in groups}) > 1:
            raise ValueError(f"agent_id: the {side}' teams differ in size between the tasks; a one-hot agent id needs one team size (use network: entities)")
        centralised = algo == "mappo"
        hidden, activation, norm_obs = list(recipe["hidden"]), recipe["activation"], bool(recipe["norm_obs"])
        if recipe["network"] == "entities":
            if entity_shape is None:
                raise ValueError(f"network: entities needs the {side}' entity observations (env.{'wolf' if side == 'wolves' else 'target'}_observation: entities)")
            self_dim, row_size, state_row = entity_shape
            width, pool, heads = int(recipe["entity_width"]), recipe["pool"], int(recipe["heads"])
            # What a saved model needs to rebuild its actor (wolfpack.networks.sets.build_actor).
            self.network = dict(
                kind="entities",
                self_dim=self_dim,
                row_size=row_size,
                obs_dim=obs_dim,
                hidden=hidden,
                entity_width=width,
                pool=pool,
                heads=heads,
                activation=activation,
                log_std_init=float(recipe["log_std_init"]),
                norm_obs=norm_obs,
                wall_rows=WALL_ROWS,
            )
            self.actor = build_actor(self.network).to(device)  # the actor first: the networks' initial draws in a fixed order
            self.critic = EntityCritic(self_dim, row_size, state_dim if centralised else 0, state_row, hidden, width, pool, heads, activation, norm_obs, WALL_ROWS).to(device)
        else:
            self.network = dict(
                obs_dim=obs_dim, agents=self.agents, hidden=hidden, activation=activation, log_std_init=float(recipe["log_std_init"]), agent_id=bool(recipe["agent_id"]), norm_obs=norm_obs
            )
            self.actor = build_actor(self.network).to(device)
            self.critic = Critic(obs_dim, state_dim if centralised else 0, self.agents, hidden, activation, bool(recipe["agent_id"]), norm_obs).to(device)
        self.params = [*self.actor.parameters(), *self.critic.parameters()]
        # fused: one kernel over every parameter instead of a loop of small ops, which cuts the
        # optimiser's time in an update by more than half (BENCHMARKS.md, "Optimisations").
        self.optimizer = torch.optim.Adam(self.params, lr=float(recipe["learning_rate"]), eps=1e-5, fused=True)
        # Return normalisation: the running variance of each agent's discounted return.
        self.return_norm = RunningNorm(1, enabled=bool(recipe["norm_reward"]))
        self.rollouts = [Rollout(self.n_steps, e, k, obs_dim, state_dim, centralised, device) for e, k in groups]
        #: Each group's weight in the update's losses (mean 1; multi-task training moves them
        #: towards the tasks the learner does worst on).
        self.group_weights = [1.0] * len(groups)
        self._critic_thread = ThreadPoolExecutor(1, thread_name_prefix=f"wolfpack-{side}-critic") if side_by_side else None

    # --- the rollout ----------------------------------------------------------------------------

    @staticmethod
    def _normalise_into(norm: RunningNorm, raw: np.ndarray, out: torch.Tensor, count: bool = True) -> None:
        out.copy_(torch.from_numpy(raw))  # the one copy: the batch's array into the buffer (and onto the device)
        if count:
            norm.accumulate(out)
        norm.normalise_(out)

    @torch.no_grad()
    def act(self, t: int, obs: np.ndarray, state: np.ndarray | None, group: int = 0) -> np.ndarray:
        """Step ``t``'s actions for group ``group``'s observations ``obs`` [E, K, D] (and its
        state [E, S], MAPPO): a draw from the policy, stored with its log-probability and value.
        Returns the clipped actions as float32 [E, K, 2], a view of a buffer reused every step."""
        r = self.rollouts[group]
        o = r.obs[t]
        self._normalise_into(self.actor.norm, obs, o)
        s = None
        if r.state is not None:
            s = r.state[t]
            self._normalise_into(self.critic.state_norm, state, s)
        # The actor's and the critic's per-agent inputs are the same rows (see update): built once.
        x = self.actor.inputs(o)
        mean = self.actor.body(x)
        torch.randn(r.noise.shape, generator=self.gen, device=self.device, out=r.noise)
        log_std = self.actor.log_std
        a = r.actions[t]
        torch.addcmul(mean, r.noise, log_std.exp(), out=a)
        r.logp[t] = -(0.5 * r.noise * r.noise + log_std + 0.5 * LOG_2PI).sum(-1)
        r.values[t] = self.critic.value(x, s)
        r.actions_out.copy_(a.clamp(-1.0, 1.0))
        return r.actions_out.numpy()

    def record(self, t: int, rewards: np.ndarray, dones: torch.Tensor, group: int = 0) -> None:
        """Step ``t``'s rewards [E, K] and episode ends [E] (bool, on the CPU) of ``group``."""
        r = self.rollouts[group]
        rw = torch.from_numpy(rewards)
        r.rewards[t].copy_(rw)
        r.dones[t].copy_(dones)
        if self.return_norm.enabled:
            r.discounted.mul_(float(self.recipe["gamma"])).add_(rw)
            self.return_norm.accumulate(r.discounted.reshape(-1, 1))
            r.discounted[dones] = 0.0

    @torch.no_grad()
    def finish_rollout(self, obs: np.ndarray | list[np.ndarray], state: np.ndarray | None | list) -> None:
        """Bootstraps from the observations after the last step (one array per group, or the
        one group's), scales the rewards, computes GAE advantages and returns, and merges the
        rollout's normalisation statistics."""
        if not isinstance(obs, list):
            obs, state = [obs], [state]
        last_values = []
        for r, o_raw, s_raw in zip(self.rollouts, obs, state):
            o = torch.empty_like(r.obs[0])
            self._normalise_into(self.actor.norm, o_raw, o, count=False)  # counted as the next rollout's first step
            s = None
            if r.state is not None:
                s = torch.empty_like(r.state[0])
                self._normalise_into(self.critic.state_norm, s_raw, s, count=False)
            last_values.append(self.critic.value(self.critic.agent_inputs(o), s))
        self.return_norm.commit()
        gamma, lam = float(self.recipe["gamma"]), float(self.recipe["gae_lambda"])
        for r, last_value in zip(self.rollouts, last_values):
            if self.return_norm.enabled:
                r.rewards.mul_(self.return_norm.scale[0])
            gae = torch.zeros_like(last_value)
            for t in reversed(range(self.n_steps)):
                alive = (1.0 - r.dones[t]).unsqueeze(-1)
                next_value = last_value if t == self.n_steps - 1 else r.values[t + 1]
                delta = r.rewards[t] + gamma * next_value * alive - r.values[t]
                gae = delta + gamma * lam * alive * gae
                r.advantages[t] = gae
            torch.add(r.advantages, r.values, out=r.returns)
        self.actor.norm.commit()
        if self.critic.state_norm is not None:
            self.critic.state_norm.commit()

    # --- the update ------------------------------------------------------------------------------

    def set_learning_rate(self, lr: float) -> None:
        for group in self.optimizer.param_groups:
            group["lr"] = lr

    def _minibatches(self, sizes: list[int], mbs: list[int]) -> list[tuple[int, torch.Tensor]]:
        """One epoch's minibatches as (group, world-step indices): each group's world-steps
        shuffled and cut into minibatches of its size; with several groups, the minibatches
        of all of them in a shuffled order (one group: its own order, the random stream of a
        single-task run)."""
        batches = []
        for g, (n, mb) in enumerate(zip(sizes, mbs)):
            order = torch.randperm(n, generator=self.gen, device=self.device)
            batches.extend((g, order[lo : lo + mb]) for lo in range(0, n - mb + 1, mb))
        if len(sizes) > 1:
            batches = [batches[i] for i in torch.randperm(len(batches), generator=self.gen).tolist()]
        return batches

    def update(self, train_actor: bool = True) -> dict[str, float]:
        """PPO's clipped update over the rollout: ``epochs`` passes of shuffled minibatches
        (``train_actor=False``: the critic's loss alone, the actor left as it is). Returns the
        mean losses, entropy, approximate KL, clip fraction and explained variance."""
        rc = self.recipe
        clip, clip_v = float(rc["clip"]), rc["clip_value"]
        ent_coef, vf_coef, max_norm = float(rc["ent_coef"]), float(rc["vf_coef"]), float(rc["max_grad_norm"])
        target_kl = rc["target_kl"]
        # Minibatches of whole world-steps (all K agents of a world at a step together), so that
        # the critic projects each world's state once for its K agents (Critic.value).
        data = []
        for r in self.rollouts:
            T, E, K = self.n_steps, r.num_envs, r.agents
            with torch.no_grad():
                # The actor's and the critic's per-agent inputs are the same rows (the normalised
                # observation, ⊕ the agent id when the recipe asks for it): gathered once.
                agent_in = self.actor.rollout_inputs(r.obs).reshape(T * E, K, -1)
            data.append(
                dict(
                    agent_in=agent_in,
                    states=r.state.reshape(T * E, -1) if r.state is not None else None,
                    actions=r.actions.reshape(T * E, K, 2),
                    old_logp=r.logp.reshape(T * E, K),
                    adv=r.advantages.reshape(T * E, K),
                    ret=r.returns.reshape(T * E, K),
                    old_v=r.values.reshape(T * E, K),
                )
            )
        sizes = [self.n_steps * r.num_envs for r in self.rollouts]
        mbs = [max(1, min(int(rc["minibatch_size"]), n * r.agents) // r.agents) for n, r in zip(sizes, self.rollouts)]
        sums = dict(policy_loss=0.0, value_loss=0.0, entropy=0.0, approx_kl=0.0, clip_fraction=0.0)
        steps = 0
        stop = False
        if self._critic_thread is not None:
            # A thread of its own starts with torch's default thread count: give it the caller's.
            self._critic_thread.submit(torch.set_num_threads, torch.get_num_threads()).result()

        def critic_step(d: dict, x: torch.Tensor, idx: torch.Tensor, weight: float) -> torch.Tensor:
            """The critic's loss for minibatch ``idx`` (inputs ``x``), its gradients accumulated."""
            states = d["states"]
            v = self.critic.value(x, states.index_select(0, idx) if states is not None else None)
            r = d["ret"].index_select(0, idx)
            if clip_v is not None:
                v_old = d["old_v"].index_select(0, idx)
                v_clipped = v_old + (v - v_old).clamp(-float(clip_v), float(clip_v))
                value_loss = 0.5 * torch.max((v - r) ** 2, (v_clipped - r) ** 2).mean()
            else:
                value_loss = 0.5 * ((v - r) ** 2).mean()
            loss = vf_coef * value_loss
            (loss if weight == 1.0 else weight * loss).backward()
            return value_loss.detach()

        for _ in range(int(rc["epochs"])):
            for g, idx in self._minibatches(sizes, mbs):
                d, weight = data[g], self.group_weights[g]
                self.optimizer.zero_grad(set_to_none=True)
                # index_select, not x[idx]: the same rows, gathered 2–4x faster on the CPU (the
                # generic indexing kernel was 19 % of an update's time).
                x = d["agent_in"].index_select(0, idx)
                critic = self._critic_thread.submit(critic_step, d, x, idx, weight) if self._critic_thread else None
                with torch.set_grad_enabled(train_actor):
                    mean = self.actor.body(x)
                    logp = self.actor.log_prob(mean, d["actions"].index_select(0, idx))
                    log_ratio = logp - d["old_logp"].index_select(0, idx)
                    ratio = log_ratio.exp()
                    a = d["adv"].index_select(0, idx)
                    a = (a - a.mean()) / (a.std() + 1e-8)
                    policy_loss = torch.max(-a * ratio, -a * ratio.clamp(1 - clip, 1 + clip)).mean()
                    entropy = self.actor.entropy()
                if train_actor:
                    loss = policy_loss - ent_coef * entropy
                    (loss if weight == 1.0 else weight * loss).backward()
                value_loss = critic.result() if critic else critic_step(d, x, idx, weight)
                nn.utils.clip_grad_norm_(self.params, max_norm)
                self.optimizer.step()
                with torch.no_grad():
                    kl = ((ratio - 1) - log_ratio).mean().item()
                    sums["policy_loss"] += policy_loss.item()
                    sums["value_loss"] += value_loss.item()
                    sums["entropy"] += entropy.item()
                    sums["approx_kl"] += kl
                    sums["clip_fraction"] += ((ratio - 1).abs() > clip).float().mean().item()
                steps += 1
                if target_kl is not None and kl > 1.5 * float(target_kl):
                    stop = True
                    break
            if stop:
                break
        stats = {k: v / max(steps, 1) for k, v in sums.items()}
        ret = torch.cat([d["ret"].reshape(-1) for d in data])
        old_v = torch.cat([d["old_v"].reshape(-1) for d in data])
        var = ret.var()
        stats["explained_variance"] = float(1 - (ret - old_v).var() / var) if var > 0 else float("nan")
        stats["gradient_steps"] = steps
        return stats

    # --- state for checkpoints -------------------------------------------------------------------

    def state_dict(self) -> dict[str, Any]:
        return {
            "actor": self.actor.state_dict(),
            "critic": self.critic.state_dict(),
            "optimizer": self.optimizer.state_dict(),
            "return_norm": self.return_norm.state_dict(),
        }

    def load_state_dict(self, state: dict[str, Any]) -> None:
        self.actor.load_state_dict(state["actor"])
        self.critic.load_state_dict(state["critic"])
        self.optimizer.load_state_dict(state["optimizer"])
        self.return_norm.load_state_dict(state["return_norm"])

    def policy(self):
        """The current policy as a numpy callable ``obs [..., D] -> actions [..., 2]`` (the
        clipped mean), for evaluations during training."""

        def act(obs: np.ndarray) -> np.ndarray:
            x = torch.from_numpy(np.ascontiguousarray(obs, dtype=np.float32)).to(self.device)
            return self.actor.deterministic(x.reshape(-1, x.shape[-1])).cpu().numpy().reshape(*obs.shape[:-1], 2)

        return act
