"""The browser viewer: the packing of episodes (within its stated precision, within its size
budget), the pages the commands write (``wolfpack view``, ``hunt --out``'s index.html,
``replay --html``) and their refusals, and the page itself in a real browser (headless Chromium
from the system, driven by Playwright): it loads without a console error or a network request,
draws the recorded states, plays and pauses, keeps compared panes in step, and draws each wolf
in its colour where the state says it is."""

from __future__ import annotations

import base64
import json
import re
import shutil
import time
from pathlib import Path

import numpy as np
import pytest
import wolfpack
from conftest import synthetic_result
from wolfpack import _core, logs
from wolfpack.cli import main as cli_main
from wolfpack.viewer import encode
from wolfpack.viewer.page import page_data, render_page

PARAMS = _core.validate_params(None, resolve=True)
#: The largest error the packing may make (half a grid step, and float rounding).
POSITION_TOL = encode.POSITION_STEP / 2 + 1e-9
ANGLE_TOL = encode.ANGLE_STEP / 2 + 1e-9


def run(argv, capsys=None) -> tuple[int, str]:
    """``wolfpack ARGV`` in this process: (exit status, stderr)."""
    try:
        cli_main([str(a) for a in argv])
        status = 0
    except SystemExit as done:
        status = done.code or 0
    return status, capsys.readouterr().err if capsys is not None else ""


def page_json(path: Path) -> dict:
    """The data a page carries (its JSON script element)."""
    text = path.read_text(encoding="utf-8")
    found = re.search(r'<script type="application/json" id="wolfpack-data">(.*?)</script>', text, re.S)
    assert found, "no data in the page"
    return json.loads(found.group(1))


@pytest.fixture(scope="module")
def small_run(tmp_path_factory) -> Path:
    """Three short recorded episodes (60 steps at most) and their index.html."""
    out = tmp_path_factory.mktemp("viewer") / "run"
    cli_main(["hunt", "--episodes", "3", "--seed", "4", "--set", "world.max_steps=60", "--plots", "0", "--out", str(out)])
    return out


# --- packing -------------------------------------------------------------------------------


def test_varints_round_trip_every_magnitude():
    powers = 2 ** np.arange(41, dtype=np.int64)
    values = np.concatenate([[0], powers, -powers, powers - 1, 1 - powers, np.random.default_rng(0).integers(-(2**40) + 1, 2**40, 5000)])
    assert np.array_equal(encode._read_varints(encode._varints(values), len(values)), values)
    # zigzag: small magnitudes of either sign take one byte
    assert len(encode._varints(np.array([0, -1, 1, -64, 63]))) == 5


def _close(a, b, tol):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b)), initial=0.0)) <= tol


@pytest.mark.parametrize("source", ["synthetic", "simulated"])
def test_packing_round_trips_within_the_stated_precision(source):
    if source == "synthetic":
        arrays = logs.trajectory_arrays(synthetic_result(n=4, m=2, steps=30, seed=3), PARAMS)
    else:
        arrays = logs.trajectory_arrays(wolfpack.run_episodes(None, 1, 9, record=True)[0], PARAMS)
    packed = json.loads(json.dumps(encode.encode_episode(arrays, PARAMS, "x")))  # as the page holds it
    back = encode.decode_episode(packed)
    for side in ("wolves", "targets"):
        a, b = arrays[side], back[side]
        assert a.shape == b.shape
        assert _close(a[..., :2], b[..., :2], POSITION_TOL), side
        assert _close(a[..., 2], b[..., 2], ANGLE_TOL), side
        assert _close(a[..., 3], b[..., 3], encode.POSITION_STEP / 2 + 1e-9) and _close(a[..., 4], b[..., 4], ANGLE_TOL)
    assert _close(arrays["obstacle_poses"][..., :2], back["obstacle_poses"][..., :2], POSITION_TOL)
    assert _close(arrays["obstacle_poses"][..., 2], back["obstacle_poses"][..., 2], ANGLE_TOL)
    assert _close(arrays["energy"], back["energy"], encode.ENERGY_STEP / 2 + 1e-9)
    assert np.array_equal(arrays["interaction"], back["interaction"])
    assert packed["outcome"] == str(arrays["outcome"]) and packed["steps"] == len(arrays["wolves"]) - 1
    assert packed["first_sighting"] == encode.first_sighting(arrays)


