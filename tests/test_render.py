"""Rendering: frames from the Rust rasteriser through the envs, hunt --video and replay.

Frames must have the right shape and dtype, change between steps, agree with the world state
(the pixel at a body's centroid has that agent's colour), work without a display, and a replay
of trajectory.npz must give exactly the live frames."""

from __future__ import annotations

import os
import subprocess
import sys

import gymnasium
import numpy as np
import pytest
import wolfpack
from pettingzoo.test import render_test
from wolfpack import render
from wolfpack.cli import main as cli_main


def pixel_of(frame: np.ndarray, border, x: float, y: float) -> tuple[int, int, int]:
    """The pixel showing world point (x, y): the same mapping as render.rs's View (a status band
    of 5 % of the height, 8–40 px, on top; the arena fills 94 % of the rest, centred, y up)."""
    h, w = frame.shape[:2]
    x0, y0, x1, y1 = border
    below = h - min(max(round(h * 0.05), 8), 40)
    scale = 0.94 * min(w / (x1 - x0), below / (y1 - y0))
    ox = (w - scale * (x1 - x0)) / 2 - scale * x0
    oy = (below - scale * (y1 - y0)) / 2 - scale * y0
    px, py = ox + scale * x, h - (oy + scale * y)
    return tuple(int(v) for v in frame[int(np.floor(py)), int(np.floor(px))])


def centroid(pose, body_height: float, scale_px: float) -> tuple[float, float]:
    h = max(body_height, render.MIN_BODY_PIXELS / scale_px)
    return pose[0] + h / 3 * np.cos(pose[2]), pose[1] + h / 3 * np.sin(pose[2])


class _nothing:
    def __enter__(self):
        return self

    def __exit__(self, *exc):
        return False


def test_rgb_array_frames_agree_with_the_world_state():
    env = wolfpack.parallel_env(render_mode="rgb_array")
    env.reset(seed=5)
    frames = [env.render()]
    for _ in range(30):
        env.step(env.unwrapped.expert_actions())
        frames.append(env.render())
    for f in frames:
        assert f.shape == (512, 512, 3) and f.dtype == np.uint8
    assert all((a != b).any() for a, b in zip(frames, frames[1:])), "every step changes the frame (the clock at least)"
    state = env.unwrapped.world_state()
    border = env.unwrapped.params["world"]["border"]
    scale = 0.94 * (512 - 26) / (border[3] - border[1])  # 26 px status band (5 % of 512)
    height = env.unwrapped.params["agents"]["body"]["height"]
    poses = list(state["wolves"]) + list(state["targets"])
    colours = [render.wolf_colour(i) for i in range(len(state["wolves"]))] + [render.TARGET_COLOUR] * len(state["targets"])
    checked = 0
    for k, (pose, colour) in enumerate(zip(poses, colours)):
        # only agents whose body no other body overlaps (bodies are drawn in index order)
        if any(np.hypot(*(np.asarray(q[:2]) - pose[:2])) < 2 * 9 / scale for j, q in enumerate(poses) if j != k):
            continue
        assert pixel_of(frames[-1], border, *centroid(pose, height, scale)) == colour, f"agent {k}"
        checked += 1
    assert checked >= 2
    # an obstacle's centre (circles) shows its kind's colour
    for o in state["obstacles"]:
        if o["kind"] == "circle" and o["radius"] * scale > 4:
            want = render.MOVING_OBSTACLE_COLOUR if o["moving"] else render.STATIC_OBSTACLE_COLOUR
            assert pixel_of(frames[-1], border, *o["center"]) == want


def test_render_options_and_bad_render_input():
    env = wolfpack.parallel_env(render_mode="rgb_array", render_options={"width": 320, "height": 200, "sensing": True, "links": True, "trail": 0})
    env.reset(seed=0)
    assert env.render().shape == (200, 320, 3)
    with pytest.raises(ValueError, match="render_mode"):
        wolfpack.parallel_env(render_mode="ansi")
    with pytest.raises(ValueError, match="render_mode"):
        gymnasium.make("wolfpack/Escape-v0", render_mode="rgb")
    with pytest.raises(ValueError, match="render_options: unknown key"):
        wolfpack.parallel_env(render_mode="rgb_array", render_options={"colour": "blue"})
    with pytest.raises(ValueError, match="render width"):
        wolfpack.parallel_env(render_mode="rgb_array", render_options={"width": 5})
    fresh = wolfpack.parallel_env(render_mode="rgb_array")
    with pytest.raises(ValueError, match="before reset"):
        fresh.render()
    with pytest.raises(ValueError, match="unknown field"):
        wolfpack._core.render_frame({"bogus": 1}, 64, 64)
    assert wolfpack.parallel_env().render() is None


