"""``wolfpack train``: the native trainer's command line (the run itself:
:func:`wolfpack.learn.run.run_training`)."""

from __future__ import annotations

import argparse
import shlex
from dataclasses import fields
from typing import Sequence

from wolfpack import config
from wolfpack.cli.args import folder, int_at_least, positive_minutes
from wolfpack.learn.recipes import ALGOS, LEARNERS
from wolfpack.learn.run import DEVICES, TrainOptions, run_training
from wolfpack.learn.tasks import TASK_WEIGHTS, VARIANTS, parse_vary
from wolfpack.sides import SIDES
from wolfpack.task import TASK_ORDER

TRAIN_DESCRIPTION = """\
Train wolves, targets or both sides at once with PPO on the native batch.

--algo ippo: every agent of a side shares one actor and one critic that both read the agent's
own observation (independent PPO with parameter sharing). --algo mappo (default): the same
actor, and a centralised critic that reads the world's global state (BatchEnv.state()) with
the agent's own observation. --side both: wolves and targets learn together in the same
worlds, each side with its own networks and optimiser; otherwise the other side follows
--opponent (a law's name or a saved model; default: its law in params). --opponent given
more than once makes a pool: before every rollout one of them is drawn uniformly (give one
twice to draw it twice as often) and takes over the other side in every world; the first is the
one the held-out evaluations play.

--imitate-rounds R (or --imitate MINUTES) first clones each learning side's scripted law
(params policies.<side>, the laws' actions from BatchEnv.expert_actions()) into the same actor
with R rounds of DAgger, then trains it with PPO (the critic alone for the first 3 updates);
its minutes count in the time limit. Rounds are reproducible; minutes give a busier machine
fewer rounds (both: whichever comes first).

Hyperparameters: the packaged recipes (wolfpack/learn/recipes.yaml; one per side and
algorithm, the defaults measured best), each key changed with --hp KEY=VALUE. Observations
and returns are normalised by running statistics saved with the model; the policy is a Gaussian
whose draws the environment clips to the action box.

A budget is needed: --time-limit MINUTES (wall clock of this invocation) and/or --timesteps
(agent-steps in all; one batch step of E worlds with N learning wolves is E*N agent-steps);
training stops at whichever comes first, and the learning rate anneals over it. Held-out
evaluations (deterministic, episodes 500000 + k, never trained on) run at every tenth of the
budget (--evaluations) and at the end; checkpoints at every fifth. A --timesteps run is bit-identical when
rerun on the CPU with the same seed and thread counts; a --time-limit run stops where the clock
says.

Writes into --out DIR (a new or empty folder; --resume continues the run there):
  config.yaml                  the run: sides, algorithm, opponent, params, recipes, command
  wolves/, targets/            each learning side's model: policy.pt + config.yaml; any
                               model path takes it (opponent=DIR, wolfpack.load_policy(DIR),
                               training/evaluate.py DIR)
  progress.csv                 one row per update: wall_s, agent_steps, agent_steps_per_s,
                               outcome rates, per side return, losses, entropy, KL, and the
                               held-out evaluations; TensorBoard events beside it
  evaluations.json             every held-out evaluation (after imitation too: phase)
  imitation.json               with --imitate(-rounds): each DAgger round (beta, samples, loss)
  checkpoints/<agent steps>/   models and resume state; trainer.pt the latest state
  summary.json                 agent steps, wall time, throughput, the final evaluation
Ctrl-C saves the models as they are and exits with status 130."""

TRAIN_EPILOG = """\
examples:
  wolfpack train --side wolves --time-limit 15 --out runs/wolves
  wolfpack train --side targets --algo ippo --opponent bvc --time-limit 10 --out runs/escape
  wolfpack train --side wolves --opponent escape --opponent results/models/escape_ppo --time-limit 15 --out runs/pool
  wolfpack train --side both --timesteps 20000000 --seed 3 --out runs/both
  wolfpack train --side wolves --out runs/wolves --resume --time-limit 15
  wolfpack train --side wolves --task all --hp network=entities --time-limit 60 --out runs/generalist
  wolfpack train --side wolves --init runs/generalist --opponent escape --opponent runs/escaper --time-limit 15 --out runs/tuned"""


