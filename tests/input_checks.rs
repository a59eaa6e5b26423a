//! Input validation of the `jeffcott` command line: requests that cannot be met (more
//! memory than the machine has, period counts beyond the shared cap, speeds beyond
//! 1e5 rad/s), ambiguous ones (a key given twice) and contradictory ones (a minimum
//! above its maximum, a start state already diverged) end with exit code 2 and an error
//! that names the option and what is allowed, before any output directory exists. Also:
//! stderr stays free of Vulkan-loader noise, frozen lanes record NaN rather than their
//! last finite state, and too short records are "unclassified".
//!
//! The GPU checks need an adapter (Mesa's lavapipe counts). Without one they are
//! skipped, unless `JEFFCOTT_REQUIRE_GPU=1`, which makes them fail.

use std::path::Path;
use std::process::{Command, Output};

mod common;
use common::{jeffcott, jeffcott_out, jeffcott_temp, npy, require_gpu, temp_out, words};

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Asserts exit code 2 and an error line containing every piece of `needles`.
fn assert_refused(o: &Output, needles: &[&str]) -> String {
    let e = stderr(o);
    assert_eq!(o.status.code(), Some(2), "stderr: {e}");
    assert!(e.starts_with("error: invalid value for `"), "{e}");
    for n in needles {
        assert!(e.contains(n), "`{n}` missing from: {e}");
    }
    e
}

/// Asserts that the run of `args` with `--out` a fresh temporary path is refused
/// ([`assert_refused`]) and makes no output directory.
fn assert_refused_before_output(args: &[&str], needles: &[&str]) {
    let (_dir, out) = temp_out("run");
    let o = jeffcott(&[args, &["--out", out.to_str().unwrap()]].concat());
    assert_refused(&o, needles);
    assert!(!out.exists(), "{args:?} created its output");
}

/// True when `jeffcott info` sees an adapter; panics without one when
/// `JEFFCOTT_REQUIRE_GPU=1`.
fn gpu_present() -> bool {
    let o = jeffcott(&["info"]);
    assert!(o.status.success(), "{}", stderr(&o));
    let present = String::from_utf8_lossy(&o.stdout)
        .lines()
        .any(|l| l.starts_with("GPU: ") && !l.contains("no adapter found"));
    assert!(
        present || !require_gpu(),
        "JEFFCOTT_REQUIRE_GPU=1 but `jeffcott info` lists no adapter"
    );
    if !present {
        eprintln!("skipped: no GPU adapter");
    }
    present
}

// 1. Memory.

#[test]
fn speed_ranges_too_large_for_memory_are_refused_with_the_estimate_before_allocating() {
    let (_dir, out) = temp_out("run");
    let out = out.to_str().unwrap();
    for (cmd, omega) in [
        ("ensemble", "130:140:1000000000000"),
        ("ensemble", "130:140:100000000"),
        ("lyapunov", "130:140:1000000000000"),
        ("bifurcation", "130:140:1000000000000"),
        ("bifurcation", "130:140:100000000"),
    ] {
        let o = jeffcott(&[cmd, "--omega", omega, "--out", out]);
        let e = assert_refused(&o, &["`omega`", omega, " GB of memory", "available"]);
        assert!(e.contains("fewer speeds"), "{cmd}: no hint in {e}");
        assert!(
            !Path::new(out).exists(),
            "{cmd} created its output directory"
        );
    }
}

#[test]
fn basin_grids_of_1e10_cells_are_refused_before_allocating() {
    let (_dir, out, o) = jeffcott_temp(
        "basin",
        "basin --omega 133 --x x_r:-0.006:0.006:100000 --y vx_r:-1:1:100000",
    );
    assert_refused(
        &o,
        &[
            "`x, y`",
            "100000 x 100000",
            "at most 1000000000 cells",
            "40.0 GB",
            "smaller grid",
        ],
    );
    assert!(!out.exists());
}

// 2. One cap on period counts.

