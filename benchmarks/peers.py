#!/usr/bin/env python3
"""wolfpack against its peers, measured interleaved in one run on one machine (see BENCHMARKS.md).

Every contender is prepared first (built, warmed up, its step count sized), then measured once
per round, round-robin, for ``--repeats`` rounds (the order rotates between rounds), so that
whatever else loads the machine hits every contender alike; the median over rounds is reported,
with the load average before and after each round. An env-step is one world advanced one step:
one call on a batch of E worlds is E env-steps. Same counts everywhere: 5 pursuers (wolves,
adversaries), 1 evader (target, good agent), 12 obstacles (landmarks).

Per batch size E (``--sizes``, default 1,64,1024,8192):

1. **wolfpack BatchEnv**: ``BatchEnv(num_envs=E, learners="wolves", seed=0, threads=t)``
   (autoreset on, its default), ``step`` with zero wolf actions [E, 5, 2] float32; observations,
   rewards and infos for every world each step; t in ``--threads`` (default 1,2).
2. **wolfpack make_vec_env**: ``make_vec_env(num_envs=E, learners="wolves", threads=t)``, the
   SB3 VecEnv over the same batch, ``step`` with zero actions [E*5, 2] (its 5E slots).
3. **VMAS** ``simple_tag`` on CPU, ``num_envs=E`` (torch's default threads).
4. **JaxMARL** MPE ``SimpleTagMPE`` on CPU: (a) a Python loop over ``jax.jit(jax.vmap(env.step))``
   with ``block_until_ready`` every step; (b) a ``jax.lax.scan`` of T steps of the vmapped step
   under one ``jax.jit`` (E*T env-steps / wall time; compile time excluded, reported apart).

VMAS and JaxMARL run in ``.venv-peers`` (``benchmarks/peers_venv.sh``) through
``benchmarks/peer_worker.py``, one worker process per peer that this script drives over a pipe;
without that venv their rows are skipped (``--make-venv`` builds it first). Random actions for
both, drawn before the clock starts.

Once per run (no batch size):

5. **wolfpack scripted** episodes of the documented scenario through ``wolfpack.run_episodes``
   (what ``wolfpack hunt`` runs), 200 episodes, 1 thread and all cores.
6. **mpe2 simple_tag** (PettingZoo parallel API, one world: E = 1 only), 5000 ``env.step``
   calls with random actions drawn up-front; and its ``world.step()`` alone (physics only).
7. The **published Python reference implementation**'s figure, quoted, not measured.

Steps per measurement are sized during the warm-up so that each takes about ``--seconds``
(default 1.5 s; fewer steps at large E). Usage::

    python benchmarks/peers.py                 # full run (~5 min on 2 cores), tables on stdout
    python benchmarks/peers.py --json          # the same as one JSON object on stdout
    python benchmarks/peers.py --quick         # smoke run (E = 1, 64; short measurements)
    python benchmarks/peers.py --make-venv     # build .venv-peers first if missing

Progress notes go to stderr, so ``--json`` output is clean.
"""

from __future__ import annotations

import argparse
import datetime
import json
import math
import os
import platform
import statistics
import subprocess
import sys
import time
from importlib import metadata
from pathlib import Path
from typing import Any, Callable

from peer_scenarios import COUNTS, vmas_simple_tag  # noqa: F401 (COUNTS: learning.py and render.py take it from here)

# mpe2 imports pygame, which otherwise prints a banner on stdout.
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")
# numpy's OpenBLAS worker threads busy-wait on a 2-core machine and steal time from the
# simulators' own threads; nothing here uses BLAS (as in learning.py).
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
WORKER = HERE / "peer_worker.py"
PEERS_VENV = ROOT / ".venv-peers"
PEERS_VENV_SCRIPT = HERE / "peers_venv.sh"

# docs/world-and-laws.md §1.7: the published Python reference implementation on the source scenario.
REFERENCE = {
    "name": "published Python reference implementation (docs/world-and-laws.md §1.7, quoted, not measured)",
    "env_steps_per_second": 42.0,
    "first_snapshot_range": [40.0, 45.0],
    "latest_snapshot_range": [115.0, 155.0],
    "note": "latest snapshot removed the feasibility checks (captured 14 of 20 runs)",
}

DEFAULT_SIZES = "1,64,1024,8192"


