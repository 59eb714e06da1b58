"""The generated tables of RESULTS.md, README.md and docs/tasks.md, each a function of the
results folder registered under the marker name its document uses (``BLOCKS``;
:mod:`wolfpack.report.documents` rewrites the blocks, ``training/results_report.py`` is the
command). Each table reads the JSON that a script of ``training/`` wrote (evaluate.py's
``results.json`` and ``matrix/matrix.json``, the leagues' ``league.json``, seeds.py's
``seeds.json``, the training runs' summaries, the benchmark's ``baselines.json`` /
``learned.json``) and formats with the same report functions that script uses, so a table here
reads exactly as that script prints it."""

from __future__ import annotations

import re
from pathlib import Path

from wolfpack.learn.matches import opponents_of
from wolfpack.report import benchmark as benchmark_report
from wolfpack.report import evaluation as evaluation_report
from wolfpack.report import exploitability as exploitability_report
from wolfpack.report import generalist_tables  # noqa: F401  (registers the generalist's blocks)
from wolfpack.report import league as league_report
from wolfpack.report import seeds as seeds_report
from wolfpack.report.blocks import BLOCKS as BLOCKS  # every block, the generalist's included
from wolfpack.report.blocks import block
from wolfpack.report.documents import Results, bold, change, interval, millions, minutes, percent, row_of
from wolfpack.sides import SCRIPTED_LAWS
from wolfpack.stats import iqm_cell, range_cell

# --- the tables ----------------------------------------------------------------------------------


@block("training-runs")
def training_runs(results: Results) -> str:
    """The three committed models' budgets, wall times and sizes, from their run folders
    (train.py's ``train_summary.json``, imitate.py's ``imitation.json``, both ``config.yaml``)."""
    lines = ["| run | budget | wall time | timesteps (agent-steps) | throughput |", "|---|---|---|---|---|"]
    for name in ("escape_ppo", "wolves_bc_vel_b", "wolves_ft"):
        folder = f"models/{name}"
        if (results.root / folder / "imitation.json").is_file():
            lines.append(imitation_row(name, results.json(f"{folder}/imitation.json")))
        else:
            lines.append(ppo_row(name, results.yaml(f"{folder}/config.yaml"), results.json(f"{folder}/train_summary.json")))
    return "\n".join(lines)


def imitation_row(name: str, imitation: dict) -> str:
    """Imitation runs on imitate.py's defaults; its size is the DAgger data set it ended with."""
    last = imitation["rounds"][-1]
    return f"| `{name}` (BC + {len(imitation['rounds'])} DAgger rounds) | defaults | {minutes(last['elapsed_s'])} | {last['samples'] / 1e6:.2f} M labelled states | |"


def ppo_row(name: str, config: dict, summary: dict) -> str:
    """A PPO run's budget is whichever of its two limits stopped it; a wolf slot is one agent,
    so its timesteps are world steps times the pack."""
    per_world = round(summary["timesteps"] / summary["world_steps"])
    worlds = f"{config['num_envs']} worlds × {per_world} {config['side']}" if per_world > 1 else f"{config['side']}, {config['num_envs']} worlds"
    what = "PPO fine-tuning" if config.get("init_from") else "PPO"
    if summary["stopped_by_time_limit"]:
        limit = re.search(r"--time-limit (\S+)", config["command"])
        budget, wall = f"`--time-limit {limit.group(1)}`", f"{minutes(summary['wall_s'])} (stopped by the limit)"
    else:
        budget, wall = f"{config['timesteps'] / 1e6:.0f} M timesteps", minutes(summary["wall_s"])
    steps = millions(summary["timesteps"]) + (f" ({millions(summary['world_steps'])} world steps)" if per_world > 1 else "")
    return f"| `{name}` ({what}, {worlds}) | {budget} | {wall} | {steps} | {summary['timesteps_per_s'] / 1e3:.1f} k/s |"


@block("evaluation")
def evaluation(results: Results) -> str:
    """evaluate.py's table of ``results.json`` as evaluate.py prints it."""
    return evaluation_report.markdown(results.json("results.json")["rows"])


# --- the SB3-era sections: the scenario's wall factor, (a), (b), the laws against (a) ------------

