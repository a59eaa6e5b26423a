//! Lyapunov spectra (docs/model.md 5 and 6): the sum rule, the analytic free-flight
//! exponents, a periodic attractor, the saltation matrix at contact switches, and the
//! largest exponent of the ensemble lanes against the full spectrum.

use jeffcott_core::control::Control;
use jeffcott_core::integrate::lane::{
    Lane, LaneConsts, StepperConfig, Tangent, advance_period, macro_step_tangent,
};
use jeffcott_core::lyapunov::{Spectrum, SpectrumConfig, spectrum};
use jeffcott_core::model::{Params, STATE_DIM, State};

mod common;
use common::{jeffcott, jeffcott_ok, jeffcott_out, json, ok, words};

/// -2 (2 xi_r w_r + 2 xi_s w_s) for Table 1 (docs/model.md 6) [1/s].
const TABLE1_TRACE: f64 = -2.0 * (2.0 * 0.02 * 140.0 + 2.0 * 0.05 * 540.0);

fn config(max_time: f64) -> SpectrumConfig {
    SpectrumConfig {
        transient: 500,
        min_time: max_time,
        max_time,
        ..SpectrumConfig::default()
    }
}

fn run(p: &Params, omega: f64, cfg: &SpectrumConfig) -> Spectrum {
    let s = spectrum(p, omega, &p.static_equilibrium(), cfg).expect("spectrum");
    eprintln!(
        "W = {omega}, c_c = {}: exponents {:?} +- {:?}, sum {:.5}, <tr J> {:.5}, saltation \
         rate {:e}, {} saltations (max |S - I| {:.3e}), {:.1} s in {:.2} s",
        p.c_c,
        s.exponents.map(|v| (v * 1e3).round() / 1e3),
        s.errors.map(|v| (v * 1e4).round() / 1e4),
        s.sum,
        s.trace_average,
        s.saltation_log_det_rate,
        s.saltations,
        s.max_saltation_deviation,
        s.integration_time,
        s.wall_time_s
    );
    s
}

/// The sum rule with its two sides computed independently: the exponents from the QR
/// factors, the trace from the Jacobian at the RK4 stages, the saltation term from the
/// matrices applied.
fn assert_sum_rule(s: &Spectrum, rel: f64) {
    let rhs = s.trace_average + s.saltation_log_det_rate;
    assert!(
        (s.sum - rhs).abs() <= rel * rhs.abs(),
        "sum {} vs <tr J> + saltation rate {rhs}",
        s.sum
    );
}

#[test]
fn exponents_sum_to_minus_119_2_per_second_in_periodic_and_aperiodic_regimes() {
    let p = Params::default();
    assert!((TABLE1_TRACE + 119.2).abs() < 1e-9);
    // W = 131.7: period 1 (the article); W = 140: chaotic (lambda_1 > 0 below).
    for omega in [131.7, 140.0] {
        let s = run(&p, omega, &config(30.0));
        assert!(s.saltations > 1000, "the orbit must rub: {}", s.saltations);
        assert!(
            (s.sum - TABLE1_TRACE).abs() <= 0.005 * 119.2,
            "sum {} at W = {omega}",
            s.sum
        );
        assert!((s.trace_average - TABLE1_TRACE).abs() < 1e-6);
        assert_sum_rule(&s, 1e-4);
        if omega == 140.0 {
            assert!(
                s.exponents[0] > 5.0 * s.errors[0] && s.exponents[0] > 1.0,
                "W = 140 should be chaotic: {:?}",
                s.exponents
            );
        }
    }
}

#[test]
fn period_one_response_at_131_7_has_eight_negative_exponents() {
    let p = Params::default();
    let s = run(&p, 131.7, &config(30.0));
    for (l, e) in s.exponents.iter().zip(&s.errors) {
        assert!(l + 3.0 * e < 0.0, "{l} +- {e} in {:?}", s.exponents);
    }
    // The largest is the slow rotor mode, pulled from -2.8 by the contact.
    assert!(s.exponents[0] > -2.8 && s.exponents[0] < -1.0);
}

