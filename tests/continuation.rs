//! `jeffcott continuation`: attractors followed over a parameter. What they prove: over
//! a monostable range one attractor keeps one id with fraction 1 in both ramps; at
//! W = 133 the coexisting period-4 and period-5 attractors are both tracked and their
//! fractions (uniform start states in a box) agree with `basin` over that box within
//! their errors; every tipping row with a basin sums to 1; bad input is refused.

mod common;
use common::*;
use std::process::Output;

use std::path::Path;

/// Runs a continuation into `out` with the options `extra` (`common::words`).
fn continuation(out: &Path, extra: &str) -> Output {
    let mut a = vec!["continuation", "--out", out.to_str().unwrap()];
    a.extend(words("--transient 300 --periods 32 --backend cpu --quiet"));
    a.extend(words(extra));
    jeffcott(&a)
}

#[test]
fn over_a_monostable_range_one_attractor_keeps_its_id_with_fraction_one() {
    let (_tmp, out) = temp_out("c");
    ok(&continuation(&out, "--vary omega:131.3:131.7:5 --ics 16"));
    let j = json(&out.join("continuation.json"));
    for d in ["up", "down"] {
        let ramp = &j["ramps"][d];
        assert_eq!(ramp["attractors"].as_array().unwrap().len(), 1, "{d}");
        for s in ramp["steps"].as_array().unwrap() {
            let a = s["attractors"].as_array().unwrap();
            assert_eq!(a.len(), 1, "{d} at {}", s["value"]);
            assert_eq!(a[0]["id"], 0);
            assert_eq!(a[0]["fraction"], 1.0);
            assert_eq!(a[0]["error"], 0.0);
        }
        let (shape, f) = npy::<f64>(&out.join(format!("fractions_{d}.npy")));
        assert_eq!(shape, vec![5, 2]);
        assert!(f.chunks(2).all(|r| r == [1.0, 0.0]), "{f:?}");
    }
    assert!(out.join("continuation.png").exists());
}

#[test]
fn at_133_the_period_4_and_period_5_attractors_are_tracked_with_the_fractions_of_basin() {
    let (_tmp, [c, b]) = temp_outs(["c", "b"]);
    ok(&continuation(
        &c,
        "--vary omega:132.9:133.1:3 --box x_r:-0.006:0.006,vx_r:-1:1 --ics 96",
    ));
    ok(&jeffcott_out(
        "basin --omega 133 --x x_r:-0.006:0.006:40 --y vx_r:-1:1:40 --transient 250 --periods 32 \
         --backend cpu --no-plot --quiet",
        &b,
    ));
    let basin = json(&b.join("attractors.json"));
    let basin_fraction = |class: &str| {
        of_class(&basin["attractors"], class)
            .map(|a| a["basin_fraction"].as_f64().unwrap())
            .unwrap_or_else(|| panic!("basin has no {class}"))
    };
    let j = json(&c.join("continuation.json"));
    for d in ["up", "down"] {
        let step = &j["ramps"][d]["steps"][1];
        assert_eq!(step["value"], 133.0);
        for class in ["period-4", "period-5"] {
            let a = of_class(&step["attractors"], class)
                .unwrap_or_else(|| panic!("{d}: no {class} at 133"));
            let (f, e) = (
                a["fraction"].as_f64().unwrap(),
                a["error"].as_f64().unwrap(),
            );
            let fb = basin_fraction(class);
            // 96 uniform samples against a dense grid over the same box: within 3
            // standard errors (measured: 1.2).
            assert!(
                (f - fb).abs() <= 3.0 * e,
                "{d} {class}: {f} +- {e} vs basin {fb}"
            );
        }
    }
}

#[test]
fn every_tipping_row_with_a_basin_sums_to_one() {
    let (_tmp, out) = temp_out("c");
    ok(&continuation(&out, "--vary omega:132.6:133.4:5 --ics 24"));
    for d in ["up", "down"] {
        let (shape, t) = npy::<f64>(&out.join(format!("tipping_{d}.npy")));
        let g = shape[1] as usize;
        assert_eq!(shape, vec![4, g as u64, g as u64]);
        let mut rows = 0;
        for row in t.chunks(g) {
            if row[0].is_nan() {
                assert!(row.iter().all(|v| v.is_nan()));
                continue;
            }
            rows += 1;
            let s: f64 = row.iter().sum();
            assert!((s - 1.0).abs() < 1e-12, "{d}: row sums to {s}");
        }
        assert!(rows >= 4, "{d}: {rows} rows with a basin");
    }
    // Several attractors meet in this range: the ramps follow more than one.
    let j = json(&out.join("continuation.json"));
    assert!(j["ramps"]["up"]["attractors"].as_array().unwrap().len() >= 2);
}

#[test]
fn bad_continuations_are_refused_naming_the_option() {
    let tmp = tempfile::tempdir().unwrap();
    let out = tmp.path().join("c");
    let cases: &[(&str, &[&str])] = &[
        ("--vary omega:130:130:1", &["vary", "at least 2"]),
        ("--vary mu:0:0.3:4", &["omega", "--omega"]),
        (
            "--vary x_r:0:0.001:4 --omega 133",
            &["vary", "start coordinate"],
        ),
        (
            "--vary delta:-0.001:0.006:4 --omega 133",
            &["vary", "delta"],
        ),
        (
            "--vary omega:130:131:3 --box x_r:-2:2",
            &["box", "divergence-bound"],
        ),
        (
            "--vary omega:130:131:3 --box spin:0:1",
            &["box", "unknown coordinate"],
        ),
        (
            "--vary omega:130:131:3 --match-threshold 0",
            &["match-threshold"],
        ),
        // The continued range given where a model-parameter override goes.
        (
            "--vary omega:130:131:3 --param mu:0:0.3:4",
            &["param", "--vary"],
        ),
        ("--vary omega:130:131:3 --param ''", &["param", "empty"]),
    ];
    for (args, needles) in cases {
        assert_refused_naming(&continuation(&out, args), args, needles);
    }
}

#[test]
fn model_parameter_overrides_reach_a_continuation_beside_the_continued_parameter() {
    // `--param NAME=VALUE` (every command's override) and `--vary NAME:lo:hi:n` (the
    // continued parameter) are two spellings; both reach the specification.
    let (_tmp, out) = temp_out("c");
    let mut a = vec!["continuation", "--out", out.to_str().unwrap()];
    a.extend(words(
        "--transient 20 --periods 4 --backend cpu --quiet --no-plot --no-lyapunov \
         --vary e:0.0005:0.001:2 --omega 131 --ics 2 --param mu=0.15",
    ));
    ok(&jeffcott(&a));
    let run = json(&out.join("run.json"));
    assert_eq!(run["spec"]["params"]["mu"], 0.15, "{}", run["spec"]);
    assert_eq!(run["spec"]["param"]["var"], "e", "{}", run["spec"]);
}