def test_law_modes_pack_exactly_as_run_lengths():
    arrays = logs.trajectory_arrays(wolfpack.run_episodes(None, 1, 9, record=True)[0], PARAMS)
    packed = json.loads(json.dumps(encode.encode_episode(arrays, PARAMS, "x")))
    want = np.concatenate([arrays["wolf_mode"], arrays["target_mode"]], axis=1)
    assert np.array_equal(encode.decode_episode(packed)["modes"], want)
    changes = int((np.diff(want, axis=0) != 0).sum()) + want.shape[1]
    assert len(base64.b64decode(packed["modes"])) <= 3 * 2 * changes  # a (code, length) pair per run
    # every shape of series: constant, alternating, one row, none
    for codes in (np.zeros((40, 3)), np.tile([[1], [2]], (20, 4)), np.array([[5, 0, 7]]), np.zeros((9, 0))):
        assert np.array_equal(encode.unpack_runs(encode.pack_runs(codes), *codes.shape), codes)
    # a file recorded with other names is read by name; names the page lacks are none
    other = dict(arrays, mode_names=np.array(["none", "flee", "renamed", "chase"]), wolf_mode=np.array([[0, 1, 2, 3, 3]] * len(want), np.uint8), target_mode=np.full((len(want), 1), 1, np.uint8))
    back = encode.decode_episode(encode.encode_episode(other, PARAMS))["modes"]
    assert [encode.MODE_NAMES[c] for c in back[0]] == ["none", "flee", "none", "chase", "chase", "flee"]
    # a file without modes packs none
    del other["wolf_mode"], other["target_mode"], other["mode_names"]
    assert "modes" not in encode.encode_episode(other, PARAMS) and "modes" not in encode.decode_episode(encode.encode_episode(other, PARAMS))


def test_the_error_does_not_grow_along_an_episode():
    # A slow drift of 0.3 mm a step: rounding each step's difference would lose it all.
    rows = 2000
    arrays = logs.trajectory_arrays(synthetic_result(n=1, m=1, steps=rows - 1), PARAMS)
    arrays["wolves"][:, 0, 0] = 0.0003 * np.arange(rows)
    back = encode.decode_episode(encode.encode_episode(arrays, PARAMS))
    assert _close(arrays["wolves"][..., 0], back["wolves"][..., 0], POSITION_TOL)


def _documented_episodes(count: int, seed: int = 0) -> list[dict]:
    return [logs.trajectory_arrays(r, PARAMS) for r in wolfpack.run_episodes(None, count, seed, record=True)]


def test_size_budgets_of_the_documented_scenario():
    episodes = _documented_episodes(100)
    full = [a for a in episodes if len(a["wolves"]) == 301]
    assert full, "no 300-step episode among the first 100 seeds"
    one = full[0]
    assert one["wolves"].shape[1] + one["targets"].shape[1] == 6 and one["obstacle_poses"].shape[1] == 12
    single = len(render_page(page_data([encode.encode_episode(one, PARAMS, "one")]), "one").encode())
    assert single <= 300_000, f"a 300-step episode takes {single} bytes in the page"
    hundred = len(render_page(page_data([encode.encode_episode(a, PARAMS, str(k)) for k, a in enumerate(episodes)]), "all").encode())
    assert hundred <= 10_000_000, f"100 episodes take {hundred} bytes"
    print(f"page sizes: one 300-step episode {single / 1e3:.0f} KB, 100 episodes {hundred / 1e6:.2f} MB")


def test_the_page_is_self_contained_and_a_label_cannot_end_its_script():
    arrays = logs.trajectory_arrays(synthetic_result(steps=5), PARAMS)
    text = render_page(page_data([encode.encode_episode(arrays, PARAMS, "</script><script>alert(1)</script>")]), "a <b> title")
    assert text.count("</script>") == 2  # the data's and the program's, no third from the label
    assert "<title>a &lt;b&gt; title</title>" in text
    # Nothing fetched: no external script, style, image or font.
    assert not re.search(r"""(src|href)=["'](?!data:|#)""", text), re.findall(r"""(?:src|href)=["'][^"']*""", text)
    assert "http://" not in text and "https://" not in text


# --- the commands --------------------------------------------------------------------------


def test_hunt_out_writes_an_index_of_its_recorded_episodes(small_run):
    index = small_run / "index.html"
    assert index.is_file()
    data = page_json(index)
    summary = json.loads((small_run / "summary.json").read_text())
    assert [e["outcome"] for e in data["episodes"]] == [d["outcome"] for d in summary["episodes_detail"]]
    assert [e["seed"] for e in data["episodes"]] == [4, 5, 6]
    assert "index.html" in json.loads((small_run / ".wolfpack-outputs.json").read_text())["outputs"]
    arrays = logs.load_trajectory(small_run / "episode_001" / "trajectory.npz")
    assert _close(encode.decode_episode(data["episodes"][1])["wolves"][..., :2], arrays["wolves"][..., :2], POSITION_TOL)


def test_hunt_no_html_and_replay_html(tmp_path, small_run, capsys):
    assert run(["hunt", "--episodes", "1", "--set", "world.max_steps=5", "--plots", "0", "--no-html", "--out", tmp_path / "bare"])[0] == 0
    assert not (tmp_path / "bare" / "index.html").exists()
    status, err = run(["replay", small_run / "episode_002", "--html", "--no-video", "--no-plots", "--out", tmp_path / "re"], capsys)
    assert status == 0, err
    data = page_json(tmp_path / "re" / "episode.html")
    assert len(data["episodes"]) == 1 and data["episodes"][0]["seed"] == 6


