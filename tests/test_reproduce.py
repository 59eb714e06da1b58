"""RESULTS.md's fast commands rebuild, bit for bit, the committed results they are shown beside.

A command of RESULTS.md's ``bash`` blocks whose closing comment gives its duration as at most a
minute (``# 20 s``, ``# 1 min``) is run as written, except that its ``--out results/X`` goes to a
scratch folder; every JSON file it writes there must equal the committed ``results/X`` file of
the same name. (The slow commands — training runs, hours — are reproduced by hand; RESULTS.md
says how long each takes.) A change to the core or to an evaluation script that moves a result
fails here until the result is remade with the command beside it.

Results that run learned policies (a model folder under ``results/`` among the command's
arguments) are bit for bit on the kind of machine that made them; on another CPU family torch's
kernels round a policy's last bits differently (AVX-512 against AVX2 code paths), a few episodes
fork, and only their outcome rates are held to agree, within ``LEARNED_RATE_TOLERANCE``.
"""

from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

#: Minutes of commands: README's test command leaves them out, .ci/run runs them (pytest -m slow).
pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]
RESULTS_MD = ROOT / "RESULTS.md"
#: The longest a command may say it takes to count as fast, in seconds.
FAST = 60
#: How far an outcome rate of a learned-policy result may move on another CPU family: 12 of 200
#: episodes, about the 95 % sampling interval of a rate near 0.2 (the forked episodes are a new
#: draw). Measured on a Xeon host against results made on an AMD EPYC one: at most 4.5 points,
#: in a cell where both sides are learned.
LEARNED_RATE_TOLERANCE = 0.06
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
        got, want = json.loads(path.read_text()), json.loads(committed.read_text())
        if got == want:
            continue
        assert runs_learned_policies(command, out), f"{out}/{path.name} differs from what `{command}` gives now: rerun it and commit the result"
        assert_rates_close(got, want, f"{out}/{path.name}")


def runs_learned_policies(command: str, out: str) -> bool:
    """Whether ``command`` evaluates a model of ``results/`` (a folder other than its output)."""
    return any(arg.startswith("results/") and arg != out for arg in command.split())


def is_rate(key: str) -> bool:
    return "rate" in key or key in ("iqm", "ci95", "median", "min", "max", "range")


def assert_rates_close(got, want, where: str, key: str = "") -> None:
    """The same structure and the same names; every outcome rate within
    ``LEARNED_RATE_TOLERANCE`` (means and lists of steps, energies and returns, which forked
    episodes move, are not compared)."""
    assert type(got) is type(want) or {type(got), type(want)} <= {int, float}, where
    if isinstance(want, dict):
        assert sorted(got) == sorted(want), where
        for k in want:
            assert_rates_close(got[k], want[k], f"{where}/{k}", k if not is_rate(key) else key)
    elif isinstance(want, list):
        if not is_rate(key) and all(isinstance(x, (int, float)) for x in got + want):
            return  # per-episode values (capture steps): forked episodes add or drop some
        assert len(got) == len(want), where
        for i, (g, w) in enumerate(zip(got, want)):
            assert_rates_close(g, w, f"{where}[{i}]", key)
    elif isinstance(want, (int, float)) and not isinstance(want, bool):
        if is_rate(key):
            assert abs(got - want) <= LEARNED_RATE_TOLERANCE, f"{where}: {got} against the committed {want} (more than {LEARNED_RATE_TOLERANCE} apart)"
    elif key != "against":  # the worst opponent: near ties may fall the other way
        assert got == want, f"{where}: {got!r} against the committed {want!r}"
