//! What a rotordynamics engineer reads: full spectra, rub figures and regimes, contact
//! loads, cascades, CSV. What they prove: the full spectrum separates forward from
//! backward whirl with the analytic amplitudes; free flight is the linear unbalance
//! response and never rubs; period-1 has lines at multiples of 1X only and period-2 adds
//! 1/2X; full annular rub and backward whirl are found and stable under doubling the
//! record; the contact statistics are those of the time series.

mod common;
use common::*;

use jeffcott_analysis::spectrum::{Whirl, full_spectrum, line, whirl};
use rustfft::num_complex::Complex64;
use std::path::Path;

/// z(t) = a cos(w t) + i b sin(w t) sampled 200 times per period over `p` periods.
fn ellipse(a: f64, b: f64, p: u32) -> Vec<Complex64> {
    let n = 200 * p as usize;
    (0..n)
        .map(|k| {
            let th = std::f64::consts::TAU * k as f64 / 200.0;
            Complex64::new(a * th.cos(), b * th.sin())
        })
        .collect()
}

#[test]
fn full_spectra_of_circles_and_ellipses_separate_forward_and_backward_whirl() {
    let w = 130.0;
    let fwd = full_spectrum(&ellipse(2e-3, 2e-3, 12), 12, w);
    assert!(
        (line(&fwd, 1.0) - 2e-3).abs() < 1e-15,
        "{}",
        line(&fwd, 1.0)
    );
    assert!(line(&fwd, -1.0) < 1e-18);
    assert_eq!(whirl(&fwd).0, Whirl::Forward);
    let bwd = full_spectrum(&ellipse(2e-3, -2e-3, 12), 12, w);
    assert!((line(&bwd, -1.0) - 2e-3).abs() < 1e-15);
    assert!(line(&bwd, 1.0) < 1e-18);
    assert_eq!(whirl(&bwd).0, Whirl::Backward);
    // An ellipse: (a + b)/2 forward and (a - b)/2 backward, ratio (a - b)/(a + b).
    let (a, b) = (3e-3, 1e-3);
    let el = full_spectrum(&ellipse(a, b, 12), 12, w);
    assert!((line(&el, 1.0) - (a + b) / 2.0).abs() < 1e-15);
    assert!((line(&el, -1.0) - (a - b) / 2.0).abs() < 1e-15);
    let ratio = line(&el, -1.0) / line(&el, 1.0);
    assert!((ratio - (a - b) / (a + b)).abs() < 1e-12, "{ratio}");
    // Frequencies: order k/P, Hz = order W / 2 pi.
    let k = el.order.iter().position(|&o| o == 1.0).unwrap();
    assert!((el.hz[k] - w / std::f64::consts::TAU).abs() < 1e-12);
    // Parseval for the transform itself.
    let z = ellipse(a, b, 3);
    let x = jeffcott_analysis::spectrum::dft(&z);
    let lhs: f64 = x.iter().map(|v| v.norm_sqr()).sum();
    let rhs = z.iter().map(|v| v.norm_sqr()).sum::<f64>() * z.len() as f64;
    assert!((lhs - rhs).abs() < 1e-12 * rhs);
}

fn simulate(out: &Path, extra: &[&str]) -> serde_json::Value {
    let mut a = vec!["simulate", "--out", out.to_str().unwrap(), "--quiet"];
    a.extend_from_slice(extra);
    ok(&jeffcott(&a));
    json(&out.join("summary.json"))
}

#[test]
fn free_flight_never_rubs_and_its_spectrum_is_the_linear_unbalance_response() {
    let tmp = tempfile::tempdir().unwrap();
    let w = 100.0;
    let s = simulate(
        &tmp.path().join("free"),
        &words("--omega 100 --param delta=0.5 --transient 1000 --periods 24"),
    );
    assert_eq!(s["rub"]["regime"], "no_contact");
    assert_eq!(s["rub"]["figures"]["contact_fraction"], 0.0);
    let (_, spec) = npy::<f64>(&tmp.path().join("free/full_spectrum.npy"));
    let rows: Vec<&[f64]> = spec.chunks(4).collect();
    let at = |o: f64| rows.iter().find(|r| (r[0] - o).abs() < 1e-12).unwrap()[2];
    let p = jeffcott_core::model::Params::default();
    let (amp, _) = jeffcott_core::model::linear_unbalance_response(&p, w);
    assert!(
        (at(1.0) - amp).abs() < 1e-6 * amp,
        "+1X {} vs {amp}",
        at(1.0)
    );
    // The model is isotropic: gravity shifts the orbit (the 0X line is the static sag
    // a_g / w_r^2) and adds no ellipticity, so there is no -1X line.
    let sag = p.a_g / (p.omega_r * p.omega_r);
    assert!(
        (at(0.0) - sag).abs() < 1e-6 * sag,
        "0X {} vs {sag}",
        at(0.0)
    );
    assert!(at(-1.0) < 1e-9 * amp, "-1X {}", at(-1.0));
}

