"""A self-play league with prioritised fictitious self-play (``training/selfplay.py`` is its
command; :func:`selfplay` its library entry point): wolves and targets trained against each
other, alternating, each against a pool of the other side's members.

Generation k trains one side (they alternate, ``first`` first) with the trainer of ``wolfpack
train`` (``algo`` ``mappo`` or ``ippo``, the packaged recipes, ``hps`` for both sides) against
opponents drawn from the other side's pool: its analytic laws as fixed members
(``fixed_wolves`` / ``fixed_targets``) plus every frozen model of that side so far (and any
``members``). An opponent is drawn at the start of every rollout and swapped in without
resetting any world (``BatchEnv.set_opponent``):

  latest       the other side's newest member (its last fixed law before any model exists)
  uniform      every member alike
  prioritised  prioritised fictitious self-play: weight (1 − w)² + 0.02, w the learner's
               win rate against that member in the league table (0.5 when not yet measured),
               so the opponents it still loses to are met most

The league's scenario is ``params``/``sets`` with the recipes' own params overrides of both
sides (the wolves' collision weight and the pack's last sighting in their observation). The
learner starts from its side's latest member (actor, critic, normalisers: its generation's
``trainer.pt``), else from ``init_wolves`` / ``init_targets`` (a run of ``wolfpack train``),
else afresh; its learning rate anneals over its generation. At the end of its generation it is
frozen as a new member and evaluated against every member of the other side on held-out
episodes (seeds 500000 + k, never trained on); those win rates feed prioritised sampling and
the league table. Win rate: a wolf member's capture rate, a target member's survival rate
(1 − capture rate).

The time budget (``time_limit`` minutes, for this invocation) is shared out evenly over the
generations still to run; ``timesteps`` caps each generation (agent-steps). An interruption
(Ctrl-C) stops at once; the league file only ever holds finished generations, and ``resume``
starts the interrupted one again from its side's latest member.

The population method the package recommends is ``wolfpack league`` (PSRO with a Nash
meta-solver, :mod:`wolfpack.learn.league`); this one made the committed leagues
``results/league_native`` and ``results/targets_long``.

Writes into ``out``: ``league.json`` (members, generations, evaluations, the commands and the
scenario), ``members/<name>/`` (each learned member's model) and ``generations/<k>/`` (the
trainer's run folder of generation k); the command adds the table and the curves.
"""

from __future__ import annotations

import json
import os
import random
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import yaml

from wolfpack.batch import resolve_params
from wolfpack.config import parse_override
from wolfpack.evaluation import HELD_OUT_SEED, report
from wolfpack.learn.checkpoints import TRAINER_FILE
from wolfpack.learn.matches import play
from wolfpack.learn.recipes import recipe, recipes_params_overrides
from wolfpack.learn.run import default_threads
from wolfpack.learn.sb3 import TrainedModel, load_model, prepare_out
from wolfpack.models import CONFIG_FILE, load_tensors
from wolfpack.opponents import Opponent
from wolfpack.sides import OTHER_SIDE, SCRIPTED_LAWS, SIDES, side_action_mode

LEAGUE_FILE = "league.json"
#: 2: members trained by ``wolfpack train``'s trainer (1 was SB3's PPO).
LEAGUE_FORMAT = 2
SAMPLING = ("latest", "uniform", "prioritised")
#: PFSP's floor: a member the learner always beats is still met now and then.
PFSP_FLOOR = 0.02


@dataclass(frozen=True)
class SelfPlayOptions:
    """What a self-play league is asked for (``training/selfplay.py``'s options, same names):
    the module's docstring says what each does."""

    out: str | Path
    resume: bool = False
    generations: int = 6
    time_limit: float | None = None
    timesteps: int = 200_000_000
    algo: str = "mappo"
    first: str = "targets"
    pool_sampling: str = "prioritised"
    fixed_wolves: list[str] = field(default_factory=lambda: list(SCRIPTED_LAWS["wolves"]))
    fixed_targets: list[str] = field(default_factory=lambda: ["escape"])
    members: list[str] = field(default_factory=list)
    init_wolves: str | None = None
    init_targets: str | None = None
    eval_episodes: int = 100
    num_envs_wolves: int | None = None
    num_envs_targets: int | None = None
    params: str | None = None
    sets: list[str] = field(default_factory=list)
    hps: list[str] = field(default_factory=list)
    seed: int = 0
    threads: int | None = None
    torch_threads: int | None = None
    no_progress: bool = False


def members_of(league: dict, side: str) -> list[dict]:
    return [m for m in league["members"] if m["side"] == side]


def win_rate(league: dict, member: str, side: str, opponent: str) -> float | None:
    """``member``'s (of ``side``) win rate against ``opponent`` in the league table, or None."""
    for e in league["evaluations"]:
        if (e["wolves"], e["targets"]) == ((member, opponent) if side == "wolves" else (opponent, member)):
            return e["capture_rate"] if side == "wolves" else 1.0 - e["capture_rate"]
    return None


# --- the league file ---------------------------------------------------------------------------


