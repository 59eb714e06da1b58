"""Smoke test of benchmarks/peers.py: it runs and reports positive numbers. No timing thresholds:
speed is measured by the benchmarks themselves (BENCHMARKS.md), never asserted in tests."""

from __future__ import annotations

import importlib.util
import json
import subprocess
import sys
from pathlib import Path

import pytest

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "peers.py"
HAVE_MPE2 = importlib.util.find_spec("mpe2") is not None


@pytest.fixture(scope="module")
def report() -> dict:
    if not SCRIPT.exists():
        pytest.skip("benchmarks/peers.py is not part of this checkout")
    skip = "vmas" if HAVE_MPE2 else "mpe2,vmas"
    cmd = [sys.executable, str(SCRIPT), "--quick", "--json", "--episodes", "4", "--mpe2-steps", "50", "--skip", skip]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    return json.loads(done.stdout)


def test_wolfpack_numbers_are_positive(report: dict) -> None:
    for key in ("threads_1", "threads_all"):
        r = report["wolfpack"][key]
        assert r["episodes"] == 4
        assert r["total_steps"] > 0
        assert r["env_steps_per_second"] > 0
        assert r["threads"] >= 1
        assert sum(r["outcomes"].values()) == 4
    assert report["wolfpack"]["threads_1"]["threads"] == 1


def test_reference_figure_is_quoted(report: dict) -> None:
    assert report["reference"]["env_steps_per_second"] == pytest.approx(42.0)
    assert report["ratios"]["wolfpack(1 thread) / reference"] > 0


def test_machine_info(report: dict) -> None:
    m = report["machine"]
    assert m["cores"] >= 1 and m["python"] and m["cpu"]


@pytest.mark.skipif(not HAVE_MPE2, reason="mpe2 is not installed")
def test_mpe2_numbers_are_positive(report: dict) -> None:
    r = report["mpe2"]
    assert "skipped" not in r, r
    assert r["steps"] == 50 and r["env_steps_per_second"] > 0
    assert r["physics_only_env_steps_per_second"] > 0
    assert report["ratios"]["wolfpack(1 thread) / mpe2"] > 0


LEARNING = SCRIPT.with_name("learning.py")


