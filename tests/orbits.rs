//! Periodic orbits by Newton shooting: what must hold for the orbit and its
//! Floquet multipliers. Without contact the system is linear: the period-1 orbit is the
//! analytic unbalance response and the monodromy matrix is the RK4 map's, whose
//! eigenvalues are known in closed form. With contact, Liouville's formula fixes the
//! multipliers' product, and the orbit shot at a periodic speed is the attractor a plain
//! run settles on.

mod common;

use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM, State, VX_R, VY_R, X_R, Y_R, Y_S};
use jeffcott_core::orbit::{Complex, CpuFlows, Flows, ShootConfig, Want, shoot};

/// The default parameters with the gap opened to 1 m: no contact anywhere.
fn contact_free() -> Params {
    Params {
        delta: 1.0,
        ..Params::default()
    }
}

/// The steady unbalance response at t = 0 (docs/model.md 2 without contact): the rotor on a
/// circle of radius A = e W^2 / |w_r^2 - W^2 + 2 i xi_r w_r W| lagging the unbalance by
/// psi, sagged by gravity; the stator at rest at its static deflection.
fn analytic_response(p: &Params, w: f64) -> State {
    let (wr, xi) = (p.omega_r, p.xi_r);
    let (re, im) = (wr * wr - w * w, 2.0 * xi * wr * w);
    let a = p.e * w * w / re.hypot(im);
    let psi = im.atan2(re);
    let mut x = p.static_equilibrium();
    x[X_R] = a * psi.cos();
    x[VX_R] = a * w * psi.sin();
    x[Y_R] += -a * psi.sin();
    x[VY_R] = a * w * psi.cos();
    x
}

/// RK4's stability function R(z) = 1 + z + z^2/2 + z^3/6 + z^4/24.
fn rk4(z: Complex<f64>) -> Complex<f64> {
    Complex::new(1.0, 0.0) + z + z * z / 2.0 + z * z * z / 6.0 + z * z * z * z / 24.0
}

/// The linear system's eigenvalues: each body and axis an oscillator
/// lambda = -xi w +- i w sqrt(1 - xi^2).
fn linear_eigenvalues(p: &Params) -> Vec<Complex<f64>> {
    let mut out = Vec::new();
    for (w, xi) in [(p.omega_r, p.xi_r), (p.omega_s, p.xi_s)] {
        for _axis in 0..2 {
            for sign in [1.0, -1.0] {
                out.push(Complex::new(-xi * w, sign * w * (1.0 - xi * xi).sqrt()));
            }
        }
    }
    out
}

/// Greedy match of two multiset of complex numbers: the largest distance between a value
/// of `a` and the nearest unused value of `b`.
fn multiset_distance(a: &[Complex<f64>], b: &[Complex<f64>]) -> f64 {
    let mut used = vec![false; b.len()];
    let mut worst: f64 = 0.0;
    for x in a {
        let (k, d) = b
            .iter()
            .enumerate()
            .filter(|(k, _)| !used[*k])
            .map(|(k, y)| (k, (x - y).norm()))
            .min_by(|p, q| p.1.total_cmp(&q.1))
            .unwrap();
        used[k] = true;
        worst = worst.max(d);
    }
    worst
}

#[test]
fn without_contact_the_period1_orbit_is_the_analytic_unbalance_response() {
    let p = contact_free();
    let cfg = ShootConfig::default();
    // Below and above the rotor's resonance (140 rad/s).
    for w in [120.0, 131.7, 160.0] {
        let orbit = shoot(&p, w, &p.static_equilibrium(), 1, &cfg).unwrap();
        let exact = analytic_response(&p, w);
        for (i, (got, want)) in orbit.x.iter().zip(&exact).enumerate() {
            let scale = if i % 2 == 1 { w } else { 1.0 };
            let err = (got - want).abs() / scale;
            assert!(err < 1e-9, "W = {w}: coordinate {i} off by {err:e} m");
        }
        assert!(orbit.residual <= cfg.tol);
        // A linear map: Newton lands in one step (a second confirms).
        assert!(orbit.iterations <= 2, "{} iterations", orbit.iterations);
        assert!(orbit.min_clearance > 0.99, "no contact");
        assert!(orbit.stable());
    }
}

#[test]
fn without_contact_the_multipliers_are_those_of_the_linear_system() {
    let p = contact_free();
    let cfg = ShootConfig::default();
    for w in [120.0, 160.0] {
        let orbit = shoot(&p, w, &p.static_equilibrium(), 1, &cfg).unwrap();
        let n = cfg.stepper.steps_per_period as i32;
        let h = std::f64::consts::TAU / w / n as f64;
        let lambda = linear_eigenvalues(&p);
        // The monodromy matrix is the RK4 map's: R(lambda h)^N to roundoff.
        let discrete: Vec<Complex<f64>> = lambda.iter().map(|&l| rk4(l * h).powi(n)).collect();
        let d = multiset_distance(&orbit.multipliers, &discrete);
        assert!(d < 1e-10, "W = {w}: multipliers off the RK4 map's by {d:e}");
        // ... and the flow's exp(lambda T) to RK4's truncation error ((w h)^5 N / 120).
        let flow: Vec<Complex<f64>> = lambda.iter().map(|&l| (l * h * n as f64).exp()).collect();
        let d = multiset_distance(&orbit.multipliers, &flow);
        let bound = (p.omega_s * h).powi(5) * n as f64 / 120.0;
        assert!(
            d < bound,
            "W = {w}: multipliers off exp(lambda T) by {d:e} > {bound:e}"
        );
    }
}

