"""Pages of tables whose cells open an example episode: the cross-play matrix
(``training/evaluate.py --matrix``'s ``matrix.json``: a cell per wolf policy and target policy)
and a scorecard (``wolfpack benchmark --out DIR``'s ``scorecard.json``: a row per task). Each
example is played again here, on the first episode seeds the table was measured on, so that it
is one of the episodes behind the number."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from wolfpack import _core
from wolfpack.scorecard import as_policy
from wolfpack.sides import SCRIPTED_LAWS
from wolfpack.task import task_params
from wolfpack.viewer.encode import encode_episode
from wolfpack.viewer.play import pairing_params, play_pairing


def _read_json(path: str | Path, name: str, keys: tuple[str, ...]) -> tuple[dict, Path]:
    where = Path(path)
    file = where / name if where.is_dir() else where
    if not file.is_file():
        raise ValueError(f"{where}: no {name} there")
    try:
        doc = json.loads(file.read_text(encoding="utf-8"))
    except (OSError, ValueError) as e:
        raise ValueError(f"{file}: not a readable {name} ({type(e).__name__})") from None
    missing = [k for k in keys if not isinstance(doc, dict) or k not in doc]
    if missing:
        raise ValueError(f"{file}: not a {name} (no {', '.join(missing)})")
    return doc, file


def _resolve(spec: str, models: dict[str, str], base: Path) -> str:
    """A policy named in a table: a law as it is, a model by the path the table recorded
    (relative paths from the repository the table was made in: tried from the working folder,
    then from the table's own folder upwards)."""
    path = models.get(spec)
    if path is None:
        return spec
    if Path(path).exists():
        return path
    for root in [base, *base.parents]:
        if (root / path).exists():
            return str(root / path)
    raise ValueError(f"{spec}: its model {path} is not here (run from the folder the table was made in)")


def _pct(x: float | None) -> str:
    return "—" if x is None else f"{100 * x:.0f}%"


def matrix_page(path: str | Path, episodes: int = 1, threads: int | None = None) -> dict[str, Any]:
    """The cross-play matrix as a table (wolves × targets, capture rates) whose cells open
    ``episodes`` example episodes of that pairing (the matrix's first seeds)."""

    doc, file = _read_json(path, "matrix.json", ("wolves", "targets", "cells", "params", "seed"))
    params = _core.validate_params(doc["params"], resolve=True)
    models = doc.get("models") or {}
    cells = {(c["wolves"], c["targets"]): c for c in doc["cells"]}
    loaded: dict[tuple[str, str], Any] = {}

    def driver(spec: str, side: str):
        """Each model is loaded once, however many cells it plays in."""

        if (spec, side) not in loaded:
            loaded[spec, side] = as_policy(_resolve(spec, models, file.parent), side)
        return loaded[spec, side]

    encoded: list[dict] = []
    items: list[dict] = []
    rows = []
    for w in doc["wolves"]:
        row = []
        for t in doc["targets"]:
            cell = cells.get((w, t))
            if cell is None:
                row.append({"text": "—", "value": None, "item": None, "title": f"{w} vs {t}: not played"})
                continue
            played = play_pairing(driver(w, "wolves"), driver(t, "targets"), params, episodes, int(doc["seed"]), threads)
            first = len(encoded)
            shown, who = pairing_params(driver(w, "wolves"), driver(t, "targets"), params)
            encoded += [encode_episode(a, shown, f"{w} vs {t}, seed {int(a['seed'])}", who) for a in played]
            for k in range(len(played)):
                items.append({"label": f"{w} vs {t}, seed {int(doc['seed']) + k}", "episodes": [first + k]})
            lo, hi = cell.get("capture_rate_ci95") or (None, None)
            row.append(
                {
                    "text": _pct(cell["capture_rate"]),
                    "value": cell["capture_rate"],
                    "item": len(items) - len(played),
                    "title": f"{w} vs {t}: captured {_pct(cell['capture_rate'])} of {cell.get('episodes')} episodes (95% CI {_pct(lo)}–{_pct(hi)}); click for seed {doc['seed']}",
                }
            )
        rows.append(row)
    table = {
        "caption": "capture rate of each pairing (rows: wolves, columns: targets); click a cell to watch one of its episodes",
        "corner": "wolves \\ targets",
        "rows": list(doc["wolves"]),
        "columns": list(doc["targets"]),
        "cells": rows,
    }
    return {
        "episodes": encoded,
        "items": items,
        "table": table,
        "title": f"wolfpack: cross-play matrix ({file})",
        "subtitle": f"{len(doc['wolves'])} wolf policies × {len(doc['targets'])} target policies, {doc.get('episodes')} episodes per cell from seed {doc['seed']}",
    }


def scorecard_page(path: str | Path, policy: str | None = None, episodes: int = 1, threads: int | None = None) -> dict[str, Any]:
    """A scorecard as a table (a row per task: score, interval, rank) whose rows open
    ``episodes`` example episodes of the policy on that task (the scorecard's first seeds).
    ``policy`` is the policy's law or saved model (default: the scorecard's, when a law)."""

    card, file = _read_json(path, "scorecard.json", ("policy", "side", "tasks", "first_seed"))
    side = card["side"]
    if policy is None:
        if card["policy"] not in SCRIPTED_LAWS.get(side, ()):
            raise ValueError(f"{file}: scores the model {card['policy']!r}; name its folder with --policy to play its episodes")
        policy = card["policy"]

    driver = as_policy(policy, side)
    seed = int(card["first_seed"])
    encoded: list[dict] = []
    items: list[dict] = []
    rows, names = [], []
    for task, row in card["tasks"].items():
        names.append(task)
        if "score" not in row:
            rows.append([{"text": "skipped", "value": None, "item": None, "title": row.get("skipped", "")}] + [{"text": "", "value": None, "item": None, "title": ""}] * 2)
            continue
        params = _core.validate_params(task_params(task, card.get("overrides") or {}), resolve=True)
        played = play_pairing(driver if side == "wolves" else None, driver if side == "targets" else None, params, episodes, seed, threads)
        first = len(encoded)
        shown, who = pairing_params(driver if side == "wolves" else None, driver if side == "targets" else None, params)
        encoded += [encode_episode(a, shown, f"{task}, seed {int(a['seed'])}", who) for a in played]
        for k in range(len(played)):
            items.append({"label": f"{task}, seed {seed + k}", "episodes": [first + k]})
        item = len(items) - len(played)
        lo, hi = row.get("score_ci95") or (None, None)
        rank = f"{row['rank']} of {len(row['ranked_among'])}" if row.get("rank") is not None and row.get("ranked_among") else "—"
        title = f"{task}: click for seed {seed}"
        rows.append(
            [
                {"text": _pct(row["score"]), "value": row["score"], "item": item, "title": title},
                {"text": f"{_pct(lo)}–{_pct(hi)}", "value": None, "item": item, "title": title},
                {"text": rank, "value": None, "item": item, "title": title},
            ]
        )
    skill = "captured" if side == "wolves" else "survived"
    table = {
        "caption": f"{driver.name} as the {side}: {skill} per task; click a row to watch one of its episodes",
        "corner": "task",
        "rows": names,
        "columns": [skill, "95% CI", "rank"],
        "cells": rows,
    }
    return {
        "episodes": encoded,
        "items": items,
        "table": table,
        "title": f"wolfpack: scorecard of {driver.name}",
        "subtitle": f"{card.get('episodes')} episodes per task from seed {seed}; mean over the tasks played {_pct(card.get('mean_score'))}",
    }
