"""The strongest simple GPU peer: what a competent user writes in an afternoon
with cupy, a hand-written CUDA C kernel run through cupy.RawKernel, on the benchmark's own
job.

The kernel (rk4_cuda.cu, read from beside this file) is the algorithm of
../shared/peers/nb_kernels.py exactly as benches/peer/rk4_numba.py writes it, one thread
per lane: fixed-step RK4 with h = T/N, T = 2 pi / OMEGA, the unbalance forcing of a
regular step's stages read from a per-period table of cos/sin of OMEGA t at t = j h/2,
j = 0..2N (phase OMEGA t, PHI0 = 0 as in rk4_numba.py), the contact force switched per
stage (g = r - DELTA > 0), and in `substep` mode every step whose four stage evaluations
disagree on the contact state redone from its start as 8 equal sub-steps with cos/sin at
the sub-step times (`plain`: no redo). The lane's state stays in registers while the
thread loops over periods and steps. Table 1 parameters, W = 133 rad/s. `--precision f32`
runs the same kernel in float (the table computed in f64, then rounded).

Timing: the kernel is compiled and launched once on a few lanes for one period first
(neither counted); then the full launch is timed with CUDA events around the kernel alone
(start states already on the device, final states copied back afterwards), `--repeat R`
times, and the median and the minimum are reported. Every launch is followed by a device
synchronisation, so a failing kernel raises.

On the GPU NVRTC contracts a*b + c into FMAs (its default), so f64 results agree with
rk4_numba.py's to rounding, not bit for bit; benches/peer/rk4_cuda_check.sh compiles the
same kernel source as C++ on the host without contraction and compares it with
rk4_numba.py (no GPU needed).

Usage:
  python rk4_cuda.py plain|substep N PERIODS (--states IN.npy | --standard LANES)
         --out OUT.npy [--precision f64|f32] [--block 128] [--repeat R]
  python rk4_cuda.py plain|substep N PERIODS (--states IN.npy | --standard LANES)
         --dry [--dump DIR]
IN.npy: float64 [lanes, 8] start states; OUT.npy: float64 [lanes, 8] final states after
PERIODS periods from t = 0. `--standard LANES` builds the standard job's start states
instead (x_r0 = -4 mm + 8 mm i / (LANES - 1), the other coordinates at the static
equilibrium of rk4_numba.py). Prints one JSON line: peer, precision, N, periods, lanes,
block, repeat, wall_s (median), wall_min_s, lane_periods_per_s and regular_steps_per_s
(from the median; sub-steps not counted), redone_steps_per_lane (mean), the kernel's
registers and local memory per thread, device.
`--dry` needs no cupy or GPU: it builds the table and the states, reads the kernel source
and prints their sizes; `--dump DIR` also writes them as raw little-endian f64
(states.f64, cos.f64, sin.f64, h.f64) for the host build of rk4_cuda.cu.
Needs numpy and, except with --dry, cupy (e.g. cupy-cuda13x).
"""
import argparse
import json
import math
import os
import sys

import numpy as np

HERE = os.path.dirname(os.path.abspath(__file__))
SOURCE = os.path.join(HERE, "rk4_cuda.cu")
KERNEL = "rk4_lanes"

# The parameters the host side needs (the kernel has its own copy of Table 1).
W_R, W_S, A_G, OMEGA = 140.0, 540.0, 9.81, 133.0


def standard_states(lanes):
    """The standard job's start states [lanes, 8], computed as rk4_numba.py does."""
    x = np.zeros((lanes, 8))
    if lanes > 1:
        # Same operations in the same order as rk4_numba.py, so the states are bitwise its.
        x[:, 0] = -0.004 + 0.008 * np.arange(lanes, dtype=np.float64) / (lanes - 1)
    x[:, 2] = -A_G / (W_R * W_R)
    x[:, 6] = -A_G / (W_S * W_S)
    return x


def forcing_table(n):
    """h and the per-period forcing table (cos, sin of OMEGA j h/2, j = 0..2n), float64."""
    h = 2.0 * math.pi / OMEGA / n
    w = OMEGA * (0.5 * h)
    # math.cos/sin is the libm that numba calls; np.cos may dispatch to its own SIMD code
    # on some CPUs and differ in the last bit.
    tc = np.fromiter((math.cos(w * j) for j in range(2 * n + 1)), np.float64, 2 * n + 1)
    ts = np.fromiter((math.sin(w * j) for j in range(2 * n + 1)), np.float64, 2 * n + 1)
    return h, tc, ts


def kernel_source(precision):
    real = {"f64": "double", "f32": "float"}[precision]
    with open(SOURCE) as f:
        return f"#define REAL {real}\n" + f.read()


