#!/usr/bin/env bash
# Remakes rust/pgo/wolfpack.profdata, the profile that rust/pgo/rustc-wrapper feeds to rustc
# (profile-guided optimisation of wolfpack-core and the extension on x86_64 Linux).
#
#   bash rust/pgo/regenerate.sh            # with the project's virtualenv active
#
# Run it after changing the hot path (the step, the laws, the observations, the batch): a stale
# profile still builds, but the functions that changed lose their share of the gain.
#  1. builds an instrumented wheel of the extension and instrumented Rust examples (their own
#     target folder, ≈ 3 min);
#  2. installs the wheel into a scratch folder that goes first on PYTHONPATH, so the workload
#     runs on it while numpy, gymnasium and the rest come from the active virtualenv;
#  3. runs rust/pgo/workload.py and the examples that BENCHMARKS.md times (≈ 1 min); each
#     process writes a raw profile;
#  4. merges them with llvm-profdata into rust/pgo/wolfpack.profdata.
# The examples need their own runs: a `cargo build -p wolfpack-core` unifies the dependencies'
# features differently from the extension's build, so its wolfpack-core has other symbol
# hashes, and the extension's profile does not apply to it (measured: no gain without them).
# Needs maturin and an llvm-profdata that reads rustc's raw profiles: rustc 1.95 (LLVM 22)
# writes raw version 10, which Debian's llvm-19 reads (`apt-get install llvm-19`). Set
# LLVM_PROFDATA to pick one; otherwise the newest llvm-profdata[-N] on PATH is used.
set -euo pipefail
here="$(cd "$(dirname "$0")" && pwd)"
root="$(cd "$here/../.." && pwd)"
cd "$root"

profdata="${LLVM_PROFDATA:-}"
if [ -z "$profdata" ]; then
    profdata="$(compgen -c llvm-profdata | sort -t- -k3 -n | tail -n 1 || true)"
fi
if [ -z "$profdata" ] || ! command -v "$profdata" >/dev/null; then
    echo "regenerate.sh: no llvm-profdata found (apt-get install llvm-19, or set LLVM_PROFDATA)" >&2
    exit 1
fi

scratch="$(mktemp -d)"
trap 'rm -rf "$scratch"' EXIT
raw="$scratch/raw"

echo "== instrumented build ($scratch)"
# The wrapper steps aside when it sees -Cprofile-generate, so the old profile plays no part.
RUSTFLAGS="-Cprofile-generate=$raw" maturin build --release --out "$scratch/wheel" --target-dir "$root/target/pgo-instrumented"
RUSTFLAGS="-Cprofile-generate=$raw" cargo build --release -p wolfpack-core --examples --target-dir "$root/target/pgo-instrumented"
# Build scripts and proc macros were instrumented too and wrote their own profiles: not ours.
rm -rf "$raw"

echo "== workload"
python -m pip install --quiet --no-deps --target "$scratch/site" "$scratch"/wheel/*.whl
PYTHONPATH="$scratch/site" python "$here/workload.py"
examples="$root/target/pgo-instrumented/release/examples"
"$examples/profile_step" hunt 1000
"$examples/profile_step" batch 1500 64
"$examples/profile_step" batch 100 1024
"$examples/digest" 100
"$examples/batch_threads" 64,1024 1,2 0.5

echo "== merge with $profdata"
"$profdata" merge -o "$here/wolfpack.profdata.new" "$raw"/*.profraw
mv "$here/wolfpack.profdata.new" "$here/wolfpack.profdata"
ls -l "$here/wolfpack.profdata"
echo "Rebuild to use it: pip install -e . (or maturin develop --release)."
