#!/usr/bin/env bash
# Builds the Python package (python/: PyO3 + numpy, an abi3 wheel built by maturin),
# installs the wheel into a virtual environment (python/.venv, created with maturin,
# numpy, pytest and matplotlib when absent) and runs its pytest suite against the
# command line's binary, then the notebook-style example (Fig. 3 and Fig. 7 drawn with
# matplotlib from the returned arrays) at a reduced resolution.
#
# Usage: bash scripts/python-test.sh [path to the jeffcott binary]
# The Python tests are never skipped: a Python that cannot build a virtual environment
# or install the tooling fails this script.
set -euo pipefail
cd "$(dirname "$0")/.."
bin=$(realpath "${1:-target/release/jeffcott}")
venv=python/.venv
py=${PYTHON:-python3}

if [ ! -x "$venv/bin/python" ]; then
  echo "python-test.sh: creating $venv"
  if ! "$py" -m venv "$venv" 2>/dev/null; then
    # Debian's python3 ships venv separately.
    SUDO=""
    [ "$(id -u)" -eq 0 ] || SUDO="sudo"
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
    $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq python3-venv
    "$py" -m venv "$venv"
  fi
fi
"$venv/bin/python" -m pip install -q --upgrade pip >/dev/null
"$venv/bin/python" -m pip install -q "maturin>=1.5,<2" "numpy>=1.21" "pytest>=7" "matplotlib>=3.5"

echo "== python: building the wheel"
rm -rf target/wheels
(cd python && "../$venv/bin/maturin" build --release --strip -o ../target/wheels)
"$venv/bin/python" -m pip install -q --force-reinstall --no-deps target/wheels/jeffcott-*.whl

echo "== python: pytest"
# From python/ so its tests/ are collected; the `pytest` launcher (not `python -m`)
# keeps python/jeffcott (the sources, without the built extension) off sys.path.
(cd python && JEFFCOTT_BIN="$bin" "../$venv/bin/pytest" -q tests)

echo "== python: the example (Fig. 3 and Fig. 7, reduced resolution)"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
MPLBACKEND=Agg "$venv/bin/python" python/examples/article_figures.py --quick --out "$out"
for f in fig3_bifurcation.png fig7_basin.png; do
  [ -s "$out/$f" ] || { echo "python-test.sh: the example did not draw $f"; exit 1; }
done
