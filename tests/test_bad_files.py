"""Every bad file is named: a model folder whose ``config.yaml``, ``policy.pt`` or the run's
``trainer.pt`` is garbled, truncated, foreign or partial is a ValueError naming the file and
what is wrong (exit 2 and one line on the command line) wherever a model is read, and no
``.pt`` file is ever loaded as code (``torch.load(..., weights_only=True)``)."""

from __future__ import annotations

import pickle
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

torch = pytest.importorskip("torch")

import wolfpack  # noqa: E402
from wolfpack.learn import train  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "results" / "learned" / "wolves_mappo" / "native_wolves_mappo_s2" / "wolves"  # native, 5 wolves


def wolfpack_cli(*args) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "wolfpack", *map(str, args)], capture_output=True, text=True, cwd=ROOT, timeout=300)


def one_line_exit_2(run: subprocess.CompletedProcess, *fragments: str) -> str:
    assert run.returncode == 2, (run.returncode, run.stderr)
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("wolfpack: error: "), run.stderr
    for fragment in fragments:
        assert fragment in lines[0], lines[0]
    return lines[0]


def model_copy(tmp_path: Path, name: str = "model") -> Path:
    folder = tmp_path / name
    shutil.copytree(MODEL, folder)
    return folder


def _without(key: str):
    def edit(config: dict) -> dict:
        config.pop(key)
        return config

    return edit


def _network_without_obs_dim(config: dict) -> dict:
    config["network"].pop("obs_dim")
    return config


# (what the config.yaml becomes, a fragment the error names besides the file)
BAD_CONFIGS = {
    "garbled": ("side: wolves\nalgo: [mappo\n", "not valid YAML at line"),
    "a list": ("- side\n- wolves\n", "holds a list, not a mapping"),
    "a scalar": ("wolves\n", "holds the single value 'wolves'"),
    "binary": (b"\xff\xfe\x00garbage", "not a text file"),
    "no network": (_without("network"), "no network:"),
    "no params": (_without("params"), "no params:"),
    "network without obs_dim": (_network_without_obs_dim, "network: lacks obs_dim"),
}


def corrupt_config(folder: Path, how) -> Path:
    path = folder / "config.yaml"
    if callable(how):
        path.write_text(yaml.safe_dump(how(yaml.safe_load(path.read_text()))))
    elif isinstance(how, bytes):
        path.write_bytes(how)
    else:
        path.write_text(how)
    return path


@pytest.mark.parametrize("case", list(BAD_CONFIGS))
def test_load_policy_names_a_bad_config_yaml(tmp_path, case):
    how, fragment = BAD_CONFIGS[case]
    path = corrupt_config(model_copy(tmp_path), how)
    with pytest.raises(ValueError) as caught:
        wolfpack.load_policy(path.parent)
    assert str(path) in str(caught.value) and fragment in str(caught.value)


@pytest.mark.parametrize("case", ["garbled", "a list", "no network"])
def test_every_command_that_reads_a_model_names_its_bad_config_yaml(tmp_path, case):
    how, fragment = BAD_CONFIGS[case]
    path = corrupt_config(model_copy(tmp_path), how)
    folder = path.parent
    one_line_exit_2(wolfpack_cli("benchmark", "--wolves", folder, "--tasks", "hunt-v1", "--episodes", "1"), str(path), fragment)
    one_line_exit_2(wolfpack_cli("dataset", "--task", "hunt-v1", "--policy", folder, "--episodes", "1", "--out", tmp_path / "d"), str(path), fragment)
    one_line_exit_2(wolfpack_cli("train", "--side", "targets", "--opponent", folder, "--timesteps", "100", "--out", tmp_path / "t"), str(path), fragment)
    assert not (tmp_path / "d").exists() and not (tmp_path / "t").exists()


class _Payload:
    """Unpickling it runs code: creates the file ``marker``."""

    def __init__(self, marker: Path) -> None:
        self.marker = marker

    def __reduce__(self):
        return (Path.touch, (self.marker,))


