"""Plots of ``wolfpack hunt --out DIR`` (matplotlib, Agg; no display needed).

Every function reads the arrays of ``trajectory.npz`` (see :mod:`wolfpack.logs`), so a saved run
can be re-plotted later with :func:`wolfpack.logs.load_trajectory`. Figures are built with the
object-oriented API (:class:`matplotlib.figure.Figure`) rather than pyplot: no global figure
state to leak between episodes and no interactive backend to select.
"""

from __future__ import annotations

from collections import Counter
from pathlib import Path
from typing import Any, Mapping, Sequence

# Figure.savefig imports the Agg backend (a C extension) at its first call; importing it here
# moves that cost, and the window in which a Ctrl-C turns into "ImportError: initialization
# failed" inside the extension's initialisation, to start-up instead of the middle of a run.
import matplotlib.backends.backend_agg  # noqa: F401
import numpy as np
from matplotlib.collections import PatchCollection
from matplotlib.figure import Figure
from matplotlib.patches import Circle, Polygon, Rectangle
from matplotlib.ticker import MaxNLocator

#: Each ending outcome's colour in every picture (summary.png, the viewer's timeline and badges),
#: in the order the pictures list them (the outcomes themselves: ``wolfpack.OUTCOMES``).
OUTCOME_COLOURS = {"captured": "tab:green", "cornered": "tab:olive", "collision": "tab:red", "timeout": "tab:gray"}
_TARGET_COLOUR = "crimson"
# The wolves' family: blues, teals and greens, far from the target's red (no orange, brown,
# pink or purple, which read as red beside it), dark and light alternating so that neighbours
# differ.
_WOLF_COLOURS = ("#1f77b4", "#17becf", "#2ca02c", "#08306b", "#74add1", "#00665e", "#66c2a4", "#3f5f9f", "#41ab5d")
#: Each side's colour where a picture shows the sides rather than the agents (a league's curves).
SIDE_COLOURS = {"wolves": _WOLF_COLOURS[0], "targets": _TARGET_COLOUR}
#: How a collision is marked on a trajectory: where the wolf stood when it ended the episode.
_COLLISION_MARK = {"marker": "X", "markersize": 11, "markerfacecolor": "black", "markeredgecolor": "white", "linestyle": "none"}
_LINE_STYLES = ("-", "--", ":", "-.")