@pytest.mark.skipif(not HAVE_MPE2, reason="mpe2 is not installed")
def test_learning_benchmark_runs_and_compares_with_mpe2() -> None:
    cmd = [sys.executable, str(LEARNING), "--quick", "--json", "--num-envs", "4", "--skip", "vmas"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    r = json.loads(done.stdout)
    for key in ("vec_env_1_thread", "vec_env_all_cores"):
        assert r[key]["num_envs"] == 4 and r[key]["slots"] == 20
        assert r[key]["env_steps_per_second"] > 0 and 0 < r[key]["native_share_of_step"]
    assert r["parallel_env"]["env_steps_per_second"] > 0
    assert r["ratios"]["parallel_env / mpe2"] > 0


RENDER = SCRIPT.with_name("render.py")


@pytest.mark.skipif(not HAVE_MPE2, reason="mpe2 is not installed")
def test_render_benchmark_runs_and_compares_with_mpe2() -> None:
    done = subprocess.run([sys.executable, str(RENDER), "--quick", "--json"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    r = json.loads(done.stdout)
    assert r["wolfpack"]["shape"] == r["mpe2"]["shape"] == [700, 700, 3], "same resolution on both sides"
    assert r["wolfpack"]["frames_per_second"] > 0 and r["mpe2"]["frames_per_second"] > 0
    assert r["ratio_vs_mpe2"] > 0 and r["video"]["frames"] > 1


@pytest.mark.slow  # the benchmark's own runs of every stack
def test_stacks_benchmark_runs_every_stack():
    """benchmarks/stacks.py --quick: every row reports a positive rate (no thresholds)."""
    script = Path(__file__).resolve().parents[1] / "benchmarks" / "stacks.py"
    done = subprocess.run([sys.executable, str(script), "--quick", "--json", "--num-envs", "2"], capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    rows = json.loads(done.stdout)["rows"]
    assert len(rows) == 7
    for r in rows:
        assert "skipped" not in r, r
        assert r["env_steps"] > 0 and r["env_steps_per_second"] > 0, r


def test_alternating_benchmark_runs_and_reports_both_rates():
    script = SCRIPT.parent / "alternating.py"
    cmd = [sys.executable, str(script), "--sizes", "8", "--repeats", "1", "--env-steps", "800"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    line = done.stdout.strip().splitlines()[-1]
    assert line.startswith("E=8 threads=2 round 1: one batch ") and "two in turn" in line, line
    rates = [float(w) for w in line.replace(",", " ").split() if w.replace(".", "").isdigit()]
    assert len(rates) >= 2 and all(r > 0 for r in rates[-2:]), line


@pytest.mark.slow  # the benchmark's own runs of every stack
def test_torchrl_view_benchmark_reports_both_rates_per_size():
    pytest.importorskip("torchrl")
    script = SCRIPT.parent / "torchrl_view.py"
    cmd = [sys.executable, str(script), "--sizes", "8", "16", "--repeats", "1", "--seconds", "0.05", "--json"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    doc = json.loads(done.stdout)
    assert set(doc["sizes"]) == {"8", "16"}
    for rates in doc["sizes"].values():
        assert set(rates) == {"batch", "torchrl"} and all(r["median"] > 0 and len(r["runs"]) == 1 for r in rates.values()), rates


def test_under_load_benchmark_runs_with_a_busy_process_and_stops_it(tmp_path):
    script = SCRIPT.parent / "under_load.py"
    out = tmp_path / "under_load.json"
    cmd = [sys.executable, str(script), "--loads", "0,1", "--sizes", "8", "--repeats", "1", "--seconds", "0.05", "--out", str(out)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert [line.split()[0] for line in done.stdout.strip().splitlines()] == ["K=0", "K=1"], done.stdout
    doc = json.loads(out.read_text())
    for k in ("0", "1"):
        rates = doc["loads"][k]["8"]["median"]
        assert set(rates) == {"1", "2"} and all(r > 0 for r in rates.values()), doc["loads"][k]
    spinning = subprocess.run(["pgrep", "-f", "while True: pass"], capture_output=True, text=True)
    assert spinning.stdout.strip() == "", "a busy process outlived the benchmark"


def _bench_module(monkeypatch, name: str):
    """benchmarks/NAME.py, loaded by file path under a private name (its sibling modules
    importable, as when a script runs)."""
    path = SCRIPT.with_name(f"{name}.py")
    if not path.exists():
        pytest.skip(f"benchmarks/{name}.py is not part of this checkout")
    monkeypatch.syspath_prepend(str(SCRIPT.parent))
    spec = importlib.util.spec_from_file_location(f"wolfpack_bench_{name}", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def test_ratios_to_jaxmarl_pair_the_rates_of_each_round(monkeypatch) -> None:
    """'lowest round' pairs our rate with the best JaxMARL variant of the same round (hand-worked:
    3/1.5, 6/2, 9/4), so a machine that speeds up between rounds does not flatter either side."""
    tables = _bench_module(monkeypatch, "peer_tables")
    row = {
        "batch_env_2t": {"rates": [3.0, 6.0, 9.0], "env_steps_per_second": 6.0},
        "jaxmarl_loop": {"rates": [1.0, 2.0, 4.0], "env_steps_per_second": 2.0},
        "jaxmarl_scan": {"rates": [1.5, 1.0, 3.0], "env_steps_per_second": 1.5},
    }
    r = tables.size_ratios(row, [1, 2])
    assert r["BatchEnv(2t) / JaxMARL best"] == pytest.approx(3.0)  # medians: 6 / max(2, 1.5)
    assert r["BatchEnv(2t) / JaxMARL best, each round"] == pytest.approx([2.0, 3.0, 2.25])
    assert r["BatchEnv(2t) / JaxMARL best, lowest round"] == pytest.approx(2.0)
    row["jaxmarl_scan"] = {"skipped": "jaxmarl is not installed"}
    assert tables.size_ratios(row, [1, 2])["BatchEnv(2t) / JaxMARL best, each round"] == pytest.approx([3.0, 3.0, 2.25])
    row["jaxmarl_loop"] = {"skipped": "jaxmarl is not installed"}
    r = tables.size_ratios(row, [1, 2])
    assert r["BatchEnv(2t) / JaxMARL best, each round"] == [] and r["BatchEnv(2t) / JaxMARL best, lowest round"] is None


def test_cpu_caches_read_what_one_core_sees_from_sysfs(monkeypatch, tmp_path) -> None:
    """A hand-made sysfs cache tree (Linux's layout: index*/level, type, size) of a 2-core VM
    with 1 MiB L2 per core; an entry without a size and a malformed one are left out."""
    machine = _bench_module(monkeypatch, "machine")
    for index, (level, kind, size) in enumerate([("1", "Data", "32K"), ("1", "Instruction", "32K"), ("2", "Unified", "1024K"), ("3", "Unified", "32768K"), ("4", "Unified", "huge")]):
        d = tmp_path / f"index{index}"
        d.mkdir()
        for name, text in (("level", level), ("type", kind), ("size", size)):
            (d / name).write_text(text + "\n", encoding="ascii")
    (tmp_path / "index9").mkdir()  # no files: skipped
    (tmp_path / "uevent").write_text("", encoding="ascii")
    caches = machine.cpu_caches(tmp_path)
    assert caches == {"L1d": 32 * 1024, "L1i": 32 * 1024, "L2": 1024**2, "L3": 32 * 1024**2}
    assert machine.caches_text(caches) == ", caches L2 1 MiB, L3 32 MiB"
    assert machine.caches_text({}) == "" and machine.cpu_caches(tmp_path / "missing") == {}


def test_episode_engines_play_the_same_episodes_and_report_both_rates() -> None:
    script = SCRIPT.with_name("episode_engines.py")
    cmd = [sys.executable, str(script), "--episodes", "8", "--loads", "0", "--repeats", "1", "--json"]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=600)
    assert done.returncode == 0, done.stderr
    doc = json.loads(done.stdout)
    medians = doc["loads"]["0"]["median"]
    assert set(medians) == {"episodes (rayon)", "batch"}
    assert all(rate > 0 for by_threads in medians.values() for rate in by_threads.values())
    assert set(medians["batch"]) == {"1", "2"}