def test_pettingzoo_render_test_passes():
    # PettingZoo's render test drives the AEC API: our ParallelEnv through its standard
    # parallel_to_aec conversion, every render mode (human warns: no display here).
    from pettingzoo.utils.conversions import parallel_to_aec

    with pytest.warns(UserWarning, match="no display") if not render.display_available() else _nothing():
        render_test(lambda render_mode=None: parallel_to_aec(wolfpack.parallel_env(render_mode=render_mode)))


def test_rendering_needs_no_display(tmp_path):
    """A fresh interpreter without DISPLAY/WAYLAND_DISPLAY renders frames, and human mode warns
    instead of failing."""
    code = (
        "import warnings, wolfpack, gymnasium\n"
        "e = gymnasium.make('wolfpack/Escape-v0', render_mode='rgb_array'); e.reset(seed=0)\n"
        "f = e.render(); assert f.shape == (512, 512, 3) and f.any()\n"
        "h = wolfpack.parallel_env(render_mode='human'); h.reset(seed=0)\n"
        "with warnings.catch_warnings(record=True) as w:\n"
        "    warnings.simplefilter('always')\n"
        "    assert h.render() is None\n"
        "assert any('no display' in str(x.message) for x in w)\n"
        "print('ok')\n"
    )
    env = {k: v for k, v in os.environ.items() if k not in ("DISPLAY", "WAYLAND_DISPLAY")}
    env["MPLBACKEND"] = ""
    env.pop("MPLBACKEND")
    done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr


def test_gymnasium_record_video_on_escape(tmp_path):
    pytest.importorskip("moviepy")
    env = gymnasium.wrappers.RecordVideo(gymnasium.make("wolfpack/Escape-v0", render_mode="rgb_array"), str(tmp_path), episode_trigger=lambda k: True, disable_logger=True)
    env.reset(seed=1)
    steps = 0
    done = False
    while not done:
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        steps += 1
        done = term or trunc
    env.close()
    videos = list(tmp_path.glob("*.mp4"))
    assert len(videos) == 1
    # RecordVideo captures the reset frame and every step's; it may drop the terminal one
    assert len(render.read_video(videos[0])) in (steps, steps + 1)


def test_hunt_video_has_one_frame_per_state_and_replay_reproduces_the_live_frames(tmp_path, capsys):
    out = tmp_path / "run"
    cli_main(["hunt", "--episodes", "1", "--seed", "4", "--out", str(out), "--video"])
    episode = out / "episode_000"
    arrays = wolfpack.logs.load_trajectory(episode / "trajectory.npz")
    video = render.read_video(episode / "episode.mp4")
    assert video.shape == (len(arrays["wolves"]), 512, 512, 3)
    # The live run through the ParallelEnv with the scripted laws as actions draws what the
    # replay of the saved arrays draws, frame for frame.
    env = wolfpack.parallel_env(learners="none", render_mode="rgb_array")
    env.reset(seed=4)
    live = [env.render()]
    state = env.unwrapped.world_state()
    while state["outcome"] == "running":
        env.step({})
        live.append(env.render())
        state = env.unwrapped.world_state()
    replayed = list(render.trajectory_frames(arrays, env.unwrapped.params))
    assert len(live) == len(replayed) == len(arrays["wolves"])
    for t, (a, b) in enumerate(zip(live, replayed)):
        assert np.array_equal(a, b), f"frame {t} differs"
    # wolfpack replay writes video and plots elsewhere
    capsys.readouterr()
    cli_main(["replay", str(episode), "--out", str(tmp_path / "re")])
    for name in ("episode.mp4", "trajectory.png", "curves.png"):
        assert (tmp_path / "re" / name).is_file(), name
    assert len(render.read_video(tmp_path / "re" / "episode.mp4")) == len(arrays["wolves"])


@pytest.mark.parametrize(
    "argv, message",
    [
        (["hunt", "--episodes", "1", "--video"], "--video needs --out"),
        (["replay", "/nonexistent/episode_000"], "no such episode"),
    ],
)
def test_bad_video_and_replay_input(argv, message, capsys):
    with pytest.raises(SystemExit) as done:
        cli_main(argv)
    assert done.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err and err.count("\n") == 1


def test_replay_of_a_corrupt_or_foreign_directory(tmp_path, capsys):
    (tmp_path / "empty").mkdir()
    (tmp_path / "corrupt").mkdir()
    (tmp_path / "corrupt" / "trajectory.npz").write_bytes(b"PK\x03\x04 not really a zip")
    (tmp_path / "foreign").mkdir()
    np.savez(tmp_path / "foreign" / "trajectory.npz", wolves=np.zeros((3, 5, 5)))
    for name, message in (("empty", "no trajectory.npz"), ("corrupt", "not a readable trajectory.npz"), ("foreign", "not a wolfpack trajectory")):
        with pytest.raises(SystemExit) as done:
            cli_main(["replay", str(tmp_path / name)])
        assert done.value.code == 2, name
        err = capsys.readouterr().err
        assert message in err and "Traceback" not in err, err


