"""The Python package against the physics, the command line and the rules of the
library: each test names what it proves. The command line's binary is
``$JEFFCOTT_BIN`` or ``target/release/jeffcott`` of this checkout (scripts/test.sh
builds it first). With ``JEFFCOTT_REQUIRE_GPU=1`` (CI) a missing GPU adapter fails the
GPU test instead of skipping it."""

import json
import os
import subprocess
import sys
import threading
import time
import _thread
from pathlib import Path

import numpy as np
import pytest

import jeffcott

ROOT = Path(__file__).resolve().parents[2]
BIN = Path(os.environ.get("JEFFCOTT_BIN", ROOT / "target" / "release" / "jeffcott"))


def cli(*args):
    """Runs the command line; returns its output directory's files."""
    assert BIN.exists(), f"{BIN} is missing: build it with `cargo build --release`"
    out = subprocess.run([str(BIN), *args, "--quiet"], capture_output=True, text=True)
    assert out.returncode == 0, out.stderr


def assert_arrays_and_summary_equal_the_cli(r, out, summary, names, same="shape"):
    """Each array `names` of `r` has the `same` (shape or dtype) and the bytes of the CLI's
    NAME.npy in `out`, and r["summary"] is the CLI's `summary` file less "files" and
    "jeffcott_version"."""
    for name in names:
        want = np.load(out / f"{name}.npy")
        assert getattr(r[name], same) == getattr(want, same), name
        assert r[name].tobytes() == want.tobytes(), name
    s = json.loads((out / summary).read_text())
    for k in ("files", "jeffcott_version"):
        s.pop(k)
    assert r["summary"] == s


def test_simulate_131_7_is_period_1_and_132_2_is_period_2():
    a = jeffcott.simulate(131.7)
    assert a["class"] == "period-1" and a["period"] == 1
    assert a["status"] == "ok"
    assert a["poincare"].shape == (64, 8)
    # Period 1: every recorded Poincare point is the same point (to the classifier's
    # tolerance, 1e-7 m), and the run is in the article's rubbing regime's neighbourhood.
    p = a["poincare"]
    assert np.max(np.abs(p[:, [0, 2, 4, 6]] - p[0, [0, 2, 4, 6]])) < 1e-7
    b = jeffcott.simulate(132.2)
    assert b["class"] == "period-2" and b["period"] == 2
    q = b["poincare"]
    # Period 2: points repeat every 2 periods but not every period.
    assert np.max(np.abs(q[2:, [0, 2]] - q[:-2, [0, 2]])) < 1e-7
    assert np.max(np.abs(q[1:, [0, 2]] - q[:-1, [0, 2]])) > 1e-6
    # The arrays that go with it: the time series (t, state), the full spectrum and the
    # contact history of the rub stretch.
    assert b["timeseries"].shape[1] == 9
    assert b["full_spectrum"].shape[1] == 4 and b["contact_history"].shape[1] == 5
    assert b["rub"]["regime"] in ("partial_rub", "full_annular_rub")


def test_simulate_returns_the_keys_and_values_of_the_cli_summary_json(tmp_path):
    out = tmp_path / "sim"
    cli("simulate", "--omega", "132.2", "--transient", "300", "--periods", "16",
        "--no-plot", "--out", str(out))
    s = json.loads((out / "summary.json").read_text())
    r = jeffcott.simulate(132.2, transient=300, periods=16)
    for k in ("files", "jeffcott_version"):
        s.pop(k)
    assert "wall_time_s" not in s, "a wall time in summary.json: a re-run is not byte-identical"
    for k in ("wall_time_s", "poincare", "timeseries", "full_spectrum", "contact_history"):
        r.pop(k)
    assert r == s
    p = np.load(out / "poincare.npy")
    assert jeffcott.simulate(132.2, transient=300, periods=16)["poincare"].tobytes() == p.tobytes()