/// The attractor a plain run from the static equilibrium settles on at `w` after
/// `periods` periods (its state at t = kT).
fn settled(p: &Params, w: f64, periods: u32) -> State {
    let stepper = StepperConfig::default();
    jeffcott_core::orbit::advance(p, w, &p.static_equilibrium(), periods, &stepper)
        .expect("the plain run stays within the divergence bound")
}

#[test]
fn in_contact_the_orbit_is_the_attractor_and_the_multipliers_product_is_liouvilles() {
    let p = Params::default();
    let cfg = ShootConfig::default();
    let w = 131.7;
    // From a state still far from the orbit (60 periods in): Newton does the work.
    let start = settled(&p, w, 60);
    let orbit = shoot(&p, w, &start, 1, &cfg).unwrap();
    assert!(orbit.iterations >= 2, "{} iterations", orbit.iterations);
    assert!(
        orbit.min_clearance < 0.0,
        "the period-1 orbit at 131.7 rubs"
    );
    assert!(orbit.stable(), "an attractor: {:?}", orbit.multipliers);
    // The plain run converges onto it (at the slowest multiplier's rate).
    let later = settled(&p, w, 1500);
    let off = (0..STATE_DIM)
        .map(|i| (later[i] - orbit.x[i]).abs() / if i % 2 == 1 { w } else { 1.0 })
        .fold(0.0, f64::max);
    assert!(off < 1e-9, "the plain run is {off:e} m from the orbit");
    // det M = exp(trace(A) T): the contact force depends on positions only, so the
    // trace is the damping's, -4 (xi_r w_r + xi_s w_s) = -119.2 1/s.
    let trace = -2.0 * 2.0 * (p.xi_r * p.omega_r + p.xi_s * p.omega_s);
    let t = std::f64::consts::TAU / w;
    let log_det: f64 = orbit.multipliers.iter().map(|m| m.norm().ln()).sum();
    let rel = (log_det - trace * t).abs() / (trace * t).abs();
    eprintln!(
        "131.7 rad/s: {} iterations, residual {:e} m, clearance {:e} m, multipliers {:?}, \
         ln det M = {log_det}, trace T = {}",
        orbit.iterations,
        orbit.residual,
        orbit.min_clearance,
        orbit.multipliers,
        trace * t
    );
    assert!(rel < 1e-5, "ln det M = {log_det}, trace T = {}", trace * t);
    // The stator's own static sag is part of the orbit.
    assert!(orbit.x[Y_S] < 0.0);
}

#[test]
fn shooting_refuses_a_period_out_of_range_and_a_non_finite_start_naming_the_field() {
    let p = Params::default();
    let cfg = ShootConfig::default();
    let e = shoot(&p, 133.0, &p.static_equilibrium(), 0, &cfg).unwrap_err();
    assert!(e.to_string().contains("period"), "{e}");
    let mut bad = p.static_equilibrium();
    bad[0] = f64::NAN;
    let e = shoot(&p, 133.0, &bad, 1, &cfg).unwrap_err();
    assert!(e.to_string().contains("start"), "{e}");
}

#[test]
fn in_contact_the_floquet_exponents_are_the_lyapunov_spectrum_within_its_error_bars() {
    // Two independent routes to the same numbers: ln|mu_i| / T of the orbit shot at
    // 131.7 rad/s, and the QR (Benettin) spectrum of a long run on the attractor.
    let p = Params::default();
    let w = 131.7;
    let orbit = shoot(&p, w, &settled(&p, w, 60), 1, &ShootConfig::default()).unwrap();
    let floquet = orbit.exponents();
    let cfg = jeffcott_core::lyapunov::SpectrumConfig::default();
    let s = jeffcott_core::lyapunov::spectrum(&p, w, &p.static_equilibrium(), &cfg).unwrap();
    let mut qr: Vec<(f64, f64)> = s.exponents.iter().copied().zip(s.errors).collect();
    qr.sort_by(|a, b| b.0.total_cmp(&a.0));
    eprintln!("Floquet {floquet:?}\nQR {qr:?}");
    for (k, (f, (l, err))) in floquet.iter().zip(&qr).enumerate() {
        // Three of the spectrum's error bars (a complex pair's two QR exponents straddle
        // their common real part until the pair's rotation averages out).
        assert!(
            (f - l).abs() <= 3.0 * err,
            "exponent {k}: Floquet {f}, QR {l} +- {err}"
        );
    }
}

/// The period-1 branch over W in [lo, hi] from `start_value` in `direction`.
fn w_spec(
    p: &Params,
    start: State,
    start_value: f64,
    (lo, hi): (f64, f64),
    direction: f64,
) -> jeffcott_analysis::orbits::BranchSpec {
    jeffcott_analysis::orbits::BranchSpec {
        params: p.clone(),
        omega: start_value,
        var: jeffcott_analysis::map::MapVar::Omega,
        lo,
        hi,
        start_value,
        start,
        period: 1,
        direction,
        max_points: 400,
        ds: 2e-5,
        ds_max: 2e-4,
        shoot: ShootConfig::default(),
    }
}

/// [`w_spec`]'s branch, continued.
fn w_branch(
    p: &Params,
    start: State,
    start_value: f64,
    range: (f64, f64),
    direction: f64,
) -> jeffcott_analysis::orbits::Branch {
    let spec = w_spec(p, start, start_value, range, direction);
    jeffcott_analysis::orbits::continue_branch(&spec, &CpuFlows).unwrap()
}