#[test]
fn free_flight_gives_the_damping_rates_of_the_uncoupled_oscillators() {
    let p = Params {
        delta: 1.0,
        ..Params::default()
    };
    let s = run(&p, 133.0, &config(40.0));
    assert_eq!(s.saltations, 0);
    assert_eq!(s.counters.contact_steps, 0);
    let rotor = -p.xi_r * p.omega_r; // -2.8 1/s
    let stator = -p.xi_s * p.omega_s; // -27 1/s
    let mut got: Vec<(f64, f64)> = s.exponents.into_iter().zip(s.errors).collect();
    got.sort_by(|a, b| b.0.total_cmp(&a.0));
    for (i, (l, e)) in got.iter().enumerate() {
        let want = if i < 4 { rotor } else { stator };
        // Each exponent within its error estimate (the running estimates of a damped
        // oscillator's pair approach -xi w as 1/t, the tangent vectors rotating) ...
        assert!(
            (l - want).abs() <= *e && *e < 0.2,
            "exponent {i}: {l} +- {e} vs {want} ({got:?})"
        );
    }
    // ... and each group's mean exact: it is the log-volume rate of its subspace.
    let mean = |r: std::ops::Range<usize>| got[r.clone()].iter().map(|g| g.0).sum::<f64>() / 4.0;
    assert!((mean(0..4) - rotor).abs() < 1e-3, "{}", mean(0..4));
    assert!((mean(4..8) - stator).abs() < 1e-3, "{}", mean(4..8));
}

/// A state on the attractor at `omega`, `periods` forcing periods from equilibrium.
fn settled(p: &Params, omega: f64, periods: u32) -> State {
    let lc = LaneConsts::<f64>::new(p, omega, &StepperConfig::default());
    let mut lane = Lane::<f64>::new(&p.static_equilibrium(), p.delta);
    for _ in 0..periods {
        advance_period(&lc, &mut lane);
    }
    lane.state_f64()
}

/// The one-period map of the lane stepper from `x` (t = 0), with 8 tangent vectors
/// started at the identity: (the end state, the tangent map as columns, the tangent).
fn period_map(
    p: &Params,
    omega: f64,
    x: &State,
    saltation: bool,
) -> (State, Tangent<f64, STATE_DIM>) {
    let lc = LaneConsts::<f64>::new(p, omega, &StepperConfig::default());
    let mut lane = Lane::<f64>::new(x, p.delta);
    let mut id = [[0.0; STATE_DIM]; STATE_DIM];
    for (i, row) in id.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let mut tan = Tangent::new(id);
    tan.saltation = saltation;
    for _ in 0..lc.n {
        macro_step_tangent(&lc, &mut lane, &mut tan);
    }
    (lane.state_f64(), tan)
}

/// Relative error of the tangent map of one period against central differences of the
/// period map, column j scaled by the step.
fn tangent_vs_finite_differences(p: &Params, omega: f64, x: &State, saltation: bool) -> f64 {
    let (_, tan) = period_map(p, omega, x, saltation);
    let mut num = 0.0;
    let mut den = 0.0;
    for j in 0..STATE_DIM {
        let h = if j % 2 == 0 { 1e-9 } else { 1e-7 };
        let (mut xp, mut xm) = (*x, *x);
        xp[j] += h;
        xm[j] -= h;
        let (fp, _) = period_map(p, omega, &xp, saltation);
        let (fm, _) = period_map(p, omega, &xm, saltation);
        for i in 0..STATE_DIM {
            // Rows scaled like the columns: positions in m, velocities in 100 m/s.
            let w = if i % 2 == 0 { 1.0 } else { 1e-2 } / if j % 2 == 0 { 1.0 } else { 1e-2 };
            let fd = (fp[i] - fm[i]) / (2.0 * h);
            num += (w * (tan.v[j][i] - fd)).powi(2);
            den += (w * fd).powi(2);
        }
    }
    (num / den).sqrt()
}

