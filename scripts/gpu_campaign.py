"""The GPU campaign (docs/gpu.md), run by scripts/gpu-campaign.sh (read it first).

Steps, in order of what a short lease must not miss; each has a share of one deadline
and a step that fails is recorded and the next one runs:

1. adapter: nvidia-smi and `jeffcott info --kernel-stats` (name, driver, f64, limits;
   each kernel variant's compile time and the driver's statistics: registers, spills).
2. parity: the standard job's lanes for a few periods on the CPU and the GPU, f64 and
   f32: bit-identical lanes, largest difference, and the regime that implies.
3. tests: the GPU test executables carried in .campaign/tests with a GPU required,
   quick parity-critical ones first, within their own share of the deadline (two
   campaigns that ran them last never reached them).
4. bench: `jeffcott bench` on the GPU at 16k, 128k and 1M lanes (f64, f32), and on this
   machine's CPU for scale.
4a. anatomy: where the GPU's time per lane-step goes, at 1M lanes in f64 and f32: the
   kernel, its free-flight twin and each part of it timed alone on the same lanes
   (`jeffcott bench --anatomy all`, jeffcott-gpu's anatomy.rs), then the kernel in its
   other form of lane constants (JEFFCOTT_GPU_CONSTS), and in the GPU form with the
   lean path's forcing phasor evaluated rather than looked up (JEFFCOTT_GPU_FORCING).
5. standard job (docs/performance.md: 1024 lanes at W = 133, x_r0 evenly over
   [-4, 4] mm, 200 periods from t = 0, error = worst lane's last Poincare position
   against a reference good to ~1e-9 m), replicated 128 times so it fills the GPU (the
   1024 lanes alone leave the H100 latency-bound: 5.2e3-7.1e3 lane-periods/s in f64, two
   campaigns), by jeffcott's GPU kernel and by the hand-written CUDA kernel of the numba
   loop's algorithm (benches/peer/rk4_cuda.py, through cupy): lane-periods per second
   and worst-lane error for each.
6. basin: 1000 x 1000 at W = 133 (250 + 32 periods) end to end in f32 and f64, the two
   label sets compared, and a 100 x 100 subgrid computed on the CPU compared with both.

With a previous build of jeffcott beside this one (--previous, or
.campaign/bin/jeffcott-previous.gz, which scripts/gpu-campaign-prepare.sh --previous REV
builds), the adapter, bench, standard and basin steps measure it too, on the same
lanes in the same call, so a change of the kernel is measured old against new on the
same GPU.

Results go to --out as at most 8 files: summary.md (also printed last), results.json,
info.txt, campaign.log (every command and its output) and tests.log.
"""
import argparse
import gzip
import json
import os
import shutil
import subprocess
import sys
import tempfile
import time
import traceback

import numpy as np

STEPS = ["adapter", "parity", "tests", "bench", "anatomy", "standard", "peer", "basin", "explore"]
# GPU tests bound by one lane's serial speed (a few lanes for hundreds of periods): on
# the H100 and H200 each ran past 90 s (2026-11-25, -27), on lavapipe seconds. On
# hardware the tests step runs them last, one at a time (the rest of their executable
# first, with --skip).
SLOW_ON_HARDWARE = {
    "gpu": ["f32_gpu_lanes_find_the_f64_cpu_period_and_points_within_1e_5_m"],
    "map": ["cells_computed_in_one_map_equal_the_same_cells_run_alone_on_the_gpu",
            "a_gpu_f64_map_equals_the_cpu_map_bit_for_bit_but_lambda1_within_1e_9",
            "per_lane_parameters_on_the_gpu_equal_the_cpu_lanes_bit_for_bit_in_f64"],
    "shards": ["a_basin_sharded_on_the_gpu_in_f64_merges_to_the_cpu_run"],
}
ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
POS = [0, 2, 4, 6]  # x_r, y_r, x_s, y_s in the state vector
OMEGA = 133.0


def parse_args():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", default=os.environ.get("OUT") or "target/campaign")
    ap.add_argument("--local", action="store_true", help="use this machine as it is (no loader set-up, target/release/jeffcott)")
    ap.add_argument("--small", action="store_true", help="small sizes, for CI and lavapipe")
    ap.add_argument("--jeffcott", help="the binary (default .campaign/bin/jeffcott, else target/release/jeffcott)")
    ap.add_argument("--previous", help="a previous build to measure beside it (default "
                    ".campaign/bin/jeffcott-previous.gz where present; 'none': none)")
    ap.add_argument("--deadline", type=float, help="seconds for all steps (default 530, small 600)")
    ap.add_argument("--reference-only", action="store_true", help="only build the standard job's reference into --ref-dir")
    ap.add_argument("--ref-dir", default=".campaign/ref")
    ap.add_argument("--lanes", type=int, help="the standard job's lanes (default 1024, small 64)")
    ap.add_argument("--periods", type=int, help="the standard job's periods (default 200, small 20)")
    ap.add_argument("--only", help="comma-separated steps to run, in this order (adapter always runs, first): "
                    + ",".join(STEPS))
    ap.add_argument("--std-rows", help="the standard job's jeffcott rows to run, comma-separated indices "
                    "(default all; full: 0 f64 N=500, 1 f64 N=700, 2 f32 N=500, 3 f64 N=350 exact)")
    ap.add_argument("--basin-timeout", type=float, help="seconds one GPU basin may take (default: the deadline's rest)")
    ap.add_argument("--basin-precisions", default="f32,f64", help="precisions of the GPU basin")
    ap.add_argument("--tests", help="comma-separated test executables to run (default: all carried)")
    ap.add_argument("--tests-budget", type=float, help="seconds the tests step may take (default 200, small: no limit)")
    ap.add_argument("--bench-lanes", help="the GPU bench's lane counts, comma-separated (default 16384,131072,1048576)")
    ap.add_argument("--bench-lane-periods", type=int, help="the GPU bench's lane-periods per row (default 8388608)")
    ap.add_argument("--bench-backends", default="gpu,cpu", help="backends the bench step runs (default gpu,cpu)")
    ap.add_argument("--twin-at", type=int, default=0, help="lanes of the bench's free-flight twin (0: none)")
    return ap.parse_args()


