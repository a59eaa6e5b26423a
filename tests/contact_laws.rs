//! The contact laws of docs/model.md 7 (Hertz's power law k_c g^n, Hunt-Crossley
//! damping) against what physics fixes independently of the integrator: conservation
//! of energy through impacts and its order of convergence, the coefficient of
//! restitution of Hunt and Crossley's closed form, the static balance of forces, the
//! analytic Jacobian, and the GPU kernel's bits equal to the CPU's.

mod common;

use common::{gpu_f64_device, unit};
use jeffcott_analysis::backend::Engine;
use jeffcott_core::control::Control;
use jeffcott_core::ensemble::{Backend, EnsembleResult, EnsembleSpec, LaneSpec, Precision};
use jeffcott_core::integrate::lane::{Lane, LaneConsts, StepperConfig, macro_step};
use jeffcott_core::model::{self, Params, STATE_DIM, State, VX_R, VX_S, VY_R, X_R, X_S};

/// The article's machine with the contact law of exponent `n`, its stiffness scaled so
/// that a 0.1 mm overlap pushes as hard as the article's linear spring does there.
fn hertz(n: f64) -> Params {
    let p = Params::default();
    Params {
        n_c: n,
        k_c: p.k_c * 1e-4f64.powf(1.0 - n),
        ..p
    }
}

/// The undamped, unforced, frictionless machine of contact exponent `n` with the rotor
/// thrown against the stator (it rubs about twice a rotor cycle).
fn conservative_rub(n: f64) -> (Params, State) {
    let p = Params {
        xi_r: 0.0,
        xi_s: 0.0,
        e: 0.0,
        mu: 0.0,
        ..hertz(n)
    };
    let mut x0 = p.static_equilibrium();
    x0[VX_R] = 1.1;
    x0[VY_R] = 0.4;
    (p, x0)
}

/// The worst relative energy error over 40 periods at N steps a period, and the
/// contact switches taken.
fn energy_drift(n_c: f64, n: u32) -> (f64, u64) {
    let (p, x0) = conservative_rub(n_c);
    let cfg = StepperConfig {
        steps_per_period: n,
        ..StepperConfig::default()
    };
    let lc = LaneConsts::<f64>::new(&p, 133.0, &cfg);
    let mut lane = Lane::<f64>::new(&x0, p.delta);
    let e0 = model::energy(&p, &x0);
    let mut worst: f64 = 0.0;
    for _ in 0..40 * n {
        macro_step(&lc, &mut lane);
        worst = worst.max((model::energy(&p, &lane.x) - e0).abs() / e0.abs());
    }
    (worst, lane.counters.switches)
}

#[test]
fn undamped_power_law_impacts_conserve_energy_at_the_order_the_law_allows() {
    // Every step of a contact is smooth but the one that starts at the touch, where the
    // force grows as t^n: RK4's quadrature of it errs by O(h^(n+1)) (Simpson's rule is
    // exact to cubics), so the order through an impact is min(4, n + 1) (docs/numerics.md).
    let steps = [500, 1000, 2000];
    let laws = [1.5, 2.0, 2.5, 3.0];
    let drifts: Vec<Vec<(f64, u64)>> = laws
        .iter()
        .map(|&n_c| steps.iter().map(|&n| energy_drift(n_c, n)).collect())
        .collect();
    for (n_c, d) in laws.iter().zip(&drifts) {
        let order = (d[0].0 / d[2].0).log2() / 2.0;
        eprintln!("n = {n_c}: drifts at N = {steps:?}: {d:?}, observed order {order:.2}");
    }
    for (n_c, d) in laws.iter().zip(&drifts) {
        for (_, sw) in d {
            assert!(*sw > 40, "n = {n_c}: the test must exercise contact ({sw})");
        }
        assert!(d[2].0 < 1e-5, "n = {n_c}: drift {:.3e} at N = 2000", d[2].0);
        let order = (d[0].0 / d[2].0).log2() / 2.0;
        let expected = (n_c + 1.0).min(4.0);
        assert!(
            order >= expected - 0.25,
            "n = {n_c}: observed order {order:.2} < {expected} from {d:?}"
        );
    }
}

