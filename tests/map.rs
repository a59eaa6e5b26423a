//! `jeffcott map`: two-parameter maps. What they prove: a map row over omega is the
//! brute-force bifurcation at the same speeds; without unbalance nothing rubs; a cell's
//! figures depend on that cell alone (lane independence, both backends); per-lane
//! parameters reach the GPU bit for bit; the run resumes and refuses bad axes.
//!
//! GPU checks need an adapter; without one they are skipped unless
//! `JEFFCOTT_REQUIRE_GPU=1` (CI, lavapipe), where they fail.

mod common;
use common::*;
use std::process::{Command, Output};

use jeffcott_core::control::Control;
use jeffcott_core::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::Params;
use std::path::Path;

/// Short runs: 300 transient and 32 recorded periods at N = 500.
const RUN: &[&str] = &["--transient", "300", "--periods", "32", "--quiet"];

fn map(out: &Path, extra: &[&str]) -> Output {
    let mut a = vec!["map", "--out", out.to_str().unwrap()];
    a.extend_from_slice(RUN);
    a.extend_from_slice(extra);
    jeffcott(&a)
}

#[test]
fn a_map_row_over_omega_reproduces_the_brute_force_classes_at_the_same_speeds() {
    let (_tmp, [m, b]) = temp_outs(["map", "bif"]);
    // Row 0 has e = 1 mm (Table 1), row 1 a larger unbalance.
    ok(&map(
        &m,
        &words("--x omega:131.5:133.5:5 --y e:0.001:0.0012:2 --backend cpu"),
    ));
    ok(&jeffcott_out(
        "bifurcation --omega 131.5:133.5:5 --sweep none --ics 1 --max-seeds 0 \
         --brute-transient 300 --periods 32 --backend cpu --no-plot --quiet",
        &b,
    ));
    let mj = json(&m.join("map.json"));
    let bj = json(&b.join("summary.json"));
    let (_, period) = npy::<i32>(&m.join("period.npy"));
    let cells = mj["cell_attractors"].as_array().unwrap();
    let mut classes = Vec::new();
    for (ix, w) in bj["per_omega"].as_array().unwrap().iter().enumerate() {
        let brute = &w["brute_force"]["attractors"][0];
        let cell = &cells[ix]; // row 0
        assert_eq!(
            (cell["ix"].as_u64(), cell["iy"].as_u64()),
            (Some(ix as u64), Some(0))
        );
        let eq = &cell["attractors"][cell["equilibrium"].as_u64().unwrap() as usize];
        assert_eq!(eq["class"], brute["class"], "class at W = {}", w["omega"]);
        assert_eq!(
            eq["period"], brute["period"],
            "period at W = {}",
            w["omega"]
        );
        // The same lane (speed, parameters, start state) on the same backend: its
        // lambda_1 is the same number.
        assert_eq!(
            eq["lambda1"], brute["lambda1"],
            "lambda_1 at W = {}",
            w["omega"]
        );
        let p = brute["period"].as_i64().unwrap_or(0) as i32;
        assert_eq!(period[ix], p);
        classes.push(brute["class"].as_str().unwrap().to_string());
    }
    // The range crosses the article's period-1 -> period-2 and period-5 regimes, so the
    // comparison is not between constant rows.
    classes.dedup();
    assert!(classes.len() >= 2, "{classes:?}");
}

#[test]
fn without_unbalance_no_cell_rubs_and_with_it_the_rotor_does() {
    let tmp = tempfile::tempdir().unwrap();
    let m = tmp.path().join("map");
    ok(&map(
        &m,
        &words("--x omega:120:145:6 --y e:0:0.001:2 --backend cpu --no-lyapunov"),
    ));
    let (shape, contact) = npy::<f64>(&m.join("contact.npy"));
    assert_eq!(shape, vec![2, 6]);
    let (_, force) = npy::<f64>(&m.join("peak_force.npy"));
    let (_, period) = npy::<i32>(&m.join("period.npy"));
    // Row 0: e = 0, the rotor rests at its static sag (0.5 mm, gap 6 mm): period-1,
    // no contact, no force.
    for ix in 0..6 {
        assert_eq!(contact[ix], 0.0, "contact at e = 0, cell {ix}");
        assert_eq!(force[ix], 0.0, "force at e = 0, cell {ix}");
        assert_eq!(period[ix], 1, "period at e = 0, cell {ix}");
    }
    // Row 1: e = 1 mm rubs near the rotor's natural frequency 140 rad/s.
    assert!(
        (6..12).any(|i| contact[i] > 0.0 && force[i] > 0.0),
        "{:?}",
        &contact[6..]
    );
    let mj = json(&m.join("map.json"));
    assert_eq!(mj["cells"], 12);
    assert!(mj["rubbing_cells"].as_u64().unwrap() >= 1);
    for f in ["map_period.png", "map_multistability.png", "run.json"] {
        assert!(m.join(f).exists(), "{f}");
    }
}

