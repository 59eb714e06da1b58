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

from wolfpack.learn.nets import LOG_2PI, Actor, Critic, RunningNorm


class SideLearner:
    """The learner of one side (``"wolves"`` or ``"targets"``) on ``num_envs`` worlds with
    ``agents`` agents each, collecting ``n_steps`` steps per update.

    Buffers (on ``device``, allocated once): normalised observations [T, E, K, D], normalised
    states [T, E, S] (MAPPO), raw actions [T, E, K, 2], their log-probabilities, values and
    rewards [T, E, K], episode ends [T, E].

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
        agents: int,
        num_envs: int,
        device: torch.device,
        generator: torch.Generator,
        side_by_side: bool = False,
    ) -> None:
        self.side, self.algo, self.recipe, self.device, self.gen = side, algo, recipe, device, generator
        self.agents, self.num_envs, self.n_steps = agents, num_envs, int(recipe["n_steps"])
        centralised = algo == "mappo"
        self.network = dict(
            obs_dim=obs_dim,
            agents=agents,
            hidden=list(recipe["hidden"]),
            activation=recipe["activation"],
            log_std_init=float(recipe["log_std_init"]),
            agent_id=bool(recipe["agent_id"]),
            norm_obs=bool(recipe["norm_obs"]),
        )
        self.actor = Actor(**self.network).to(device)
        self.critic = Critic(obs_dim, state_dim if centralised else 0, agents, list(recipe["hidden"]), recipe["activation"], bool(recipe["agent_id"]), bool(recipe["norm_obs"])).to(device)
        self.params = [*self.actor.parameters(), *self.critic.parameters()]
        # fused: one kernel over every parameter instead of a loop of small ops (42 → 17 ms an update).
        self.optimizer = torch.optim.Adam(self.params, lr=float(recipe["learning_rate"]), eps=1e-5, fused=True)
        # Return normalisation: the running variance of each agent's discounted return.
        self.return_norm = RunningNorm(1, enabled=bool(recipe["norm_reward"]))
        self._discounted = torch.zeros(num_envs, agents, dtype=torch.float64)
        T, E, K = self.n_steps, num_envs, agents
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
        self._noise = zeros(E, K, 2)
        self._actions_out = torch.zeros(E, K, 2)  # on the CPU, what the batch reads
        self._critic_thread = ThreadPoolExecutor(1, thread_name_prefix=f"wolfpack-{side}-critic") if side_by_side else None

    # --- the rollout ----------------------------------------------------------------------------

    @staticmethod
    def _normalise_into(norm: RunningNorm, raw: np.ndarray, out: torch.Tensor, count: bool = True) -> None:
        out.copy_(torch.from_numpy(raw))  # the one copy: the batch's array into the buffer (and onto the device)
        if count:
            norm.accumulate(out)
        norm.normalise_(out)

    @torch.no_grad()
    def act(self, t: int, obs: np.ndarray, state: np.ndarray | None) -> np.ndarray:
        """Step ``t``'s actions for the batch's observations ``obs`` [E, K, D] (and its state
        [E, S], MAPPO): a draw from the policy, stored with its log-probability and value.
        Returns the clipped actions as float32 [E, K, 2], a view of a buffer reused every step."""
        o = self.obs[t]
        self._normalise_into(self.actor.norm, obs, o)
        s = None
        if self.state is not None:
            s = self.state[t]
            self._normalise_into(self.critic.state_norm, state, s)
        # The actor's and the critic's per-agent inputs are the same rows (see update): built once.
        x = self.actor.inputs(o)
        mean = self.actor.body(x)
        torch.randn(self._noise.shape, generator=self.gen, device=self.device, out=self._noise)
        log_std = self.actor.log_std
        a = self.actions[t]
        torch.addcmul(mean, self._noise, log_std.exp(), out=a)
        self.logp[t] = -(0.5 * self._noise * self._noise + log_std + 0.5 * LOG_2PI).sum(-1)
        self.values[t] = self.critic.value(x, s)
        self._actions_out.copy_(a.clamp(-1.0, 1.0))
        return self._actions_out.numpy()

    def record(self, t: int, rewards: np.ndarray, dones: torch.Tensor) -> None:
        """Step ``t``'s rewards [E, K] and episode ends [E] (bool, on the CPU)."""
        r = torch.from_numpy(rewards)
        self.rewards[t].copy_(r)
        self.dones[t].copy_(dones)
        if self.return_norm.enabled:
            self._discounted.mul_(float(self.recipe["gamma"])).add_(r)
            self.return_norm.accumulate(self._discounted.reshape(-1, 1))
            self._discounted[dones] = 0.0

    @torch.no_grad()
    def finish_rollout(self, obs: np.ndarray, state: np.ndarray | None) -> None:
        """Bootstraps from the observations after the last step, scales the rewards, computes
        GAE advantages and returns, and merges the rollout's normalisation statistics."""
        o = torch.empty_like(self.obs[0])
        self._normalise_into(self.actor.norm, obs, o, count=False)  # counted as the next rollout's first step
        s = None
        if self.state is not None:
            s = torch.empty_like(self.state[0])
            self._normalise_into(self.critic.state_norm, state, s, count=False)
        last_value = self.critic.value(self.critic.agent_inputs(o), s)
        self.return_norm.commit()
        if self.return_norm.enabled:
            self.rewards.mul_(self.return_norm.scale[0])
        gamma, lam = float(self.recipe["gamma"]), float(self.recipe["gae_lambda"])
        gae = torch.zeros_like(last_value)
        for t in reversed(range(self.n_steps)):
            alive = (1.0 - self.dones[t]).unsqueeze(-1)
            next_value = last_value if t == self.n_steps - 1 else self.values[t + 1]
            delta = self.rewards[t] + gamma * next_value * alive - self.values[t]
            gae = delta + gamma * lam * alive * gae
            self.advantages[t] = gae
        torch.add(self.advantages, self.values, out=self.returns)
        self.actor.norm.commit()
        if self.critic.state_norm is not None:
            self.critic.state_norm.commit()

    # --- the update ------------------------------------------------------------------------------

    def set_learning_rate(self, lr: float) -> None:
        for group in self.optimizer.param_groups:
            group["lr"] = lr

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
        T, E, K = self.n_steps, self.num_envs, self.agents
        with torch.no_grad():
            # The actor's and the critic's per-agent inputs are the same rows (the normalised
            # observation, ⊕ the agent id when the recipe asks for it): gathered once.
            agent_in = self.actor.inputs(self.obs).reshape(T * E, K, -1)
        states = self.state.reshape(T * E, -1) if self.state is not None else None
        actions, old_logp = self.actions.reshape(T * E, K, 2), self.logp.reshape(T * E, K)
        adv, ret, old_v = self.advantages.reshape(T * E, K), self.returns.reshape(T * E, K), self.values.reshape(T * E, K)
        n = T * E
        mb = max(1, min(int(rc["minibatch_size"]), n * K) // K)
        sums = dict(policy_loss=0.0, value_loss=0.0, entropy=0.0, approx_kl=0.0, clip_fraction=0.0)
        steps = 0
        stop = False
        if self._critic_thread is not None:
            # A thread of its own starts with torch's default thread count: give it the caller's.
            self._critic_thread.submit(torch.set_num_threads, torch.get_num_threads()).result()

        def critic_step(x: torch.Tensor, idx: torch.Tensor) -> torch.Tensor:
            """The critic's loss for minibatch ``idx`` (inputs ``x``), its gradients accumulated."""
            v = self.critic.value(x, states.index_select(0, idx) if states is not None else None)
            r = ret.index_select(0, idx)
            if clip_v is not None:
                v_old = old_v.index_select(0, idx)
                v_clipped = v_old + (v - v_old).clamp(-float(clip_v), float(clip_v))
                value_loss = 0.5 * torch.max((v - r) ** 2, (v_clipped - r) ** 2).mean()
            else:
                value_loss = 0.5 * ((v - r) ** 2).mean()
            (vf_coef * value_loss).backward()
            return value_loss.detach()

        for _ in range(int(rc["epochs"])):
            order = torch.randperm(n, generator=self.gen, device=self.device)
            for lo in range(0, n - mb + 1, mb):
                idx = order[lo : lo + mb]
                self.optimizer.zero_grad(set_to_none=True)
                # index_select, not x[idx]: the same rows, gathered 2–4x faster on the CPU (the
                # generic indexing kernel was 19 % of an update's time).
                x = agent_in.index_select(0, idx)
                critic = self._critic_thread.submit(critic_step, x, idx) if self._critic_thread else None
                with torch.set_grad_enabled(train_actor):
                    mean = self.actor.body(x)
                    logp = self.actor.log_prob(mean, actions.index_select(0, idx))
                    log_ratio = logp - old_logp.index_select(0, idx)
                    ratio = log_ratio.exp()
                    a = adv.index_select(0, idx)
                    a = (a - a.mean()) / (a.std() + 1e-8)
                    policy_loss = torch.max(-a * ratio, -a * ratio.clamp(1 - clip, 1 + clip)).mean()
                    entropy = self.actor.entropy()
                if train_actor:
                    (policy_loss - ent_coef * entropy).backward()
                value_loss = critic.result() if critic else critic_step(x, idx)
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