def test_ensemble_arrays_equal_the_cli_poincare_npy_bit_for_bit(tmp_path):
    out = tmp_path / "ens"
    cli("ensemble", "--omega", "130:141:37", "--transient", "40", "--periods", "8",
        "--init", "x_r=0.004,vx_r=-0.3", "--param", "mu=0.05", "--backend", "cpu",
        "--lyapunov", "--out", str(out))
    r = jeffcott.ensemble("130:141:37", transient=40, periods=8,
                          init={"x_r": 0.004, "vx_r": -0.3}, params={"mu": 0.05},
                          backend="cpu", lyapunov=True)
    for name in ("poincare", "status", "lanes", "params", "lambda1"):
        want = np.load(out / f"{name}.npy")
        got = r[name]
        assert got.dtype == want.dtype and got.shape == want.shape, name
        assert got.tobytes() == want.tobytes(), name
    run = json.loads((out / "run.json").read_text())
    assert r["run"]["counters"] == run["counters"]
    assert r["run"]["status_counts"] == run["status_counts"]


def test_an_ensemble_from_a_lane_table_equals_the_cli_lanes_csv_run(tmp_path):
    table = np.array([[131.0, 0.003, 0.0], [133.0, -0.002, 0.1], [139.5, 0.0, 0.3]])
    csv = tmp_path / "lanes.csv"
    csv.write_text("omega,x_r,mu\n" + "\n".join(",".join(repr(float(v)) for v in row) for row in table))
    out = tmp_path / "ens"
    cli("ensemble", "--lanes", str(csv), "--transient", "30", "--periods", "4",
        "--backend", "cpu", "--out", str(out))
    r = jeffcott.ensemble(lanes=table, columns=["omega", "x_r", "mu"], transient=30,
                          periods=4, backend="cpu")
    assert r["poincare"].tobytes() == np.load(out / "poincare.npy").tobytes()
    assert r["params"].tobytes() == np.load(out / "params.npy").tobytes()


def test_basin_labels_and_attractors_equal_the_cli_files_rub_figures_included(tmp_path):
    out = tmp_path / "basin"
    cli("basin", "--omega", "133", "--x", "x_r:-0.006:0.006:12", "--y", "vx_r:-1:1:10",
        "--transient", "250", "--periods", "32", "--backend", "cpu",
        "--uncertainty-samples", "0", "--no-plot", "--out", str(out))
    r = jeffcott.basin(133, ("x_r", -0.006, 0.006, 12), "vx_r:-1:1:10", transient=250,
                       periods=32, backend="cpu")
    want = np.load(out / "labels.npy")
    assert r["labels"].dtype == np.int32 and r["labels"].shape == (10, 12)
    assert np.array_equal(r["labels"], want)
    assert r["x"].tobytes() == np.load(out / "x.npy").tobytes()
    attractors = json.loads((out / "attractors.json").read_text())["attractors"]
    # The same list as attractors.json, each attractor with its rub figures (one study
    # behind both front ends).
    assert r["attractors"] == attractors
    assert all("regime" in a["rub"] for a in r["attractors"])
    # Coexisting attractors at 133 rad/s (the article's Fig. 7): period 4 and 5.
    assert sorted(a["period"] for a in r["attractors"]) == [4, 5]


def test_a_refined_basin_and_its_measures_equal_the_cli_basin_metrics_json(tmp_path):
    out = tmp_path / "basin"
    cli("basin", "--omega", "133", "--x", "x_r:-0.006:0.006:9", "--y", "vx_r:-1:1:9",
        "--transient", "150", "--periods", "24", "--backend", "cpu", "--refine", "1",
        "--uncertainty-samples", "12", "--no-plot", "--out", str(out))
    r = jeffcott.basin(133, "x_r:-0.006:0.006:9", "vx_r:-1:1:9", transient=150,
                       periods=24, backend="cpu", refine=1, uncertainty_samples=12)
    # One level of refinement: (9 - 1) 2 + 1 = 17 points per side.
    assert r["labels"].shape == (17, 17) and r["refined"].shape == (17, 17)
    assert np.array_equal(r["labels"], np.load(out / "labels.npy"))
    assert np.array_equal(r["refined"], np.load(out / "refined.npy"))
    want = json.loads((out / "basin_metrics.json").read_text())
    assert r["metrics"] == want
    f = [b["fraction"] for b in r["metrics"]["fractions"]["basins"]]
    assert abs(sum(f) - 1.0) < 1e-12
    assert r["metrics"]["uncertainty_reintegration"] is not None


