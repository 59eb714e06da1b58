"""RESULTS.md's tables of the generalist pack's robustness: its exploitability per training seed,
and what the fine-tuning leagues (``wolfpack league --fine-tune``) made of it, each read from
the JSON under ``results/learned/generalist/``."""

from __future__ import annotations

from wolfpack.report import exploitability as exploitability_report
from wolfpack.report import psro as psro_report
from wolfpack.report.blocks import block
from wolfpack.report.documents import Results
from wolfpack.sides import SCRIPTED_LAWS
from wolfpack.stats import iqm_cell, iqm_interval, seed_rates_cell


@block("generalist-exploitability")
def generalist_exploitability(results: Results) -> str:
    """The warm-started generalist's exploitability on hunt-v1, per training seed measured
    (``learned/generalist/imitation-exploit-seed<S>/exploit.json``) and over them."""
    docs = {}
    for folder in sorted((results.root / "learned" / "generalist").glob("imitation-exploit-seed*"), key=lambda p: int(p.name.rsplit("seed", 1)[1])):
        seed = folder.name.rsplit("seed", 1)[1]
        config = results.yaml(f"learned/generalist/imitation-seed{seed}/config.yaml")
        rounds = len(results.json(f"learned/generalist/imitation-seed{seed}/imitation.json"))
        clone = f"`--imitate-rounds {config['imitate_rounds']}`" if config.get("imitate_rounds") else f"`--imitate {config['imitate_min']:g}`: {rounds} rounds"
        docs[f"seed {seed} ({clone})"] = results.json(f"learned/generalist/{folder.name}/exploit.json")
    return exploitability_report.over_training_seeds(docs)


#: The fine-tuning leagues of one plan (``--fine-tune``, Nash, the targets starting from
#: ``escape`` and the seven committed learned escapers), by the generalist's training seed: each
#: league's folder and its final pack's exploitability folder under ``learned/generalist/``.
#: Seed 4's ran first, under the name its models' labels still carry.
POOL_LEAGUES = {
    **{seed: (f"league-pool-seed{seed}", f"league-pool-exploit-seed{seed}") for seed in (0, 1, 2, 3)},
    4: ("league-tuned-seed4", "league-tuned-exploit-seed4"),
}
#: The league from seed 2's pack whose targets started from ``escape`` alone.
ESCAPE_LEAGUE = ("league-tuned-seed2", "league-tuned-exploit-seed2")
#: Seed 4's league again with the uniform meta-solver (fictitious play).
UNIFORM_LEAGUE = ("league-uniform-seed4", "league-uniform-exploit-seed4")
#: Leagues of the POOL_LEAGUES plan but ``--fine-tune wolves`` (the targets' best responses
#: from scratch every iteration), by training seed: the league's folder and its final pack's
#: exploitability folder.
WOLVES_ONLY_LEAGUES = {seed: (f"league-wolves-seed{seed}", f"league-wolves-exploit-seed{seed}") for seed in (2, 0, 1)}
#: The cross-play matrices (``training/evaluate.py --matrix``) of each plan's final packs against
#: ``escape`` and the committed learned escapers.
MATRICES = {"both": "league-pool/matrix", "wolves": "league-wolves/matrix"}


def _members(members: list[str]) -> str:
    return ", ".join(f"`{m}`" for m in members)


def _exploitability_path(doc: dict) -> str:
    return " → ".join(f"{100 * r['exploitability']['wolves']:.0f}" for r in doc["history"])


@block("fine-tuned-league")
def fine_tuned_league(results: Results) -> str:
    """The fine-tuning leagues (``wolfpack league --fine-tune``), one per generalist seed, all of
    one plan: what the league itself measured of the wolves' mixture, iteration by iteration;
    then the league that differs, from seed 2's pack with the targets starting from ``escape``
    alone, in full."""
    docs = {seed: results.json(f"learned/generalist/{league}/league.json") for seed, (league, _) in POOL_LEAGUES.items()}
    first = next(iter(docs.values()))
    plan = ("iterations", "budget", "task", "targets", "meta_solver", "fine_tune")
    for seed, doc in docs.items():
        differs = [k for k in plan if doc.get(k) != first.get(k)]
        if differs:
            raise ValueError(f"{POOL_LEAGUES[seed][0]}: another plan than the other seeds' ({', '.join(differs)})")
    lines = [
        f"{first['iterations']} iterations of {first['budget']:,} agent-steps per side on `{first['task']}`, the wolves starting from each seed's warm-started generalist "
        f"and the targets from {_members(first['targets'])}:",
        "",
        "| training seed | wall time | the wolves' mixture's exploitability, iteration 1 → last (%) | NashConv, last iteration | final wolves' mixture |",
        "|---:|---:|---|---:|---|",
    ]
    for seed, doc in docs.items():
        final = ", ".join(f"`{m}` {w:.2f}" for m, w in doc["final"]["mixtures"]["wolves"].items())
        lines.append(f"| {seed} | {doc['wall_s'] / 60:.0f} min | {_exploitability_path(doc)} | {doc['history'][-1]['nash_conv']:.3f} | {final} |")
    escape = results.json(f"learned/generalist/{ESCAPE_LEAGUE[0]}/league.json")
    lines += [
        "",
        f"From seed 2's pack with the targets starting from {_members(escape['targets'])} alone ({escape['wall_s'] / 60:.0f} min):",
        "",
        psro_report.history_table(escape),
    ]
    return "\n".join(lines)