/// The figures of cell (ix, iy) of a map: arrays and attractor list.
fn cell_figures(dir: &Path, ix: usize, iy: usize) -> (Vec<u64>, serde_json::Value) {
    let nx = json(&dir.join("map.json"))["x"]["n"].as_u64().unwrap() as usize;
    let c = iy * nx + ix;
    let mut bits = Vec::new();
    for f in ["lambda1.npy", "contact.npy", "peak_force.npy"] {
        bits.push(npy::<f64>(&dir.join(f)).1[c].to_bits());
    }
    for f in ["period.npy", "class.npy", "attractors.npy"] {
        bits.push(npy::<i32>(&dir.join(f)).1[c] as u64);
    }
    let mut cell = json(&dir.join("map.json"))["cell_attractors"][c].clone();
    cell["ix"] = 0.into();
    cell["iy"] = 0.into();
    (bits, cell)
}

fn cells_alone_equal_cells_in_a_map(backend: &str, precision: &str) {
    let tmp = tempfile::tempdir().unwrap();
    let big = tmp.path().join("big");
    let common = ["--ics", "3", "--backend", backend, "--precision", precision];
    let mut a = words("--x omega:132:134:3 --y mu:0:0.2:2");
    a.extend_from_slice(&common);
    ok(&map(&big, &a));
    let mu = ["0", "0.2"];
    for (ix, iy) in [(1, 0), (2, 1)] {
        let w = ["132", "133", "134"][ix];
        let alone = tmp.path().join(format!("alone-{ix}-{iy}"));
        let (xa, ya) = (
            format!("omega:{w}:{w}:1"),
            format!("mu:{}:{}:1", mu[iy], mu[iy]),
        );
        let mut a = vec!["--x", &xa, "--y", &ya];
        a.extend_from_slice(&common);
        ok(&map(&alone, &a));
        assert_eq!(
            cell_figures(&big, ix, iy),
            cell_figures(&alone, 0, 0),
            "cell ({ix}, {iy}) on {backend} {precision}"
        );
    }
}

#[test]
fn cells_computed_in_one_map_equal_the_same_cells_run_alone_on_the_cpu() {
    cells_alone_equal_cells_in_a_map("cpu", "f64");
}

#[test]
fn cells_computed_in_one_map_equal_the_same_cells_run_alone_on_the_gpu() {
    if gpu_f64_present() {
        cells_alone_equal_cells_in_a_map("gpu", "f64");
    }
}

#[test]
fn a_gpu_f64_map_equals_the_cpu_map_bit_for_bit_but_lambda1_within_1e_9() {
    if !gpu_f64_present() {
        return;
    }
    let (_tmp, [c, g]) = temp_outs(["cpu", "gpu"]);
    let axes = words("--x omega:131:135:4 --y delta:0.0055:0.0065:2 --ics 2");
    let mut a = axes.to_vec();
    a.extend_from_slice(&["--backend", "cpu"]);
    ok(&map(&c, &a));
    let mut a = axes.to_vec();
    a.extend_from_slice(&words("--backend gpu --precision f64"));
    ok(&map(&g, &a));
    // The lanes are bit-identical (f64 on lavapipe), so is everything computed from
    // their records and final states. lambda_1 comes from per-period growth factors that
    // the kernel reduces in its own order: within 1e-9 1/s (tests/lyapunov.rs measures
    // ~2e-12), as the lambda_1 parity test allows.
    for f in [
        "period.npy",
        "class.npy",
        "attractors.npy",
        "contact.npy",
        "peak_force.npy",
    ] {
        assert_eq!(
            std::fs::read(c.join(f)).unwrap(),
            std::fs::read(g.join(f)).unwrap(),
            "{f}"
        );
    }
    let (_, lc) = npy::<f64>(&c.join("lambda1.npy"));
    let (_, lg) = npy::<f64>(&g.join("lambda1.npy"));
    for (a, b) in lc.iter().zip(&lg) {
        assert!((a - b).abs() < 1e-9, "lambda_1 {a} vs {b}");
    }
    let strip = |mut v: serde_json::Value| {
        for cell in v.as_array_mut().unwrap() {
            for a in cell["attractors"].as_array_mut().unwrap() {
                a["lambda1"] = serde_json::Value::Null;
            }
        }
        v
    };
    assert_eq!(
        strip(json(&c.join("map.json"))["cell_attractors"].clone()),
        strip(json(&g.join("map.json"))["cell_attractors"].clone())
    );
}

