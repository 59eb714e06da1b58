"""Frames of a hunt: headless RGB rendering for envs, ``wolfpack hunt --video`` and replays.

The pixels come from the Rust core (:func:`wolfpack._core.render_frame`, tiny-skia): no display
server, no SDL, pyglet or X, so ``render_mode="rgb_array"`` works on a headless machine. This
module only assembles the scene — from a live ``world_state()`` or from a saved
``trajectory.npz`` — with the same numbers either way, so a replay reproduces the live frames
exactly.

A frame shows the arena (outside grey), obstacles with their exact shapes (static dark grey,
moving brown), each agent's trail over the last ``trail`` steps, the
capture ring (radius ``capture.distance``) around every uncaptured target, optionally each
agent's sensing circle and the interaction links of the step (observer → observed, from the
interaction matrix), wolves as oriented triangles in their own colours (``wolf_colour(i)``),
targets in red (hollow once captured), and, in a band above the arena, the step count and a legend strip. Bodies are
drawn at true size but at least 9 px long.
"""

from __future__ import annotations

from collections import deque
from typing import Any, Iterator, Mapping

import numpy as np

from wolfpack import _core

#: Default frame size (pixels).
DEFAULT_WIDTH = 512
DEFAULT_HEIGHT = 512
#: Default trail length (steps).
DEFAULT_TRAIL = 40

#: RGB colours, as the core draws them (read from it).
WOLF_COLOURS: list[tuple[int, int, int]] = [tuple(c) for c in _core.WOLF_COLOURS]
TARGET_COLOUR: tuple[int, int, int] = tuple(_core.TARGET_COLOUR)
STATIC_OBSTACLE_COLOUR: tuple[int, int, int] = tuple(_core.STATIC_OBSTACLE_COLOUR)
MOVING_OBSTACLE_COLOUR: tuple[int, int, int] = tuple(_core.MOVING_OBSTACLE_COLOUR)
MIN_BODY_PIXELS = 9.0


def wolf_colour(i: int) -> tuple[int, int, int]:
    return WOLF_COLOURS[i % len(WOLF_COLOURS)]


