//! Physics statements the model and the integrators must satisfy (docs/model.md 6). Each test
//! is named by what it proves.

use jeffcott_core::integrate::article::{ArticleConfig, ArticleStepper, ErrorNorm};
use jeffcott_core::integrate::lane::{Lane, LaneConsts, StepperConfig, advance_period, macro_step};
use jeffcott_core::model::*;

mod common;

use common::{POSITIONS, max_abs_diff};

fn lane_run(p: &Params, omega: f64, x0: State, n: u32, periods: u32) -> Vec<State> {
    lane_run_r(
        p,
        omega,
        x0,
        n,
        StepperConfig::default().contact_substeps,
        periods,
    )
}

/// [`lane_run`] with contact refinement `r`.
fn lane_run_r(p: &Params, omega: f64, x0: State, n: u32, r: u32, periods: u32) -> Vec<State> {
    let cfg = StepperConfig {
        steps_per_period: n,
        contact_substeps: r,
        ..StepperConfig::default()
    };
    let lc = LaneConsts::<f64>::new(p, omega, &cfg);
    let mut lane = Lane::<f64>::new(&x0, p.delta);
    (0..periods)
        .map(|_| {
            advance_period(&lc, &mut lane);
            assert!(!lane.status.is_frozen(), "lane froze: {:?}", lane.status);
            lane.x
        })
        .collect()
}

#[test]
fn free_flight_matches_linear_unbalance_response() {
    let p = Params {
        delta: 1.0,
        ..Params::default()
    };
    let y_r0 = -p.a_g / (p.omega_r * p.omega_r);
    let y_s0 = -p.a_g / (p.omega_s * p.omega_s);
    for omega in [100.0, 133.0, 139.0, 160.0] {
        let pts = lane_run(&p, omega, p.static_equilibrium(), 500, 600);
        let x = pts.last().unwrap();
        let (amp, lag) = linear_unbalance_response(&p, omega);
        // At t = kT (phi0 = 0): x_r = A cos(lag), y_r - y0 = -A sin(lag),
        // vx_r = A W sin(lag), vy_r = A W cos(lag).
        let amp_num = (x[X_R].powi(2) + (x[Y_R] - y_r0).powi(2)).sqrt();
        let lag_num = (-(x[Y_R] - y_r0)).atan2(x[X_R]);
        let amp_vel = (x[VX_R].powi(2) + x[VY_R].powi(2)).sqrt() / omega;
        assert!(
            (amp_num / amp - 1.0).abs() < 1e-6,
            "W={omega}: amplitude {amp_num} vs {amp}"
        );
        assert!(
            (amp_vel / amp - 1.0).abs() < 1e-6,
            "W={omega}: velocity amplitude {amp_vel} vs {amp}"
        );
        assert!(
            (lag_num - lag).abs() < 1e-6,
            "W={omega}: phase lag {lag_num} vs {lag}"
        );
        // A circular orbit: the velocity leads the displacement by a quarter turn.
        let lag_vel = x[VX_R].atan2(x[VY_R]);
        assert!(
            (lag_vel - lag).abs() < 1e-6,
            "W={omega}: velocity phase {lag_vel} vs {lag}"
        );
        // The stator rests at its static deflection.
        assert!(x[X_S].abs() < 1e-14 && (x[Y_S] - y_s0).abs() < 1e-14);
        assert!(x[VX_S].abs() < 1e-12 && x[VY_S].abs() < 1e-12);
    }
}

/// The undamped, unforced, frictionless system with the rotor thrown against the stator.
fn conservative_rub() -> (Params, State) {
    let p = Params {
        xi_r: 0.0,
        xi_s: 0.0,
        e: 0.0,
        mu: 0.0,
        ..Params::default()
    };
    let mut x0 = p.static_equilibrium();
    // Free amplitude ~ v/w_r = 7.9 mm > the 6 mm gap: it rubs twice per rotor cycle.
    x0[VX_R] = 1.1;
    x0[VY_R] = 0.4;
    (p, x0)
}

fn energy_drift(n: u32) -> (f64, u64) {
    let (p, x0) = conservative_rub();
    let omega = 133.0;
    let cfg = StepperConfig {
        steps_per_period: n,
        ..StepperConfig::default()
    };
    let lc = LaneConsts::<f64>::new(&p, omega, &cfg);
    let mut lane = Lane::<f64>::new(&x0, p.delta);
    let e0 = energy(&p, &x0);
    let mut worst: f64 = 0.0;
    for _ in 0..100 * n {
        macro_step(&lc, &mut lane);
        worst = worst.max((energy(&p, &lane.x) - e0).abs() / e0.abs());
    }
    (worst, lane.counters.switches)
}

