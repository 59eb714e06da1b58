"""RESULTS.md's tables of the generalist pack's robustness: its exploitability per training seed,
and what the fine-tuning leagues (``wolfpack league --fine-tune``) made of it, each read from
the JSON under ``results/learned/generalist/``."""

from __future__ import annotations

from wolfpack.report import exploitability as exploitability_report
from wolfpack.report import psro as psro_report
from wolfpack.report.blocks import block
from wolfpack.report.documents import Results


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


def _tuned_seeds(results: Results) -> list[str]:
    """The training seeds of the generalist whose pack a fine-tuning league went on from and
    whose result was measured (``learned/generalist/league-tuned-exploit-seed<S>``)."""
    found = (results.root / "learned" / "generalist").glob("league-tuned-exploit-seed*")
    return sorted((p.name.rsplit("seed", 1)[1] for p in found), key=int)


@block("fine-tuned-league")
def fine_tuned_league(results: Results) -> str:
    """Each fine-tuning league's history (``wolfpack league --fine-tune`` from a generalist seed)."""
    parts = []
    for seed in _tuned_seeds(results):
        doc = results.json(f"learned/generalist/league-tuned-seed{seed}/league.json")
        targets = ", ".join(f"`{t}`" for t in doc["targets"])
        parts.append(
            f"From seed {seed}'s pack, the targets' population starting with {targets}; {doc['iterations']} iterations of {doc['budget']:,} agent-steps per side ({doc['wall_s'] / 60:.0f} min):\n\n"
            + psro_report.history_table(doc)
        )
    return "\n".join(parts)


@block("fine-tuned-exploitability")
def fine_tuned_exploitability(results: Results) -> str:
    """The exploitability of each generalist seed's pack before and after its fine-tuning league,
    measured the same way (fresh escapers from scratch, 5 seeds)."""
    docs = {}
    for seed in _tuned_seeds(results):
        docs[f"seed {seed}: the warm-started generalist"] = results.json(f"learned/generalist/imitation-exploit-seed{seed}/exploit.json")
        docs[f"seed {seed}: after the fine-tuning league (its final pack)"] = results.json(f"learned/generalist/league-tuned-exploit-seed{seed}/exploit.json")
    lines, _ = exploitability_report.packs_table(docs)
    return "\n".join(lines) + "\n"