class FrameOptions:
    """What a frame shows and how large it is; checked once (ValueError naming the option)."""

    def __init__(self, width: int = DEFAULT_WIDTH, height: int = DEFAULT_HEIGHT, trail: int = DEFAULT_TRAIL, sensing: bool = False, links: bool = False) -> None:
        for name, value, lo in (("width", width, 16), ("height", height, 16), ("trail", trail, 0)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < lo or (name != "trail" and value > 4096):
                limit = f"an integer >= {lo}" if name == "trail" else "an integer in 16..4096"
                raise ValueError(f"render {name} must be {limit}, got {value!r}")
        self.width, self.height, self.trail = int(width), int(height), int(trail)
        self.sensing, self.links = bool(sensing), bool(links)


def _body(params: Mapping[str, Any]) -> float:
    body = params["agents"]["body"]
    return float(max(body["height"], body["base"]))


def _scene(params: Mapping[str, Any], border, wolves, targets, captured, obstacles, trails, interaction, step: int, opts: FrameOptions) -> dict:
    links = []
    if opts.links and interaction is not None:
        links = [[int(i), int(j)] for i, j in zip(*np.nonzero(interaction)) if i != j]
    return {
        "border": [float(v) for v in border],
        "wolves": np.asarray(wolves, dtype=np.float64)[:, :3].tolist(),
        "targets": np.asarray(targets, dtype=np.float64)[:, :3].tolist(),
        "target_captured": [bool(c) for c in captured],
        "obstacles": obstacles,
        "trails": trails,
        "links": links,
        "capture_distance": float(params["capture"]["distance"]),
        "sense_radius": float(params["agents"]["wolf"]["sense_radius"]) if opts.sensing else 0.0,
        "body": _body(params),
        "step": int(step),
    }


def _trails(history: list[np.ndarray]) -> list[list[list[float]]]:
    """Per-agent polylines from positions [L, N+M, 2], oldest first."""
    if not history:
        return []
    stacked = np.stack(history)  # [L, A, 2]
    return stacked.transpose(1, 0, 2).tolist()


def _draw(scene: dict, opts: FrameOptions) -> np.ndarray:
    return _core.render_frame(scene, opts.width, opts.height)


class LiveRenderer:
    """Frames of a running world: call :meth:`record` with every new ``world_state()`` (reset
    and each step), :meth:`frame` whenever a picture is wanted."""

    def __init__(self, params: Mapping[str, Any], options: FrameOptions | None = None) -> None:
        self.params = params
        self.opts = options or FrameOptions()
        self._positions: deque[np.ndarray] = deque(maxlen=max(1, self.opts.trail + 1))
        self._state: Mapping[str, Any] | None = None

    def record(self, state: Mapping[str, Any]) -> None:
        if self._state is not None and state["step"] <= self._state["step"]:
            self._positions.clear()  # a new episode
        self._state = state
        self._positions.append(np.concatenate([state["wolves"][:, :2], state["targets"][:, :2]]))

    def frame(self) -> np.ndarray:
        if self._state is None:
            raise ValueError("render() before reset(): there is no world to draw yet")
        s = self._state
        obstacles = [
            {
                "kind": o["kind"],
                "moving": bool(o["moving"]),
                "center": [float(v) for v in o["center"]],
                "angle": float(o["angle"]),
                "radius": float(o["radius"]),
                "local": np.asarray(o["local"], dtype=np.float64).tolist(),
            }
            for o in s["obstacles"]
        ]
        history = list(self._positions)[-(self.opts.trail + 1) :] if self.opts.trail > 0 else []
        scene = _scene(
            self.params, self.params["world"]["border"], s["wolves"], s["targets"], s["captured"], obstacles, _trails(history), s["interaction"] if s["step"] > 0 else None, s["step"], self.opts
        )
        return _draw(scene, self.opts)


def trajectory_frames(arrays: Mapping[str, np.ndarray], params: Mapping[str, Any], options: FrameOptions | None = None) -> Iterator[np.ndarray]:
    """One frame per recorded state (T+1 frames) of a ``trajectory.npz`` (see :mod:`wolfpack.logs`),
    identical to what :class:`LiveRenderer` drew during the run. ``params`` supply the body
    size and sensing radius (the arrays carry border and capture distance)."""
    opts = options or FrameOptions()
    wolves, targets = np.asarray(arrays["wolves"]), np.asarray(arrays["targets"])
    rows = len(wolves)
    kinds = [str(k) for k in np.asarray(arrays["obstacle_kind"]).reshape(-1)]
    poses = np.asarray(arrays["obstacle_poses"], dtype=np.float64)
    radius = np.asarray(arrays["obstacle_radius"], dtype=np.float64)
    table = np.asarray(arrays["obstacle_vertices"], dtype=np.float64)
    local = [table[k][~np.isnan(table[k]).any(axis=1)].tolist() if table.size else [] for k in range(len(kinds))]
    interaction = np.asarray(arrays["interaction"])
    ended_at = _target_end_steps(arrays, targets.shape[1], rows)
    scene_params = {**params, "capture": {**params["capture"], "distance": float(np.asarray(arrays["capture_distance"]))}}
    positions = np.concatenate([wolves[:, :, :2], targets[:, :, :2]], axis=1)
    for t in range(rows):
        obstacles = [
            {
                "kind": "circle" if kinds[k].endswith("circle") else "polygon",
                "moving": kinds[k].startswith("moving"),
                "center": poses[t, k, :2].tolist(),
                "angle": float(poses[t, k, 2]),
                "radius": float(radius[k]),
                "local": local[k],
            }
            for k in range(len(kinds))
        ]
        history = list(positions[max(0, t - opts.trail) : t + 1]) if opts.trail > 0 else []
        captured = [0 <= end <= t for end in ended_at]
        scene = _scene(scene_params, arrays["border"], wolves[t], targets[t], captured, obstacles, _trails(history), interaction[t - 1] if t > 0 else None, t, opts)
        yield _draw(scene, opts)


def _target_end_steps(arrays: Mapping[str, np.ndarray], m: int, rows: int) -> list[int]:
    """The step each target's hunt ended (−1: never), as the live world flagged it. Files from
    before ``target_capture_step`` existed know only the episode's outcome: every target then
    counts as captured at the last step of a captured episode."""
    if "target_capture_step" in arrays:
        return [int(c) for c in np.asarray(arrays["target_capture_step"]).reshape(-1)]
    ended = str(np.asarray(arrays["outcome"])) in ("captured", "cornered")
    return [rows - 1 if ended else -1] * m


#: Render modes of the envs.
RENDER_MODES = ["human", "rgb_array"]
#: matplotlib backends that draw to files only.
NON_INTERACTIVE_BACKENDS = {"agg", "pdf", "ps", "svg", "pgf", "cairo", "template"}


def display_available() -> bool:
    """Whether a window can be opened: a DISPLAY or WAYLAND_DISPLAY on Linux/BSD; assumed
    elsewhere (macOS, Windows)."""
    import os
    import sys

    if sys.platform.startswith(("linux", "freebsd", "openbsd", "netbsd")):
        return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))
    return True


