"""Evaluate every scripted pairing and every given model on identical seeds.

    python training/evaluate.py --episodes 200 --seed 0 [--json] [--out DIR] [MODEL ...]

Rows: every scripted pairing (wolf law × target law) that this version implements, then every
MODEL (a run folder of `wolfpack train`, train.py or imitate.py, or a .zip in one) against the scripted opponent it
was trained with. Episode k of every row is world ``seed + k``'s first episode, so the
seed000-vs-escape row is exactly ``wolfpack hunt --episodes K --seed S``. Per row: capture rate
with its 95 % Wilson interval, median and mean capture steps (over captured episodes), wolf
collision rate (episodes ended by a wolf collision), target collision rate (episodes in which a
target touched an obstacle), timeout rate, cornered rate (episodes ended as ``cornered``: only
with ``--set capture.cornered=true``), success rate (captured + cornered), the share of episodes
in which the target was ever cornered (world-and-laws §1.7; counted whether or not that ends an episode),
mean energy (J per episode, all agents), mean
return per agent of each side (the env's rewards, undiscounted), and the median distance of the
target to the nearest wall when the episode ended (pinned to a wall, a target is hard to ring).

Cross-play (--matrix): every wolf policy — the analytic laws seed000, bvc and formation and every
wolf MODEL — against every target policy — escape, random, still and every target MODEL — on the
same episodes of one scenario (--params/--set; default the documented one; each model acts in
its own action mode, so models trained in different modes meet). A MODEL may also be a league
folder of selfplay.py (every learned member joins). Per cell the columns above; then each
policy's worst case over all its opponents (the robustness column: a wolf policy's lowest
capture rate, a target policy's lowest survival rate). Cells run in parallel on --jobs
processes (default: all cores); the scripted-vs-scripted cells are exactly ``wolfpack hunt``'s
episodes. With --out: DIR/matrix.md, DIR/matrix.json and DIR/matrix.png (a heat map of capture
rates with the worst cases beside it).

    python training/evaluate.py --matrix --episodes 200 --out runs/matrix results/models/* results/league

Output: a Markdown table on stdout, or with --json one JSON object ``{"episodes", "seed",
"rows": [{"wolves": "seed000", "targets": "escape", ...}, ...], "skipped": [...]}``. With
--out DIR: DIR/results.md, DIR/results.json, DIR/capture_rates.png (bars with intervals) and
DIR/capture_times.png (capture-step distributions). Bad arguments exit with status 2 and one
line on stderr.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import (  # noqa: E402
    TARGET_LAWS,
    WOLF_LAWS,
    UsageError,
    available_laws,
    env_params,
    evaluate_model,
    load_model,
    model_policies,
    play,
    player_name,
    positive_int,
    prepare_out,
    record_episode,
    report,
    rollout,
    seed_int,
    with_laws,
)
from wolfpack.models import native_model_folders  # noqa: E402

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


def draw_trajectories(folder: Path, base: dict, jobs, models, args) -> None:
    """``<wolves>_vs_<targets>_seed<k>.png`` for the first --trajectories episodes of each row."""
    from wolfpack.plots import plot_trajectory

    folder.mkdir(exist_ok=True)
    rows = [(w, t, with_laws(base, w, t), {}) for w, t in jobs]
    for m in models:
        w, t = (m.label, m.params["policies"]["targets"]) if m.side == "wolves" else (m.params["policies"]["wolves"], m.label)
        rows.append((w, t, m.params, model_policies(m, not args.stochastic)))
    for w, t, params, policies in rows:
        for k in range(min(args.trajectories, args.episodes)):
            seed = args.seed + k
            name = f"{w}_vs_{t}_seed{seed}".replace(":", "-").replace("/", "-")
            plot_trajectory(record_episode(params, seed, **policies), folder / f"{name}.png", f"{w} vs {t}")


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="evaluate.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("models", nargs="*", metavar="MODEL", help="run folders (with model.zip and config.yaml) or .zip files in one")
    p.add_argument("--episodes", type=positive_int, default=200, help="episodes per row (default 200)")
    p.add_argument("--seed", type=seed_int, default=0, help="first episode seed (default 0, as wolfpack hunt)")
    p.add_argument("--params", default=None, help="params YAML for the scripted rows (default: the documented scenario)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="params override for the scripted rows (repeatable)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument("--out", default=None, help="write results.md, results.json and plots here")
    p.add_argument("--trajectories", type=int, default=0, metavar="K", help="with --out: draw the first K episodes of every row (DIR/trajectories/)")
    p.add_argument("--no-scripted", action="store_true", help="evaluate the models only")
    p.add_argument("--stochastic", action="store_true", help="sample model actions instead of taking the mean")
    p.add_argument("--threads", type=positive_int, default=None, help="native worker threads (default all cores; results do not depend on it)")
    p.add_argument("--matrix", action="store_true", help="cross-play: every wolf policy against every target policy (laws and MODELs) in one scenario")
    p.add_argument("--jobs", type=positive_int, default=None, help="--matrix: cells evaluated in parallel processes (default: all cores)")
    return p


# --- cross-play ------------------------------------------------------------------------------

MATRIX_KEYS = (
    "wolves",
    "targets",
    "episodes",
    "first_seed",
    "capture_rate",
    "capture_rate_ci95",
    "survival_rate",
    "median_capture_steps",
    "mean_capture_steps",
    "collision_rate",
    "target_collision_rate",
    "timeout_rate",
    "cornered_rate",
    "success_rate",
    "ever_cornered_rate",
    "mean_energy",
    "mean_return_wolves",
    "mean_return_targets",
    "median_final_target_wall_distance",
)


def expand_models(paths: list[str]) -> list[str]:
    """Run folders and zips as they are; a selfplay.py league folder becomes its learned
    members (those it trained; the models it borrowed are given on their own); a run of
    ``wolfpack train`` in which both sides learned becomes its two models."""
    out = []
    for p in paths:
        league = Path(p) / "league.json"
        native = native_model_folders(p)
        if len(native) > 1:
            out += [str(folder) for folder in native.values()]
        elif league.is_file():
            doc = json.loads(league.read_text())
            out += [str(Path(p) / m["path"]) for m in doc["members"] if m["kind"] == "model" and not m.get("fixed")]
        else:
            out.append(p)
    return out


_LOADED: dict = {}


def _player(spec: str):
    """A law's name as it is, a model path loaded (once per process)."""
    if spec in WOLF_LAWS + TARGET_LAWS:
        return spec
    if spec not in _LOADED:
        _LOADED[spec] = load_model(spec)
    return _LOADED[spec]


