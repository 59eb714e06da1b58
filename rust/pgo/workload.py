"""The training run of wolfpack's profile-guided optimisation (rust/pgo/regenerate.sh runs it
on an instrumented build of the extension).

PGO lays out and inlines code by how often each branch ran here, so this runs what users run,
in about the proportions that matter to them: scripted episodes of every wolf law (the engine
behind ``wolfpack hunt``), the native batch with either side learning at small and large E
(observations included), the SB3 VecEnv and the PettingZoo env, and a few rendered frames.
Code that never runs here is compiled as cold, so each public path gets at least a little
work. Prints what it ran and which extension it ran on (the instrumented one must be the one
Python imports).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import wolfpack
from wolfpack import _core


def scripted(law: str, episodes: int) -> None:
    params = wolfpack.load_params(overrides={"policies.wolves": law})
    results = wolfpack.run_episodes(params, episodes, seed=0, threads=1)
    print(f"  hunt {law}: {episodes} episodes, {sum(r['steps'] for r in results)} env-steps")


def batch(learners: str, num_envs: int, steps: int, into: bool = False, with_state: bool = False) -> None:
    """``steps`` random steps; ``into``: into the caller's buffers (``step(out=...)``, the
    trainer's way), else into new arrays."""
    env = wolfpack.BatchEnv(num_envs=num_envs, learners=learners, seed=1, threads=1, with_state=with_state)
    env.reset()
    out = env.new_outputs() if into else None
    rng = np.random.default_rng(0)
    n, m = env.n_wolves, env.n_targets
    for _ in range(steps):
        wolves = rng.uniform(-1, 1, (num_envs, n, 2)).astype(np.float32) if env.learns_wolves else None
        targets = rng.uniform(-1, 1, (num_envs, m, 2)).astype(np.float32) if env.learns_targets else None
        env.step(wolves, targets, out=out)
    print(f"  BatchEnv learners={learners} E={num_envs}{' into buffers' if into else ''}: {steps} steps")


def vec_env(num_envs: int, steps: int) -> None:
    venv = wolfpack.make_vec_env(num_envs=num_envs, seed=2, threads=1)
    venv.reset()
    actions = np.zeros((venv.num_envs, 2), np.float32)
    for _ in range(steps):
        venv.step(actions)
    print(f"  make_vec_env E={num_envs}: {steps} steps")


def parallel(steps: int) -> None:
    env = wolfpack.parallel_env(render_mode="rgb_array", seed=3)
    env.reset()
    frames = 0
    for t in range(steps):
        actions = {a: env.action_space(a).sample() for a in env.agents}
        _, _, terminations, truncations, _ = env.step(actions)
        if t % 25 == 0:
            env.render()
            frames += 1
        if any(terminations.values()) or any(truncations.values()):
            env.reset()
    print(f"  parallel_env: {steps} steps, {frames} frames")


def main() -> None:
    print(f"PGO workload on {_core.__file__}")
    start = time.perf_counter()
    scripted("seed000", 3000)
    scripted("bvc", 300)
    scripted("formation", 300)
    batch("wolves", 64, 1500)
    batch("wolves", 1024, 100)
    batch("targets", 64, 500)
    batch("all", 64, 300)
    batch("wolves", 256, 300, into=True, with_state=True)
    vec_env(64, 500)
    parallel(600)
    print(f"done in {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    sys.exit(main())