class EnvRendering:
    """``render_mode`` handling shared by the ParallelEnv and Escape-v0.

    ``rgb_array``: :meth:`render` returns the current frame (H×W×3 uint8). ``human``: each
    :meth:`render` shows the frame in a matplotlib window and returns None; without a display
    it warns once and shows nothing (so headless test suites can still exercise the mode).
    """

    def __init__(self, render_mode: str | None, params: Mapping[str, Any], options: FrameOptions | None = None, fps: float = 10.0) -> None:
        self.mode = render_mode
        self.live = LiveRenderer(params, options) if render_mode is not None else None
        self.fps = fps
        self._window = None
        self._warned = False

    def record(self, state_fn) -> None:
        """Remember the new state (called after every reset and step; free without a mode)."""
        if self.live is not None:
            self.live.record(state_fn())

    def render(self) -> np.ndarray | None:
        if self.live is None:
            return None
        frame = self.live.frame()
        if self.mode == "rgb_array":
            return frame
        self._show(frame)
        return None

    def _warn_once(self, message: str) -> None:
        if not self._warned:
            import warnings

            warnings.warn(message, stacklevel=4)
            self._warned = True

    def _show(self, frame: np.ndarray) -> None:
        if not display_available():
            self._warn_once("render_mode='human': no display (DISPLAY is not set), nothing is shown; use render_mode='rgb_array' on a headless machine")
            return
        import matplotlib.pyplot as plt

        if plt.get_backend().lower() in NON_INTERACTIVE_BACKENDS:
            # matplotlib could not start a GUI backend (no reachable X server, no tkinter/Qt)
            self._warn_once(
                f"render_mode='human': matplotlib has no window backend here (it chose {plt.get_backend()!r}), nothing is shown; set MPLBACKEND=TkAgg or QtAgg, or use render_mode='rgb_array'"
            )
            return

        if self._window is None:
            fig, ax = plt.subplots(figsize=(frame.shape[1] / 100, frame.shape[0] / 100), dpi=100)
            ax.set_axis_off()
            fig.subplots_adjust(0, 0, 1, 1)
            self._window = (fig, ax.imshow(frame))
            plt.show(block=False)
        else:
            self._window[1].set_data(frame)
        self._window[0].canvas.draw_idle()
        plt.pause(1.0 / self.fps)

    def close(self) -> None:
        if self._window is not None:
            import matplotlib.pyplot as plt

            plt.close(self._window[0])
            self._window = None


#: Frames per second of videos: one frame per step at Ts = 0.1 s is real time.
VIDEO_FPS = 10


def write_video(frames, path, fps: float = VIDEO_FPS) -> int:
    """Encodes RGB frames (an iterable of equal-sized H×W×3 uint8 arrays) as an H.264 mp4 with
    the ffmpeg binary of the imageio-ffmpeg wheel; returns the number of frames written."""
    import imageio.v2 as imageio

    count = 0
    # macro_block_size=1: keep the frame size as it is (the default size 512 is a multiple of
    # 16 anyway); yuv420p so that every player decodes it. Log level "fatal": a Ctrl-C that lands
    # inside a frame write leaves ffmpeg a partial frame, which it would report on the user's
    # terminal below the one-line "interrupted" (an ffmpeg failure still raises here).
    with imageio.get_writer(str(path), fps=fps, codec="libx264", macro_block_size=1, pixelformat="yuv420p", ffmpeg_log_level="fatal") as writer:
        for frame in frames:
            writer.append_data(frame)
            count += 1
    return count


def read_video(path) -> np.ndarray:
    """All frames of a video as one uint8 array [F, H, W, 3] (for tests and checks)."""
    import imageio.v3 as iio

    return iio.imread(str(path), plugin="FFMPEG")
