#!/usr/bin/env bash
# Runs jeffcott's test suite in release mode (the physics tests integrate many periods).
# GPU tests need a Vulkan adapter: when no Vulkan driver is installed, this installs
# Mesa's software driver lavapipe (Debian package mesa-vulkan-drivers) first, so the
# kernel runs for real on the CPU. Set JEFFCOTT_REQUIRE_GPU=1 to make a missing adapter
# fail the GPU tests instead of skipping them (CI does).
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$HOME/.cargo/bin:$PATH"

if ! ls /usr/share/vulkan/icd.d/*.json /etc/vulkan/icd.d/*.json >/dev/null 2>&1; then
  echo "test.sh: no Vulkan driver found; installing Mesa's lavapipe (mesa-vulkan-drivers)"
  SUDO=""
  [ "$(id -u)" -eq 0 ] || SUDO="sudo"
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get update -qq
  $SUDO env DEBIAN_FRONTEND=noninteractive apt-get install -y -qq mesa-vulkan-drivers
fi

cargo test --release "$@"
