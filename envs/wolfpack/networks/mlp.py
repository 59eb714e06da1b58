"""The networks of the native trainer: a running normaliser, the Gaussian actor and the critic.

The actor is a Gaussian over the raw action box with a state-independent log standard
deviation; the environment clips every action to [-1, 1]. Why a clipped Gaussian rather than a
squashed (tanh) Gaussian or a Beta: the laws' best actions often lie on the bounds (full speed
is a0 = 1 in unicycle mode, a hard turn a1 = ±1), and clipping puts probability mass exactly
there, where tanh and Beta only approach the bound with ever smaller densities and ever larger
pre-activations. The log-probability is that of the unclipped draw (as in SB3 and CleanRL), so
the PPO ratio is exact for the sampled action; the deterministic action is the clipped mean.
"""

from __future__ import annotations

import torch
from torch import nn

ACTIVATIONS = {"tanh": nn.Tanh, "relu": nn.ReLU}
LOG_2PI = float(torch.log(torch.tensor(2 * torch.pi)))


class RunningNorm(nn.Module):
    """Normalises inputs by a running mean and variance: ``clamp((x - mean) / sqrt(var + eps),
    -clip, clip)``. The statistics are buffers, saved with the model, and change only in
    :meth:`commit`, so that a whole rollout is normalised alike (its stored inputs and the
    update that learns from them agree). :meth:`accumulate` gathers sums in float64 between
    commits; :meth:`commit` merges them (Chan et al.'s parallel variance)."""

    def __init__(self, dim: int, clip: float = 10.0, eps: float = 1e-8, enabled: bool = True) -> None:
        super().__init__()
        self.clip, self.eps, self.enabled = clip, eps, enabled
        self.register_buffer("mean", torch.zeros(dim, dtype=torch.float64))
        self.register_buffer("var", torch.ones(dim, dtype=torch.float64))
        self.register_buffer("count", torch.zeros((), dtype=torch.float64))
        self.register_buffer("shift", torch.zeros(dim))
        self.register_buffer("scale", torch.ones(dim))
        self._sum = torch.zeros(dim, dtype=torch.float64)
        self._sumsq = torch.zeros(dim, dtype=torch.float64)
        self._n = 0

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.normalise_(x.clone()) if self.enabled else x

    def normalise_(self, x: torch.Tensor) -> torch.Tensor:
        """Normalises ``x`` in place (a rollout buffer's row) and returns it."""
        if self.enabled:
            x.sub_(self.shift).mul_(self.scale).clamp_(-self.clip, self.clip)
        return x

    def accumulate(self, x: torch.Tensor) -> None:
        """Adds rows ``x`` [..., dim] to the pending statistics."""
        if not self.enabled:
            return
        flat = x.reshape(-1, x.shape[-1]).to(torch.float64)
        if self._sum.device != flat.device:
            self._sum, self._sumsq = self._sum.to(flat.device), self._sumsq.to(flat.device)
        self._sum += flat.sum(0)
        self._sumsq += (flat * flat).sum(0)
        self._n += flat.shape[0]

    @torch.no_grad()
    def commit(self) -> None:
        """Merges the pending statistics into the running ones."""
        if not self.enabled or self._n == 0:
            return
        n = float(self._n)
        batch_mean = self._sum / n
        batch_var = (self._sumsq / n - batch_mean * batch_mean).clamp_(min=0.0)
        total = self.count + n
        delta = batch_mean - self.mean
        self.var.copy_((self.var * self.count + batch_var * n + delta * delta * self.count * n / total) / total)
        self.mean.add_(delta * n / total)
        self.count.copy_(total)
        self.shift.copy_(self.mean.float())
        self.scale.copy_((self.var + self.eps).rsqrt().float())
        self._sum.zero_()
        self._sumsq.zero_()
        self._n = 0


def mlp(sizes: list[int], activation: str, out_gain: float) -> nn.Sequential:
    """Linear layers with ``activation`` between them, orthogonally initialised (hidden gain
    √2, the last layer ``out_gain``), biases zero: PPO's usual initialisation."""
    layers: list[nn.Module] = []
    for i in range(len(sizes) - 1):
        last = i == len(sizes) - 2
        layer = nn.Linear(sizes[i], sizes[i + 1])
        nn.init.orthogonal_(layer.weight, out_gain if last else 2**0.5)
        nn.init.zeros_(layer.bias)
        layers.append(layer)
        if not last:
            layers.append(ACTIVATIONS[activation]())
    return nn.Sequential(*layers)