#: evaluate.py's scripted rows in the two worlds of "The scenario's decisions": the default is
#: the reference's target wall factor κ 1.6 / 1.3, the source document's is 1.2 / 1.2 (and the
#: world the SB3 models were trained in). ``results.json`` is the 200 episodes of the default.
WALL_FACTOR_RUNS = (
    ("1.6 / 1.3 (default, reference)", "results.json"),
    ("1.2 / 1.2 (source document)", "wall_factor/source_200/results.json"),
    ("1.6 / 1.3 (default, reference)", "wall_factor/reference_1000/results.json"),
    ("1.2 / 1.2 (source document)", "wall_factor/source_1000/results.json"),
)
#: The source document's wall factor, 200 episodes: the world of the SB3 models' own params.
SOURCE_WALL = "wall_factor/source_200/results.json"
LAWS = SCRIPTED_LAWS["wolves"]


@block("wall-factor")
def wall_factor(results: Results) -> str:
    """seed000 against escape in the two wall-factor worlds, 200 and 1,000 episodes."""
    lines = ["| target's wall κ | episodes | captured | wolf collisions | timeout | median capture step | ever cornered |", "|---|---|---|---|---|---|---|"]
    for label, file in WALL_FACTOR_RUNS:
        r = row_of(results.json(file), "seed000", "escape")
        lines.append(
            f"| {label} | {r['episodes']} | {percent(r['capture_rate'])} | {percent(r['collision_rate'])} | {percent(r['timeout_rate'])} "
            f"| {r['median_capture_steps']:g} | {percent(r['ever_cornered_rate'])} |"
        )
    return "\n".join(lines)


@block("escape-ppo")
def escape_ppo(results: Results) -> str:
    """(a): the SB3 escaper against seed000 beside the scripted escape target, both on the model's
    params (κ 1.2)."""
    scripted = row_of(results.json(SOURCE_WALL), "seed000", "escape")
    learned = row_of(results.json("results.json"), "seed000", "ppo:escape_ppo")
    wall = results.json("models/escape_ppo/train_summary.json")["wall_s"]
    ratio = learned["survival_rate"] / scripted["survival_rate"]
    return "\n".join(
        [
            "| target vs seed000 wolves (κ = 1.2, the model's params) | survived (not captured) | 95% CI | vs scripted escape |",
            "|---|---|---|---|",
            f"| scripted `escape` | {percent(scripted['survival_rate'])} | {interval(scripted['capture_rate_ci95'], survival=True)} | 1× |",
            f"| PPO, final model ({wall / 60:.0f} min) | **{percent(learned['survival_rate'])}** | {interval(learned['capture_rate_ci95'], survival=True)} | **{ratio:.1f}×** |",
        ]
    )


@block("wolves-imitation")
def wolves_imitation(results: Results) -> str:
    """(b): the imitation clone and its PPO fine-tuning beside seed000, on the models' params (κ 1.2)."""
    law = row_of(results.json(SOURCE_WALL), "seed000", "escape")
    rows = results.json("results.json")
    clone, tuned = row_of(rows, "imitation:wolves_bc_vel_b", "escape"), row_of(rows, "ppo:wolves_ft", "escape")
    clone_min = results.json("models/wolves_bc_vel_b/imitation.json")["rounds"][-1]["elapsed_s"] / 60
    tuned_min = results.json("models/wolves_ft/train_summary.json")["wall_s"] / 60

    def line(name: str, r: dict, capture: str, steps: str, energy: str) -> str:
        return f"| {name} | {capture} | {interval(r['capture_rate_ci95'])} | {steps} | {percent(r['collision_rate'])} | {energy} |"

    return "\n".join(
        [
            "| wolves vs scripted escape (κ = 1.2, the models' params) | capture | 95% CI | median capture step | wolf collisions | energy (J) |",
            "|---|---|---|---|---|---|",
            line("seed000 (analytic)", law, percent(law["capture_rate"]), f"{law['median_capture_steps']:.1f}", f"{law['mean_energy']:.0f}"),
            line(
                f"imitation (BC + DAgger), {clone_min:.0f} min",
                clone,
                f"{percent(clone['capture_rate'])} (**{percent(clone['capture_rate'] / law['capture_rate'])} of seed000**)",
                f"{clone['median_capture_steps']:.1f}",
                f"{clone['mean_energy']:.0f}",
            ),
            line(
                f"imitation + PPO fine-tuning, {tuned_min:.0f} min",
                tuned,
                percent(tuned["capture_rate"]),
                f"**{tuned['median_capture_steps']:.1f} ({change(tuned['median_capture_steps'], law['median_capture_steps'])})**",
                f"**{tuned['mean_energy']:.0f} ({change(tuned['mean_energy'], law['mean_energy'])})**",
            ),
        ]
    )