/// The bifurcations of `kind` on `b` (the branch's summary printed for the log).
fn of_kind(
    b: &jeffcott_analysis::orbits::Branch,
    kind: jeffcott_analysis::orbits::Crossing,
) -> Vec<&jeffcott_analysis::orbits::Bifurcation> {
    eprintln!(
        "{} points, stop: {}, bifurcations {:?}",
        b.points.len(),
        b.stop,
        b.found("", 8, "none")
    );
    b.bifurcations.iter().filter(|x| x.kind == kind).collect()
}

/// Where the contact-free response grazes the stator: the rotor's circle of radius
/// A(W), centred a_g / w_r^2 - a_g / w_s^2 below the stator's centre (the two sag by
/// different amounts), reaches the gap: A(W) + offset = delta, by bisection in [a, b].
fn analytic_grazing(p: &Params, a: f64, b: f64) -> f64 {
    let offset = p.a_g / (p.omega_r * p.omega_r) - p.a_g / (p.omega_s * p.omega_s);
    let f = |w: f64| {
        let (re, im) = (p.omega_r * p.omega_r - w * w, 2.0 * p.xi_r * p.omega_r * w);
        p.e * w * w / re.hypot(im) + offset - p.delta
    };
    let (mut lo, mut hi) = (a, b);
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if (f(mid) > 0.0) == (f(lo) > 0.0) {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

#[test]
fn grazing_of_the_contact_free_orbit_is_located_where_the_analytic_response_reaches_the_gap() {
    use jeffcott_analysis::orbits::Crossing;
    let p = Params::default();
    // Below the rotor's resonance, W increasing from 120; above it, decreasing from 170.
    for (start, range, direction, bracket) in [
        (120.0, (120.0, 129.5), 1.0, (120.0, 139.0)),
        (170.0, (150.0, 170.0), -1.0, (141.0, 170.0)),
    ] {
        let b = w_branch(&p, p.static_equilibrium(), start, range, direction);
        let want = analytic_grazing(&p, bracket.0, bracket.1);
        let g = of_kind(&b, Crossing::Grazing);
        eprintln!("from {start}: analytic grazing at {want}");
        assert_eq!(g.len(), 1, "one grazing in {range:?}");
        assert!(
            (g[0].value - want).abs() < 1e-6,
            "grazing at {} rad/s, analytic {want}",
            g[0].value
        );
        assert!(g[0].min_clearance.abs() < 1e-9);
    }
}

#[test]
fn a_period_doubling_is_found_where_the_brute_force_sees_period_1_turn_into_period_2() {
    use jeffcott_analysis::orbits::Crossing;
    let p = Params::default();
    // The brute force: period 1 at 131.95 rad/s, period 2 at 132.27.
    let b = w_branch(&p, settled(&p, 131.7, 60), 131.7, (131.7, 132.4), 1.0);
    let pd = of_kind(&b, Crossing::PeriodDoubling);
    assert_eq!(pd.len(), 1);
    let w = pd[0].value;
    assert!((131.95..132.27).contains(&w), "period doubling at {w}");
    // A multiplier at -1 there.
    let near = pd[0]
        .multipliers
        .iter()
        .map(|m| (m[0] + 1.0).hypot(m[1]))
        .fold(f64::INFINITY, f64::min);
    assert!(near < 1e-5, "closest multiplier to -1 is {near:e} away");
    // Stable before, unstable after.
    assert!(b.points[pd[0].after_point].stable);
    assert!(!b.points.last().unwrap().stable);
}

#[test]
fn the_orbits_command_writes_the_branch_and_names_the_period_doubling_under_omega() {
    let (_tmp, out, b) = branches_of("orbits --vary omega:131.7:132.4 --quiet");
    assert_eq!(b["param"], "omega");
    let branch = &b["branches"][0];
    assert_eq!(branch["period"], 1);
    let bif = branch["bifurcations"].as_array().unwrap();
    assert_eq!(bif.len(), 1, "{bif:?}");
    assert_eq!(bif[0]["type"], "period_doubling");
    let w = bif[0]["omega"].as_f64().unwrap();
    assert!((131.95..132.27).contains(&w), "{w}");
    let (shape, rows) = common::npy::<f64>(&out.join("branch.npy"));
    let n = branch["points"].as_array().unwrap().len();
    assert_eq!(shape, vec![n as u64, 13]);
    assert_eq!((rows[0], rows[1]), (0.0, 131.7));
    let (shape, _) = common::npy::<f64>(&out.join("multipliers.npy"));
    assert_eq!(shape, vec![n as u64, 8, 2]);
    assert_eq!(common::json(&out.join("run.json"))["state"], "complete");
}

#[test]
fn the_doubled_branch_born_at_the_period_doubling_holds_the_period_2_attractor_of_a_plain_run() {
    use jeffcott_analysis::orbits::{Crossing, doubled_branch};
    let p = Params::default();
    let spec = w_spec(&p, settled(&p, 131.7, 60), 131.7, (131.7, 132.4), 1.0);
    let b = jeffcott_analysis::orbits::continue_branch(&spec, &CpuFlows).unwrap();
    let pd = of_kind(&b, Crossing::PeriodDoubling)[0];
    let d = doubled_branch(&spec, pd, &CpuFlows).unwrap();
    assert_eq!(d.period, 2);
    let first = d.points[0].value;
    assert!(
        first > pd.value && first - pd.value < 1e-2,
        "starts at {first}"
    );
    assert!(
        d.points[0].stable,
        "the doubled orbit of a supercritical doubling is stable"
    );
    // At 132.2 rad/s: shoot the period-2 orbit from the branch's nearest point and
    // compare with where a plain run settles (either of the orbit's two points).
    let near = d
        .points
        .iter()
        .min_by(|a, b| (a.value - 132.2).abs().total_cmp(&(b.value - 132.2).abs()))
        .unwrap();
    assert!(
        (near.value - 132.2).abs() < 0.05,
        "the branch reaches 132.2: {}",
        near.value
    );
    let orbit = shoot(&p, 132.2, &near.x, 2, &ShootConfig::default()).unwrap();
    let plain = settled(&p, 132.2, 2000);
    let other =
        jeffcott_core::orbit::advance(&p, 132.2, &orbit.x, 1, &StepperConfig::default()).unwrap();
    let dist = |a: &State, b: &State| {
        jeffcott_core::orbit::metric(&std::array::from_fn(|i| a[i] - b[i]), 132.2)
    };
    let off = dist(&plain, &orbit.x).min(dist(&plain, &other));
    assert!(
        off < 1e-8,
        "the plain run's attractor is {off:e} m from the doubled orbit"
    );
    assert!(dist(&orbit.x, &other) > 1e-6, "a genuine period-2 orbit");
}

#[test]
fn the_orbits_command_follows_the_doubled_branch_when_asked() {
    let (_tmp, out, b) = branches_of("orbits --vary omega:131.7:132.4 --follow-doublings --quiet");
    let branches = b["branches"].as_array().unwrap();
    assert_eq!(branches.len(), 2);
    assert_eq!(
        (
            branches[0]["period"].as_u64(),
            branches[1]["period"].as_u64()
        ),
        (Some(1), Some(2))
    );
    let pd = branches[0]["bifurcations"][0]["omega"].as_f64().unwrap();
    let first = branches[1]["points"][0]["value"].as_f64().unwrap();
    assert!(
        first > pd && first - pd < 1e-2,
        "the doubled branch starts at {first}"
    );
    let (shape, rows) = common::npy::<f64>(&out.join("branch.npy"));
    let n: usize = branches
        .iter()
        .map(|b| b["points"].as_array().unwrap().len())
        .sum();
    assert_eq!(shape, vec![n as u64, 13]);
    assert_eq!(
        rows[(n - 1) * 13],
        1.0,
        "the last row is the doubled branch's"
    );
}

#[test]
fn the_orbits_command_draws_its_branches_over_a_brute_force_and_refuses_a_wrong_one() {
    let tmp = tempfile::tempdir().unwrap();
    let (bif, out) = (tmp.path().join("bif"), tmp.path().join("orbits"));
    common::ok(&common::jeffcott_out(
        "bifurcation --omega 131.7:132.4:8 --no-sweep --ics 2 --brute-transient 200 \
         --periods 16 --no-lyapunov --no-plot --backend cpu --quiet",
        &bif,
    ));
    let line = format!(
        "orbits --vary omega:131.7:132.4 --follow-doublings --coord vx_s --quiet --over {}",
        bif.display()
    );
    common::ok(&common::jeffcott_out(&line, &out));
    let png = std::fs::read(out.join("branch.png")).unwrap();
    assert_eq!(&png[1..4], b"PNG");
    let outputs = common::json(&out.join("run.json"))["outputs"].clone();
    assert!(
        outputs
            .as_array()
            .unwrap()
            .iter()
            .any(|o| o == "branch.png"),
        "{outputs}"
    );
    // A brute force is drawn under a branch over omega only, and must be one.
    let wrong = [
        format!(
            "orbits --vary e:0.0008:0.0012 --omega 132.2 --over {}",
            bif.display()
        ),
        format!(
            "orbits --vary omega:131.7:132.4 --over {}",
            tmp.path().join("none").display()
        ),
        "orbits --vary omega:131.7:132.4 --coord spin".to_string(),
        // Another model's diagram, and a diagram of other speeds.
        format!(
            "orbits --vary omega:131.7:132.4 --param mu=0.1 --over {}",
            bif.display()
        ),
        format!("orbits --vary omega:135:136 --over {}", bif.display()),
    ];
    let needles = [
        "over",
        "over",
        "coord",
        "another model (mu = ",
        "outside the branch's range",
    ];
    for (line, needle) in wrong.iter().zip(needles) {
        let o = common::jeffcott_out(line, tmp.path().join("refused"));
        assert!(!o.status.success(), "{line} was accepted");
        let err = String::from_utf8_lossy(&o.stderr);
        assert!(err.contains(needle), "{line}: {err}");
    }
}

#[test]
fn two_folds_are_passed_by_pseudo_arclength_and_the_branch_between_them_is_unstable() {
    use jeffcott_analysis::orbits::Crossing;
    // Over 131.3..131.7 rad/s the period-1 branch turns back at a fold, runs down in W
    // unstable, and turns forward again at a second fold (the hysteresis the up and
    // down sweeps show near 131.5): a natural continuation in W would stop at the first.
    let p = Params::default();
    let b = w_branch(&p, settled(&p, 131.3, 300), 131.3, (131.3, 131.7), 1.0);
    let folds = of_kind(&b, Crossing::Fold);
    assert_eq!(folds.len(), 2, "two folds");
    let (upper, lower) = (folds[0].value, folds[1].value);
    assert!(
        upper > lower,
        "the branch turns back at {upper}, forward at {lower}"
    );
    // W decreases between the folds, and the orbits there are unstable (a multiplier
    // through +1 at each fold).
    let between: Vec<_> = b.points[folds[0].after_point + 1..=folds[1].after_point]
        .iter()
        .collect();
    assert!(!between.is_empty());
    assert!(between.windows(2).all(|w| w[1].value < w[0].value));
    assert!(between.iter().all(|pt| !pt.stable));
    for f in &folds {
        let near_one = f
            .multipliers
            .iter()
            .map(|m| (m[0] - 1.0).hypot(m[1]))
            .fold(f64::INFINITY, f64::min);
        assert!(
            near_one < 1e-4,
            "a multiplier at +1 at the fold: {near_one:e} away"
        );
    }
    assert!(
        b.points.last().unwrap().value >= 131.7,
        "continued past both folds"
    );
}

/// Every bit of a branch: each point's value, state, multipliers and clearance, each
/// bifurcation's value and state.
fn branch_bits(b: &jeffcott_analysis::orbits::Branch) -> Vec<u64> {
    let mut bits = Vec::new();
    for p in &b.points {
        bits.push(p.value.to_bits());
        bits.push(p.min_clearance.to_bits());
        bits.extend(p.x.iter().map(|v| v.to_bits()));
        bits.extend(p.multipliers.iter().flatten().map(|v| v.to_bits()));
    }
    for x in &b.bifurcations {
        bits.push(x.value.to_bits());
        bits.extend(x.x.iter().map(|v| v.to_bits()));
    }
    bits
}

/// Starts for many orbits at once: period-1 guesses at three speeds in contact, settled
/// from the static equilibrium.
fn many_starts(p: &Params) -> Vec<jeffcott_core::orbit::Start> {
    [131.7, 131.95, 132.05]
        .iter()
        .map(|&w| jeffcott_core::orbit::Start {
            params: p.clone(),
            omega: w,
            x0: settled(p, w, 60),
            period: 1,
        })
        .collect()
}

#[test]
fn many_orbits_shot_at_once_are_each_the_orbit_shot_alone() {
    let p = Params::default();
    let starts = many_starts(&p);
    let cfg = ShootConfig::default();
    let many = jeffcott_core::orbit::shoot_many(&CpuFlows, &starts, &cfg).unwrap();
    assert_eq!(many.len(), starts.len());
    for (s, o) in starts.iter().zip(&many) {
        let alone = shoot(&p, s.omega, &s.x0, 1, &cfg).unwrap();
        let o = o.as_ref().unwrap();
        assert_eq!(o.x, alone.x, "W = {}", s.omega);
        assert_eq!(o.monodromy, alone.monodromy, "W = {}", s.omega);
        assert_eq!(o.iterations, alone.iterations);
        assert!(o.residual <= cfg.tol);
    }
    // A start that does not converge leaves the others alone and says why.
    let mut with_bad = starts.clone();
    with_bad.insert(
        1,
        jeffcott_core::orbit::Start {
            x0: [0.5; STATE_DIM],
            ..starts[0].clone()
        },
    );
    // A start that is not finite is refused on its own; the others go on.
    let nan = jeffcott_core::orbit::Start {
        x0: [f64::NAN; STATE_DIM],
        ..starts[0].clone()
    };
    let both =
        jeffcott_core::orbit::shoot_many(&CpuFlows, &[nan, starts[1].clone()], &cfg).unwrap();
    let err = both[0].as_ref().unwrap_err().to_string();
    assert!(err.contains("`start`") && err.contains("finite"), "{err}");
    assert_eq!(both[1].as_ref().unwrap().x, many[1].as_ref().unwrap().x);
    let tight = ShootConfig { max_iter: 2, ..cfg };
    let mixed = jeffcott_core::orbit::shoot_many(&CpuFlows, &with_bad, &tight).unwrap();
    let err = mixed[1].as_ref().unwrap_err().to_string();
    assert!(err.contains("did not converge"), "{err}");
    for (k, s) in [(0, &starts[0]), (2, &starts[1]), (3, &starts[2])] {
        let alone = jeffcott_core::orbit::shoot_many(&CpuFlows, std::slice::from_ref(s), &tight)
            .unwrap()
            .remove(0);
        assert_eq!(
            mixed[k].as_ref().map(|o| o.x).map_err(|e| e.to_string()),
            alone.map(|o| o.x).map_err(|e| e.to_string()),
            "start {k}"
        );
    }
}

#[test]
fn gpu_and_cpu_give_the_same_orbits_and_branch_to_the_bit_in_f64() {
    use jeffcott_analysis::backend::Engine;
    use jeffcott_analysis::orbits::{Crossing, continue_branch};
    use jeffcott_core::ensemble::{Backend, Precision};
    if !common::gpu_f64_present() {
        return;
    }
    let gpu = Engine::new(Backend::Gpu, Precision::F64).expect("an f64 adapter opened above");
    let p = Params::default();
    // Many orbits at once: the eight tangent lanes of every start side by side.
    let starts = many_starts(&p);
    let cfg = ShootConfig::default();
    let on_gpu = jeffcott_core::orbit::shoot_many(&gpu, &starts, &cfg).unwrap();
    let on_cpu = jeffcott_core::orbit::shoot_many(&CpuFlows, &starts, &cfg).unwrap();
    for ((g, c), s) in on_gpu.iter().zip(&on_cpu).zip(&starts) {
        let (g, c) = (g.as_ref().unwrap(), c.as_ref().unwrap());
        assert_eq!(g.x, c.x, "W = {}", s.omega);
        assert_eq!(g.monodromy, c.monodromy, "W = {}", s.omega);
        assert_eq!(g.min_clearance.to_bits(), c.min_clearance.to_bits());
        assert_eq!(g.iterations, c.iterations);
    }
    // Zero periods (settling by 0): the start itself and the identity, on both.
    let zero: Vec<jeffcott_core::orbit::FlowAsk> = [Want::Monodromy, Want::End]
        .into_iter()
        .map(|want| jeffcott_core::orbit::FlowAsk {
            params: p.clone(),
            omega: 131.7,
            x0: starts[0].x0,
            periods: 0,
            want,
        })
        .collect();
    let stepper = StepperConfig::default();
    let (g, c) = (
        gpu.flows(&zero, &stepper).unwrap(),
        CpuFlows.flows(&zero, &stepper).unwrap(),
    );
    for (g, c) in g.iter().zip(&c) {
        assert_eq!(
            (g.end, g.monodromy, g.finite),
            (c.end, c.monodromy, c.finite)
        );
        assert_eq!(g.min_clearance.to_bits(), c.min_clearance.to_bits());
    }
    assert_eq!(c[0].monodromy, Some(jeffcott_core::orbit::identity()));
    // A branch through the period doubling at 132.07 rad/s, located on both.
    let spec = jeffcott_analysis::orbits::BranchSpec {
        max_points: 8,
        ds: 1e-4,
        ds_max: 4e-4,
        ..w_spec(&p, settled(&p, 132.0, 60), 132.0, (132.0, 132.2), 1.0)
    };
    let cpu_branch = continue_branch(&spec, &CpuFlows).unwrap();
    let gpu_branch = continue_branch(&spec, &gpu).unwrap();
    assert!(
        !of_kind(&cpu_branch, Crossing::PeriodDoubling).is_empty(),
        "the branch reaches the period doubling: {:?}",
        cpu_branch.found("omega", 5, "none")
    );
    assert_eq!(cpu_branch.points.len(), gpu_branch.points.len());
    assert_eq!(branch_bits(&cpu_branch), branch_bits(&gpu_branch));
}

#[test]
fn the_orbits_command_on_a_gpu_writes_the_cpus_branch_files_to_the_byte() {
    if !common::gpu_f64_present() {
        return;
    }
    let tmp = tempfile::tempdir().unwrap();
    let run = |backend: &str| {
        let out = tmp.path().join(backend);
        common::ok(&common::jeffcott_out(
            &format!(
                "orbits --vary omega:132.0:132.2 --max-points 14 --follow-doublings \
                 --backend {backend} --no-plot --quiet"
            ),
            &out,
        ));
        // The backend is recorded, and is not part of the specification.
        let run = common::json(&out.join("run.json"));
        assert_eq!(run["backend"], backend, "{run}");
        assert!(run["spec"].get("backend").is_none(), "{run}");
        out
    };
    let (cpu, gpu) = (run("cpu"), run("gpu"));
    // The period-1 branch through the period doubling at 132.07 and the doubled branch.
    let b = common::json(&cpu.join("branches.json"));
    assert_eq!(b["branches"].as_array().unwrap().len(), 2, "{b}");
    for f in ["branch.npy", "multipliers.npy", "branches.json"] {
        assert!(
            std::fs::read(cpu.join(f)).unwrap() == std::fs::read(gpu.join(f)).unwrap(),
            "{f} differs"
        );
    }
}

#[test]
fn the_orbits_command_starts_from_the_periodic_attractors_of_a_basin_a_bifurcation_and_a_continuation()
 {
    let tmp = tempfile::tempdir().unwrap();
    // `orbits ARGS --from DIR` into tmp/NAME: its branches.json.
    let orbits_from = |name: &str, args: &str, dir: &std::path::Path| {
        let out = tmp.path().join(name);
        common::ok(&common::jeffcott_out(
            &format!("orbits {args} --from {} --no-plot --quiet", dir.display()),
            &out,
        ));
        common::json(&out.join("branches.json"))
    };
    // A basin at 132.2 rad/s, where the period-2 attractor lives (Fig. 6).
    let basin = tmp.path().join("basin");
    common::ok(&common::jeffcott_out(
        "basin --omega 132.2 --x x_r:-0.006:0.006:4 --y vx_r:-1:1:4 --transient 300 \
         --periods 16 --backend cpu --no-plot --quiet",
        &basin,
    ));
    let attractors = common::json(&basin.join("attractors.json"));
    let a = &attractors["attractors"][0];
    assert_eq!(a["period"], 2, "{attractors}");
    let b = orbits_from(
        "from-basin",
        "--param omega:131.9:132.4 --direction down",
        &basin,
    );
    let branch = &b["branches"][0];
    assert_eq!(branch["period"], 2);
    let first = &branch["points"][0];
    assert_eq!(first["value"], 132.2);
    // The orbit shot from the attractor's Poincare point is that attractor: one of its
    // two points lies within the basin record's transient residue of the start.
    let x: Vec<f64> = serde_json::from_value(first["x"].clone()).unwrap();
    let p0: Vec<f64> = serde_json::from_value(a["points"][0].clone()).unwrap();
    let d = x
        .iter()
        .zip(&p0)
        .map(|(u, v)| (u - v).abs())
        .fold(0.0, f64::max);
    assert!(d < 1e-6, "orbit {x:?} vs attractor point {p0:?}: {d:e}");
    // Going down it ends where it was born, the period doubling of the period-1 branch
    // at 132.0698: seen from the doubled branch (fixed points of P^2, the period-1 orbit
    // among them) a pitchfork, a multiplier at +1 where the branch turns back.
    let bif = branch["bifurcations"].as_array().unwrap();
    assert!(
        bif.iter().any(|x| x["type"] == "fold"
            && (x["omega"].as_f64().unwrap() - 132.0698).abs() < 1e-3
            && (x["multipliers"][0][0].as_f64().unwrap() - 1.0).abs() < 1e-4),
        "{bif:?}"
    );
    // A bifurcation diagram's brute force at the speed nearest the start (131.0:
    // a period-1 attractor there, beside aperiodic ones that start nothing).
    let bif_dir = tmp.path().join("bifurcation");
    common::ok(&common::jeffcott_out(
        "bifurcation --omega 131:131.8:2 --ics 2 --transient 20 --transient-first 300 \
         --brute-transient 300 --periods 12 --backend cpu --no-plot --quiet",
        &bif_dir,
    ));
    let b = orbits_from("from-bifurcation", "--param omega:131:131.2", &bif_dir);
    let branches = b["branches"].as_array().unwrap();
    assert!(!branches.is_empty());
    for br in branches {
        assert_eq!(br["points"][0]["value"], 131.0, "{br}");
    }
    let run = common::json(&tmp.path().join("from-bifurcation/run.json"));
    assert!(
        run["spec"]["from"]
            .as_str()
            .unwrap()
            .ends_with("bifurcation")
    );
    // A continuation's attractors at the step nearest the branch's start (132.1).
    let cont = tmp.path().join("continuation");
    common::ok(&common::jeffcott_out(
        "continuation --vary omega:132.1:132.3:3 --ics 8 --transient 300 --periods 16 \
         --backend cpu --no-plot --quiet",
        &cont,
    ));
    let c = common::json(&cont.join("continuation.json"));
    assert_eq!(
        c["ramps"]["up"]["steps"][0]["attractors"][0]["period"], 2,
        "{c}"
    );
    let b = orbits_from("from-continuation", "--param omega:132.0:132.3", &cont);
    let br = &b["branches"][0];
    assert_eq!(
        (br["period"].as_u64(), br["points"][0]["value"].as_f64()),
        (Some(2), Some(132.1))
    );
    // ... over its own parameter only.
    let line = format!(
        "orbits --vary e:0.0009:0.0011 --from {} --no-plot --quiet",
        cont.display()
    );
    let refused = common::jeffcott_out(&line, tmp.path().join("refused-var"));
    common::assert_refused_naming(&refused, &line, &["continuation over omega"]);
    // Another model's attractors are refused, naming the parameter.
    let line = format!(
        "orbits --vary omega:131.9:132.4 --from {} --param mu=0.1 --no-plot --quiet",
        basin.display()
    );
    let refused = common::jeffcott_out(&line, tmp.path().join("refused"));
    common::assert_refused_naming(&refused, &line, &["`from`", "mu"]);
}

#[test]
fn a_closed_branch_stops_when_it_comes_back_to_its_first_orbit() {
    use jeffcott_analysis::orbits::Crossing;
    // The period-2 branch born at the period doubling of the period-1 branch near
    // 137.30 rad/s (`orbits --vary omega:130:141 --follow-doublings` reaches it there):
    // a loop that leaves it and comes back through the doubling at 136.42. The guess is
    // that run's first doubled-branch point; Newton re-shoots it here.
    let p = Params::default();
    let start = [
        0.005942289579602519,
        0.14149200927414507,
        -0.0013539651024248255,
        0.7976184843457342,
        6.578164251845993e-05,
        0.036577683894988514,
        -1.3886880459990444e-05,
        0.019224786577048382,
    ];
    let spec = jeffcott_analysis::orbits::BranchSpec {
        period: 2,
        max_points: 1000,
        ..w_spec(&p, start, 137.28893464890245, (135.0, 139.0), -1.0)
    };
    let b = jeffcott_analysis::orbits::continue_branch(&spec, &CpuFlows).unwrap();
    assert!(
        b.stop.starts_with("closed"),
        "{} after {} points",
        b.stop,
        b.points.len()
    );
    // Before, it went round until max-points (1000).
    assert!(b.points.len() < 400, "{} points", b.points.len());
    // The last step passed the first orbit: its state at t = 0 or at t = T.
    let (first, last) = (&b.points[0], b.points.last().unwrap());
    let image =
        jeffcott_core::orbit::advance(&p, first.value, &first.x, 1, &StepperConfig::default())
            .unwrap();
    let off = |x: &State| {
        jeffcott_core::orbit::metric(&std::array::from_fn(|i| last.x[i] - x[i]), first.value)
    };
    let d = off(&first.x).min(off(&image));
    assert!(d < 1e-4 && (last.value - first.value).abs() < 0.05, "{d:e}");
    // The loop meets the period doubling at 136.4237 at both of an orbit's Poincare
    // points: listed once.
    let pd = of_kind(&b, Crossing::PeriodDoubling);
    assert!(!pd.is_empty(), "{:?}", b.found("omega", 5, "none"));
    for (i, x) in pd.iter().enumerate() {
        for y in &pd[i + 1..] {
            assert!((x.value - y.value).abs() > 1e-7, "{} twice", x.value);
        }
    }
}

#[test]
fn the_branch_from_the_contact_free_orbit_passes_grazing_and_the_corner_after_it_onto_the_attractors_branch()
 {
    use jeffcott_analysis::orbits::Crossing;
    // From the contact-free orbit at 120 rad/s: grazing at 129.1297, then a corner at
    // 129.461 where a further contact episode begins and the pseudo-arclength corrector
    // fails at every step (the natural-parameter step takes it past), then on to the
    // Neimark-Sacker bifurcation at 130.421 that the branch continued from the
    // attractor at 130 rad/s shows too: the two are one branch.
    let p = Params::default();
    let from_below = jeffcott_analysis::orbits::BranchSpec {
        max_points: 600,
        ..w_spec(&p, settled(&p, 120.0, 300), 120.0, (120.0, 130.6), 1.0)
    };
    let b = jeffcott_analysis::orbits::continue_branch(&from_below, &CpuFlows).unwrap();
    assert!(b.stop.starts_with("left the range"), "{}", b.stop);
    let graze = of_kind(&b, Crossing::Grazing);
    assert!(
        (graze[0].value - 129.12968804).abs() < 1e-6,
        "{:?}",
        b.found("omega", 8, "none")
    );
    let ns_below: Vec<f64> = of_kind(&b, Crossing::NeimarkSacker)
        .iter()
        .map(|x| x.value)
        .collect();
    let from_attractor = w_branch(&p, settled(&p, 130.0, 300), 130.0, (130.0, 130.6), 1.0);
    let ns = of_kind(&from_attractor, Crossing::NeimarkSacker)[0].value;
    assert!(
        ns_below.iter().any(|v| (v - ns).abs() < 1e-6),
        "Neimark-Sacker at {ns} from the attractor; from below: {ns_below:?}"
    );
}

/// Runs `line` (an `orbits` command) into a temporary directory: the directory (it
/// lasts while held), the output directory and the branches.json written.
fn branches_of(line: &str) -> (tempfile::TempDir, std::path::PathBuf, serde_json::Value) {
    let (tmp, out) = common::jeffcott_ok("orbits", line);
    let b = common::json(&out.join("branches.json"));
    (tmp, out, b)
}

#[test]
fn a_period_1_orbit_shot_as_period_2_is_reported_as_period_1() {
    let (_tmp, out, j) =
        branches_of("orbits --vary omega:131.0:131.5 --period 2 --max-points 5 --no-plot");
    let b = &j["branches"][0];
    assert_eq!(
        (b["period"].as_u64(), b["minimal_period"].as_u64()),
        (Some(2), Some(1))
    );
    let o = common::jeffcott_out(
        "orbits --vary omega:131.0:131.5 --period 2 --max-points 5 --no-plot",
        &out,
    );
    common::ok(&o);
    let said = String::from_utf8_lossy(&o.stdout);
    assert!(
        said.contains("Period-1 branch (asked for period 2"),
        "{said}"
    );
    // A genuine period-2 orbit stays period 2.
    let (_tmp2, _, j) =
        branches_of("orbits --vary omega:132.2:132.4 --period 2 --max-points 5 --no-plot");
    assert_eq!(j["branches"][0]["minimal_period"].as_u64(), Some(2));
}

#[test]
fn orbits_from_a_run_that_is_still_running_is_refused() {
    let tmp = tempfile::tempdir().unwrap();
    let basin = tmp.path().join("basin");
    common::ok(&common::jeffcott_out(
        "basin --omega 132.2 --x x_r:-0.004:0.004:4 --y vx_r:-0.5:0.5:3 --transient 200 \
         --periods 16 --no-plot --backend cpu --quiet",
        &basin,
    ));
    let run = basin.join("run.json");
    let text = std::fs::read_to_string(&run).unwrap();
    std::fs::write(&run, text.replace("\"complete\"", "\"running\"")).unwrap();
    let o = common::jeffcott_out(
        &format!("orbits --vary omega:132:132.4 --from {}", basin.display()),
        tmp.path().join("o"),
    );
    let err = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{err}");
    assert!(err.contains("`from`") && err.contains("running"), "{err}");
}

#[test]
fn the_former_spellings_param_range_and_set_still_run_the_same_branch_with_a_warning() {
    // `--vary NAME:lo:hi` and `--param NAME=VALUE`, as every other command spells them,
    // against the spellings of the release before (`--param NAME:lo:hi`, `--set`).
    let new = "orbits --vary omega:131.0:131.2 --param mu=0.1 --max-points 3 --no-plot --quiet";
    let old = "orbits --param omega:131.0:131.2 --set mu=0.1 --max-points 3 --no-plot --quiet";
    let (_a, out_new, b_new) = branches_of(new);
    let (tmp, out_old) = common::temp_out("old");
    let o = common::jeffcott_out(old, &out_old);
    common::ok(&o);
    let warned = String::from_utf8_lossy(&o.stderr);
    for needle in ["--vary omega:131.0:131.2", "--param mu=0.1", "deprecated"] {
        assert!(warned.contains(needle), "{needle} not in: {warned}");
    }
    assert_eq!(b_new, common::json(&out_old.join("branches.json")));
    assert_eq!(
        std::fs::read(out_new.join("branch.npy")).unwrap(),
        std::fs::read(out_old.join("branch.npy")).unwrap()
    );
    // Read the old way, the continued parameter overridden is refused as it is the new
    // way.
    let clash = common::jeffcott_out(
        "orbits --param mu:0:0.1 --omega 132 --set mu=0.05 --no-plot --quiet",
        out_old.join("clash"),
    );
    assert_eq!(clash.status.code(), Some(2));
    let said = String::from_utf8_lossy(&clash.stderr);
    assert!(
        said.contains("varies mu") && said.contains("`param`"),
        "{said}"
    );
    drop(tmp);
}
