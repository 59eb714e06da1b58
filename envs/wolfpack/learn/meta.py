"""The meta-solvers of the league: the mixture of each population that the other side's next
best response trains against. ``nash`` (the default): a Nash equilibrium of the empirical game
between the two populations; ``uniform``: every member alike (fictitious play), kept to measure
the choice against.

Pursuit–evasion between one pack and one escaper is a two-player zero-sum game (what the wolves
capture the targets lose), so its Nash equilibria are its minimax mixtures, and a linear program
finds them exactly (scipy's HiGHS): the wolves' mixture maximises the capture rate the worst
target member allows, the targets' mixture minimises the capture rate the best wolf member
gets. Against the alternatives: a uniform mixture (fictitious play) keeps weight on members
that are beaten by everything later; prioritised fictitious self-play weighs by a heuristic of
win rates and has no equilibrium to converge to. With a Nash mixture, the best response of each
side measures that mixture's exploitability directly, which is what the league logs.
"""

from __future__ import annotations

import numpy as np

#: The meta-solvers a league can use (:func:`mixtures`).
META_SOLVERS = ("nash", "uniform")


def mixtures(payoff: np.ndarray, solver: str) -> tuple[np.ndarray, np.ndarray, float]:
    """Each side's mixture over its population for the zero-sum game ``payoff`` [wolves,
    targets] (the wolves maximise): (wolves' mixture, targets' mixture, the payoff of the one
    against the other). ``nash``: the minimax mixtures (:func:`nash`); ``uniform``: every
    member alike."""
    if solver == "nash":
        return nash(payoff)
    if solver == "uniform":
        m = np.asarray(payoff, dtype=float)
        x, y = np.full(m.shape[0], 1.0 / m.shape[0]), np.full(m.shape[1], 1.0 / m.shape[1])
        return x, y, float(x @ m @ y)
    raise ValueError(f"meta-solver {solver!r}: one of {', '.join(META_SOLVERS)}")


def nash(payoff: np.ndarray) -> tuple[np.ndarray, np.ndarray, float]:
    """The minimax mixtures of the zero-sum matrix game ``payoff`` [rows, columns] (the row
    player maximises, the column player minimises): (row mixture, column mixture, value)."""
    from scipy.optimize import linprog

    m = np.asarray(payoff, dtype=float)
    if m.ndim != 2 or not m.size or not np.isfinite(m).all():
        raise ValueError(f"the payoff matrix must be a finite, non-empty matrix, got shape {m.shape}")
    rows, cols = m.shape
    # Row player: maximise v subject to x·M[:, j] ≥ v for every column, Σx = 1, x ≥ 0.
    row = linprog(
        c=np.r_[np.zeros(rows), -1.0],
        A_ub=np.c_[-m.T, np.ones(cols)],
        b_ub=np.zeros(cols),
        A_eq=np.r_[np.ones(rows), 0.0][None],
        b_eq=[1.0],
        bounds=[(0, None)] * rows + [(None, None)],
        method="highs",
    )
    # Column player: minimise u subject to M[i, :]·y ≤ u for every row, Σy = 1, y ≥ 0.
    col = linprog(
        c=np.r_[np.zeros(cols), 1.0],
        A_ub=np.c_[m, -np.ones(rows)],
        b_ub=np.zeros(rows),
        A_eq=np.r_[np.ones(cols), 0.0][None],
        b_eq=[1.0],
        bounds=[(0, None)] * cols + [(None, None)],
        method="highs",
    )
    if not (row.success and col.success):
        raise RuntimeError(f"the meta-solver failed: {row.message if not row.success else col.message}")
    x, y = _clean(row.x[:rows]), _clean(col.x[:cols])
    return x, y, float(x @ m @ y)


def _clean(p: np.ndarray) -> np.ndarray:
    """A mixture without the solver's round-off: no negative or tiny weights, summing to 1."""
    p = np.where(p < 1e-9, 0.0, p)
    return p / p.sum()