#[test]
fn period_counts_beyond_1e8_are_refused_by_every_command() {
    let (_dir, out) = temp_out("run");
    let out = out.to_str().unwrap();
    let huge = "4294967295";
    // Each command line ends with the option that `huge` is given to.
    let cases = [
        ("simulate --omega 133 --transient", "transient"),
        ("ensemble --omega 133 --transient", "transient"),
        ("ensemble --omega 133 --periods", "periods"),
        (
            "bifurcation --omega 130:131:3 --transient-first",
            "transient-first",
        ),
        ("bifurcation --omega 130:131:3 --transient", "transient"),
        (
            "bifurcation --omega 130:131:3 --brute-transient",
            "brute-transient",
        ),
        ("lyapunov --omega 133 --transient", "transient"),
        (
            "lyapunov --omega 133 --tangent-transient",
            "tangent-transient",
        ),
        (
            "basin --omega 133 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4 --transient",
            "transient",
        ),
        (
            "ensemble --omega 133 --lyapunov --lyapunov-align",
            "lyapunov-align",
        ),
        (
            "basin --omega 133 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4 --early-exit-after",
            "early-exit-after",
        ),
    ];
    for (line, option) in cases {
        let args = [words(line), vec![huge]].concat();
        let cap = format!("`{option}`: {huge}");
        assert_refused_before_output(&args, &[&cap, "..=100000000 forcing periods"]);
    }
    // The cap itself is allowed (refused here only for lack of --ics, after the counts).
    let o = jeffcott_out(
        "bifurcation --omega 130:131:3 --brute-transient 100000000 --sweep none --ics 0",
        out,
    );
    assert_refused(&o, &["`ics`"]);
}

#[test]
fn lyapunov_times_beyond_1e8_forcing_periods_are_refused() {
    let o = jeffcott(&words(
        "lyapunov --omega 133 --time 1e9 --out /nonexistent/x",
    ));
    assert_refused(&o, &["`time`", "100000000 periods"]);
}

// 3. --config then --param.

#[test]
fn a_config_value_replaced_by_param_is_not_validated_but_the_final_set_is() {
    let dir = tempfile::tempdir().unwrap();
    let cfg = dir.path().join("params.toml");
    std::fs::write(&cfg, "mu = -0.5\n").unwrap();
    let cfg = cfg.to_str().unwrap();
    let out = dir.path().join("run");
    let out = out.to_str().unwrap();
    let base = [
        "simulate",
        "--omega",
        "133",
        "--transient",
        "2",
        "--periods",
        "2",
        "--no-plot",
        "--quiet",
        "--config",
        cfg,
        "--out",
        out,
    ];
    let mut args = base.to_vec();
    args.extend(["--param", "mu=0.1"]);
    let o = jeffcott(&args);
    assert!(o.status.success(), "{}", stderr(&o));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(Path::new(out).join("summary.json")).unwrap())
            .unwrap();
    assert_eq!(s["params"]["mu"], 0.1);
    std::fs::remove_dir_all(out).unwrap();
    // Without the override the config's value is the final one, and refused.
    assert_refused(&jeffcott(&base), &["`mu`: -0.5", ">= 0"]);
    assert!(!Path::new(out).exists());
    // Parse errors of the file are still reported, override or not.
    std::fs::write(cfg, "mu = \n").unwrap();
    let o = jeffcott(&args);
    assert_eq!(o.status.code(), Some(2));
    assert!(
        stderr(&o).contains("cannot use config file"),
        "{}",
        stderr(&o)
    );
}

// 4. --sweep none.