def parse_args(argv):
    p = argparse.ArgumentParser(description="cupy RawKernel RK4 peer (see module docstring)")
    p.add_argument("mode", choices=("plain", "substep"))
    p.add_argument("n", metavar="N", type=int, help="RK4 steps per forcing period")
    p.add_argument("periods", metavar="PERIODS", type=int)
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--states", metavar="IN.npy", help="float64 [lanes, 8] start states")
    src.add_argument("--standard", metavar="LANES", type=int,
                     help="the standard job's start states on LANES lanes")
    p.add_argument("--out", metavar="OUT.npy", help="float64 [lanes, 8] final states")
    p.add_argument("--precision", choices=("f64", "f32"), default="f64")
    p.add_argument("--block", type=int, default=128, help="threads per block")
    p.add_argument("--repeat", type=int, default=1, help="timed runs (median, min reported)")
    p.add_argument("--dry", action="store_true", help="build the inputs only, no cupy")
    p.add_argument("--dump", metavar="DIR", help="with --dry: write the inputs as raw f64")
    a = p.parse_args(argv)
    if a.n < 1 or a.periods < 0 or a.repeat < 1 or not 1 <= a.block <= 1024:
        p.error("need N >= 1, PERIODS >= 0, --repeat >= 1, 1 <= --block <= 1024")
    if a.standard is not None and a.standard < 1:
        p.error("--standard needs LANES >= 1")
    if a.dump and not a.dry:
        p.error("--dump goes with --dry")
    if not a.dry and not a.out:
        p.error("--out is required (except with --dry)")
    return a


def load_states(a):
    if a.standard is not None:
        return standard_states(a.standard)
    x = np.load(a.states)
    if x.ndim != 2 or x.shape[1] != 8 or x.shape[0] < 1:
        raise SystemExit(f"{a.states}: expected a [lanes, 8] array, got shape {x.shape}")
    return np.ascontiguousarray(x, dtype=np.float64)


def dry_run(a, states, h, tc, ts):
    """Everything but the GPU: the inputs the kernel would get, optionally written out."""
    src = kernel_source(a.precision)
    if a.dump:
        os.makedirs(a.dump, exist_ok=True)
        for name, v in (("states", states), ("cos", tc), ("sin", ts), ("h", np.array([h]))):
            np.ascontiguousarray(v, dtype="<f8").tofile(os.path.join(a.dump, name + ".f64"))
    return {"peer": f"cuda_rk4_{a.mode}", "dry": True, "precision": a.precision, "N": a.n,
            "periods": a.periods, "lanes": int(states.shape[0]), "block": a.block,
            "h": h, "table_entries": int(tc.size), "source_bytes": len(src.encode())}


def gpu_run(a, states, h, tc, ts):
    import cupy as cp

    real = np.float64 if a.precision == "f64" else np.float32
    lanes = states.shape[0]
    kern = cp.RawKernel(kernel_source(a.precision), KERNEL, options=("-std=c++17",))
    kern.compile()

    d_tc = cp.asarray(tc.astype(real))
    d_ts = cp.asarray(ts.astype(real))
    d_in = cp.asarray(states)
    d_out = cp.empty_like(d_in)
    d_redone = cp.zeros(lanes, dtype=cp.int32)

    def launch(nlanes, periods):
        grid = ((nlanes + a.block - 1) // a.block,)
        kern(grid, (a.block,), (d_in, d_out, d_redone, d_tc, d_ts, real(h), np.int32(a.n),
                                np.int32(periods), np.int32(nlanes),
                                np.int32(a.mode == "substep")))

    # Warm-up: module load and first-launch costs stay out of the timing.
    launch(min(lanes, a.block), 1)
    cp.cuda.runtime.deviceSynchronize()

    walls = []
    start, end = cp.cuda.Event(), cp.cuda.Event()
    for _ in range(a.repeat):
        # The kernel reads d_in and overwrites d_out and d_redone, so runs are identical.
        start.record()
        launch(lanes, a.periods)
        end.record()
        end.synchronize()
        cp.cuda.runtime.deviceSynchronize()
        walls.append(cp.cuda.get_elapsed_time(start, end) / 1e3)

    out = cp.asnumpy(d_out)
    redone = cp.asnumpy(d_redone)
    np.save(a.out, out)
    wall = float(np.median(walls))
    return {"peer": f"cuda_rk4_{a.mode}", "precision": a.precision, "N": a.n,
            "periods": a.periods, "lanes": lanes, "block": a.block, "repeat": a.repeat,
            "wall_s": wall, "wall_min_s": float(min(walls)),
            "lane_periods_per_s": lanes * a.periods / wall,
            "regular_steps_per_s": lanes * a.periods * a.n / wall,
            "redone_steps_per_lane": float(redone.astype(np.float64).mean()),
            # Local memory here is the stack of CUDA's cos/sin large-argument reduction
            # (5 words), not the lane's state, which stays in registers.
            "regs_per_thread": getattr(kern, "num_regs", None),
            "local_bytes_per_thread": getattr(kern, "local_size_bytes", None),
            "finite": bool(np.isfinite(out).all()),
            "device": cp.cuda.runtime.getDeviceProperties(0)["name"].decode()}


def main(argv):
    a = parse_args(argv[1:])
    states = load_states(a)
    h, tc, ts = forcing_table(a.n)
    result = (dry_run if a.dry else gpu_run)(a, states, h, tc, ts)
    print(json.dumps(result))
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv))
