"""What describes the machine and the load a benchmark ran on: CPU, caches, cores, load
average, the CPU that other processes took, and which wolfpack was measured. Every benchmark
script puts ``machine_info()`` in its report; ``busy_processes`` makes a load of its own and
``emit`` writes the report. Standard library only."""

from __future__ import annotations

import contextlib
import datetime
import json
import os
import platform
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path
from typing import Any, Iterator


def version(pkg: str) -> str | None:
    try:
        return metadata.version(pkg)
    except metadata.PackageNotFoundError:
        return None


def cpu_model() -> str:
    try:
        with open("/proc/cpuinfo", encoding="utf-8") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def cpu_caches(root: Path = Path("/sys/devices/system/cpu/cpu0/cache")) -> dict[str, int]:
    """The first CPU's caches from Linux's sysfs, bytes by name ("L1d", "L1i", "L2", "L3"):
    the size *one core* sees at each level (lscpu's totals add up the instances). Large batches
    slow down where their worlds outgrow L2 and L3, so runs on two kinds of VM compare only
    with these beside them. Empty where sysfs has no cache entries (not Linux, some VMs)."""
    units = {"K": 1024, "M": 1024**2, "G": 1024**3}
    out: dict[str, int] = {}
    for index in sorted(root.glob("index[0-9]*")):
        try:
            level = (index / "level").read_text(encoding="ascii").strip()
            kind = (index / "type").read_text(encoding="ascii").strip()
            size = (index / "size").read_text(encoding="ascii").strip()
        except OSError:
            continue
        unit = size[-1:]
        number = size[:-1] if unit in units else size
        if not number.isdigit():
            continue
        suffix = {"Data": "d", "Instruction": "i"}.get(kind, "")
        out[f"L{level}{suffix}"] = int(number) * units.get(unit, 1)
    return out


def usable_cores() -> int:
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not Linux
        return os.cpu_count() or 1


def loadavg() -> list[float] | None:
    try:
        return [round(x, 2) for x in os.getloadavg()]
    except (OSError, AttributeError):
        return None


def wolfpack_source() -> dict:
    """Which wolfpack was measured: its package folder, the extension's build time, and the git
    commit of the checkout it sits in (None outside one; ``dirty`` when the tree has changes)."""
    import importlib.util

    spec = importlib.util.find_spec("wolfpack")
    if spec is None or not spec.origin:
        return {}
    pkg = Path(spec.origin).parent
    out: dict[str, Any] = {"package": str(pkg)}
    cores = sorted(pkg.glob("_core*.so")) + sorted(pkg.glob("_core*.pyd"))
    if cores:
        out["extension_built"] = datetime.datetime.fromtimestamp(cores[0].stat().st_mtime).astimezone().isoformat(timespec="seconds")
    try:
        git = lambda *a: subprocess.run(["git", "-C", str(pkg), *a], capture_output=True, text=True, timeout=10)  # noqa: E731
        head = git("rev-parse", "--short", "HEAD")
        if head.returncode == 0:
            out["commit"] = head.stdout.strip()
            out["dirty"] = bool(git("status", "--porcelain", "--untracked-files=no").stdout.strip())
    except (OSError, subprocess.SubprocessError):
        pass
    return out


def cpu_ticks(pids: list[int]) -> tuple[int, int] | None:
    """(busy ticks of the whole machine, ticks of ``pids`` and their threads) from /proc, for the
    share of the CPUs that other processes took during a round; None where /proc is missing."""
    try:
        with open("/proc/stat", encoding="ascii") as f:
            fields = [int(x) for x in f.readline().split()[1:]]
        busy = sum(fields[:8]) - fields[3] - fields[4]  # all but idle and iowait (guest is in user)
        own = 0
        for pid in pids:
            try:
                with open(f"/proc/{pid}/stat", encoding="ascii") as f:
                    rest = f.read().rsplit(")", 1)[1].split()
                own += int(rest[11]) + int(rest[12])  # utime, stime (fields 14, 15)
            except (OSError, IndexError, ValueError):
                pass
        return busy, own
    except (OSError, IndexError, ValueError):
        return None


def others_share(before: tuple[int, int] | None, after: tuple[int, int] | None, seconds: float) -> float | None:
    """Cores' worth of CPU that processes other than this benchmark used, averaged over a round."""
    if before is None or after is None or seconds <= 0:
        return None
    hz = os.sysconf("SC_CLK_TCK")
    return round(max(0.0, ((after[0] - before[0]) - (after[1] - before[1])) / hz / seconds), 2)


def machine_info() -> dict:
    return {
        "cpu": cpu_model(),
        "cores": usable_cores(),
        "caches": cpu_caches(),
        "os": platform.platform(),
        "python": platform.python_version(),
        "load_average": loadavg(),
        "wolfpack_source": wolfpack_source(),
        "packages": {p: version(p) for p in ("wolfpack", "numpy", "mpe2", "pettingzoo", "gymnasium", "stable_baselines3", "vmas", "torch")},
    }


def caches_text(caches: dict[str, int] | None) -> str:
    """ ", caches L2 1 MiB, L3 32 MiB" (per core, from ``cpu_caches``), or "" when unknown."""
    if not caches:
        return ""
    size = lambda b: f"{b // 1024**2} MiB" if b % 1024**2 == 0 else f"{b // 1024} KiB"  # noqa: E731
    return ", caches " + ", ".join(f"{name} {size(b)}" for name, b in caches.items() if name in ("L2", "L3"))


@contextlib.contextmanager
def busy_processes(k: int) -> Iterator[None]:
    """``k`` processes that spin on a core each while the block runs (a learner beside the env),
    given a moment to start, and killed after it whatever happens."""
    busy = [subprocess.Popen([sys.executable, "-c", "while True: pass"]) for _ in range(k)]
    try:
        time.sleep(0.2 if k else 0)
        yield
    finally:
        for p in busy:
            p.kill()
            p.wait()


def emit(doc: dict, out: str | None, as_json: bool) -> None:
    """A benchmark's JSON document: written to ``out`` when given, printed when ``as_json``."""
    text = json.dumps(doc, indent=1)
    if out:
        Path(out).write_text(text + "\n")
    if as_json:
        print(text)