#[test]
fn saltation_matrix_is_identity_without_contact_damping_and_not_with_it() {
    // The model as specified: the force is k_c g, continuous at g = 0, so S = I at
    // every switch (to the roundoff of evaluating both fields on the surface).
    let p = Params::default();
    let x = settled(&p, 140.0, 300);
    let (_, tan) = period_map(&p, 140.0, &x, true);
    assert!(tan.saltations >= 2, "{} switches", tan.saltations);
    assert!(
        tan.max_saltation_deviation < 1e-8,
        "max |S - I| = {:e}",
        tan.max_saltation_deviation
    );
    assert_eq!(tan.saltation_log_det, 0.0);
    // With a normal dashpot the force jumps by c_c dg/dt: |S - I| ~ c_c / m_r.
    let damped = Params {
        c_c: 5e4,
        ..Params::default()
    };
    let x = settled(&damped, 131.7, 300);
    let (_, tan) = period_map(&damped, 131.7, &x, true);
    assert!(tan.saltations >= 2, "{} switches", tan.saltations);
    assert!(
        tan.max_saltation_deviation > 0.1 * damped.c_c / damped.m_r,
        "max |S - I| = {:e}",
        tan.max_saltation_deviation
    );
    // det S = n.f+ / n.f- = 1 even so: the jump is in the accelerations, g depends on
    // the positions only.
    assert!(tan.saltation_log_det.abs() < 1e-12);
}

#[test]
fn tangent_map_matches_finite_differences_of_the_flow_only_with_saltation() {
    // Without contact damping S = I and both agree with the finite differences.
    let p = Params::default();
    let x = settled(&p, 131.7, 300);
    let with = tangent_vs_finite_differences(&p, 131.7, &x, true);
    let without = tangent_vs_finite_differences(&p, 131.7, &x, false);
    eprintln!("c_c = 0: relative error {with:.2e} with S, {without:.2e} without");
    // The residual is the discretisation error of the tangent map, O((w_c h)^4) with
    // the contact frequency w_c ~ 2000 rad/s and h = T/500 (w_c h ~ 0.2).
    assert!(with < 1e-3 && (with - without).abs() < 1e-3 * with);
    // With contact damping the tangent map is the derivative of the flow only when the
    // saltation matrices are applied.
    let damped = Params {
        c_c: 5e4,
        ..Params::default()
    };
    let x = settled(&damped, 131.7, 300);
    let with = tangent_vs_finite_differences(&damped, 131.7, &x, true);
    let without = tangent_vs_finite_differences(&damped, 131.7, &x, false);
    eprintln!("c_c = 5e4: relative error {with:.2e} with S, {without:.2e} without");
    assert!(with < 1e-3, "with saltation: {with:e}");
    assert!(without > 30.0 * with, "without saltation: {without:e}");
}

#[test]
fn with_contact_damping_the_sum_rule_needs_the_damped_trace_and_holds_with_or_without_s() {
    let p = Params {
        c_c: 5e4,
        ..Params::default()
    };
    let with = run(&p, 131.7, &config(20.0));
    let without = run(
        &p,
        131.7,
        &SpectrumConfig {
            saltation: false,
            ..config(20.0)
        },
    );
    assert!(with.saltations > 100 && without.saltations == 0);
    // The dashpot adds -(c_c/m_r + c_c/m_s) to tr J while in contact, so the sum is
    // far below the undamped -119.2 ...
    assert!(with.trace_average < TABLE1_TRACE - 10.0);
    // ... and equals <tr J> + the saltation log-det rate, which is exactly 0 (det S = 1).
    assert_eq!(with.saltation_log_det_rate, 0.0);
    assert_sum_rule(&with, 1e-4);
    // Leaving S out cannot break the sum rule (det S = 1), so the sum rule alone
    // cannot detect a missing saltation matrix; the finite-difference test above does.
    assert_sum_rule(&without, 1e-4);
    assert!((with.sum - without.sum).abs() < 1e-6 * with.sum.abs());
}

