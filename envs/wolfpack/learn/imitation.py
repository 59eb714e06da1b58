"""Imitation of the analytic laws as a warm start (``wolfpack train --imitate-rounds R`` or
``--imitate MINUTES``).

Behaviour cloning with DAgger into the trainer's own actor: round 0 drives the worlds with the
learning side's scripted law (params ``policies.<side>``, queried through
``BatchEnv.expert_actions()``: the action the law would take in the current state, in the
learner's action space); round r ≥ 1 drives each agent with the law with probability 0.5^r and
with the current policy's mean otherwise, so that the policy learns what the law would do in the
states the policy itself reaches. Every round adds the law's labels to a data set (the most
recent ``capacity`` samples per side) and fits the actor's mean to them (mean squared error,
Adam). The observation normaliser is the actor's own, so the clone and the PPO that follows it
read observations alike; the log standard deviation keeps its initial value, which is the
exploration PPO starts from. Its minutes are part of the run's budget and of its training time,
so every time-to-skill figure includes them.

A budget in rounds is deterministic (a fixed seed and thread counts give the same clone on any
machine, loaded or not); a budget in minutes gives a machine that is busier fewer rounds. Given
both, imitation stops at whichever comes first.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from wolfpack.sides import SIDES

#: Samples kept per side (the newest), and the fit's settings: chosen so that a round's fit
#: takes about as long as its rollout on 2 cores.
CAPACITY = 1_000_000
#: At most this many bytes of observations per side, too: a million entity observations (421
#: entries each) would take 1.7 GB, longer to allocate than a short warm start lasts.
CAPACITY_BYTES = 512 << 20
LEARNING_RATE = 1e-3
MINIBATCH = 4096
FIT_PASSES = 2
MIN_FIT_STEPS = 50


class Dataset:
    """A ring of the newest ``capacity`` (raw observation, agent index, expert action) triples."""

    def __init__(self, obs_dim: int, agents: int, capacity: int) -> None:
        self.obs = torch.zeros(capacity, obs_dim)
        self.ids = torch.zeros(capacity, dtype=torch.long)
        self.actions = torch.zeros(capacity, 2)
        self.agents, self.capacity, self.size, self.head = agents, capacity, 0, 0

    def add(self, obs: np.ndarray, actions: np.ndarray) -> None:
        """One step's observations [E, K, D] and the law's actions [E, K, 2]."""
        o = torch.from_numpy(np.ascontiguousarray(obs, dtype=np.float32)).reshape(-1, self.obs.shape[1])
        a = torch.from_numpy(np.clip(actions, -1.0, 1.0).astype(np.float32)).reshape(-1, 2)
        n = o.shape[0]
        rows = (self.head + torch.arange(n)) % self.capacity
        self.obs[rows], self.actions[rows] = o, a
        self.ids[rows] = torch.arange(n) % self.agents
        self.head = (self.head + n) % self.capacity
        self.size = min(self.capacity, self.size + n)


def imitate(trainer, minutes: float | None, clock, max_rounds: int | None = None) -> list[dict]:
    """Runs DAgger rounds on ``trainer``'s batches (one per task in multi-task training, each
    with its task's law) for every learning side until ``minutes`` have passed on ``clock`` (a
    function giving the run's training seconds so far), or after ``max_rounds``; at least one
    of the two is given. Returns one record per round: β, samples, loss, seconds."""
    if minutes is None and max_rounds is None:
        raise ValueError("imitation needs a budget: minutes and/or rounds")
    learners, gen = trainer.learners, trainer.generator
    deadline = math.inf if minutes is None else clock() + 60.0 * minutes
    data = {side: Dataset(learner.actor.obs_dim, learner.agents, min(CAPACITY, CAPACITY_BYTES // (4 * learner.actor.obs_dim))) for side, learner in learners.items()}
    optimisers = {side: torch.optim.Adam(learner.actor.body.parameters(), lr=LEARNING_RATE) for side, learner in learners.items()}
    rng = np.random.default_rng(trainer.spec.seed)
    outs = [env.reset() for env in trainer.envs]
    history = []
    r = 0
    while clock() < deadline and (max_rounds is None or r < max_rounds):
        beta = 1.0 if r == 0 else 0.5**r
        for _ in range(trainer.n_steps):
            for g, env in enumerate(trainer.envs):
                outs[g] = _dagger_step(env, outs[g], learners, data, beta, rng)
        losses = {}
        for side, learner in learners.items():
            learner.actor.norm.commit()
            losses[side] = _fit(learner.actor, data[side], optimisers[side], gen, deadline, clock)
        history.append({"round": r, "beta": beta, "samples": {s: d.size for s, d in data.items()}, "loss": losses, "train_s": clock()})
        r += 1
    return history


def _dagger_step(env, out: dict, learners: dict, data: dict, beta: float, rng: np.random.Generator) -> dict:
    """One step of a DAgger round on ``env`` from its outputs ``out``: the law's labels into
    ``data``, each agent driven by the law with probability ``beta``, else by the policy's mean.
    Returns the step's outputs."""
    experts = dict(zip(SIDES, env.expert_actions()))
    actions = {}
    for side, learner in learners.items():
        obs = out[f"obs_{side}"]
        expert = experts[side]
        data[side].add(obs, expert)
        learner.actor.norm.accumulate(torch.from_numpy(obs))
        if beta >= 1.0:
            actions[side] = np.ascontiguousarray(expert, dtype=np.float32)
        else:
            own = learner.policy()(obs)
            use_expert = rng.random(expert.shape[:-1]) < beta
            actions[side] = np.ascontiguousarray(np.where(use_expert[..., None], expert, own), dtype=np.float32)
    return env.step(actions.get("wolves"), actions.get("targets"))


def _fit(actor, data: Dataset, optimiser, gen: torch.Generator, deadline: float, clock) -> float:
    """The actor's mean fitted to the law's actions (mean squared error) by random minibatches:
    FIT_PASSES passes' worth of them over the data set, and at least MIN_FIT_STEPS (stopping
    at the deadline). Returns the mean loss of the last pass's worth of steps."""
    n = data.size
    device = next(actor.parameters()).device
    eye = torch.eye(actor.agents) if actor.agent_id else None
    batch = min(MINIBATCH, n)
    steps = max(MIN_FIT_STEPS, FIT_PASSES * n // batch)
    recent = max(1, steps // FIT_PASSES)
    losses = []
    for _ in range(steps):
        idx = torch.randint(n, (batch,), generator=gen, device=gen.device).cpu()
        x = actor.norm(data.obs[idx])
        if actor.agent_id:  # rows are drawn at random: the index travels with each sample
            x = torch.cat([x, eye[data.ids[idx]]], dim=1)
        mean = actor.body(x.to(device))
        loss = ((mean - data.actions[idx].to(device)) ** 2).mean()
        optimiser.zero_grad(set_to_none=True)
        loss.backward()
        optimiser.step()
        losses.append(loss.item())
        if clock() >= deadline:
            break
    return float(np.mean(losses[-recent:]))
