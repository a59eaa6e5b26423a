#!/usr/bin/env bash
# The work-precision diagram: builds the C loop (OpenMP), sets up the
# numba peer's interpreter (a virtual environment target/peer-venv with numpy and numba,
# made once) and runs examples/work_precision.rs, which writes docs/work-precision.png and
# .csv and prints the ratios against both loops.
# Usage: bash benches/baseline/run.sh [LANES] [PERIODS]   (default: 1024 200)
#
# The C loop is built with -fno-tree-vectorize: gcc 12's vectorizer packs its 8-element
# loops into AVX-512 shuffles and runs it 1.9x slower (0.85 s against 1.60 s for 256
# lanes x 20 periods at N = 6144 on the 2-core VM, same bits); without it the loop runs
# as fast as the numba peer, as a competent user's loop would after one profile.
set -euo pipefail
cd "$(dirname "$0")/../.."
dir=$(mktemp -d)
gcc -O3 -march=native -fno-tree-vectorize -fopenmp benches/baseline/rk4_switch.c -o "$dir/rk4_switch" -lm
venv=${CARGO_TARGET_DIR:-target}/peer-venv
if [ ! -x "$venv/bin/python" ] || ! "$venv/bin/python" -c "import numba" 2>/dev/null; then
  python3 -m venv "$venv"
  "$venv/bin/pip" install -q "numpy>=1.21" "numba>=0.58"
fi
cargo build --release --example work_precision
"${CARGO_TARGET_DIR:-target}/release/examples/work_precision" "$dir/rk4_switch" "${1:-1024}" "${2:-200}" "$venv/bin/python"
rm -rf "$dir"