fn is_png(path: &std::path::Path) -> bool {
    std::fs::read(path).is_ok_and(|b| b.starts_with(b"\x89PNG\r\n\x1a\n"))
}

#[test]
fn lyapunov_command_writes_the_spectrum_for_one_speed_and_a_range() {
    let (dir, one) = jeffcott_ok("one", "lyapunov --omega 131.7 --transient 300 --time 5");
    let s = json(&one.join("spectrum.json"));
    assert_eq!(s["omega"], 131.7);
    let exps = s["exponents"].as_array().unwrap();
    let bits = s["exponents_bits"].as_array().unwrap();
    assert_eq!((exps.len(), bits.len()), (8, 8));
    let l0 = exps[0].as_f64().unwrap();
    assert!((bits[0].as_f64().unwrap() - l0 / std::f64::consts::LN_2).abs() < 1e-12);
    for key in [
        "sum",
        "trace_average",
        "saltation_log_det_rate",
        "integration_time",
    ] {
        assert!(s[key].is_number(), "{key}");
    }
    // The wall time is run.json's only, so a re-run's spectrum.json is byte-identical.
    assert!(s.get("wall_time_s").is_none());
    assert!(json(&one.join("run.json"))["wall_time_s"].is_number());
    assert_eq!(s["errors"].as_array().unwrap().len(), 8);
    assert!(is_png(&one.join("convergence.png")));

    let range = dir.path().join("range");
    ok(&jeffcott_out(
        "lyapunov --omega 131:133:3 --transient 200 --time 3 --param c_c=1e4",
        &range,
    ));
    let bytes = std::fs::read(range.join("lyapunov.npy")).unwrap();
    let header = String::from_utf8_lossy(&bytes[..128]).replace(' ', "");
    assert!(header.contains("'shape':(3,8)") || header.contains("'shape':(3,8,)"));
    assert!(is_png(&range.join("lyapunov.png")));
    let j = json(&range.join("lyapunov.json"));
    assert_eq!(j["omega"].as_array().unwrap().len(), 3);
    assert_eq!(j["run"]["params"]["c_c"], 1e4);

    // Bad input: a clear error naming the option, exit code 2.
    let o = jeffcott(&words("lyapunov --omega 131.7 --time -1"));
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("`time`"));
    let o = jeffcott(&words("lyapunov --omega 131.7 --param c_c=-1"));
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("c_c"));
}

/// An ensemble of one parameter set per entry of `params`, every lane from the static
/// equilibrium, f64.
fn ensemble_spec(
    lanes: &[(f64, Params)],
    transient: u32,
    recorded: u32,
) -> jeffcott_core::ensemble::EnsembleSpec {
    use jeffcott_core::ensemble::{EnsembleSpec, LaneSpec, Precision};
    EnsembleSpec {
        param_sets: lanes.iter().map(|(_, p)| p.clone()).collect(),
        lanes: lanes
            .iter()
            .enumerate()
            .map(|(i, (omega, p))| LaneSpec {
                omega: *omega,
                x0: p.static_equilibrium(),
                param_set: i as u32,
            })
            .collect(),
        transient,
        recorded,
        stepper: StepperConfig::default(),
        precision: Precision::F64,
    }
}

#[test]
fn cpu_lambda1_of_a_lane_agrees_with_the_first_exponent_of_the_full_spectrum() {
    let p = Params::default();
    let cfg = config(20.0);
    for omega in [131.7, 140.0] {
        let s = run(&p, omega, &cfg);
        // The same accumulation window: the spectrum's tangents start after its
        // transient and align over `tangent_transient` periods, the lane's start
        // `lyapunov_align` periods before its record.
        let mut spec = ensemble_spec(
            &[(omega, p.clone())],
            cfg.transient + cfg.tangent_transient,
            s.periods,
        );
        spec.stepper.lyapunov_align = cfg.tangent_transient;
        let res = jeffcott_core::ensemble::cpu::run(&spec, true, Control::none()).unwrap();
        let l1 = res.lambda1.as_ref().unwrap()[0];
        eprintln!(
            "W = {omega}: lane lambda_1 {l1:.5}, spectrum {:.5} +- {:.1e}",
            s.exponents[0], s.errors[0]
        );
        assert!(
            (l1 - s.exponents[0]).abs() <= s.errors[0],
            "W = {omega}: {l1} vs {} +- {}",
            s.exponents[0],
            s.errors[0]
        );
        // The plain run records the same points and computes no exponent.
        let plain = jeffcott_core::ensemble::cpu::run(&spec, false, Control::none()).unwrap();
        assert!(plain.lambda1.is_none());
        assert_eq!(plain.poincare, res.poincare);
    }
}

