"""The contenders of ``peers.py`` and how each is run: wolfpack's (scripted episodes,
``BatchEnv``, ``make_vec_env``) and mpe2 in this process, VMAS and JaxMARL through a
``peer_worker.py`` process each; every one prepared once (built, warmed up, its step count
sized), then measured once per round. Also the standalone measurements and helpers that
``learning.py`` and ``render.py`` use (``attempt``, ``median_rate``, ``bench_mpe2``,
``bench_vmas``)."""

from __future__ import annotations

import json
import os
import statistics
import subprocess
import sys
import time
from pathlib import Path
from typing import Any, Callable

from calibration import calibrate
from machine import usable_cores
from peer_scenarios import COUNTS, vmas_simple_tag

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


def note(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


def median_rate(runs: list[tuple[int, float]]) -> float:
    return statistics.median(steps / secs for steps, secs in runs)


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