#[test]
fn per_lane_parameters_on_the_gpu_equal_the_cpu_lanes_bit_for_bit_in_f64() {
    if !gpu_f64_present() {
        return;
    }
    // Every lane its own parameter set: friction, gap, unbalance, contact stiffness and
    // damping all differ, and every lane rubs at some point.
    let mut param_sets = Vec::new();
    let mut lanes = Vec::new();
    for i in 0..24u32 {
        let p = Params {
            mu: 0.05 * (i % 5) as f64,
            delta: 0.0055 + 0.0001 * (i % 7) as f64,
            e: 0.0008 + 0.0001 * (i % 4) as f64,
            k_c: 5e7 * (1 + i % 3) as f64,
            c_c: 1e3 * (i % 2) as f64,
            ..Params::default()
        };
        lanes.push(LaneSpec {
            omega: 131.0 + 0.4 * i as f64,
            x0: {
                let mut x = p.static_equilibrium();
                x[0] = 0.005;
                x
            },
            param_set: i,
        });
        param_sets.push(p);
    }
    let spec = EnsembleSpec {
        param_sets,
        lanes,
        transient: 20,
        recorded: 10,
        stepper: StepperConfig {
            steps_per_period: 200,
            ..Default::default()
        },
        precision: Precision::F64,
    };
    let none = |_: u64, _: u64| {};
    let (cpu, _) =
        jeffcott_analysis::backend::run(&spec, Backend::Cpu, false, Control::progress(&none))
            .unwrap();
    let (gpu, _) =
        jeffcott_analysis::backend::run(&spec, Backend::Gpu, false, Control::progress(&none))
            .unwrap();
    assert!(cpu.counters.iter().all(|c| c.contact_steps > 0));
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&cpu.poincare), bits(&gpu.poincare));
    assert_eq!(cpu.status, gpu.status);
}

#[test]
fn a_killed_map_resumes_to_the_files_of_an_uninterrupted_run() {
    let (_tmp, [r, k]) = temp_outs(["ref", "killed"]);
    let axes = words("--x omega:131:135:8 --y e:0.0009:0.0011:3 --backend cpu --chunk 2 --no-plot");
    ok(&map(&r, &axes));
    // Kill once the first units are committed, then resume.
    let mut a = vec!["map", "--out", k.to_str().unwrap()];
    a.extend_from_slice(RUN);
    a.extend_from_slice(&axes);
    let mut child = Command::new(env!("CARGO_BIN_EXE_jeffcott"))
        .args(&a)
        .spawn()
        .unwrap();
    let t = std::time::Instant::now();
    loop {
        let n = std::fs::read_dir(k.join("units"))
            .map(|d| d.count())
            .unwrap_or(0);
        if n >= 3 || t.elapsed().as_secs() > 120 {
            break;
        }
        if child.try_wait().unwrap().is_some() {
            break;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    ok(&jeffcott(&a));
    for f in map_files() {
        assert_eq!(
            std::fs::read(r.join(f)).unwrap(),
            std::fs::read(k.join(f)).unwrap(),
            "{f}"
        );
    }
}

#[test]
fn bad_axes_are_refused_naming_the_option_and_range() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("m");
    let cases: &[(&str, &[&str])] = &[
        (
            "--x speed:1:2:3 --y e:0:1e-3:2",
            &["x", "unknown axis", "omega"],
        ),
        ("--x omega:130:140:3 --y omega:1:2:2", &["y", "different"]),
        ("--x e:0:1e-3:3 --y mu:0:0.1:2", &["omega", "--omega"]),
        (
            "--x omega:130:140:3 --y delta:-1e-3:1e-3:2",
            &["x, y", "delta"],
        ),
        (
            "--x omega:130:140:3 --y e:0:1e-3:2 --log-y",
            &["y", "lo > 0"],
        ),
        ("--x omega:140:130:3 --y e:0:1e-3:2", &["x", "lo < hi"]),
        ("--x omega:130:140:3 --y e:0:1e-3:2 --ics 0", &["ics"]),
    ];
    for (args, needles) in cases {
        assert_refused_naming(&map(&out, &words(args)), args, needles);
        assert!(!out.join("map.json").exists());
    }
}