def with_agent_id(x: torch.Tensor, agents: int) -> torch.Tensor:
    """``x`` [..., K·rows in agent order, D] with a one-hot agent index appended: row r is agent
    ``r mod agents`` (every wolfpack batch lists a world's agents together, world after world)."""
    flat = x.reshape(-1, x.shape[-1])
    ids = torch.eye(agents, dtype=x.dtype, device=x.device).repeat(flat.shape[0] // agents, 1)
    return torch.cat([flat, ids], dim=1).reshape(*x.shape[:-1], x.shape[-1] + agents)


class GaussianActor(nn.Module):
    """What every actor shares: ``body`` maps the network's inputs (:meth:`inputs` of the
    normalised observation) to the mean of a Gaussian over the two action entries, whose log
    standard deviation ``log_std`` is a free parameter; ``norm`` normalises raw observations.
    Subclasses build the three."""

    norm: nn.Module
    body: nn.Module
    log_std: nn.Parameter
    obs_dim: int | None

    def accepts(self, dim: int) -> bool:
        """Whether observations of ``dim`` entries fit: the size it was built for."""
        return dim == self.obs_dim

    def inputs(self, normed_obs: torch.Tensor) -> torch.Tensor:
        """The network's input for already normalised observations [..., D]."""
        return normed_obs

    def rollout_inputs(self, normed_obs: torch.Tensor) -> torch.Tensor:
        """The network's inputs for a whole rollout's normalised observations [..., D], from
        which an update gathers its minibatches: :meth:`inputs` (an actor may also leave out
        entries that no observation of the rollout uses)."""
        return self.inputs(normed_obs)

    def mean(self, normed_obs: torch.Tensor) -> torch.Tensor:
        """The Gaussian's mean for already normalised observations [..., D]."""
        return self.body(self.inputs(normed_obs))

    @torch.no_grad()
    def deterministic(self, obs: torch.Tensor) -> torch.Tensor:
        """The deterministic action for raw observation rows [n, D]: the clipped mean."""
        return self.mean(self.norm(obs)).clamp(-1.0, 1.0)

    def log_prob(self, mean: torch.Tensor, actions: torch.Tensor) -> torch.Tensor:
        """log π(a) summed over the two entries."""
        z = (actions - mean) * torch.exp(-self.log_std)
        return -(0.5 * z * z + self.log_std + 0.5 * LOG_2PI).sum(-1)

    def entropy(self) -> torch.Tensor:
        return (self.log_std + 0.5 * (1.0 + LOG_2PI)).sum()


class Actor(GaussianActor):
    """The policy of one side over the flat observation: normalised observation (⊕ one-hot
    agent id) → an MLP → the Gaussian's mean."""

    def __init__(self, obs_dim: int, agents: int, hidden: list[int], activation: str, log_std_init: float, agent_id: bool, norm_obs: bool) -> None:
        super().__init__()
        self.obs_dim, self.agents, self.agent_id = obs_dim, agents, agent_id
        self.norm = RunningNorm(obs_dim, enabled=norm_obs)
        self.body = mlp([obs_dim + (agents if agent_id else 0), *hidden, 2], activation, 0.01)
        self.log_std = nn.Parameter(torch.full((2,), float(log_std_init)))

    def inputs(self, normed_obs: torch.Tensor) -> torch.Tensor:
        """The network's input for already normalised observations [..., D]."""
        return with_agent_id(normed_obs, self.agents) if self.agent_id else normed_obs


class Critic(nn.Module):
    """The value function of one side. IPPO: the agent's own normalised observation. MAPPO
    (centralised): the world's normalised global state (``BatchEnv.state()``) followed by the
    agent's own observation, MAPPO's agent-specific global state (Yu et al., 2022): one critic
    for every agent of the side that still tells them apart, as their rewards differ.

    The first layer's input is [state, observation (⊕ one-hot agent id)], but it is applied as
    ``W_state · state + W_obs · observation``: the state is the same for every agent of a world,
    so :meth:`value` projects it once per world and adds it to each agent's row (the state is
    98 of the wolves' 151 inputs: a fifth of the work in that layer)."""

    def __init__(self, obs_dim: int, state_dim: int, agents: int, hidden: list[int], activation: str, agent_id: bool, norm_obs: bool) -> None:
        super().__init__()
        self.agents, self.agent_id, self.state_dim = agents, agent_id, state_dim
        self.state_norm = RunningNorm(state_dim, enabled=norm_obs) if state_dim else None
        self.body = mlp([state_dim + obs_dim + (agents if agent_id else 0), *hidden, 1], activation, 1.0)

    def agent_inputs(self, normed_obs: torch.Tensor) -> torch.Tensor:
        """The per-agent part of the input for normalised observations [..., K, D]."""
        return with_agent_id(normed_obs, self.agents) if self.agent_id else normed_obs

    def value(self, agent_inputs: torch.Tensor, normed_state: torch.Tensor | None) -> torch.Tensor:
        """Values [..., K] of per-agent inputs [..., K, D'] (:meth:`agent_inputs`) in worlds of
        normalised states [..., S] (MAPPO; None for IPPO)."""
        first, rest = self.body[0], self.body[1:]
        if normed_state is None:
            h = first(agent_inputs)
        else:
            s = self.state_dim
            h = nn.functional.linear(agent_inputs, first.weight[:, s:], first.bias)
            h = h + nn.functional.linear(normed_state, first.weight[:, :s]).unsqueeze(-2)
        return rest(h).squeeze(-1)
