#!/usr/bin/env bash
# Builds the hand-written C baseline (single-threaded and OpenMP) and compares it with
# the lane stepper on the same lanes: accuracy against a fine reference and speed.
# Usage: bash benches/handwritten/run.sh [LANES] [PERIODS]
set -euo pipefail
cd "$(dirname "$0")/../.."
lanes=${1:-256}
periods=${2:-20}
dir=$(mktemp -d)
gcc -O3 -march=native -fno-tree-vectorize benches/handwritten/rk4_loop.c -o "$dir/rk4_loop_1thread" -lm -Wno-unknown-pragmas
gcc -O3 -march=native -fno-tree-vectorize -fopenmp benches/handwritten/rk4_loop.c -o "$dir/rk4_loop_openmp" -lm
cargo build --release --example handwritten
ex=${CARGO_TARGET_DIR:-target}/release/examples/handwritten
"$ex" "$dir/rk4_loop_1thread" "$lanes" "$periods" 500 2000 8000 32000
"$ex" "$dir/rk4_loop_openmp" "$lanes" "$periods" 8000 32000
rm -rf "$dir"