#[test]
fn bifurcation_sweep_none_is_offered_and_runs_the_brute_force_only() {
    let help = jeffcott(&words("bifurcation --help"));
    let help = String::from_utf8_lossy(&help.stdout);
    assert!(help.contains("none"), "{help}");
    let (_dir, out) = temp_out("bif");
    let out = out.to_str().unwrap();
    let o = jeffcott_out(
        "bifurcation --omega 131:132:3 --sweep none --ics 2 --max-seeds 0 --brute-transient 20 \
         --periods 4 --no-lyapunov --no-plot --backend cpu --quiet",
        out,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (shape, _) = npy::<f64>(&Path::new(out).join("bifurcation_rows.npy"));
    assert_eq!(shape[0], 3 * 2, "brute-force rows only: {shape:?}");
    let o = jeffcott_out(
        "bifurcation --omega 131:132:3 --sweep none --ics 0",
        format!("{out}-2"),
    );
    assert_refused(&o, &["`ics`", "at least one brute-force start state"]);
}

// 5. Duplicates, contradictions, out-of-range options.

#[test]
fn a_key_given_twice_is_refused_naming_the_key() {
    let sim = "simulate --omega 133";
    let basin = "basin --omega 133 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4";
    let cases = [
        (
            sim,
            "--param mu=0.1,mu=0.2",
            "`param mu`: mu=0.1 and mu=0.2",
        ),
        (sim, "--param mu=0.1 --param k_c=2e8,mu=0.2", "`param mu`"),
        (sim, "--init x_r=1,x_r=2", "`init x_r`: x_r=1 and x_r=2"),
        (sim, "--init x_r=0.001 --init x_r=0.002", "`init x_r`"),
        (basin, "--fix y_r=0,y_r=0.001", "`fix y_r`"),
        (basin, "--fix y_r=0 --fix y_r=0.001", "`fix y_r`"),
    ];
    for (cmd, extra, needle) in cases {
        let args = [words(cmd), words(extra)].concat();
        assert_refused_before_output(&args, &[needle, "given twice"]);
    }
}

#[test]
fn lyapunov_min_time_above_time_is_refused_and_the_default_follows_a_short_time() {
    assert_refused_before_output(
        &words("lyapunov --omega 133 --min-time 5 --time 1"),
        &["`min-time`: 5", "0..=time (1 s)"],
    );
    // Without --min-time a --time under the default 20 s is fine.
    let (_dir, _, o) = jeffcott_temp(
        "ly",
        "lyapunov --omega 133 --transient 5 --tangent-transient 2 --time 0.5 --quiet",
    );
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn bench_twin_at_must_be_zero_or_a_measured_size() {
    let o = jeffcott(&words("bench --lanes 8,16 --twin-at 99999999999"));
    assert_refused(
        &o,
        &[
            "`twin-at`: 99999999999",
            "0 (no free-flight twin) or one of the --lanes sizes (8, 16)",
        ],
    );
}

#[test]
fn bifurcation_portraits_outside_the_speed_range_are_refused_before_the_run() {
    assert_refused_before_output(
        &words("bifurcation --omega 130:140:11 --portraits 135,999"),
        &["`portraits`: 999", "130..=140 rad/s"],
    );
}

#[test]
fn start_positions_beyond_the_divergence_bound_are_refused_naming_coordinate_and_bound() {
    let bound = ["--divergence-bound", "1"];
    let cases = [
        ("simulate --omega 133 --init x_r=5", "`init x_r`: 5"),
        ("ensemble --omega 133 --init y_s=-5", "`init y_s`: -5"),
        ("lyapunov --omega 133 --init x_r=5", "`init x_r`: 5"),
        (
            "basin --omega 133 --fix y_r=3 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4",
            "`fix y_r`: 3",
        ),
        (
            "basin --omega 133 --x x_r:-2:2:4 --y vx_r:-1:1:4",
            "`x x_r`: -2",
        ),
    ];
    for (line, needle) in cases {
        let args = [words(line), bound.to_vec()].concat();
        let needles = [needle, "--divergence-bound 1 m", "-1..=1 m"];
        assert_refused_before_output(&args, &needles);
    }
}

// 6. Nothing but errors on stderr.

#[test]
fn gpu_runs_leave_stderr_free_of_xdg_runtime_dir_noise() {
    if !gpu_present() {
        return;
    }
    let (_dir, out) = temp_out("ens");
    let runs: [&[&str]; 2] = [
        &["info"],
        &[
            "ensemble",
            "--omega",
            "130:131:4",
            "--transient",
            "2",
            "--periods",
            "2",
            "--backend",
            "gpu",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ],
    ];
    for args in runs {
        // As in an ssh session or CI job: no desktop session, no user choice of device.
        let o = Command::new(env!("CARGO_BIN_EXE_jeffcott"))
            .args(args)
            .env_remove("XDG_RUNTIME_DIR")
            .env_remove("WAYLAND_DISPLAY")
            .env_remove("DISPLAY")
            .env_remove("NODEVICE_SELECT")
            .env_remove("MESA_VK_DEVICE_SELECT")
            .env_remove("DRI_PRIME")
            .output()
            .unwrap();
        let e = stderr(&o);
        assert!(o.status.success(), "{args:?}: {e}");
        assert!(!e.contains("XDG_RUNTIME_DIR"), "{args:?}: {e}");
        assert!(e.trim().is_empty(), "{args:?} wrote to stderr: {e}");
    }
}

// 7. Frozen lanes record NaN.

/// Rows of `poincare` [lanes, periods, 8] per lane: the index of the first NaN row
/// (`periods` if none), after checking that every row from there on is all NaN and
/// every row before it finite.
fn first_nan_rows(shape: &[u64], p: &[f64]) -> Vec<usize> {
    let (lanes, periods) = (shape[0] as usize, shape[1] as usize);
    (0..lanes)
        .map(|l| {
            let row = |j: usize| &p[(l * periods + j) * 8..(l * periods + j + 1) * 8];
            let first = (0..periods)
                .find(|&j| row(j).iter().any(|v| v.is_nan()))
                .unwrap_or(periods);
            for j in 0..periods {
                if j < first {
                    assert!(row(j).iter().all(|v| v.is_finite()), "lane {l} row {j}");
                } else {
                    assert!(row(j).iter().all(|v| v.is_nan()), "lane {l} row {j}");
                }
            }
            first
        })
        .collect()
}

#[test]
fn frozen_lanes_record_nan_from_the_period_they_froze_in_identically_on_both_backends() {
    // A bound of 6.5 mm: the lanes at the top of the range are thrown past it in their
    // third period, the others stay inside.
    let dir = tempfile::tempdir().unwrap();
    let mut runs = vec![("cpu", false), ("cpu", true)];
    if gpu_present() {
        runs.extend([("gpu", false), ("gpu", true)]);
    }
    let mut files = Vec::new();
    for (backend, lyapunov) in runs {
        let out = dir.path().join(format!("{backend}-{lyapunov}"));
        let mut line = format!(
            "ensemble --omega 130:140:10 --transient 0 --periods 32 --divergence-bound 0.0065 \
             --backend {backend} --precision f64 --quiet"
        );
        if lyapunov {
            line += " --lyapunov";
        }
        let o = jeffcott_out(&line, &out);
        assert!(o.status.success(), "{}", stderr(&o));
        let (shape, p) = npy::<f64>(&out.join("poincare.npy"));
        assert_eq!(shape, vec![10, 32, 8]);
        let (_, status) = npy::<u32>(&out.join("status.npy"));
        let first = first_nan_rows(&shape, &p);
        assert!(status.contains(&0) && status.contains(&2), "{status:?}");
        for (l, (&s, &f)) in status.iter().zip(&first).enumerate() {
            if s == 2 || s == 3 {
                assert!(f < 32, "frozen lane {l} has no NaN rows");
                assert!(
                    f > 0,
                    "lane {l}: it froze during recording, rows before are real"
                );
            } else {
                assert_eq!(f, 32, "lane {l} with status {s} has NaN rows");
            }
        }
        files.push(std::fs::read(out.join("poincare.npy")).unwrap());
    }
    for f in &files[1..] {
        assert!(
            f == &files[0],
            "poincare.npy differs between backends or variants"
        );
    }
}

#[test]
fn a_simulation_that_diverges_writes_nan_rows_and_no_infinite_distances() {
    let (_dir, out) = temp_out("sim");
    // Thrown out of the 1 m bound in the transient: no Poincare point at all.
    let o = jeffcott_out(
        "simulate --omega 133 --init vx_r=1e6 --transient 10 --periods 4 --no-plot",
        &out,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(stdout.contains("no recorded points"), "{stdout}");
    assert!(!stdout.contains("inf"), "{stdout}");
    let (shape, p) = npy::<f64>(&out.join("poincare.npy"));
    assert_eq!(shape, vec![4, 8]);
    assert!(p.iter().all(|v| v.is_nan()));
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["class"], "diverged");
    assert_eq!(s["recorded_poincare_points"], 0);
    // Diverging during the recording: the periods reached are real, the rest NaN.
    // Another run into the same directory: --overwrite replaces the first.
    let o = jeffcott_out(
        "simulate --omega 140 --transient 0 --periods 32 --divergence-bound 0.0065 --no-plot \
         --quiet --overwrite",
        &out,
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let (shape, p) = npy::<f64>(&out.join("poincare.npy"));
    assert_eq!(shape, vec![32, 8]);
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    let k = s["recorded_poincare_points"].as_u64().unwrap() as usize;
    assert!(k > 0 && k < 32, "{k}");
    assert_eq!(first_nan_rows(&[1, 32], &p), vec![k]);
}

// 8. Absurd speeds; too short records.

#[test]
fn absurd_speeds_are_refused_with_the_range_and_without_a_301_digit_number() {
    let (_dir, out) = temp_out("run");
    let out = out.to_str().unwrap();
    let e = assert_refused(
        &jeffcott_out("simulate --omega 1e300", out),
        &["`omega`: 1e300", "<= 1e5 rad/s"],
    );
    assert!(e.len() < 200, "{e}");
    assert_refused(
        &jeffcott_out("ensemble --omega 100:2e5:2", out),
        &["`omega (lane 1)`: 200000", "<= 1e5 rad/s"],
    );
    assert_refused(
        &jeffcott_out(
            "basin --omega 1e6 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4",
            out,
        ),
        &["`omega`", "<= 1e5 rad/s"],
    );
    assert!(!Path::new(out).exists());
}

#[test]
fn one_recorded_period_is_unclassified_not_aperiodic() {
    let (_dir, out, o) = jeffcott_temp(
        "sim",
        "simulate --omega 131.7 --transient 10 --periods 1 --no-plot",
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("unclassified") && stdout.contains("too few"),
        "{stdout}"
    );
    assert!(!stdout.contains("aperiodic"), "{stdout}");
    let s: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("summary.json")).unwrap()).unwrap();
    assert_eq!(s["class"], "unclassified");
    assert!(s["period"].is_null());
    assert!(
        s["classification"]["reason"]
            .as_str()
            .unwrap()
            .contains("at least 2")
    );
}

#[test]
fn contact_refinement_other_than_a_power_of_two_up_to_16_is_refused_naming_the_option() {
    let dir = tempfile::tempdir().unwrap();
    for bad in ["3", "0", "32"] {
        let out = dir.path().join(format!("r{bad}"));
        let o = jeffcott(&[
            "simulate",
            "--omega",
            "133",
            "--contact-substeps",
            bad,
            "--no-plot",
            "--out",
            out.to_str().unwrap(),
        ]);
        assert_refused(&o, &["`contact-substeps`", "1, 2, 4, 8, 16"]);
        assert!(!out.exists(), "nothing may be written for R = {bad}");
    }
}

/// `--exact-free-flight` reaches the stepper: run.json records it, and the points differ
/// from RK4's (the GPU's agreement with the CPU is tests/gpu.rs's).
#[test]
fn exact_free_flight_reaches_the_stepper_and_its_record() {
    let base: Vec<&str> = "ensemble --omega 133 --transient 2 --periods 2 --quiet --backend cpu"
        .split(' ')
        .collect();
    let (_dir, out) = temp_out("runs");
    let run = |extra: &[&str], name: &str| {
        let dir = out.join(name);
        let o = jeffcott(&[&base[..], &["--out", dir.to_str().unwrap()], extra].concat());
        assert!(o.status.success(), "{}", stderr(&o));
        let run = std::fs::read_to_string(dir.join("run.json")).expect("run.json");
        let on = run.contains("\"exact_free_flight\": true");
        (
            std::fs::read(dir.join("poincare.npy")).expect("poincare.npy"),
            on,
        )
    };
    let (exact, on) = run(&["--exact-free-flight"], "exact");
    let (rk4, off) = run(&[], "rk4");
    assert!(on && !off, "run.json does not record the choice");
    assert_ne!(exact, rk4);
}
