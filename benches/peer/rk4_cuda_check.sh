#!/usr/bin/env bash
# Host check of the cupy peer's kernel (benches/peer/rk4_cuda.cu), no GPU needed: build the
# kernel source as plain C++ (g++ -DHOST_CHECK, no FMA contraction), feed it the table and
# start states that rk4_cuda.py builds (its --dry --dump path), run the standard job on 64
# lanes for 20 periods at N = 6144, substep and plain, and compare the final states with
# rk4_numba.py's. Same algorithm, same operations: they should agree to rounding (in
# practice bit for bit). Fails if the largest position difference exceeds 1e-9 m or the
# redone-step counts differ. The plain run uses blocks of 24 threads, so the kernel's lane
# indexing over several blocks, the last one partial, is exercised too. Also builds the
# f32 variant and runs it (its difference from f64 is printed, not judged), and checks
# rk4_cuda.py's --states path against --standard.
#
# Usage: bash benches/peer/rk4_cuda_check.sh   (needs g++ and target/peer-venv with numpy
# and numba: python3 -m venv target/peer-venv && target/peer-venv/bin/pip install numpy numba)
set -euo pipefail
cd "$(dirname "$0")/../.."

PY=target/peer-venv/bin/python
N=6144 PERIODS=20 LANES=64 TOL=1e-9
TMP=$(mktemp -d)
trap 'rm -rf "$TMP"' EXIT

for prec in double float; do
    g++ -std=c++17 -O2 -ffp-contract=off -Wall -Wextra -Wno-unknown-pragmas -DHOST_CHECK \
        -DREAL=$prec -x c++ benches/peer/rk4_cuda.cu -o "$TMP/host_$prec" -lm
done

# The python side without cupy: the inputs from --standard, and the --states path on the
# same states saved as .npy; both dumps must be identical.
$PY benches/peer/rk4_cuda.py substep $N $PERIODS --standard $LANES --dry --dump "$TMP/in"
$PY -c "import sys; sys.path.insert(0, 'benches/peer'); import numpy as np, rk4_cuda; \
np.save('$TMP/std.npy', rk4_cuda.standard_states($LANES))"
$PY benches/peer/rk4_cuda.py substep $N $PERIODS --states "$TMP/std.npy" --precision f32 \
    --dry --dump "$TMP/in2" >/dev/null
for f in states cos sin h; do cmp "$TMP/in/$f.f64" "$TMP/in2/$f.f64"; done

cat >"$TMP/compare.py" <<'EOF'
import sys
import numpy as np
tmp, tol, host, ref = sys.argv[1], float(sys.argv[2]), sys.argv[3], sys.argv[4]
load = lambda name: np.fromfile(f"{tmp}/{name}", dtype="<f8").reshape(-1, 8)
a, b, c = load("cuda64.bin"), load("numba.bin"), load("cuda32.bin")
pos = [0, 2, 4, 6]
diff = np.abs(a - b)
scale = np.maximum(np.abs(b), 1e-300)
print(f"  f64 host kernel vs rk4_numba.py: max |diff| positions {diff[:, pos].max():.3e} m, "
      f"all components {diff.max():.3e}, max rel {(diff / scale).max():.3e}, "
      f"bitwise equal lanes {int((a == b).all(axis=1).sum())}/{len(a)}")
print(f"  f32 host kernel vs f64 (information only): max |diff| positions "
      f"{np.abs(c - a)[:, pos].max():.3e} m, finite {bool(np.isfinite(c).all())}")
redone = lambda s: s.split("redone_steps=")[1].split()[0]
ok = (a.shape == b.shape and np.isfinite(a).all() and diff[:, pos].max() <= tol
      and redone(host) == redone(ref))
print("  PASS" if ok else f"  FAIL (tolerance {tol} m, redone {redone(host)} vs {redone(ref)})")
sys.exit(0 if ok else 1)
EOF

status=0
for mode in substep plain; do
    block=$([ $mode = plain ] && echo 24 || echo 128)
    host=$("$TMP/host_double" $mode $N $PERIODS "$TMP/in" "$TMP/cuda64.bin" $block)
    echo "host kernel f64: $host (block $block)"
    "$TMP/host_float" $mode $N $PERIODS "$TMP/in" "$TMP/cuda32.bin" $block >/dev/null
    ref=$($PY benches/peer/rk4_numba.py $mode $N $PERIODS $LANES "$TMP/numba.bin")
    echo "rk4_numba.py:    $ref"
    $PY "$TMP/compare.py" "$TMP" "$TOL" "$host" "$ref" || status=1
done
if [ $status = 0 ]; then echo "rk4_cuda_check: PASS"; else echo "rk4_cuda_check: FAIL"; fi
exit $status