def write_league(out: Path, league: dict) -> None:
    """league.json, replaced atomically: an interruption never leaves half a file."""
    tmp = out / f".{LEAGUE_FILE}.tmp"
    tmp.write_text(json.dumps(league, indent=1) + "\n")
    os.replace(tmp, out / LEAGUE_FILE)


def league_params(args: SelfPlayOptions) -> dict:
    """The league's scenario: ``--params`` with the recipes' params overrides of both sides
    (reward weights, observation keys such as the wolves' last sighting) and then ``--set``."""
    hp = dict(parse_override(s) for s in args.hps)
    overrides = recipes_params_overrides({side: recipe(side, args.algo, hp) for side in SIDES})
    overrides.update(parse_override(s) for s in args.sets)
    return resolve_params(args.params, overrides)


def new_league(args: SelfPlayOptions, params: dict, out: Path) -> dict:
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
        if self.model is None:
            return self.name
        return Opponent(self.model.model, side=self.model.side, action_mode=self.model.action_mode, name=self.name)


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


def run_generation(args: SelfPlayOptions, out: Path, league: dict, k: int, side: str, deadline: float | None, rng: random.Random) -> dict | None:
    """Trains generation ``k`` (``side``) with ``wolfpack train``'s trainer and freezes it as a
    member; None when no update finished (interrupted, or no time left)."""
    import torch

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


def evaluate_member(args: SelfPlayOptions, out: Path, league: dict, entry: dict, progress=None, against: list[dict] | None = None) -> list[dict]:
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


# --- the league --------------------------------------------------------------------------------


def open_league(args: SelfPlayOptions) -> dict:
    """The league in ``args.out``: a new one (its folder prepared), or with ``resume`` the one
    there. ValueError naming the problem: a league there without ``resume`` (or none with it),
    an older format, a resumed league given another scenario or recipe, an ``init_*`` that is
    not a run of ``wolfpack train``."""
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
    return league


def selfplay(args: SelfPlayOptions, *, command: str, log: Callable[[str], None] = lambda line: None, on_generation: Callable[[dict], None] | None = None) -> dict:
    """Runs (or with ``resume`` goes on with) the league in ``args.out`` until it holds
    ``generations`` generations or the time limit ends it, and returns the league
    (``league.json``, written after every generation). ``command`` is recorded in the league;
    ``log`` gets a line per generation; ``on_generation(league)`` is called after each one is
    written (the command draws the table and curves there). ValueError on bad input or a
    generation that cannot start (nothing of a finished generation is lost); a Ctrl-C
    propagates, leaving ``league.json`` with the finished generations."""
    from tqdm import tqdm

    league = open_league(args)
    out = Path(args.out)
    league["commands"].append(command)
    no_bars = args.no_progress or not sys.stderr.isatty()
    if not league["generations"] and not league["evaluations"]:
        # The fixed members against each other once: the table's first rows, PFSP's first rates.
        fixed_wolves, fixed_targets = members_of(league, "wolves"), members_of(league, "targets")
        with tqdm(total=len(fixed_wolves) * len(fixed_targets), unit="pair", desc="fixed members", disable=no_bars) as bar:
            for w in fixed_wolves:
                league["evaluations"].extend(evaluate_member(args, out, league, w, bar.update, against=fixed_targets))
    write_league(out, league)
    start = time.perf_counter()
    end = None if args.time_limit is None else start + 60 * args.time_limit
    rng = random.Random(league["seed"] * 1_000_003 + len(league["generations"]))
    while len(league["generations"]) < args.generations:
        k = len(league["generations"]) + 1
        side = league["first"] if k % 2 == 1 else OTHER_SIDE[league["first"]]
        left = args.generations - k + 1
        # This generation's share of what is left, keeping ~10 % of it for the evaluations.
        deadline = None if end is None else time.perf_counter() + 0.9 * max(0.0, end - time.perf_counter()) / left
        if end is not None and end - time.perf_counter() < 30:
            log(f"time limit reached before generation {k}")
            break
        log(f"generation {k}/{args.generations}: {side} learn ({args.pool_sampling} opponents)")
        done = run_generation(args, out, league, k, side, deadline, rng)
        if done is None:
            break
        entry = done["member"]
        pool_size = len(members_of(league, OTHER_SIDE[side]))
        with tqdm(total=pool_size, unit="pair", desc=f"evaluate {entry['name']}", disable=no_bars) as bar:
            rows = evaluate_member(args, out, league, entry, bar.update)
        league["members"].append(entry)
        league["generations"].append(done["generation"])
        league["evaluations"].extend(rows)
        write_league(out, league)
        if on_generation is not None:
            on_generation(league)
        rates = ", ".join(f"{r['targets'] if side == 'wolves' else r['wolves']} {100 * (r['capture_rate'] if side == 'wolves' else 1 - r['capture_rate']):.0f} %" for r in rows)
        log(f"  {entry['name']}: {entry['timesteps']:,} timesteps in {entry['wall_s'] / 60:.1f} min; {'capture' if side == 'wolves' else 'survival'}: {rates}")
    return league
