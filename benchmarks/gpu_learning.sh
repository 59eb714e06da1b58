#!/usr/bin/env bash
# The native trainer on a machine with many cores and one GPU (BENCHMARKS.md, "Learning"):
#   1. the default recipe with the networks on CUDA and the batch on every core;
#   2. a batch sized for the machine (2,048 worlds, minibatches of 65,536) on CUDA;
#   3. five training seeds side by side, each pinned to two cores with the networks on the CPU:
#      the 2-core figure of the default recipe, five times at once.
# Usage: bash benchmarks/gpu_learning.sh OUT_DIR [MINUTES_GPU] [MINUTES_PINNED]
# Every run's folder lands in OUT_DIR; summary.txt has one line per run.
set -uo pipefail
out=${1:?usage: gpu_learning.sh OUT_DIR [MINUTES_GPU] [MINUTES_PINNED]}
gpu_min=${2:-1.5}
pinned_min=${3:-5}
mkdir -p "$out"
cores=$(nproc)
train() { python3 -m wolfpack.cli train --side wolves --no-progress --eval-episodes 200 "$@"; }
{
  echo "machine: $cores cores; $(nvidia-smi -L 2>/dev/null | head -1)"
  train --device cuda --threads "$cores" --torch-threads "$cores" --time-limit "$gpu_min" --evaluations 6 --out "$out/gpu_default"
  train --device cuda --threads "$cores" --torch-threads "$cores" --time-limit "$gpu_min" --evaluations 6 \
    --hp num_envs=2048 --hp minibatch_size=65536 --out "$out/gpu_2048"
  for seed in 0 1 2 3 4; do
    first=$((2 * seed))
    if [ $((first + 1)) -lt "$cores" ]; then
      taskset -c "$first,$((first + 1))" python3 -m wolfpack.cli train --side wolves --no-progress --eval-episodes 200 --device cpu \
        --threads 2 --torch-threads 2 --seed "$seed" --time-limit "$pinned_min" --evaluations 10 --out "$out/pinned_s$seed" &
    fi
  done
  wait
} 2>&1 | tee "$out/summary.txt"
