"""rust/pgo/rustc-wrapper: which compilations get the profile-guided optimisation flag.

The wrapper sits between cargo and rustc for every crate of every build in this workspace, so
the tests run it with `echo` standing in for rustc and read back the command line it would run.
Only wolfpack-core and the extension, optimised, for x86_64 Linux, may gain
`-Cprofile-use=…/wolfpack.profdata`; everything else must pass through untouched.
"""

from __future__ import annotations

import os
import shutil
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
WRAPPER = ROOT / "rust" / "pgo" / "rustc-wrapper"
PROFILE = ROOT / "rust" / "pgo" / "wolfpack.profdata"

pytestmark = pytest.mark.skipif(shutil.which("sh") is None, reason="the wrapper is a POSIX sh script")

OURS = ["--crate-name", "wolfpack_core", "--edition=2021", "rust/core/src/lib.rs", "-C", "opt-level=3"]
LINUX = ["--target", "x86_64-unknown-linux-gnu"]


def wrapped(args: list[str], **env: str) -> list[str]:
    """The command line the wrapper runs for `rustc ARGS` (with `echo` as rustc)."""
    environ = {k: v for k, v in os.environ.items() if k != "WOLFPACK_PGO"} | env
    out = subprocess.run([str(WRAPPER), "echo", *args], capture_output=True, text=True, check=True, env=environ)
    return out.stdout.split()


def use_flag() -> str:
    return f"-Cprofile-use={PROFILE}"


def test_cargo_runs_the_wrapper_from_the_workspace_config():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    config = tomllib.loads((ROOT / ".cargo" / "config.toml").read_text(encoding="utf-8"))
    assert (ROOT / config["build"]["rustc-wrapper"]).resolve() == WRAPPER
    assert os.access(WRAPPER, os.X_OK), "cargo executes the wrapper directly"


def test_the_profile_is_in_the_repository():
    # Without it the wrapper passes everything through (no error, no gain).
    assert PROFILE.is_file() and PROFILE.stat().st_size > 0


@pytest.mark.parametrize("crate", ["wolfpack_core", "_core"])
def test_our_optimised_linux_crates_get_the_profile(crate):
    args = ["--crate-name", crate, *OURS[2:], *LINUX]
    assert wrapped(args) == [*args, use_flag()]


def test_joined_flag_spellings_count_too():
    args = ["--crate-name", "_core", "-Copt-level=3", "--target=x86_64-unknown-linux-gnu"]
    assert wrapped(args) == [*args, use_flag()]


@pytest.mark.parametrize(
    "args",
    [
        pytest.param(["--crate-name", "serde", *OURS[2:], *LINUX], id="a dependency"),
        pytest.param(["--crate-name", "build_script_build", *OURS[2:], *LINUX], id="a build script"),
        pytest.param([*OURS[:4], "-C", "opt-level=0", *LINUX], id="a debug build"),
        pytest.param([*OURS, "--target", "aarch64-apple-darwin"], id="another target"),
        pytest.param([*OURS, *LINUX, "-Cprofile-generate=/tmp/raw"], id="an instrumented build"),
        pytest.param([*OURS, *LINUX, "-C", "profile-generate=/tmp/raw"], id="an instrumented build, split"),
        pytest.param(["-vV"], id="cargo asking for the version"),
    ],
)
def test_everything_else_passes_through_unchanged(args):
    assert wrapped(args) == args


@pytest.mark.parametrize("off", ["0", "off", "no", "false"])
def test_wolfpack_pgo_off_turns_it_off(off):
    args = [*OURS, *LINUX]
    assert wrapped(args, WOLFPACK_PGO=off) == args
    assert wrapped(args, WOLFPACK_PGO="1") == [*args, use_flag()]


def test_without_target_the_host_decides():
    # Cargo passes no --target when building for the host.
    host_is_x86_64_linux = os.uname().sysname == "Linux" and os.uname().machine == "x86_64"
    assert wrapped(OURS) == (OURS + [use_flag()] if host_is_x86_64_linux else OURS)


def test_arguments_with_spaces_survive():
    args = [*OURS, *LINUX, "--cfg", 'feature="a b"']
    out = subprocess.run([str(WRAPPER), "printf", "%s\n", *args], capture_output=True, text=True, check=True)
    assert out.stdout.splitlines() == [*args, use_flag()]
