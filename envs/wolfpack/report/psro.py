"""``wolfpack league``'s ``league.json`` as Markdown: the exploitability of each side's Nash
mixture iteration after iteration, and the final mixtures (what the command prints and
RESULTS.md shows)."""

from __future__ import annotations


def history_table(doc: dict) -> str:
    """Per iteration the populations, the game's value, each mixture's exploitability and
    NashConv; then the final mixtures."""
    lines = [
        "| iteration | members (wolves / targets) | game value (capture) | wolves' exploitability | targets' exploitability | NashConv |",
        "|---:|---|---:|---:|---:|---:|",
    ]
    for r in doc["history"]:
        ex = r["exploitability"]
        lines.append(
            f"| {r['iteration']} | {r['population']['wolves']} / {r['population']['targets']} | {100 * r['value']:.1f} % | {100 * ex['wolves']:.1f} % | {100 * ex['targets']:.1f} % | {r['nash_conv']:.3f} |"
        )
    final = doc["final"]
    lines += ["", f"Final mixtures (game value {100 * final['value']:.1f} %): wolves {_mix(final['mixtures']['wolves'])}; targets {_mix(final['mixtures']['targets'])}.", ""]
    return "\n".join(lines)


def markdown(doc: dict) -> str:
    """league.json as the command prints it: what was run, then :func:`history_table`."""
    return "\n".join(
        [
            f"# League on `{doc['task']}`: {doc['iterations']} iterations of {doc['budget']:,} agent-steps per side",
            "",
            "Exploitability of each side's Nash mixture: the survival of the targets' best response against the wolves' mixture, the capture rate of the wolves' best response against the targets' mixture.",
            "",
            history_table(doc),
        ]
    )


def _mix(weights: dict[str, float]) -> str:
    return ", ".join(f"`{m}` {w:.2f}" for m, w in weights.items())
