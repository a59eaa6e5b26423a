//! Periodic orbits by Newton shooting on the stroboscopic map, with their Floquet
//! multipliers (issue 26, first part).
//!
//! A period-n orbit (n forcing periods T = 2 pi / W) is a fixed point of P^n, the map
//! that advances a state at t = kT by n periods with the lane stepper (RK4 with switches
//! located, MODEL.md 4): F(x) = P^n(x) - x = 0. Its Jacobian is M - I, with M the
//! monodromy matrix dP^n/dx: the 8 tangent vectors e_1 .. e_8 advanced through the same
//! steps, Mueller's saltation matrix applied at every switch (`integrate::tangent`), so M
//! is the derivative of the nonsmooth flow and Newton converges quadratically also for
//! orbits in contact (Leine and Nijmeijer, "Dynamics and Bifurcations of Non-Smooth
//! Mechanical Systems", 2004, ch. 7). The Floquet multipliers are M's eigenvalues; the
//! orbit is stable when all lie inside the unit circle.
//!
//! Checks that hold for every orbit (tests/orbits.rs): without contact the period-1
//! orbit is the analytic unbalance response and the multipliers are exp(lambda T) of
//! the linear system's eigenvalues; with contact the multipliers' product is
//! exp(trace(A) nT) (the contact force depends on positions only, so it leaves the
//! trace at -4 (xi_r w_r + xi_s w_s), and det S = 1 at every switch).

use crate::error::{Error, Result};
use crate::integrate::lane::{Lane, LaneConsts, StepperConfig, Tangent, macro_step_tangent};
use crate::model::{Params, STATE_DIM, State, penetration, relative_motion};
pub use nalgebra::Complex;
use nalgebra::{SMatrix, SVector};

/// How a periodic orbit is shot.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShootConfig {
    /// The lane stepper (steps per period, contact refinement).
    pub stepper: StepperConfig,
    /// Convergence: |P^n(x) - x| below this in the classification metric (positions in
    /// metres, velocities divided by W) [m].
    pub tol: f64,
    /// Newton iterations at most.
    pub max_iter: u32,
}

impl Default for ShootConfig {
    fn default() -> Self {
        ShootConfig {
            stepper: StepperConfig::default(),
            tol: 1e-11,
            max_iter: 40,
        }
    }
}

/// n periods of the flow from a state at t = 0 and their derivative.
#[derive(Clone, Debug)]
pub struct Flow {
    /// The state after n periods.
    pub end: State,
    /// The monodromy matrix dP^n/dx, `m[i][j]` = d end_i / d x0_j.
    pub monodromy: [[f64; STATE_DIM]; STATE_DIM],
    /// The smallest clearance delta - |d| between rotor and stator over the n periods
    /// [m] (negative: in contact), within each macro step by [`max_distance`].
    pub min_clearance: f64,
    /// Whether the lane stayed finite and within the divergence bound.
    pub finite: bool,
}

/// Advances `x0` (a state at t = 0) by `periods` forcing periods at speed `omega` with
/// the 8 tangent vectors of the identity: the end state and the monodromy matrix.
pub fn flow(p: &Params, omega: f64, x0: &State, periods: u32, stepper: &StepperConfig) -> Flow {
    let lc = LaneConsts::<f64>::new(p, omega, stepper);
    let mut lane = Lane::<f64>::new(x0, p.delta);
    let mut identity = [[0.0; STATE_DIM]; STATE_DIM];
    for (j, v) in identity.iter_mut().enumerate() {
        v[j] = 1.0;
    }
    let mut tan = Tangent::<f64, STATE_DIM>::new(identity);
    let mut min_clearance = -penetration(p.delta, &lane.x);
    let h = lc.h;
    'periods: for _ in 0..periods {
        for _ in 0..stepper.steps_per_period {
            let before = lane.x;
            macro_step_tangent(&lc, &mut lane, &mut tan);
            if lane.status.is_frozen() {
                break 'periods;
            }
            min_clearance = min_clearance.min(p.delta - max_distance(&before, &lane.x, h));
        }
    }
    let mut monodromy = [[0.0; STATE_DIM]; STATE_DIM];
    for (j, v) in tan.v.iter().enumerate() {
        for (i, row) in monodromy.iter_mut().enumerate() {
            row[j] = v[i];
        }
    }
    Flow {
        end: lane.x,
        monodromy,
        min_clearance,
        finite: !lane.status.is_frozen(),
    }
}

