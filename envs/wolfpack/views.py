"""What the training-stack views of the batch (PettingZoo, Gymnasium, SB3's VecEnv, TorchRL)
share: each agent's info dict from a step's outputs, one observation layout for both sides
(``shared_space=True``), and one agent's action checked."""

from __future__ import annotations

from typing import Any, Mapping

import numpy as np

from wolfpack._checks import check_flag
from wolfpack.batch import OUTCOMES, first_cornered_step
from wolfpack.sides import check_learners


class SharedObservation:
    """One observation layout for every agent (``shared_space=True``, ``learners="both"``), so
    that one shared policy can drive both sides: D = 2 + (N+M) + max(Dw, Dt) entries —

    ==================  ==========================================================
    entry               meaning
    ==================  ==========================================================
    0                   1 for a wolf, else 0 (the side flag)
    1                   1 for a target, else 0
    2 … 2+N+M−1         one-hot agent index: wolves 0..N−1, then targets N..N+M−1
    2+N+M …             the agent's own observation (as without shared_space),
                        zero-padded to max(Dw, Dt)
    ==================  ==========================================================
    """

    def __init__(self, n: int, m: int, dw: int, dt: int) -> None:
        self.n, self.m, self.dw, self.dt = n, m, dw, dt
        self.head = 2 + n + m
        self.dim = self.head + max(dw, dt)
        self._template = np.zeros((n + m, self.dim), np.float32)
        self._template[:n, 0] = 1.0
        self._template[n:, 1] = 1.0
        self._template[np.arange(n + m), 2 + np.arange(n + m)] = 1.0

    def pack(self, obs_wolves: np.ndarray, obs_targets: np.ndarray) -> np.ndarray:
        """[E, N, Dw] and [E, M, Dt] → [E, N+M, D] (a fresh array)."""
        out = np.repeat(self._template[None], obs_wolves.shape[0], axis=0)
        out[:, : self.n, self.head : self.head + self.dw] = obs_wolves
        out[:, self.n :, self.head : self.head + self.dt] = obs_targets
        return out


def check_shared_space(shared_space: Any, learners: str) -> bool:
    shared_space = check_flag(shared_space, "shared_space")
    if shared_space and check_learners(learners) != "both":
        raise ValueError(f"shared_space=True needs learners='both' (one policy for both sides), got learners={learners!r}")
    return shared_space


def check_action(x: Any, who: str) -> np.ndarray:
    """One agent's action as an array of shape (2,) and a floating dtype; ValueError naming
    ``who`` otherwise. (Non-finite values are caught by the core, which names the agent.)"""
    a = np.asarray(x)
    if a.dtype.kind != "f":
        raise ValueError(f"{who}: must be floating point, got dtype {a.dtype}")
    if a.shape != (2,):
        raise ValueError(f"{who}: expected shape (2,), got {a.shape}")
    return a


_SUCCESS_CODES = (OUTCOMES.index("captured"), OUTCOMES.index("cornered"))


def agent_infos(out: Mapping[str, np.ndarray], n_wolves: int, lo: int, hi: int) -> list[dict]:
    """The info dicts of agents ``lo .. hi`` (wolves 0..N-1, then targets) of every world of a
    :meth:`BatchEnv.step` output, world-major. Every value is a number of one type for the
    whole episode, so that libraries that stack infos (Gymnasium's vector envs, TorchRL) can:
    ``outcome`` (int code, :data:`OUTCOMES`), ``capture_step`` (int; a wolf: the step its
    episode succeeded, a target: its own capture step; −1 until then), ``cornered_step`` (int:
    the first step at which a target of the world was cornered, −1 if none ever was; the same
    for every agent), ``energy`` (float, J), ``collisions`` (int, steps in contact),
    ``distance`` (float, m; −1 for a wolf once no target is left)."""
    # Plain Python lists first (.tolist()): indexing numpy scalars one by one costs several
    # times more than the dicts themselves at 64 worlds x 5 wolves.
    codes = out["outcome"].tolist()
    energy = out["energy"][:, lo:hi].tolist()
    collisions = out["collisions"][:, lo:hi].tolist()
    distance = out["distance"][:, lo:hi].tolist()
    caps = out["capture_step"].tolist()
    corners = out["cornered_step"].tolist()
    infos = []
    for e, code in enumerate(codes):
        infos.extend(_world_infos(code, caps[e], corners[e], energy[e], collisions[e], distance[e], n_wolves, lo, hi))
    return infos


def world_agent_infos(out: Mapping[str, np.ndarray], e: int, n_wolves: int, lo: int, hi: int) -> list[dict]:
    """:func:`agent_infos` of world ``e`` alone — the same dicts — reading only that world's
    rows. A VecEnv builds infos only for the few worlds that ended in a step, and converting
    every world's rows for them cost more than the rest of its step's Python side."""
    return _world_infos(
        int(out["outcome"][e]),
        out["capture_step"][e].tolist(),
        out["cornered_step"][e].tolist(),
        out["energy"][e, lo:hi].tolist(),
        out["collisions"][e, lo:hi].tolist(),
        out["distance"][e, lo:hi].tolist(),
        n_wolves,
        lo,
        hi,
    )


def _world_infos(code: int, caps: list, corners: list, energy: list, collisions: list, distance: list, n_wolves: int, lo: int, hi: int) -> list[dict]:
    """The info dicts of agents ``lo .. hi`` of one world from its rows as Python lists:
    ``caps`` and ``corners`` per target, the rest per agent in the range (the definitions:
    :func:`agent_infos`)."""
    world_cap = max(caps) if code in _SUCCESS_CODES else -1
    wolves_in_range = max(0, min(hi, n_wolves) - lo)
    targets_in_range = slice(max(lo, n_wolves) - n_wolves, max(hi - n_wolves, 0))
    cap = [world_cap] * wolves_in_range + caps[targets_in_range]
    cornered = first_cornered_step(corners)
    return [{"outcome": code, "capture_step": c, "cornered_step": cornered, "energy": en, "collisions": co, "distance": d} for c, en, co, d in zip(cap, energy, collisions, distance)]
