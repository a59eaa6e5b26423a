//! The convergence study that fixes the lane stepper's default N (docs/numerics.md,
//! convergence). For W in {131.7, 132.2, 135}, from the static equilibrium, compares the
//! Poincare point after 200 periods with a reference at 16x finer steps, for the lane
//! stepper and, for context, the article's scheme (MODEL.md 4.1, error on positions) at
//! the Table 1 bound E_max = 1e-9 m. Left out because 200 periods take many minutes: the
//! article's scheme with the error on all 8 components, or on positions with E_max =
//! 1e-12 m (once a step is cut inside contact it never grows back before the contact ends).
//!
//! Run: `cargo run --release --example convergence` (prints a Markdown table).

use jeffcott_core::integrate::article::{ArticleConfig, ArticleStepper, ErrorNorm};
use jeffcott_core::integrate::lane::{Lane, LaneConsts, StepperConfig, advance_period};
use jeffcott_core::model::{Params, STATE_DIM, State};
use std::time::Instant;

const PERIODS: u32 = 200;

fn lane(p: &Params, omega: f64, n: u32) -> (State, f64, f64) {
    // The study of docs/convergence.md was made without contact refinement.
    let cfg = StepperConfig {
        steps_per_period: n,
        contact_substeps: 1,
        ..StepperConfig::default()
    };
    let lc = LaneConsts::<f64>::new(p, omega, &cfg);
    let mut l = Lane::<f64>::new(&p.static_equilibrium(), p.delta);
    let t = Instant::now();
    for _ in 0..PERIODS {
        advance_period(&lc, &mut l);
    }
    let us = t.elapsed().as_secs_f64() * 1e6 / PERIODS as f64;
    let rk4_per_period =
        (l.counters.macro_steps + l.counters.extra_substeps) as f64 / PERIODS as f64;
    (l.x, us, rk4_per_period)
}

fn article(p: &Params, omega: f64, n: u32, norm: ErrorNorm) -> (State, f64, f64) {
    let cfg = ArticleConfig {
        steps_per_period: n,
        norm,
        ..ArticleConfig::default()
    };
    let mut a = ArticleStepper::new(p, omega, cfg, p.static_equilibrium());
    let t = Instant::now();
    for _ in 0..PERIODS {
        a.advance_period();
    }
    let us = t.elapsed().as_secs_f64() * 1e6 / PERIODS as f64;
    (a.x, us, a.counters.rk4_evaluations as f64 / PERIODS as f64)
}

fn err(a: &State, b: &State) -> (f64, f64) {
    let pos = [0, 2, 4, 6]
        .iter()
        .map(|&i| (a[i] - b[i]).abs())
        .fold(0.0, f64::max);
    let vel = (0..STATE_DIM)
        .filter(|i| i % 2 == 1)
        .map(|i| (a[i] - b[i]).abs())
        .fold(0.0, f64::max);
    (pos, vel)
}

fn main() {
    let p = Params::default();
    println!(
        "| W [rad/s] | integrator | N | position error [m] | velocity error [m/s] | RK4 steps / period | us / period |"
    );
    println!("|---|---|---|---|---|---|---|");
    for omega in [131.7, 132.2, 135.0] {
        for n in [125u32, 250, 500, 1000, 2000] {
            let (x, us, steps) = lane(&p, omega, n);
            let (r, _, _) = lane(&p, omega, 16 * n);
            let (ep, ev) = err(&x, &r);
            println!(
                "| {omega} | lane (crossings located) | {n} | {ep:.2e} | {ev:.2e} | {steps:.0} | {us:.0} |"
            );
        }
        // Context: the article's scheme against the finest lane reference.
        let (r, _, _) = lane(&p, omega, 32000);
        for n in [500u32, 1000, 2000] {
            let (x, us, steps) = article(&p, omega, n, ErrorNorm::Positions);
            let (ep, ev) = err(&x, &r);
            println!(
                "| {omega} | article, E on positions | {n} | {ep:.2e} | {ev:.2e} | {steps:.0} | {us:.0} |"
            );
        }
    }
}
