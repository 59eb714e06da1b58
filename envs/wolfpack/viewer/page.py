"""One self-contained HTML page: the episodes (packed by :mod:`wolfpack.viewer.encode`), the
script and the styles inlined into ``page.html``, so that the file opens offline, from disk or
as a CI artefact, with nothing fetched.

A page shows a list of items; an item is one episode, or the same episode seed played by
several policies (then ``panes`` names them, one canvas each, scrubbed together).
"""

from __future__ import annotations

import html
import json
import re
from importlib import resources
from pathlib import Path
from typing import Any, Sequence

from wolfpack import _core, logs, render
from wolfpack.viewer import encode

#: The page's ``<meta name="generator">``: how ``--force`` knows a file is a page it wrote.
GENERATOR = "wolfpack view"
#: The markers of page.html that the parts replace.
_SLOTS = re.compile(r"@@(GENERATOR|TITLE|CSS|JS|DATA)@@")


def _asset(name: str) -> str:
    return resources.files("wolfpack.viewer").joinpath(name).read_text(encoding="utf-8")


def colours() -> dict[str, Any]:
    """The project's colours, from where they are kept: the frames' (the core's, as the videos
    draw them) for agents and obstacles, the plots' for outcomes."""
    from matplotlib.colors import to_hex

    from wolfpack import plots  # matplotlib

    return {
        "wolves": [list(c) for c in render.WOLF_COLOURS],
        "target": list(render.TARGET_COLOUR),
        "static_obstacle": list(render.STATIC_OBSTACLE_COLOUR),
        "moving_obstacle": list(render.MOVING_OBSTACLE_COLOUR),
        "outcomes": {k: to_hex(v) for k, v in plots.OUTCOME_COLOURS.items()},
        "sighting": "#4a7fb0",
        "arena": "#ffffff",
        "outside": "#d0d0d0",
    }


def page_data(episodes: Sequence[dict], items: Sequence[dict] | None = None, panes: Sequence[str] | None = None, subtitle: str = "", table: dict | None = None) -> dict[str, Any]:
    """The page's JSON: ``episodes`` are :func:`encode.encode_episode` objects; ``items`` list
    ``{"label", "episodes": [index per pane]}`` (default: one item per episode); ``table``
    (:mod:`wolfpack.viewer.tables`) is shown first, its cells opening items."""
    if items is None:
        items = [{"label": e["label"], "episodes": [k]} for k, e in enumerate(episodes)]
    if not items:
        raise ValueError("a page needs at least one episode")
    width = len(panes) if panes else 1
    for it in items:
        if len(it["episodes"]) != width or not all(0 <= k < len(episodes) for k in it["episodes"]):
            raise ValueError(f"item {it['label']!r}: expected {width} episode indices below {len(episodes)}, got {it['episodes']}")
    return {
        "version": _core.__version__,
        "subtitle": subtitle,
        "grid": {"agent": list(encode.AGENT_STEPS), "pose": list(encode.POSE_STEPS), "energy": encode.ENERGY_STEP},
        "mode_names": list(encode.MODE_NAMES),
        "colours": colours(),
        "panes": list(panes) if panes else None,
        "items": list(items),
        "episodes": list(episodes),
        "table": table,
    }


def render_page(data: dict[str, Any], title: str) -> str:
    """The HTML text of a page showing ``data`` (:func:`page_data`)."""
    # "<" never appears raw inside the data's script element, so no "</script>" in a label
    # can end it early.
    text = json.dumps(data, separators=(",", ":"), allow_nan=False).replace("<", "\\u003c")
    parts = {"GENERATOR": GENERATOR, "TITLE": html.escape(title), "CSS": _asset("page.css"), "JS": _asset("page.js"), "DATA": text}
    return _SLOTS.sub(lambda m: parts[m.group(1)], _asset("page.html"))


def is_page(path: Path) -> bool:
    """Whether ``path`` is a page this module wrote (its generator tag, near the start)."""
    try:
        with open(path, encoding="utf-8", errors="replace") as f:
            head = f.read(2048)
    except OSError:
        return False
    return f'<meta name="generator" content="{GENERATOR}">' in head


def write_page(path: Path, data: dict[str, Any], title: str) -> int:
    """Writes the page under a temporary name, then renames it (never half a page under the
    final name); returns its size in bytes."""

    text = render_page(data, title).encode("utf-8")
    with logs.atomic_path(Path(path), keep_suffix=True) as tmp:
        tmp.write_bytes(text)
    return len(text)
