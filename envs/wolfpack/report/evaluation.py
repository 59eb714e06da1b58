"""Tables and figures of policies played against each other (``training/evaluate.py``): the rows
of a set of pairings, and the cross-play matrix with each policy's worst case."""

from __future__ import annotations

import json
import re
from pathlib import Path

from wolfpack.task import PLAYER_SECTIONS, TASK_ORDER, task_params

COLUMNS = (
    ("wolves", "wolves", "{}"),
    ("targets", "targets", "{}"),
    ("capture", "capture_rate", "{:.1%}"),
    ("95% CI", "capture_rate_ci95", None),
    ("median steps", "median_capture_steps", "{:.1f}"),
    ("mean steps", "mean_capture_steps", "{:.1f}"),
    ("wolf coll.", "collision_rate", "{:.1%}"),
    ("target coll.", "target_collision_rate", "{:.1%}"),
    ("timeout", "timeout_rate", "{:.1%}"),
    ("cornered", "cornered_rate", "{:.1%}"),
    ("success", "success_rate", "{:.1%}"),
    ("ever cornered", "ever_cornered_rate", "{:.1%}"),
    ("energy (J)", "mean_energy", "{:.0f}"),
    ("return wolf", "mean_return_wolves", "{:.2f}"),
    ("return target", "mean_return_targets", "{:.2f}"),
    ("target–wall (m)", "median_final_target_wall_distance", "{:.2f}"),
)


def markdown(rows: list[dict]) -> str:
    lines = ["| " + " | ".join(c[0] for c in COLUMNS) + " |", "|" + "---|" * len(COLUMNS)]
    for r in rows:
        cells = []
        for _, key, fmt in COLUMNS:
            v = r[key]
            if key == "capture_rate_ci95":
                cells.append(f"{v[0]:.1%}–{v[1]:.1%}")
            elif v is None:
                cells.append("–")
            else:
                cells.append(fmt.format(v))
        lines.append("| " + " | ".join(cells) + " |")
    return "\n".join(lines)


def plot(rows: list[dict], out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    names = [f"{r['wolves']}\nvs {r['targets']}" for r in rows]
    rates = np.array([r["capture_rate"] for r in rows])
    # Clipped at 0: at a rate of 0 or 1 the Wilson bound can round a hair inside the rate.
    lo = np.clip(rates - np.array([r["capture_rate_ci95"][0] for r in rows]), 0, None)
    hi = np.clip(np.array([r["capture_rate_ci95"][1] for r in rows]) - rates, 0, None)
    fig, ax = plt.subplots(figsize=(max(5, 1.3 * len(rows)), 4))
    ax.bar(range(len(rows)), rates * 100, yerr=[lo * 100, hi * 100], capsize=4, color="tab:blue", alpha=0.8)
    ax.set_xticks(range(len(rows)), names, fontsize=8)
    ax.set_ylabel("capture rate (%), 95% Wilson interval")
    ax.set_ylim(0, 105)
    ax.set_title(f"{rows[0]['episodes']} episodes per row, seeds {rows[0]['first_seed']}–{rows[0]['first_seed'] + rows[0]['episodes'] - 1}")
    fig.tight_layout()
    fig.savefig(out / "capture_rates.png", dpi=120)
    plt.close(fig)

    from wolfpack.plots import line_styles

    fig, ax = plt.subplots(figsize=(9, 4), layout="constrained")
    for r, name, (colour, style) in zip(rows, names, line_styles(len(rows))):
        steps = np.sort(np.array(r["capture_steps"], dtype=float))
        if len(steps) == 0:
            continue
        # Empirical capture-time curve: fraction of all episodes captured by step t.
        frac = np.arange(1, len(steps) + 1) / r["episodes"]
        ax.step(np.concatenate([[0], steps]), np.concatenate([[0], frac]) * 100, where="post", color=colour, linestyle=style, label=name.replace("\n", " "))
    ax.set_xlabel("step")
    ax.set_ylabel("episodes captured by this step (%)")
    ax.set_ylim(0, 100)
    ax.grid(alpha=0.3)
    if ax.get_legend_handles_labels()[0]:
        ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)  # outside the data
    fig.savefig(out / "capture_times.png", dpi=120)
    plt.close(fig)


def scenario_name(params: dict) -> str:
    """The named task whose world ``params`` are (``hunt-v1``, the documented scenario: …), or
    what they are when they match none (who plays, what a learner observes and is paid aside:
    ``wolfpack.task.PLAYER_SECTIONS``): tables and figures say which scenario they come from."""

    def world(p: dict) -> dict:  # as JSON holds it (tuples become lists)
        return json.loads(json.dumps({k: v for k, v in p.items() if k not in PLAYER_SECTIONS}))

    for name in TASK_ORDER:
        if world(params) == world(task_params(name)):
            return f"task `{name}`" + (" (the documented scenario, params.yaml)" if name == "hunt-v1" else "")
    return "params of no named task (the `params` of the JSON beside this file)"