@block("laws-vs-escape-ppo")
def laws_vs_escape_ppo(results: Results) -> str:
    """The three laws against the scripted escape target in both wall-factor worlds and against the
    SB3 escaper of (a) (the matrix's cells: the wall factor steers only the scripted target)."""
    source, default, matrix = results.json(SOURCE_WALL), results.json("results.json"), results.json("matrix/matrix.json")
    lines = [
        "| wolves vs | scripted escape, κ 1.2: captured / collisions / median | scripted escape, defaults (κ 1.6 / 1.3) | learned escape (a): captured (95 % CI) / median / collisions |",
        "|---|---|---|---|",
    ]

    def short(r: dict) -> str:
        return f"{percent(r['capture_rate'])} / {percent(r['collision_rate'])} / {r['median_capture_steps']:g}"

    for law in LAWS:
        learned = row_of(matrix, law, "ppo:escape_ppo")
        lo, hi = learned["capture_rate_ci95"]
        lines.append(
            f"| {law} | {short(row_of(source, law, 'escape'))} | {short(row_of(default, law, 'escape'))} "
            f"| {percent(learned['capture_rate'])} ({100 * lo:.1f}–{100 * hi:.1f}) / {learned['median_capture_steps']:g} / {percent(learned['collision_rate'])} |"
        )
    return "\n".join(lines)


# --- the SB3 leagues against the targets set for them ----------------------------------------------

#: What the SB3 leagues were asked to reach (capture or survival rates, seeds 0–199).
LEAGUE_WOLVES_VS_ESCAPE = 0.97
LEAGUE_WOLVES_VS_ESCAPER = 0.90
LEAGUE_COLLISIONS = 0.01
LEAGUE_ESCAPER_SURVIVAL = 0.50
LEAGUE_HOURS_PER_SIDE = 2


def model_name(policy: str) -> str:
    """``league/wolves_g06`` for ``ppo:league/wolves_g06``: a model without its kind."""
    return policy.split(":", 1)[1]


