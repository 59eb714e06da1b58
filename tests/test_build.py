"""How the extension is built: the allocator it links, and which compilations get the
profile-guided optimisation flag (rust/pgo/rustc-wrapper).

The wrapper sits between cargo and rustc for every crate of every build in this workspace, so
the tests run it with `echo` standing in for rustc and read back the command line it would run.
Only wolfpack-core and the extension, optimised, for x86_64 Linux, may gain
`-Cprofile-use=…/wolfpack.profdata`; everything else must pass through untouched.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
WRAPPER = ROOT / "rust" / "pgo" / "rustc-wrapper"
PROFILE = ROOT / "rust" / "pgo" / "wolfpack.profdata"

needs_sh = pytest.mark.skipif(shutil.which("sh") is None, reason="the wrapper is a POSIX sh script")

#: The values of WOLFPACK_PGO that the wrapper reads as "off" (exactly these, case included).
PGO_OFF = ("0", "off", "no", "false")
HOST_IS_X86_64_LINUX = sys.platform == "linux" and os.uname().machine == "x86_64"

OURS = ["--crate-name", "wolfpack_core", "--edition=2021", "rust/core/src/lib.rs", "-C", "opt-level=3"]
LINUX = ["--target", "x86_64-unknown-linux-gnu"]


def wrapped(args: list[str], **env: str) -> list[str]:
    """The command line the wrapper runs for `rustc ARGS` (with `echo` as rustc)."""
    environ = {k: v for k, v in os.environ.items() if k != "WOLFPACK_PGO"} | env
    out = subprocess.run([str(WRAPPER), "echo", *args], capture_output=True, text=True, check=True, env=environ)
    return out.stdout.split()


def use_flag() -> str:
    return f"-Cprofile-use={PROFILE}"


@needs_sh
def test_cargo_runs_the_wrapper_from_the_workspace_config():
    tomllib = pytest.importorskip("tomllib")  # Python >= 3.11
    config = tomllib.loads((ROOT / ".cargo" / "config.toml").read_text(encoding="utf-8"))
    # The workspace wrapper: only this workspace's crates, after any RUSTC_WRAPPER (sccache).
    assert "rustc-wrapper" not in config["build"]
    assert (ROOT / config["build"]["rustc-workspace-wrapper"]).resolve() == WRAPPER
    assert os.access(WRAPPER, os.X_OK), "cargo executes the wrapper directly"


def test_the_profile_is_in_the_repository():
    # Without it the wrapper passes everything through (no error, no gain).
    assert PROFILE.is_file() and PROFILE.stat().st_size > 0


@needs_sh
@pytest.mark.parametrize("crate", ["wolfpack_core", "_core"])
def test_our_optimised_linux_crates_get_the_profile(crate):
    args = ["--crate-name", crate, *OURS[2:], *LINUX]
    assert wrapped(args) == [*args, use_flag()]


@needs_sh
def test_joined_flag_spellings_count_too():
    args = ["--crate-name", "_core", "-Copt-level=3", "--target=x86_64-unknown-linux-gnu"]
    assert wrapped(args) == [*args, use_flag()]


@needs_sh
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


@needs_sh
@pytest.mark.parametrize("off", PGO_OFF)
def test_wolfpack_pgo_off_turns_it_off(off):
    args = [*OURS, *LINUX]
    assert wrapped(args, WOLFPACK_PGO=off) == args
    assert wrapped(args, WOLFPACK_PGO="1") == [*args, use_flag()]


@needs_sh
def test_without_target_the_host_decides():
    # Cargo passes no --target when building for the host.
    assert wrapped(OURS) == (OURS + [use_flag()] if HOST_IS_X86_64_LINUX else OURS)


@needs_sh
def test_arguments_with_spaces_survive():
    args = [*OURS, *LINUX, "--cfg", 'feature="a b"']
    out = subprocess.run([str(WRAPPER), "printf", "%s\n", *args], capture_output=True, text=True, check=True)
    assert out.stdout.splitlines() == [*args, use_flag()]


def test_the_extension_loads_after_torch_and_steps_threads_across_a_fork():
    """mimalloc (rust/py/src/lib.rs) must load with dlopen after torch has taken its share of
    the static TLS block, and a batch stepped on two threads must step again in a forked child
    (which has none of the parent's threads)."""
    pytest.importorskip("torch")
    if not hasattr(os, "fork"):
        pytest.skip("no fork on this platform")
    script = """
import os
import torch  # first: its libraries take static TLS before the extension is loaded
import numpy as np
import wolfpack
env = wolfpack.BatchEnv(num_envs=8, seed=0, threads=2)
env.reset()
zeros = np.zeros((8, env.n_wolves, 2), np.float32)
for _ in range(5):
    env.step(zeros)
pid = os.fork()
if pid == 0:
    for _ in range(5):
        env.step(zeros)
    os._exit(0)
_, status = os.waitpid(pid, 0)
assert os.WIFEXITED(status) and os.WEXITSTATUS(status) == 0, status
print("ok")
"""
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, timeout=300)
    assert out.returncode == 0 and out.stdout.strip() == "ok", out.stderr[-2000:]


def dynamic_flags(library: Path) -> int:
    """DT_FLAGS of an ELF64 little-endian shared library (0 when it has none)."""
    import struct

    data = library.read_bytes()
    assert data[:4] == b"\x7fELF" and data[4] == 2 and data[5] == 1, "expected ELF64 little-endian"
    (shoff,) = struct.unpack_from("<Q", data, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", data, 0x3A)
    for k in range(shnum):
        (sh_type,) = struct.unpack_from("<I", data, shoff + k * shentsize + 4)
        if sh_type == 6:  # SHT_DYNAMIC: (tag, value) pairs
            offset, size = struct.unpack_from("<QQ", data, shoff + k * shentsize + 0x18)
            for tag, value in struct.iter_unpack("<qQ", data[offset : offset + size]):
                if tag == 0x1E:  # DT_FLAGS
                    return value
    return 0


@pytest.mark.skipif(sys.platform != "linux", reason="an ELF check")
def test_the_extension_needs_no_static_tls():
    # DF_STATIC_TLS: the library uses initial-exec TLS, which dlopen can only serve from the
    # static block's small surplus. mimalloc without `local_dynamic_tls` sets it.
    from wolfpack import _core

    assert not dynamic_flags(Path(_core.__file__)) & 0x10


@pytest.mark.skipif(not HOST_IS_X86_64_LINUX, reason="PGO is applied on x86_64 Linux only")
def test_the_release_extension_in_this_checkout_was_profile_guided():
    """Guards against the wrapper silently stepping aside (say, if cargo changed how it spells
    the crate name or the opt-level): rustc lists `-Cprofile-use`'s file among a build's inputs,
    so the dep-info of the release extension built here (by `pip install -e .` or
    `maturin develop --release`) must name the profile."""
    dep_infos = sorted((ROOT / "target" / "release" / "deps").glob("_core*.d"), key=lambda p: p.stat().st_mtime)
    if not dep_infos:
        pytest.skip("no release build of the extension in this checkout")
    if os.environ.get("WOLFPACK_PGO") in PGO_OFF or os.environ.get("RUSTC_WORKSPACE_WRAPPER") == "":
        pytest.skip("PGO turned off in this environment")
    assert str(PROFILE) in dep_infos[-1].read_text(encoding="utf-8"), (
        f"{dep_infos[-1]} does not list {PROFILE}: the last release build was not profile-guided (built with WOLFPACK_PGO=0? then rebuild without it)"
    )
