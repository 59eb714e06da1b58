"""A league's table and curves (``training/selfplay.py``'s ``league.json``, the format of
:mod:`wolfpack.learn.selfplay`): every member's rate against every member of the other side,
and the members' rates generation after generation."""

from __future__ import annotations

from pathlib import Path

from wolfpack.learn.selfplay import members_of, win_rate
from wolfpack.plots import SIDE_COLOURS
from wolfpack.sides import OTHER_SIDE, SIDES


def league_table(league: dict, steps_header: str = "timesteps") -> str:
    """Markdown: wolf members (rows) × target members (columns), capture rates; then one row per
    generation. ``steps_header`` names what a generation's ``timesteps`` count (RESULTS.md calls
    the native trainer's agent-steps by their name)."""
    wolves, targets = members_of(league, "wolves"), members_of(league, "targets")
    lines = [
        "capture rate (held-out episodes; rows: wolves, columns: targets; blank: not played)",
        "",
        "| wolves \\ targets | " + " | ".join(t["name"] for t in targets) + " |",
        "|---|" + "---|" * len(targets),
    ]
    for w in wolves:
        cells = []
        for t in targets:
            rate = win_rate(league, w["name"], "wolves", t["name"])
            cells.append("" if rate is None else f"{rate:.0%}")
        lines.append(f"| {w['name']} | " + " | ".join(cells) + " |")
    lines += ["", f"| generation | side | {steps_header} | wall (min) | started from | opponents drawn |", "|---|---|---|---|---|---|"]
    for g in league["generations"]:
        drawn = ", ".join(f"{k} ×{v}" for k, v in sorted(g["opponents_drawn"].items(), key=lambda kv: -kv[1]))
        lines.append(f"| {g['generation']} | {g['side']} | {g['timesteps']:,} | {g['wall_s'] / 60:.1f} | {g['started_from'] or 'fresh'} | {drawn} |")
    return "\n".join(lines) + "\n"


#: The opponents' markers in the league's curves, one each (in turn beyond ten).
MARKERS = ("o", "s", "^", "D", "v", "P", "X", "<", ">", "*")


def league_curves(out: Path, league: dict) -> None:
    import csv

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.lines import Line2D

    from wolfpack.plots import line_styles

    fig, axes = plt.subplots(1, 3, figsize=(16, 4.6), layout="constrained")
    for ax, side in zip(axes[:2], SIDES):
        mine = [m for m in members_of(league, side) if m["kind"] == "model"]
        theirs = members_of(league, OTHER_SIDE[side])
        # Two opponents often give a member the same rate (0 % against two laws, say): each
        # opponent's points are shifted sideways by its own small amount and drawn with its own
        # marker, so that coincident points stay visible side by side.
        spread = min(0.3, 0.06 * len(theirs))
        for k, (opp, (colour, style)) in enumerate(zip(theirs, line_styles(len(theirs)))):
            dodge = spread * (k / max(len(theirs) - 1, 1) - 0.5)
            pts = [(m["generation"], win_rate(league, m["name"], side, opp["name"])) for m in mine]
            pts = [(g + dodge, 100 * w) for g, w in pts if w is not None]
            if pts:
                ax.plot(*zip(*pts), marker=MARKERS[k % len(MARKERS)], markersize=5, color=colour, linestyle=style, label=f"vs {opp['name']}")
        ax.set_title(f"{side} members: {'capture' if side == 'wolves' else 'survival'} rate (held-out; points dodged sideways)", fontsize=10)
        ax.set_xlabel("generation")
        last = max([g["generation"] for g in league["generations"]] + [1])
        first = min([m["generation"] for m in mine] + [1])  # 0: a borrowed model (--member)
        ax.set_xlim(first - 0.5, last + 0.5)
        ax.set_xticks(range(first, last + 1))  # generations are whole numbers, however few
        if not mine:
            ax.text(0.5, 0.5, f"no learned {side} in this league", ha="center", va="center", transform=ax.transAxes, color="0.4")
        ax.set_ylabel("%")
        ax.set_ylim(-2, 102)
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0)
    ax = axes[2]
    offset = 0
    for g in league["generations"]:
        path = out / "generations" / f"{g['generation']:02d}" / "progress.csv"
        if not path.is_file():
            continue
        with path.open() as f:
            reader = csv.DictReader(f)
            # The native trainer's log, or SB3's logger (leagues of format 1).
            x_key, y_key = ("agent_steps", f"{g['side']}_return") if "agent_steps" in (reader.fieldnames or []) else ("time/total_timesteps", "rollout/ep_rew_mean")
            rows = [r for r in reader if r.get(y_key)]
        if rows:
            xs = [offset + float(r[x_key]) / 1e6 for r in rows]
            ys = [float(r[y_key]) for r in rows]
            colour = SIDE_COLOURS[g["side"]]
            # Each rollout meets another opponent: the raw curve is noisy, its running mean
            # over 20 rollouts is the trend.
            ax.plot(xs, ys, color=colour, alpha=0.25, linewidth=0.8)
            window = 20
            smooth = [sum(ys[max(0, i - window + 1) : i + 1]) / len(ys[max(0, i - window + 1) : i + 1]) for i in range(len(ys))]
            ax.plot(xs, smooth, color=colour, linewidth=1.8)
        offset += g["timesteps"] / 1e6
    ax.set_title("training return per episode (line: mean of 20 rollouts)", fontsize=10)
    ax.legend(handles=[Line2D([], [], color=SIDE_COLOURS["wolves"], label="wolves learn"), Line2D([], [], color=SIDE_COLOURS["targets"], label="targets learn")], fontsize=7, loc="best")
    ax.set_xlabel("league agent-steps (millions)")
    ax.grid(alpha=0.3)
    fig.savefig(out / "league_curves.png", dpi=120)
    plt.close(fig)