/// The largest rotor-stator distance |d| over a macro step of length `h` from state `a`
/// to state `b`: d(t) from the cubic Hermite interpolant of the relative displacement
/// and velocity at the step's ends (error O(h^4), ~1e-11 m at the default steps), its
/// maximum bracketed on 8 samples and refined by golden-section search. Grazing (the
/// clearance reaching 0 between steps) is located with it to ~1e-7 rad/s.
pub fn max_distance(a: &State, b: &State, h: f64) -> f64 {
    let (ra, rb) = (relative_motion(a), relative_motion(b));
    let at = |s: f64| -> f64 {
        // Hermite basis on [0, 1] for value and derivative (derivative times h).
        let (s2, s3) = (s * s, s * s * s);
        let (h00, h10, h01, h11) = (
            2.0 * s3 - 3.0 * s2 + 1.0,
            s3 - 2.0 * s2 + s,
            -2.0 * s3 + 3.0 * s2,
            s3 - s2,
        );
        let c = |k: usize| h00 * ra[k] + h10 * h * ra[k + 2] + h01 * rb[k] + h11 * h * rb[k + 2];
        c(0).hypot(c(1))
    };
    let samples = 8;
    let (mut best, mut best_s) = (f64::NEG_INFINITY, 0.0);
    for i in 0..=samples {
        let s = i as f64 / samples as f64;
        let v = at(s);
        if v > best {
            (best, best_s) = (v, s);
        }
    }
    // Golden-section search on the bracket around the best sample.
    let step = 1.0 / samples as f64;
    let (mut lo, mut hi) = ((best_s - step).max(0.0), (best_s + step).min(1.0));
    let g = 0.5 * (5f64.sqrt() - 1.0);
    let (mut x1, mut x2) = (hi - g * (hi - lo), lo + g * (hi - lo));
    let (mut f1, mut f2) = (at(x1), at(x2));
    for _ in 0..40 {
        if f1 > f2 {
            hi = x2;
            (x2, f2) = (x1, f1);
            x1 = hi - g * (hi - lo);
            f1 = at(x1);
        } else {
            lo = x1;
            (x1, f1) = (x2, f2);
            x2 = lo + g * (hi - lo);
            f2 = at(x2);
        }
    }
    best.max(f1).max(f2)
}

/// The state after `periods` forcing periods from `x0` at t = 0 (no tangent vectors;
/// `None` when the lane froze): the map whose parameter derivative continuation takes
/// by finite differences.
pub fn advance(
    p: &Params,
    omega: f64,
    x0: &State,
    periods: u32,
    stepper: &StepperConfig,
) -> Option<State> {
    let lc = LaneConsts::<f64>::new(p, omega, stepper);
    let mut lane = Lane::<f64>::new(x0, p.delta);
    for _ in 0..periods {
        crate::integrate::lane::advance_period(&lc, &mut lane);
    }
    (!lane.status.is_frozen()).then_some(lane.x)
}

/// A periodic orbit.
#[derive(Clone, Debug)]
pub struct Orbit {
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// Period in forcing periods.
    pub period: u32,
    /// The orbit's state at t = 0 (a fixed point of P^n).
    pub x: State,
    /// |P^n(x) - x| in the classification metric [m].
    pub residual: f64,
    /// Newton iterations taken.
    pub iterations: u32,
    /// The monodromy matrix at `x` (`m[i][j]` = d P^n(x)_i / d x_j).
    pub monodromy: [[f64; STATE_DIM]; STATE_DIM],
    /// Floquet multipliers (eigenvalues of the monodromy matrix), by decreasing modulus.
    pub multipliers: Vec<Complex<f64>>,
    /// The smallest rotor-stator clearance over the orbit [m] (negative: in contact).
    pub min_clearance: f64,
}

impl Orbit {
    /// Stable when every multiplier lies inside the unit circle.
    pub fn stable(&self) -> bool {
        self.multipliers.iter().all(|m| m.norm() < 1.0)
    }

    /// The largest multiplier modulus.
    pub fn max_multiplier(&self) -> f64 {
        self.multipliers.first().map_or(f64::NAN, |m| m.norm())
    }