/// Two free bodies (supports a million times softer than the article's, no gravity)
/// and a Hunt-Crossley contact of damping `alpha`: the rotor, `gap` short of the stator,
/// moves onto it at `v` [m/s]. Returns the coefficient of restitution of the one impact
/// (separation speed over approach speed, after one period).
fn restitution(n_c: f64, alpha: f64, v: f64) -> f64 {
    let p = Params {
        omega_r: 1e-3,
        omega_s: 1e-3,
        xi_r: 0.0,
        xi_s: 0.0,
        e: 0.0,
        a_g: 0.0,
        alpha_c: alpha,
        ..hertz(n_c)
    };
    let mut x0 = [0.0; STATE_DIM];
    x0[X_R] = p.delta - 1e-4;
    x0[VX_R] = v;
    let cfg = StepperConfig {
        steps_per_period: 4000,
        ..StepperConfig::default()
    };
    let lc = LaneConsts::<f64>::new(&p, 130.0, &cfg);
    let mut lane = Lane::<f64>::new(&x0, p.delta);
    for _ in 0..4000 {
        macro_step(&lc, &mut lane);
    }
    assert!(
        lane.counters.switches == 2,
        "one impact: {:?}",
        lane.counters
    );
    assert!(lane.x[X_R] - lane.x[X_S] < p.delta, "separated");
    -(lane.x[VX_R] - lane.x[VX_S]) / v
}

/// The restitution of the one-degree-of-freedom impact m g'' = -k g^n (1 + 3/2 alpha g')
/// from g = 0 at g' = v: an independent reference, integrated by RK4 with 200 000 steps
/// over the contact and the exit located by linear interpolation.
fn restitution_reference(n: f64, k: f64, m: f64, alpha: f64, v: f64) -> f64 {
    let acc = |g: f64, gd: f64| -k / m * g.max(0.0).powf(n) * (1.0 + 1.5 * alpha * gd);
    // The undamped contact lasts about 3.2 g_max / v; g_max from the energy.
    let g_max = ((n + 1.0) * 0.5 * m * v * v / k).powf(1.0 / (n + 1.0));
    let dt = 4.0 * g_max / v / 200_000.0;
    let (mut g, mut gd) = (0.0, v);
    loop {
        let f = |g: f64, gd: f64| (gd, acc(g, gd));
        let k1 = f(g, gd);
        let k2 = f(g + 0.5 * dt * k1.0, gd + 0.5 * dt * k1.1);
        let k3 = f(g + 0.5 * dt * k2.0, gd + 0.5 * dt * k2.1);
        let k4 = f(g + dt * k3.0, gd + dt * k3.1);
        let gn = g + dt / 6.0 * (k1.0 + 2.0 * k2.0 + 2.0 * k3.0 + k4.0);
        let gdn = gd + dt / 6.0 * (k1.1 + 2.0 * k2.1 + 2.0 * k3.1 + k4.1);
        if gn <= 0.0 && gdn < 0.0 {
            let s = g / (g - gn);
            return -(gd + s * (gdn - gd)) / v;
        }
        (g, gd) = (gn, gdn);
    }
}

#[test]
fn hunt_crossley_restitution_is_one_minus_alpha_v_for_slow_impacts() {
    // Hunt and Crossley (1975): e = 1 - alpha v_in to first order in alpha v_in, for any
    // exponent; the remainder is second order, so it falls 4x when alpha v_in halves.
    // Each impact also equals an independent integration of the impact alone.
    for n_c in [1.0, 1.5] {
        let undamped = restitution(n_c, 0.0, 0.1);
        assert!((undamped - 1.0).abs() < 1e-6, "n = {n_c}: e = {undamped}");
        let mut last = f64::NAN;
        for av in [0.04, 0.02, 0.01] {
            let v = 0.1;
            let e = restitution(n_c, av / v, v);
            let p = hertz(n_c);
            let m = p.m_r * p.m_s / (p.m_r + p.m_s);
            let reference = restitution_reference(n_c, p.k_c, m, av / v, v);
            let remainder = e - (1.0 - av);
            eprintln!(
                "n = {n_c}, alpha v = {av}: e = {e:.8}, reference {reference:.8}, \
                 remainder {remainder:.3e}"
            );
            assert!(
                (e - reference).abs() < 1e-6,
                "n = {n_c}: {e} vs {reference}"
            );
            assert!(
                remainder.abs() < 1.5 * av * av,
                "n = {n_c}: e = {e} at {av}"
            );
            if last.is_finite() {
                let ratio = last / remainder;
                assert!((3.0..5.0).contains(&ratio), "n = {n_c}: ratio {ratio}");
            }
            last = remainder;
        }
    }
}

