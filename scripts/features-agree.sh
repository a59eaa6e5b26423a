#!/usr/bin/env bash
# Checks that the test build (`cargo test --release`: the default members with their
# dev-dependencies) and the Python wheel's build (maturin: jeffcott-py alone, with
# pyo3/extension-module) resolve every crate they share with the same features. Where
# they differ, cargo compiles that crate and everything above it twice, and the wheel's
# build repeats most of the test build (wgpu and naga included). The remedy is to add
# the crate with the union of its features to crates/workspace-hack/Cargo.toml. The
# workspace's library layers (jeffcott-core, -gpu, -analysis) are checked too: a feature
# of theirs that only one build turns on would make the wheel compile them again (about
# ten minutes here), which is why they have none.
set -euo pipefail
cd "$(dirname "$0")/.."
export PATH="$HOME/.cargo/bin:$PATH"
tree() { cargo tree --locked "$@" -f '{p} [{f}]' --prefix none | sed 's/ (\*)$//' | sort -u; }
test_build=$(mktemp) wheel_build=$(mktemp)
trap 'rm -f "$test_build" "$wheel_build"' EXIT
tree -e normal,build,dev >"$test_build"
tree -p jeffcott-py --features pyo3/extension-module -e normal,build >"$wheel_build"
python3 - "$test_build" "$wheel_build" <<'PY'
import sys

def features(path):
    """package name and version -> the set of feature lists cargo tree printed for it"""
    found = {}
    for line in open(path):
        package, _, feats = line.rstrip("\n").partition(" [")
        package = package.split(" (")[0].strip()
        found.setdefault(package, set()).add(feats.rstrip("]"))
    return found

test_build, wheel_build = features(sys.argv[1]), features(sys.argv[2])
differ = [p for p in sorted(wheel_build)
          if p in test_build and wheel_build[p] != test_build[p]]
for p in differ:
    print(f"{p}\n  test build: {sorted(test_build[p])}\n  wheel:      {sorted(wheel_build[p])}")
if differ:
    print(f"features-agree.sh: {len(differ)} shared crates resolve different features in the "
          "test build and the wheel's build; add the union to crates/workspace-hack/Cargo.toml")
    sys.exit(1)
shared = sum(1 for p in wheel_build if p in test_build)
print(f"features-agree.sh: the {shared} crates the wheel shares with the test build "
      "have the same features")
PY
