"""A self-play league: wolves and targets trained against each other.

    python training/selfplay.py --out runs/league --generations 6 --time-limit 60
    python training/selfplay.py --out runs/league --resume --generations 8 --time-limit 30

Alternating best responses against a pool. Generation k trains one side (they alternate,
``--first`` first) with the trainer of ``wolfpack train`` (``--algo mappo`` or ``ippo``, the
packaged recipes, ``--hp`` for both sides) against opponents drawn from the other side's pool:
its analytic laws as fixed members (seed000, bvc, formation / escape, random, still;
``--fixed-wolves`` / ``--fixed-targets`` choose) plus every frozen model of that side so far
(and any ``--member``). An opponent is drawn at the start of every rollout and swapped in
without resetting any world (``BatchEnv.set_opponent``):

  latest       the other side's newest member (its last fixed law before any model exists)
  uniform      every member alike
  prioritised  prioritised fictitious self-play: weight (1 − w)² + 0.02, w the learner's
               win rate against that member in the league table (0.5 when not yet measured),
               so the opponents it still loses to are met most

The league's scenario is ``--params``/``--set`` with the recipes' own params overrides of both
sides (the wolves' collision weight and the pack's last sighting in their observation). The
learner starts from its side's latest member (actor, critic, normalisers: its generation's
``trainer.pt``), else from ``--init-wolves`` / ``--init-targets`` (a run of ``wolfpack
train``), else afresh; its learning rate anneals over its generation. At the
end of its generation it is frozen as a new member and evaluated against every member of the
other side on held-out episodes (seeds 500000 + k, never trained on); those win rates feed
prioritised sampling and the league table. Win rate: a wolf member's capture rate, a target
member's survival rate (1 − capture rate).

The time budget (``--time-limit`` minutes, for this invocation) is shared out evenly over the
generations still to run; ``--timesteps`` caps each generation (agent-steps). Ctrl-C stops at once; the
league file only ever holds finished generations, and ``--resume`` starts the interrupted one
again from its side's latest member.

Writes into --out (refused if it holds a league, unless --resume):
  league.json        members (name, side, kind, generation, timesteps, wall time, path),
                     generations (side, timesteps, wall time, opponents drawn and how often),
                     evaluations (every pair measured: capture rate with 95 % interval,
                     collisions, median capture step), the arguments and the scenario
  members/<name>/    policy.pt + config.yaml of every learned member (evaluate.py, opponent=
                     and wolfpack.load_policy read them)
  generations/<k>/   the trainer's run folder of generation k (progress.csv, TensorBoard,
                     evaluations.json, trainer.pt: the state the side's next generation
                     starts from)
  league.md          the league table (each member's win rate against each opposing member)
  league_curves.png  win rates of each generation's member against the fixed laws and the
                     learned opponents, and the training return of every generation
"""

from __future__ import annotations

import argparse
import json
import os
import random
import shlex
import shutil
import sys
import time
from pathlib import Path

import yaml
from wolfpack.batch import resolve_params
from wolfpack.cli.args import int_at_least, positive_number
from wolfpack.config import parse_override
from wolfpack.evaluation import HELD_OUT_SEED, report
from wolfpack.learn.checkpoints import TRAINER_FILE
from wolfpack.learn.matches import play
from wolfpack.learn.recipes import ALGOS, recipe, recipes_params_overrides
from wolfpack.learn.sb3 import TrainedModel, load_model, prepare_out
from wolfpack.models import CONFIG_FILE, load_tensors
from wolfpack.report.league import league_curves, league_table, members_of, win_rate
from wolfpack.sides import OTHER_SIDE, SCRIPTED_LAWS, SIDES, side_action_mode

LEAGUE_FILE = "league.json"
#: 2: members trained by ``wolfpack train``'s trainer (1 was SB3's PPO).
LEAGUE_FORMAT = 2
SAMPLING = ("latest", "uniform", "prioritised")
#: PFSP's floor: a member the learner always beats is still met now and then.
PFSP_FLOOR = 0.02