def line_styles(k: int) -> list[tuple[str, str]]:
    """``k`` distinct (colour, line style) pairs, for any ``k``: the 9 wolf colours with solid
    lines first, then again dashed, dotted and dash-dotted (36 pairs); beyond that, ``k`` colours
    sampled evenly from a perceptual colour map, each with a line style. No two lines of a plot
    look alike, whatever the number of wolves or rows."""
    if k <= len(_WOLF_COLOURS) * len(_LINE_STYLES):
        return [(_WOLF_COLOURS[i % len(_WOLF_COLOURS)], _LINE_STYLES[i // len(_WOLF_COLOURS)]) for i in range(k)]
    from matplotlib import colormaps
    from matplotlib.colors import to_hex

    cmap = colormaps["viridis"]
    return [(to_hex(cmap(i / (k - 1))), _LINE_STYLES[i % len(_LINE_STYLES)]) for i in range(k)]


def _legend_outside(ax, **kw) -> None:
    """A legend to the right of the axes, never over the data."""
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0.0, fontsize=7, **kw)


_DPI = 100


def obstacle_outline(kind: str, radius: float, local: np.ndarray, pose: np.ndarray):
    """The patch of one obstacle at ``pose`` = (x, y, angle): a circle, or the polygon whose
    world vertices are centre + R(angle) · local (``local`` may carry NaN padding rows)."""
    centre = pose[:2]
    if "circle" in kind:
        return Circle(centre, radius)
    verts = local[~np.isnan(local).any(axis=1)]
    c, s = np.cos(pose[2]), np.sin(pose[2])
    world = verts @ np.array([[c, s], [-s, c]]) + centre  # row-vector form of R(angle) · v
    return Polygon(world, closed=True)


def _obstacles(ax, a: Mapping[str, np.ndarray], row: int, **style) -> None:
    patches = [obstacle_outline(str(kind), float(r), local, pose) for kind, r, local, pose in zip(a["obstacle_kind"], a["obstacle_radius"], a["obstacle_vertices"], a["obstacle_poses"][row])]
    if patches:
        ax.add_collection(PatchCollection(patches, **style))


def _title(a: Mapping[str, np.ndarray], label: str) -> str:
    outcome = str(a["outcome"])
    steps = a["interaction"].shape[0]
    cs = int(a["capture_step"])
    when = f"captured at step {cs}" if outcome == "captured" else f"{outcome} after {steps} steps"
    cornered = int(a["cornered_step"]) if "cornered_step" in a else -1
    if cornered >= 0 and outcome != "cornered":
        when += f", cornered at step {cornered}"
    return f"{label}: {when} (seed {int(a['seed'])})"


def plot_trajectory(a: Mapping[str, np.ndarray], path: Path, label: str = "episode") -> None:
    """``trajectory.png``: arena border; obstacles at their initial pose (light) and final pose;
    each wolf's path (o = start, ▲ = end; wolves in blues and greens) and the targets' paths (red);
    a ring of radius ``capture_distance`` around each target's final position; on an episode
    ended by a collision, a black ✕ where each colliding wolf stood at that step; title with
    outcome and steps."""
    fig = Figure(figsize=(7.6, 6.4), dpi=_DPI, layout="constrained")
    ax = fig.add_subplot()
    x0, y0, x1, y1 = a["border"]
    ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fill=False, edgecolor="black", linewidth=1.5))
    _obstacles(ax, a, 0, facecolor="0.85", edgecolor="0.7", linewidth=0.5, linestyle="--")
    _obstacles(ax, a, -1, facecolor="0.45", edgecolor="0.2", linewidth=0.8, alpha=0.8)
    styles = line_styles(a["wolves"].shape[1])
    for i, (colour, style) in enumerate(styles):
        path_i = a["wolves"][:, i, :2]
        ax.plot(path_i[:, 0], path_i[:, 1], color=colour, linestyle=style, linewidth=1.0, label=f"wolf {i}")
        ax.plot(*path_i[0], "o", color=colour, markersize=4)
        ax.plot(*path_i[-1], "^", color=colour, markersize=6)
    if str(a["outcome"]) == "collision" and "collisions" in a:
        # The episode ends at the step of the collision: each wolf that was touching an
        # obstacle or another wolf then stands where it happened.
        n = a["wolves"].shape[1]
        hit = [i for i in range(n) if int(a["collisions"][i]) > 0]
        steps = a["interaction"].shape[0]
        for k, i in enumerate(hit):
            ax.plot(*a["wolves"][-1, i, :2], **_COLLISION_MARK, label=f"collision (step {steps})" if k == 0 else None)
            ax.annotate(f"wolf {i}", a["wolves"][-1, i, :2], xytext=(6, 6), textcoords="offset points", fontsize=8)
    for j in range(a["targets"].shape[1]):
        path_j = a["targets"][:, j, :2]
        ax.plot(path_j[:, 0], path_j[:, 1], color=_TARGET_COLOUR, linewidth=1.6, label="target" if j == 0 else None)
        ax.plot(*path_j[0], "o", color=_TARGET_COLOUR, markersize=5)
        ax.plot(*path_j[-1], "*", color=_TARGET_COLOUR, markersize=10)
        ax.add_patch(Circle(path_j[-1], float(a["capture_distance"]), fill=False, edgecolor=_TARGET_COLOUR, linestyle=":"))
    margin = 0.05 * max(x1 - x0, y1 - y0)
    ax.set_xlim(x0 - margin, x1 + margin)
    ax.set_ylim(y0 - margin, y1 + margin)
    ax.set_aspect("equal")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title(_title(a, label), fontsize=10)
    _legend_outside(ax)
    fig.savefig(path)


