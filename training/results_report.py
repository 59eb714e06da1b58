#!/usr/bin/env python3
"""The tables of RESULTS.md (and README's and docs/tasks.md's), generated from the JSON in results/.

    python training/results_report.py             # rewrite every generated table of RESULTS.md
    python training/results_report.py --check     # exit 1 naming the stale tables; writes nothing
    python training/results_report.py --figures   # also redraw the figures made from committed JSON

RESULTS.md keeps its prose by hand. Every table made from results sits between
``<!-- generated: NAME -->`` and ``<!-- end generated -->``; this script owns the text in
between and rewrites it with the function registered under NAME, from the JSON of ``--results``
(default ``results/``): evaluate.py's ``results.json`` and ``matrix/matrix.json``, the leagues'
``league.json``, seeds.py's ``seeds.json``, the training runs' summaries and the benchmark's
``baselines.json`` / ``learned.json`` (the tables: :mod:`wolfpack.report.results_tables`).

``--check`` is what the test suite runs: a result changed without its table, or a table edited
by hand, is reported on one line with the names of the blocks that differ. Bad markers or a
missing results file exit with status 2.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from wolfpack.report import benchmark as benchmark_report
from wolfpack.report import evaluation as evaluation_report
from wolfpack.report import imitation as imitation_report
from wolfpack.report import league as league_report
from wolfpack.report import seeds as seeds_report
from wolfpack.report.documents import ReportError, Results, blocks_of, check, regenerate
from wolfpack.report.results_tables import BLOCKS, benchmark_baselines

ROOT = Path(__file__).resolve().parents[1]
#: The documents with generated blocks: RESULTS.md, README's front-page benchmark table and the
#: task suite's page (its exploitability table).
DOCUMENTS = [ROOT / "RESULTS.md", ROOT / "README.md", ROOT / "docs" / "tasks.md"]


def check_documents(documents: Path | list[Path], results: Path) -> list[str]:
    """What ``--check`` reports for ``documents`` against the results folder ``results`` (the
    models its configurations name are this checkout's)."""
    return check(documents, Results(results, checkout=ROOT), BLOCKS)


# --- the figures ---------------------------------------------------------------------------------


def figures(results: Results) -> list[Path]:
    """Redraws the figures of RESULTS.md that a script draws from committed JSON alone, in place;
    returns their paths. Not redrawn: the trajectories (they need the simulator: evaluate.py
    ``--trajectories``) and the SB3 runs' learning curves (their right panel is the training return
    of a progress.csv that was not committed)."""
    root = results.root
    evaluation_report.plot(results.json("results.json")["rows"], root / "figures")
    drawn = [root / "figures" / "capture_rates.png", root / "figures" / "capture_times.png", root / "matrix" / "matrix.png"]
    evaluation_report.matrix_plot(results.json("matrix/matrix.json"), drawn[-1])
    for league in ("league", "targets_long", "league_native"):
        league_report.league_curves(root / league, results.json(f"{league}/league.json"))
        drawn.append(root / league / "league_curves.png")
    drawn.append(root / "figures" / "wolves_bc_imitation.png")
    imitation_report.plot(root / "models" / "wolves_bc_vel_b", results.json("models/wolves_bc_vel_b/imitation.json")["rounds"], "wolves", path=drawn[-1])
    baselines = benchmark_baselines(results)
    for name, draw in (("tasks.png", benchmark_report.task_figure), ("profiles.png", benchmark_report.profile_figure)):
        drawn.append(root / "benchmark" / name)
        draw(baselines, drawn[-1])
    for folder, axis in (
        ("learned/wolves_mappo", "minutes"),
        ("learned/wolves_pool", "minutes"),
        ("learned/targets_mappo", "minutes"),
        ("learned/ippo_vs_mappo/ippo", "steps"),
        ("learned/ippo_vs_mappo/mappo", "steps"),
    ):
        doc = results.json(f"{folder}/seeds.json")
        runs = [root / folder / Path(run).name for run in doc["runs"]]
        seeds_report.curves(root / folder, runs, doc["side"], axis, opponent=next(iter(doc["opponents"])))
        drawn.append(root / folder / "curves.png")
    return drawn


# --- the document --------------------------------------------------------------------------------


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="results_report.py", description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--results", type=Path, default=ROOT / "results", help="the results folder the tables are made from (default: results/)")
    p.add_argument("--out", type=Path, nargs="+", default=DOCUMENTS, metavar="FILE", help="the documents whose generated blocks are rewritten (default: RESULTS.md, README.md, docs/tasks.md)")
    p.add_argument("--check", action="store_true", help="write nothing; exit 1 if any generated block differs from what the results give")
    p.add_argument("--figures", action="store_true", help="also redraw, in --results, the figures drawn from committed JSON")
    args = p.parse_args(argv)
    try:
        if args.check:
            problems = check_documents(args.out, args.results)
            if problems:
                print(f"results_report.py: the documents do not match {args.results}: {'; '.join(problems)} (rerun python training/results_report.py)", file=sys.stderr)
                return 1
            return 0
        rewritten = {document: regenerate(document.read_text(), Results(args.results, checkout=ROOT), BLOCKS) for document in args.out}
    except ReportError as e:
        print(f"results_report.py: error: {e}", file=sys.stderr)
        return 2
    for document, (text, stale) in rewritten.items():
        if stale:
            document.write_text(text)
        print(f"{document}: {len(stale)} of {len(blocks_of(text))} generated blocks rewritten{': ' + ', '.join(stale) if stale else ''}", file=sys.stderr)
    if args.figures:
        for path in figures(Results(args.results, checkout=ROOT)):
            print(f"drew {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    sys.exit(main())
