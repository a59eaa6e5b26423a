#!/usr/bin/env bash
# Builds, here, what the GPU campaign (scripts/gpu-campaign.sh, docs/gpu.md) needs on a lent
# GPU machine that has no Rust toolchain and no network, into the ignored folder
# .campaign/ (carried to the device with `carry: [".campaign"]`, 64 MiB in all):
#   bin/jeffcott        the stripped release binary
#   bin/exe-path        where the test executables look for it (CARGO_BIN_EXE_jeffcott is
#                       baked in at compile time; the campaign puts the binary there)
#   tests/NAME.gz       the stripped test executables that drive a GPU, gzipped
#   gl/*.deb            the Vulkan loader and GL vendor-neutral dispatch (libvulkan1,
#                       libglvnd0 and its GL/EGL/GLX front ends): NVIDIA's Vulkan ICD is
#                       libGLX_nvidia, which needs libglvnd's libGLdispatch to load
#   bin/jeffcott-previous.gz
#                       with --previous REV only: the stripped release binary of git
#                       revision REV, built in a worktree of its own (target/previous,
#                       ignored; a cold build, minutes), which the campaign measures
#                       beside this build (old against new on the same GPU)
#   ref/std_L1024_P200.npy
#                       the standard job's reference (lane stepper, CPU f64, N = 8000;
#                       N = 4000 beside it says how converged it is), so the device
#                       spends no time on it
# Usage: bash scripts/gpu-campaign-prepare.sh [--previous REV]
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$HOME/.cargo/bin:$PATH"
previous=""
if [ "${1:-}" = "--previous" ]; then
  previous="${2:?--previous needs a git revision}"
  git rev-parse --verify --quiet "$previous^{commit}" >/dev/null ||
    { echo "prepare: --previous $previous is not a commit of this repository" >&2; exit 2; }
fi
dst=.campaign
rm -rf "$dst/bin" "$dst/tests" "$dst/gl"
mkdir -p "$dst/bin" "$dst/tests" "$dst/gl" "$dst/ref"

# The binary and the test executables, release mode as the README's test command builds.
cargo build --release --quiet
strip -o "$dst/bin/jeffcott" target/release/jeffcott
echo "$PWD/target/release/jeffcott" >"$dst/bin/exe-path"
if [ -n "$previous" ]; then
  wt=target/previous/src
  rm -rf "$wt"
  git worktree prune
  git worktree add --detach "$wt" "$previous" >/dev/null
  (cd "$wt" && CARGO_TARGET_DIR="$PWD/../build" cargo build --release --quiet --bin jeffcott)
  echo "prepare: previous build $(target/previous/build/release/jeffcott --version)"
  strip -o "$dst/bin/jeffcott-previous" target/previous/build/release/jeffcott
  gzip -9f "$dst/bin/jeffcott-previous"
  git worktree remove --force "$wt"
fi
# The test targets that drive a GPU adapter (they fail, not skip, with
# JEFFCOTT_REQUIRE_GPU=1) and the GPU crate's own unit tests.
gpu_tests=(gpu mirror basin_gpu early_exit lyapunov orbits map runs shards input_checks jeffcott_gpu)
cargo test --release --no-run --message-format=json 2>/dev/null |
  python3 -c '
import json, sys
for line in sys.stdin:
    m = json.loads(line)
    if m.get("reason") == "compiler-artifact" and m.get("executable") and m["profile"]["test"]:
        print(m["target"]["name"], m["executable"])
' >"$dst/tests/all.txt"
for t in "${gpu_tests[@]}"; do
  exe=$(awk -v t="$t" '$1 == t { print $2 }' "$dst/tests/all.txt" | head -1)
  [ -n "$exe" ] || { echo "prepare: no test executable named $t" >&2; exit 1; }
  strip -o "$dst/tests/$t" "$exe"
  gzip -9f "$dst/tests/$t"
done
rm "$dst/tests/all.txt"

# The Vulkan loader and libglvnd for the device (x86-64 Debian packages, unpacked there
# into /; ../.library/device/README.md names the same set).
(cd "$dst/gl" && apt-get download libvulkan1 libegl1 libglvnd0 libopengl0 libgl1 libglx0 libgles2 2>/dev/null)

# The standard job's reference (docs/performance.md): 1024 lanes at W = 133, x_r0 evenly
# over [-4, 4] mm, the rest at the static equilibrium, 200 periods from t = 0; the final
# state by the lane stepper at N = 8000 (as examples/work_precision.rs) and at N = 4000.
if [ ! -f "$dst/ref/std_L1024_P200.npy" ]; then
  bash scripts/gpu-campaign.sh --reference-only --lanes 1024 --periods 200 \
    --jeffcott target/release/jeffcott --ref-dir "$dst/ref"
fi
du -sh "$dst"
size=$(du -sm "$dst" | cut -f1)
[ "$size" -lt 56 ] || { echo "prepare: $dst is $size MiB, over the 56 MiB left beside the working tree" >&2; exit 1; }
echo "prepare: ready; run on the device: bash scripts/gpu-campaign.sh --out \$OUT (carry .campaign)"
