#!/usr/bin/env sh
# Batched wgpu frames per second (84², 128², 256²; batches of 1,024 views over two
# 1M-triangle dense scenes uploaded side by side) with the adapter's name: the id + depth
# pass with its one read-back, and with colour, depth and semantics derived on all cores.
# Needs a GPU (or lavapipe) that wgpu finds; prints why it skipped otherwise.
#   scripts/gpu_bench.sh            (CARGO_TARGET_DIR is honoured;
#   MINOS_GPU_BENCH_VIEWS=64 for a smaller batch on a software adapter such as lavapipe)
set -eu
cd "$(dirname "$0")/.."
exec cargo bench --bench render -- gpu
