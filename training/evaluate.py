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

from wolfpack.cli.args import int_at_least
from wolfpack.evaluation import report, rollout
from wolfpack.learn.matches import available_laws, evaluate_model, matrix_cell, matrix_worker_start, model_policies, play, record_episode, with_laws
from wolfpack.learn.sb3 import env_params, load_model, prepare_out
from wolfpack.models import expand_models
from wolfpack.report.evaluation import markdown, matrix_markdown, matrix_plot, plot, robustness


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
    p.add_argument("--episodes", type=int_at_least(1), default=200, help="episodes per row (default 200)")
    p.add_argument("--seed", type=int_at_least(0), default=0, help="first episode seed (default 0, as wolfpack hunt)")
    p.add_argument("--params", default=None, help="params YAML for the scripted rows (default: the documented scenario)")
    p.add_argument("--set", dest="sets", action="append", default=[], metavar="KEY=VALUE", help="params override for the scripted rows (repeatable)")
    p.add_argument("--json", action="store_true", help="print one JSON object instead of the table")
    p.add_argument("--out", default=None, help="write results.md, results.json and plots here")
    p.add_argument("--trajectories", type=int, default=0, metavar="K", help="with --out: draw the first K episodes of every row (DIR/trajectories/)")
    p.add_argument("--no-scripted", action="store_true", help="evaluate the models only")
    p.add_argument("--stochastic", action="store_true", help="sample model actions instead of taking the mean")
    p.add_argument("--threads", type=int_at_least(1), default=None, help="native worker threads (default all cores; results do not depend on it)")
    p.add_argument("--matrix", action="store_true", help="cross-play: every wolf policy against every target policy (laws and MODELs) in one scenario")
    p.add_argument("--jobs", type=int_at_least(1), default=None, help="--matrix: cells evaluated in parallel processes (default: all cores)")
    return p


# --- cross-play ------------------------------------------------------------------------------


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
        raise ValueError(f"--matrix: two models share the name {next(x for x in labels if labels.count(x) > 1)!r} (given twice, or two run folders of the same name)")
    for p, m in models:  # fail before any work: every model must fit the scenario
        try:
            play(base, m if m.side == "wolves" else wolf_laws[0], m if m.side == "targets" else target_laws[0], episodes=1, seed=args.seed, threads=1)
        except ValueError as e:
            raise ValueError(f"--matrix: {e}") from None
    jobs = [(base, w, t, args.episodes, args.seed, not args.stochastic) for w in wolf_specs for t in target_specs]
    workers = min(len(jobs), args.jobs or os.cpu_count() or 1)
    cells: list[dict | None] = [None] * len(jobs)
    with tqdm(total=len(jobs), unit="cell", desc="cross-play", disable=args.json or not sys.stderr.isatty()) as bar:
        if workers == 1:
            matrix_worker_start()
            for i, job in enumerate(jobs):
                cells[i] = matrix_cell(job)
                bar.update(1)
        else:
            with cf.ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn"), initializer=matrix_worker_start) as pool:
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
    except ValueError as e:
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
