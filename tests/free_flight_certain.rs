//! The free-flight certificate (no switch search where no switch can
//! happen): wherever `free_flight_certain` says a free-flight trial step stays clear of
//! the stator, the full search finds no switch and the Hermite interpolant it searches
//! stays below the gap at every fraction; and on real runs (the standard job, grazing
//! orbits) it does skip most free-flight searches. The contact certificate likewise:
//! a certified contact sub-step's full search finds no switch and no g above the lane's
//! largest penetration so far. That a skipped search changes no output bit is proven by
//! the scalar/batch/GPU parity tests and the golden set.

use jeffcott_core::integrate::lane::{
    Lane, LaneConsts, StepperConfig, find_switch, free_flight_certain, hermite_gap,
    in_contact_certain, macro_step, rk4_substep,
};
use jeffcott_core::model::{Params, STATE_DIM, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S};
use jeffcott_core::real::Real;

/// A deterministic uniform number in [-1, 1) from (i, d) (splitmix64).
fn unit(i: u64, d: u64) -> f64 {
    let mut z = i
        .wrapping_mul(0x9E37_79B9_7F4A_7C15)
        .wrapping_add(d.wrapping_mul(0xD1B5_4A32_D192_ED03));
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// A state whose relative displacement has length `r` at angle `phi` and relative
/// velocity `v` (stator parts random and small).
fn state(i: u64, r: f64, phi: f64, v: [f64; 2]) -> [f64; STATE_DIM] {
    let mut x = [0.0; STATE_DIM];
    x[X_S] = 1e-4 * unit(i, 1);
    x[Y_S] = 1e-4 * unit(i, 2);
    x[VX_S] = 0.05 * unit(i, 3);
    x[VY_S] = 0.05 * unit(i, 4);
    x[X_R] = x[X_S] + r * phi.cos();
    x[Y_R] = x[Y_S] + r * phi.sin();
    x[VX_R] = x[VX_S] + v[0];
    x[VY_R] = x[VY_S] + v[1];
    x
}

fn cast<R: Real>(x: &[f64; STATE_DIM]) -> [R; STATE_DIM] {
    std::array::from_fn(|i| R::lit(x[i]))
}

/// Pairs (x0, x1, hs) of arbitrary end states around the gap (not steps of the
/// dynamics: the certificate must hold for any interpolant), with velocities from
/// gentle to violent and durations from a macro step to a whole period.
fn synthetic<R: Real>(count: u64) -> Vec<([R; STATE_DIM], [R; STATE_DIM], R)> {
    let delta = 0.006;
    (0..count)
        .map(|i| {
            let r0 = delta * (1.0 + 0.3 * unit(i, 10)).abs();
            let r1 = delta * (1.0 + 0.3 * unit(i, 11)).abs();
            let speed = 10f64.powf(-3.0 + 3.5 * (unit(i, 12) + 1.0) / 2.0);
            let v0 = [speed * unit(i, 13), speed * unit(i, 14)];
            let v1 = [speed * unit(i, 15), speed * unit(i, 16)];
            let hs = 10f64.powf(-5.0 + 3.0 * (unit(i, 17) + 1.0) / 2.0);
            let phi0 = std::f64::consts::PI * unit(i, 18);
            let phi1 = phi0 + 0.5 * unit(i, 19);
            (
                cast(&state(i, r0, phi0, v0)),
                cast(&state(i + 7, r1, phi1, v1)),
                R::lit(hs),
            )
        })
        .collect()
}

fn certificate_never_hides_a_switch<R: Real>() {
    let lc = LaneConsts::<R>::new(&Params::default(), 133.0, &StepperConfig::default());
    let delta = lc.c.delta;
    let (mut certain, mut uncertain, mut near) = (0, 0, 0);
    for (x0, x1, hs) in synthetic::<R>(40_000) {
        if !free_flight_certain(&lc, &x0, &x1, hs) {
            uncertain += 1;
            continue;
        }
        certain += 1;
        let sw = find_switch(&lc, &x0, &x1, hs, false);
        assert!(
            sw.theta.to_f64() > 1.0,
            "{}: certified step has a switch at {:?}: {x0:?} -> {x1:?}, hs {hs:?}",
            R::WGSL_NAME,
            sw.theta
        );
        // Densely, not only where the search looks.
        let mut top = f64::NEG_INFINITY;
        for j in 0..=512 {
            let (g, _) = hermite_gap(delta, &x0, &x1, hs, R::lit(j as f64 / 512.0));
            assert!(
                g.to_f64() <= 0.0,
                "{}: certified step reaches g = {g:?} at {j}/512",
                R::WGSL_NAME
            );
            top = top.max(g.to_f64());
        }
        // Certified steps that come within 1 % of the gap: the bound is not slack.
        if top > -0.01 * delta.to_f64() {
            near += 1;
        }
    }
    eprintln!(
        "{}: {certain} certified ({near} within 1 % of the gap), {uncertain} searched",
        R::WGSL_NAME
    );
    assert!(
        certain > 5000 && uncertain > 5000 && near > 100,
        "{certain} {uncertain} {near}"
    );
}

#[test]
fn a_certified_free_flight_step_never_has_a_switch_on_40000_steps_around_the_gap() {
    certificate_never_hides_a_switch::<f64>();
    certificate_never_hides_a_switch::<f32>();
}

/// Real runs: every untouched macro step of `lanes` lanes over `periods` periods at
/// `omega` is checked (certificate => the full search finds nothing, and the step does
/// not touch the stator); returns the share of free-flight macro steps certified and
/// the number of them that touched.
fn certified_share_on_runs(
    p: &Params,
    omega: f64,
    x0s: &[[f64; STATE_DIM]],
    periods: u32,
) -> (f64, u64) {
    let cfg = StepperConfig::default();
    let lc = LaneConsts::<f64>::new(p, omega, &cfg);
    let (mut free, mut certified, mut touched) = (0u64, 0u64, 0u64);
    for x0 in x0s {
        let mut lane = Lane::<f64>::new(x0, p.delta);
        for _ in 0..periods * lc.n {
            let mut certain = false;
            let starts_free = !lane.contact && !lane.status.is_frozen();
            if starts_free {
                free += 1;
                let x1 = rk4_substep(&lc, &lane.x, lane.k, 0.0, 1.0, false);
                if free_flight_certain(&lc, &lane.x, &x1, lc.h) {
                    certain = true;
                    certified += 1;
                    let sw = find_switch(&lc, &lane.x, &x1, lc.h, false);
                    assert!(sw.theta > 1.0, "W = {omega}: certified step switches");
                }
            }
            let before = lane.counters.contact_steps;
            macro_step(&lc, &mut lane);
            if starts_free && lane.counters.contact_steps > before {
                touched += 1;
                assert!(!certain, "W = {omega}: a certified step touched the stator");
            }
        }
    }
    assert!(free > 0);
    (certified as f64 / free as f64, touched)
}

#[test]
fn on_the_standard_job_and_grazing_orbits_certified_steps_hide_no_switch() {
    let p = Params::default();
    // The standard job's lanes (x_r0 over [-4, 4] mm at W = 133), 16 of them.
    let x0s: Vec<[f64; STATE_DIM]> = (0..16)
        .map(|i| {
            let mut x = p.static_equilibrium();
            x[X_R] = -0.004 + 0.008 * i as f64 / 15.0;
            x
        })
        .collect();
    let (share, _) = certified_share_on_runs(&p, 133.0, &x0s, 30);
    eprintln!(
        "standard job: {:.1} % of free-flight macro steps certified",
        100.0 * share
    );
    assert!(share > 0.3, "{share}");
    // Grazing orbits: the free orbit at W = 120 (no rub there), then the gap set to its
    // largest relative displacement within +1e-6 / -1e-5, so the orbit skims the stator
    // once a period (just missing it, or just touching it). (At +1e-5 the convex-hull
    // bound, which exceeds the orbit by (hs |v|)^2 / (18 |p|), about 9e-6 of it here,
    // rightly certifies every step.)
    let start = [p.static_equilibrium()];
    let lc = LaneConsts::<f64>::new(&p, 120.0, &StepperConfig::default());
    let mut lane = Lane::<f64>::new(&start[0], p.delta);
    let mut reach: f64 = 0.0;
    let mut orbit_start = [lane.x];
    for period in 0..60 {
        if period == 40 {
            // The reach is measured on the stretch the runs below repeat, so that a gap
            // below it is certainly touched.
            orbit_start = [lane.x];
        }
        for _ in 0..lc.n {
            macro_step(&lc, &mut lane);
            if period >= 40 {
                let x = lane.x;
                reach = reach.max((x[X_R] - x[X_S]).hypot(x[Y_R] - x[Y_S]));
            }
        }
    }
    assert_eq!(lane.counters.contact_steps, 0, "W = 120 must not rub");
    assert!(reach > 0.5 * p.delta, "{reach}");
    for scale in [1.0 + 1e-6, 1.0 - 1e-5] {
        let q = Params {
            delta: reach * scale,
            ..p.clone()
        };
        let (share, touched) = certified_share_on_runs(&q, 120.0, &orbit_start, 20);
        eprintln!(
            "grazing (gap {scale} x reach): {:.2} % certified, {touched} steps from free \
             flight touched (none of them certified)",
            100.0 * share
        );
        // Touching the stator once a period: the steps that touch are there to be
        // declined (just missing it, every step may be certified: each certified step
        // was searched above and hid no switch).
        if scale < 1.0 {
            assert!(touched > 0, "the orbit does not touch the stator");
        }
    }
}

/// The contact certificate (`in_contact_certain`, which lets the steppers skip the
/// search of a contact sub-step): on real runs at W = 133, every certified contact
/// sub-step's full search finds no switch, and no sampled g above the lane's largest
/// penetration so far, so skipping it changes no bit; and it declines where the rotor
/// leaves the stator.
#[test]
fn a_certified_contact_step_has_no_switch_and_no_new_largest_penetration() {
    let p = Params::default();
    let cfg = StepperConfig::default();
    let lc = LaneConsts::<f64>::new(&p, 133.0, &cfg);
    let (mut held, mut certified, mut leaving, mut leaving_certified) = (0u64, 0u64, 0u64, 0u64);
    for i in 0..16 {
        let mut x0 = p.static_equilibrium();
        x0[X_R] = -0.004 + 0.008 * i as f64 / 15.0;
        let mut lane = Lane::<f64>::new(&x0, p.delta);
        for _ in 0..30 * lc.n {
            if lane.contact && !lane.status.is_frozen() {
                held += 1;
                let hs = lc.inv_r * lc.h;
                let x1 = rk4_substep(&lc, &lane.x, lane.k, 0.0, lc.inv_r, true);
                let max_pen = lane.counters.max_penetration;
                let sw = find_switch(&lc, &lane.x, &x1, hs, true);
                let certain = in_contact_certain(p.delta, &lane.x, &x1, hs, max_pen);
                if sw.theta <= 1.0 {
                    leaving += 1;
                }
                if certain {
                    certified += 1;
                    leaving_certified += (sw.theta <= 1.0) as u64;
                    assert!(sw.max_g <= max_pen, "{} > {max_pen}", sw.max_g);
                }
            }
            macro_step(&lc, &mut lane);
        }
    }
    eprintln!(
        "contact sub-steps: {certified} of {held} certified; {leaving} leave the stator, \
         {leaving_certified} of them certified"
    );
    assert_eq!(
        leaving_certified, 0,
        "a certified contact step leaves the stator"
    );
    assert!(
        leaving > 100 && certified > held / 2,
        "{leaving} {certified} {held}"
    );
}
