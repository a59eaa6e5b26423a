#!/usr/bin/env bash
# The work-precision diagram of issue 12: builds the strong baseline (OpenMP C) and runs
# examples/work_precision.rs, which writes docs/work-precision.png and .csv.
# Usage: bash benches/baseline/run.sh [LANES] [PERIODS]   (default: 1024 200)
set -euo pipefail
cd "$(dirname "$0")/../.."
dir=$(mktemp -d)
gcc -O3 -march=native -fopenmp benches/baseline/rk4_switch.c -o "$dir/rk4_switch" -lm
cargo build --release --example work_precision
"${CARGO_TARGET_DIR:-target}/release/examples/work_precision" "$dir/rk4_switch" "${1:-1024}" "${2:-200}"
rm -rf "$dir"
