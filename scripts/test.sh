#!/usr/bin/env bash
# Runs jeffcott's test suite in release mode (the physics tests integrate many periods),
# then the Python package's (scripts/python-test.sh: builds the wheel with maturin in a
# virtual environment python/.venv, installing maturin, numpy, pytest and matplotlib
# there when absent, and runs pytest and the example), then the explorer's page in a real
# browser (scripts/browser-test.sh: Debian's chromium, installed when absent, driven by
# selenium; JEFFCOTT_REQUIRE_BROWSER=1 makes a missing browser fail instead of skip, as
# in CI), then every command of the
# README's tour and of docs/guide.md (scripts/docs-commands.sh), then the GPU campaign's local
# mode (scripts/gpu-campaign.sh --local --small), then the refactoring check's
# self-test (scripts/golden.sh selftest: its command set runs twice to identical
# outputs), then the real-Slurm test of the
# cluster recipe (scripts/slurm-test.sh: a single-node
# Slurm started by hand, a 4-task array job and its merge; it needs root and installs
# slurm-wlm when absent; JEFFCOTT_REQUIRE_SLURM=1 makes a Slurm that cannot start fail
# instead of skip, as in CI).
# GPU tests need a Vulkan adapter: when no Vulkan driver is installed, this installs
# Mesa's software driver lavapipe (Debian package mesa-vulkan-drivers) first, so the
# kernel runs for real on the CPU. Set JEFFCOTT_REQUIRE_GPU=1 to make a missing adapter
# fail the GPU tests instead of skipping them (CI does).
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$HOME/.cargo/bin:$PATH"

# A Vulkan driver is installed when either ICD folder holds a manifest (`ls a/* b/*`
# would fail whenever one of the two folders is empty, so test each on its own).
has_icd() { compgen -G "$1/*.json" >/dev/null; }
if ! has_icd /usr/share/vulkan/icd.d && ! has_icd /etc/vulkan/icd.d; then
  echo "test.sh: no Vulkan driver found; installing Mesa's lavapipe (mesa-vulkan-drivers)"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers
fi

cargo test --release "$@"
bash scripts/python-test.sh target/release/jeffcott
bash scripts/browser-test.sh target/release/jeffcott python/.venv/bin/python
bash scripts/docs-commands.sh target/release/jeffcott python/.venv/bin/python
# The GPU campaign's local mode: every step of what a lent H100 runs, at small
# sizes on the adapter at hand, so the campaign cannot rot between the rare GPU sessions.
bash scripts/gpu-campaign.sh --local --small --out target/campaign-small
# The refactoring check (scripts/golden.sh: a fixed command set, every study and every
# Python function, hashed) runs, and two runs give identical outputs.
bash scripts/golden.sh selftest target/release/jeffcott python/.venv/bin/python
bash scripts/slurm-test.sh target/release/jeffcott