/// Eleven lanes at periodic, quasiperiodic and chaotic speeds (one batch of 8 and
/// three lanes stepped alone), with and without contact damping, whose tangent starts
/// at period 25 of a 40-period transient (`lyapunov_align` 15).
fn windowed_spec() -> jeffcott_core::ensemble::EnsembleSpec {
    let speeds = [
        131.7, 132.2, 133.0, 135.0, 137.0, 138.5, 140.0, 141.0, 133.5, 136.0, 139.0,
    ];
    let lanes: Vec<(f64, Params)> = speeds
        .iter()
        .enumerate()
        .map(|(i, &w)| {
            (
                w,
                if i % 3 == 0 {
                    damped()
                } else {
                    Params::default()
                },
            )
        })
        .collect();
    let mut spec = ensemble_spec(&lanes, 40, 10);
    spec.stepper.steps_per_period = 200;
    spec.stepper.lyapunov_align = 15;
    spec
}

#[test]
fn lambda1_with_its_tangent_started_15_periods_before_the_record_is_a_fresh_tangents_from_there_to_the_bit()
 {
    // The windowed run against lanes restarted at period 25 from its states with the
    // tangent over their whole 15-period transient (`lyapunov_align` 0): the same
    // exponents, so the tangent starts afresh at period 25 and nothing before it
    // counts, in the batches and in the lanes stepped alone.
    let spec = windowed_spec();
    let windowed = jeffcott_core::ensemble::cpu::run(&spec, true, Control::none()).unwrap();
    let mut to25 = spec.clone();
    to25.transient = 23;
    to25.recorded = 2;
    let at25 = jeffcott_core::ensemble::cpu::run(&to25, false, Control::none()).unwrap();
    let mut rest = spec.clone();
    rest.transient = 15;
    rest.stepper.lyapunov_align = 0;
    for (l, x) in rest.lanes.iter_mut().zip(&at25.final_state) {
        l.x0 = *x;
    }
    let restarted = jeffcott_core::ensemble::cpu::run(&rest, true, Control::none()).unwrap();
    let (a, b) = (windowed.lambda1.unwrap(), restarted.lambda1.unwrap());
    assert!(a.iter().all(|l| l.is_finite()), "{a:?}");
    for (i, (x, y)) in a.iter().zip(&b).enumerate() {
        assert_eq!(x.to_bits(), y.to_bits(), "lane {i}: {x} against {y}");
    }
    // And the window matters: over the whole transient the exponents differ.
    let mut whole = spec.clone();
    whole.stepper.lyapunov_align = 0;
    let w = jeffcott_core::ensemble::cpu::run(&whole, true, Control::none()).unwrap();
    assert!(w.lambda1.unwrap().iter().zip(&a).any(|(x, y)| x != y));
    assert_eq!(w.poincare, windowed.poincare);
}

#[test]
fn gpu_lambda1_with_its_tangent_started_before_the_record_is_the_cpus_to_the_bit() {
    let Some(runner) = f64_runner() else {
        return;
    };
    let spec = windowed_spec();
    let cpu = jeffcott_core::ensemble::cpu::run(&spec, true, Control::none()).unwrap();
    let gpu =
        jeffcott_analysis::backend::run_on_gpu(&spec, &runner, true, Control::none()).unwrap();
    let (c, g) = (cpu.lambda1.unwrap(), gpu.lambda1.unwrap());
    for (i, (x, y)) in c.iter().zip(&g).enumerate() {
        assert_eq!(x.to_bits(), y.to_bits(), "lane {i}: CPU {x}, GPU {y}");
    }
}