#[test]
fn a_hertzian_contact_holds_an_offset_stator_in_static_balance() {
    // A stator set 1 mm beyond the gap: the rest state in contact balances every force,
    // k_r x_r = k_c g^n along x with the stator's spring taking the rest.
    let p = Params {
        o_x: 0.007,
        e: 0.0,
        ..hertz(1.5)
    };
    let x = p.rest_state().expect("a rest state");
    let g = model::penetration(p.delta, &x);
    assert!(g > 0.0 && g < p.delta / 10.0, "g = {g}");
    let a = model::rhs(&p, 1.0, 0.0, &x);
    for (i, v) in a.iter().enumerate() {
        assert!(v.abs() < 1e-9 * p.a_g, "acceleration {i}: {v}");
    }
    let spring = p.k_r() * x[X_R];
    let contact = -p.k_c * g.powf(1.5) * (x[X_R] - x[X_S]) / (g + p.delta);
    assert!(
        (spring - contact).abs() < 1e-9 * spring.abs(),
        "{spring} vs {contact}"
    );
}

#[test]
fn contact_law_values_out_of_range_are_refused_naming_them() {
    for (name, bad) in [
        ("n_c", 1.25),
        ("n_c", 0.5),
        ("n_c", 3.5),
        ("n_c", f64::NAN),
        ("alpha_c", -0.1),
        ("alpha_c", f64::INFINITY),
    ] {
        let mut p = Params::default();
        p.set(name, bad).unwrap();
        let text = p.validate().unwrap_err().to_string();
        assert!(text.contains(name), "{name}: {text}");
        if name == "n_c" {
            assert!(text.contains("1, 1.5, 2, 2.5 or 3"), "{text}");
        }
    }
}

/// The gap's power a^(n-1) is exact arithmetic on a: a product of a's and at most one
/// correctly rounded square root, for every allowed n; and its root-free form (which a
/// CPU batch whose exponents are all whole takes) has the same bits where n - 1 is whole.
#[test]
fn the_gaps_power_is_products_and_one_root_and_its_root_free_form_agrees_for_whole_n() {
    use model::{pow_half, pow_whole};
    let mut a = 1.0e-9_f64;
    while a < 1.0e3 {
        // Gaps of 1 nm to 1 km, and 0; each also as an f32 value.
        for x in [a, f64::from(a as f32), 0.0] {
            let want = [1.0, x.sqrt(), x, x * x.sqrt(), x * x];
            for (i, m) in [0.0, 0.5, 1.0, 1.5, 2.0].into_iter().enumerate() {
                assert_eq!(pow_half(x, m).to_bits(), want[i].to_bits(), "{x}^{m}");
                let y = x as f32;
                let want32 = [1.0, y.sqrt(), y, y * y.sqrt(), y * y][i];
                assert_eq!(pow_half(y, m as f32).to_bits(), want32.to_bits(), "{y}^{m}");
                if m.fract() == 0.0 {
                    assert_eq!(pow_whole(x, m).to_bits(), pow_half(x, m).to_bits());
                    assert_eq!(pow_whole(y, m as f32).to_bits(), want32.to_bits());
                }
            }
        }
        a *= 1.37;
    }
}

#[test]
fn a_pick_by_bits_returns_the_chosen_operand_exactly() {
    use jeffcott_core::real::Real;
    // Signed zeros, a NaN with a payload, infinities, a subnormal: the picked value's
    // bits are the chosen operand's, as an `if` would return them.
    let v = [
        0.0,
        -0.0,
        f64::from_bits(0x7ff8_0000_0000_beef),
        f64::NEG_INFINITY,
        5e-324,
        1.5,
    ];
    for x in v {
        for y in v {
            for c in [true, false] {
                let want = if c { x } else { y };
                assert_eq!(f64::pick(c, x, y).to_bits(), want.to_bits(), "{c} {x} {y}");
                let (x32, y32) = (x as f32, y as f32);
                let want32 = if c { x32 } else { y32 };
                assert_eq!(f32::pick(c, x32, y32).to_bits(), want32.to_bits());
            }
        }
    }
}