def add_parser(sub) -> argparse.ArgumentParser:
    """Registers ``train`` on the ``wolfpack`` command's subparsers."""
    p = sub.add_parser(
        "train",
        help="train wolves, targets or both with PPO (IPPO or MAPPO) on the native batch",
        description=TRAIN_DESCRIPTION,
        epilog=TRAIN_EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    p.add_argument("--side", required=True, choices=LEARNERS, dest="learners", help="which side learns (both: both sides at once)")
    p.add_argument("--algo", choices=ALGOS, default="mappo", help="ippo (decentralised critic) or mappo (centralised critic on the global state; default)")
    p.add_argument("--out", required=True, metavar="DIR", type=folder, help="run folder (new or empty, or the run to --resume)")
    p.add_argument("--time-limit", metavar="MIN", type=positive_minutes, default=None, dest="time_limit_min", help="stop after this many minutes of this invocation")
    p.add_argument("--timesteps", metavar="N", type=int_at_least(1), default=None, help="stop after this many agent-steps in all")
    p.add_argument("--seed", metavar="S", type=int_at_least(0), default=0, help="seed of the networks, the sampling and the training worlds 1000000*(S+1)+e; 0 <= S < 10^13 (default 0)")
    p.add_argument(
        "--opponent",
        metavar="LAW_OR_MODEL",
        action="append",
        default=None,
        help="what drives the other side: a law (seed000, bvc, formation / escape, random, still) or a saved model (default: its law in params); repeated: a pool, one drawn per rollout, the first evaluated",
    )
    scenario = p.add_mutually_exclusive_group()
    scenario.add_argument("--params", metavar="P", default=None, help="scenario YAML (default: the packaged params.yaml)")
    scenario.add_argument(
        "--task",
        metavar="NAME",
        action="append",
        default=None,
        help=f"train on a task of the benchmark suite (docs/tasks.md): {', '.join(TASK_ORDER)}; repeated, or 'all': one model over several tasks, each with its share of the worlds",
    )
    p.add_argument(
        "--vary",
        metavar="KEY=LO:HI",
        action="append",
        default=[],
        help=f"with --task: draw a params key within a range, e.g. world.wolves=3:8 (repeatable; {VARIANTS} groups of worlds per task, each with its own draw)",
    )
    p.add_argument(
        "--task-weights",
        choices=TASK_WEIGHTS,
        default="uniform",
        help="how the tasks weigh in the update: uniform (default); or after each held-out evaluation, adaptive (by how often the learner fails on each) or shortfall (by how far it is below each task's best law)",
    )
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=[], dest="overrides", help="params override, e.g. --set world.wolves=8 (repeatable)")
    p.add_argument("--hp", metavar="KEY=VALUE", action="append", default=[], dest="hp", help="hyperparameter override, e.g. --hp learning_rate=1e-4 (repeatable; keys: wolfpack/learn/recipes.yaml)")
    p.add_argument("--device", choices=DEVICES, default="auto", help="where the networks run: auto (CUDA when present), cpu or cuda; the worlds always step on the CPU")
    p.add_argument("--threads", metavar="T", type=int_at_least(1, 256), default=None, help="the batch's worker threads (default: the recipe's choice for this machine, see --help's text)")
    p.add_argument(
        "--torch-threads",
        metavar="T",
        type=int_at_least(1, 256),
        default=None,
        help="torch's threads (default: all cores; the batch and torch take turns, never run together; on the CPU the rollout uses one, and with two or more the update learns the actor and the critic side by side, each with half)",
    )
    p.add_argument("--eval-episodes", metavar="K", type=int_at_least(1), default=100, help="episodes per held-out evaluation (default 100)")
    p.add_argument(
        "--imitate",
        metavar="MIN",
        dest="imitate_min",
        type=positive_minutes,
        default=None,
        help="first clone each learning side's scripted law (params policies.<side>) for this many minutes with DAgger, then PPO; part of the time limit",
    )
    p.add_argument(
        "--imitate-rounds",
        metavar="R",
        type=int_at_least(1),
        default=None,
        help="first clone each learning side's scripted law with this many DAgger rounds (reproducible on any machine), then PPO",
    )
    p.add_argument(
        "--init",
        metavar="MODEL",
        action="append",
        default=None,
        help="start the learning side from this saved model of 'wolfpack train' (a model or run folder; repeated with --side both: one per side): its actor and its recipe (--hp changes it), a fresh critic that learns alone for the first updates; e.g. to fine-tune a pack against new opponents",
    )
    p.add_argument("--evaluations", metavar="K", type=int_at_least(1), default=10, help="held-out evaluations per budget, evenly spread (default 10), and one at the end")
    p.add_argument("--resume", action="store_true", help="continue the run in --out from its latest state (its configuration must match)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=cmd_train)
    return p


def cmd_train(args: argparse.Namespace, argv: Sequence[str]) -> None:
    # The parser's destinations are TrainOptions' field names; these options are converted.
    converted = {
        "overrides": dict(config.parse_override(text) for text in args.overrides),
        "hp": dict(config.parse_override(text, "--hp") for text in args.hp),
        "vary": parse_vary(args.vary),
        "progress": not args.no_progress,
        "command": " ".join(shlex.quote(a) for a in ["wolfpack", *argv]),
    }
    given = {f.name: getattr(args, f.name) for f in fields(TrainOptions) if hasattr(args, f.name) and f.name not in converted}
    options = TrainOptions(**given, **converted)
    summary = run_training(options)
    final = summary.get("final_evaluation") or {}
    rate = summary["this_invocation"]["agent_steps_per_s"] or 0
    line = f"{summary['learners']} {summary['algo']}: {summary['agent_steps']:,} agent-steps, {summary['train_s'] / 60:.1f} min, {rate / 1000:.0f}k agent-steps/s"
    for side in SIDES:
        if side in final:
            r = final[side]
            shown = "capture" if side == "wolves" else "survival"
            value = r["capture_rate"] if side == "wolves" else r["survival_rate"]
            line += f"; held-out {side} {shown} {100 * value:.1f} % (collisions {100 * r['collision_rate']:.1f} %)"
    print(line + f"; models in {args.out}")