def test_view_writes_runs_episodes_and_files(tmp_path, small_run, capsys):
    out = tmp_path / "v.html"
    status, err = run(["view", small_run, small_run / "episode_000" / "trajectory.npz", "--episodes", "2", "--out", out], capsys)
    assert status == 0, err
    data = page_json(out)
    assert [e["seed"] for e in data["episodes"]] == [4, 5, 4] and data["panes"] is None
    # --force replaces a page it wrote
    status, err = run(["view", small_run / "episode_002", "--out", out, "--force"], capsys)
    assert status == 0, err
    assert [e["seed"] for e in page_json(out)["episodes"]] == [6]


def _scenario_b(tmp_path: Path) -> Path:
    out = tmp_path / "other"
    cli_main(["hunt", "--episodes", "1", "--seed", "4", "--set", "world.max_steps=20", "--set", "world.wolves=4", "--plots", "0", "--out", str(out)])
    return out


@pytest.mark.parametrize(
    "case, message",
    [
        ("empty folder", "no trajectories there"),
        ("missing", "no such file or folder"),
        ("truncated npz", "not a readable trajectory.npz"),
        ("foreign npz", "not a wolfpack trajectory"),
        ("different scenarios", "episodes of different scenarios"),
        ("output exists", "exists; choose another name, or add --force"),
        ("force over a foreign file", "not a page 'wolfpack view' wrote"),
        ("output is a folder", "is a folder"),
        ("nothing to show", "name runs"),
        ("one run to compare", "name two or more runs"),
        ("runs and policies", "recorded runs"),
    ],
)
def test_view_refuses_bad_input_in_one_line_and_writes_nothing(tmp_path, small_run, capsys, case, message):
    out = tmp_path / "page.html"
    args = [small_run]
    if case == "empty folder":
        (tmp_path / "empty").mkdir()
        args = [tmp_path / "empty"]
    elif case == "missing":
        args = [tmp_path / "nowhere"]
    elif case == "truncated npz":
        whole = (small_run / "episode_000" / "trajectory.npz").read_bytes()
        (tmp_path / "cut.npz").write_bytes(whole[: len(whole) // 2])
        args = [tmp_path / "cut.npz"]
    elif case == "foreign npz":
        np.savez(tmp_path / "foreign.npz", wolves=np.zeros((3, 5, 5)))
        args = [tmp_path / "foreign.npz"]
    elif case == "different scenarios":
        args = [small_run, _scenario_b(tmp_path), "--compare"]
    elif case == "output exists":
        out.write_text("mine")
    elif case == "force over a foreign file":
        out.write_text("<!DOCTYPE html><html>my own page</html>")
        args = [small_run, "--force"]
    elif case == "output is a folder":
        out.mkdir()
    elif case == "nothing to show":
        args = []
    elif case == "one run to compare":
        args = [small_run, "--compare"]
    elif case == "runs and policies":
        args = [small_run, "--compare", "bvc"]
    before = out.read_bytes() if out.is_file() else None
    status, err = run(["view", *args, "--out", out], capsys)
    assert status == 2, (case, err)
    assert message in err and err.count("\n") == 1 and "Traceback" not in err, err
    if before is None:
        assert not out.is_file(), case
    else:
        assert out.read_bytes() == before
    assert not list(tmp_path.glob(".page*")), "a temporary file left behind"


def test_compare_recorded_runs_side_by_side(tmp_path, small_run, capsys):
    other = tmp_path / "bvc"
    cli_main(["hunt", "--episodes", "2", "--seed", "5", "--set", "world.max_steps=60", "--wolves", "bvc", "--plots", "0", "--out", str(other)])
    status, err = run(["view", small_run, other, "--compare", "--out", tmp_path / "c.html"], capsys)
    assert status == 0, err
    data = page_json(tmp_path / "c.html")
    assert data["panes"] == ["run", "bvc"]
    assert [it["label"] for it in data["items"]] == ["seed 5", "seed 6"]  # the seeds both hold
    for it in data["items"]:
        a, b = (data["episodes"][k] for k in it["episodes"])
        assert a["seed"] == b["seed"]


def test_compare_plays_policies_on_the_same_episodes(tmp_path, capsys):
    out = tmp_path / "cmp.html"
    status, err = run(["view", "--compare", "bvc", "seed000", "--episodes", "2", "--seed", "3", "--set", "world.max_steps=40", "--out", out], capsys)
    assert status == 0, err
    data = page_json(out)
    assert data["panes"] == ["bvc", "seed000"] and len(data["items"]) == 2
    # Each pane is the episode 'wolfpack hunt' plays with that law and seed.
    for law, pane in (("bvc", 0), ("seed000", 1)):
        params = wolfpack.load_params(overrides={"world.max_steps": 40, "policies.wolves": law})
        hunted = wolfpack.run_episodes(params, 2, 3, record=True)
        for k, it in enumerate(data["items"]):
            shown = data["episodes"][it["episodes"][pane]]
            want = logs.trajectory_arrays(hunted[k], _core.validate_params(params, resolve=True))
            assert shown["seed"] == 3 + k and shown["outcome"] == str(want["outcome"])
            assert _close(encode.decode_episode(shown)["wolves"][..., :3], want["wolves"][..., :3], POSITION_TOL)


LEARNED_PACK = Path(__file__).resolve().parents[1] / "results" / "learned" / "wolves_mappo" / "native_wolves_mappo_s0"


@pytest.mark.skipif(not LEARNED_PACK.is_dir(), reason="the committed learned pack is not in this checkout")
def test_compare_a_law_with_a_committed_learned_pack(tmp_path, capsys):
    out = tmp_path / "cmp.html"
    status, err = run(["view", "--compare", "bvc", LEARNED_PACK, "--episodes", "1", "--set", "world.max_steps=30", "--out", out], capsys)
    assert status == 0, err
    data = page_json(out)
    assert len(data["panes"]) == 2 and "native_wolves_mappo_s0" in data["panes"][1]


# --- in a real browser -----------------------------------------------------------------------


def _chromium() -> str | None:
    import os

    for name in (os.environ.get("WOLFPACK_CHROMIUM"), "chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        if name and (found := shutil.which(name)):
            return found
    return None


CHROMIUM = _chromium()
browser_test = pytest.mark.skipif(CHROMIUM is None, reason="no Chromium on this machine (apt-get install chromium; .ci/run installs it, or set WOLFPACK_CHROMIUM)")


@pytest.fixture(scope="module")
def browser():
    from playwright.sync_api import sync_playwright  # the [dev] extra

    with sync_playwright() as p:
        b = p.chromium.launch(executable_path=CHROMIUM, headless=True)
        yield b
        b.close()


class Page:
    """A page opened in the browser, with every console message, page error and request
    outside the file kept."""

    def __init__(self, browser, path: Path, hash: str = ""):
        self.problems: list[str] = []
        self.requests: list[str] = []
        self.context = browser.new_context(viewport={"width": 1100, "height": 760}, device_scale_factor=1)
        self.page = self.context.new_page()
        self.page.on("console", lambda m: self.problems.append(f"console {m.type}: {m.text}") if m.type in ("error", "warning") else None)
        self.page.on("pageerror", lambda e: self.problems.append(f"page error: {e}"))
        self.page.on("request", lambda r: None if r.url.startswith(("file:", "data:")) else self.requests.append(r.url))
        self.page.goto(path.as_uri() + hash)
        self.page.wait_for_function("window.wolfpack && window.wolfpack.ready", timeout=10_000)

    def js(self, expression: str, arg=None):
        return self.page.evaluate(expression, arg)

    def scrub(self, step: int) -> None:
        """Drags the scrub bar to ``step`` (the input event a drag fires)."""
        self.page.eval_on_selector("#scrub", "(el, s) => { el.value = s; el.dispatchEvent(new Event('input', {bubbles: true})); }", step)

    def close(self) -> None:
        self.context.close()


@pytest.fixture
def open_page(browser):
    opened = []

    def open_(path: Path, hash: str = "") -> Page:
        opened.append(Page(browser, path, hash))
        return opened[-1]

    yield open_
    for p in opened:
        p.close()


def _assert_state(state: dict, arrays: dict, step: int) -> None:
    assert state["step"] == step
    for side in ("wolves", "targets"):
        got, want = np.array(state[side]), arrays[side][step, :, :3]
        assert got.shape == want.shape, side
        assert _close(got[:, :2], want[:, :2], POSITION_TOL), (side, step)
        assert _close(got[:, 2], want[:, 2], ANGLE_TOL), (side, step)


@browser_test
def test_the_page_loads_cleanly_and_draws_the_recorded_states(open_page, small_run):
    page = open_page(small_run / "index.html")
    assert page.js("[wolfpack.items(), wolfpack.episodes(), wolfpack.panes(), wolfpack.step()]") == [3, 3, 1, 0]
    arrays = logs.load_trajectory(small_run / "episode_000" / "trajectory.npz")
    last = len(arrays["wolves"]) - 1
    assert page.js("wolfpack.lastStep()") == last
    for step in (0, 1, 17, last // 2, last):
        page.scrub(step)
        assert page.js("wolfpack.step()") == step
        _assert_state(page.js("wolfpack.state(wolfpack.step())"), arrays, step)
    # the page reads back exactly what the Python decoder does
    twin = encode.decode_episode(page_json(small_run / "index.html")["episodes"][0])
    assert page.js("wolfpack.state(17).wolves") == twin["wolves"][17, :, :3].tolist()
    # the keys: one step back, ten forward, the ends
    page.scrub(20)
    page.page.keyboard.press("ArrowLeft")
    assert page.js("wolfpack.step()") == 19
    page.page.keyboard.press("Shift+ArrowRight")
    assert page.js("wolfpack.step()") == 29
    page.page.keyboard.press("Home")
    assert page.js("wolfpack.step()") == 0
    # another episode from the list
    page.page.click("#list li[data-item='2']")
    assert page.js("wolfpack.item()") == 2 and page.js("location.hash") == "#item=2"  # a link to it
    _assert_state(page.js("wolfpack.state(5)"), logs.load_trajectory(small_run / "episode_002" / "trajectory.npz"), 5)
    # the interface is read-only
    page.js("() => { try { wolfpack.state = null; } catch (e) {} }")
    assert page.js("typeof wolfpack.state") == "function"
    assert page.problems == [] and page.requests == []


@browser_test
def test_play_advances_and_pause_stops(open_page, small_run):
    page = open_page(small_run / "index.html")
    page.page.select_option("#speed", "4")
    page.page.click("#play")
    page.page.wait_for_function("wolfpack.step() >= 5", timeout=5_000)
    assert page.js("wolfpack.playing()")
    page.page.keyboard.press(" ")  # pause
    assert not page.js("wolfpack.playing()")
    stopped = page.js("wolfpack.step()")
    time.sleep(0.4)
    assert page.js("wolfpack.step()") == stopped
    # played to the end, it stops there
    page.page.keyboard.press("End")
    page.page.click("#forward")
    assert page.js("[wolfpack.step(), wolfpack.playing()]") == [page.js("wolfpack.lastStep()"), False]
    assert page.problems == []


def _wolf_pixels(page: Page, step: int, pane: int = 0) -> list[tuple[list[float], list[int]]]:
    """Where each wolf's body is drawn at ``step`` (the centroid of its triangle, from the
    state and the page's transform) and the colour it should have there."""
    state = page.js(f"wolfpack.state({step}, {pane})")
    colours = page.js("wolfpack.colours()")["wolves"]
    a, b = page.js(f"[wolfpack.toScreen(0, 0, {pane}), wolfpack.toScreen(1, 0, {pane})]")
    scale = b[0] - a[0]  # pixels per metre
    body = PARAMS["agents"]["body"]
    height = body["height"] * max(1.0, 9.0 / (max(body["height"], body["base"]) * scale))  # at least 9 px long
    out = []
    for i, (x, y, th) in enumerate(state["wolves"]):
        cx, cy = x + height / 3 * np.cos(th), y + height / 3 * np.sin(th)
        out.append((page.js(f"wolfpack.toScreen({cx}, {cy}, {pane})"), colours[i % len(colours)]))
    return out


def _apart(state: dict, metres: float = 0.6) -> bool:
    pts = np.array(state["wolves"] + state["targets"])[:, :2]
    d = np.linalg.norm(pts[:, None] - pts[None], axis=-1) + np.eye(len(pts)) * 1e9
    return bool(d.min() > metres)


def _pixel(png: bytes, xy) -> list[int]:
    import io

    from PIL import Image

    image = Image.open(io.BytesIO(png)).convert("RGB")
    return list(image.getpixel((int(round(xy[0])), int(round(xy[1])))))


@browser_test
def test_a_screenshot_has_each_wolf_in_its_colour_where_the_state_puts_it(open_page, small_run):
    page = open_page(small_run / "index.html")
    page.page.uncheck("#show-trails")
    checked = 0
    for step in (0, 10, 25):
        page.scrub(step)
        if not _apart(page.js(f"wolfpack.state({step})")):
            continue
        shot = page.page.screenshot()
        for xy, colour in _wolf_pixels(page, step):
            got = _pixel(shot, xy)
            assert max(abs(g - c) for g, c in zip(got, colour)) <= 8, (step, xy, got, colour)
        checked += 1
    assert checked >= 1
    # zoomed in and panned, the bodies are still where the transform says
    page.page.keyboard.press("+")
    page.page.keyboard.press("+")
    box = page.page.locator("#panes canvas").bounding_box()
    page.page.mouse.move(box["x"] + 200, box["y"] + 200)
    page.page.mouse.down()
    page.page.mouse.move(box["x"] + 260, box["y"] + 230, steps=4)
    page.page.mouse.up()
    page.scrub(0)
    shot = page.page.screenshot()
    inside = 0
    for xy, colour in _wolf_pixels(page, 0):
        if box["x"] + 5 < xy[0] < box["x"] + box["width"] - 5 and box["y"] + 30 < xy[1] < box["y"] + box["height"] - 5:
            inside += 1
            assert max(abs(g - c) for g, c in zip(_pixel(shot, xy), colour)) <= 8
    assert inside >= 1
    assert page.problems == []


@browser_test
def test_clicking_a_wolf_shows_its_state(open_page, small_run):
    page = open_page(small_run / "index.html")
    page.scrub(12)
    arrays = logs.load_trajectory(small_run / "episode_000" / "trajectory.npz")
    (xy, _), *_ = _wolf_pixels(page, 12)
    page.page.mouse.click(*xy)
    assert page.js("wolfpack.selected()") == {"pane": 0, "agent": 0}
    text = page.page.inner_text("#info")
    x, y, th, v, _ = arrays["wolves"][12, 0]
    assert "wolf 0" in text and f"{x:.3f}, {y:.3f} m" in text and f"{v:.3f} m/s" in text, text
    # it follows the step
    page.page.keyboard.press("ArrowRight")
    x, y = arrays["wolves"][13, 0, :2]
    assert f"{x:.3f}, {y:.3f} m" in page.page.inner_text("#info")
    # the keys zoom around it: it stays where it is drawn
    scale = lambda: page.js(f"wolfpack.toScreen({x} + 1, {y})[0] - wolfpack.toScreen({x}, {y})[0]")  # noqa: E731
    before, zoom = page.js(f"wolfpack.toScreen({x}, {y})"), scale()
    page.page.keyboard.press("+")
    assert np.allclose(page.js(f"wolfpack.toScreen({x}, {y})"), before, atol=0.5) and scale() > 1.2 * zoom
    assert page.problems == []


def _info(page: Page) -> dict[str, str]:
    """The clicked agent's details, as the panel lists them."""
    return dict(page.js("Array.from(document.querySelectorAll('#agent-state tr')).map(r => [r.cells[0].textContent, r.cells[1].textContent])"))


@browser_test
def test_clicking_an_agent_shows_its_laws_mode(open_page, small_run, tmp_path, capsys):
    arrays = logs.load_trajectory(small_run / "episode_000" / "trajectory.npz")
    names = arrays["mode_names"].tolist()
    assert names == list(_core.LAW_MODES)
    page = open_page(small_run / "index.html")
    last = len(arrays["wolves"]) - 1
    # the script interface gives every agent's mode, as the file records it
    for step in (0, 1, 12, last):
        state = page.js(f"wolfpack.state({step})")
        assert state["wolf_modes"] == [names[c] for c in arrays["wolf_mode"][step]], step
        assert state["target_modes"] == [names[c] for c in arrays["target_mode"][step]], step
    # clicking wolf 0 lists its mode at the step shown ...
    page.scrub(12)
    (xy, _), *_ = _wolf_pixels(page, 12)
    page.page.mouse.click(*xy)
    assert page.js("wolfpack.selected()") == {"pane": 0, "agent": 0}
    assert _info(page)["mode"] == names[arrays["wolf_mode"][12, 0]]
    # ... and follows the step to where the mode is another
    other = next(t for t in range(1, last + 1) if arrays["wolf_mode"][t, 0] != arrays["wolf_mode"][12, 0])
    page.scrub(other)
    assert _info(page)["mode"] == names[arrays["wolf_mode"][other, 0]] != names[arrays["wolf_mode"][12, 0]]
    page.scrub(0)
    assert _info(page)["mode"] == "(from step 1)"
    # the target's mode, clicked where it is drawn
    page.scrub(12)
    x, y, th = arrays["targets"][12, 0, :3]
    page.page.mouse.click(*page.js(f"wolfpack.toScreen({x + 0.1 * np.cos(th)}, {y + 0.1 * np.sin(th)})"))
    assert page.js("wolfpack.selected()") == {"pane": 0, "agent": 5}
    assert _info(page)["mode"] == names[arrays["target_mode"][12, 0]]
    assert page.problems == []
    # A file written before modes were recorded: no mode shown, none given, and no error.
    old = tmp_path / "old.npz"
    np.savez_compressed(old, **{k: v for k, v in arrays.items() if k not in ("wolf_mode", "target_mode", "mode_names")})
    assert run(["view", old, "--out", tmp_path / "old.html"], capsys)[0] == 0
    assert "modes" not in page_json(tmp_path / "old.html")["episodes"][0]
    page = open_page(tmp_path / "old.html")
    assert page.js("[wolfpack.state(12).wolf_modes, wolfpack.state(12).target_modes]") == [None, None]
    page.scrub(12)
    (xy, _), *_ = _wolf_pixels(page, 12)
    page.page.mouse.click(*xy)
    assert "mode" not in _info(page) and "position" in _info(page)
    assert page.problems == []


@browser_test
def test_the_comparison_view_stays_in_step(open_page, tmp_path, capsys):
    out = tmp_path / "cmp.html"
    assert run(["view", "--compare", "bvc", "formation", "--episodes", "2", "--seed", "1", "--set", "world.max_steps=50", "--out", out], capsys)[0] == 0
    data = page_json(out)
    page = open_page(out, "#item=1&step=3")
    assert page.js("[wolfpack.panes(), wolfpack.item(), wolfpack.step()]") == [2, 1, 3]
    shown = [encode.decode_episode(data["episodes"][k]) for k in data["items"][1]["episodes"]]
    for step in (0, 7, 30, page.js("wolfpack.lastStep()")):
        page.scrub(step)
        for pane, arrays in enumerate(shown):
            last = len(arrays["wolves"]) - 1
            # each pane draws the shared step (a pane whose episode ended holds its last state)
            _assert_state(page.js(f"wolfpack.state(undefined, {pane})"), arrays, min(step, last))
    page.page.keyboard.press("Home")
    page.page.click("#play")
    page.page.wait_for_function("wolfpack.step() >= 3", timeout=5_000)
    page.page.click("#play")
    step = page.js("wolfpack.step()")
    shot = page.page.screenshot()
    for pane in (0, 1):
        assert page.js(f"wolfpack.state(undefined, {pane}).step") == step
        if _apart(page.js(f"wolfpack.state({step}, {pane})")):
            for xy, colour in _wolf_pixels(page, step, pane):
                assert max(abs(g - c) for g, c in zip(_pixel(shot, xy), colour)) <= 8, (pane, xy)
    assert page.problems == [] and page.requests == []


def test_the_page_data_is_plain_base64():
    arrays = logs.trajectory_arrays(synthetic_result(steps=3), PARAMS)
    packed = encode.encode_episode(arrays, PARAMS)
    for key in ("agents", "poses", "energy", "interaction"):
        base64.b64decode(packed[key], validate=True)


@browser_test
def test_the_lidar_drawn_is_the_wolves_observation(open_page, tmp_path):
    from conftest import layout_dict
    from wolfpack.batch import BatchEnv

    # Wolves near the walls and the obstacles, so that rays end on both.
    layout = layout_dict()
    layout["wolves"] = [[-8.6, -8.8, 3.9], [3.5, 5.0, 0.1], [-7.2, 5.1, 0.0], [9.0, 0.0, 1.0], [0.0, -9.2, 4.5]]
    (tmp_path / "layout.json").write_text(json.dumps(layout))
    cli_main(["hunt", "--episodes", "1", "--layout", str(tmp_path / "layout.json"), "--set", "world.max_steps=5", "--plots", "0", "--out", str(tmp_path / "run")])
    page = open_page(tmp_path / "run" / "index.html")
    block = next(b for b in wolfpack.observation_layout("wolves") if b["name"] == "lidar")
    batch = BatchEnv(wolfpack.load_params(overrides={"world.max_steps": 5}), num_envs=1, learners="wolves", seed=0, autoreset=False)
    obs = np.asarray(batch.reset_world(0, 0, layout)["obs_wolves"])
    obs = obs.reshape(-1, obs.shape[-1])
    rng = PARAMS["env"]["lidar"]["range"]
    hits = 0
    for i in range(obs.shape[0]):
        want = obs[i, block["start"] : block["start"] + block["size"]] * rng
        got = np.array(page.js(f"wolfpack.lidar(0, {i})"))
        assert got.shape == want.shape
        # positions to 1 mm and headings to 0.001 rad move a hit by a few mm at most (more only
        # where a ray grazes a corner, hence the median)
        assert np.median(np.abs(got - want)) < 0.005 and np.mean(np.abs(got - want) < 0.02) >= 0.9, (i, got, want)
        hits += int((want < rng - 1e-6).sum())
    assert hits >= 10, "too few rays end on something to test the casting"
    # clicking a wolf draws its rays and says what they hit
    (xy, _), *_ = _wolf_pixels(page, 0)
    page.page.mouse.click(*xy)
    assert "lidar" in page.page.inner_text("#info") and "16 rays" in page.page.inner_text("#info")
    assert page.problems == []


def test_view_help_names_the_ways_and_the_precision(cli):
    proc = cli("view", "--help")
    assert proc.returncode == 0
    for word in ("RUN_OR_NPZ", "--out", "--compare", "--episodes", "--force", "1 mm", "0.001 rad", "window.wolfpack.state", "examples:"):
        assert word in proc.stdout, word
    assert "view" in cli("--help").stdout


# --- tables whose cells open episodes ----------------------------------------------------------


@pytest.fixture(scope="module")
def small_matrix(tmp_path_factory) -> Path:
    """A cross-play matrix of laws in matrix.json's format (the numbers are made up: the page
    shows them, it does not recompute them)."""
    folder = tmp_path_factory.mktemp("matrix")
    wolves, targets = ["bvc", "seed000"], ["escape", "still"]
    cells = [
        {"wolves": w, "targets": t, "episodes": 10, "first_seed": 2, "capture_rate": 0.1 * (i + 1), "capture_rate_ci95": [0.0, 0.5]} for i, (w, t) in enumerate((w, t) for w in wolves for t in targets)
    ]
    params = wolfpack.load_params(overrides={"world.max_steps": 40})
    (folder / "matrix.json").write_text(json.dumps({"episodes": 10, "seed": 2, "params": params, "wolves": wolves, "targets": targets, "models": {}, "cells": cells, "robustness": {}, "skipped": []}))
    return folder


def test_the_matrix_page_opens_an_episode_of_each_pairing(tmp_path, small_matrix, capsys):
    out = tmp_path / "m.html"
    status, err = run(["view", "--matrix", small_matrix, "--out", out], capsys)
    assert status == 0, err
    data = page_json(out)
    table = data["table"]
    assert table["rows"] == ["bvc", "seed000"] and table["columns"] == ["escape", "still"]
    assert [[c["text"] for c in row] for row in table["cells"]] == [["10%", "20%"], ["30%", "40%"]]
    for r, w in enumerate(table["rows"]):
        for c, t in enumerate(table["columns"]):
            shown = data["episodes"][data["items"][table["cells"][r][c]["item"]]["episodes"][0]]
            params = wolfpack.load_params(overrides={"world.max_steps": 40, "policies.wolves": w, "policies.targets": t})
            want = logs.trajectory_arrays(wolfpack.run_episodes(params, 1, 2, record=True)[0], PARAMS)
            assert shown["seed"] == 2 and shown["outcome"] == str(want["outcome"]), (w, t)
            assert _close(encode.decode_episode(shown)["targets"][..., :2], want["targets"][..., :2], POSITION_TOL)


def test_the_scorecard_page_opens_an_episode_of_each_task(tmp_path, capsys):
    card = tmp_path / "card"
    assert run(["benchmark", "--wolves", "bvc", "--episodes", "2", "--tasks", "hunt-v1", "open-v1", "--out", card], capsys)[0] == 0
    out = tmp_path / "card.html"
    status, err = run(["view", "--scorecard", card, "--out", out], capsys)
    assert status == 0, err
    data = page_json(out)
    assert data["table"]["rows"] == ["hunt-v1", "open-v1"]
    from wolfpack.task import task_params

    for r, task in enumerate(data["table"]["rows"]):
        shown = data["episodes"][data["items"][data["table"]["cells"][r][0]["item"]]["episodes"][0]]
        want = wolfpack.run_episodes(task_params(task, {"policies.wolves": "bvc"}), 1, 500_000)[0]
        assert shown["seed"] == 500_000 and shown["outcome"] == want["outcome"] and shown["steps"] == want["steps"], task
    # a scorecard of a model needs the model
    doc = json.loads((card / "scorecard.json").read_text())
    doc["policy"] = "mappo:somewhere"
    (card / "scorecard.json").write_text(json.dumps(doc))
    status, err = run(["view", "--scorecard", card, "--out", tmp_path / "other.html"], capsys)
    assert status == 2 and "--policy" in err and err.count("\n") == 1
    assert not (tmp_path / "other.html").exists()


def test_a_file_that_is_no_matrix_is_refused(tmp_path, capsys):
    (tmp_path / "matrix.json").write_text('{"wolves": []}')
    status, err = run(["view", "--matrix", tmp_path / "matrix.json", "--out", tmp_path / "m.html"], capsys)
    assert status == 2 and "not a matrix.json" in err and err.count("\n") == 1
    assert not (tmp_path / "m.html").exists()


@browser_test
def test_a_matrix_cell_opens_its_episode_in_the_browser(open_page, tmp_path, small_matrix, capsys):
    out = tmp_path / "m.html"
    assert run(["view", "--matrix", small_matrix, "--out", out], capsys)[0] == 0
    data = page_json(out)
    page = open_page(out)
    assert page.js("wolfpack.showing()") == "table"
    page.page.click("td.cell[data-row='1'][data-column='0']")  # seed000 vs escape
    item = data["table"]["cells"][1][0]["item"]
    assert page.js("[wolfpack.showing(), wolfpack.item()]") == ["episode", item]
    shown = encode.decode_episode(data["episodes"][data["items"][item]["episodes"][0]])
    page.scrub(9)
    _assert_state(page.js("wolfpack.state(9)"), shown, 9)
    page.page.click("#to-table")
    assert page.js("wolfpack.showing()") == "table"
    assert page.problems == [] and page.requests == []


@browser_test
def test_the_hunting_points_are_those_the_capture_rule_checks(open_page, tmp_path):
    # With capture.rule: hunting_points an episode is captured at the first step at which every
    # wolf stands within arrive_tolerance of its hunting point: the points the page places must
    # say so at that step.
    out = tmp_path / "run"
    cli_main(
        ["hunt", "--wolves", "bvc", "--targets", "still", "--set", "capture.rule=hunting_points", "--set", "world.max_steps=100", "--episodes", "2", "--seed", "1", "--plots", "0", "--out", str(out)]
    )
    page = open_page(out / "index.html")
    tol = PARAMS["capture"]["arrive_tolerance"]
    checked = 0
    for k in range(2):
        arrays = logs.load_trajectory(out / f"episode_{k:03d}" / "trajectory.npz")
        if str(arrays["outcome"]) != "captured":
            continue
        page.page.click(f"#list li[data-item='{k}']")
        step = int(arrays["capture_step"])
        points = page.js(f"wolfpack.hunting({step})")
        assert sorted(p[2] for p in points) == list(range(arrays["wolves"].shape[1]))  # one per wolf
        r = PARAMS["bvc"]["radius"]
        target = arrays["targets"][step, 0, :2]
        for x, y, i in points:
            assert abs(np.hypot(x - target[0], y - target[1]) - r) < 2e-3  # on the ring
            assert np.hypot(*(arrays["wolves"][step, i, :2] - [x, y])) <= tol + 2e-3, (k, i)
        # distinct points, evenly spaced: n points, each 2π/n from the next
        angles = sorted(np.arctan2(y - target[1], x - target[0]) % (2 * np.pi) for x, y, _ in points)
        assert np.allclose(np.diff(angles), 2 * np.pi / len(points), atol=2e-3)
        assert min(angles[0], 2 * np.pi - angles[-1]) < 2e-3  # the first at angle 0
        checked += 1
    assert checked >= 1
    page.page.click("#list li[data-item='0']")
    assert page.page.is_visible("#hunting-toggle")
    assert page.problems == []