def wolf_target_distance(a: Mapping[str, np.ndarray]) -> np.ndarray:
    """[T+1, N]: each wolf's distance to its nearest target (with one target: to the target)."""
    diff = a["wolves"][:, :, None, :2] - a["targets"][:, None, :, :2]
    return np.linalg.norm(diff, axis=-1).min(axis=2)


def plot_curves(a: Mapping[str, np.ndarray], path: Path, label: str = "episode") -> None:
    """``curves.png`` against time t·Ts (s): per-agent speed v and turn rate ω; each wolf's
    distance to the (nearest) target, with the capture distance dashed; per-agent accumulated
    energy."""
    n, m = a["wolves"].shape[1], a["targets"].shape[1]
    time = np.arange(a["wolves"].shape[0]) * float(a["ts"])
    names = [f"wolf {i}" for i in range(n)] + [f"target {j}" if m > 1 else "target" for j in range(m)]
    styles = line_styles(n) + [(_TARGET_COLOUR, _LINE_STYLES[j % len(_LINE_STYLES)]) for j in range(m)]
    speeds = np.concatenate([a["wolves"][:, :, 3], a["targets"][:, :, 3]], axis=1)

    turns = np.concatenate([a["wolves"][:, :, 4], a["targets"][:, :, 4]], axis=1)

    fig = Figure(figsize=(7.0, 10.0), dpi=_DPI, layout="constrained")
    ax_v, ax_w, ax_d, ax_e = fig.subplots(4, 1, sharex=True)
    for k, (name, (colour, style)) in enumerate(zip(names, styles)):
        ax_v.plot(time, speeds[:, k], color=colour, linestyle=style, linewidth=0.8, label=name)
        ax_w.plot(time, turns[:, k], color=colour, linestyle=style, linewidth=0.6)
        ax_e.plot(time, a["energy"][:, k], color=colour, linestyle=style, linewidth=0.8)
    ax_w.set_ylabel("turn rate ω (rad/s)")
    for i, d in enumerate(wolf_target_distance(a).T):
        ax_d.plot(time, d, color=styles[i][0], linestyle=styles[i][1], linewidth=0.8)
    ax_d.axhline(float(a["capture_distance"]), color="black", linestyle="--", linewidth=0.8, label="capture distance")
    ax_v.set_ylabel("speed v (m/s)")
    ax_d.set_ylabel("wolf–target distance (m)")
    ax_e.set_ylabel("energy Σ ½mv² (J)")
    ax_e.set_xlabel("time (s)")
    _legend_outside(ax_v)
    _legend_outside(ax_d)
    ax_v.set_title(_title(a, label), fontsize=10)
    fig.savefig(path)


