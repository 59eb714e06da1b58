"""Each of the project's vocabularies is defined once, and everything else reads it from there:
the sides and who opposes whom, the action modes, the outcomes, the laws' names and the
pictures' colours. A second spelling drifts (one order here, another there), so the sources of
the package and of training/ must not carry one."""

from __future__ import annotations

import re
from pathlib import Path

import wolfpack
from wolfpack import _core
from wolfpack.plots import OUTCOME_COLOURS, SIDE_COLOURS
from wolfpack.sides import ACTION_MODES, OTHER_SIDE, SCRIPTED_LAWS, SIDES

PACKAGE = Path(wolfpack.__file__).parent
SOURCES = sorted([*PACKAGE.rglob("*.py"), *(PACKAGE.parents[1] / "training").glob("*.py")])

#: A vocabulary's spelling (a regular expression over the sources) -> the one file that may hold it.
DEFINITIONS = {
    r'\(\s*"wolves",\s*"targets"\s*\)': "wolfpack/sides.py",
    r'\{\s*"wolves":\s*"targets",\s*"targets":\s*"wolves"\s*\}': "wolfpack/sides.py",
    r'\(\s*"unicycle",\s*"velocity"\s*\)': "wolfpack/sides.py",
    r'"seed000",\s*"bvc",\s*"formation"': None,  # the core's list: wolfpack.sides.SCRIPTED_LAWS
    r"\bOUTCOMES\s*(?::[^=]*)?=": "wolfpack/batch.py",
    r'"crimson"|"#1f77b4"': "wolfpack/plots.py",
}


def holders(pattern: str) -> set[str]:
    found = set()
    for path in SOURCES:
        if re.search(pattern, path.read_text(encoding="utf-8")):
            found.add(str(path.relative_to(PACKAGE.parent)) if PACKAGE in path.parents else f"training/{path.name}")
    return found


def test_every_vocabulary_is_spelled_in_one_file():
    spread = {pattern: sorted(holders(pattern)) for pattern in DEFINITIONS}
    wrong = {pattern: files for pattern, files in spread.items() if set(files) - {DEFINITIONS[pattern]}}
    assert not wrong, wrong


def test_the_definitions_cover_what_the_core_knows():
    assert set(SIDES) == set(OTHER_SIDE) == set(OTHER_SIDE.values()) == set(SIDE_COLOURS)
    assert all(OTHER_SIDE[OTHER_SIDE[side]] == side for side in SIDES)
    assert SCRIPTED_LAWS == {"wolves": tuple(_core.WOLF_LAWS), "targets": tuple(_core.TARGET_LAWS)}
    assert set(ACTION_MODES) == {"unicycle", "velocity"}
    # Every way an episode ends has its colour in the pictures (running is no ending).
    assert set(OUTCOME_COLOURS) == set(wolfpack.OUTCOMES) - {"running"}