@block("fine-tuned-exploitability")
def fine_tuned_exploitability(results: Results) -> str:
    """The exploitability of each seed's pack after its fine-tuning league, over the training
    seeds (fresh escapers from scratch, 5 seeds each); then the league that started the targets
    from ``escape`` alone, before and after."""
    docs = {f"seed {seed}: after its fine-tuning league": results.json(f"learned/generalist/{exploit}/exploit.json") for seed, (_, exploit) in POOL_LEAGUES.items()}
    escape = {
        "seed 2, targets from `escape` alone: the warm-started generalist": results.json("learned/generalist/imitation-exploit-seed2/exploit.json"),
        "seed 2, targets from `escape` alone: after its league": results.json(f"learned/generalist/{ESCAPE_LEAGUE[1]}/exploit.json"),
    }
    lines, _ = exploitability_report.packs_table(escape)
    return exploitability_report.over_training_seeds(docs) + "\n" + "\n".join(lines) + "\n"


@block("fine-tuned-side")
def fine_tuned_side(results: Results) -> str:
    """Fine-tuning both sides against fine-tuning the wolves alone, the plan otherwise the same,
    per training seed: what the league measured of its wolves' mixture, what fresh escapers get
    through its final pack, that pack against ``escape`` on hunt-v1's held-out episodes (its
    scorecard) and its worst case against the committed learned escapers (:data:`MATRICES`)."""
    worst = {side: _worst_learned(results.json(f"learned/generalist/{folder}/matrix.json")) for side, folder in MATRICES.items()}
    lines = [
        "| training seed | `--fine-tune` | wall time | the wolves' mixture's exploitability in the league, iteration 1 → last (%) "
        "| final pack: survival of fresh escapers, IQM [95 % CI] | per best-response seed | hunt-v1: captured / wolf collisions | worst committed escaper |",
        "|---:|---|---:|---|---|---|---|---:|",
    ]
    for seed, wolves_only in WOLVES_ONLY_LEAGUES.items():
        for side, (league_folder, exploit_folder) in (("both", POOL_LEAGUES[seed]), ("wolves", wolves_only)):
            doc = results.json(f"learned/generalist/{league_folder}/league.json")
            if doc.get("fine_tune") != (True if side == "both" else side):
                raise ValueError(f"{league_folder}: a league with fine_tune {doc.get('fine_tune')!r}, not {side}")
            b = results.json(f"learned/generalist/{exploit_folder}/exploit.json")["budgets"][0]
            hunt = results.json(f"learned/generalist/{league_folder}/scorecard/scorecard.json")["tasks"]["hunt-v1"]
            seeds = seed_rates_cell(b["per_seed"])
            lines.append(
                f"| {seed} | {side} | {doc['wall_s'] / 60:.0f} min | {_exploitability_path(doc)} | {iqm_cell(b)} | {seeds} "
                f"| {100 * hunt['capture_rate']:.1f} % / {100 * hunt['collision_rate']:.1f} % | {100 * worst[side][f'{league_folder}/final/wolves']:.1f} % |"
            )
    return "\n".join(lines) + "\n"


def _learned_escapers(matrix: dict) -> list[str]:
    """A cross-play matrix's target columns that are models, not the targets' laws."""
    return [t for t in matrix["targets"] if t not in SCRIPTED_LAWS["targets"]]