/// A GPU runner on an f64 device, or `None` (after saying so) without one.
fn f64_runner() -> Option<jeffcott_gpu::GpuRunner> {
    common::gpu_f64_device().map(jeffcott_gpu::GpuRunner::new)
}

/// The default parameters with contact damping (saltation matrices != I).
fn damped() -> Params {
    Params {
        c_c: 3e4,
        ..Params::default()
    }
}

#[test]
fn gpu_lambda1_matches_cpu_lambda1_within_1e_3_per_second() {
    let Some(runner) = f64_runner() else {
        return;
    };
    let damped = damped();
    // Periodic, quasiperiodic and chaotic speeds, with and without contact damping
    // (saltation matrices != I), and one lane that never touches.
    let mut lanes: Vec<(f64, Params)> = Vec::new();
    for (i, omega) in [131.7, 132.2, 133.0, 135.0, 137.0, 138.5, 140.0, 141.0]
        .into_iter()
        .enumerate()
    {
        lanes.push((omega, Params::default()));
        if i % 2 == 0 {
            lanes.push((omega, damped.clone()));
        }
    }
    lanes.push((
        133.0,
        Params {
            delta: 0.05,
            ..Params::default()
        },
    ));
    let spec = ensemble_spec(&lanes, 100, 100);
    let t = std::time::Instant::now();
    let gpu =
        jeffcott_analysis::backend::run_on_gpu(&spec, &runner, true, Control::none()).unwrap();
    eprintln!("GPU: {:.2} s", t.elapsed().as_secs_f64());
    let cpu = jeffcott_core::ensemble::cpu::run(&spec, true, Control::none()).unwrap();
    let (g, c) = (gpu.lambda1.unwrap(), cpu.lambda1.unwrap());
    let mut identical = 0;
    let mut worst: f64 = 0.0;
    for (i, ((lg, lc), (omega, p))) in g.iter().zip(&c).zip(&lanes).enumerate() {
        worst = worst.max((lg - lc).abs());
        eprintln!(
            "lane {i}: W = {omega}, c_c = {}: GPU {lg:.6}, CPU {lc:.6}",
            p.c_c
        );
        assert!(lc.is_finite(), "lane {i}");
        assert!((lg - lc).abs() <= 1e-3, "lane {i}: GPU {lg} vs CPU {lc}");
        identical += (lg.to_bits() == lc.to_bits()) as usize;
        assert!(cpu.counters[i].switches > 0 || p.delta > 0.01);
    }
    // The states are bit-identical; the tangent arithmetic may round differently in
    // the last bits (the shader compiler may reassociate the Jacobian-vector sums).
    eprintln!(
        "{identical}/{} lanes bit-identical, worst difference {worst:.1e} 1/s",
        lanes.len()
    );
    assert_eq!(gpu.poincare, cpu.poincare, "the states are unchanged");
    // The sweep spans all three kinds of attractor.
    assert!(c.iter().any(|l| *l > 1.0) && c.iter().all(|l| *l < 50.0));
    assert!(c.iter().filter(|l| **l < -0.5).count() >= 3);
}