def newton_labels(n):
    """Newton's method for z^3 = 1 from an n x n grid over [-2, 2]^2: the index of the
    root reached within 1e-6 after at most 100 steps, -1 otherwise."""
    v = np.linspace(-2.0, 2.0, n)
    z = v[None, :] + 1j * v[:, None]
    roots = np.exp(2j * np.pi * np.arange(3) / 3)
    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(100):
            z = z - (z**3 - 1) / (3 * z**2)
    d = np.abs(z[..., None] - roots)
    labels = np.where(d.min(axis=-1) < 1e-6, d.argmin(axis=-1), -1)
    return labels.astype(np.int32)


def test_basin_metrics_of_newtons_cubic_find_three_wada_basins_with_a_fractal_boundary():
    # A known answer independent of the rotor: the three basins of Newton's method for
    # z^3 = 1 share one fractal (Wada) boundary; the grid is symmetric under z -> conj z,
    # which swaps the basins of the two complex roots.
    m = jeffcott.basin_metrics(newton_labels(301))
    basins = [b for b in m["fractions"]["basins"] if b["label"] >= 0]
    assert len(basins) == 3
    assert abs(basins[1]["fraction"] - basins[2]["fraction"]) < 1e-3
    assert all(b["fraction"] > 0.3 for b in basins)
    assert m["entropy"]["s_bb"] > np.log(2)
    assert m["wada"]["applicable"] and m["wada"]["wada"]
    assert m["boundary"]["kind"] == "fractal"
    # Two half planes (the line between them inside a column of entropy boxes): a smooth
    # boundary, S_bb below ln 2, the uncertainty exponent near 1.
    halves = np.zeros((60, 60), dtype=np.int32)
    halves[:, 32:] = 1
    h = jeffcott.basin_metrics(halves)
    assert [b["fraction"] for b in h["fractions"]["basins"]] == [32 / 60, 28 / 60]
    assert h["entropy"]["s_bb"] < np.log(2)
    assert abs(h["uncertainty"]["fit"]["slope"] - 1.0) < 0.1
    assert h["boundary"]["kind"] == "smooth"


def test_cascade_arrays_and_summary_equal_the_cli_cascade(tmp_path):
    out = tmp_path / "cascade"
    cli("cascade", "--omega", "131:134:5", "--transient-first", "100", "--transient", "40",
        "--periods", "16", "--no-plot", "--out", str(out))
    r = jeffcott.cascade("131:134:5", transient_first=100, transient=40, periods=16)
    assert_arrays_and_summary_equal_the_cli(
        r, out, "cascade.json", ("omega", "orders", "cascade", "cascade_stator", "regime"))
    assert r["summary"]["sweeps"] == ["up", "down"]
    # The 1X line: every spectrum of a rubbing or free rotor has its largest line at
    # order +1 somewhere along the sweep.
    k1 = int(np.argmin(np.abs(r["orders"] - 1.0)))
    assert np.all(np.nanargmax(r["cascade"][0], axis=1) == k1)


def test_map_arrays_and_summary_equal_the_cli_map(tmp_path):
    out = tmp_path / "map"
    cli("map", "--x", "omega:131:134:4", "--y", "e:0.0005:0.001:3", "--transient", "200",
        "--periods", "16", "--ics", "2", "--backend", "cpu", "--no-plot", "--out", str(out))
    r = jeffcott.map(("omega", 131, 134, 4), "e:0.0005:0.001:3", transient=200, periods=16,
                     ics=2, backend="cpu")
    assert_arrays_and_summary_equal_the_cli(
        r, out, "map.json", ("period", "class", "attractors", "regime", "lambda1", "contact",
                             "peak_force", "x", "y"), same="dtype")