def test_replay_frames_are_pngs_of_the_replayed_frames(tmp_path):
    import imageio.v3 as iio

    cli_main(["hunt", "--episodes", "1", "--seed", "2", "--out", str(tmp_path / "run"), "--plots", "0"])
    episode = tmp_path / "run" / "episode_000"
    cli_main(["replay", str(episode), "--no-video", "--no-plots", "--frames", "0", "9999", "--out", str(tmp_path / "pics")])
    arrays = wolfpack.logs.load_trajectory(episode / "trajectory.npz")
    last = len(arrays["wolves"]) - 1
    assert sorted(p.name for p in (tmp_path / "pics").iterdir()) == ["frame_000.png", f"frame_{last:03d}.png"]
    frames = list(render.trajectory_frames(arrays, wolfpack.load_params()))
    assert np.array_equal(iio.imread(tmp_path / "pics" / "frame_000.png"), frames[0])
    assert np.array_equal(iio.imread(tmp_path / "pics" / f"frame_{last:03d}.png"), frames[-1])


def test_human_mode_without_a_window_backend_warns_and_returns_none(monkeypatch):
    """A DISPLAY that matplotlib cannot use (here: a display variable with no X server behind
    it, so matplotlib stays on Agg) must not fail; it warns once."""
    import matplotlib

    matplotlib.use("Agg")
    monkeypatch.setenv("DISPLAY", ":99")
    env = wolfpack.parallel_env(render_mode="human")
    env.reset(seed=0)
    with pytest.warns(UserWarning, match="no window backend"):
        assert env.render() is None
    env.step(env.unwrapped.expert_actions())
    assert env.render() is None  # once only: no second warning needed
    env.close()


@pytest.mark.skipif(not __import__("shutil").which("Xvfb"), reason="Xvfb (a virtual X server) is not installed")
def test_human_mode_opens_a_window_on_a_display(tmp_path):
    """Under a virtual X server, human mode draws into a real matplotlib window (TkAgg/QtAgg)."""
    display = ":%d" % (90 + os.getpid() % 9)
    server = subprocess.Popen(["Xvfb", display, "-screen", "0", "800x600x24"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    try:
        code = (
            "import warnings, wolfpack\n"
            "warnings.simplefilter('error')\n"
            "env = wolfpack.parallel_env(render_mode='human'); env.reset(seed=0)\n"
            "for _ in range(3):\n"
            "    env.step(env.unwrapped.expert_actions()); assert env.render() is None\n"
            "import matplotlib.pyplot as plt\n"
            "assert plt.get_backend().lower() not in ('agg',), plt.get_backend()\n"
            "assert plt.get_fignums(), 'no window'\n"
            "env.close(); assert not plt.get_fignums()\n"
            "print('ok')\n"
        )
        env = {**os.environ, "DISPLAY": display}
        env.pop("MPLBACKEND", None)
        import time

        time.sleep(1.0)  # let the server come up
        done = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
        if "TclError" in done.stderr or "no window backend" in done.stderr:
            pytest.skip(f"no GUI toolkit for matplotlib here: {done.stderr.strip().splitlines()[-1]}")
        assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr
    finally:
        server.terminate()
        server.wait(timeout=10)


def test_replay_hides_each_targets_ring_from_its_own_capture_step(tmp_path):
    """Two still targets captured at steps 17 and 78 (seed 3): the replay of trajectory.npz
    draws every frame as the live render did, including the first target shown captured (its
    ring hidden, hollow) from step 17 on while the other is still hunted."""
    sets = {"world.targets": 2, "policies.targets": "still", "capture.count": 3}
    out = tmp_path / "run"
    cli_main(["hunt", "--episodes", "1", "--seed", "3", "--plots", "0", "--out", str(out), *[a for k, v in sets.items() for a in ("--set", f"{k}={v}")]])
    arrays = wolfpack.logs.load_trajectory(out / "episode_000" / "trajectory.npz")
    assert arrays["target_capture_step"].tolist() == [78, 17]
    env = wolfpack.parallel_env(learners="none", render_mode="rgb_array", **sets)
    env.reset(seed=3)
    live = [env.render()]
    while env.unwrapped.world_state()["outcome"] == "running":
        env.step({})
        live.append(env.render())
    replayed = list(render.trajectory_frames(arrays, env.unwrapped.params))
    assert len(live) == len(replayed) == 79
    for t, (a, b) in enumerate(zip(live, replayed)):
        assert np.array_equal(a, b), f"frame {t} differs"
