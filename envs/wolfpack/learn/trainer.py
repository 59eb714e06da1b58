"""The training loop of ``wolfpack train``: the batch, one :class:`SideLearner` per learning
side, the budget, and when to evaluate (:mod:`~wolfpack.learn.held_out`), log
(:mod:`~wolfpack.learn.progress`) and save (:mod:`~wolfpack.learn.checkpoints`).

A run folder (``--out DIR``):

=================================  ===========================================================
``config.yaml``                    what the run is: sides, algorithm, opponent, the exact
                                   params, each side's recipe, seed, threads, device, command,
                                   versions; written first (``--resume`` checks against it)
``wolves/``, ``targets/``          the model of each learning side (``policy.pt`` +
                                   ``config.yaml``): ``opponent=DIR``, ``wolfpack.load_policy``
                                   and ``training/evaluate.py DIR`` read them
``trainer.pt``                     everything ``--resume`` needs (networks, optimisers,
                                   normalisers, random generator, counters)
``checkpoints/<agent steps>/``     the same, at the checkpoint cadence
``progress.csv``                   one row per update (columns: :data:`BASE_COLUMNS`, then per
                                   side :data:`SIDE_COLUMNS`, then the held-out evaluations)
``events.out.tfevents.*``          the same as TensorBoard scalars
``evaluations.json``               every held-out evaluation (wolfpack.evaluation.report rows)
``summary.json``                   the outcome of the run, written when it ends
=================================  ===========================================================
"""

from __future__ import annotations

import csv
import json
import math
import time
from pathlib import Path
from typing import Any, Callable, Mapping

import numpy as np
import torch
import yaml

from wolfpack.batch import ENTITY_STATE_FIELDS, OUTCOMES, BatchEnv, entity_kinds, entity_shape
from wolfpack.evaluation import TRAIN_SEED_BASE
from wolfpack.interrupt import sigint_held
from wolfpack.learn.checkpoints import TRAINER_FILE, latest_resume_state, plain, versions, write_atomic
from wolfpack.learn.held_out import HeldOut
from wolfpack.learn.ppo import SideLearner
from wolfpack.learn.progress import BASE_COLUMNS, EVAL_COLUMNS, SIDE_COLUMNS, cell, postfix, progress_bar, tensorboard
from wolfpack.learn.spec import TrainSpec
from wolfpack.models import CONFIG_FILE, POLICY_FILE, load_policy
from wolfpack.opponents import Opponent, as_opponent, opponent_side

CAPTURED, COLLISION, TIMEOUT, CORNERED = (OUTCOMES.index(k) for k in ("captured", "collision", "timeout", "cornered"))


