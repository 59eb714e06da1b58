"""RESULTS.md's fast commands rebuild, bit for bit, the committed results they are shown beside.

A command of RESULTS.md's ``bash`` blocks whose closing comment gives its duration as at most a
minute (``# 20 s``, ``# 1 min``) is run as written, except that its ``--out results/X`` goes to a
scratch folder; every JSON file it writes there must equal the committed ``results/X`` file of
the same name. (The slow commands — training runs, hours — are reproduced by hand; RESULTS.md
says how long each takes.) A change to the core or to an evaluation script that moves a result
fails here until the result is remade with the command beside it.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
RESULTS_MD = ROOT / "RESULTS.md"
#: The longest a command may say it takes to count as fast, in seconds.
FAST = 60
DURATION = re.compile(r"\s+#\s*(\d+(?:\.\d+)?)\s*(s|min)\s*$")


def commands(text: str) -> list[str]:
    """Every command of the ``bash`` blocks of ``text``, continuation lines joined."""
    found = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        joined = re.sub(r"\s*\\\n\s*", " ", block)
        found += [line.strip() for line in joined.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    return found


def fast_commands(text: str) -> list[tuple[str, str]]:
    """(command without its comment, the results folder it writes) of every fast command."""
    fast = []
    for line in commands(text):
        m = DURATION.search(line)
        if m is None:
            continue
        seconds = float(m.group(1)) * (60 if m.group(2) == "min" else 1)
        out = re.search(r"--out (results/\S+)", line)
        if seconds <= FAST and out:
            fast.append((line[: m.start()], out.group(1)))
    return fast


FAST_COMMANDS = fast_commands(RESULTS_MD.read_text())


def test_results_md_has_fast_commands_and_the_parser_sees_durations():
    assert len(FAST_COMMANDS) >= 3
    sample = "```bash\npython a.py --out results/x \\\n    more   # 20 s\npython b.py --out results/y   # 6 min\n```"
    assert fast_commands(sample) == [("python a.py --out results/x more", "results/x")]


@pytest.mark.parametrize(("command", "out"), FAST_COMMANDS, ids=[out for _, out in FAST_COMMANDS])
def test_a_fast_command_rebuilds_its_committed_results(command, out, tmp_path):
    scratch = tmp_path / out
    run = command.replace(f"--out {out}", f"--out {scratch}")
    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}{os.pathsep}{os.environ['PATH']}"}
    done = subprocess.run(["bash", "-c", run], cwd=ROOT, env=env, capture_output=True, text=True, timeout=1800)
    assert done.returncode == 0, f"{run}\n--- stderr ---\n{done.stderr[-3000:]}"
    written = sorted(scratch.glob("*.json"))
    assert written, f"{run} wrote no JSON under {scratch}"
    for path in written:
        committed = ROOT / out / path.name
        assert committed.exists(), f"{out}/{path.name} is not committed"
        assert json.loads(path.read_text()) == json.loads(committed.read_text()), f"{out}/{path.name} differs from what `{command}` gives now: rerun it and commit the result"