def test_continuation_arrays_and_summary_equal_the_cli_continuation(tmp_path):
    out = tmp_path / "cont"
    cli("continuation", "--vary", "omega:131.5:132.5:3", "--ics", "6", "--transient", "200",
        "--periods", "16", "--backend", "cpu", "--no-plot", "--out", str(out))
    r = jeffcott.continuation(("omega", 131.5, 132.5, 3), ics=6, transient=200, periods=16,
                              backend="cpu")
    assert_arrays_and_summary_equal_the_cli(
        r, out, "continuation.json", ("values", "fractions_up", "fraction_errors_up", "tipping_up",
                                      "fractions_down", "fraction_errors_down", "tipping_down"))
    # Every row of a tipping matrix with a basin sums to one (Kaszas et al. 2019).
    t = r["tipping_up"]
    rows = t[~np.isnan(t[:, :, 0])]
    assert np.allclose(rows.sum(axis=-1), 1.0)


def test_basin_stability_equals_the_cli_and_its_intervals_cover_the_fractions(tmp_path):
    out = tmp_path / "bs"
    cli("basin-stability", "--omega", "133", "--sample", "40", "--box",
        "x_r:-0.006:0.006,vx_r:-1:1", "--transient", "250", "--periods", "32",
        "--backend", "cpu", "--no-plot", "--out", str(out))
    r = jeffcott.basin_stability(133, "x_r:-0.006:0.006,vx_r:-1:1", sample=40,
                                 transient=250, periods=32, backend="cpu")
    assert_arrays_and_summary_equal_the_cli(
        r, out, "basin_stability.json", ("omega", "fractions", "ci_low", "ci_high"))
    f = r["fractions"]
    assert np.allclose(f.sum(axis=1), 1.0)
    assert np.all(r["ci_low"] <= f) and np.all(f <= r["ci_high"])


@pytest.mark.parametrize(
    "call, field",
    [
        (lambda: jeffcott.simulate(132.2, params={"k_c": -1.0}), "k_c"),
        (lambda: jeffcott.simulate(132.2, params={"no_such_key": 1.0}), "no_such_key"),
        (lambda: jeffcott.simulate(-5.0), "omega"),
        (lambda: jeffcott.simulate(132.2, init={"x_r": 2.0}), "init x_r"),
        (lambda: jeffcott.simulate(132.2, rel_tol=0.0), "rel_tol"),
        (lambda: jeffcott.ensemble("130:141:0"), "omega"),
        (lambda: jeffcott.ensemble(133.0, backend="tpu"), "backend"),
        (lambda: jeffcott.ensemble(133.0, precision="f16"), "precision"),
        (lambda: jeffcott.ensemble(133.0, contact_substeps=3), "contact"),
        (lambda: jeffcott.basin(133, ("x_r", 0.0, 1.0, 4), ("x_r", 0.0, 1.0, 4)), "y"),
        (lambda: jeffcott.bifurcation("130:141:4", sweep="sideways"), "sweep"),
        (lambda: jeffcott.lyapunov(140, time=-1.0), "time`"),
        (lambda: jeffcott.map(("omega", 131, 134, 4), ("nope", 0, 1, 3)), "y"),
        (lambda: jeffcott.continuation("omega:130:141:1"), "param"),
        (lambda: jeffcott.continuation("omega:130:141:3", direction="sideways"), "direction"),
        (lambda: jeffcott.basin_stability(133, "x_r:-0.006:0.006", sample=1), "sample"),
        (lambda: jeffcott.basin_stability(133, "q_r:0:1"), "start_box"),
        (lambda: jeffcott.cascade("131:134:1"), "omega"),
        (lambda: jeffcott.cascade("131:134:5", direction="sideways"), "direction"),
        (lambda: jeffcott.cascade("131:134:5", periods=20000), "periods"),
        (lambda: jeffcott.basin(133, "x_r:-0.006:0.006:9", "vx_r:-1:1:9", refine=9), "refine"),
        (lambda: jeffcott.basin(133, "x_r:-0.006:0.006:9", "vx_r:-1:1:9", entropy_box=10),
         "entropy_box"),
        (lambda: jeffcott.basin(133, "x_r:-0.006:0.006:100000", "vx_r:-1:1:100000"), "x, y"),
        (lambda: jeffcott.basin_metrics(np.zeros((4, 4), dtype=np.int32), entropy_box=0),
         "entropy_box"),
    ],
)
def test_bad_input_raises_value_error_naming_the_field(call, field):
    with pytest.raises(ValueError) as e:
        call()
    assert f"`{field}" in str(e.value), str(e.value)