def note(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


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


def median_rate(runs: list[tuple[int, float]]) -> float:
    return statistics.median(steps / secs for steps, secs in runs)


def calibrate(run: Callable[[int], tuple[int, float]], target_s: float, min_steps: int = 1, max_steps: int = 10_000_000) -> int:
    """After one warm-up step, times runs of 1, 4, 16, ... steps until one takes ≥ target_s / 4
    (they warm up too), then returns the step count for about ``target_s`` seconds. (The same rule as
    peer_worker.calibrate.)"""
    run(1)  # a first step can be slow (allocation, caches): warm up before timing anything
    n = 1
    while True:
        _, secs = run(n)
        if secs >= target_s / 4 or n >= max_steps:
            break
        n = min(max_steps, n * 4 if secs < target_s / 40 else max(n + 1, math.ceil(n * target_s / 4 / max(secs, 1e-9))))
    return int(max(min_steps, min(max_steps, round(target_s * n / max(secs, 1e-9)))))


def import_wolfpack():
    """wolfpack, retried a few times: the extension may be being rebuilt right now."""
    for attempt_no in range(5):
        try:
            import wolfpack

            return wolfpack
        except ImportError as e:
            if attempt_no == 4:
                raise
            note(f"[wolfpack] import failed ({e}); retrying in 3 s")
            time.sleep(3)
    raise AssertionError("unreachable")


def attempt(name: str, fn: Callable[[], dict], optional: bool = False) -> dict:
    """Runs one peer benchmark; a missing package becomes a ``skipped`` entry, not a failure.
    For an ``optional`` peer (VMAS) any error is reported and skipped too. (learning.py and
    render.py use it.)"""
    try:
        return fn()
    except ImportError as e:
        note(f"[{name}] skipped: {e}")
        return {"skipped": f"not importable: {e}"}
    except Exception as e:  # noqa: BLE001 - an optional peer must not sink the run
        if not optional:
            raise
        note(f"[{name}] skipped after an error: {type(e).__name__}: {e}")
        return {"skipped": f"failed: {type(e).__name__}: {e}"}


# ---------------------------------------------------------------------------------------------
# Standalone measurements (used by learning.py and render.py too)


def bench_wolfpack(episodes: int, threads: int | None, repeats: int, seed: int = 0) -> dict:
    c = Scripted(threads, episodes, seed)
    c.prepare()
    for _ in range(repeats):
        c.runs.append(c.measure())
    return c.result()


def bench_mpe2(steps: int, repeats: int, seed: int = 0) -> dict:
    api = Mpe2(steps, seed)
    api.prepare()
    for _ in range(repeats):
        api.runs.append(api.measure())
    # The same world's physics alone, after the API runs (holding the last actions).
    physics = Mpe2Physics(api)
    for _ in range(repeats):
        physics.runs.append(physics.measure())
    out = api.result()
    out["physics_only_env_steps_per_second"] = physics.result()["env_steps_per_second"]
    api.close()
    return out


def bench_vmas(steps: int, num_envs: int, repeats: int, seed: int = 0) -> dict:
    """VMAS in this process (where vmas and torch are importable here): learning.py uses it."""
    import torch

    env = vmas_simple_tag(num_envs, seed)
    # Drawn up-front, within each agent's action range (VMAS's own sampler).
    plan = [[env.get_random_action(a) for a in env.agents] for _ in range(steps)]
    for actions in plan[: min(steps, 20)]:  # warm-up
        env.step(actions)
    runs = []
    for _ in range(repeats):
        env.reset()
        t0 = time.perf_counter()
        for actions in plan:
            env.step(actions)
        runs.append((steps * num_envs, time.perf_counter() - t0))
    return {
        "scenario": f"vmas simple_tag, num_envs={num_envs}, cpu, torch threads={torch.get_num_threads()}",
        "steps": steps * num_envs,
        "num_envs": num_envs,
        "seconds": [s for _, s in runs],
        "env_steps_per_second": median_rate(runs),
    }


# ---------------------------------------------------------------------------------------------
# Contenders: prepare() once (build, warm up, size), then measure() once per round.


class Contender:
    group = ""  # key in the report: "batch_env_1t", "jaxmarl_scan", ...
    label = ""
    num_envs: int | None = None

    def __init__(self) -> None:
        self.runs: list[tuple[int, float]] = []
        self.info: dict = {}
        self.skipped: str | None = None

    @property
    def key(self) -> str:
        return self.group if self.num_envs is None else f"{self.group}@{self.num_envs}"

    def prepare(self) -> None:
        raise NotImplementedError

    def measure(self) -> tuple[int, float]:
        raise NotImplementedError

    def close(self) -> None:
        pass

    def result(self) -> dict:
        if self.skipped is not None:
            return {"skipped": self.skipped}
        rates = [s / t for s, t in self.runs]
        return self.info | {
            "env_steps_per_run": self.runs[-1][0] if self.runs else None,
            "seconds": [round(t, 4) for _, t in self.runs],
            "rates": [round(r, 1) for r in rates],
            "env_steps_per_second": statistics.median(rates) if rates else None,
        }


class Scripted(Contender):
    """wolfpack.run_episodes on the documented scenario (what `wolfpack hunt` runs)."""

    def __init__(self, threads: int | None, episodes: int, seed: int = 0) -> None:
        super().__init__()
        self.threads, self.episodes, self.seed = threads, episodes, seed
        self.group = "scripted_1t" if threads == 1 else "scripted_all"
        self.label = f"wolfpack scripted run_episodes, {threads or usable_cores()} thread{'s' if (threads or usable_cores()) > 1 else ''}"

    def prepare(self) -> None:
        wolfpack = import_wolfpack()
        self.wolfpack = wolfpack
        self.params = wolfpack.load_params()
        wolfpack.run_episodes(self.params, min(self.episodes, 4), seed=self.seed, threads=self.threads)  # warm-up

    def measure(self) -> tuple[int, float]:
        t0 = time.perf_counter()
        results = self.wolfpack.run_episodes(self.params, self.episodes, seed=self.seed, threads=self.threads)
        secs = time.perf_counter() - t0
        self.outcomes: dict[str, int] = {}
        for r in results:
            self.outcomes[r["outcome"]] = self.outcomes.get(r["outcome"], 0) + 1
        return sum(int(r["steps"]) for r in results), secs

    def result(self) -> dict:
        out = super().result()
        if "skipped" in out:
            return out
        return out | {
            "episodes": self.episodes,
            "threads": self.threads if self.threads is not None else usable_cores(),
            "total_steps": self.runs[-1][0],
            "outcomes": self.outcomes,
        }


class Batch(Contender):
    """wolfpack BatchEnv (native batch) or make_vec_env (SB3 VecEnv over it), zero actions."""

    def __init__(self, vec: bool, num_envs: int, threads: int, target_s: float) -> None:
        super().__init__()
        self.vec, self.num_envs, self.threads, self.target_s = vec, num_envs, threads, target_s
        self.group = f"{'vec_env' if vec else 'batch_env'}_{threads}t"
        self.label = f"{'make_vec_env' if vec else 'BatchEnv'} {threads}t"

    def prepare(self) -> None:
        import numpy as np

        wolfpack = import_wolfpack()
        E, t = self.num_envs, self.threads
        if self.vec:
            self.env = wolfpack.make_vec_env(num_envs=E, learners="wolves", seed=0, threads=t)
            self.actions = np.zeros((self.env.num_envs, 2), np.float32)  # 5E slots
            call = f"make_vec_env(num_envs={E}, learners='wolves', seed=0, threads={t}); step(zeros[{E * 5}, 2])"
        else:
            self.env = wolfpack.BatchEnv(num_envs=E, learners="wolves", seed=0, threads=t)
            self.actions = np.zeros((E, self.env.n_wolves, 2), np.float32)
            call = f"BatchEnv(num_envs={E}, learners='wolves', seed=0, threads={t}); step(zeros[{E}, {self.env.n_wolves}, 2])"
        self.env.reset()
        self.steps = calibrate(self.run, self.target_s)
        self.info = {"call": call, "threads": t, "num_envs": E, "steps_per_run": self.steps}

    def run(self, steps: int) -> tuple[int, float]:
        env, a = self.env, self.actions
        t0 = time.perf_counter()
        for _ in range(steps):
            env.step(a)
        return steps * self.num_envs, time.perf_counter() - t0

    def measure(self) -> tuple[int, float]:
        return self.run(self.steps)

    def close(self) -> None:
        if self.vec and hasattr(self, "env"):
            self.env.close()


class Mpe2(Contender):
    group, label, num_envs = "mpe2", "mpe2 simple_tag (1 world)", None

    def __init__(self, steps: int, seed: int = 0) -> None:
        super().__init__()
        self.steps, self.seed = steps, seed

    def prepare(self) -> None:
        import numpy as np
        from mpe2 import simple_tag_v3

        self.env = env = simple_tag_v3.parallel_env(
            num_good=COUNTS["targets"],
            num_adversaries=COUNTS["wolves"],
            num_obstacles=COUNTS["obstacles"],
            max_cycles=self.steps + 10,
            continuous_actions=True,
            render_mode=None,
        )
        env.reset(seed=self.seed)
        rng = np.random.default_rng(self.seed)
        agents = list(env.agents)
        # All actions drawn before the clock starts: [steps, agents, 5] in the Box(0, 1, (5,)).
        table = {a: rng.random((self.steps, env.action_space(a).shape[0]), dtype=np.float32) for a in agents}
        self.plan = [{a: table[a][t] for a in agents} for t in range(self.steps)]
        for t in range(min(self.steps, 50)):  # warm-up
            env.step(self.plan[t])
        self.info = {
            "scenario": (f"simple_tag_v3.parallel_env(num_adversaries={COUNTS['wolves']}, num_good={COUNTS['targets']}, num_obstacles={COUNTS['obstacles']}, continuous_actions=True)"),
            "steps": self.steps,
        }

    def measure(self) -> tuple[int, float]:
        env = self.env
        env.reset(seed=self.seed)  # max_cycles is above the run: no reset inside the clock
        t0 = time.perf_counter()
        done = 0
        for actions in self.plan:
            env.step(actions)
            done += 1
        return done, time.perf_counter() - t0

    def close(self) -> None:
        if hasattr(self, "env"):
            self.env.close()


class Mpe2Physics(Contender):
    """The same world's world.step() alone (forces, collisions, integration; no observations,
    rewards or PettingZoo wrappers), holding the last actions: an upper bound on what any API
    over mpe2's engine could reach."""

    group, label, num_envs = "mpe2_physics", "mpe2 world.step() only", None

    def __init__(self, api: Mpe2) -> None:
        super().__init__()
        self.api = api

    def prepare(self) -> None:
        if self.api.skipped is not None:
            raise RuntimeError(f"mpe2 skipped: {self.api.skipped}")
        self.info = {"steps": self.api.steps}

    def measure(self) -> tuple[int, float]:
        world, steps = self.api.env.unwrapped.world, self.api.steps
        t0 = time.perf_counter()
        for _ in range(steps):
            world.step()
        return steps, time.perf_counter() - t0


class Worker:
    """One benchmarks/peer_worker.py process (``--serve``): JSON lines over its stdin/stdout,
    its stderr passed through."""

    def __init__(self, python: str, name: str) -> None:
        self.name = name
        env = dict(os.environ, JAX_PLATFORMS="cpu", PYTHONUNBUFFERED="1")
        self.proc = subprocess.Popen([python, str(WORKER), "--serve"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=env, cwd=str(ROOT))
        self.hello = self.call({"op": "info", "peers": [name]})

    def call(self, req: dict) -> dict:
        if self.proc.poll() is not None:
            raise RuntimeError(f"{self.name} worker exited with code {self.proc.returncode}")
        self.proc.stdin.write(json.dumps(req) + "\n")
        self.proc.stdin.flush()
        line = self.proc.stdout.readline()
        if not line:
            raise RuntimeError(f"{self.name} worker died (exit code {self.proc.wait()})")
        reply = json.loads(line)
        if "error" in reply:
            raise RuntimeError(reply["error"])
        return reply

    def close(self) -> None:
        if self.proc.poll() is None:
            try:
                self.proc.stdin.write(json.dumps({"op": "quit"}) + "\n")
                self.proc.stdin.close()
                self.proc.wait(timeout=30)
            except (OSError, subprocess.TimeoutExpired):
                self.proc.kill()
                self.proc.wait()


class Remote(Contender):
    """A measurement run by a peer worker (VMAS, JaxMARL)."""

    LABELS = {"vmas": "VMAS simple_tag (cpu)", "jaxmarl_loop": "JaxMARL jit+vmap loop", "jaxmarl_scan": "JaxMARL lax.scan"}

    def __init__(self, worker: Worker | None, kind: str, num_envs: int, target_s: float, steps: int | None, why_not: str | None) -> None:
        super().__init__()
        self.worker, self.kind, self.num_envs, self.target_s, self.steps = worker, kind, num_envs, target_s, steps
        self.group, self.label = kind, self.LABELS[kind]
        self.skipped = why_not

    def prepare(self) -> None:
        self.info = self.worker.call({"op": "prepare", "id": self.key, "kind": self.kind, "num_envs": self.num_envs, "target_s": self.target_s, "steps": self.steps})

    def measure(self) -> tuple[int, float]:
        r = self.worker.call({"op": "measure", "id": self.key})
        return int(r["env_steps"]), float(r["seconds"])

    def close(self) -> None:
        if self.worker is not None and self.skipped is None and self.worker.proc.poll() is None:
            try:
                self.worker.call({"op": "close", "id": self.key})
            except RuntimeError:
                pass


# ---------------------------------------------------------------------------------------------
# Peer workers


def peers_python(explicit: str | None) -> str | None:
    if explicit:
        return explicit
    py = PEERS_VENV / "bin" / "python"
    return str(py) if py.exists() else None


def start_workers(args, want: set[str]) -> tuple[dict[str, Worker | None], dict[str, str], dict]:
    """Starts a worker per wanted peer ("jaxmarl", "vmas"). Returns the workers, the reasons for
    the ones that cannot run, and what the workers said about themselves."""
    workers: dict[str, Worker | None] = {}
    why: dict[str, str] = {}
    about: dict[str, Any] = {}
    if not want:
        return workers, why, about
    if args.make_venv and not (args.peers_python or (PEERS_VENV / "bin" / "python").exists()):
        note(f"[peers] building {PEERS_VENV} (bash {PEERS_VENV_SCRIPT.relative_to(ROOT)}) ...")
        subprocess.run(["bash", str(PEERS_VENV_SCRIPT)], check=True, stdout=sys.stderr)
    py = peers_python(args.peers_python)
    for peer in sorted(want):
        exe = py
        if exe is None:
            import importlib.util

            if peer == "vmas" and importlib.util.find_spec("vmas") and importlib.util.find_spec("torch"):
                exe = sys.executable  # VMAS is importable here: run its worker with this python
            else:
                why[peer] = f"no peers venv ({PEERS_VENV.relative_to(ROOT)}): run bash benchmarks/peers_venv.sh, or pass --make-venv"
                note(f"[{peer}] skipped: {why[peer]}")
                continue
        note(f"[{peer}] starting worker: {exe} {WORKER.relative_to(ROOT)} --serve")
        try:
            w = Worker(exe, peer)
        except (OSError, RuntimeError, json.JSONDecodeError) as e:
            why[peer] = f"worker failed to start: {e}"
            note(f"[{peer}] skipped: {why[peer]}")
            continue
        problem = w.hello["importable"].get(peer)
        if problem:
            why[peer] = f"not importable in {exe}: {problem}"
            note(f"[{peer}] skipped: {why[peer]}")
            w.close()
            continue
        workers[peer] = w
        about[peer] = w.hello["versions"]
    return workers, why, about


# ---------------------------------------------------------------------------------------------
# Report


def fmt_rate(x: float | None) -> str:
    return "-" if x is None else f"{x:,.0f}"


def fmt_ratio(x: float | None) -> str:
    if x is None:
        return "-"
    return f"{x:,.0f}x" if x >= 10 else f"{x:.2f}x"


def ratio(a: float | None, b: float | None) -> float | None:
    return a / b if a and b else None


def rate(entry: dict | None) -> float | None:
    return None if not entry or "skipped" in entry else entry.get("env_steps_per_second")


def round_rates(entry: dict | None) -> list[float]:
    """A contender's rate in each round, in round order (empty when it was skipped)."""
    return [] if not entry or "skipped" in entry else list(entry.get("rates") or [])


def paired_ratios(ours: dict | None, peers: list[dict | None]) -> list[float]:
    """Round by round, our rate over the best of the peers' rates in that same round: the
    contenders of a round run minutes apart at most, so a machine that speeds up or slows down
    between rounds (a VM's neighbours) moves both sides of each ratio alike. Rounds where we or
    every peer have no rate are left out."""
    mine = round_rates(ours)
    theirs = [round_rates(p) for p in peers]
    out = []
    for k, a in enumerate(mine):
        best = max((r[k] for r in theirs if k < len(r)), default=None)
        if a and best:
            out.append(a / best)
    return out


def size_ratios(row: dict, threads: list[int]) -> dict:
    tmax = max(threads)
    jax_best = max((r for r in (rate(row.get("jaxmarl_loop")), rate(row.get("jaxmarl_scan"))) if r), default=None)
    ours = row.get(f"batch_env_{tmax}t")
    out = {f"BatchEnv({tmax}t) / JaxMARL best": ratio(rate(ours), jax_best)}
    by_round = paired_ratios(ours, [row.get("jaxmarl_loop"), row.get("jaxmarl_scan")])
    out[f"BatchEnv({tmax}t) / JaxMARL best, each round"] = [round(x, 3) for x in by_round]
    out[f"BatchEnv({tmax}t) / JaxMARL best, lowest round"] = min(by_round, default=None)
    for t in threads:
        out[f"make_vec_env({t}t) / BatchEnv({t}t)"] = ratio(rate(row.get(f"vec_env_{t}t")), rate(row.get(f"batch_env_{t}t")))
    out[f"BatchEnv({tmax}t) / VMAS"] = ratio(rate(row.get(f"batch_env_{tmax}t")), rate(row.get("vmas")))
    return out


def caches_text(caches: dict[str, int] | None) -> str:
    """ ", caches L2 1 MiB, L3 32 MiB" (per core, from ``cpu_caches``), or "" when unknown."""
    if not caches:
        return ""
    size = lambda b: f"{b // 1024**2} MiB" if b % 1024**2 == 0 else f"{b // 1024} KiB"  # noqa: E731
    return ", caches " + ", ".join(f"{name} {size(b)}" for name, b in caches.items() if name in ("L2", "L3"))


def tables(report: dict) -> str:
    m = report["machine"]
    threads = report["threads"]
    tmax = max(threads)
    out = [
        f"date: {report['date']}; command: {report['command']}",
        *([f"note: {report['note']}"] if report.get("note") else []),
        f"machine: {m['cpu']}, {m['cores']} cores{caches_text(m.get('caches'))}, {m['os']}, Python {m['python']}",
        "packages: " + ", ".join(f"{k} {v}" for k, v in m["packages"].items() if v),
    ]
    src = m.get("wolfpack_source") or {}
    if src:
        where = f"commit {src['commit']}{' + uncommitted changes' if src.get('dirty') else ''}" if src.get("commit") else "not in a git checkout"
        out.append(f"wolfpack from {src['package']} ({where}; extension built {src.get('extension_built', '?')})")
    pv = report.get("peers_venv") or {}
    by_exe: dict[str, tuple[list[str], dict]] = {}
    for peer, v in pv.get("versions", {}).items():
        by_exe.setdefault(v.get("executable", ""), ([], v))[0].append(peer)
    for exe, (peers, v) in by_exe.items():
        rel = os.path.relpath(exe, ROOT) if exe.startswith(str(ROOT)) else exe
        out.append(f"peer workers ({', '.join(peers)}) in {rel}: " + ", ".join(f"{k} {x}" for k, x in v.items() if x and k != "executable"))
    out += [
        f"scenario: {COUNTS['wolves']} pursuers, {COUNTS['targets']} evader, {COUNTS['obstacles']} obstacles; "
        f"{report['repeats']} interleaved rounds, median; ~{report['target_seconds']} s per measurement",
        f"load average (1, 5, 15 min) at the start: {m['load_average']}, at the end: {m.get('load_average_after')}",
        "per round, load before -> after (it counts this benchmark, 1-2 on 2 cores), and the cores other processes used: "
        + "; ".join(f"{r['round']}: {r['load_before']} -> {r['load_after']}, others {r['others_cores']} ({r['seconds']:.0f} s)" for r in report["rounds"]),
        "",
        "env-steps/s by batch size E (an env-step = one world advanced one step); ratios of the medians,"
        " and 'lowest round' the smallest of the ratios taken round by round (both sides of each from the same round):",
        "",
    ]
    cols = [f"batch_env_{t}t" for t in threads] + [f"vec_env_{t}t" for t in threads] + ["vmas", "jaxmarl_loop", "jaxmarl_scan"]
    heads = [f"BatchEnv {t}t" for t in threads] + [f"make_vec_env {t}t" for t in threads] + ["VMAS cpu", "JaxMARL jit+vmap loop", "JaxMARL lax.scan"]
    rkeys = [f"BatchEnv({tmax}t) / JaxMARL best", f"BatchEnv({tmax}t) / JaxMARL best, lowest round"] + [f"make_vec_env({t}t) / BatchEnv({t}t)" for t in threads]
    rheads = [f"BatchEnv {tmax}t / JaxMARL best", "lowest round"] + [f"vec / Batch {t}t" for t in threads]
    rows = [["E"] + heads + rheads]
    for E, row in report["batch"].items():
        rr = report["ratios_by_size"][E]
        rows.append([E] + [fmt_rate(rate(row.get(c))) for c in cols] + [fmt_ratio(rr.get(k)) for k in rkeys])
    widths = [max(len(r[i]) for r in rows) for i in range(len(rows[0]))]
    line = lambda r: "| " + " | ".join(x.rjust(w) for x, w in zip(r, widths)) + " |"  # noqa: E731
    out.append(line(rows[0]))
    out.append("|" + "|".join("-" * (w + 1) + ":" for w in widths) + "|")
    out += [line(r) for r in rows[1:]]

    # Once-per-run rows.
    out += ["", "no batch size (E = 1 or whole episodes):", ""]
    once = []
    wp = report["wolfpack"]
    for key in ("threads_1", "threads_all"):
        r = wp.get(key, {})
        if "skipped" in r or not r:
            once.append((f"wolfpack scripted run_episodes ({key})", "-", r.get("skipped", "")))
        else:
            once.append((f"wolfpack scripted run_episodes, {r['threads']}t", fmt_rate(r["env_steps_per_second"]), f"{r['episodes']} episodes, {r['total_steps']} steps"))
    r = report["mpe2"]
    if "skipped" in r:
        once.append(("mpe2 simple_tag (E = 1 only: one world)", "-", "skipped: " + r["skipped"]))
    else:
        once.append(("mpe2 simple_tag (E = 1 only: one world)", fmt_rate(r["env_steps_per_second"]), f"{r['steps']} env.step calls"))
        once.append(("mpe2 world.step() only", fmt_rate(r.get("physics_only_env_steps_per_second")), "physics alone: no obs, rewards, wrappers"))
    ref = report["reference"]
    once.append(
        (
            "Python reference impl. (quoted)",
            f"~{ref['env_steps_per_second']:.0f}",
            f"first snapshot {ref['first_snapshot_range'][0]:.0f}-{ref['first_snapshot_range'][1]:.0f}, latest {ref['latest_snapshot_range'][0]:.0f}-{ref['latest_snapshot_range'][1]:.0f}",
        )
    )
    w0 = max(len(a) for a, _, _ in once)
    w1 = max(len("env-steps/s"), *(len(b) for _, b, _ in once))
    out.append(f"| {'simulator':<{w0}} | {'env-steps/s':>{w1}} | notes |")
    out.append(f"|{'-' * (w0 + 2)}|{'-' * (w1 + 1)}:|---|")
    out += [f"| {a:<{w0}} | {b:>{w1}} | {c} |" for a, b, c in once]
    out.append("")
    for k, v in report["ratios"].items():
        out.append(f"{k}: {fmt_ratio(v)}")

    # Sizes and compile times.
    out += ["", "steps per measurement (env-steps = E x steps) and JaxMARL compile seconds:"]
    for E, row in report["batch"].items():
        parts = []
        for c in cols:
            r = row.get(c)
            if not r or "skipped" in r:
                continue
            s = f"{c} {r.get('steps_per_run')}"
            if c.startswith("jaxmarl") and r.get("compile_s") is not None:
                s += f" (compile {r['compile_s']:.1f} s)"
            parts.append(s)
        out.append(f"  E={E}: " + ", ".join(parts))
    skipped = sorted({f"{c}: {r['skipped']}" for row in report["batch"].values() for c, r in row.items() if "skipped" in r})
    if skipped:
        out += ["skipped:"] + [f"  {s}" for s in skipped]
    return "\n".join(out)


# ---------------------------------------------------------------------------------------------


def parse_ints(text: str, what: str) -> list[int]:
    try:
        vals = [int(x) for x in text.split(",") if x.strip()]
    except ValueError:
        raise SystemExit(f"{what}: expected a comma list of integers, got {text!r}") from None
    if not vals or min(vals) < 1:
        raise SystemExit(f"{what}: expected positive integers, got {text!r}")
    return vals


SKIPPABLE = ("scripted", "batch", "vec", "mpe2", "vmas", "jaxmarl", "jaxmarl_loop", "jaxmarl_scan")


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--quick", action="store_true", help="smoke run: E = 1,64 (VMAS, JaxMARL at the first only), short measurements, one round")
    ap.add_argument("--json", action="store_true", help="print one JSON object instead of the tables")
    ap.add_argument("--sizes", default=None, help=f"batch sizes E, comma list (default {DEFAULT_SIZES}; quick 1,64)")
    ap.add_argument("--threads", default="1,2", help="wolfpack batch threads, comma list (default 1,2)")
    ap.add_argument("--seconds", type=float, default=None, help="target seconds per measurement (default 1.5; quick 0.05)")
    ap.add_argument("--episodes", type=int, default=None, help="wolfpack scripted episodes per run (default 200; quick 10)")
    ap.add_argument("--mpe2-steps", type=int, default=None, help="mpe2 env-steps per run (default 5000; quick 300)")
    ap.add_argument("--vmas-steps", type=int, default=None, help="VMAS steps per run at every E (default: sized like the others)")
    ap.add_argument("--repeats", type=int, default=None, help="interleaved rounds, median reported (default 3; quick 1)")
    ap.add_argument("--skip", default="", help=f"comma list of contenders to skip: {','.join(SKIPPABLE)}")
    ap.add_argument("--make-venv", action="store_true", help="build .venv-peers (benchmarks/peers_venv.sh) first if it is missing")
    ap.add_argument("--peers-python", default=None, help="python of the peers venv (default .venv-peers/bin/python)")
    ap.add_argument("--note", default=None, help="a line kept in the report (e.g. which build of wolfpack this is)")
    args = ap.parse_args(argv)

    sizes = parse_ints(args.sizes or ("1,64" if args.quick else DEFAULT_SIZES), "--sizes")
    threads = parse_ints(args.threads, "--threads")
    target_s = args.seconds or (0.05 if args.quick else 1.5)
    episodes = args.episodes or (10 if args.quick else 200)
    mpe2_steps = args.mpe2_steps or (300 if args.quick else 5000)
    repeats = args.repeats or (1 if args.quick else 3)
    skip = {s.strip() for s in args.skip.split(",") if s.strip()}
    unknown = skip - set(SKIPPABLE)
    if unknown:
        ap.error(f"--skip: unknown {', '.join(sorted(unknown))} (choose from {', '.join(SKIPPABLE)})")
    if "jaxmarl" in skip:
        skip |= {"jaxmarl_loop", "jaxmarl_scan"}

    report: dict[str, Any] = {
        "date": datetime.datetime.now().astimezone().isoformat(timespec="seconds"),
        "command": " ".join(
            ([f"PYTHONPATH={os.environ['PYTHONPATH']}"] if os.environ.get("PYTHONPATH") else []) + ["python", os.path.relpath(__file__, ROOT)] + (sys.argv[1:] if argv is None else list(argv))
        ),
        "note": args.note,
        "machine": machine_info(),
        "quick": args.quick,
        "counts": COUNTS,
        "sizes": sizes,
        "threads": threads,
        "target_seconds": target_s,
        "repeats": repeats,
    }
    t_start = time.perf_counter()

    want = set()
    if "vmas" not in skip:
        want.add("vmas")
    if not {"jaxmarl_loop", "jaxmarl_scan"} <= skip:
        want.add("jaxmarl")
    workers, why_not, about = start_workers(args, want)
    report["peers_venv"] = {
        "python": peers_python(args.peers_python),
        "versions": about,
        "skipped": why_not,
    }

    # The contenders, in measuring order (rotated between rounds).
    scripted = [] if "scripted" in skip else [Scripted(1, episodes), Scripted(None, episodes)]
    once: list[Contender] = list(scripted)
    mpe2 = None
    if "mpe2" not in skip:
        mpe2 = Mpe2(mpe2_steps)
        once += [mpe2, Mpe2Physics(mpe2)]
    per_size: list[Contender] = []
    for E in sizes:
        for vec in (False, True):
            if ("vec" if vec else "batch") in skip:
                continue
            per_size += [Batch(vec, E, t, target_s) for t in threads]
        # --quick: the peer workers at the smallest E only (their start and JAX's compiles are
        # most of a quick run's time; one size exercises the whole path).
        peers_here = not args.quick or E == sizes[0]
        if "vmas" not in skip and peers_here:
            per_size.append(Remote(workers.get("vmas"), "vmas", E, target_s, args.vmas_steps, why_not.get("vmas")))
        for kind in ("jaxmarl_loop", "jaxmarl_scan"):
            if kind not in skip and peers_here:
                # --quick: a fixed, short scan (one compile instead of the sizing probes').
                fixed = 16 if (kind == "jaxmarl_scan" and args.quick) else None
                per_size.append(Remote(workers.get("jaxmarl"), kind, E, target_s, fixed, why_not.get("jaxmarl")))
    contenders = once + per_size

    # Prepare: build, warm up, size. A peer that fails is skipped, wolfpack must not fail.
    for c in contenders:
        if c.skipped is not None:
            continue
        t_prep = time.perf_counter()
        try:
            c.prepare()
            note(f"[prepare] {c.label}" + (f", E={c.num_envs}" if c.num_envs else "") + f": {time.perf_counter() - t_prep:.1f} s")
        except ImportError as e:
            c.skipped = f"not importable: {e}"
            note(f"[{c.key}] skipped: {c.skipped}")
        except Exception as e:  # noqa: BLE001 - an optional peer must not sink the run
            if isinstance(c, (Scripted, Batch)):
                raise
            c.skipped = f"failed: {type(e).__name__}: {e}"
            note(f"[{c.key}] skipped: {c.skipped}")
    live = [c for c in contenders if c.skipped is None]

    # Rounds: each live contender once per round, the order rotated.
    rounds = []
    shift = max(1, math.ceil(len(live) / max(repeats, 1)))
    for r in range(repeats):
        order = live[(r * shift) % len(live) :] + live[: (r * shift) % len(live)] if live else []
        pids = [os.getpid()] + [w.proc.pid for w in workers.values()]
        before, ticks, t0 = loadavg(), cpu_ticks(pids), time.perf_counter()
        note(f"[round {r + 1}/{repeats}] {len(order)} measurements, load {before}")
        for c in order:
            if c.skipped is not None:
                continue
            try:
                c.runs.append(c.measure())
            except Exception as e:  # noqa: BLE001
                if isinstance(c, (Scripted, Batch)):
                    raise
                c.skipped = f"failed: {type(e).__name__}: {e}"
                note(f"[{c.key}] skipped: {c.skipped}")
        secs = time.perf_counter() - t0
        rounds.append(
            {
                "round": r + 1,
                "load_before": before,
                "load_after": loadavg(),
                "seconds": secs,
                # CPU used by every other process on the machine during the round, in cores (0 = the
                # benchmark had the machine to itself; the load average counts the benchmark too).
                "others_cores": others_share(ticks, cpu_ticks(pids), secs),
            }
        )
    report["rounds"] = rounds
    for c in contenders:
        c.close()
    for w in workers.values():
        w.close()

    # Once-per-run results, under the keys earlier versions of this script used.
    res = {c.group: c.result() for c in once}
    report["wolfpack"] = {
        "scenario": "params.yaml (documented scenario)",
        "threads_1": res.get("scripted_1t", {"skipped": "--skip scripted"}),
        "threads_all": res.get("scripted_all", {"skipped": "--skip scripted"}),
    }
    if mpe2 is None:
        report["mpe2"] = {"skipped": "--skip mpe2"}
    else:
        report["mpe2"] = res["mpe2"]
        if "skipped" not in res["mpe2"]:
            report["mpe2"]["physics_only_env_steps_per_second"] = res["mpe2_physics"].get("env_steps_per_second")
    report["batch"] = {}
    for c in per_size:
        report["batch"].setdefault(str(c.num_envs), {})[c.group] = c.result()
    for E in map(str, sizes):
        report["batch"].setdefault(E, {})
    report["vmas"] = report["batch"].get("1", {}).get("vmas", {"skipped": "--skip vmas" if "vmas" in skip else "E = 1 not in --sizes"})
    report["reference"] = REFERENCE
    report["ratios_by_size"] = {E: size_ratios(row, threads) for E, row in report["batch"].items()}

    one, all_ = rate(report["wolfpack"]["threads_1"]), rate(report["wolfpack"]["threads_all"])
    mpe, phys = rate(report["mpe2"]), report["mpe2"].get("physics_only_env_steps_per_second")
    ref = REFERENCE["env_steps_per_second"]
    report["ratios"] = {
        "wolfpack(1 thread) / mpe2": ratio(one, mpe),
        "wolfpack(all cores) / mpe2": ratio(all_, mpe),
        "wolfpack(1 thread) / mpe2 world.step() only": ratio(one, phys),
        "wolfpack(1 thread) / reference": ratio(one, ref),
        "wolfpack(all cores) / reference": ratio(all_, ref),
    }
    if "1" in report["batch"]:
        report["ratios"]["BatchEnv(1t), E=1 / mpe2"] = ratio(rate(report["batch"]["1"].get("batch_env_1t")), mpe)
    report["machine"]["load_average_after"] = loadavg()
    report["wall_seconds"] = time.perf_counter() - t_start

    if args.json:
        print(json.dumps(report, indent=2))
    else:
        print(tables(report))
    return 0


if __name__ == "__main__":
    sys.exit(main())
