"""What a ``wolfpack train`` run trains (:class:`TrainSpec`): the one object the CLI, the
league and library callers build and :class:`wolfpack.learn.trainer.Trainer` takes; its
:meth:`~TrainSpec.identity` is what ``--resume`` checks a run folder against."""

from __future__ import annotations

from dataclasses import dataclass, field

from wolfpack.sides import SIDES


@dataclass
class TrainSpec:
    """What a run trains: ``learners`` (``wolves``, ``targets`` or ``both``), ``algo``
    (``ippo`` or ``mappo``), the validated ``params``, each learning side's ``recipes``, the
    ``opponent`` of a one-sided run (None: the params' law; it is what the held-out evaluations
    play), the ``opponent_pool`` (more than one: the other side's drivers, one drawn uniformly
    for each rollout; ``opponent`` is its first), and how it runs."""

    learners: str
    algo: str
    params: dict
    recipes: dict[str, dict]
    seed: int = 0
    opponent: str | None = None
    opponent_pool: tuple[str, ...] = ()
    timesteps: int | None = None
    time_limit_min: float | None = None
    threads: int | None = None
    torch_threads: int | None = None
    device: str = "cpu"
    eval_episodes: int = 100
    evaluations: int = 10
    imitate_min: float | None = None
    imitate_rounds: int | None = None
    command: str = ""
    extra: dict = field(default_factory=dict)
    #: Multi-task training: the groups of worlds the batch is split into, ``(label, task,
    #: params)`` each (one per task, or per task and ``--vary`` draw); a batch holds worlds of
    #: one params, so each group is a batch of its own, stepped in turn. Empty: one group of
    #: ``params``.
    groups: tuple[tuple[str, str, dict], ...] = ()
    #: The tasks of the held-out evaluations, ``(task, params)`` each; empty: ``params``.
    eval_tasks: tuple[tuple[str, dict], ...] = ()
    #: How the groups weigh in the update, one of :data:`wolfpack.learn.tasks.TASK_WEIGHTS`.
    task_weights: str = "uniform"
    #: ``{side: model folder}``: the saved models whose actors the learning sides start from
    #: (``--init``); the critics start afresh and learn alone for the first updates.
    init: dict[str, str] = field(default_factory=dict)

    @property
    def sides(self) -> tuple[str, ...]:
        return SIDES if self.learners == "both" else (self.learners,)

    def identity(self) -> dict:
        """What must match for ``--resume`` to continue a run: the sides, algorithm, opponent,
        params, recipes and seed (and the opponent pool, when there is one)."""
        identity = {"learners": self.learners, "algo": self.algo, "opponent": self.opponent, "params": self.params, "recipes": self.recipes, "seed": self.seed}
        if len(self.opponent_pool) > 1:
            identity["opponent_pool"] = list(self.opponent_pool)
        if self.groups:
            identity["groups"] = [{"label": label, "task": task, "params": params} for label, task, params in self.groups]
            identity["task_weights"] = self.task_weights
        if self.init:
            identity["init"] = dict(self.init)
        return identity