#[test]
fn period_1_has_lines_at_multiples_of_1x_only_and_period_2_adds_a_half_x_line() {
    let tmp = tempfile::tempdir().unwrap();
    let top_and_fractional = |dir: &Path| {
        let (_, spec) = npy::<f64>(&dir.join("full_spectrum.npy"));
        let rows: Vec<&[f64]> = spec.chunks(4).collect();
        let top = rows.iter().map(|r| r[2]).fold(0.0, f64::max);
        let half = rows.iter().find(|r| (r[0] - 0.5).abs() < 1e-12).unwrap()[2];
        // Away from the integer orders by more than the Hann window's main lobe (one bin,
        // 1/24 of an order at the default 24 periods on either side).
        let frac = rows
            .iter()
            .filter(|r| (r[0] - r[0].round()).abs() > 1.5 / 24.0)
            .map(|r| r[2])
            .fold(0.0, f64::max);
        (top, half, frac)
    };
    let s = simulate(&tmp.path().join("p1"), &["--omega", "131.7"]);
    assert_eq!(s["class"], "period-1");
    assert_eq!(s["rub"]["regime"], "partial_rub");
    let (top, _, frac) = top_and_fractional(&tmp.path().join("p1"));
    assert!(frac < 1e-12 * top, "a non-integer line {frac} at period-1");
    let s = simulate(&tmp.path().join("p2"), &["--omega", "132.2"]);
    assert_eq!(s["class"], "period-2");
    assert_eq!(s["rub"]["regime"], "partial_rub");
    let (top, half, _) = top_and_fractional(&tmp.path().join("p2"));
    assert!(
        half > 1e-3 * top,
        "1/2X {half} against the largest line {top}"
    );
    let names: Vec<&str> = s["rub"]["rotor_lines"]
        .as_array()
        .unwrap()
        .iter()
        .map(|l| l["name"].as_str().unwrap())
        .collect();
    assert!(names.contains(&"+1/2X"), "{names:?}");
}

/// The regime of a run with `args` over `periods` spectrum periods.
fn regime(dir: &Path, args: &[&str], periods: &str) -> (String, serde_json::Value) {
    let mut a = args.to_vec();
    a.extend_from_slice(&["--spectrum-periods", periods, "--no-plot"]);
    let s = simulate(dir, &a);
    (
        s["rub"]["regime"].as_str().unwrap().to_string(),
        s["rub"]["figures"].clone(),
    )
}

#[test]
fn full_annular_rub_and_backward_whirl_are_found_and_stable_under_doubling_the_record() {
    let tmp = tempfile::tempdir().unwrap();
    // Table 1 at 155 rad/s: the orbit outgrows the gap and stays on the stator all round.
    let annular = ["--omega", "155"];
    // Soft contact and friction, the rotor thrown backward into the stator (docs/rub.md).
    let backward = words("--omega 140 --param mu=0.25,k_c=1e6 --init x_r=0.0065,vy_r=-1");
    for (name, args, expect) in [
        ("annular", &annular[..], "full_annular_rub"),
        ("backward", &backward[..], "backward_whirl"),
    ] {
        for p in ["24", "48"] {
            let (r, f) = regime(&tmp.path().join(format!("{name}-{p}")), args, p);
            assert_eq!(r, expect, "{name} over {p} periods: {f}");
        }
    }
    let (_, f) = regime(&tmp.path().join("annular-check"), &annular, "24");
    assert!(f["contact_fraction"].as_f64().unwrap() >= 0.99);
    assert!(f["contact_arc_deg"].as_f64().unwrap() >= 355.0);
    let (_, f) = regime(&tmp.path().join("backward-check"), &backward, "24");
    assert_eq!(f["whirl"], "backward");
}

