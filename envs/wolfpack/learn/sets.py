"""Networks over entity observations (``env.observation: entities``): one model for any team
size, target count and obstacle count within the capacities it is played with.

An entity observation is the agent's own features followed by rows of ``row_size`` fields
(docs/interface.md, "Entity observations"); field 0 of a row is its mask (1 present, 0
padding) and fields 1–4 its type, one-hot. The networks here never depend on the number of
rows: each row goes through one shared encoder, and the rows are pooled over the mask.

Two poolings, chosen by the recipe's ``pool``:

- ``attention``: multi-head attention pooling with the agent's own embedding as the query
  (the agent decides which entities matter to it), over the row embeddings as keys and values.
  The keys are the row embeddings themselves and the values too (no key or value projection):
  a projection of every row costs rows × width² multiply-adds per agent, more than the rest
  of the network together, while the query's projection is paid once per agent.
- ``mean_max``: the masked mean and the masked maximum of the row embeddings, concatenated
  (Deep Sets with two symmetric poolings).

The four wall rows close every observation in a fixed order whatever the capacities, so the
networks read them as own features (each wall's x, y and distance: ``wall_rows``), not as set
elements: the set encoder's per-row work is most of an update's time, and the walls need no
permutation invariance.

Normalisation is per field, not per slot (:class:`EntityNorm`): the statistics of a row field
are gathered over present rows only and shared by every row, so that they do not depend on
which slot a row lands in or on how many slots there are.
"""

from __future__ import annotations

import torch
from torch import nn

from wolfpack.learn.nets import Actor, GaussianActor, RunningNorm, mlp
from wolfpack.learn.recipes import POOLS

#: Fields 0..MASKED-1 of a row (the mask and the type) pass through normalisation unchanged.
MASKED = 5


