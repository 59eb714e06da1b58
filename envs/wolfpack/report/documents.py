"""Documents with generated tables: Markdown in which every table made from results sits
between ``<!-- generated: NAME -->`` and ``<!-- end generated -->``, and is rewritten by the
function registered under NAME (``training/results_report.py`` registers RESULTS.md's); the
prose around them stays hand-written. With the number formats those tables share."""

from __future__ import annotations

import json
import re
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping

import yaml

BEGIN = re.compile(r"^<!-- generated: ([a-z0-9-]+) -->\n", re.M)


END = "<!-- end generated -->"


class ReportError(ValueError):
    """RESULTS.md's markers or the results cannot be read: one line on stderr, status 2."""


@dataclass
class Results:
    """The results folder; each file parsed once however many tables read it. ``checkout``: the
    folder that model paths in the results' configurations are relative to (the repository the
    runs were trained in; default: the results folder's parent)."""

    root: Path
    checkout: Path | None = None
    _cache: dict = field(default_factory=dict)

    def model_path(self, spec: str) -> str:
        """A configuration's model path as a path to open, or ``spec`` itself (a law's name)."""
        checkout = self.checkout or self.root.parent
        return str(checkout / spec) if (checkout / spec).exists() else spec

    def json(self, relative: str) -> dict:
        if relative not in self._cache:
            self._cache[relative] = json.loads((self.root / relative).read_text())
        return self._cache[relative]

    def yaml(self, relative: str) -> dict:
        if relative not in self._cache:
            self._cache[relative] = yaml.safe_load((self.root / relative).read_text())
        return self._cache[relative]


# --- number formats, as RESULTS.md writes them ----------------------------------------------


def minutes(seconds: float) -> str:
    """Wall times as RESULTS.md states them (one decimal of a minute)."""
    return f"{seconds / 60:.1f} min"


def millions(count: float) -> str:
    """Step counts in millions, as the training tables state them."""
    return f"{count / 1e6:.1f} M"


def percent(share: float) -> str:
    """A share as RESULTS.md's prose tables write it, with a space before the sign."""
    return f"{100 * share:.1f} %"


def row_of(doc: dict, wolves: str, targets: str) -> dict:
    """The row (or matrix cell) of one pairing."""
    for row in doc.get("rows", doc.get("cells", [])):
        if row["wolves"] == wolves and row["targets"] == targets:
            return row
    raise KeyError(f"{wolves} vs {targets}")


def interval(ci: list[float], survival: bool = False) -> str:
    """A Wilson interval as ``89.8 %–96.5 %``; of the survival rate when ``survival``."""
    lo, hi = (1 - ci[1], 1 - ci[0]) if survival else ci
    return f"{percent(lo)}–{percent(hi)}"


def change(new: float, old: float) -> str:
    """``−30 %``: a relative change, rounded to a whole percent."""
    return f"{100 * (new - old) / old:+.0f} %".replace("-", "−")


def bold(text: str, on: bool) -> str:
    """Emphasis the prose relies on (the result a section is about), kept in a generated table."""
    return f"**{text}**" if on else text


# --- the blocks of a document ------------------------------------------------------------------


def blocks_of(text: str) -> list[tuple[str, int, int]]:
    """(name, start, end) of every generated block's body: the text between its two markers."""
    found = []
    for m in BEGIN.finditer(text):
        end = text.find(END, m.end())
        following = BEGIN.search(text, m.end())
        if end < 0 or (following is not None and following.start() < end):
            raise ReportError(f"block {m.group(1)}: no {END} before the next block or the end")
        found.append((m.group(1), m.end(), end))
    return found


def render_block(name: str, results: Results, blocks: Mapping[str, Callable[[Results], str]]) -> str:
    """A block's body: the table with a blank line either side, so that the markers never touch it."""
    if name not in blocks:
        raise ReportError(f"block {name}: no such table (known: {', '.join(blocks)})")
    try:
        return "\n" + blocks[name](results).strip("\n") + "\n\n"
    except (OSError, KeyError, ValueError) as e:
        raise ReportError(f"block {name}: cannot render from {results.root}: {type(e).__name__}: {e}") from None


def regenerate(text: str, results: Results, blocks: Mapping[str, Callable[[Results], str]]) -> tuple[str, list[str]]:
    """The document with every block rewritten, and the names of the blocks that changed."""
    out, stale, done = [], [], 0
    for name, start, end in blocks_of(text):
        body = render_block(name, results, blocks)
        if body != text[start:end]:
            stale.append(name)
        out += [text[done:start], body]
        done = end
    out.append(text[done:])
    return "".join(out), stale


def check(documents: Path | list[Path], results: Results, blocks: Mapping[str, Callable[[Results], str]]) -> list[str]:
    """The problems ``--check`` reports: each document's stale blocks, and tables that have no
    block in any of the documents."""
    documents = [documents] if isinstance(documents, Path) else documents
    problems, placed = [], set()
    for document in documents:
        text = document.read_text()
        _, stale = regenerate(text, results, blocks)
        if stale:
            problems.append(f"stale in {document.name}: {', '.join(stale)}")
        placed |= {name for name, _, _ in blocks_of(text)}
    missing = sorted(set(blocks) - placed)
    if missing:
        problems.append(f"no block for: {', '.join(missing)}")
    return problems
