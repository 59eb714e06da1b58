"""Every Python block of README.md and of the docs pages that carry README's moved examples runs
as written (extracted from the files themselves), each in a fresh interpreter, in a scratch
folder."""

from __future__ import annotations

import re
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
# The pages README's sections moved to (README links to them); their examples are README's.
DOCS = [ROOT / "docs" / name for name in ("scenario.md", "guide.md", "learning.md", "tasks.md")]


def python_blocks(path: Path) -> list[str]:
    # dedent: a block inside a list item is indented with it
    return [textwrap.dedent(code) for code in re.findall(r"```python\n(.*?)```", path.read_text(), flags=re.S)]


# (file, index within the file, code)
BLOCKS = [(path.name, k, code) for path in [README, *DOCS] for k, code in enumerate(python_blocks(path))]
#: The pages whose examples train models (tens of seconds each): end-to-end checks that README's
#: test command leaves to the slow run.
TRAINING_PAGES = ("learning.md",)


def test_readme_has_python_blocks():
    assert len(python_blocks(README)) >= 1
    assert len(BLOCKS) >= 4


@pytest.mark.parametrize(
    ("name", "index", "code"),
    [pytest.param(name, k, code, id=f"{name}-block{k}", marks=[pytest.mark.slow] if name in TRAINING_PAGES else []) for name, k, code in BLOCKS],
)
def test_readme_python_block_runs_as_written(name, index, code, tmp_path):
    # The timeout guards against a hang; how long the examples take is measured, not asserted
    # (the text around each block states it).
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"{name} block {index} failed:\n{code}\n--- stderr ---\n{done.stderr[-3000:]}"