    /// The Floquet exponents' real parts ln|mu| / (nT) [1/s], by decreasing value: the
    /// orbit's Lyapunov spectrum.
    pub fn exponents(&self) -> Vec<f64> {
        let nt = self.period as f64 * std::f64::consts::TAU / self.omega;
        self.multipliers
            .iter()
            .map(|m| m.norm().ln() / nt)
            .collect()
    }
}

/// The monodromy matrix's eigenvalues, by decreasing modulus.
pub fn multipliers(m: &[[f64; STATE_DIM]; STATE_DIM]) -> Vec<Complex<f64>> {
    let a = SMatrix::<f64, STATE_DIM, STATE_DIM>::from_fn(|i, j| m[i][j]);
    let mut mu: Vec<Complex<f64>> = a.complex_eigenvalues().iter().copied().collect();
    mu.sort_by(|a, b| b.norm().total_cmp(&a.norm()));
    mu
}

/// The classification metric's norm of a state difference (positions in metres,
/// velocities divided by W).
pub fn metric(d: &State, omega: f64) -> f64 {
    d.iter()
        .enumerate()
        .map(|(i, v)| if i % 2 == 1 { v.abs() / omega } else { v.abs() })
        .fold(0.0, f64::max)
}

/// Longest period shot, in forcing periods.
pub const MAX_PERIOD: u32 = 64;

/// Checks a period of orbits (field `period`): 1..=[`MAX_PERIOD`] forcing periods.
pub fn check_period(period: u32) -> Result<()> {
    if (1..=MAX_PERIOD).contains(&period) {
        Ok(())
    } else {
        Err(Error::invalid(
            "period",
            period,
            format!("must be in 1..={MAX_PERIOD} forcing periods"),
        ))
    }
}

/// Shoots a period-`period` orbit at speed `omega` from the guess `x0` by Newton's
/// method on P^n(x) - x, each step halved until the residual decreases (at most 12
/// times). Errors name `period` or `start` when the input is refused, and say so when
/// Newton does not converge within `cfg.max_iter` iterations.
pub fn shoot(p: &Params, omega: f64, x0: &State, period: u32, cfg: &ShootConfig) -> Result<Orbit> {
    check_period(period)?;
    if x0.iter().any(|v| !v.is_finite()) {
        return Err(Error::invalid("start", format!("{x0:?}"), "must be finite"));
    }
    let mut x = *x0;
    let mut f = flow(p, omega, &x, period, &cfg.stepper);
    let residual_of = |x: &State, f: &Flow| {
        if !f.finite {
            return f64::INFINITY;
        }
        let d: State = std::array::from_fn(|i| f.end[i] - x[i]);
        metric(&d, omega)
    };
    let mut res = residual_of(&x, &f);
    let mut it = 0;
    while res > cfg.tol {
        if it == cfg.max_iter || !res.is_finite() {
            return Err(Error::invalid(
                "start",
                format!("{x0:?}"),
                format!(
                    "Newton shooting for a period-{period} orbit at W = {omega} rad/s did not \
                     converge: |P^n(x) - x| = {res:.3e} m after {it} iterations (tolerance \
                     {:.1e} m); start closer to the orbit (e.g. from an attractor)",
                    cfg.tol
                ),
            ));
        }
        it += 1;
        let j = SMatrix::<f64, STATE_DIM, STATE_DIM>::from_fn(|r, c| {
            f.monodromy[r][c] - if r == c { 1.0 } else { 0.0 }
        });
        let rhs = SVector::<f64, STATE_DIM>::from_fn(|r, _| x[r] - f.end[r]);
        let Some(dx) = j.lu().solve(&rhs) else {
            return Err(Error::invalid(
                "start",
                format!("{x0:?}"),
                format!(
                    "M - I is singular at W = {omega} rad/s (a multiplier at +1: a fold); \
                     shooting cannot converge here"
                ),
            ));
        };
        let mut step = 1.0;
        loop {
            let trial: State = std::array::from_fn(|i| x[i] + step * dx[i]);
            let ft = flow(p, omega, &trial, period, &cfg.stepper);
            let rt = residual_of(&trial, &ft);
            if rt < res || step < 1.0 / 4096.0 {
                x = trial;
                f = ft;
                res = rt;
                break;
            }
            step *= 0.5;
        }
    }
    let multipliers = multipliers(&f.monodromy);
    Ok(Orbit {
        omega,
        period,
        x,
        residual: res,
        iterations: it,
        monodromy: f.monodromy,
        multipliers,
        min_clearance: f.min_clearance,
    })
}
