#!/usr/bin/env bash
# The explorer's page in a real browser (tests/browser/test_explorer.py): Debian's
# chromium driven through chromedriver by selenium, against `BIN explore`.
# Installs chromium and chromium-driver when absent (as root, or with sudo), and selenium
# into the Python test environment PYTHON's (python/.venv, made by scripts/python-test.sh).
# Without a browser the test is skipped, unless JEFFCOTT_REQUIRE_BROWSER=1 (CI), where
# it fails. Screenshots go to target/explore-screenshots.
# Usage: scripts/browser-test.sh [BIN] [PYTHON]
set -euo pipefail
cd "$(dirname "$0")/.."
BIN=${1:-target/release/jeffcott}
PY=${2:-python/.venv/bin/python}

if ! command -v chromium >/dev/null || ! command -v chromedriver >/dev/null; then
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  echo "browser-test.sh: installing Debian's chromium and chromium-driver"
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq || true
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq chromium chromium-driver \
    || echo "browser-test.sh: could not install chromium"
fi
if ! "$PY" -c "import selenium" 2>/dev/null; then
  "$PY" -m pip install -q "selenium>=4.20,<5" || echo "browser-test.sh: could not install selenium"
fi
JEFFCOTT_BIN="$BIN" JEFFCOTT_SCREENSHOTS="${JEFFCOTT_SCREENSHOTS:-target/explore-screenshots}" \
  "$PY" -m pytest -q -p no:cacheprovider tests/browser
