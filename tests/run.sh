#!/usr/bin/env bash
# README's test command: installs what the tests need, then runs the Rust core's tests and the
# Python tests on every core (pytest-xdist), leaving out the slow end-to-end checks and the
# RLlib tests (their own virtualenv: tests/rllib/run.sh), which .ci/run runs after it. Run it
# from any folder, in the virtualenv where README's first command installed wolfpack. Extra
# arguments go to pytest.
set -euo pipefail
cd "$(dirname "$0")/.."

echo "== installing the learning and test extras into $(python3 -c 'import sys; print(sys.prefix)')"
echo "   [train]: stable-baselines3 and torch (the trainer, SB3 and TorchRL tests), tensorboard, rich, scipy"
echo "   [dev]:   pytest (and pytest-xdist: every core), hypothesis, the peer simulator mpe2, moviepy, torchrl, supersuit, minari"
echo "   torch is the big download (~2.5 GB with its CUDA libraries; a CPU-only machine can install"
echo "   the CPU build first: pip install torch --index-url https://download.pytorch.org/whl/cpu)"
python3 -m pip install -e ".[train,dev]"

# The tests' time, after the installs: README promises it.
started=$SECONDS
echo "== Rust core"
cargo test --profile test-build
echo "== Python (on every core; without the slow end-to-end checks and the RLlib tests:"
echo "   python3 -m pytest -m slow and bash tests/rllib/run.sh run those, and CI runs both)"
python3 -m pytest -m "not slow" -n auto "$@"
echo "== the tests took $((SECONDS - started)) s after the installs"