def laws_arg(side: str):
    allowed = SCRIPTED_LAWS["wolves"] if side == "wolves" else SCRIPTED_LAWS["targets"]

    def parse(text: str) -> list[str]:
        laws = [t for t in text.split(",") if t]
        bad = [t for t in laws if t not in allowed]
        if bad:
            raise argparse.ArgumentTypeError(f"unknown {side} law {bad[0]!r} (one of {', '.join(allowed)})")
        return laws

    return parse


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="selfplay.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--out", required=True, help="the league folder")
    p.add_argument("--resume", action="store_true", help="go on with the league in --out (its scenario and fixed members)")
    p.add_argument("--generations", type=int_at_least(1), default=6, help="generations in the league in all (default 6; with --resume: the new total)")
    p.add_argument("--time-limit", type=positive_number, default=None, metavar="MIN", help="wall-clock minutes for this invocation, shared over the generations still to run")
    p.add_argument("--timesteps", type=int_at_least(1), default=200_000_000, help="most agent-steps per generation (default 2e8; the time limit usually ends a generation first)")
    p.add_argument("--algo", choices=ALGOS, default="mappo", help="the trainer's algorithm for both sides (default mappo; a new league only)")
    p.add_argument("--first", choices=SIDES, default="targets", help="the side of generation 1 (default targets)")
    p.add_argument("--pool-sampling", choices=SAMPLING, default="prioritised", help="how each rollout's opponent is drawn (default prioritised)")
    p.add_argument("--fixed-wolves", type=laws_arg("wolves"), default=list(SCRIPTED_LAWS["wolves"]), metavar="LAWS", help="comma-separated wolf laws in the pool (default all three)")
    p.add_argument(
        "--fixed-targets", type=laws_arg("targets"), default=["escape"], metavar="LAWS", help="comma-separated target laws in the pool (default escape; random and still teach wolves little)"
    )
    p.add_argument("--member", dest="members", action="append", default=[], metavar="RUN", help="an existing model (run folder) as a fixed member of its side's pool (repeatable)")
    p.add_argument("--init-wolves", default=None, metavar="RUN", help="the wolves' first learner starts from this run of wolfpack train (its trainer.pt: actor, critic, normalisers)")
    p.add_argument("--init-targets", default=None, metavar="RUN", help="the targets' first learner starts from this run of wolfpack train")
    p.add_argument("--eval-episodes", type=int_at_least(1), default=100, help="held-out episodes per evaluated pair (default 100)")
    p.add_argument("--num-envs-wolves", type=int_at_least(1), default=None, help="worlds while wolves learn (default: the recipe's)")
    p.add_argument("--num-envs-targets", type=int_at_least(1), default=None, help="worlds while targets learn (default: the recipe's)")
    p.add_argument("--params", default=None, help="params YAML of the league's scenario (default: the documented scenario)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="params override (repeatable)")
    p.add_argument("--hp", dest="hps", action="append", default=[], metavar="KEY=VALUE", help="recipe override for both sides (repeatable; keys: wolfpack/learn/recipes.yaml; a new league only)")
    p.add_argument("--seed", type=int_at_least(0), default=0, help="seed of the league (training worlds, PPO, sampling; default 0)")
    p.add_argument("--threads", type=int_at_least(1), default=None, help="the batch's threads (default: all cores; the batch and torch take turns)")
    p.add_argument("--torch-threads", type=int_at_least(1), default=None, help="torch threads (default: all cores)")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


# --- the league file ---------------------------------------------------------------------------


def write_league(out: Path, league: dict) -> None:
    """league.json, replaced atomically: an interruption never leaves half a file."""
    tmp = out / f".{LEAGUE_FILE}.tmp"
    tmp.write_text(json.dumps(league, indent=1) + "\n")
    os.replace(tmp, out / LEAGUE_FILE)


def league_params(args) -> dict:
    """The league's scenario: ``--params`` with the recipes' params overrides of both sides
    (reward weights, observation keys such as the wolves' last sighting) and then ``--set``."""
    hp = dict(parse_override(s) for s in args.hps)
    overrides = recipes_params_overrides({side: recipe(side, args.algo, hp) for side in SIDES})
    overrides.update(parse_override(s) for s in args.sets)
    return resolve_params(args.params, overrides)


def new_league(args, params: dict, out: Path) -> dict:
    fixed = [{"name": law, "side": "wolves", "kind": "scripted", "generation": 0} for law in args.fixed_wolves]
    fixed += [{"name": law, "side": "targets", "kind": "scripted", "generation": 0} for law in args.fixed_targets]
    for run in args.members:
        m = load_model(run)
        # Relative to the league folder, so that the league can move with the repository.
        fixed.append({"name": Path(run).resolve().name, "side": m.side, "kind": "model", "generation": 0, "path": os.path.relpath(Path(run).resolve(), out.resolve()), "fixed": True})
    names = [m["name"] for m in fixed]
    if len(set(names)) != len(names):
        raise ValueError(f"two fixed members share a name: {sorted(n for n in names if names.count(n) > 1)[0]!r}")
    return {
        "format": LEAGUE_FORMAT,
        "algo": args.algo,
        "hp": dict(parse_override(s) for s in args.hps),
        "params": params,
        "first": args.first,
        "seed": args.seed,
        "init": {side: None if run is None else os.path.relpath(Path(run).resolve(), out.resolve()) for side, run in (("wolves", args.init_wolves), ("targets", args.init_targets))},
        "members": fixed,
        "generations": [],
        "evaluations": [],
        "commands": [],
    }


def sampling_weights(league: dict, side: str, learner: str | None, pool: list[dict], how: str) -> list[float]:
    if how == "latest":
        newest = max(range(len(pool)), key=lambda i: (pool[i]["generation"], i))
        return [1.0 if i == newest else 0.0 for i in range(len(pool))]
    if how == "uniform" or learner is None:
        return [1.0] * len(pool)
    rates = [win_rate(league, learner, side, m["name"]) for m in pool]
    return [(1.0 - (0.5 if w is None else w)) ** 2 + PFSP_FLOOR for w in rates]


# --- one generation ----------------------------------------------------------------------------


class Member:
    """A pool member ready to play: a law's name or a loaded model."""

    def __init__(self, entry: dict, out: Path) -> None:
        self.entry = entry
        self.name = entry["name"]
        self.model: TrainedModel | None = None
        if entry["kind"] == "model":
            self.model = load_model(out / entry["path"])

    @property
    def player(self):
        return self.name if self.model is None else self.model

    def opponent(self):
        """What ``set_opponent`` takes: the law's name, or the model (it brings its own action
        mode and observation keys)."""
        import wolfpack

        if self.model is None:
            return self.name
        return wolfpack.Opponent(self.model.model, side=self.model.side, action_mode=self.model.action_mode, name=self.name)


def start_state(out: Path, league: dict, side: str) -> tuple[dict | None, str | None]:
    """The learner state a generation of ``side`` starts from and its label: the side's latest
    learned member (its generation's ``trainer.pt``), else ``--init-<side>`` (a run of
    ``wolfpack train``), else (None, None): a fresh learner."""
    learned = [m for m in members_of(league, side) if m["kind"] == "model" and not m.get("fixed")]
    if learned:
        path, label = out / learned[-1]["state"], learned[-1]["name"]
    elif league["init"][side]:
        path, label = out / league["init"][side] / TRAINER_FILE, league["init"][side]
    else:
        return None, None
    if not path.is_file():
        raise ValueError(f"{path}: missing (the learner state a generation of the {side} starts from)")
    try:
        state = load_tensors(path)
    except ValueError as e:
        raise ValueError(str(e)) from None
    if side not in state.get("learners", {}):
        raise ValueError(f"{path}: holds no learner of the {side}")
    return state["learners"][side], Path(label).name


def run_generation(args, out: Path, league: dict, k: int, side: str, deadline: float | None, rng: random.Random) -> dict | None:
    """Trains generation ``k`` (``side``) with ``wolfpack train``'s trainer and freezes it as a
    member; None when no update finished (interrupted, or no time left)."""
    import torch
    from wolfpack.learn.run import default_threads
    from wolfpack.learn.trainer import Trainer, TrainSpec

    pool = [Member(m, out) for m in members_of(league, OTHER_SIDE[side])]
    state, started_from = start_state(out, league, side)
    weights = sampling_weights(league, side, started_from, [m.entry for m in pool], args.pool_sampling)
    drawn: dict[str, int] = {}

    def draw():
        m = rng.choices(pool, weights=weights)[0]
        drawn[m.name] = drawn.get(m.name, 0) + 1
        return m.opponent()

    hp = dict(league["hp"])
    num_envs = args.num_envs_wolves if side == "wolves" else args.num_envs_targets
    if num_envs:
        hp["num_envs"] = num_envs
    minutes = None if deadline is None else (deadline - time.perf_counter()) / 60
    if minutes is not None and minutes <= 0:
        return None
    cores_env, cores_torch = default_threads()
    torch.set_num_threads(args.torch_threads or cores_torch)
    spec = TrainSpec(
        learners=side,
        algo=league["algo"],
        params=league["params"],
        recipes={side: recipe(side, league["algo"], hp)},
        seed=league["seed"] * 10_000 + k,
        timesteps=args.timesteps,
        time_limit_min=minutes,
        threads=args.threads or cores_env,
        torch_threads=args.torch_threads or cores_torch,
        device="cpu",
        eval_episodes=args.eval_episodes,
        evaluations=1,
        command=league["commands"][-1],
    )
    logs = out / "generations" / f"{k:02d}"
    if logs.exists():  # an interrupted generation: it starts again
        shutil.rmtree(logs)
    trainer = Trainer(spec, logs, progress=not args.no_progress and sys.stderr.isatty(), opponents=draw)
    if state is not None:
        try:
            trainer.start_from({side: state})
        except ValueError as e:
            raise ValueError(f"generation {k}: {e}") from None
    summary = trainer.run()
    if summary["updates"] == 0:
        return None
    name = f"{side}_g{k:02d}"
    folder = out / "members" / name
    if folder.exists():
        shutil.rmtree(folder)
    shutil.copytree(logs / side, folder)
    config = yaml.safe_load((folder / CONFIG_FILE).read_text())
    # The member's label is its name (``mappo:wolves_g02``), not its generation folder's.
    config["run"] = name
    config["league_member"] = {"generation": k, "started_from": started_from, "agent_steps": summary["agent_steps"], "opponents_drawn": drawn}
    (folder / CONFIG_FILE).write_text(yaml.safe_dump(json.loads(json.dumps(config)), sort_keys=False))
    wall = summary["train_s"]
    return {
        "member": {
            "name": name,
            "side": side,
            "kind": "model",
            "generation": k,
            "path": f"members/{name}",
            "state": f"generations/{k:02d}/{TRAINER_FILE}",
            "timesteps": summary["agent_steps"],
            "wall_s": round(wall, 1),
            "action_mode": side_action_mode(league["params"], side),
        },
        "generation": {
            "generation": k,
            "side": side,
            "timesteps": summary["agent_steps"],
            "wall_s": round(wall, 1),
            "agent_steps_per_s": summary["this_invocation"]["agent_steps_per_s"],
            "started_from": started_from,
            "sampling": args.pool_sampling,
            "weights": dict(zip([m.name for m in pool], weights)),
            "opponents_drawn": drawn,
            "stopped_by_time_limit": summary["stopped_by"] == "time_limit",
        },
    }


def evaluate_member(args, out: Path, league: dict, entry: dict, progress=None, against: list[dict] | None = None) -> list[dict]:
    """The new member against every member of the other side (or ``against``), on held-out
    episodes."""
    me = Member(entry, out)
    rows = []
    for other in members_of(league, OTHER_SIDE[entry["side"]]) if against is None else against:
        them = Member(other, out)
        wolves, targets = (me, them) if entry["side"] == "wolves" else (them, me)
        results = play(league["params"], wolves.player, targets.player, episodes=args.eval_episodes, seed=HELD_OUT_SEED, threads=args.threads)
        r = report(results, wolves.name, targets.name)
        rows.append({k: r[k] for k in ("wolves", "targets", "episodes", "first_seed", "capture_rate", "capture_rate_ci95", "collision_rate", "target_collision_rate", "median_capture_steps")})
        if progress is not None:
            progress(1)
    return rows


# --- main --------------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        out = Path(args.out)
        if (out / LEAGUE_FILE).is_file():
            if not args.resume:
                raise ValueError(f"--out {out} already holds a league ({LEAGUE_FILE}); --resume to go on with it, or choose another folder")
            league = json.loads((out / LEAGUE_FILE).read_text())
            if league.get("format") != LEAGUE_FORMAT:
                raise ValueError(f"--resume: {out / LEAGUE_FILE} is a league of an older format ({league.get('format')}, trained with SB3); start a new league")
            if args.params is not None or args.sets or args.hps:
                raise ValueError("--resume goes on in the league's own scenario and recipe: no --params/--set/--hp")
        else:
            if args.resume:
                raise ValueError(f"--resume: no {LEAGUE_FILE} in {out}")
            for flag, init in (("--init-wolves", args.init_wolves), ("--init-targets", args.init_targets)):
                if init is not None:
                    load_model(init)  # fails early, naming the file
                    if not (Path(init) / TRAINER_FILE).is_file():
                        raise ValueError(f"{flag} {init}: not a run of wolfpack train (no {TRAINER_FILE}); a generation starts from a trainer's state")
            league = new_league(args, league_params(args), out)
        prepare_out(out)
    except ValueError as e:
        print(f"selfplay.py: error: {e}", file=sys.stderr)
        return 2

    from tqdm import tqdm

    league["commands"].append(" ".join(shlex.quote(a) for a in ["python", "training/selfplay.py", *(sys.argv[1:] if argv is None else argv)]))
    if not league["generations"] and not league["evaluations"]:
        # The fixed members against each other once: the table's first rows, PFSP's first rates.
        fixed_wolves, fixed_targets = members_of(league, "wolves"), members_of(league, "targets")
        with tqdm(total=len(fixed_wolves) * len(fixed_targets), unit="pair", desc="fixed members", disable=args.no_progress or not sys.stderr.isatty()) as bar:
            for w in fixed_wolves:
                league["evaluations"].extend(evaluate_member(args, out, league, w, bar.update, against=fixed_targets))
    write_league(out, league)
    start = time.perf_counter()
    end = None if args.time_limit is None else start + 60 * args.time_limit
    rng = random.Random(league["seed"] * 1_000_003 + len(league["generations"]))
    try:
        while len(league["generations"]) < args.generations:
            k = len(league["generations"]) + 1
            side = league["first"] if k % 2 == 1 else OTHER_SIDE[league["first"]]
            left = args.generations - k + 1
            # This generation's share of what is left, keeping ~10 % of it for the evaluations.
            deadline = None if end is None else time.perf_counter() + 0.9 * max(0.0, end - time.perf_counter()) / left
            if end is not None and end - time.perf_counter() < 30:
                print(f"selfplay.py: time limit reached before generation {k}", file=sys.stderr)
                break
            print(f"generation {k}/{args.generations}: {side} learn ({args.pool_sampling} opponents)", file=sys.stderr)
            try:
                done = run_generation(args, out, league, k, side, deadline, rng)
            except ValueError as e:
                print(f"selfplay.py: error: {e}", file=sys.stderr)
                return 2
            if done is None:
                break
            entry = done["member"]
            pool_size = len(members_of(league, OTHER_SIDE[side]))
            with tqdm(total=pool_size, unit="pair", desc=f"evaluate {entry['name']}", disable=args.no_progress or not sys.stderr.isatty()) as bar:
                rows = evaluate_member(args, out, league, entry, bar.update)
            league["members"].append(entry)
            league["generations"].append(done["generation"])
            league["evaluations"].extend(rows)
            write_league(out, league)
            (out / "league.md").write_text(league_table(league))
            league_curves(out, league)
            rates = ", ".join(f"{r['targets'] if side == 'wolves' else r['wolves']} {100 * (r['capture_rate'] if side == 'wolves' else 1 - r['capture_rate']):.0f} %" for r in rows)
            print(f"  {entry['name']}: {entry['timesteps']:,} timesteps in {entry['wall_s'] / 60:.1f} min; {'capture' if side == 'wolves' else 'survival'}: {rates}", file=sys.stderr)
    except KeyboardInterrupt:
        print(f"selfplay.py: interrupted; {LEAGUE_FILE} holds the {len(league['generations'])} finished generations (--resume goes on)", file=sys.stderr)
        return 130
    print(f"league: {len(league['generations'])} generations, {len(league['members'])} members; {out / LEAGUE_FILE}, {out / 'league.md'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