@block("league-targets")
def league_targets(results: Results) -> str:
    """The targets set for the SB3 leagues, each measured on the cross-play matrix's SB3-era cut
    and the league's wall times, and whether it was met."""
    doc = results.json("matrix/matrix.json")
    cells = {(c["wolves"], c["targets"]): c for c in doc["cells"]}
    wolves = [w for w in doc["wolves"] if ":" in w and trained_by_sb3(w)]
    escapers = [t for t in doc["targets"] if ":" in t and trained_by_sb3(t)]

    def capture(w: str, t: str) -> float:
        return cells[w, t]["capture_rate"]

    def collisions(w: str, t: str) -> float:
        return cells[w, t]["collision_rate"]

    def survival(t: str, w: str) -> float:
        return 1 - capture(w, t)

    def yes_no(met: bool, why: str = "") -> str:
        return "yes" if met else f"**no**{why}"

    rows = []

    best = max(wolves, key=lambda w: capture(w, "escape"))
    league = [capture(w, "escape") for w in wolves if w.startswith("ppo:league/")]
    rows.append(
        (
            f"learned wolves ≥ {100 * LEAGUE_WOLVES_VS_ESCAPE:.0f} % against scripted escape",
            f"best learned: {model_name(best)} {percent(capture(best, 'escape'))} ({percent(collisions(best, 'escape'))} collisions); league wolves {100 * min(league):.0f}–{100 * max(league):.0f} %",
            yes_no(capture(best, "escape") >= LEAGUE_WOLVES_VS_ESCAPE),
        )
    )

    best = max(wolves, key=lambda w: capture(w, "ppo:escape_ppo"))
    rate = capture(best, "ppo:escape_ppo")
    lo, hi = cells[best, "ppo:escape_ppo"]["capture_rate_ci95"]
    rows.append(
        (
            f"learned wolves ≥ {100 * LEAGUE_WOLVES_VS_ESCAPER:.0f} % against the learned escaper escape_ppo",
            f"best: {model_name(best)} {percent(rate)} ({100 * lo:.0f}–{100 * hi:.0f} %)",
            yes_no(rate >= LEAGUE_WOLVES_VS_ESCAPER, f" ({100 * (LEAGUE_WOLVES_VS_ESCAPER - rate):.1f} points short)"),
        )
    )

    both = ("escape", "ppo:escape_ppo")
    law = max(LAWS, key=lambda w: min(capture(w, t) for t in both))
    better = [w for w in LAWS if all(capture(w, t) >= capture(best, t) and collisions(w, t) <= collisions(best, t) for t in both)]

    def spread(w: str) -> str:
        return f"{100 * min(collisions(w, t) for t in both):.1f}–{100 * max(collisions(w, t) for t in both):.1f} %"

    met = all(collisions(best, t) <= LEAGUE_COLLISIONS for t in both) and not better
    rows.append(
        (
            f"… with ≤ {100 * LEAGUE_COLLISIONS:.0f} % wolf collisions, better than every analytic law on both",
            f"{model_name(best)}: {spread(best)} collisions; {law}: {' / '.join(percent(capture(law, t)) for t in both)} with {spread(law)}",
            yes_no(met, f": {' and '.join(better)} {'is' if len(better) == 1 else 'are'} better on both" if better else ""),
        )
    )

    best = max(escapers, key=lambda t: min(survival(t, w) for w in LAWS))
    beaten = [w for w in LAWS if any(survival(t, w) >= LEAGUE_ESCAPER_SURVIVAL for t in escapers)]
    rows.append(
        (
            f"a learned escaper survives ≥ {100 * LEAGUE_ESCAPER_SURVIVAL:.0f} % against each of {', '.join(LAWS[:-1])} and {LAWS[-1]}",
            f"best against its worst law: {model_name(best)} {' / '.join(percent(survival(best, w)) for w in LAWS)}; "
            f"survived ≥ {100 * LEAGUE_ESCAPER_SURVIVAL:.0f} % by some escaper: {', '.join(beaten) or 'none'}",
            yes_no(len(beaten) == len(LAWS) and min(survival(best, w) for w in LAWS) >= LEAGUE_ESCAPER_SURVIVAL, f" ({', '.join(beaten)} only)" if beaten else ""),
        )
    )

    wall = {}
    for g in results.json("league/league.json")["generations"]:
        wall[g["side"]] = wall.get(g["side"], 0.0) + g["wall_s"] / 60
    rows.append(
        (
            f"within ≤ {LEAGUE_HOURS_PER_SIDE} h per side on 2 cores",
            "league: " + " and ".join(f"{m:.0f} min ({side})" for side, m in wall.items()),
            yes_no(max(wall.values()) <= 60 * LEAGUE_HOURS_PER_SIDE),
        )
    )
    return "\n".join(["| target | measured (seeds 0–199) | met? |", "|---|---|---|", *(f"| {a} | {b} | {c} |" for a, b, c in rows)])


@block("league")
def league(results: Results) -> str:
    """The SB3 league's table, as selfplay.py writes league.md."""
    return league_report.league_table(results.json("league/league.json"))


def trained_by_sb3(policy: str) -> bool:
    """A law, or a model of the SB3 era (``ppo:``, ``imitation:``) — the policies the section on
    the SB3 leagues compares; the native trainer's (``mappo:``) are discussed in (f)."""
    return ":" not in policy or policy.split(":", 1)[0] in ("ppo", "imitation")


@block("matrix")
def matrix(results: Results) -> str:
    """The cross-play table of the laws and SB3 models, cut from ``matrix.json`` (which holds the
    native models as well, same cells to the episode), worst cases over that cut."""
    doc = results.json("matrix/matrix.json")
    wolves = [w for w in doc["wolves"] if trained_by_sb3(w)]
    targets = [t for t in doc["targets"] if trained_by_sb3(t)]
    cells = [c for c in doc["cells"] if c["wolves"] in wolves and c["targets"] in targets]
    cut = {**doc, "wolves": wolves, "targets": targets, "cells": cells, "robustness": evaluation_report.robustness(cells, wolves, targets)}
    return evaluation_report.matrix_summary_markdown(cut)


