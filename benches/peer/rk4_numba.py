"""The strongest simple peer: the loop a competent user writes in an
afternoon with numba, run on the benchmark's own job beside the C loop and the lane
stepper (examples/work_precision.rs, `bash benches/baseline/run.sh`).

Fixed-step RK4 with T/N per step, the unbalance forcing of a regular step's stages read
from a per-period table indexed by the step's number (entries 2s, 2s + 1, 2s + 2 at
multiples of h/2), the contact force switched per stage (g > 0), and in `substep` mode
every step whose four stage evaluations disagree on the contact state redone from its
start as 8 equal sub-steps (libm cos/sin there); lanes shared among threads by numba's
prange. It is the algorithm of ../shared/peers/nb_kernels.py on the lanes of
benches/baseline/rk4_switch.c: W = 133 rad/s, x_r0 = -4 mm + 8 mm i / (lanes - 1), every
other coordinate at the static equilibrium, from t = 0.

Usage: python rk4_numba.py plain|substep N PERIODS LANES OUT.bin
writes LANES x 8 f64 final states (little endian) and prints, as the C loop does,
`mode=... N=... periods=... lanes=... wall=SECONDS s redone_steps=...`; the wall time
excludes numba's compilation (a warm-up call on two lanes runs first).
Needs numpy and numba (`python3 -m venv V && V/bin/pip install numpy numba`).
"""
import math
import sys
import time

import numpy as np
from numba import njit, prange

# Table 1 of the article (MODEL.md), the standard job's speed.
W_R, W_S, XI_R, XI_S = 140.0, 540.0, 0.02, 0.05
DELTA, MU, M_R, M_S, ECC = 0.006, 0.0, 50.0, 50.0, 0.001
K_C, A_G, OMEGA = 1e8, 9.81, 133.0
SUB = 8


@njit(inline="always")
def rhs(x, c, s, f):
    """f = dx/dt with forcing (cos, sin) of W t = (c, s); True in contact (g > 0)."""
    dx = x[0] - x[4]
    dy = x[2] - x[6]
    r = math.sqrt(dx * dx + dy * dy)
    fx = 0.0
    fy = 0.0
    contact = r - DELTA > 0.0
    if contact:
        k = K_C * (r - DELTA) / r
        fx = -k * dx + MU * k * dy
        fy = -k * dy - MU * k * dx
    ew2 = ECC * OMEGA * OMEGA
    f[0] = x[1]
    f[1] = -W_R * W_R * x[0] - 2.0 * XI_R * W_R * x[1] + ew2 * c + fx / M_R
    f[2] = x[3]
    f[3] = -W_R * W_R * x[2] - 2.0 * XI_R * W_R * x[3] + ew2 * s - A_G + fy / M_R
    f[4] = x[5]
    f[5] = -W_S * W_S * x[4] - 2.0 * XI_S * W_S * x[5] - fx / M_S
    f[6] = x[7]
    f[7] = -W_S * W_S * x[6] - 2.0 * XI_S * W_S * x[7] - A_G - fy / M_S
    return contact


@njit(inline="always")
def rk4(x, h, c0, s0, c1, s1, c2, s2, k1, k2, k3, k4, y):
    """One RK4 step of x in place (stage forcing (c0, s0), (c1, s1) twice, (c2, s2));
    True when its stages disagree on the contact state."""
    a = rhs(x, c0, s0, k1)
    for d in range(8):
        y[d] = x[d] + 0.5 * h * k1[d]
    b = rhs(y, c1, s1, k2)
    for d in range(8):
        y[d] = x[d] + 0.5 * h * k2[d]
    c = rhs(y, c1, s1, k3)
    for d in range(8):
        y[d] = x[d] + h * k3[d]
    e = rhs(y, c2, s2, k4)
    for d in range(8):
        x[d] += h / 6.0 * (k1[d] + 2.0 * k2[d] + 2.0 * k3[d] + k4[d])
    return not (a == b and b == c and c == e)


@njit(parallel=True)
def run(n, periods, lanes, redo):
    """Final states [lanes, 8] and the redone steps per lane."""
    h = 2.0 * math.pi / OMEGA / n
    tc = np.empty(2 * n + 1)
    ts = np.empty(2 * n + 1)
    for j in range(2 * n + 1):
        tc[j] = math.cos(OMEGA * (0.5 * h) * j)
        ts[j] = math.sin(OMEGA * (0.5 * h) * j)
    out = np.empty((lanes, 8))
    redone = np.zeros(lanes, dtype=np.int64)
    for i in prange(lanes):
        x = np.zeros(8)
        x[0] = -0.004 + 0.008 * i / (lanes - 1) if lanes > 1 else 0.0
        x[2] = -A_G / (W_R * W_R)
        x[6] = -A_G / (W_S * W_S)
        x0 = np.empty(8)
        k1 = np.empty(8)
        k2 = np.empty(8)
        k3 = np.empty(8)
        k4 = np.empty(8)
        y = np.empty(8)
        for _ in range(periods):
            for s in range(n):
                for d in range(8):
                    x0[d] = x[d]
                changed = rk4(x, h, tc[2 * s], ts[2 * s], tc[2 * s + 1], ts[2 * s + 1],
                              tc[2 * s + 2], ts[2 * s + 2], k1, k2, k3, k4, y)
                if redo and changed:
                    redone[i] += 1
                    for d in range(8):
                        x[d] = x0[d]
                    hs = h / SUB
                    for k in range(SUB):
                        ta = s * h + k * hs
                        tb = ta + 0.5 * hs
                        te = ta + hs
                        rk4(x, hs, math.cos(OMEGA * ta), math.sin(OMEGA * ta),
                            math.cos(OMEGA * tb), math.sin(OMEGA * tb),
                            math.cos(OMEGA * te), math.sin(OMEGA * te), k1, k2, k3, k4, y)
        for d in range(8):
            out[i, d] = x[d]
    return out, redone


def main(argv):
    if len(argv) != 6 or argv[1] not in ("plain", "substep"):
        sys.stderr.write(f"usage: {argv[0]} plain|substep N PERIODS LANES OUT.bin\n")
        return 2
    mode, n, periods, lanes, path = argv[1], int(argv[2]), int(argv[3]), int(argv[4]), argv[5]
    redo = mode == "substep"
    run(8, 1, 2, redo)  # compile outside the timed work
    t0 = time.perf_counter()
    out, redone = run(n, periods, lanes, redo)
    wall = time.perf_counter() - t0
    np.ascontiguousarray(out, dtype="<f8").tofile(path)
    print(f"mode={mode} N={n} periods={periods} lanes={lanes} wall={wall:.3f} s "
          f"redone_steps={int(redone.sum())}")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