#[test]
fn the_concentric_guard_without_a_root_agrees_with_the_distance_being_zero() {
    // Zeros of either sign, squares that underflow to zero or to subnormals, ordinary
    // and huge offsets, infinities and NaN: |d| <= 0 where, and only where, the guard
    // holds.
    let v = [
        0.0,
        -0.0,
        1e-200,
        -1e-170,
        1e-160,
        2.5e-4,
        -3.0,
        1e200,
        f64::INFINITY,
        f64::NAN,
    ];
    for dx in v {
        for dy in v {
            let r = (dx * dx + dy * dy).sqrt();
            assert_eq!(model::concentric(dx, dy), r <= 0.0, "({dx}, {dy})");
            let (x, y) = (dx as f32, dy as f32);
            let r32 = (x * x + y * y).sqrt();
            assert_eq!(model::concentric(x, y), r32 <= 0.0, "({x}, {y}) in f32");
        }
    }
}

#[test]
fn the_analytic_jacobian_of_every_contact_law_matches_central_differences() {
    for (i, n_c) in [1.0, 1.5, 2.0, 2.5, 3.0].into_iter().enumerate() {
        for (mu, c_c, alpha) in [(0.0, 0.0, 0.0), (0.2, 0.0, 0.4), (0.1, 2e4, 0.2)] {
            let p = Params {
                mu,
                c_c,
                alpha_c: alpha,
                ..hertz(n_c)
            };
            let mut x = p.static_equilibrium();
            x[X_R] = p.delta + 2e-4 * (1.0 + unit(i, 1).abs());
            x[VX_R] = 0.3;
            x[VY_R] = -0.2;
            x[VX_S] = 0.05;
            assert!(model::penetration(p.delta, &x) > 0.0);
            let scale = p.k_c * 1e-4f64.powf(n_c - 1.0) / p.m_r;
            common::assert_jacobian_matches_central_differences(&p, &x, 1e-9 * scale);
        }
    }
}

fn run(spec: &EnsembleSpec, backend: Backend, lyapunov: bool) -> EnsembleResult {
    spec.validate().expect("a valid spec");
    Engine::new(backend, spec.precision)
        .expect("an engine")
        .run(spec, lyapunov, Control::none())
        .expect("a run")
        .0
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn the_gpu_kernel_runs_every_contact_law_to_the_cpus_bits() {
    if gpu_f64_device().is_none() {
        return;
    }
    // Each exponent with and without Hunt-Crossley damping, friction on some, and lanes
    // of the linear spring among them (each lane takes its own law in a kernel that has
    // the laws' code), from states thrown at the stator.
    let sets: Vec<Params> = (0..12)
        .map(|i| Params {
            alpha_c: if i % 3 == 1 {
                0.3 * unit(i, 1).abs()
            } else {
                0.0
            },
            mu: if i % 2 == 0 { 0.0 } else { 0.15 },
            o_x: if i % 4 == 3 { 0.002 } else { 0.0 },
            ..hertz([1.0, 1.5, 2.0, 2.5, 3.0, 1.5][i % 6])
        })
        .collect();
    let lanes: Vec<LaneSpec> = (0..sets.len())
        .map(|i| {
            let mut x0 = sets[i].static_equilibrium();
            x0[VX_R] = 0.9 * unit(i, 2);
            x0[VY_R] = 0.9 * unit(i, 3);
            LaneSpec {
                omega: 128.0 + 6.0 * unit(i, 4).abs(),
                x0,
                param_set: i as u32,
            }
        })
        .collect();
    for (exact, lyapunov) in [(false, false), (true, false), (false, true)] {
        let case = format!("exact free flight {exact}, lambda_1 {lyapunov}");
        let s = EnsembleSpec {
            lanes: lanes.clone(),
            param_sets: sets.clone(),
            transient: 40,
            recorded: 6,
            stepper: StepperConfig {
                exact_free_flight: exact,
                ..StepperConfig::default()
            },
            precision: Precision::F64,
        };
        let cpu = run(&s, Backend::Cpu, lyapunov);
        let gpu = run(&s, Backend::Gpu, lyapunov);
        assert!(
            cpu.counters.iter().all(|c| c.contact_steps > 0),
            "{case}: a lane did not rub: {:?}",
            cpu.counters
        );
        assert_eq!(bits(&cpu.poincare), bits(&gpu.poincare), "{case}");
        assert_eq!(cpu.status, gpu.status, "{case}");
        assert_eq!(cpu.counters, gpu.counters, "{case}");
        assert_eq!(
            bits(&cpu.final_state.concat()),
            bits(&gpu.final_state.concat()),
            "{case}"
        );
        if lyapunov {
            let (a, b) = (
                cpu.lambda1.expect("lambda_1"),
                gpu.lambda1.expect("lambda_1"),
            );
            assert_eq!(bits(&a), bits(&b), "{case}");
        }
    }
}