#[test]
fn contact_statistics_equal_those_integrated_from_the_time_series() {
    let tmp = tempfile::tempdir().unwrap();
    let dir = tmp.path().join("s");
    // A period-1 attractor: the stretch continued from the final state repeats the last
    // recorded periods, so the time series gives the same statistics.
    let s = simulate(
        &dir,
        &words("--omega 131.7 --periods 24 --timeseries-periods 24 --spectrum-periods 24 --csv"),
    );
    let (shape, ts) = npy::<f64>(&dir.join("timeseries.npy"));
    assert_eq!(shape[1], 9);
    let p = jeffcott_core::model::Params::default();
    let (mut n, mut inc, mut sum, mut peak) = (0usize, 0usize, 0.0, 0.0f64);
    for r in ts.chunks(9).skip(1) {
        n += 1;
        let g = ((r[1] - r[5]).powi(2) + (r[3] - r[7]).powi(2)).sqrt() - p.delta;
        if g > 0.0 {
            inc += 1;
            sum += p.k_c * g;
            peak = peak.max(p.k_c * g);
        }
    }
    let f = &s["rub"]["figures"];
    let rel = |a: f64, b: f64| (a - b).abs() / b.abs().max(1e-300);
    assert!(
        rel(
            f["contact_fraction"].as_f64().unwrap(),
            inc as f64 / n as f64
        ) < 1e-9
    );
    assert!(rel(f["peak_force_n"].as_f64().unwrap(), peak) < 1e-4, "{f}");
    assert!(
        rel(f["mean_force_n"].as_f64().unwrap(), sum / inc as f64) < 1e-4,
        "{f}"
    );
    // contact.npy holds the normal force of each grid point, and the CSV twin the same.
    let (cshape, c) = npy::<f64>(&dir.join("contact.npy"));
    assert_eq!(cshape[1], 5);
    let cpeak = c.chunks(5).map(|r| r[4]).fold(0.0, f64::max);
    assert!(rel(cpeak, f["peak_force_n"].as_f64().unwrap()) < 1e-12);
    let csv = std::fs::read_to_string(dir.join("timeseries.csv")).unwrap();
    let mut lines = csv.lines();
    assert_eq!(
        lines.next().unwrap(),
        "t_s,x_r,vx_r,y_r,vy_r,x_s,vx_s,y_s,vy_s"
    );
    let row: Vec<f64> = lines
        .next()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(row, ts[..9].to_vec(), "CSV rows round-trip the NPY values");
    for f in [
        "full_spectrum.csv",
        "contact.csv",
        "full_spectrum.png",
        "contact.png",
    ] {
        assert!(dir.join(f).exists(), "{f}");
    }
}

#[test]
fn a_cascade_shows_no_contact_below_the_rub_band_and_hysteresis_above_it() {
    let (_tmp, out) = jeffcott_ok(
        "c",
        "cascade --omega 120:170:26 --transient 100 --periods 12 --quiet",
    );
    let (shape, amp) = npy::<f64>(&out.join("cascade.npy"));
    assert_eq!(shape[..2], [2, 26]);
    let bins = shape[2] as usize;
    let (_, orders) = npy::<f64>(&out.join("orders.npy"));
    let one = orders.iter().position(|&o| o == 1.0).unwrap();
    let bytes = std::fs::read(out.join("regime.npy")).unwrap();
    let regime: Vec<i32> = npyz::NpyFile::new(&bytes[..]).unwrap().into_vec().unwrap();
    // 120 rad/s (first speed): below the rub band, no contact on either sweep, and the
    // strongest non-static line is +1X.
    for sweep in 0..2 {
        assert_eq!(regime[sweep * 26], 0, "sweep {sweep} at 120 rad/s");
        let row = &amp[sweep * 26 * bins..(sweep * 26 + 1) * bins];
        let best = (0..bins)
            .filter(|&k| orders[k].abs() > 0.05)
            .max_by(|&a, &b| row[a].total_cmp(&row[b]))
            .unwrap();
        assert_eq!(best, one);
    }
    // At 170 rad/s the run-up is still in full annular rub, the run-down (from above) free.
    assert_eq!(regime[25], 2, "run-up at 170: {:?}", &regime[..26]);
    assert_eq!(regime[26 + 25], 0, "run-down at 170: {:?}", &regime[26..]);
    assert!(out.join("cascade_up.png").exists() && out.join("cascade_down.png").exists());
}