def _worker_start() -> None:
    import torch

    torch.set_num_threads(1)


def matrix_cell(job: tuple) -> dict:
    """One cell: (base params, wolf spec, target spec, episodes, seed, deterministic) → its
    report row (process-pool worker)."""
    base, w, t, episodes, seed, deterministic = job
    wolves, targets = _player(w), _player(t)
    results = play(base, wolves, targets, episodes=episodes, seed=seed, threads=1, deterministic=deterministic)
    r = report(results, player_name(wolves), player_name(targets))
    row = {k: r[k] for k in MATRIX_KEYS}
    row["capture_steps"] = r["capture_steps"]
    return row


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


def scenario_name(params: dict) -> str:
    """The named task whose world ``params`` are (``hunt-v1``, the documented scenario: …), or
    what they are when they match none (who plays, what a learner observes and is paid aside:
    ``wolfpack.task.PLAYER_SECTIONS``): tables and figures say which scenario they come from."""
    from wolfpack.task import PLAYER_SECTIONS, TASK_ORDER, task_params

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

    def wrap(name: str) -> str:
        """A long model name on two lines (``ppo:league/`` + ``targets_g05``)."""
        return name.replace("/", "/\n", 1) if len(name) > 14 else name

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


def run_matrix(args, base: dict, model_paths: list[str], out: Path | None) -> int:
    import concurrent.futures as cf
    import multiprocessing

    from tqdm import tqdm

    wolf_laws, target_laws, skipped = available_laws(base)
    models = [(p, load_model(p)) for p in model_paths]
    wolf_specs = wolf_laws + [p for p, m in models if m.side == "wolves"]
    target_specs = target_laws + [p for p, m in models if m.side == "targets"]
    names = {p: m.label for p, m in models}
    labels = list(names.values())
    if len(set(labels)) != len(labels):
        raise UsageError(f"--matrix: two models share the name {next(x for x in labels if labels.count(x) > 1)!r} (given twice, or two run folders of the same name)")
    for p, m in models:  # fail before any work: every model must fit the scenario
        try:
            play(base, m if m.side == "wolves" else wolf_laws[0], m if m.side == "targets" else target_laws[0], episodes=1, seed=args.seed, threads=1)
        except UsageError as e:
            raise UsageError(f"--matrix: {e}") from None
    jobs = [(base, w, t, args.episodes, args.seed, not args.stochastic) for w in wolf_specs for t in target_specs]
    workers = min(len(jobs), args.jobs or os.cpu_count() or 1)
    cells: list[dict | None] = [None] * len(jobs)
    with tqdm(total=len(jobs), unit="cell", desc="cross-play", disable=args.json or not sys.stderr.isatty()) as bar:
        if workers == 1:
            _worker_start()
            for i, job in enumerate(jobs):
                cells[i] = matrix_cell(job)
                bar.update(1)
        else:
            with cf.ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"), initializer=_worker_start) as pool:
                futures = {pool.submit(matrix_cell, job): i for i, job in enumerate(jobs)}
                try:
                    for f in cf.as_completed(futures):
                        cells[futures[f]] = f.result()
                        bar.update(1)
                except BaseException:
                    pool.shutdown(wait=False, cancel_futures=True)
                    raise
    wolves = [names.get(w, w) for w in wolf_specs]
    targets = [names.get(t, t) for t in target_specs]
    doc = {
        "episodes": args.episodes,
        "seed": args.seed,
        "params": base,
        "wolves": wolves,
        "targets": targets,
        "models": {names[p]: str(p) for p, _ in models},
        "cells": cells,
        "robustness": robustness(cells, wolves, targets),
        "skipped": skipped,
    }
    table = matrix_markdown(doc)
    if out is not None:
        (out / "matrix.md").write_text(table + "\n")
        (out / "matrix.json").write_text(json.dumps(doc, indent=1) + "\n")
        matrix_plot(doc, out / "matrix.png")
    if args.json:
        print(json.dumps(doc))
    else:
        print(table)
    return 0


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        if args.matrix:
            base = env_params(args.params, args.sets)
            out = prepare_out(args.out) if args.out else None
            return run_matrix(args, base, expand_models(args.models), out)
        models = [load_model(m) for m in expand_models(args.models)]
        base = env_params(args.params, args.sets)
        out = prepare_out(args.out) if args.out else None
    except (UsageError, ValueError) as e:
        print(f"evaluate.py: error: {e}", file=sys.stderr)
        return 2
    from tqdm import tqdm

    wolf_laws, target_laws, skipped = available_laws(base)
    jobs = [] if args.no_scripted else [(w, t) for w in wolf_laws for t in target_laws]
    rows = []
    with tqdm(total=args.episodes * (len(jobs) + len(models)), unit="ep", desc="evaluate", disable=args.json or not sys.stderr.isatty()) as bar:
        for w, t in jobs:
            results = rollout(with_laws(base, w, t), episodes=args.episodes, seed=args.seed, threads=args.threads, progress=bar.update)
            rows.append(report(results, w, t))
        for m in models:
            rows.append(evaluate_model(m, episodes=args.episodes, seed=args.seed, threads=args.threads, deterministic=not args.stochastic, progress=bar.update))
    if out is not None and args.trajectories > 0:
        draw_trajectories(out / "trajectories", base, jobs, models, args)
    doc = {"episodes": args.episodes, "seed": args.seed, "rows": rows, "skipped": skipped}
    table = markdown(rows)
    if out is not None:
        (out / "results.md").write_text(table + "\n")
        (out / "results.json").write_text(json.dumps(doc, indent=1) + "\n")
        plot(rows, out)
    if args.json:
        print(json.dumps(doc))
    else:
        print(table)
        for s in skipped:
            print(f"skipped: {s}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