def matrix_summary_markdown(doc: dict) -> str:
    """The cross-play table alone (capture rate, interval and collisions per cell, each policy's
    worst case): what RESULTS.md quotes, without the every-column table below it."""
    by = {(c["wolves"], c["targets"]): c for c in doc["cells"]}
    wolves, targets, rob = doc["wolves"], doc["targets"], doc["robustness"]
    lines = [
        f"Capture rate (95 % interval) · wolf collisions; {doc['episodes']} episodes per cell, seeds {doc['seed']}–{doc['seed'] + doc['episodes'] - 1}; played in {scenario_name(doc['params'])}.",
        "",
        "| wolves \\ targets | " + " | ".join(targets) + " | worst case (capture) |",
        "|---|" + "---|" * (len(targets) + 1),
    ]
    for w in wolves:
        cells = []
        for t in targets:
            c = by[(w, t)]
            lo, hi = c["capture_rate_ci95"]
            cells.append(f"{c['capture_rate']:.1%} ({lo:.0%}–{hi:.0%}) · {c['collision_rate']:.1%}")
        r = rob["wolves"][w]
        cells.append(f"**{r['worst_capture_rate']:.1%}** vs {r['against']}")
        lines.append(f"| {w} | " + " | ".join(cells) + " |")
    lines.append("| worst case (survival) | " + " | ".join(f"**{rob['targets'][t]['worst_survival_rate']:.1%}** vs {rob['targets'][t]['against']}" for t in targets) + " | |")
    return "\n".join(lines)


def matrix_markdown(doc: dict) -> str:
    """matrix.md: the cross-play table, then every cell with every column."""
    return "\n".join([matrix_summary_markdown(doc), "", "Every cell, every column:", "", markdown(doc["cells"])])


def matrix_plot(doc: dict, path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    wolves, targets, rob = doc["wolves"], doc["targets"], doc["robustness"]
    by = {(c["wolves"], c["targets"]): c for c in doc["cells"]}
    grid = np.array([[by[(w, t)]["capture_rate"] for t in targets] for w in wolves]) * 100
    fig = plt.figure(figsize=(2.4 + 1.35 * (len(targets) + 1), 1.6 + 0.75 * (len(wolves) + 1)), layout="constrained")
    gs = fig.add_gridspec(2, 2, width_ratios=[len(targets), 1.3], height_ratios=[len(wolves), 1])
    ax, side, bottom = fig.add_subplot(gs[0, 0]), fig.add_subplot(gs[0, 1]), fig.add_subplot(gs[1, 0])

    def shade(value: float) -> str:
        return "white" if value < 60 else "black"

    def wrap(name: str, width: int = 15) -> str:
        """A long model name on lines of about ``width`` characters, broken after a ``/``, ``:``
        or ``-`` (``ppo:league/`` + ``targets_g05``), so that a cell's text stays in its cell."""
        lines = [""]
        for part in re.findall(r"[^/:-]+[/:-]?|[/:-]", name):
            if lines[-1] and len(lines[-1]) + len(part) > width:
                lines.append("")
            lines[-1] += part
        return "\n".join(lines)

    im = ax.imshow(grid, cmap="viridis", vmin=0, vmax=100, aspect="auto")
    for i, w in enumerate(wolves):
        for j, t in enumerate(targets):
            c = by[(w, t)]
            ax.text(j, i, f"{c['capture_rate']:.0%}\ncoll {c['collision_rate']:.0%}", ha="center", va="center", fontsize=8, color=shade(grid[i, j]))
    ax.set_xticks(range(len(targets)), [])
    ax.set_yticks(range(len(wolves)), wolves, fontsize=8)
    ax.set_ylabel("wolf policy")
    ax.set_title(f"capture rate, {doc['episodes']} episodes per cell (same seeds), in {scenario_name(doc['params']).split(' (')[0].replace('`', '')}", fontsize=9)
    worst = np.array([[rob["wolves"][w]["worst_capture_rate"] * 100] for w in wolves])
    side.imshow(worst, cmap="viridis", vmin=0, vmax=100, aspect="auto")
    for i, w in enumerate(wolves):
        side.text(0, i, f"{worst[i, 0]:.0f}% vs\n{wrap(rob['wolves'][w]['against'])}", ha="center", va="center", fontsize=7, color=shade(worst[i, 0]))
    side.set_xticks([])
    side.set_yticks([])
    side.set_title("wolves' worst case\n(lowest capture)", fontsize=8)
    # The targets' worst case as the capture rate it means, on the same colour scale.
    survival = np.array([[rob["targets"][t]["worst_survival_rate"] * 100 for t in targets]])
    bottom.imshow(100 - survival, cmap="viridis", vmin=0, vmax=100, aspect="auto")
    for j, t in enumerate(targets):
        bottom.text(j, 0, f"survives {survival[0, j]:.0f}%\nvs {wrap(rob['targets'][t]['against'])}", ha="center", va="center", fontsize=7, color=shade(100 - survival[0, j]))
    bottom.set_xticks(range(len(targets)), targets, rotation=30, ha="right", fontsize=8)
    bottom.set_yticks([0], ["targets' worst\ncase"], fontsize=8)
    bottom.set_xlabel("target policy")
    fig.colorbar(im, ax=[ax, side, bottom], label="capture rate (%)", shrink=0.8)
    fig.savefig(path, dpi=130)
    plt.close(fig)


def robustness(cells: list[dict], wolves: list[str], targets: list[str]) -> dict:
    """Each policy's worst case over its opponents: a wolf policy's lowest capture rate (and the
    target that held it there), a target policy's lowest survival rate."""
    by = {(c["wolves"], c["targets"]): c for c in cells}
    out = {"wolves": {}, "targets": {}}
    for w in wolves:
        worst = min(targets, key=lambda t: by[(w, t)]["capture_rate"])
        out["wolves"][w] = {"worst_capture_rate": by[(w, worst)]["capture_rate"], "against": worst, "worst_collision_rate": max(by[(w, t)]["collision_rate"] for t in targets)}
    for t in targets:
        worst = max(wolves, key=lambda w: by[(w, t)]["capture_rate"])
        out["targets"][t] = {"worst_survival_rate": 1.0 - by[(worst, t)]["capture_rate"], "against": worst}
    return out