def _worst_learned(matrix: dict) -> dict[str, float]:
    """Each learned pack of a cross-play matrix (by its label without the algorithm) and its
    lowest capture rate against the learned escapers."""
    learned = _learned_escapers(matrix)
    cells = {(c["wolves"], c["targets"]): c["capture_rate"] for c in matrix["cells"]}
    return {w.split(":", 1)[1]: min(cells[(w, t)] for t in learned) for w in matrix["wolves"] if ":" in w}


@block("meta-solver")
def meta_solver(results: Results) -> str:
    """The meta-solver measured: seed 4's fine-tuning league with the Nash mixture and with the
    uniform one (fictitious play), each final pack's exploitability by fresh escapers."""
    rows = {"nash": POOL_LEAGUES[4], "uniform": UNIFORM_LEAGUE}
    lines = [
        "| meta-solver | wall time | the wolves' mixture's exploitability in the league, iteration 1 → last (%) | final pack: survival of fresh escapers, IQM [95 % CI] | per best-response seed |",
        "|---|---:|---|---|---|",
    ]
    for solver, (league_folder, exploit_folder) in rows.items():
        doc = results.json(f"learned/generalist/{league_folder}/league.json")
        if doc["meta_solver"] != solver:
            raise ValueError(f"{league_folder}: a league of the {doc['meta_solver']} meta-solver, not {solver}")
        b = results.json(f"learned/generalist/{exploit_folder}/exploit.json")["budgets"][0]
        seeds = seed_rates_cell(b["per_seed"])
        lines.append(f"| {solver} | {doc['wall_s'] / 60:.0f} min | {_exploitability_path(doc)} | {iqm_cell(b)} | {seeds} |")
    return "\n".join(lines) + "\n"


@block("fine-tuned-tasks")
def fine_tuned_tasks(results: Results) -> str:
    """Every task of the suite: the fine-tuned packs over their training seeds (each final pack's
    scorecard) beside the packs they started from (``training/generalist.py``'s JSON of those)
    and the best law."""
    before = results.json("learned/generalist/imitation/generalist.json")
    cards = [results.json(f"learned/generalist/{league}/scorecard/scorecard.json") for league, _ in POOL_LEAGUES.values()]
    lines = [
        f"| task | after the leagues: IQM of {len(cards)} seeds [95 % CI] / wolf collisions | per seed ({', '.join(map(str, POOL_LEAGUES))}) | before (the warm-started generalists) | best law |",
        "|---|---|---|---|---|",
    ]
    for task in cards[0]["tasks_played"]:
        rows = [card["tasks"][task] for card in cards]
        captured, collisions = iqm_interval([r["score"] for r in rows]), iqm_interval([r["collision_rate"] for r in rows])
        was, law = before["tasks"][task], before["tasks"][task]["best_law"]
        per_seed = ", ".join(f"{100 * r['score']:g}" for r in rows)
        lines.append(
            f"| `{task}` | {iqm_cell(captured)} / {100 * collisions['iqm']:.1f} % | {per_seed} | "
            f"{100 * was['captured']['iqm']:.1f} % / {100 * was['collisions']['iqm']:.1f} % | `{law['name']}` {100 * law['captured']:.1f} % |"
        )
    return "\n".join(lines) + "\n"


@block("fine-tuned-escapers")
def fine_tuned_escapers(results: Results) -> str:
    """The fine-tuned packs and the laws against ``escape`` and every committed learned escaper
    (``training/evaluate.py --matrix``'s JSON): capture rate and, against ``escape``, wolf
    collisions; the last column each pack's worst case over the learned escapers."""
    doc = results.json("learned/generalist/league-pool/matrix/matrix.json")
    cells = {(c["wolves"], c["targets"]): c for c in doc["cells"]}
    learned = _learned_escapers(doc)
    header = " | ".join(f"`{t.split(':', 1)[1]}`" for t in learned)
    lines = [f"| wolves | `escape` (collisions) | {header} | worst learned |", "|---|---:|" + "---:|" * len(learned) + "---|"]
    for w in doc["wolves"]:
        rates = [cells[(w, t)]["capture_rate"] for t in learned]
        escape = cells[(w, "escape")]
        worst = min(range(len(learned)), key=lambda k: rates[k])
        name = f"`{w}`" if ":" not in w else f"`{w.split(':', 1)[1]}`"
        lines.append(
            f"| {name} | {100 * escape['capture_rate']:.1f} % ({100 * escape['collision_rate']:.1f} %) | " + " | ".join(f"{100 * r:.1f}" for r in rates) + f" | **{100 * rates[worst]:.1f} %** |"
        )
    return "\n".join(lines) + "\n"
