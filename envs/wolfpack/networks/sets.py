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

from wolfpack.networks import POOLS
from wolfpack.networks.mlp import Actor, GaussianActor, RunningNorm, mlp

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


class _EncodeMeanMax(torch.autograd.Function):
    """The masked mean and maximum over rows of ``relu(rows @ weightᵀ)`` (≥ 0, and padding
    rows 0, as :func:`row_encoder` makes them: the masked maximum is the plain maximum), with a
    hand-written backward.

    Why: the rows × width embedding is the update's largest tensor, and on the CPU every
    elementwise pass over it costs about as much as the encoder's matrix product. Autograd's
    backward of ``relu``, ``sum`` and ``amax`` builds it six times over (``amax``'s backward
    alone, with its boolean masks and tie counting, was half of a minibatch's time). Here the
    forward keeps the embedding and its row maxima, and the backward writes the embedding's
    gradient in five float passes, then one matrix product for the weight's. On the 2-core VM
    this and :func:`occupied_slots` took a PPO update of the wolves' default recipe on hunt-v1
    from 2.2 to 1.55 s (``benchmarks/set_network.py``).

    At a tie for a row maximum every tied row gets the maximum's whole gradient (autograd's
    ``amax`` shares it out): ties among positive embeddings need two rows with the same
    projection, and ties at 0 (all rows inactive in a channel) carry no gradient through the
    ReLU either way."""

    @staticmethod
    def forward(ctx, rows: torch.Tensor, weight: torch.Tensor, count: torch.Tensor) -> torch.Tensor:  # type: ignore[override]
        h = torch.matmul(rows, weight.t()).clamp_min_(0.0)  # [B, R, W]
        top = h.amax(1, keepdim=True)  # [B, 1, W]
        # The sum row by row, in slot order: adding a padding row's exact zero then changes
        # nothing, so the sum is the same bits whichever padding slots occupied_slots dropped
        # (torch's sum over a dimension adds in a tree whose shape depends on its length).
        total = h[:, 0].clone()
        for r in range(1, h.shape[1]):
            total.add_(h[:, r])
        ctx.save_for_backward(rows, weight, count, h, top)
        return torch.cat([total.div_(count), top.squeeze(1)], -1)

    @staticmethod
    def backward(ctx, grad: torch.Tensor) -> tuple[torch.Tensor | None, torch.Tensor | None, None]:  # type: ignore[override]
        rows, weight, count, h, top = ctx.saved_tensors
        width = weight.shape[0]
        g_mean = (grad[:, :width] / count).unsqueeze(1)  # [B, 1, W]
        g_max = grad[:, width:].unsqueeze(1)
        # d/dh of the pooled output, through the ReLU: (g_max·[h = top] + g_mean)·[h > 0].
        g_h = torch.eq(h, top, out=torch.empty_like(h)).mul_(g_max).add_(g_mean)
        g_h.mul_(torch.sign(h))  # sign(h) is [h > 0] for h ≥ 0, as a float pass
        flat = g_h.reshape(-1, width)
        g_weight = flat.t().mm(rows.reshape(-1, rows.shape[-1])) if ctx.needs_input_grad[1] else None
        g_rows = g_h.matmul(weight) if ctx.needs_input_grad[0] else None
        return g_rows, g_weight, None


def occupied_slots(rows: torch.Tensor) -> torch.Tensor:
    """Rows [B, R, F] (field 0 the mask) without the slots that are padding in every row of the
    batch, as a contiguous [B, R', F] (R' ≥ 1).

    Why: capacities are set for the largest world a model may meet, so most slots of a batch of
    one task are padding everywhere (hunt-v1's wolves: 12 of 18 set slots ever hold a row, 5 in
    an open arena), and the set encoder's cost is per slot. Dropping them changes no value: a
    padding row encodes to 0, which adds nothing to the sum and is never above the maximum."""
    occupied = rows[:, :, 0].gt(0.5).any(0)
    if bool(occupied.all()):
        return rows.contiguous()
    slots = occupied.nonzero().squeeze(1)
    return rows.index_select(1, slots if slots.numel() else slots.new_zeros(1))


def encode_mean_max(rows: torch.Tensor, encoder: nn.Linear) -> torch.Tensor:
    """Rows [B, R, F] (field 0 the mask) through ``encoder`` (a :func:`row_encoder`) and a ReLU,
    pooled by their masked mean and maximum: [B, 2W]. Each observation's result is the same
    bits whatever the other observations of the batch (:func:`occupied_slots` and the sum in
    slot order)."""
    count = rows[:, :, 0].sum(1, keepdim=True).clamp_(min=1.0)
    return _EncodeMeanMax.apply(occupied_slots(rows), encoder.weight, count)


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
        own = torch.relu(self.own(own_in))
        if self.pool == "attention":
            e = torch.relu(self.encode(rows))  # [B, R, W]; padding rows 0 (row_encoder)
            pooled = self._attend(own, e, rows[:, :, :1])
        else:
            pooled = encode_mean_max(rows, self.encode)
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

    def without_empty_slots(self, x: torch.Tensor) -> torch.Tensor:
        """Observations [..., D] without the set's slots that are padding in every one of them
        (:func:`occupied_slots`, for a whole rollout at once): the same values for the
        networks, in fewer entries to gather and encode."""
        end = x.shape[-1] - self.rows * self.row_size
        slots = (end - self.self_dim) // self.row_size
        occupied = x[..., self.self_dim : end : self.row_size].gt(0.5).reshape(-1, slots).any(0)
        if bool(occupied.all()):
            return x
        occupied[0] |= not bool(occupied.any())  # one slot at least, as occupied_slots keeps
        # Copied as runs of neighbouring entries (the own features and walls, each run of
        # occupied slots): one copy pass, where a gather by entry index took four times as long.
        runs, start = [], 0
        for slot, used in enumerate(occupied.tolist()):
            lo = self.self_dim + slot * self.row_size
            if not used:
                if lo > start:
                    runs.append(x[..., start:lo])
                start = lo + self.row_size
        runs.append(x[..., start:])
        return torch.cat(runs, -1)

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

    def rollout_inputs(self, normed_obs: torch.Tensor) -> torch.Tensor:
        """The rollout's observations without the row slots that none of them uses."""
        return self.body.walls.without_empty_slots(normed_obs)

    def accepts(self, dim: int) -> bool:
        """Whether observations of ``dim`` entries fit: the same own features and whole rows."""
        return dim > self.self_dim and (dim - self.self_dim) % self.row_size == 0


class EntityCritic(nn.Module):
    """The value function over entity observations, with the same ``value(agent_inputs,
    normed_state)`` interface as :class:`wolfpack.networks.mlp.Critic`.

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
        pooled = torch.cat([encode_mean_max(rows, self.state_rows), flat[:, -1:]], -1)
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
    ``kind``) the flat :class:`wolfpack.networks.mlp.Actor`."""
    args = {k: v for k, v in arch.items() if k != "kind"}
    return EntityActor(**args) if arch.get("kind") == "entities" else Actor(**args)