class EntityNorm(nn.Module):
    """Running normalisation of entity observations [..., D]: the own features by
    :class:`RunningNorm`, the row fields from :data:`MASKED` on by one shared
    :class:`RunningNorm` over present rows; padding rows stay all zero. The same interface as
    :class:`RunningNorm` (``forward``, ``normalise_``, ``accumulate``, ``commit``)."""

    def __init__(self, self_dim: int, row_size: int, enabled: bool = True) -> None:
        super().__init__()
        self.self_dim, self.row_size, self.enabled = self_dim, row_size, enabled
        self.own = RunningNorm(self_dim, enabled=enabled)
        self.rows = RunningNorm(row_size - MASKED, enabled=enabled)

    def _split(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Views of ``x``'s own features and rows (``view``, never a copy: :meth:`normalise_`
        writes through them)."""
        rows = x[..., self.self_dim :]
        return x[..., : self.self_dim], rows.view(*x.shape[:-1], rows.shape[-1] // self.row_size, self.row_size)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.normalise_(x.clone()) if self.enabled else x

    def normalise_(self, x: torch.Tensor) -> torch.Tensor:
        if not self.enabled:
            return x
        own, rows = self._split(x)
        self.own.normalise_(own)
        fields = rows[..., MASKED:]
        self.rows.normalise_(fields)
        fields.mul_(rows[..., :1])  # padding rows back to zero
        return x

    def accumulate(self, x: torch.Tensor) -> None:
        if not self.enabled:
            return
        own, rows = self._split(x)
        self.own.accumulate(own)
        flat = rows.reshape(-1, self.row_size)
        self.rows.accumulate(flat[flat[:, 0] > 0.5, MASKED:])

    @torch.no_grad()
    def commit(self) -> None:
        self.own.commit()
        self.rows.commit()


def row_encoder(row_size: int, width: int) -> nn.Linear:
    """The shared row encoder's linear layer, without a bias: a row's ``present`` entry (1 for
    every row, 0 for padding) plays the bias's part, so a padding row (all zeros) encodes to
    exactly 0 and the pooling needs no mask multiply (one pass fewer over the rows × width
    tensor, forward and backward)."""
    layer = nn.Linear(row_size, width, bias=False)
    nn.init.orthogonal_(layer.weight, 2**0.5)
    return layer


def mean_max(e: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """The masked mean and maximum over rows of embeddings ``e`` [B, R, W] (≥ 0, padding rows
    0, as :func:`row_encoder` and a ReLU make them) with ``mask`` [B, R, 1]: [B, 2W]."""
    return torch.cat([e.sum(1) / mask.sum(1).clamp(min=1.0), e.amax(1)], -1)


class SetNet(nn.Module):
    """Entity observation [..., D] (normalised) → [..., out]: own features and pooled rows,
    then an MLP of widths ``hidden``. ``out_gain`` is the last layer's initial gain.

    The row encoder is one linear layer and a ReLU whatever the recipe's activation: its
    output is rows × width per agent, by far the largest tensor of an update, and on the CPU
    its elementwise passes cost as much as its matrix product (on the 2-core VM a minibatch of
    8,192 took 13–15 % less time with ReLU than with tanh). With ReLU every embedding is ≥ 0 and
    a padding row's is 0 (:func:`row_encoder`), so the masked maximum is the plain maximum."""

    def __init__(self, self_dim: int, row_size: int, width: int, hidden: list[int], out: int, activation: str, pool: str, heads: int, out_gain: float, wall_rows: int = 0) -> None:
        super().__init__()
        if pool not in POOLS:
            raise ValueError(f"pool must be one of {', '.join(POOLS)}, got {pool!r}")
        if width % heads:
            raise ValueError(f"entity_width {width} must be a multiple of the {heads} attention heads")
        self.self_dim, self.row_size, self.width, self.pool, self.heads = self_dim, row_size, width, pool, heads
        self.walls = Walls(self_dim, row_size, wall_rows)
        self.own = mlp([self.walls.own_dim, width], "relu", 2**0.5)
        self.encode = row_encoder(row_size, width)
        pooled = width if pool == "attention" else 2 * width
        if pool == "attention":
            self.query = nn.Linear(width, width)
            nn.init.orthogonal_(self.query.weight, 1.0)
            nn.init.zeros_(self.query.bias)
        self.head = mlp([width + pooled, *hidden, out], activation, out_gain)

    def embed(self, x: torch.Tensor) -> torch.Tensor:
        """The features the head reads, [..., width + pooled]."""
        lead = x.shape[:-1]
        x = x.reshape(-1, x.shape[-1])
        own_in, rows = self.walls.split(x)  # [B, own], [B, R, F]
        mask = rows[:, :, :1]  # [B, R, 1]: 1 present, 0 padding
        own = torch.relu(self.own(own_in))
        e = torch.relu(self.encode(rows))  # [B, R, W]; padding rows 0 (row_encoder)
        if self.pool == "attention":
            pooled = self._attend(own, e, mask)
        else:
            pooled = mean_max(e, mask)
        return torch.cat([own, pooled], -1).reshape(*lead, -1)

    def _attend(self, own: torch.Tensor, e: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
        b, r = e.shape[0], e.shape[1]
        h, d = self.heads, self.width // self.heads
        q = self.query(own).reshape(b, h, d, 1)
        keys = e.reshape(b, r, h, d).transpose(1, 2)  # [B, H, R, d]
        scores = torch.matmul(keys, q).squeeze(-1) / d**0.5  # [B, H, R]
        # A large negative, not -inf: a world with no present row (never the case, the walls
        # are always there) then averages its zero rows instead of dividing by zero.
        scores = scores.masked_fill(mask.reshape(b, 1, r) < 0.5, -1e9)
        weights = torch.softmax(scores, dim=-1).unsqueeze(-2)  # [B, H, 1, R]
        return torch.matmul(weights, keys).reshape(b, self.width)

    def forward(self, x: torch.Tensor) -> torch.Tensor:
        return self.head(self.embed(x))


class Walls:
    """Reads the last ``rows`` rows of an entity observation (the walls) as own features: their
    x, y and distance after the agent's own features. ``rows`` = 0 reads every row as a set
    element."""

    FIELDS = slice(5, 8)  # x, y, distance

    def __init__(self, self_dim: int, row_size: int, rows: int) -> None:
        self.self_dim, self.row_size, self.rows = self_dim, row_size, rows
        self.own_dim = self_dim + rows * (self.FIELDS.stop - self.FIELDS.start)

    def own(self, x: torch.Tensor) -> torch.Tensor:
        """[..., D] → the own features [..., own_dim]."""
        if not self.rows:
            return x[..., : self.self_dim]
        tail = x[..., x.shape[-1] - self.rows * self.row_size :].reshape(*x.shape[:-1], self.rows, self.row_size)
        return torch.cat([x[..., : self.self_dim], tail[..., self.FIELDS].reshape(*x.shape[:-1], -1)], -1)

    def split(self, x: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """[B, D] → (own features [B, own_dim], the set's rows [B, R, F])."""
        rows = x[:, self.self_dim : x.shape[-1] - self.rows * self.row_size]
        return self.own(x), rows.reshape(x.shape[0], -1, self.row_size)


class EntityActor(GaussianActor):
    """The policy of one side over entity observations: a :class:`SetNet` as its body and an
    :class:`EntityNorm`. It has no agent id: one model plays any team size."""

    agent_id = False

    def __init__(
        self,
        self_dim: int,
        row_size: int,
        hidden: list[int],
        entity_width: int,
        pool: str,
        heads: int,
        activation: str,
        log_std_init: float,
        norm_obs: bool,
        obs_dim: int | None = None,
        agents: int | None = None,
        wall_rows: int = 0,
    ) -> None:
        super().__init__()
        self.self_dim, self.row_size, self.obs_dim, self.agents = self_dim, row_size, obs_dim, agents
        self.norm = EntityNorm(self_dim, row_size, enabled=norm_obs)
        self.body = SetNet(self_dim, row_size, entity_width, hidden, 2, activation, pool, heads, 0.01, wall_rows)
        self.log_std = nn.Parameter(torch.full((2,), float(log_std_init)))

    def accepts(self, dim: int) -> bool:
        """Whether observations of ``dim`` entries fit: the same own features and whole rows."""
        return dim > self.self_dim and (dim - self.self_dim) % self.row_size == 0


class EntityCritic(nn.Module):
    """The value function over entity observations, with the same ``value(agent_inputs,
    normed_state)`` interface as :class:`wolfpack.learn.nets.Critic`.

    IPPO: a :class:`SetNet` over the agent's own entity observation. MAPPO: the world's entity
    state (``env.state: entities``: one row per agent of :data:`wolfpack.ENTITY_STATE_FIELDS`,
    then the clock) through a shared row encoder pooled by masked mean and maximum, once per
    world, and the agent's own features (not its rows): the state already holds every agent,
    and encoding each agent's rows again for the critic would double the update's largest
    cost for what the actor's rows add to the value (the obstacles near the agent)."""

    def __init__(
        self, self_dim: int, row_size: int, state_dim: int, state_row: int, hidden: list[int], entity_width: int, pool: str, heads: int, activation: str, norm_obs: bool, wall_rows: int = 0
    ) -> None:
        super().__init__()
        self.self_dim, self.state_dim, self.state_row = self_dim, state_dim, state_row
        self.walls = Walls(self_dim, row_size, wall_rows)
        # The entity state's entries are already in [-1, 1] and its padding must stay zero.
        self.state_norm = RunningNorm(state_dim, enabled=False) if state_dim else None
        width = entity_width
        if state_dim:
            self.own = mlp([self.walls.own_dim, width], "relu", 2**0.5)
            self.state_rows = row_encoder(state_row, width)
            self.body = mlp([3 * width + 1, *hidden, 1], activation, 1.0)
        else:
            self.trunk = SetNet(self_dim, row_size, width, hidden, 1, activation, pool, heads, 1.0, wall_rows)

    def agent_inputs(self, normed_obs: torch.Tensor) -> torch.Tensor:
        return normed_obs

    def _state_features(self, s: torch.Tensor) -> torch.Tensor:
        """[..., S] → [..., 2·width + 1]: pooled agent rows and the clock."""
        lead = s.shape[:-1]
        flat = s.reshape(-1, s.shape[-1])
        rows = flat[:, :-1].reshape(flat.shape[0], -1, self.state_row)
        mask = rows[:, :, :1]
        e = torch.relu(self.state_rows(rows))
        pooled = torch.cat([mean_max(e, mask), flat[:, -1:]], -1)
        return pooled.reshape(*lead, -1)

    def value(self, agent_inputs: torch.Tensor, normed_state: torch.Tensor | None) -> torch.Tensor:
        if not self.state_dim:
            return self.trunk(agent_inputs).squeeze(-1)
        own = torch.relu(self.own(self.walls.own(agent_inputs)))  # [..., K, W]
        world = self._state_features(normed_state).unsqueeze(-2).expand(*own.shape[:-1], -1)
        return self.body(torch.cat([own, world], -1)).squeeze(-1)


def build_actor(arch: dict) -> nn.Module:
    """The actor a saved model's ``network`` entry describes: ``kind: entities`` an
    :class:`EntityActor`, anything else (models saved before entity observations have no
    ``kind``) the flat :class:`wolfpack.learn.nets.Actor`."""
    args = {k: v for k, v in arch.items() if k != "kind"}
    return EntityActor(**args) if arch.get("kind") == "entities" else Actor(**args)
