"""The registry of generated blocks: each table function of the report modules registered under
the marker name its document uses (``<!-- generated: NAME -->``)."""

from __future__ import annotations

from typing import Callable

from wolfpack.report.documents import Results

#: NAME → the function that renders block NAME from the results.
BLOCKS: dict[str, Callable[[Results], str]] = {}


def block(name: str):
    """Registers a table function under the marker name RESULTS.md uses for it."""

    def register(render: Callable[[Results], str]) -> Callable[[Results], str]:
        BLOCKS[name] = render
        return render

    return register