#: How RESULTS.md names seeds.py's opponents (a name not here stands as it is).
OPPONENT_LABELS = {
    "ppo:escape_ppo": "ppo:escape_ppo (the committed learned escaper)",
    "ppo:league/targets_g01": "SB3 league targets_g01",
    "ppo:league/targets_g03": "SB3 league targets_g03",
    "ppo:league/targets_g05": "SB3 league targets_g05",
    "mappo:targets_g01": "native league targets_g01",
    "mappo:targets_g03": "native league targets_g03",
    "mappo:native_wolves_mappo_s0": "MAPPO wolves of (e), seed 0",
    "mappo:wolves_pool_s0": "pool-trained wolves of (g), seed 0",
    "ppo:targets_long/targets_g01": "targets_long targets_g01 (45 min, against the laws)",
}
#: (g)'s names where they differ: its first opponent is one of the pool, the one played during training.
POOL_LABELS = {"escape": "escape (scripted; evaluated during training)", "still": "still (`--against still`)"}


def seeds_table(doc: dict, header: str, emphasised: tuple[str, ...]) -> str:
    """seeds.py's table of ``seeds.json`` with RESULTS.md's names: the first opponent is the one
    the seeds trained against, and its ``emphasised`` cells ("skill", "collisions") are bold."""
    lines = [header, "|---|---|---|---|---|"]
    for k, (name, entry) in enumerate(doc["opponents"].items()):
        label = OPPONENT_LABELS.get(name, name) + (" (trained against)" if k == 0 else "")
        step = seeds_report.median_capture_step(entry["rows"])
        skill = bold(iqm_cell(entry["skill"]), k == 0 and "skill" in emphasised)
        collisions = bold(iqm_cell(entry["collision_rate"]), k == 0 and "collisions" in emphasised)
        lines.append(f"| {label} | {skill} | {range_cell(entry['skill'])} | {collisions} | {'—' if step is None else f'{step:g}'} |")
    return "\n".join(lines)


@block("wolves-mappo-seeds")
def wolves_mappo_seeds(results: Results) -> str:
    """(e): five seeds of native MAPPO wolves."""
    header = "| target | captured: IQM [95 % CI] | median (range) | wolf collisions: IQM [95 % CI] | median capture step |"
    return seeds_table(results.json("learned/wolves_mappo/seeds.json"), header, ("skill", "collisions"))


@block("targets-mappo-seeds")
def targets_mappo_seeds(results: Results) -> str:
    """(i): five seeds of the native escaper."""
    header = "| wolves | survival IQM [95 % CI] | median (range) | wolf collisions IQM [95 % CI] | median capture step |"
    return seeds_table(results.json("learned/targets_mappo/seeds.json"), header, ("skill",))


@block("wolves-pool-seeds")
def wolves_pool_seeds(results: Results) -> str:
    """(g): five seeds of wolves trained against a pool of escapers, and whether each opponent of
    the evaluation was in that pool (read from the runs' ``config.yaml``)."""
    doc = results.json("learned/wolves_pool/seeds.json")
    pools = {tuple(results.yaml(f"learned/wolves_pool/{Path(run).name}/config.yaml")["opponent_pool"]) for run in doc["runs"]}
    if len(pools) != 1:
        raise ValueError("the pool's training seeds trained against different pools")
    specs = [results.model_path(spec) for spec in pools.pop()]
    pool = {p if isinstance(p, str) else p.label for p in opponents_of("wolves", specs)}
    lines = ["| target | in the pool? | captured: IQM [95 % CI] | median (range) | wolf collisions: IQM [95 % CI] | median capture step |", "|---|---|---|---|---|---|"]
    for k, (name, entry) in enumerate(doc["opponents"].items()):
        label = POOL_LABELS.get(name, OPPONENT_LABELS.get(name, name))
        step = seeds_report.median_capture_step(entry["rows"])
        learned = ":" in name
        in_pool = "yes" if name in pool else bold("no", learned)
        lines.append(
            f"| {label} | {in_pool} | {bold(iqm_cell(entry['skill']), k < 2)} | {range_cell(entry['skill'])} "
            f"| {bold(iqm_cell(entry['collision_rate']), k == 0)} | {'—' if step is None else f'{step:g}'} |"
        )
    return "\n".join(lines)


