"""Evaluate every scripted pairing and every given model on identical seeds.

    python training/evaluate.py --episodes 200 --seed 0 [--json] [--out DIR] [MODEL ...]

Rows: every scripted pairing (wolf law × target law) that this version implements, then every
MODEL (a run folder of train.py/imitate.py, or a .zip in one) against the scripted opponent it
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

Output: a Markdown table on stdout, or with --json one JSON object ``{"episodes", "seed",
"rows": [{"wolves": "seed000", "targets": "escape", ...}, ...], "skipped": [...]}``. With
--out DIR: DIR/results.md, DIR/results.json, DIR/capture_rates.png (bars with intervals) and
DIR/capture_times.png (capture-step distributions). Bad arguments exit with status 2 and one
line on stderr.
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))

from common import (  # noqa: E402
    UsageError,
    available_laws,
    env_params,
    evaluate_model,
    load_model,
    model_policies,
    positive_int,
    prepare_out,
    record_episode,
    report,
    rollout,
    seed_int,
    with_laws,
)

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
    lo = rates - np.array([r["capture_rate_ci95"][0] for r in rows])
    hi = np.array([r["capture_rate_ci95"][1] for r in rows]) - rates
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
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        models = [load_model(m) for m in args.models]
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