class Trainer:
    """Runs a :class:`TrainSpec` into ``out`` (a new or empty folder, or with ``resume`` a folder
    of the same run).

    ``opponents``, for leagues: a function that draws the other side's driver (anything
    ``opponent=`` takes) for each rollout; the batch starts with the first draw and swaps in the
    next one before every later rollout without resetting any world (``set_opponent``). It
    replaces ``spec.opponent`` while training; evaluations stay against ``spec.opponent``.
    Without it, a ``spec.opponent_pool`` of more than one driver draws the same way: uniformly,
    from a generator seeded by the run's seed and the update's number (a resumed run draws as
    the uninterrupted one would)."""

    def __init__(
        self,
        spec: TrainSpec,
        out: Path,
        *,
        resume: bool = False,
        progress: bool = True,
        opponents: Callable[[], Any] | None = None,
        init_models: Mapping[str, Any] | None = None,
    ) -> None:
        self.spec, self.out, self.progress = spec, Path(out), progress
        self.device = torch.device(spec.device)
        wolves_recipe = spec.recipes[spec.sides[0]]
        self.num_envs, self.n_steps = int(wolves_recipe["num_envs"]), int(wolves_recipe["n_steps"])
        for side in spec.sides:  # the batch's keys are shared; the per-side recipes must agree
            spec.recipes[side]["num_envs"], spec.recipes[side]["n_steps"] = self.num_envs, self.n_steps
        self.generator = torch.Generator(device=self.device)
        self.generator.manual_seed(spec.seed)
        torch.manual_seed(spec.seed)  # network initialisation
        self.updates = 0
        self.agent_steps = 0
        self.train_s_before = 0.0  # training seconds of earlier invocations (resume)
        self.resumes = 0
        state = self._load_resume_state() if resume else None
        if state is not None:
            self.resumes = int(state["resumes"]) + 1
            self.updates = int(state["updates"])  # before the first draw of an opponent pool
        pool_members: list[Opponent] = []
        if opponents is None and len(spec.opponent_pool) > 1:
            opponents, pool_members = self._pool_draw()
        self.opponents = opponents
        opponent = self._opponent() if opponents is None else opponents()
        world_seed = TRAIN_SEED_BASE * (spec.seed + 1) + self.num_envs * self.resumes
        groups = spec.groups or (("", "", spec.params),)
        if self.num_envs < len(groups):
            raise ValueError(f"num_envs {self.num_envs} is below the {len(groups)} groups of worlds (one per task and --vary draw): raise it with --hp num_envs=N")
        # The worlds split as evenly as they go; group g's worlds are seeded after those of the
        # groups before it, so that no two training worlds share a seed.
        sizes = [self.num_envs // len(groups) + (1 if g < self.num_envs % len(groups) else 0) for g in range(len(groups))]
        offsets = np.cumsum([0, *sizes[:-1]]).tolist()
        # MAPPO's critic reads every world's state after every step: written by each world's
        # own task in the step (with_state) rather than by a serial pass after it.
        self.envs = [
            BatchEnv(params, num_envs=e, learners=spec.learners, seed=world_seed + offset, threads=spec.threads, opponent=opponent, with_state=spec.algo == "mappo")
            for (_, _, params), e, offset in zip(groups, sizes, offsets)
        ]
        self.env = self.envs[0]
        self.group_tasks = [task for _, task, _ in groups]
        for env in self.envs:
            for member in pool_members:  # every pool member fits these worlds, up front
                env._check_opponent_fits(member)
        # Torch's threads: one for the rollout's forward passes (E x K rows: too small to share; on
        # the 2-core VM two threads made the rollout 1.6-1.8x slower, and the batch's threads need
        # the cores then); in the update, the actor and the critic side by side on CPUs with two
        # or more threads for torch, each with half of them (SideLearner, BENCHMARKS.md "Learning").
        torch_threads = spec.torch_threads or torch.get_num_threads()
        side_by_side = self.device.type == "cpu" and torch_threads >= 2
        self._threads = {"rollout": 1 if self.device.type == "cpu" else torch_threads, "update": torch_threads // 2 if side_by_side else torch_threads, "rest": torch_threads}
        self.learners: dict[str, SideLearner] = {}
        for side in spec.sides:
            obs_dims = {env.wolf_obs_dim if side == "wolves" else env.target_obs_dim for env in self.envs}
            state_dims = {env.state_dim for env in self.envs}
            if len(obs_dims) > 1 or len(state_dims) > 1:
                what = "observation" if len(obs_dims) > 1 else "global state"
                raise ValueError(
                    f"the tasks give the {side} {what}s of different sizes ({', '.join(map(str, sorted(obs_dims if len(obs_dims) > 1 else state_dims)))}): train one model over them with entity observations (--hp network=entities)"
                )
            self.learners[side] = SideLearner(
                side,
                spec.algo,
                spec.recipes[side],
                obs_dim=obs_dims.pop(),
                state_dim=state_dims.pop(),
                groups=[(env.num_envs, env.n_wolves if side == "wolves" else env.n_targets) for env in self.envs],
                entity_shape=_entity_shape(side, self.env.params),
                device=self.device,
                generator=self.generator,
                side_by_side=side_by_side,
            )
        if state is None:
            self._start_from_models(init_models or {})
        else:
            try:
                self._restore(state)
            except (KeyError, RuntimeError, TypeError, ValueError) as e:  # another network's state
                raise ValueError(f"--resume: {self._resume_path}: does not fit this run's networks ({' '.join(str(e).split())[:200]})") from None
        self.agents_per_step = sum(env.num_envs * sum(env.n_wolves if side == "wolves" else env.n_targets for side in spec.sides) for env in self.envs)
        self.held_out = HeldOut(spec, self.out, self.group_tasks, resume)

    # --- set-up -----------------------------------------------------------------------------------

    def _opponent(self) -> Opponent | None:
        if self.spec.opponent is None:
            return None
        opp = as_opponent(self.spec.opponent)
        opponent_side(opp, self.spec.learners)  # a ValueError when it would drive a learning side
        return opp

    def _pool_draw(self) -> tuple[Callable[[], Opponent], list[Opponent]]:
        """The draw of ``spec.opponent_pool`` and its distinct members, each loaded once and
        checked against the learning side; the opponent of the rollout that makes update n + 1
        is picked with a generator seeded by (seed, n), n = ``self.updates`` at the draw."""
        pool: dict[str, Opponent] = {}
        for name in self.spec.opponent_pool:
            if name not in pool:
                pool[name] = as_opponent(name)
                opponent_side(pool[name], self.spec.learners)
        drivers = [pool[name] for name in self.spec.opponent_pool]  # a repeated one weighs more

        def draw() -> Opponent:
            return drivers[int(np.random.default_rng([self.spec.seed, self.updates]).integers(len(drivers)))]

        return draw, list(pool.values())

    def start_from(self, learner_states: dict[str, dict]) -> None:
        """Starts each side in ``learner_states`` (side -> the ``learners`` entry of a
        ``trainer.pt``) from that learner: actor, critic, optimiser and normalisers. The budget,
        the learning-rate schedule and the counters start afresh (a league's next generation).
        A learner of another architecture is a ValueError naming the side."""
        for side, state in learner_states.items():
            try:
                self.learners[side].load_state_dict(state)
            except (KeyError, RuntimeError, ValueError) as e:
                raise ValueError(f"cannot start the {side} from that learner: another network or observation size ({type(e).__name__}: {str(e).splitlines()[0]})") from None

    def _start_from_models(self, loaded: Mapping[str, Any]) -> None:
        """Each side of ``spec.init`` starts with that saved model's actor (its weights, its
        action spread and its observation normaliser): ``loaded[side]`` where the caller has
        loaded it already (``run_training`` checks the models before anything is written),
        loaded here otherwise. The model must have this run's network; with entity observations
        the number of rows may differ (the set network reads any)."""
        for side, folder in self.spec.init.items():
            model = loaded[side] if side in loaded else load_policy(folder, side)
            theirs, mine = dict(model.config["network"]), dict(self.learners[side].network)
            if mine.get("kind") == "entities":
                for network in (theirs, mine):
                    network.pop("obs_dim", None)
            differ = sorted(k for k in set(theirs) | set(mine) if theirs.get(k) != mine.get(k))
            if differ:
                shown = "; ".join(f"{k}: {theirs.get(k)!r} there, {mine.get(k)!r} here" for k in differ)
                raise ValueError(f"--init {folder}: another network than this run's ({shown}): give the model's hyperparameters with --hp, or none")
            self.learners[side].actor.load_state_dict(model.actor.state_dict())

    def _load_resume_state(self) -> dict | None:
        self._resume_path, state = latest_resume_state(self.out, self.spec.sides, self.device)
        return state

    def _restore(self, state: dict) -> None:
        for side, learner in self.learners.items():
            learner.load_state_dict(state["learners"][side])
        self.generator.set_state(state["generator"].cpu() if self.device.type == "cpu" else state["generator"])
        for side, weights in (state.get("group_weights") or {}).items():
            self.learners[side].group_weights = list(weights)
        self.updates, self.agent_steps, self.train_s_before = int(state["updates"]), int(state["agent_steps"]), float(state["train_s"])

    # --- the budget -------------------------------------------------------------------------------

    def _fraction_done(self, train_s: float) -> float:
        """How much of the budget is spent: agent steps of --timesteps, or minutes of this
        invocation's --time-limit (the larger), for annealing and the cadences."""
        f = 0.0
        if self.spec.timesteps:
            f = max(f, self.agent_steps / self.spec.timesteps)
        if self.spec.time_limit_min:
            f = max(f, train_s / (60.0 * self.spec.time_limit_min))
        return f

    def _learning_rate(self, side: str, fraction: float) -> float:
        rc = self.spec.recipes[side]
        lr = float(rc["learning_rate"])
        return lr * max(1.0 - fraction, 0.0) if rc["anneal_lr"] else lr

    # --- the loop ---------------------------------------------------------------------------------

    def run(self) -> dict:
        """Trains until the budget is spent (or Ctrl-C: the model is saved at the last finished
        update and KeyboardInterrupt is raised again). Returns the summary."""
        spec = self.spec
        self.out.mkdir(parents=True, exist_ok=True)
        csv_path = self.out / "progress.csv"
        columns = list(BASE_COLUMNS) + [f"{s}_{c}" for s in spec.sides for c in SIDE_COLUMNS] + [f"eval_{s}_{c}" for s in spec.sides for c in EVAL_COLUMNS]
        # Multi-task: each task's held-out rates too, and the weight its worlds have in the update.
        columns += [f"eval_{task}_{s}_{c}" for task, _ in spec.eval_tasks for s in spec.sides for c in EVAL_COLUMNS[:2]]
        columns += [f"weight_{task}" for task in dict.fromkeys(self.group_tasks) if spec.groups]
        new_csv = not csv_path.is_file()
        csv_file = open(csv_path, "a", newline="")
        writer = csv.DictWriter(csv_file, fieldnames=columns)
        if new_csv:
            writer.writeheader()
        tb = tensorboard(self.out)
        bar = progress_bar(spec, self.progress)
        # A resumed run goes on from the cadence it had reached.
        evals_done = ckpts_done = 0
        if spec.timesteps:
            evals_done = int(self.agent_steps / spec.timesteps * self.spec.evaluations)
            ckpts_done = int(self.agent_steps / spec.timesteps * self.CHECKPOINTS)

        t_start = time.perf_counter()
        eval_s = 0.0
        steps_at_start = self.agent_steps
        interrupted = False
        stats: dict = {}
        critic_only = 0
        rollouts = 0
        try:
            if (spec.imitate_min or spec.imitate_rounds) and self.updates == 0:
                from wolfpack.learn.imitation import imitate

                rounds = imitate(self, spec.imitate_min, lambda: time.perf_counter() - t_start - eval_s, spec.imitate_rounds)
                te = time.perf_counter()
                self._evaluate(time.perf_counter() - t_start - eval_s, phase="imitation")
                eval_s += time.perf_counter() - te
                (self.out / "imitation.json").write_text(json.dumps(rounds, indent=1) + "\n")
                critic_only = self.CRITIC_WARMUP_UPDATES
            if spec.init and self.updates == 0:
                critic_only = self.CRITIC_WARMUP_UPDATES
            outs = [env.reset() for env in self.envs]
            # The step's outputs go into these arrays, step after step (the learners copy what
            # they keep into their rollout buffers); made anew when the opponent changes, since
            # a learned opponent's observations are among them.
            buffers = [env.new_outputs() for env in self.envs]
            ep_return = {side: [np.zeros(env.num_envs) for env in self.envs] for side in spec.sides}
            while True:
                train_s = time.perf_counter() - t_start - eval_s
                fraction = self._fraction_done(train_s)
                if fraction >= 1.0 or (not spec.timesteps and not spec.time_limit_min):
                    break
                t0 = time.perf_counter()
                if self.opponents is not None and rollouts > 0:
                    drawn = self.opponents()
                    for env in self.envs:
                        env.set_opponent(drawn)
                    buffers = [env.new_outputs() for env in self.envs]
                rollouts += 1
                torch.set_num_threads(self._threads["rollout"])
                outcomes = np.zeros(len(OUTCOMES), np.int64)
                finished_returns: dict[str, list[float]] = {side: [] for side in spec.sides}
                for t in range(self.n_steps):
                    for g, env in enumerate(self.envs):
                        out = outs[g]
                        state = out.get("state")
                        actions = {side: learner.act(t, out[f"obs_{side}"], state, g) for side, learner in self.learners.items()}
                        out = outs[g] = env.step(actions.get("wolves"), actions.get("targets"), out=buffers[g])
                        done_np = out["terminated"] | out["truncated"]
                        done = torch.from_numpy(done_np)
                        for side, learner in self.learners.items():
                            rewards = out[f"rewards_{side}"]
                            learner.record(t, rewards, done, g)
                            ep_return[side][g] += rewards.mean(axis=1)
                        if done_np.any():
                            outcomes += np.bincount(out["outcome"][done_np], minlength=len(OUTCOMES))
                            for side in spec.sides:
                                finished_returns[side].extend(ep_return[side][g][done_np].tolist())
                                ep_return[side][g][done_np] = 0.0
                for side, learner in self.learners.items():
                    learner.finish_rollout([out[f"obs_{side}"] for out in outs], [out.get("state") for out in outs])
                t1 = time.perf_counter()
                torch.set_num_threads(self._threads["update"])
                for side, learner in self.learners.items():
                    learner.set_learning_rate(self._learning_rate(side, fraction))
                    stats[side] = learner.update(train_actor=critic_only == 0)
                torch.set_num_threads(self._threads["rest"])  # evaluations, checkpoints, imitation
                critic_only = max(critic_only - 1, 0)
                t2 = time.perf_counter()
                self.updates += 1
                self.agent_steps += self.agents_per_step * self.n_steps
                train_s = time.perf_counter() - t_start - eval_s
                row = self._row(train_s, steps_at_start, t1 - t0, t2 - t1, outcomes, finished_returns, stats)
                fraction = self._fraction_done(train_s)
                if fraction >= (evals_done + 1) / self.spec.evaluations or fraction >= 1.0:
                    te = time.perf_counter()
                    row.update(self._evaluate(self.train_s_before + train_s))
                    eval_s += time.perf_counter() - te
                    evals_done = int(fraction * self.spec.evaluations)
                # Held back from Ctrl-C: TensorBoard's writer hands events to its thread through a
                # queue, and a KeyboardInterrupt inside the queue's notify can leave that thread
                # asleep, so the close below waits for its flush timer (two minutes).
                with sigint_held():
                    writer.writerow({k: cell(row.get(k)) for k in columns})
                    csv_file.flush()
                    if tb is not None:
                        for k, v in row.items():
                            if k not in ("update", "agent_steps") and isinstance(v, (int, float)) and math.isfinite(v):
                                tb.add_scalar(k, v, self.agent_steps)
                if bar is not None:
                    bar.update(self._bar_position(train_s) - bar.n)
                    bar.set_postfix_str(postfix(row, spec.sides), refresh=False)
                if fraction >= (ckpts_done + 1) / self.CHECKPOINTS and fraction < 1.0:
                    self._save(self.out / "checkpoints" / f"{self.agent_steps:012d}", train_s, checkpoint=True)
                    ckpts_done = int(fraction * self.CHECKPOINTS)
        except KeyboardInterrupt:
            interrupted = True
        finally:
            try:
                with sigint_held():
                    csv_file.close()
                    if bar is not None:
                        bar.close()
                    if tb is not None:
                        tb.close()
            except KeyboardInterrupt:  # a Ctrl-C while the logs closed: the run still saves
                interrupted = True
        train_s = time.perf_counter() - t_start - eval_s
        self._save(self.out, train_s)
        summary = {
            "learners": spec.learners,
            "algo": spec.algo,
            "agent_steps": self.agent_steps,
            "updates": self.updates,
            "train_s": self.train_s_before + train_s,
            "this_invocation": {
                "train_s": train_s,
                "eval_s": eval_s,
                "agent_steps": self.agent_steps - steps_at_start,
                "agent_steps_per_s": (self.agent_steps - steps_at_start) / train_s if train_s > 0 else None,
            },
            "stopped_by": "interrupt" if interrupted else ("timesteps" if spec.timesteps and self.agent_steps >= spec.timesteps else "time_limit"),
            "final_evaluation": self.held_out.records[-1] if self.held_out.records else None,
        }
        (self.out / "summary.json").write_text(json.dumps(summary, indent=1) + "\n")
        if interrupted:
            raise KeyboardInterrupt
        return summary

    #: Checkpoints per budget: at every fifth of it (of --timesteps, or of --time-limit's
    #: minutes: whichever is spent first). Held-out evaluations: ``spec.evaluations`` per
    #: budget, and at the end.
    CHECKPOINTS = 5

    #: PPO updates after an imitation warm start or a start from a saved model (``--init``) in
    #: which only the critics learn: the actor meets a critic that has seen its returns before
    #: any policy gradient moves it.
    CRITIC_WARMUP_UPDATES = 3

    def _bar_position(self, train_s: float) -> int:
        return int(1000 * min(self._fraction_done(train_s), 1.0))

    def _row(self, train_s: float, steps_at_start: int, rollout_s: float, update_s: float, outcomes: np.ndarray, returns: dict, stats: dict) -> dict:
        episodes = int(outcomes.sum())
        rate = lambda code: outcomes[code] / episodes if episodes else float("nan")  # noqa: E731
        row: dict[str, Any] = {
            "update": self.updates,
            "wall_s": self.train_s_before + train_s,
            "agent_steps": self.agent_steps,
            "agent_steps_per_s": (self.agent_steps - steps_at_start) / train_s if train_s > 0 else float("nan"),
            "rollout_s": rollout_s,
            "update_s": update_s,
            "episodes": episodes,
            "captured_rate": rate(CAPTURED),
            "collision_rate": rate(COLLISION),
            "timeout_rate": rate(TIMEOUT),
            "cornered_rate": rate(CORNERED),
        }
        for side in self.spec.sides:
            row[f"{side}_return"] = float(np.mean(returns[side])) if returns[side] else float("nan")
            for k in SIDE_COLUMNS[1:-1]:
                row[f"{side}_{k}"] = stats[side][k]
            row[f"{side}_learning_rate"] = self.learners[side].optimizer.param_groups[0]["lr"]
        if self.spec.groups:
            weights = self.learners[self.spec.sides[0]].group_weights
            for task, w in zip(self.group_tasks, weights):
                row[f"weight_{task}"] = w
        return row

    # --- evaluation --------------------------------------------------------------------------------

    def _evaluate(self, train_s: float, phase: str = "ppo") -> dict:
        """The held-out evaluation of every learning side now (:class:`HeldOut`); its entries of
        progress.csv's row."""
        return self.held_out.evaluate(self.learners, self.agent_steps, self.updates, train_s, phase)

    # --- saving ------------------------------------------------------------------------------------

    def _save(self, folder: Path, train_s: float, checkpoint: bool = False) -> None:
        """The models of every side and the resume state into ``folder`` (files written under a
        temporary name, then renamed: a file present is complete)."""
        folder.mkdir(parents=True, exist_ok=True)
        for side, learner in self.learners.items():
            model_dir = folder / side
            model_dir.mkdir(exist_ok=True)
            config = {
                "side": side,
                "algo": self.spec.algo,
                "learners": self.spec.learners,
                "trainer": "wolfpack train",
                "run": str(self.out.resolve()),
                "checkpoint_steps": self.agent_steps if checkpoint else None,
                "agent_steps": self.agent_steps,
                "network": learner.network,
                **({"entity_kinds": sorted(set().union(*(entity_kinds(side, env.params) for env in self.envs)))} if learner.network.get("kind") == "entities" else {}),
                "recipe": self.spec.recipes[side],
                "opponent": self.spec.opponent,
                "opponent_pool": list(self.spec.opponent_pool) if len(self.spec.opponent_pool) > 1 else None,
                "init": self.spec.init.get(side),
                "seed": self.spec.seed,
                "command": self.spec.command,
                "versions": versions(),
                "params": self.spec.params,
            }
            write_atomic(model_dir / CONFIG_FILE, lambda p: p.write_text(yaml.safe_dump(plain(config), sort_keys=False)))
            write_atomic(model_dir / POLICY_FILE, lambda p, a=learner.actor: torch.save({k: v.cpu() for k, v in a.state_dict().items()}, p))
        state = {
            "learners": {side: learner.state_dict() for side, learner in self.learners.items()},
            "generator": self.generator.get_state(),
            "group_weights": {side: list(learner.group_weights) for side, learner in self.learners.items()},
            "updates": self.updates,
            "agent_steps": self.agent_steps,
            "train_s": self.train_s_before + train_s,
            "resumes": self.resumes,
        }
        write_atomic(folder / TRAINER_FILE, lambda p: torch.save(state, p))


def _entity_shape(side: str, params: dict) -> tuple[int, int, int] | None:
    """(own features, row size, state row size) of ``side``'s entity observation, or None."""
    shape = entity_shape(side, params)
    return (*shape, len(ENTITY_STATE_FIELDS)) if shape else None
