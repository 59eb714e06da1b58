#!/usr/bin/env bash
# Builds .venv-peers at the repository root: the virtualenv in which benchmarks/peers.py runs the
# peers that cannot share wolfpack's .venv (benchmarks/peer_worker.py is run with its python).
#
#   bash benchmarks/peers_venv.sh          # create or complete it (idempotent: a second run
#                                          # only checks the pins and the imports)
#   PEERS_VENV=/elsewhere bash benchmarks/peers_venv.sh
#
# Why a venv of its own:
# - JaxMARL (MPE simple_tag in JAX) brings jax/jaxlib, flax, chex, gymnax, which .venv does not
#   need, and wolfpack's own tests must not depend on.
# - VMAS pins pyglet<=1.5.27 and needs the old `gym` package; kept out of .venv for the same
#   reason. It needs torch: PyPI's Linux wheel (CUDA libraries included, ~4 GB; the CPU-only
#   wheels live on an index this project's machines cannot reach). The benchmark runs it on CPU.
#
# jaxmarl is installed with its declared dependencies (jax>=0.4.25, flax, chex, jaxtyping,
# gymnax, matplotlib, pillow, safetensors): none pins an old jax; the heavy training stack
# (wandb, hydra, optax, distrax, flashbax) is only in its "algs" extra, not installed here.
# `import jaxmarl` imports every environment package (Hanabi, SMAX, Overcooked...), so all of
# those declared dependencies are needed even for MPE alone.
set -euo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
VENV="${PEERS_VENV:-$ROOT/.venv-peers}"
PY="${PYTHON:-python3}"

# Pins: the versions the BENCHMARKS.md peers tables were measured with.
PINS=(
  "jax==0.10.2"
  "jaxlib==0.10.2"
  "jaxmarl==0.2.0"
  "vmas==1.5.2"
  "torch==2.15.0"
  "numpy==2.4.6"
)

if [ ! -x "$VENV/bin/python" ]; then
  echo "[peers_venv] creating $VENV with $($PY --version)" >&2
  "$PY" -m venv "$VENV"
  "$VENV/bin/python" -m pip install --quiet --upgrade pip
fi

if "$VENV/bin/python" - "${PINS[@]}" >/dev/null 2>&1 <<'PYEOF'
import sys
from importlib import metadata
for pin in sys.argv[1:]:
    name, want = pin.split("==")
    if metadata.version(name) != want:
        sys.exit(1)
import jax, jaxmarl, torch, vmas  # noqa: E401,F401
PYEOF
then
  echo "[peers_venv] $VENV is complete (${PINS[*]})" >&2
  exit 0
fi

echo "[peers_venv] installing ${PINS[*]} into $VENV" >&2
start=$(date +%s)
"$VENV/bin/python" -m pip install --quiet "${PINS[@]}"
# Check the imports the worker needs (jaxmarl prints a note about its optional submodules).
"$VENV/bin/python" -c "import jax, jaxmarl, torch, vmas; print('[peers_venv] jax', jax.__version__, 'jaxmarl', jaxmarl.__version__, 'torch', torch.__version__, 'vmas', vmas.__version__)" >&2
echo "[peers_venv] done in $(( $(date +%s) - start )) s; size $(du -sh "$VENV" | cut -f1)" >&2
