#!/usr/bin/env bash
# The RLlib tests in their own virtualenv (.venv-rllib): ray[rllib] pins gymnasium, so it does not
# share the project's main environment. Creates the virtualenv on first use, (re)installs the
# project into it (editable: the current source), then runs tests/rllib.
set -euo pipefail
cd "$(dirname "$0")/../.."
if [ ! -x .venv-rllib/bin/python ]; then
  echo "making .venv-rllib for the RLlib tests: ray[rllib] and torch, several GB on first use"
  python3 -m venv .venv-rllib
  .venv-rllib/bin/python -m pip install --quiet --upgrade pip
fi
.venv-rllib/bin/python -m pip install -e ".[rllib]" "pytest>=8"
# Keep Ray on loopback for the tests (on a real cluster leave this unset).
export RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER=0
exec .venv-rllib/bin/python -m pytest -p no:cacheprovider tests/rllib "$@"