class Fatal(Exception):
    """A failure after which no later step can succeed."""


class Sizes:
    """Every size of the campaign; --small shrinks them for CI on lavapipe."""

    def __init__(self, small, lanes, periods):
        self.small = small
        self.parity_lanes, self.parity_periods, self.parity_n = (64, 4, 500) if small else (1024, 20, 500)
        self.bench_gpu = ([256, 1024], 2048) if small else ([16384, 131072, 1048576], 8388608)
        self.bench_cpu = ([1024], 2048) if small else ([131072], 1048576)
        # One size for the anatomy: 4 periods a lane at 1M lanes.
        self.anatomy = (1024, 4096) if small else (1048576, 4194304)
        self.std_lanes = lanes or (64 if small else 1024)
        self.std_periods = periods or (20 if small else 200)
        self.replicas = 4 if small else 128
        # (lanes multiple, precision, N): N = 700 f64 and the peer's N = 6144 meet the
        # same worst-lane error (1.57e-8 and 1.48e-8 m on the H100).
        # The exact free-flight step (--exact-free-flight) at half the N and twice the
        # R: on the 2-core CPU N = 350, R = 4 met N = 700, R = 2's worst lane 1.30-1.44x
        # faster.
        exact = ["--contact-substeps", "4", "--exact-free-flight"]
        self.jeffcott_rows = [(1, "f64", 500, []), (self.replicas, "f64", 500, []), (self.replicas, "f32", 500, []),
                              (1, "f64", 250, exact)] if small \
            else [(self.replicas, "f64", 500, []), (self.replicas, "f64", 700, []), (self.replicas, "f32", 500, []),
                  (self.replicas, "f64", 350, exact)]
        self.peer_rows = [(1, "f64", 1024), (self.replicas, "f32", 1024)] if small \
            else [(self.replicas, "f64", 3072), (self.replicas, "f64", 6144), (self.replicas, "f32", 6144)]
        self.basin_n, self.basin_t, self.basin_p, self.basin_stride = (40, 30, 8, 4) if small else (1000, 250, 32, 10)