def _bad_pt(kind: str, good: bytes, marker: Path) -> bytes:
    if kind == "truncated":
        return good[: len(good) // 2]
    if kind == "empty":
        return b""
    if kind == "garbage":
        return b"not a torch file " * 20
    return pickle.dumps({"weights": _Payload(marker)})  # code, not tensors


@pytest.mark.parametrize("kind", ["truncated", "empty", "garbage", "code"])
def test_a_bad_policy_pt_is_named_never_run_and_torchs_unsafe_advice_is_not_relayed(tmp_path, kind):
    folder = model_copy(tmp_path)
    marker = tmp_path / "ran"
    (folder / "policy.pt").write_bytes(_bad_pt(kind, (MODEL / "policy.pt").read_bytes(), marker))
    with pytest.raises(ValueError) as caught:
        wolfpack.load_policy(folder)
    message = str(caught.value)
    assert str(folder / "policy.pt") in message and "weights_only" not in message and "\n" not in message
    assert not marker.exists()
    line = one_line_exit_2(wolfpack_cli("benchmark", "--wolves", folder, "--tasks", "hunt-v1", "--episodes", "1"), str(folder / "policy.pt"))
    assert "weights_only" not in line and not marker.exists()


def test_a_policy_pt_with_nan_weights_is_named(tmp_path):
    folder = model_copy(tmp_path)
    state = torch.load(folder / "policy.pt", weights_only=True)
    name = next(k for k, v in state.items() if v.is_floating_point() and v.ndim == 2)
    state[name][0, 0] = float("nan")
    torch.save(state, folder / "policy.pt")
    with pytest.raises(ValueError, match="holds NaN or inf weights") as caught:
        wolfpack.load_policy(folder)
    assert str(folder / "policy.pt") in str(caught.value)


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "run"
    args = dict(overrides={"world.max_steps": 40}, hp={"num_envs": 4, "n_steps": 16, "epochs": 1, "minibatch_size": 32, "hidden": [8]}, threads=1, torch_threads=1, eval_episodes=2, evaluations=1)
    train("targets", "mappo", out=out, timesteps=600, device="cpu", progress=False, **args)
    return out


RESUME = ("train", "--side", "targets", "--timesteps", "1200", "--hp", "num_envs=4", "--hp", "n_steps=16", "--hp", "epochs=1", "--hp", "minibatch_size=32", "--hp", "hidden=[8]")


def test_the_resume_state_is_tensors_only(tiny_run):
    state = torch.load(tiny_run / "trainer.pt", weights_only=True)  # the trainer's own state loads safely
    assert isinstance(state["generator"], torch.Tensor) and state["agent_steps"] > 0


@pytest.mark.parametrize("kind", ["truncated", "code", "foreign"])
def test_resume_from_a_bad_trainer_pt_is_exit_2_naming_the_file(tiny_run, tmp_path, kind):
    out = tmp_path / "run"
    shutil.copytree(tiny_run, out)
    for stale in out.glob("checkpoints/*/trainer.pt"):  # only the latest state is left to read
        stale.unlink()
    marker = tmp_path / "ran"
    # "foreign": tensors, but a model's weights rather than a resume state.
    bad = (MODEL / "policy.pt").read_bytes() if kind == "foreign" else _bad_pt(kind, (tiny_run / "trainer.pt").read_bytes(), marker)
    (out / "trainer.pt").write_bytes(bad)
    before = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}
    config = yaml.safe_load((out / "config.yaml").read_text())
    run = wolfpack_cli(
        *RESUME, "--set", "world.max_steps=40", "--threads", "1", "--torch-threads", "1", "--eval-episodes", "2", "--evaluations", "1", "--seed", str(config["seed"]), "--out", out, "--resume"
    )
    line = one_line_exit_2(run, str(out / "trainer.pt"))
    assert "internal error" not in line and "weights_only" not in line and not marker.exists()
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == before
