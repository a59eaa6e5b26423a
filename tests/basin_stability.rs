//! `jeffcott basin-stability`: what it proves: the fractions of uniform draws in a box
//! agree with a dense basin grid over the same box within their 95 % intervals; more than
//! two coordinates and a speed range work, with the stacked plot; bad boxes are refused.

mod common;
use common::*;

/// The options every run of this file shares.
const RUN: &str = "--transient 250 --periods 32 --backend cpu --quiet";

#[test]
fn basin_stability_agrees_with_a_dense_grid_over_the_same_box_within_its_95_percent_intervals() {
    let (_tmp, [s, b]) = temp_outs(["s", "b"]);
    let sample = "basin-stability --omega 133 --sample 160 --box x_r:-0.006:0.006,vx_r:-1:1";
    ok(&jeffcott_out(&format!("{sample} {RUN}"), &s));
    let grid = "basin --omega 133 --x x_r:-0.006:0.006:40 --y vx_r:-1:1:40 --no-plot";
    ok(&jeffcott_out(&format!("{grid} {RUN}"), &b));
    let grid = json(&b.join("attractors.json"));
    let st = json(&s.join("basin_stability.json"));
    let found = st["per_omega"][0]["attractors"].as_array().unwrap();
    for class in ["period-4", "period-5"] {
        let g = of_class(&grid["attractors"], class).unwrap()["basin_fraction"]
            .as_f64()
            .unwrap();
        let a = found.iter().find(|a| a["class"] == class).unwrap();
        let (lo, hi) = (
            a["ci95"][0].as_f64().unwrap(),
            a["ci95"][1].as_f64().unwrap(),
        );
        assert!(lo <= g && g <= hi, "{class}: grid {g} outside [{lo}, {hi}]");
    }
}

#[test]
fn four_coordinates_and_a_speed_range_give_fractions_summing_to_one_and_a_stacked_plot() {
    let tmp = tempfile::tempdir().unwrap();
    let s = tmp.path().join("s");
    let sample = "basin-stability --omega 132:134:3 --sample 24 \
                  --box x_r:-0.006:0.006,vx_r:-1:1,y_r:-0.006:0.0,vy_r:-0.5:0.5";
    ok(&jeffcott_out(&format!("{sample} {RUN}"), &s));
    let bytes = std::fs::read(s.join("fractions.npy")).unwrap();
    let f = npyz::NpyFile::new(&bytes[..]).unwrap();
    let g = f.shape()[1] as usize;
    let v: Vec<f64> = f.into_vec().unwrap();
    for row in v.chunks(g) {
        assert!((row.iter().sum::<f64>() - 1.0).abs() < 1e-12, "{row:?}");
    }
    assert!(s.join("basin_stability.png").exists());
    for (bad, needle) in [
        ("x_r:-2:2", "divergence-bound"),
        ("x_r:0.001:-0.001", "lo <= hi"),
        ("x_r:0:1e-3,x_r:0:1e-3", "twice"),
    ] {
        let line = format!("basin-stability --omega 133 --box {bad}");
        let o = jeffcott_out(&line, tmp.path().join("bad"));
        assert_eq!(o.status.code(), Some(2), "{bad}");
        assert!(String::from_utf8_lossy(&o.stderr).contains(needle), "{bad}");
    }
}
