//! `basin --refine K`: what it proves: every integrated point of a refined basin has the
//! label the full fine grid gives that start state, and at W = 133 the refined labels
//! (interiors filled from their parents) agree with the full fine grid in >= 99 % of all
//! points, for fewer lanes than the fine grid.

mod common;
use common::*;

use std::path::Path;

/// Labels as attractor classes (ids differ between runs; at 133 every class is one
/// attractor).
fn classes(dir: &Path) -> Vec<String> {
    let j = json(&dir.join("attractors.json"));
    let name = |l: i32| {
        j["attractors"]
            .as_array()
            .unwrap()
            .iter()
            .find(|a| a["id"] == l)
            .map(|a| a["class"].as_str().unwrap().to_string())
            .unwrap_or_else(|| l.to_string())
    };
    npy::<i32>(&dir.join("labels.npy"))
        .1
        .into_iter()
        .map(name)
        .collect()
}

#[test]
fn a_refined_basin_has_the_fine_grids_labels_where_it_integrated_and_at_99_percent_overall() {
    let (_tmp, [r, f]) = temp_outs(["refined", "fine"]);
    // The two runs differ in their grids only.
    let basin = |y: &str, x: &str| {
        format!(
            "basin --omega 133 --y {y} --transient 250 --steps-per-period 250 --periods 32 \
             --backend cpu --quiet --no-plot --uncertainty-samples 0 --x {x}"
        )
    };
    let coarse = basin("vx_r:-1:1:15", "x_r:-0.006:0.006:15");
    ok(&jeffcott_out(&format!("{coarse} --refine 2"), &r));
    ok(&jeffcott_out(
        &basin("vx_r:-1:1:57", "x_r:-0.006:0.006:57"),
        &f,
    ));
    let (shape, computed) = npy::<u8>(&r.join("refined.npy"));
    assert_eq!(shape, vec![57, 57]);
    let (rl, fl) = (classes(&r), classes(&f));
    assert_eq!(rl.len(), 57 * 57);
    let mut at_computed = 0;
    for p in 0..rl.len() {
        if computed[p] == 1 {
            at_computed += 1;
            assert_eq!(rl[p], fl[p], "integrated point {p}");
        }
    }
    let agree = (0..rl.len()).filter(|&p| rl[p] == fl[p]).count() as f64 / rl.len() as f64;
    assert!(agree >= 0.99, "refined and fine grids agree at {agree}");
    let run = json(&r.join("run.json"));
    let lanes = run["refinement"]["lanes"].as_u64().unwrap() as usize + 15 * 15;
    assert_eq!(lanes, at_computed);
    assert!(lanes < 57 * 57, "{lanes} lanes");
    // The measures are computed on the fine grid.
    let m = json(&r.join("basin_metrics.json"));
    assert_eq!(m["fractions"]["cells"], 57 * 57);
}