#: Seed 0 of each algorithm shared the cores with other work, so its speed is not comparable.
SPEED_EXCLUDED_SEEDS = {0}


def training_speeds(results: Results, folder: str) -> dict[int, float]:
    """Training seed → agent-steps per second, for the runs of ``folder``'s seeds.json whose
    speed is comparable."""
    speeds = {}
    for run in results.json(f"{folder}/seeds.json")["runs"]:
        name = Path(run).name
        seed = results.yaml(f"{folder}/{name}/config.yaml")["seed"]
        if seed not in SPEED_EXCLUDED_SEEDS:
            speeds[seed] = results.json(f"{folder}/{name}/summary.json")["this_invocation"]["agent_steps_per_s"]
    return speeds


@block("ippo-vs-mappo")
def ippo_vs_mappo(results: Results) -> str:
    """(h): the two critics at a fixed budget, speed and skill side by side."""
    speeds = {algo: training_speeds(results, f"learned/ippo_vs_mappo/{algo}") for algo in ("ippo", "mappo")}
    timed = sorted(set().union(*speeds.values()))
    lines = [
        f"| algorithm | agent-steps/s (seeds {timed[0]}–{timed[-1]}) | against escape: captured IQM [95 % CI] | collisions IQM [95 % CI] | against escape_ppo: captured |",
        "|---|---|---|---|---|",
    ]
    for algo, per_seed in speeds.items():
        opponents = results.json(f"learned/ippo_vs_mappo/{algo}/seeds.json")["opponents"]
        lines.append(
            f"| {algo.upper()} | {min(per_seed.values()) / 1e3:.0f}–{max(per_seed.values()) / 1e3:.0f} k | {iqm_cell(opponents['escape']['skill'])} "
            f"| {iqm_cell(opponents['escape']['collision_rate'])} | {iqm_cell(opponents['ppo:escape_ppo']['skill'])} |"
        )
    return "\n".join(lines)


@block("native-league")
def native_league(results: Results) -> str:
    """(f): the league on the native trainer, whose generations count agent-steps."""
    return league_report.league_table(results.json("league_native/league.json"), steps_header="agent-steps")


@block("environment-share")
def environment_share(results: Results) -> str:
    """Where the SB3 runs' training time went, from train.py's ``train_summary.json``."""
    lines = ["| run | training wall time | inside the environment | rollout collection (env + policy inference + SB3) | gradient updates |", "|---|---|---|---|---|"]
    for name in ("escape_ppo", "wolves_ft"):
        s = results.json(f"models/{name}/train_summary.json")
        worlds = results.yaml(f"models/{name}/config.yaml")["num_envs"]
        slots = worlds * round(s["timesteps"] / s["world_steps"])
        total = s["training_s"]
        lines.append(
            f"| `{name}` ({worlds} worlds, {slots} slots) | {total:.0f} s | {s['env_s']:.0f} s (**{percent(s['env_share_of_training'])}**) "
            f"| {s['collect_s']:.0f} s ({percent(s['collect_s'] / total)}) | {s['update_s']:.0f} s ({percent(s['update_s'] / total)}) |"
        )
    return "\n".join(lines)


def benchmark_baselines(results: Results) -> dict:
    """Every baseline of the benchmark per side, as benchmark_report.py collects them (the
    learned ones only once learned.json exists)."""
    learned_file = results.root / "benchmark" / "learned.json"
    learned = results.json("benchmark/learned.json") if learned_file.is_file() else {}
    return benchmark_report.collect(results.json("benchmark/baselines.json"), learned)


@block("benchmark")
def benchmark(results: Results) -> str:
    """The benchmark's per-task table of every baseline, as benchmark_report.py writes it."""
    return benchmark_report.tables_markdown(benchmark_baselines(results), heading="###")


@block("exploitability")
def exploitability_table(results: Results) -> str:
    """Best-response escapers against each law and the best learned wolves, as exploitability.py writes it."""
    return exploitability_report.table(results.json("benchmark/exploitability/exploitability.json"))


@block("front-page-benchmark")
def front_page_benchmark(results: Results) -> str:
    """README's short benchmark table: per task the best law and the best learner of each side."""
    return benchmark_report.front_page_markdown(benchmark_baselines(results))
