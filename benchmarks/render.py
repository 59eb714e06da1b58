#!/usr/bin/env python3
"""Rendering speed: wolfpack's ``rgb_array`` frames against mpe2's, same resolution, one run.

Both sides render the same counts (5 pursuers, 1 evader, 12 obstacles) at mpe2's frame size
(700 × 700, its fixed screen) on a headless machine (pygame with SDL's dummy video driver for
mpe2; wolfpack needs no display at all). Timed: ``env.render()`` alone, on states reached by
stepping with random actions outside the clock, one frame per step.

1. **wolfpack** ``parallel_env(render_mode="rgb_array", render_options={"width": 700,
   "height": 700})``: trails (40 steps), capture ring, bodies, exact obstacle shapes, step count;
   also with sensing circles and interaction links on.
2. **mpe2** ``simple_tag_v3.parallel_env(render_mode="rgb_array")``.
3. The cost of a whole ``wolfpack hunt --video`` episode: frames from trajectory.npz plus
   H.264 encoding (imageio-ffmpeg), per frame.

Usage::

    python benchmarks/render.py          # table
    python benchmarks/render.py --json
    python benchmarks/render.py --quick  # smoke run
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
os.environ.setdefault("SDL_VIDEODRIVER", "dummy")  # pygame (mpe2) without a display
os.environ.setdefault("PYGAME_HIDE_SUPPORT_PROMPT", "1")

import numpy as np
from machine import machine_info
from peer_contenders import attempt, median_rate
from peer_scenarios import COUNTS

SIZE = 700  # mpe2's screen is 700 x 700 pixels


def bench_wolfpack_frames(frames: int, repeats: int, sensing_and_links: bool) -> dict:
    import wolfpack

    options = {"width": SIZE, "height": SIZE, "sensing": sensing_and_links, "links": sensing_and_links}
    env = wolfpack.parallel_env(render_mode="rgb_array", render_options=options)
    rng = np.random.default_rng(0)
    runs = []
    for r in range(repeats):
        env.reset(seed=r)
        total = 0.0
        shape = None
        for _ in range(frames):
            if not env.agents:
                env.reset(seed=r + 1000)
            env.step({a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents})
            t0 = time.perf_counter()
            frame = env.render()
            total += time.perf_counter() - t0
            shape = frame.shape
        runs.append((frames, total))
    return {"frames_per_second": median_rate(runs), "shape": list(shape)}


def bench_mpe2_frames(frames: int, repeats: int) -> dict:
    from mpe2 import simple_tag_v3

    env = simple_tag_v3.parallel_env(
        num_good=COUNTS["targets"], num_adversaries=COUNTS["wolves"], num_obstacles=COUNTS["obstacles"], max_cycles=frames + 10, continuous_actions=True, render_mode="rgb_array"
    )
    rng = np.random.default_rng(0)
    runs = []
    shape = None
    for r in range(repeats):
        env.reset(seed=r)
        total = 0.0
        for _ in range(frames):
            env.step({a: rng.random(env.action_space(a).shape[0], dtype=np.float32) for a in env.agents})
            t0 = time.perf_counter()
            frame = env.render()
            total += time.perf_counter() - t0
            shape = frame.shape
        runs.append((frames, total))
    env.close()
    return {"frames_per_second": median_rate(runs), "shape": list(shape)}


def bench_video(repeats: int) -> dict:
    """A whole episode to mp4 (wolfpack hunt --video's path) at the default 512 x 512."""
    import wolfpack
    from wolfpack import logs, render

    params = wolfpack.load_params()
    result = wolfpack.run_episodes(params, episodes=1, seed=0, record=True)[0]
    arrays = logs.trajectory_arrays(result, wolfpack._core.validate_params(params, resolve=True))
    runs = []
    with tempfile.TemporaryDirectory() as tmp:
        for _ in range(repeats):
            t0 = time.perf_counter()
            n = render.write_video(render.trajectory_frames(arrays, params), Path(tmp) / "episode.mp4")
            runs.append((n, time.perf_counter() - t0))
    return {"frames_per_second": median_rate(runs), "frames": runs[0][0]}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--json", action="store_true")
    ap.add_argument("--quick", action="store_true", help="few frames: a smoke run, not a measurement")
    args = ap.parse_args(argv)
    frames, repeats = (20, 1) if args.quick else (200, 3)
    report = {
        "machine": machine_info(),
        "size": [SIZE, SIZE],
        "wolfpack": attempt("wolfpack", lambda: bench_wolfpack_frames(frames, repeats, False)),
        "wolfpack_sensing_links": attempt("wolfpack", lambda: bench_wolfpack_frames(frames, repeats, True)),
        "mpe2": attempt("mpe2", lambda: bench_mpe2_frames(frames, repeats), optional=True),
        "video": attempt("video", lambda: bench_video(1 if args.quick else 2)),
    }
    w, m = report["wolfpack"].get("frames_per_second"), report["mpe2"].get("frames_per_second")
    report["ratio_vs_mpe2"] = w / m if w and m else None
    if args.json:
        print(json.dumps(report))
        return 0
    mi = report["machine"]
    print(f"machine: {mi.get('cpu')}, {mi.get('cores')} cores, Python {mi.get('python')}")
    print(f"rgb_array frames of {SIZE}x{SIZE}, 5 pursuers, 1 evader, 12 obstacles; render() alone")
    for key, name in (("wolfpack", "wolfpack parallel_env"), ("wolfpack_sensing_links", "wolfpack + sensing circles, links"), ("mpe2", "mpe2 simple_tag_v3")):
        r = report[key]
        print(f"  {name:<36} {r.get('frames_per_second', 0) or 0:>10.0f} frames/s  {r.get('error', '')}")
    if report["ratio_vs_mpe2"]:
        print(f"wolfpack / mpe2: {report['ratio_vs_mpe2']:.1f}x")
    v = report["video"]
    print(f"whole episode to mp4 (512x512, frames + H.264): {v.get('frames_per_second', 0) or 0:.0f} frames/s over {v.get('frames')} frames")
    return 0


if __name__ == "__main__":
    sys.exit(main())