def test_a_machine_variant_by_keyword_equals_the_cli_and_its_params_table_has_every_key(tmp_path):
    # Supports stiffer in y than in x (an engineer's directional stiffnesses), one
    # dashpot, the stator set off-centre, a Hertzian contact with Hunt-Crossley
    # damping: docs/model.md 7.
    machine = {"k_rx": 8.0e5, "k_ry": 1.4e6, "c_r": 350.0, "o_x": 0.0021, "o_y": -0.001,
               "n_c": 1.5, "k_c": 2e10, "alpha_c": 0.3}
    out = tmp_path / "ens"
    cli("ensemble", "--omega", "128:136:9", "--transient", "40", "--periods", "4",
        "--param", ",".join(f"{k}={v}" for k, v in machine.items()), "--backend", "cpu",
        "--out", str(out))
    r = jeffcott.ensemble("128:136:9", transient=40, periods=4, params=machine, backend="cpu")
    for name in ("poincare", "params"):
        want = np.load(out / f"{name}.npy")
        assert r[name].tobytes() == want.tobytes() and r[name].shape == want.shape, name
    # Every parameter is a column once a set is not the article's, in PARAM_KEYS order.
    assert r["params"].shape == (1, len(jeffcott.PARAM_KEYS))
    row = dict(zip(jeffcott.PARAM_KEYS, r["params"][0]))
    assert row["o_x"] == 0.0021 and row["o_y"] == -0.001
    assert row["n_c"] == 1.5 and row["alpha_c"] == 0.3 and row["k_c"] == 2e10
    assert row["omega_rx"] == np.sqrt(8.0e5 / 50.0) and row["omega_ry"] == np.sqrt(1.4e6 / 50.0)
    # One dashpot: each direction's ratio c / (2 m w) with its own frequency.
    assert abs(row["xi_rx"] - 350.0 / (2 * 50.0 * row["omega_rx"])) < 1e-15
    assert abs(row["xi_ry"] - 350.0 / (2 * 50.0 * row["omega_ry"])) < 1e-15


def test_lyapunov_spectrum_sums_to_the_damping_trace():
    # docs/model.md 6: the exponents sum to <tr J> = -2 (2 xi_r w_r + 2 xi_s w_s) = -119.2 1/s.
    s = jeffcott.lyapunov(131.7, time=30.0, transient=300)
    assert len(s["exponents"]) == 8
    assert abs(s["sum"] + 119.2) < 0.5
    assert s["history"].shape[1] == 9
    assert max(s["exponents"]) < 0  # period-1: a stable cycle


def test_orbits_finds_the_period_doubling_of_the_period_1_orbit_and_names_it_under_omega():
    r = jeffcott.orbits("omega:131.7:132.4")
    assert r["param"] == "omega"
    (b,) = r["branches"]
    (pd,) = b["bifurcations"]
    assert pd["type"] == "period_doubling" and 131.95 < pd["omega"] < 132.27
    n = len(b["points"])
    assert r["branch"].shape == (n, 13) and r["multipliers"].shape == (n, 8, 2)
    assert r["branch"][0, 1] == 131.7 and b["points"][0]["stable"]
    # The doubled branch, when asked for.
    two = jeffcott.orbits("omega:131.7:132.4", follow_doublings=True)
    assert [b["period"] for b in two["branches"]] == [1, 2]
    # Bad input (a missing W, a direction both ways, ...): test_bad_inputs.py's table.


def test_bifurcation_sweeps_find_period_1_then_period_2():
    r = jeffcott.bifurcation([131.7, 132.2], ics=2, transient_first=600, transient=300,
                             brute_transient=300, periods=16, backend="cpu")
    per_w = r["summary"]["per_omega"]
    assert [w["up"]["period"] for w in per_w] == [1, 2]
    rows = r["rows"]
    assert rows.shape[1] == 4 and r["points"].shape == (rows.shape[0], 16, 8)


def require_gpu():
    return os.environ.get("JEFFCOTT_REQUIRE_GPU") == "1"


