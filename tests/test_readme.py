"""Every Python block of README.md runs as written (extracted from README.md itself), each in a
fresh interpreter, in a scratch folder."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"
BLOCKS = re.findall(r"```python\n(.*?)```", README.read_text(), flags=re.S)


def test_readme_has_python_blocks():
    assert len(BLOCKS) >= 3


@pytest.mark.parametrize("index", range(len(BLOCKS)), ids=[f"block{k}" for k in range(len(BLOCKS))])
def test_readme_python_block_runs_as_written(index, tmp_path):
    code = BLOCKS[index]
    # The timeout guards against a hang; how long the examples take is measured, not asserted
    # (README states it).
    done = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, capture_output=True, text=True, timeout=900)
    assert done.returncode == 0, f"README block {index} failed:\n{code}\n--- stderr ---\n{done.stderr[-3000:]}"