class Campaign:
    def __init__(self, args):
        self.args = args
        self.t0 = time.monotonic()
        self.sizes = Sizes(args.small, args.lanes, args.periods)
        if args.bench_lanes or args.bench_lane_periods:
            lanes, lp = self.sizes.bench_gpu
            self.sizes.bench_gpu = ([int(v) for v in args.bench_lanes.split(",")] if args.bench_lanes else lanes,
                                    args.bench_lane_periods or lp)
        self.deadline = args.deadline or (600.0 if args.small else 530.0)
        os.makedirs(args.out, exist_ok=True)
        self.out = args.out
        self.work = tempfile.mkdtemp(prefix="jeffcott-campaign-")
        self.log = open(os.path.join(self.out, "campaign.log"), "w")
        self.results = {"mode": "small" if args.small else "full", "steps": {},
                        # The kernel's path to the driver (jeffcott-gpu's ShaderPath): exact
                        # SPIR-V where the adapter takes it, unless JEFFCOTT_GPU_SHADER says wgsl.
                        "JEFFCOTT_GPU_SHADER": os.environ.get("JEFFCOTT_GPU_SHADER", "")}
        self.jeffcott = os.path.abspath(self.pick_binary())
        self.previous = self.pick_previous()
        if self.previous:
            _, version, _ = self.sh([self.previous, "--version"], check=False)
            self.results["previous"] = {"binary": self.previous, "version": version.strip()}

    def pick_binary(self):
        if self.args.jeffcott:
            return self.args.jeffcott
        carried = os.path.join(ROOT, ".campaign/bin/jeffcott")
        if not self.args.local and os.path.exists(carried):
            return carried
        return os.path.join(ROOT, "target/release/jeffcott")

    def pick_previous(self):
        if self.args.previous == "none":
            return None
        if self.args.previous:
            return os.path.abspath(self.args.previous)
        carried = os.path.join(ROOT, ".campaign/bin/jeffcott-previous.gz")
        if not os.path.exists(carried):
            return None
        path = os.path.join(self.work, "jeffcott-previous")
        with gzip.open(carried) as src, open(path, "wb") as dst:
            shutil.copyfileobj(src, dst)
        os.chmod(path, 0o755)
        return path

    def builds(self):
        """(label, binary) of this build, then of the previous one where there is one."""
        return [("current", self.jeffcott)] + ([("previous", self.previous)] if self.previous else [])

    def left(self):
        return self.deadline - (time.monotonic() - self.t0)

    def say(self, msg):
        line = f"[{time.monotonic() - self.t0:7.1f} s] {msg}"
        print(line, flush=True)
        self.log.write(line + "\n")
        self.log.flush()

    def sh(self, cmd, timeout=None, env=None, check=True):
        """Runs cmd (a list), logs it and its output; returns (rc, output, seconds)."""
        limit = max(5.0, min(timeout or 1e9, self.left() - 5.0))
        self.say("$ " + " ".join(str(c) for c in cmd))
        t = time.monotonic()
        try:
            p = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, timeout=limit,
                               env={**os.environ, **(env or {})})
            rc, out = p.returncode, p.stdout + p.stderr
        except subprocess.TimeoutExpired as e:
            rc = 124
            out = (e.stdout or b"").decode(errors="replace") if isinstance(e.stdout, bytes) else (e.stdout or "")
            out += f"\n(killed after {limit:.0f} s)"
        dt = time.monotonic() - t
        self.log.write(out + f"\n(rc {rc}, {dt:.2f} s)\n")
        self.log.flush()
        if check and rc != 0:
            raise RuntimeError(f"{cmd[0]} {cmd[1] if len(cmd) > 1 else ''} failed (rc {rc}): {out.strip()[-600:]}")
        return rc, out, dt

    def step(self, name, fn, need):
        """Runs one step if at least `need` seconds are left; records its result or error."""
        if self.left() < need:
            self.results["steps"][name] = {"skipped": f"deadline ({self.left():.0f} s left, {need} s needed)"}
            self.say(f"== {name}: skipped, deadline")
            return
        self.say(f"== {name}")
        t = time.monotonic()
        try:
            r = fn()
            r = r if isinstance(r, dict) else {}
        except Exception as e:  # a failed step is a result; the campaign goes on
            self.log.write(traceback.format_exc())
            r = {"error": str(e)[-1500:]}
            self.say(f"   {name} failed: {str(e)[-300:]}")
            if isinstance(e, Fatal):
                self.deadline = 0.0
        r["step_s"] = round(time.monotonic() - t, 2)
        self.results["steps"][name] = r
        self.save()

    def save(self):
        with open(os.path.join(self.out, "results.json"), "w") as f:
            json.dump(self.results, f, indent=1, default=float)

    # ---- jeffcott runs -------------------------------------------------------------

    def ensemble(self, tag, xr, periods, transient, n, backend, precision, timeout=None, extra=(), binary=None):
        """`jeffcott ensemble` on lanes x_r0 = xr at W = 133 (the rest at the static
        equilibrium): (poincare [lanes, periods, 8], run.json, lanes.npy)."""
        d = os.path.join(self.work, tag)
        shutil.rmtree(d, ignore_errors=True)
        table = os.path.join(self.work, f"lanes-{len(xr)}.csv")
        if not os.path.exists(table):
            with open(table, "w") as f:
                f.write("x_r\n" + "".join(f"{v!r}\n" for v in xr.tolist()))
        self.sh([binary or self.jeffcott, "ensemble", "--lanes", table, "--omega", OMEGA, "--transient", transient,
                 "--periods", periods, "--steps-per-period", n, "--backend", backend, "--precision", precision,
                 "--out", d, "--quiet", *extra], timeout=timeout)
        with open(os.path.join(d, "run.json")) as f:
            run = json.load(f)
        pts = np.load(os.path.join(d, "poincare.npy"))
        lanes = np.load(os.path.join(d, "lanes.npy"))
        shutil.rmtree(d, ignore_errors=True)
        return pts, run, lanes

    # ---- 1. adapter ----------------------------------------------------------------

    def adapter(self):
        text = []
        if shutil.which("nvidia-smi"):
            _, out, _ = self.sh(["nvidia-smi"], check=False)
            text.append(out)
            _, q, _ = self.sh(["nvidia-smi", "--query-gpu=name,driver_version,memory.total,clocks.sm,clocks.max.sm,"
                               "power.limit,temperature.gpu", "--format=csv"], check=False)
            text.append(q)
        # The driver's statistics of each kernel variant (registers, spills: why the kernel
        # is slow on the H100, docs/gpu.md); plain `info` if that fails.
        rc, info, _ = self.sh([self.jeffcott, "info", "--kernel-stats"], timeout=90, check=False)
        if rc != 0:
            text.append(info)
            _, info, _ = self.sh([self.jeffcott, "info"])
        text.append(info)
        # The statistics of the other form of reading the lane constants and holding the
        # committed lane too (JEFFCOTT_GPU_CONSTS; shader.rs's Variant::consts_each_step),
        # so the registers it saves on this compiler are measured, not assumed.
        once = ""
        if rc == 0:
            _, once, _ = self.sh([self.jeffcott, "info", "--kernel-stats"], timeout=90, check=False,
                                 env={"JEFFCOTT_GPU_CONSTS": "once"})
            text.append("JEFFCOTT_GPU_CONSTS=once:\n" + once)
        # The previous build's kernels on the same driver: old against new.
        previous = ""
        if self.previous:
            _, previous, _ = self.sh([self.previous, "info", "--kernel-stats"], timeout=90, check=False)
            text.append("previous build:\n" + previous)
        with open(os.path.join(self.out, "info.txt"), "w") as f:
            f.write("\n".join(text))
        gpus = [line for line in info.splitlines() if line.startswith("GPU:")]
        hardware = [g for g in gpus if "f64 yes" in g and "software" not in g and "Vulkan" in g]
        if not self.args.local and not hardware:
            # Nothing else can run: say why (the loader's own errors) and stop early, so a
            # lease is not spent on steps that cannot find the adapter.
            _, dbg, _ = self.sh([self.jeffcott, "info"], env={"VK_LOADER_DEBUG": "error,warn"}, check=False)
            with open(os.path.join(self.out, "info.txt"), "a") as f:
                f.write("\n\nVK_LOADER_DEBUG=error,warn:\n" + dbg)
            raise Fatal("no hardware Vulkan adapter with f64: " + dbg.strip()[-800:])
        kernels = [line.strip() for line in info.splitlines() if line.startswith(("kernel", "  ["))]
        kernels_once = [line.strip() for line in once.splitlines() if line.startswith(("kernel", "  ["))]
        kernels_prev = [line.strip() for line in previous.splitlines() if line.startswith(("kernel", "  ["))]
        return {"jeffcott_info": info.strip().splitlines(), "gpus": gpus, "kernel_stats": kernels,
                "kernel_stats_constants_once": kernels_once, "kernel_stats_previous": kernels_prev}

    # ---- 2. parity -----------------------------------------------------------------

    def parity(self):
        s = self.sizes
        xr = standard_xr(s.parity_lanes)
        out = {}
        for prec in ("f64", "f32"):
            cpu, _, _ = self.ensemble(f"par-cpu-{prec}", xr, s.parity_periods, 0, s.parity_n, "cpu", prec)
            gpu, run, _ = self.ensemble(f"par-gpu-{prec}", xr, s.parity_periods, 0, s.parity_n, "gpu", prec)
            same_lane = np.all(cpu == gpu, axis=(1, 2))
            diff = np.abs(cpu - gpu)[:, :, POS].max(axis=(0, 2))  # per recorded period
            first = next((int(p) + 1 for p in range(len(diff)) if diff[p] > 0), None)
            out[prec] = {
                "device": run.get("device"),
                "lanes": int(len(xr)),
                "periods": s.parity_periods,
                "bit_identical_lanes": int(same_lane.sum()),
                "bit_identical_values_share": float(np.mean(cpu == gpu)),
                "max_position_diff_m_per_period": [float(v) for v in diff],
                "first_period_with_a_difference": first,
                "regime": "bit-identical" if same_lane.all() else "tolerance",
            }
            self.say(f"   {prec}: {out[prec]['bit_identical_lanes']}/{len(xr)} lanes bit-identical, "
                     f"largest position difference {diff.max():.3e} m")
        return out

    # ---- 3. bench ------------------------------------------------------------------

    def bench(self):
        rows, util = [], None
        backends = self.args.bench_backends.split(",")
        runs = [("gpu", build, binary, self.sizes.bench_gpu) for build, binary in self.builds()]
        runs.append(("cpu", "current", self.jeffcott, self.sizes.bench_cpu))
        for backend, build, binary, (lanes, lp) in runs:
            if backend not in backends:
                continue
            path = os.path.join(self.work, f"bench-{backend}-{build}.json")
            sampler = None
            if backend == "gpu" and build == "current" and shutil.which("nvidia-smi"):
                # Is the GPU busy while the bench runs (a slow kernel), or waiting on the host?
                sampler = subprocess.Popen(["nvidia-smi", "--query-gpu=utilization.gpu,clocks.sm,power.draw,memory.used",
                                            "--format=csv,noheader,nounits", "-lms", "250"],
                                           stdout=subprocess.PIPE, text=True)
            twin = self.args.twin_at if backend == "gpu" else 0
            rc, out, _ = self.sh([binary, "bench", "--backend", backend, "--lanes", ",".join(map(str, lanes)),
                                  "--lane-periods", lp, "--precision", "f64,f32", "--twin-at", twin, "--out", path],
                                 check=(backend == "gpu" and build == "current"), timeout=240)
            if sampler:
                sampler.terminate()
                samples = [line.split(",") for line in sampler.communicate()[0].splitlines() if line.count(",") == 3]
                vals = np.array([[float(v) for v in x] for x in samples]) if samples else np.zeros((0, 4))
                util = {"samples": len(vals), "gpu_util_pct_median": float(np.median(vals[:, 0])) if len(vals) else None,
                        "sm_clock_mhz_median": float(np.median(vals[:, 1])) if len(vals) else None,
                        "power_w_median": float(np.median(vals[:, 2])) if len(vals) else None}
                self.say(f"   GPU while benched: {util}")
            if rc == 0:
                with open(path) as f:
                    for r in json.load(f):
                        r["build"] = build
                        rows.append(r)
        return {"rows": rows, "gpu_utilisation": util}

    # ---- 4a. the kernel's anatomy -------------------------------------------------

    def anatomy(self):
        """The kernel and its parts timed alone on the same lanes (f64, f32), then the
        kernel in the other form of its lane constants: which part of a lane-step costs
        what on this GPU, beside the CUDA peer's whole step (docs/gpu.md)."""
        lanes, lp = self.sizes.anatomy
        base = [self.jeffcott, "bench", "--backend", "gpu", "--lanes", lanes, "--lane-periods", lp,
                "--precision", "f64,f32"]

        def bench(tag, extra_args, env):
            path = os.path.join(self.work, f"anatomy-{tag}.json")
            self.sh(base + extra_args + ["--out", path], timeout=150, env=env, check=env is None)
            if not os.path.exists(path):
                return []
            with open(path) as f:
                return json.load(f)

        rows = bench("default", ["--twin-at", lanes, "--anatomy", "all"], None)
        for r in rows:
            r["form"] = "default"
        # The kernel in the form of lane constants this adapter does not take by default
        # (`jeffcott info` says which it takes: "read at every sub-step" or "read once").
        device = rows[0]["device"] if rows else ""
        line = next((g for g in self.results["steps"].get("adapter", {}).get("gpus", [])
                     if g.startswith(f"GPU: {device} [")), "")
        other = "once" if "read at every sub-step" in line else "each-step"
        for r in bench("other", ["--twin-at", 0], {"JEFFCOTT_GPU_CONSTS": other}):
            r["form"] = f"JEFFCOTT_GPU_CONSTS={other}"
            rows.append(r)
        # The GPU form's lean path with the forcing phasor evaluated instead of looked up
        # (shader.rs's Variant::forcing_table): which of the two this GPU runs faster.
        gpu_form = {} if other == "once" else {"JEFFCOTT_GPU_CONSTS": "each-step"}
        for r in bench("polynomial", ["--twin-at", 0], {**gpu_form, "JEFFCOTT_GPU_FORCING": "polynomial"}):
            r["form"] = "JEFFCOTT_GPU_FORCING=polynomial"
            rows.append(r)
        return {"rows": rows}

    # ---- 4. the standard job -------------------------------------------------------

    def reference(self):
        """The standard job's reference (final states, CPU f64 lane stepper at N = 8000)
        and its start states, from --ref-dir or computed now."""
        s = self.sizes
        base = os.path.join(self.args.ref_dir, f"std_L{s.std_lanes}_P{s.std_periods}")
        if not os.path.exists(base + ".npy"):
            os.makedirs(self.args.ref_dir, exist_ok=True)
            xr = standard_xr(s.std_lanes)
            fine, run, lanes = self.ensemble("ref8000", xr, 1, s.std_periods - 1, 8000, "cpu", "f64")
            half, _, _ = self.ensemble("ref4000", xr, 1, s.std_periods - 1, 4000, "cpu", "f64")
            np.save(base + ".npy", fine[:, -1, :])
            np.save(base + "_x0.npy", lanes[:, 2:])
            conv = float(np.abs(fine - half)[:, -1, POS].max())
            with open(base + ".json", "w") as f:
                json.dump({"N": 8000, "worst_lane_diff_N4000_m": conv, "wall_s": run["wall_time_s"]}, f)
            self.say(f"   reference: N = 8000, worst lane against N = 4000 {conv:.2e} m")
        with open(base + ".json") as f:
            meta = json.load(f)
        return np.load(base + ".npy"), np.load(base + "_x0.npy"), meta

    def standard(self):
        s = self.sizes
        meta, _, errors = self.standard_errors()
        L, P = s.std_lanes, s.std_periods
        rows = []

        def add(row, final):
            row["worst_lane_m"], row["p99_lane_m"] = errors(final)
            rows.append(row)
            self.say(f"   {row['integrator']} {row['precision']} N={row['N']} lanes={row['lanes']}: "
                     f"{row['lane_periods_per_s']:.3e} lane-periods/s, worst lane {row['worst_lane_m']:.2e} m")

        xr = standard_xr(L)
        keep = {int(i) for i in self.args.std_rows.split(",")} if self.args.std_rows else None
        for i, (lanes_mult, prec, n, extra) in enumerate(s.jeffcott_rows):
            if keep is not None and i not in keep:
                continue
            xs = np.tile(xr, lanes_mult)
            for build, binary in self.builds():
                pts, run, _ = self.ensemble(f"std-{prec}-{n}-{build}", xs, 1, P - 1, n, "gpu", prec, timeout=120,
                                            extra=extra, binary=binary)
                compute = run["wall_time_s"] - run.get("setup_time_s", 0.0)
                name = "jeffcott-gpu exact-ff R=4" if extra else "jeffcott-gpu"
                name += " (previous build)" if build == "previous" else ""
                add({"integrator": name, "device": run["device"], "precision": prec, "N": n,
                     "lanes": len(xs), "wall_s": run["wall_time_s"], "setup_s": run.get("setup_time_s"),
                     "lane_periods_per_s": len(xs) * P / compute}, pts[:, -1, :])
        # this machine's CPU on the 1024 lanes, at the N that meets 1e-7 m on the 2-core VM
        pts, run, _ = self.ensemble("std-cpu", xr, 1, P - 1, 700 if not s.small else 500, "cpu", "f64", timeout=120)
        add({"integrator": "jeffcott-cpu", "device": run["device"], "precision": "f64", "N": run["steps_per_period"],
             "lanes": L, "wall_s": run["wall_time_s"], "lane_periods_per_s": L * P / run["wall_time_s"]}, pts[:, -1, :])
        return {"reference": meta, "rows": rows}

    def standard_errors(self):
        """The reference's metadata, start states and the error function of the
        standard job (worst and 99th-percentile lane, lanes replicated allowed)."""
        ref, x0, meta = self.reference()
        L = len(ref)

        def errors(final):
            e = np.abs(final[:, POS] - np.tile(ref, (len(final) // L, 1))[:, POS]).max(axis=1)
            return float(e.max()), float(np.quantile(e, 0.99))
        return meta, x0, errors

    def peer(self):
        meta, x0, errors = self.standard_errors()
        return {"reference": meta, "rows": self.cuda_peer(x0, self.sizes.std_periods, errors)}

    def cuda_peer(self, x0, periods, errors):
        """The hand-written CUDA kernel (benches/peer/rk4_cuda.py) on the same lanes."""
        try:
            import cupy  # noqa: F401
        except Exception as e:  # no CUDA here (lavapipe, CI)
            self.say(f"   CUDA peer skipped: cupy unavailable ({type(e).__name__})")
            return [{"integrator": "cuda-peer", "skipped": "cupy unavailable"}]
        rows = []
        for lanes_mult, prec, n in self.sizes.peer_rows:
            states = os.path.join(self.work, f"x0-{lanes_mult}.npy")
            np.save(states, np.tile(x0, (lanes_mult, 1)))
            final = os.path.join(self.work, "peer-final.npy")
            _, out, _ = self.sh([sys.executable, os.path.join(ROOT, "benches/peer/rk4_cuda.py"), "substep", n,
                                 periods, "--states", states, "--out", final, "--precision", prec,
                                 "--repeat", 3 if lanes_mult == 1 else 1], timeout=150)
            r = json.loads([line for line in out.splitlines() if line.startswith("{")][-1])
            r["worst_lane_m"], r["p99_lane_m"] = errors(np.load(final))
            r["integrator"] = "cuda-peer"
            r["N"] = n
            rows.append(r)
            self.say(f"   cuda-peer {prec} N={n} lanes={r['lanes']}: {r['lane_periods_per_s']:.3e} "
                     f"lane-periods/s, worst lane {r['worst_lane_m']:.2e} m")
        return rows

    # ---- 5. the basin --------------------------------------------------------------

    def basin_run(self, tag, n, hi_x, hi_y, backend, prec, binary=None):
        s = self.sizes
        d = os.path.join(self.work, tag)
        shutil.rmtree(d, ignore_errors=True)
        cmd = [binary or self.jeffcott, "basin", "--omega", OMEGA, "--x", f"x_r:-0.006:{hi_x!r}:{n}", "--y", f"vx_r:-1:{hi_y!r}:{n}",
               "--transient", s.basin_t, "--periods", s.basin_p, "--backend", backend, "--precision", prec,
               "--out", d, "--quiet"]
        limit = self.left() - 30
        if backend == "gpu" and self.args.basin_timeout:
            limit = min(limit, self.args.basin_timeout)
        rc, out, wall = self.sh(cmd, timeout=limit, check=False)
        if rc != 0:
            # A basin cut by the deadline still says how far it got: its committed units
            # (the 1000 x 1000 grid at 250 + 32 periods is 283 units of 3546 lanes, run::unit_lanes).
            units = os.path.join(d, "units")
            done = len([u for u in os.listdir(units) if u.endswith(".unit")]) if os.path.isdir(units) else 0
            raise RuntimeError(f"basin {tag} (rc {rc}) after {wall:.0f} s with {done} units committed: "
                               f"{out.strip()[-400:]}")
        labels = np.load(os.path.join(d, "labels.npy"))
        with open(os.path.join(d, "attractors.json")) as f:
            attractors = json.load(f)
        shutil.rmtree(d, ignore_errors=True)
        return labels, attractors, wall

    def basin(self):
        s = self.sizes
        n, k = s.basin_n, s.basin_stride
        out, labels = {}, {}
        for prec in self.args.basin_precisions.split(","):
            lab, att, wall = self.basin_run(f"basin-{prec}", n, 0.006, 1.0, "gpu", prec)
            labels[prec] = lab
            out[prec] = {"cells": int(lab.size), "end_to_end_s": wall, "attractors": summarize_attractors(att),
                         "label_counts": np.unique(lab, return_counts=True)[1].tolist()}
            self.say(f"   {n} x {n} {prec}: {wall:.1f} s end to end")
            if self.previous and self.left() > 60:
                # The previous build on the same grid: its time, and whether its labels agree.
                try:
                    plab, _, pwall = self.basin_run(f"basin-prev-{prec}", n, 0.006, 1.0, "gpu", prec,
                                                    binary=self.previous)
                    out[f"previous_{prec}"] = {"end_to_end_s": pwall, "labels_equal": bool(np.array_equal(plab, lab))}
                except Exception as e:  # cut by the deadline or the timeout: say so, keep the rest
                    out[f"previous_{prec}"] = {"error": str(e)[-300:]}
                self.say(f"   previous build {prec}: {out[f'previous_{prec}']}")
        if "f32" in labels and "f64" in labels:
            out["f32_vs_f64_agreement"] = agreement(labels["f32"], labels["f64"])
        # The CPU on every k-th cell in each direction (the same start states up to
        # rounding of the axis values).
        m = n // k
        hi_x = -0.006 + (m - 1) * k * 0.012 / (n - 1)
        hi_y = -1.0 + (m - 1) * k * 2.0 / (n - 1)
        if self.left() > 60:
            lab, att, wall = self.basin_run("basin-cpu", m, hi_x, hi_y, "cpu", "f64")
            out["cpu_subgrid"] = {"cells": int(lab.size), "end_to_end_s": wall, "attractors": summarize_attractors(att)}
            for prec in labels:
                out[f"cpu_subgrid_vs_gpu_{prec}"] = agreement(lab, labels[prec][::k, ::k][:m, :m])
        return out

    # ---- the explorer on this GPU ------------------------------------------------

    def explore(self):
        """`jeffcott explore --backend gpu` over HTTP, as its page asks: the first slice of
        the default bifurcation view (every 32nd of 400 columns, 4 starts), the whole view
        in one request, and the 128 x 128 basin at 133 rad/s (the page's last level)."""
        import re
        import urllib.request
        n, k, cells = (48, 2, 16) if self.sizes.small else (400, 4, 128)
        p = subprocess.Popen([self.jeffcott, "explore", "--no-browser", "--port", "0", "--backend", "gpu"],
                             stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
        try:
            url = re.search(r"(http://\S+)", p.stdout.readline()).group(1).rstrip("/")

            def get(q):
                t = time.monotonic()
                urllib.request.urlopen(url + q, timeout=max(10, self.left() - 20)).read()
                return time.monotonic() - t

            info = json.loads(urllib.request.urlopen(url + "/api/info").read())
            out = {"device": info["device"], "precision": info["precision"]}
            step = 32 if n > 64 else 8
            out["bifurcation_first_slice_s"] = get(f"/api/bifurcation?tab=c&n={n}&from=0&step={step}&count={(n - 1) // step + 1}&k={k}")
            out["bifurcation_whole_view_s"] = get(f"/api/bifurcation?tab=c&n={n}&k={k}")
            out[f"basin_{cells}x{cells}_s"] = get(f"/api/basin?tab=c&n={cells}")
        finally:
            p.terminate()
            p.wait(timeout=10)
        self.say(f"   explore: {out}")
        return out

    # ---- 6. the GPU tests ----------------------------------------------------------

    def tests(self):
        src = os.path.join(ROOT, ".campaign/tests")
        if not os.path.isdir(src):
            return {"skipped": "no .campaign/tests (made by scripts/gpu-campaign-prepare.sh; CI runs the suite itself)"}
        self.place_binary_for_tests()
        log = open(os.path.join(self.out, "tests.log"), "w")
        out = {}
        wanted = self.args.tests.split(",") if self.args.tests else None
        # Quick, parity-critical executables first: on the H100 (2026-11-25) three GPU
        # tests of `map` ran past 90 s and the executables after it were never reached.
        first = ["mirror", "gpu", "input_checks", "lyapunov", "orbits", "basin_gpu", "early_exit", "jeffcott_gpu"]
        budget = self.args.tests_budget or (1e9 if self.sizes.small else 200.0)
        t0 = time.monotonic()
        rank = {name: i for i, name in enumerate(first)}
        # On hardware the tests bound by one lane's serial speed run last, one at a time,
        # after every other test has had its turn (SLOW_ON_HARDWARE).
        slow = {} if self.sizes.small else SLOW_ON_HARDWARE
        exes = {}

        def run(exe, args, label):
            spent = time.monotonic() - t0
            if self.left() < 20:
                out[label] = "skipped: deadline"
                return
            if budget - spent < 20:
                out[label] = f"skipped: the step's budget ({spent:.0f} of {budget:.0f} s spent)"
                return
            # One executable may not take the whole budget: 90 s each (the slowest took
            # 14 s on the H100 apart from the slow tests).
            rc, text, dt = self.sh([exe, *args], env={"JEFFCOTT_REQUIRE_GPU": "1"},
                                   timeout=min(90, budget - spent), check=False)
            log.write(f"===== {label} (rc {rc}, {dt:.1f} s)\n{text}\n")
            log.flush()
            result = [line for line in text.splitlines() if line.startswith("test result:")]
            failed = [line.split()[1] for line in text.splitlines() if line.startswith("test ") and line.endswith("FAILED")]
            out[label] = {"rc": rc, "s": round(dt, 1), "result": result[-1] if result else None, "failed": failed}
            self.say(f"   {label}: {out[label]['result'] or 'rc %d' % rc}")

        for gz in sorted(os.listdir(src), key=lambda f: (rank.get(f.removesuffix(".gz"), len(first)), f)):
            name = gz.removesuffix(".gz")
            if wanted and name not in wanted:
                continue
            exe = os.path.join(self.work, "t-" + name)
            with gzip.open(os.path.join(src, gz)) as f, open(exe, "wb") as g:
                shutil.copyfileobj(f, g)
            os.chmod(exe, 0o755)
            exes[name] = exe
            skips = [a for t in slow.get(name, []) for a in ("--skip", t)]
            run(exe, skips, name)
        for name, tests in slow.items():
            for t in tests:
                if name in exes:
                    run(exes[name], [t, "--exact"], f"{name}::{t}")
        return out

    def place_binary_for_tests(self):
        """The test executables run `jeffcott` from the path baked in at compile time
        (CARGO_BIN_EXE_jeffcott) and read files under the crate's directory: make both
        exist here."""
        with open(os.path.join(ROOT, ".campaign/bin/exe-path")) as f:
            exe = f.read().strip()
        manifest = os.path.dirname(os.path.dirname(os.path.dirname(exe)))
        if not os.path.exists(manifest):
            os.makedirs(os.path.dirname(manifest), exist_ok=True)
            os.symlink(ROOT, manifest)
        if not os.path.exists(exe):
            os.makedirs(os.path.dirname(exe), exist_ok=True)
            shutil.copy(self.jeffcott, exe)

    # ---- summary -------------------------------------------------------------------

    def summary(self):
        st = self.results["steps"]
        md = [f"# GPU campaign ({self.results['mode']}), {time.strftime('%Y-%m-%d %H:%M UTC', time.gmtime())}", ""]
        a = st.get("adapter", {})
        md += ["## Adapter", ""] + [f"- {g}" for g in a.get("gpus", [])] + [""]
        if a.get("kernel_stats"):
            md += ["## The kernel as the driver compiled it (`jeffcott info --kernel-stats`)", ""]
            md += [f"    {line}" for line in a["kernel_stats"]] + [""]
        if a.get("kernel_stats_constants_once"):
            md += ["In the software form (`JEFFCOTT_GPU_CONSTS=once`):", ""]
            md += [f"    {line}" for line in a["kernel_stats_constants_once"]] + [""]
        if a.get("kernel_stats_previous"):
            md += [f"The previous build ({self.results.get('previous', {}).get('version')}):", ""]
            md += [f"    {line}" for line in a["kernel_stats_previous"]] + [""]
        p = st.get("parity", {})
        md += ["## Parity (CPU against GPU, the standard job's lanes)", "",
               "| precision | lanes bit-identical | largest position difference [m] | first period differing | regime |",
               "|---|---|---|---|---|"]
        for prec in ("f64", "f32"):
            r = p.get(prec)
            if r:
                md.append(f"| {prec} | {r['bit_identical_lanes']}/{r['lanes']} | "
                          f"{max(r['max_position_diff_m_per_period']):.3e} | {r['first_period_with_a_difference']} | {r['regime']} |")
        md += ["", f"## Bench (W = 133, 500 steps/period; GPU while benched: {st.get('bench', {}).get('gpu_utilisation')})", "",
               "| backend | build | device | precision | lanes | lane-steps/s | lane-periods/s | time due to contact |",
               "|---|---|---|---|---|---|---|---|"]
        for r in st.get("bench", {}).get("rows", []):
            md.append(f"| {r['backend']} | {r.get('build', 'current')} | {r['device']} | {r['precision']} | "
                      f"{r['lanes']} | {r['lane_steps_per_s']:.3e} | {r['lane_periods_per_s']:.3e} | "
                      f"{r.get('contact_time_share')} |")
        an = st.get("anatomy", {}).get("rows", [])
        if an:
            md += ["", "## Anatomy (the kernel's parts timed alone on the same lanes; `jeffcott bench --anatomy all`; "
                   "anatomy rows per second of dispatches, the lane kernel's rows per wall second)", "",
                   "| precision | kernel | constants | lane-steps/s | of the kernel's time per step | time due to contact |",
                   "|---|---|---|---|---|---|"]
            for prec in ("f64", "f32"):
                # The kernel timed as the parts are (dispatches only): "anatomy: kernel".
                whole = next((r for r in an if r["precision"] == prec and r["kernel"] == "anatomy: kernel"
                              and r["form"] == "default"), None)
                for r in an:
                    if r["precision"] != prec:
                        continue
                    share = f"{whole['lane_steps_per_s'] / r['lane_steps_per_s']:.3f}" if whole else "-"
                    contact = r.get("contact_time_share")
                    contact = "-" if contact is None else f"{100 * contact:.0f} %"
                    md.append(f"| {prec} | {r['kernel']} | {r['form']} | {r['lane_steps_per_s']:.3e} | {share} | "
                              f"{contact} |")
        sj = st.get("standard", {})
        md += ["", f"## Standard job (reference: {sj.get('reference')})", "",
               "| integrator | precision | N | lanes | lane-periods/s | worst lane [m] | p99 lane [m] |",
               "|---|---|---|---|---|---|---|"]
        for r in sj.get("rows", []) + st.get("peer", {}).get("rows", []):
            if "skipped" in r:
                md.append(f"| {r['integrator']} | skipped: {r['skipped']} | | | | | |")
            else:
                md.append(f"| {r['integrator']} | {r['precision']} | {r['N']} | {r['lanes']} | "
                          f"{r['lane_periods_per_s']:.3e} | {r['worst_lane_m']:.2e} | {r['p99_lane_m']:.2e} |")
        b = st.get("basin", {})
        md += ["", "## Basin at W = 133", ""]
        for prec in ("f32", "f64"):
            if prec in b:
                md.append(f"- {prec}: {b[prec]['cells']} cells in {b[prec]['end_to_end_s']:.1f} s end to end; "
                          f"attractors {b[prec]['attractors']}")
        for key in ("previous_f32", "previous_f64", "f32_vs_f64_agreement", "cpu_subgrid_vs_gpu_f32",
                    "cpu_subgrid_vs_gpu_f64"):
            if key in b:
                md.append(f"- {key}: {b[key]}")
        md += ["", "## GPU tests (JEFFCOTT_REQUIRE_GPU=1)", ""]
        tests = st.get("tests", {})
        if "skipped" in tests or "error" in tests:
            md.append(f"- {tests.get('skipped') or tests.get('error')}")
        for name, r in tests.items():
            if name in ("skipped", "error", "step_s"):
                continue
            md.append(f"- {name}: {r if isinstance(r, str) else (r.get('result') or r.get('rc'))}"
                      + (f"; failed: {', '.join(r['failed'])}" if isinstance(r, dict) and r.get("failed") else ""))
        md += ["", "## Steps", ""]
        for name, r in st.items():
            md.append(f"- {name}: " + (r.get("error") or r.get("skipped") or f"ok in {r.get('step_s')} s"))
        text = "\n".join(md) + "\n"
        with open(os.path.join(self.out, "summary.md"), "w") as f:
            f.write(text)
        return text


def standard_xr(lanes):
    """x_r0 of the standard job's lanes: -4 mm + 8 mm i / (lanes - 1), as the C loop,
    the numba peer and examples/work_precision.rs compute it."""
    return np.array([-0.004 + 0.008 * i / (max(lanes, 2) - 1) for i in range(lanes)])


def summarize_attractors(att):
    items = att.get("attractors", att) if isinstance(att, dict) else att
    out = []
    for a in items if isinstance(items, list) else []:
        out.append({k: a[k] for k in ("id", "class", "lanes", "basin_fraction") if k in a})
    return out


def agreement(a, b):
    """Share of cells whose labels agree, raw and after mapping each label of `a` to the
    label of `b` it most often meets (ids are numbered per run)."""
    a, b = np.asarray(a).ravel(), np.asarray(b).ravel()
    mapped = np.empty_like(a)
    for v in np.unique(a):
        sel = a == v
        vals, counts = np.unique(b[sel], return_counts=True)
        mapped[sel] = vals[np.argmax(counts)]
    return {"cells": int(a.size), "raw": float(np.mean(a == b)), "matched": float(np.mean(mapped == b))}


def check_slow_list():
    """Every test SLOW_ON_HARDWARE names exists (a renamed test would otherwise run in
    the first pass again and its --skip do nothing)."""
    for exe, tests in SLOW_ON_HARDWARE.items():
        with open(os.path.join(ROOT, "tests", exe + ".rs")) as f:
            text = f.read()
        for t in tests:
            if f"fn {t}(" not in text:
                raise SystemExit(f"gpu_campaign: SLOW_ON_HARDWARE names {exe}::{t}, not in tests/{exe}.rs")


def main():
    args = parse_args()
    check_slow_list()
    c = Campaign(args)
    if args.reference_only:
        c.reference()
        return 0
    c.say(f"jeffcott: {c.jeffcott}; deadline {c.deadline:.0f} s; work in {c.work}")
    order = [n for n in args.only.split(",") if n != "adapter"] if args.only else STEPS[1:]
    unknown = set(order) - set(STEPS)
    if unknown:
        print(f"gpu_campaign: --only names unknown steps {sorted(unknown)}; steps: {', '.join(STEPS)}", file=sys.stderr)
        return 2
    need = {"adapter": 5, "parity": 20, "bench": 60, "anatomy": 30, "standard": 90, "peer": 30, "basin": 90, "tests": 30, "explore": 60}
    for name in ["adapter"] + order:
        c.step(name, getattr(c, name), need[name])
    text = c.summary()
    c.save()
    shutil.rmtree(c.work, ignore_errors=True)
    print("\n" + text)
    # On a lent GPU every result counts, so a failed step is recorded and the rest run;
    # but the local mode is CI's guard against a campaign that rots: there a failed or
    # deadline-skipped step fails the run.
    broken = [n for n, r in c.results["steps"].items() if "error" in r or "deadline" in str(r.get("skipped", ""))]
    if args.local and broken:
        print(f"gpu_campaign: steps failed or ran out of time: {', '.join(broken)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