#[test]
fn energy_is_conserved_through_rubbing_at_fourth_order_or_better() {
    // Halving the macro step must cut the drift over 100 periods at least 16x (order >= 4).
    let steps = [250, 500, 1000, 2000];
    let drifts: Vec<(f64, u64)> = steps.iter().map(|&n| energy_drift(n)).collect();
    for (n, (d, sw)) in steps.iter().zip(&drifts) {
        eprintln!(
            "N = {n}: max relative energy drift over 100 periods {d:.3e}, {sw} contact switches"
        );
        assert!(*sw > 100, "the test must exercise contact");
    }
    for w in drifts.windows(2) {
        let ratio = w[0].0 / w[1].0;
        assert!(
            ratio >= 16.0,
            "drift fell only {ratio:.2}x on halving the step: {drifts:?}"
        );
    }
    // The named step size: N = 2000 steps per period at W = 133 rad/s, h = 23.6 us
    // (contact oscillations at ~2000 rad/s make the impacts the stiffest part).
    assert!(drifts[3].0 < 1e-6, "drift {:.3e} at N = 2000", drifts[3].0);
}

#[test]
fn contact_forces_are_equal_and_opposite_and_continuous_at_zero_penetration() {
    for mu in [0.0, 0.3] {
        let p = Params {
            mu,
            ..Params::default()
        };
        let c = Coeffs::<f64>::new(&p, 133.0);
        let mut seed = 12345u64;
        let mut rnd = || {
            seed = seed
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (seed >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        for _ in 0..500 {
            let mut x = [0.0; STATE_DIM];
            for v in x.iter_mut() {
                *v = rnd() * 0.02;
            }
            let on = rhs_frozen(&c, &x, 0.3, 0.4, true);
            let off = rhs_frozen(&c, &x, 0.3, 0.4, false);
            // Contact parts of m a: rotor gets F, stator gets -F.
            for (ar, as_) in [(VX_R, VX_S), (VY_R, VY_S)] {
                let f_rotor = p.m_r * (on[ar] - off[ar]);
                let f_stator = p.m_s * (on[as_] - off[as_]);
                let scale = f_rotor.abs().max(1.0);
                assert!(
                    (f_rotor + f_stator).abs() <= 1e-9 * scale,
                    "{f_rotor} vs {f_stator}"
                );
            }
            // The normal part points from the stator to the rotor centre when g > 0.
            let (fx, fy) = contact_force(&p, &x);
            let (dx, dy) = (x[X_R] - x[X_S], x[Y_R] - x[Y_S]);
            let g = penetration(p.delta, &x);
            if g > 0.0 {
                let radial = (fx * dx + fy * dy) / (dx * dx + dy * dy).sqrt();
                assert!(
                    (radial + p.k_c * g).abs() <= 1e-6 * p.k_c * g,
                    "normal force {radial} vs -k_c g"
                );
                let tangential = (fx * dy - fy * dx) / (dx * dx + dy * dy).sqrt();
                assert!((tangential - mu * p.k_c * g).abs() <= 1e-6 * p.k_c * g + 1e-9);
            } else {
                assert_eq!((fx, fy), (0.0, 0.0));
            }
            // Continuity: on the surface g = 0 both modes give the same field, and just
            // inside the force is k_c g (no jump).
            let r = (dx * dx + dy * dy).sqrt();
            let mut xs = x;
            for eps in [0.0, 1e-12] {
                let scale = (p.delta + eps) / r;
                xs[X_R] = x[X_S] + dx * scale;
                xs[Y_R] = x[Y_S] + dy * scale;
                let a = rhs_frozen(&c, &xs, 0.3, 0.4, true);
                let b = rhs_frozen(&c, &xs, 0.3, 0.4, false);
                let jump = (0..STATE_DIM)
                    .map(|i| (a[i] - b[i]).abs())
                    .fold(0.0, f64::max);
                assert!(
                    jump <= c.kc_mr * (eps + 1e-17) * 2.0 * (1.0 + mu) + 1e-9,
                    "jump {jump} at eps {eps}"
                );
            }
        }
    }
}

#[test]
fn rk4_converges_at_fourth_order_in_free_flight() {
    let p = Params {
        delta: 1.0,
        ..Params::default()
    };
    let omega = 133.0;
    let mut x0 = p.static_equilibrium();
    x0[VX_R] = 0.3;
    x0[X_S] = 1e-4;
    x0[VY_S] = -0.02;
    let reference = lane_run(&p, omega, x0, 6400, 5)[4];
    let errs: Vec<f64> = [50, 100, 200, 400]
        .iter()
        .map(|&n| max_abs_diff(&lane_run(&p, omega, x0, n, 5)[4], &reference, &POSITIONS))
        .collect();
    for w in errs.windows(2) {
        let order = (w[0] / w[1]).log2();
        eprintln!(
            "errors {:.3e} -> {:.3e}: observed order {order:.3}",
            w[0], w[1]
        );
        assert!(
            (3.8..=4.2).contains(&order),
            "observed order {order} from {errs:?}"
        );
    }
}

/// The rubbing transient the convergence tests integrate: Table 1 at 132.2 rad/s, from
/// the static equilibrium with the rotor thrown at 0.9 m/s.
fn rubbing_transient() -> (Params, f64, State) {
    let p = Params::default();
    let mut x0 = p.static_equilibrium();
    x0[VX_R] = 0.9;
    (p, 132.2, x0)
}

#[test]
fn lane_stepper_converges_at_fourth_order_through_contact() {
    // The located crossings keep fourth order although the field is only C0 at g = 0
    // (docs/numerics.md). Error: worst position error over 20 Poincare points of a rubbing
    // transient; successive ratios wander (error contributions of both signs), so the
    // claim is on the least-squares order over N = 250..2000, with every ratio above 2^3.5.
    let (p, omega, x0) = rubbing_transient();
    let reference = lane_run(&p, omega, x0, 32000, 20);
    let ns = [250u32, 500, 1000, 2000];
    let errs: Vec<f64> = ns
        .iter()
        .map(|&n| {
            let pts = lane_run(&p, omega, x0, n, 20);
            pts.iter()
                .zip(&reference)
                .map(|(a, b)| max_abs_diff(a, b, &POSITIONS))
                .fold(0.0, f64::max)
        })
        .collect();
    common::assert_fourth_order(&ns, &errs);
}

/// Contact refinement (R sub-steps of 1/R in contact) attacks the dominant error: in
/// contact the stiffness adds a frequency of about 2000 rad/s, 15 times the forcing's,
/// so RK4's local error there is ~1000 times that of free flight at the same step. At
/// the same N, R = 2 divides the rubbing transient's error by at least 4 (the contact
/// part of the error by up to 2^4) and R = 4 by more again; the order through contact
/// stays four with refinement on (the test above runs the default R).
#[test]
fn contact_refinement_divides_the_error_through_contact_at_equal_n() {
    let (p, omega, x0) = rubbing_transient();
    let reference = lane_run_r(&p, omega, x0, 32000, 1, 20);
    let err = |r: u32| {
        lane_run_r(&p, omega, x0, 500, r, 20)
            .iter()
            .zip(&reference)
            .map(|(a, b)| max_abs_diff(a, b, &POSITIONS))
            .fold(0.0, f64::max)
    };
    let (e1, e2, e4) = (err(1), err(2), err(4));
    eprintln!("N = 500: R = 1 {e1:e}, R = 2 {e2:e}, R = 4 {e4:e}");
    assert!(
        e2 * 4.0 < e1,
        "R = 2 gave {e2:e} against {e1:e} without refinement"
    );
    assert!(e4 < e2, "R = 4 gave {e4:e} against {e2:e} at R = 2");
}

#[test]
fn analytic_jacobian_matches_central_differences_in_and_out_of_contact() {
    for mu in [0.0, 0.25] {
        let p = Params {
            mu,
            ..Params::default()
        };
        let mut outside = p.static_equilibrium();
        outside[X_R] = 0.003;
        outside[VX_R] = 0.4;
        outside[VY_S] = 0.01;
        let mut inside = outside;
        inside[X_R] = 0.00604;
        inside[Y_R] = 0.0005;
        inside[X_S] = 1e-5;
        assert!(penetration(p.delta, &outside) < 0.0 && penetration(p.delta, &inside) > 1e-5);
        for x in [outside, inside] {
            let abs_tol = 1e-6 * p.k_c / p.m_r * 1e-3;
            common::assert_jacobian_matches_central_differences(&p, &x, abs_tol);
        }
    }
}

#[test]
fn lane_stepper_and_article_scheme_agree_on_a_periodic_attractor() {
    let p = Params::default();
    let omega = 131.7;
    let x0 = p.static_equilibrium();
    let lane = lane_run(&p, omega, x0, 500, 1000)[999];
    let cfg = ArticleConfig {
        steps_per_period: 1000,
        norm: ErrorNorm::Positions,
        ..ArticleConfig::default()
    };
    let mut art = ArticleStepper::new(&p, omega, cfg, x0);
    for _ in 0..1000 {
        art.advance_period();
    }
    let d = max_abs_diff(&lane, &art.x, &POSITIONS);
    eprintln!("lane (N=500) vs article (T/1000, positions): {d:.3e} m");
    assert!(d < 1e-7, "Poincare points differ by {d:e} m");
}
