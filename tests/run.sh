#!/usr/bin/env bash
# README's test command: installs what the tests need, then runs every test (Rust core, Python,
# then RLlib in a virtualenv of its own). Run it from any folder, in the virtualenv where README's
# first command installed wolfpack. Extra arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== installing the learning and test extras into $(python3 -c 'import sys; print(sys.prefix)')"
echo "   [train]: stable-baselines3 and torch (the trainer, SB3 and TorchRL tests), tensorboard, rich, scipy"
echo "   [dev]:   pytest, hypothesis, the peer simulator mpe2, moviepy, torchrl, supersuit, minari"
echo "   torch is the big download (~2.5 GB with its CUDA libraries; a CPU-only machine can install"
echo "   the CPU build first: pip install torch --index-url https://download.pytorch.org/whl/cpu)"
python3 -m pip install -e ".[train,dev]"

echo "== Rust core"
cargo test --release
echo "== Python (without the slow end-to-end checks: python3 -m pytest -m slow runs those)"
python3 -m pytest -m "not slow" "$@"
echo "== RLlib (its own virtualenv, .venv-rllib: ray[rllib] pins gymnasium)"
bash tests/rllib/run.sh
