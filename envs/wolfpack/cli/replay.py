"""``wolfpack replay``: a saved episode re-rendered to video, plots and a page, without
re-simulating it."""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Sequence

from wolfpack import _core, logs, render
from wolfpack.cli.args import folder, int_at_least, one_line
from wolfpack.interrupt import CtrlC
from wolfpack.viewer.encode import encode_episode
from wolfpack.viewer.page import page_data, write_page

REPLAY_DESCRIPTION = """\
Re-render a saved episode without re-simulating it: episode.mp4 (one frame per recorded state,
10 fps = real time), trajectory.png, curves.png and interaction.png, from the trajectory.npz that
'wolfpack hunt --out DIR' wrote into DIR/episode_{k:03d}/. The frames are exactly those of
render_mode="rgb_array" during the live run. Body size and sensing radius come from the run's
DIR/summary.json when it is there, else from the documented scenario. The arrays are checked
first (keys, numeric dtypes, shapes consistent with each other, finite poses and energies): a
file that fails exits with status 2 and one line naming the array.

examples:
  wolfpack hunt --episodes 3 --out runs/demo
  wolfpack replay runs/demo/episode_000
  wolfpack replay runs/demo/episode_001/trajectory.npz --out /tmp/ep1 --size 768
  wolfpack replay runs/demo/episode_000 --no-video --no-plots --frames 0 100 --out /tmp/pics
"""


def add_parser(sub) -> argparse.ArgumentParser:
    """Adds ``wolfpack replay`` to the subcommands ``sub``."""
    replay = sub.add_parser(
        "replay", help="re-render a saved episode (trajectory.npz) to video and plots without re-simulating", description=REPLAY_DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    replay.add_argument("episode", metavar="EPISODE_DIR", type=folder, help="an episode folder of 'wolfpack hunt --out' (holding trajectory.npz), or the .npz itself")
    replay.add_argument("--out", metavar="DIR", type=folder, help="where to write episode.mp4, trajectory.png, curves.png and interaction.png (default: EPISODE_DIR)")
    replay.add_argument("--no-video", action="store_true", help="no episode.mp4")
    replay.add_argument("--no-plots", action="store_true", help="no trajectory.png, curves.png, interaction.png")
    replay.add_argument("--frames", metavar="T", type=int_at_least(0), nargs="+", default=[], help="also write the frames of these steps as frame_TTT.png (a step past the end: the last frame)")
    replay.add_argument("--size", metavar="PX", type=int_at_least(16), default=512, help="video frame width and height in pixels (default: 512)")
    replay.add_argument("--trail", metavar="STEPS", type=int_at_least(0), default=40, help="trail length in steps (default: 40)")
    replay.add_argument("--html", action="store_true", help="also write episode.html, a self-contained page that plays the episode in the browser ('wolfpack view --help')")
    replay.set_defaults(func=cmd_replay)
    return replay


def load_episode(where: Path) -> tuple[dict, dict, Path]:
    """(arrays, params, episode folder) of a saved episode; ValueError saying what is wrong."""
    npz = where if where.suffix == ".npz" else where / "trajectory.npz"
    if not where.exists():
        raise ValueError(f"{where}: no such episode folder or file")
    if not npz.is_file():
        raise ValueError(f"{where}: no trajectory.npz there (an episode folder of 'wolfpack hunt --out DIR' is DIR/episode_000)")
    try:
        arrays = logs.load_trajectory(npz)
    except Exception as e:  # zip/npy errors of every kind: the file is not a trajectory
        raise ValueError(f"{npz}: not a readable trajectory.npz ({type(e).__name__}: {one_line(e)})") from None
    try:
        logs.check_trajectory(arrays)
    except ValueError as e:
        raise ValueError(f"{npz}: {e}") from None
    folder = npz.parent
    params = _core.validate_params(None, resolve=True)
    summary = folder.parent / logs.SUMMARY_NAME
    if summary.is_file():
        try:
            params = _core.validate_params(json.loads(summary.read_text())["params"], resolve=True)
        except (ValueError, KeyError, TypeError):
            pass  # an unreadable summary: the defaults draw the bodies and sensing circles
    return arrays, params, folder


def cmd_replay(args: argparse.Namespace, argv: Sequence[str]) -> None:
    from wolfpack import plots as plotting

    arrays, params, folder = load_episode(Path(args.episode))
    out = Path(args.out) if args.out else folder
    out.mkdir(parents=True, exist_ok=True)
    label = f"{folder.name} (replay)"
    written = []
    # Every file under a temporary name first (logs.atomic_path): Ctrl-C leaves no partial one.
    if not args.no_plots:
        for name, plot in (("trajectory.png", plotting.plot_trajectory), ("curves.png", plotting.plot_curves), ("interaction.png", plotting.plot_interaction)):
            CtrlC.check()
            with logs.atomic_path(out / name, keep_suffix=True) as tmp:
                plot(arrays, tmp, label=label)
            written.append(name)
    options = render.FrameOptions(width=args.size, height=args.size, trail=args.trail)
    if not args.no_video:
        with logs.atomic_path(out / "episode.mp4", keep_suffix=True) as tmp:
            frames = render.write_video(CtrlC.checked(render.trajectory_frames(arrays, params, options)), tmp)
        written.insert(0, f"episode.mp4 ({frames} frames)")
    if args.html:
        label = f"{folder.name} (seed {int(arrays['seed'])})" if "seed" in arrays else folder.name
        write_page(out / "episode.html", page_data([encode_episode(arrays, params, label)]), f"wolfpack replay: {label}")
        written.append("episode.html")
    if args.frames:
        import imageio.v3 as iio

        last = len(arrays["wolves"]) - 1
        wanted = {min(t, last) for t in args.frames}
        for t, frame in enumerate(CtrlC.checked(render.trajectory_frames(arrays, params, options))):
            if t in wanted:
                with logs.atomic_path(out / f"frame_{t:03d}.png", keep_suffix=True) as tmp:
                    iio.imwrite(tmp, frame)
                written.append(f"frame_{t:03d}.png")
    print(f"wrote {', '.join(written) or 'nothing'} to {out}")