def test_gpu_backend_on_lavapipe_reproduces_the_cpu_f64_lanes_to_the_bit():
    if not jeffcott.adapters():
        if require_gpu():
            pytest.fail("JEFFCOTT_REQUIRE_GPU=1 but wgpu finds no adapter")
        pytest.skip("no GPU adapter (install mesa-vulkan-drivers for lavapipe)")
    spec = dict(transient=30, periods=6, init={"x_r": 0.005, "vx_r": -0.4}, precision="f64")
    gpu = jeffcott.ensemble("130:141:24", backend="gpu", **spec)
    cpu = jeffcott.ensemble("130:141:24", backend="cpu", **spec)
    assert gpu["run"]["backend"] == "gpu"
    assert gpu["poincare"].tobytes() == cpu["poincare"].tobytes()
    assert np.array_equal(gpu["status"], cpu["status"])


def test_no_usable_gpu_raises_runtime_error_with_the_cli_message(tmp_path):
    # wgpu honours WGPU_BACKEND: Metal has no adapter on Linux, so the GPU backend must
    # fail, from Python with the message the command line prints after "error: ".
    env = {**os.environ, "WGPU_BACKEND": "metal"}
    py = subprocess.run(
        [sys.executable, "-c",
         "import jeffcott\n"
         "try:\n jeffcott.ensemble(133.0, backend='gpu', transient=1, periods=1)\n"
         "except RuntimeError as e:\n print(e)\n"],
        capture_output=True, text=True, cwd=tmp_path, env=env,
    )
    cl = subprocess.run(
        [str(BIN), "ensemble", "--omega", "133", "--backend", "gpu", "--transient", "1",
         "--periods", "1", "--out", str(tmp_path / "e")],
        capture_output=True, text=True, env=env,
    )
    assert cl.returncode == 4  # no usable GPU (jeffcott --help lists the exit codes)
    assert py.stdout.strip().startswith("no usable GPU adapter"), py.stdout + py.stderr
    assert cl.stderr.strip() == "error: " + py.stdout.strip()


def test_progress_callable_sees_lane_periods_up_to_the_total():
    seen = []
    jeffcott.ensemble("130:141:64", transient=100, periods=4, backend="cpu",
                      progress=lambda d, t: seen.append((d, t)))
    assert seen and seen[-1] == (64 * 104, 64 * 104)
    assert all(a[0] <= b[0] for a, b in zip(seen, seen[1:]))


def test_the_gil_is_released_during_a_run():
    # Another Python thread keeps running while an ensemble integrates (~1 s of work):
    # with the GIL held it would not advance at all until the run returned.
    ticks = []
    stop = threading.Event()

    def ticker():
        while not stop.is_set():
            ticks.append(time.monotonic())
            time.sleep(0.002)

    t = threading.Thread(target=ticker)
    t.start()
    time.sleep(0.05)
    t0 = time.monotonic()
    jeffcott.ensemble("130:141:256", transient=300, periods=8, backend="cpu")
    t1 = time.monotonic()
    stop.set()
    t.join()
    during = [x for x in ticks if t0 < x < t1]
    assert t1 - t0 > 0.2, "the run was too short to tell"
    assert len(during) >= 20, f"{len(during)} ticks in {t1 - t0:.2f} s: the GIL was held"


def test_keyboard_interrupt_during_a_long_ensemble_returns_within_a_second(sigint_raises):
    # ~100 s of CPU work; Ctrl-C (as a notebook's interrupt sends it) after 1.5 s.
    fired = []

    def interrupt():
        fired.append(time.monotonic())
        _thread.interrupt_main()

    timer = threading.Timer(1.5, interrupt)
    timer.start()
    t0 = time.monotonic()
    with pytest.raises(KeyboardInterrupt):
        jeffcott.ensemble("130:141:20000", transient=300, periods=10, backend="cpu")
    back = time.monotonic()
    timer.join()
    assert fired, "the interrupt never fired: the run ended first"
    assert back - fired[0] < 1.0, f"control came back {back - fired[0]:.2f} s after Ctrl-C"
    assert back - t0 < 10.0
    # The library is usable right after: the next run works.
    assert jeffcott.simulate(131.7, transient=200, periods=4)["status"] == "ok"
