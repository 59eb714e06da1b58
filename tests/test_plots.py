"""Pictures a person can read: no two lines of a plot look alike, whatever the number of wolves
or evaluation rows; legends sit outside the data; count axes have integer ticks."""

from __future__ import annotations

import matplotlib

matplotlib.use("Agg")
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import wolfpack  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from wolfpack import logs, plots  # noqa: E402


@pytest.mark.parametrize("k", [1, 5, 9, 10, 12, 36, 37, 100, 400])
def test_line_styles_are_distinct_for_any_count(k):
    styles = plots.line_styles(k)
    assert len(styles) == k and len(set(styles)) == k


@pytest.fixture
def saved(monkeypatch):
    """The figures the plot functions save, kept for inspection."""
    figures = []
    original = Figure.savefig

    def keep(self, *args, **kwargs):
        figures.append(self)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(Figure, "savefig", keep)
    return figures


def _lines(ax):
    return [(line.get_color(), line.get_linestyle()) for line in ax.get_lines() if line.get_label() and not line.get_label().startswith("_")]


def test_twelve_wolves_get_twelve_distinct_lines_and_outside_legends(saved, tmp_path):
    params = wolfpack.load_params(overrides={"world.wolves": 12, "world.max_steps": 60})
    result = wolfpack.run_episodes(params, episodes=1, seed=0, record=True)[0]
    arrays = logs.trajectory_arrays(result, wolfpack.BatchEnv(params).params)
    plots.plot_trajectory(arrays, tmp_path / "t.png")
    plots.plot_curves(arrays, tmp_path / "c.png")
    plots.plot_interaction(arrays, tmp_path / "i.png")
    traj, curves, inter = saved
    wolf_lines = [(line.get_color(), line.get_linestyle()) for line in traj.axes[0].get_lines() if line.get_label().startswith("wolf")]
    assert len(wolf_lines) == 12 and len(set(wolf_lines)) == 12
    speed_lines = _lines(curves.axes[0])
    assert len(speed_lines) == 13 and len(set(speed_lines)) == 13  # 12 wolves and the target
    for fig in (traj, curves):
        legend = fig.axes[0].get_legend()
        assert legend is not None and legend.get_bbox_to_anchor().x0 >= fig.axes[0].get_window_extent().x1 - 1  # right of the axes
    assert inter.axes[0].get_legend() is not None  # the heat map's key


def test_evaluation_capture_times_distinguish_twelve_rows(saved, tmp_path):
    from wolfpack.report.evaluation import plot

    rows = [
        {"wolves": f"w{k}", "targets": "escape", "episodes": 10, "first_seed": 0, "capture_rate": 0.5, "capture_rate_ci95": [0.2, 0.8], "capture_steps": list(range(10 + k, 15 + k))} for k in range(12)
    ]
    plot(rows, tmp_path)
    times = saved[-1]
    styles = [(line.get_color(), line.get_linestyle()) for line in times.axes[0].get_lines()]
    assert len(styles) == 12 and len(set(styles)) == 12


def test_summary_counts_have_integer_ticks(saved, tmp_path):
    details = [{"outcome": "captured", "capture_step": 100 + k} for k in range(3)] + [{"outcome": "timeout", "capture_step": None}]
    plots.plot_summary(details, tmp_path / "s.png")
    fig = saved[-1]
    for ax in fig.axes:
        ticks = ax.get_yticks()
        assert np.allclose(ticks, np.round(ticks)), ticks


def test_wolves_are_drawn_in_blues_and_greens_apart_from_the_red_target():
    from matplotlib.colors import rgb_to_hsv, to_rgb

    for colour, _ in plots.line_styles(36):
        hue = rgb_to_hsv(to_rgb(colour))[0]
        assert 0.25 <= hue <= 0.7, f"{colour}: hue {hue:.2f} is not a blue or a green"


def test_a_collision_is_marked_where_the_colliding_wolf_stood(saved, tmp_path):
    from conftest import synthetic_result

    result = synthetic_result(n=3, steps=9, outcome="collision")
    result["collisions"] = np.array([0, 2, 0, 0], dtype=np.uint32)  # wolf 1 touched something
    arrays = logs.trajectory_arrays(result, wolfpack.load_params())
    plots.plot_trajectory(arrays, tmp_path / "t.png")
    marks = [line for line in saved[-1].axes[0].get_lines() if line.get_marker() == "X"]
    assert len(marks) == 1 and marks[0].get_label() == "collision (step 9)"
    np.testing.assert_allclose(marks[0].get_xydata()[0], arrays["wolves"][-1, 1, :2])
    # A captured episode has no mark.
    arrays = logs.trajectory_arrays(synthetic_result(n=3, steps=9), wolfpack.load_params())
    plots.plot_trajectory(arrays, tmp_path / "c.png")
    assert not [line for line in saved[-1].axes[0].get_lines() if line.get_marker() == "X"]


def test_one_episodes_summary_reads_well(saved, tmp_path):
    plots.plot_summary([{"outcome": "captured", "capture_step": 175}], tmp_path / "s.png")
    bars, hist = saved[-1].axes[:2]
    assert bars.get_title() == "outcomes of 1 episode"
    lo, hi = hist.get_xlim()
    assert hi - lo >= 10 and lo < 175 < hi  # steps around the one capture, not a sliver
    assert all(p.get_edgecolor()[:3] == (0.0, 0.0, 0.0) for p in bars.patches)  # bars with edges


def test_league_curves_keep_coincident_rates_apart(saved, tmp_path):
    from wolfpack.report.league import league_curves

    member = {"name": "targets_g01", "side": "targets", "kind": "model", "generation": 1}
    laws = [{"name": law, "side": "wolves", "kind": "scripted", "generation": 0} for law in ("seed000", "bvc", "formation")]
    # The one target member survives bvc and formation alike: two points at the same place.
    evaluations = [{"wolves": law["name"], "targets": "targets_g01", "capture_rate": rate} for law, rate in zip(laws, (0.2, 0.9, 0.9))]
    league = {"members": [*laws, member], "evaluations": evaluations, "generations": [{"generation": 1, "side": "targets", "timesteps": 1000}]}
    league_curves(tmp_path, league)
    targets_ax = saved[-1].axes[1]
    points = {line.get_label(): (tuple(line.get_xydata()[0]), line.get_marker()) for line in targets_ax.get_lines() if line.get_label().startswith("vs ")}
    (xy_bvc, marker_bvc), (xy_formation, marker_formation) = points["vs bvc"], points["vs formation"]
    assert xy_bvc[1] == xy_formation[1] == pytest.approx(10.0) and xy_bvc[0] != xy_formation[0] and marker_bvc != marker_formation
    assert list(targets_ax.get_xticks()) == [1]
    assert "no learned wolves" in " ".join(t.get_text() for t in saved[-1].axes[0].texts)