def plot_interaction(a: Mapping[str, np.ndarray], path: Path, label: str = "episode") -> None:
    """``interaction.png``: the interaction graph over time as a heat map — one row per ordered
    pair (observer → observed) that is ever linked, one column per step, dark where the
    observer sensed or used the observed agent that step (world-and-laws §1.5) — beside the number of
    links per step."""
    inter = np.asarray(a["interaction"], dtype=np.uint8)  # [T, A, A]
    n, m = a["wolves"].shape[1], a["targets"].shape[1]
    names = [f"w{i}" for i in range(n)] + [f"t{j}" if m > 1 else "t" for j in range(m)]
    pairs = [(i, j) for i in range(n + m) for j in range(n + m) if i != j and inter.shape[0] and inter[:, i, j].any()]
    fig = Figure(figsize=(8.0, 2.0 + 0.18 * max(1, len(pairs))), dpi=_DPI, layout="constrained")
    ax_map, ax_count = fig.subplots(2, 1, sharex=True, height_ratios=[max(1, len(pairs)), 4])
    if pairs:
        image = np.array([inter[:, i, j] for i, j in pairs])
        ax_map.imshow(image, aspect="auto", interpolation="nearest", cmap="Greys", vmin=0, vmax=1, extent=(0.5, inter.shape[0] + 0.5, len(pairs) - 0.5, -0.5))
        ax_map.set_yticks(range(len(pairs)), [f"{names[i]}→{names[j]}" for i, j in pairs], fontsize=6)
        # The key: what a dark cell means, and how the rows are named.
        ax_map.legend(
            handles=[Rectangle((0, 0), 1, 1, facecolor="black"), Rectangle((0, 0), 1, 1, facecolor="white", edgecolor="0.6")],
            labels=["linked this step", "not linked"],
            title="wN = wolf N, t = target;\nrow a→b: a sensed or used b",
            loc="upper left",
            bbox_to_anchor=(1.01, 1.0),
            borderaxespad=0.0,
            fontsize=7,
            title_fontsize=7,
        )
    else:
        ax_map.text(0.5, 0.5, "no interactions", ha="center", va="center", transform=ax_map.transAxes)
    ax_map.set_title(_title(a, label) + "\ninteraction graph (observer → observed)", fontsize=10)
    steps = np.arange(1, inter.shape[0] + 1)
    ax_count.plot(steps, inter.reshape(inter.shape[0], -1).sum(axis=1) if inter.shape[0] else [], color="black", linewidth=0.8)
    ax_count.set_ylabel("links")
    ax_count.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax_count.set_xlabel("step")
    fig.savefig(path)


def step_bins(steps: Sequence[int], most: int = 40) -> np.ndarray:
    """Histogram bin edges for step counts: whole steps at the bins' centres, each bin a whole
    number of steps wide, at most ``most`` bins."""
    lo, hi = min(steps), max(steps)
    width = max(1, int(np.ceil((hi - lo + 1) / most)))
    return np.arange(lo - 0.5, hi + width + 0.5, width)


def plot_summary(details: Sequence[Mapping[str, Any]], path: Path) -> None:
    """``summary.png``: counts of each outcome (bar chart; ``cornered`` only when some episode
    ended so) and the histogram of capture steps over captured episodes. ``details`` are
    ``summary.json``'s ``episodes_detail`` entries."""
    counts = Counter(d["outcome"] for d in details)
    capture_steps = [d["capture_step"] for d in details if d["outcome"] == "captured"]
    shown = [o for o in OUTCOME_COLOURS if o != "cornered" or counts.get(o)]

    fig = Figure(figsize=(9.0, 3.6), dpi=_DPI, layout="constrained")
    ax_bar, ax_hist = fig.subplots(1, 2)
    bars = ax_bar.bar(shown, [counts.get(o, 0) for o in shown], color=[OUTCOME_COLOURS[o] for o in shown], edgecolor="black", linewidth=0.8)
    ax_bar.bar_label(bars)
    ax_bar.margins(y=0.12)  # room for the labels above the bars
    ax_bar.set_ylabel("episodes")
    ax_bar.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax_bar.set_title(f"outcomes of {len(details)} episode{'' if len(details) == 1 else 's'}", fontsize=10)
    if capture_steps:
        ax_hist.hist(capture_steps, bins=step_bins(capture_steps), color=OUTCOME_COLOURS["captured"], edgecolor="black", linewidth=0.6)
        lo, hi = min(capture_steps), max(capture_steps)
        if hi - lo < 10:  # a few episodes, or all alike: show the steps around them, not a sliver
            ax_hist.set_xlim(lo - 5, hi + 6)
        ax_hist.xaxis.set_major_locator(MaxNLocator(integer=True))
        ax_hist.axvline(float(np.median(capture_steps)), color="black", linestyle="--", label="median")
        _legend_outside(ax_hist)
    else:
        ax_hist.text(0.5, 0.5, "no captures", ha="center", va="center", transform=ax_hist.transAxes)
    ax_hist.set_xlabel("capture step")
    ax_hist.set_ylabel("episodes")
    ax_hist.yaxis.set_major_locator(MaxNLocator(integer=True))
    ax_hist.set_title("steps to capture", fontsize=10)
    fig.savefig(path)