#[test]
fn damped_contact_force_is_kelvin_voigt_along_the_normal_and_its_jacobian_is_exact() {
    use jeffcott_core::model::{
        VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S, contact_force, penetration,
    };
    for mu in [0.0, 0.2] {
        let p = Params {
            c_c: 4e4,
            mu,
            ..Params::default()
        };
        let mut x = p.static_equilibrium();
        x[X_R] = 0.00603;
        x[Y_R] = 0.0004;
        x[X_S] = 1e-5;
        x[VX_R] = 0.3;
        x[VY_R] = -0.2;
        x[VX_S] = 0.05;
        x[VY_S] = 0.01;
        let g = penetration(p.delta, &x);
        assert!(g > 1e-5);
        let (dx, dy) = (x[X_R] - x[X_S], x[Y_R] - x[Y_S]);
        let r = (dx * dx + dy * dy).sqrt();
        let gdot = (dx * (x[VX_R] - x[VX_S]) + dy * (x[VY_R] - x[VY_S])) / r;
        let (fx, fy) = contact_force(&p, &x);
        let normal = -(fx * dx + fy * dy) / r;
        let tangential = (fx * dy - fy * dx) / r;
        let want = p.k_c * g + p.c_c * gdot;
        assert!(
            (normal - want).abs() <= 1e-9 * want.abs(),
            "{normal} vs {want}"
        );
        // Friction stays mu times the spring part.
        assert!((tangential - mu * p.k_c * g).abs() <= 1e-9 * p.k_c * g + 1e-9);
        // Outside contact the dashpot does nothing.
        let mut out = x;
        out[X_R] = 0.003;
        assert_eq!(contact_force(&p, &out), (0.0, 0.0));
        // Analytic Jacobian (contact_partials) against central differences.
        let jac = common::assert_jacobian_matches_central_differences(&p, &x, 1e-3);
        // The dashpot's share of the trace: -(c_c/m_r + c_c/m_s) in contact.
        let trace: f64 = (0..STATE_DIM).map(|i| jac[i][i]).sum();
        let want = -2.0 * (2.0 * p.xi_r * p.omega_r + 2.0 * p.xi_s * p.omega_s)
            - p.c_c / p.m_r
            - p.c_c / p.m_s;
        assert!(
            (trace - want).abs() < 1e-9 * want.abs(),
            "{trace} vs {want}"
        );
    }
}

#[test]
fn gpu_lambda1_does_not_depend_on_time_slices_or_chunks() {
    use jeffcott_gpu::Schedule;
    let Some(runner) = f64_runner() else {
        return;
    };
    let cfg = StepperConfig {
        steps_per_period: 200,
        ..StepperConfig::default()
    };
    let damped = damped();
    let mut consts = Vec::new();
    let mut init = Vec::new();
    for i in 0..12 {
        let p = if i % 3 == 0 {
            damped.clone()
        } else {
            Params::default()
        };
        let omega = 131.0 + 10.0 * i as f64 / 11.0;
        consts.push(LaneConsts::<f64>::new(&p, omega, &cfg));
        init.push(Lane::<f64>::new(&p.static_equilibrium(), p.delta));
    }
    let v = [[jeffcott_core::integrate::lane::LAMBDA1_START; STATE_DIM]; 12];
    let run = |schedule: Schedule| {
        runner
            .run_lyapunov_with_progress(&consts, &init, &v, &schedule, &mut |_| true)
            .expect("GPU run")
    };
    let (whole, norms, ends) = run(Schedule::new(20, 30, 50));
    let mut sliced = Schedule::new(20, 30, 7);
    sliced.max_lanes_per_chunk = Some(5);
    let (parts, norms_parts, ends_parts) = run(sliced);
    // The final tangent vectors too (each chunk reads its own back), unit length.
    assert_eq!(ends, ends_parts);
    for (i, v) in ends.iter().enumerate() {
        let n = v.iter().map(|c| c * c).sum::<f64>().sqrt();
        assert!((n - 1.0).abs() < 1e-12, "lane {i}: |v| = {n}");
    }
    assert_eq!(norms.len(), 12);
    for (i, (a, b)) in norms.iter().zip(&norms_parts).enumerate() {
        assert_eq!(a.len(), 30);
        assert_eq!(
            a.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            b.iter().map(|x| x.to_bits()).collect::<Vec<_>>(),
            "lane {i}"
        );
        assert_eq!(whole[i].poincare, parts[i].poincare, "lane {i}");
        assert!(
            a.iter().all(|n| n.is_finite() && *n > 0.0),
            "lane {i}: {a:?}"
        );
    }
}
