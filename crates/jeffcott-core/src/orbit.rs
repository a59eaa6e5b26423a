//! Periodic orbits by Newton shooting on the stroboscopic map, with their Floquet
//! multipliers.
//!
//! A period-n orbit (n forcing periods T = 2 pi / W) is a fixed point of P^n, the map
//! that advances a state at t = kT by n periods with the lane stepper (RK4 with switches
//! located, docs/numerics.md): F(x) = P^n(x) - x = 0. Its Jacobian is M - I, with M the
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
use crate::integrate::lane::{
    Lane, LaneConsts, StepperConfig, Tangent, macro_step_tangent, renormalise,
};
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

/// n periods of the flow from a state at t = 0 and, when asked for, their derivative.
#[derive(Clone, Debug)]
pub struct Flow {
    /// The state after n periods (where it froze, for a lane that left the bound).
    pub end: State,
    /// The monodromy matrix dP^n/dx, `m[i][j]` = d end_i / d x0_j ([`Want::Monodromy`]
    /// and a finite flow only).
    pub monodromy: Option<[[f64; STATE_DIM]; STATE_DIM]>,
    /// The smallest clearance delta - |d| between rotor and stator over the n periods
    /// [m] (negative: in contact), within each macro step by [`max_distance`]
    /// ([`Want::Monodromy`] only; NaN for [`Want::End`]).
    pub min_clearance: f64,
    /// Whether the lane stayed finite and within the divergence bound.
    pub finite: bool,
}

impl Flow {
    /// The monodromy matrix of a flow asked with [`Want::Monodromy`] that stayed finite.
    pub fn jacobian(&self) -> Option<&[[f64; STATE_DIM]; STATE_DIM]> {
        self.monodromy.as_ref().filter(|_| self.finite)
    }
}

/// What a flow computes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Want {
    /// The end state only (the parameter derivative's finite differences, settling).
    End,
    /// The end state, the monodromy matrix and the smallest clearance.
    Monodromy,
}

/// One flow asked of a [`Flows`] engine: `periods` forcing periods from `x0` at t = 0
/// at speed `omega` with the model `params`.
#[derive(Clone, Debug)]
pub struct FlowAsk {
    /// The model.
    pub params: Params,
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// The state at t = 0.
    pub x0: State,
    /// Forcing periods.
    pub periods: u32,
    /// What to compute.
    pub want: Want,
}

/// Something that runs many flows at once: the CPU ([`CpuFlows`]) or a GPU (the
/// analysis crate's engine, one lane per tangent vector of the kernel's lambda_1
/// variant). Every implementation returns the same bits: [`flow`]'s arithmetic.
pub trait Flows: Sync {
    /// The flows of `asks`, in order, with the lane stepper `stepper`.
    fn flows(&self, asks: &[FlowAsk], stepper: &StepperConfig) -> Result<Vec<Flow>> {
        self.flows_until(asks, stepper, &crate::control::Cancel::new())
    }

    /// [`Flows::flows`], stopped with [`crate::Error::Interrupted`] once `cancel` is
    /// set: within a forcing period where the engine looks between periods (the CPU's
    /// end states, a settle of many periods), else after the call. The flows do not
    /// depend on `cancel` otherwise.
    fn flows_until(
        &self,
        asks: &[FlowAsk],
        stepper: &StepperConfig,
        cancel: &crate::control::Cancel,
    ) -> Result<Vec<Flow>>;
}

/// The CPU's flows: [`flow`] and [`advance`] in parallel on rayon's pool.
#[derive(Clone, Copy, Debug, Default)]
pub struct CpuFlows;

impl Flows for CpuFlows {
    fn flows_until(
        &self,
        asks: &[FlowAsk],
        stepper: &StepperConfig,
        cancel: &crate::control::Cancel,
    ) -> Result<Vec<Flow>> {
        use rayon::prelude::*;
        asks.par_iter()
            .map(|a| match a.want {
                Want::Monodromy => Ok(flow(&a.params, a.omega, &a.x0, a.periods, stepper)),
                Want::End => end_of(&a.params, a.omega, &a.x0, a.periods, stepper, cancel),
            })
            .collect()
    }
}

/// Advances `x0` (a state at t = 0) by `periods` forcing periods at speed `omega` with
/// the 8 tangent vectors of the identity: the end state and the monodromy matrix.
///
/// Each tangent vector is renormalised at the end of every period and its growths are
/// multiplied up, column j of M = (prod of e_j's growths) v_j: exactly what a lane of
/// the GPU kernel's lambda_1 variant started from e_j computes (per-vector arithmetic
/// of [`Tangent`] does not depend on the other vectors), so a GPU gives M to the bit
/// (tests/orbits.rs). The renormalisation also keeps long periods from overflowing.
pub fn flow(p: &Params, omega: f64, x0: &State, periods: u32, stepper: &StepperConfig) -> Flow {
    let w = walk(p, omega, x0, periods, stepper, identity());
    let finite = !w.lane.status.is_frozen();
    Flow {
        end: w.lane.x,
        monodromy: finite.then(|| columns(&w.tangent.v, &w.growth)),
        min_clearance: w.min_clearance,
        finite,
    }
}

/// Where [`walk`] ends: the lane, its tangent vectors (unit length), their growths
/// multiplied up, and the smallest clearance on the way.
struct Walk<const M: usize> {
    lane: Lane<f64>,
    tangent: Tangent<f64, M>,
    growth: [f64; M],
    min_clearance: f64,
}

/// `periods` periods from `x0` carrying the M tangent vectors `v0` (none: the state
/// alone, by the same state arithmetic), each renormalised at every period end, and the
/// smallest clearance within every macro step ([`max_distance`]); stops where the lane
/// freezes. The one loop behind [`flow`] and [`min_clearance`], so both see one
/// sequence of states.
fn walk<const M: usize>(
    p: &Params,
    omega: f64,
    x0: &State,
    periods: u32,
    stepper: &StepperConfig,
    v0: [[f64; STATE_DIM]; M],
) -> Walk<M> {
    let lc = LaneConsts::<f64>::new(p, omega, stepper);
    let mut w = Walk {
        lane: Lane::<f64>::new(x0, p.delta),
        tangent: Tangent::<f64, M>::new(v0),
        growth: [1.0; M],
        min_clearance: -penetration(p.delta, x0),
    };
    'periods: for _ in 0..periods {
        for _ in 0..stepper.steps_per_period {
            let before = w.lane.x;
            macro_step_tangent(&lc, &mut w.lane, &mut w.tangent);
            if w.lane.status.is_frozen() {
                break 'periods;
            }
            w.min_clearance = w
                .min_clearance
                .min(p.delta - max_distance(&before, &w.lane.x, lc.h));
        }
        for (g, v) in w.growth.iter_mut().zip(w.tangent.v.iter_mut()) {
            *g *= renormalise(v);
        }
    }
    w
}

/// The identity's columns: the tangent vectors a monodromy matrix starts from.
pub fn identity() -> [[f64; STATE_DIM]; STATE_DIM] {
    std::array::from_fn(|j| std::array::from_fn(|i| if i == j { 1.0 } else { 0.0 }))
}

/// The monodromy matrix from unit tangent vectors `v` (v[j]: the image of e_j) and their
/// accumulated growths: `m[i][j]` = v[j][i] growth[j].
pub fn columns(
    v: &[[f64; STATE_DIM]; STATE_DIM],
    growth: &[f64; STATE_DIM],
) -> [[f64; STATE_DIM]; STATE_DIM] {
    std::array::from_fn(|i| std::array::from_fn(|j| v[j][i] * growth[j]))
}

/// [`advance`] as a [`Flow`] of [`Want::End`]: no monodromy, no clearance (NaN).
fn end_of(
    p: &Params,
    omega: f64,
    x0: &State,
    periods: u32,
    stepper: &StepperConfig,
    cancel: &crate::control::Cancel,
) -> Result<Flow> {
    let lc = LaneConsts::<f64>::new(p, omega, stepper);
    let mut lane = Lane::<f64>::new(x0, p.delta);
    for _ in 0..periods {
        if cancel.is_set() {
            return Err(crate::error::Error::Interrupted {
                committed: 0,
                total: 1,
            });
        }
        crate::integrate::lane::advance_period(&lc, &mut lane);
    }
    Ok(Flow {
        end: lane.x,
        monodromy: None,
        min_clearance: f64::NAN,
        finite: !lane.status.is_frozen(),
    })
}

/// The smallest clearance over `periods` periods from `x0` (no tangent vectors): the
/// same states, hence the same value, as [`flow`]'s `min_clearance` (a GPU engine,
/// whose kernel does not track it, takes it from here).
pub fn min_clearance(
    p: &Params,
    omega: f64,
    x0: &State,
    periods: u32,
    stepper: &StepperConfig,
) -> f64 {
    walk::<0>(p, omega, x0, periods, stepper, []).min_clearance
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
    let f = end_of(
        p,
        omega,
        x0,
        periods,
        stepper,
        &crate::control::Cancel::new(),
    )
    .ok()?;
    f.finite.then_some(f.end)
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
/// times), on the CPU. Errors name `period` or `start` when the input is refused, and
/// say so when Newton does not converge within `cfg.max_iter` iterations.
pub fn shoot(p: &Params, omega: f64, x0: &State, period: u32, cfg: &ShootConfig) -> Result<Orbit> {
    let start = Start {
        params: p.clone(),
        omega,
        x0: *x0,
        period,
    };
    shoot_one(&CpuFlows, start, cfg)?
}

/// A start of [`shoot_many`]: a guess `x0` for a period-`period` orbit of the model
/// `params` at speed `omega`.
#[derive(Clone, Debug)]
pub struct Start {
    /// The model.
    pub params: Params,
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// The guess, a state at t = 0.
    pub x0: State,
    /// Period of the orbit in forcing periods.
    pub period: u32,
}

/// [`shoot_many`] of one start: the outer error refuses the period or reports the
/// engine's failure, the inner one refuses the start or says it did not converge.
pub fn shoot_one(engine: &dyn Flows, start: Start, cfg: &ShootConfig) -> Result<Result<Orbit>> {
    Ok(shoot_many(engine, &[start], cfg)?
        .pop()
        .expect("one start, one result"))
}

/// Where one start's Newton iteration stands.
struct Newton {
    x: State,
    /// The flow at `x` (none before the first).
    f: Option<Flow>,
    res: f64,
    it: u32,
    /// The Newton step from `x` and the fraction of it being tried.
    dx: State,
    step: f64,
    /// The end: the orbit, or why there is none.
    done: Option<Result<Orbit>>,
}

/// Shoots orbits from many starts at once, each of its own period: every Newton
/// iteration (and every halving of its step) of all starts not yet converged is one
/// call of `engine`, so a GPU runs them as lanes side by side (many orbits at
/// once). Each start goes exactly the way [`shoot`] takes it alone, so its orbit does
/// not depend on the others. The outer error refuses a `period` out of range or
/// reports the engine's failure; each start's own result says whether it converged
/// (a start that is not finite is refused there, naming `start`, the others go on).
pub fn shoot_many(
    engine: &dyn Flows,
    starts: &[Start],
    cfg: &ShootConfig,
) -> Result<Vec<Result<Orbit>>> {
    for s in starts {
        check_period(s.period)?;
    }
    let mut runs: Vec<Newton> = starts
        .iter()
        .map(|s| Newton {
            x: s.x0,
            f: None,
            res: f64::INFINITY,
            it: 0,
            dx: [0.0; STATE_DIM],
            step: 1.0,
            done: s.x0.iter().any(|v| !v.is_finite()).then(|| {
                Err(Error::invalid(
                    "start",
                    format!("{:?}", s.x0),
                    "must be finite",
                ))
            }),
        })
        .collect();
    loop {
        let open: Vec<usize> = (0..runs.len())
            .filter(|&k| runs[k].done.is_none())
            .collect();
        if open.is_empty() {
            break;
        }
        let asks: Vec<FlowAsk> = open
            .iter()
            .map(|&k| FlowAsk {
                params: starts[k].params.clone(),
                omega: starts[k].omega,
                x0: runs[k].trial(),
                periods: starts[k].period,
                want: Want::Monodromy,
            })
            .collect();
        let flows = engine.flows(&asks, &cfg.stepper)?;
        for ((&k, ask), f) in open.iter().zip(&asks).zip(flows) {
            runs[k].take(&starts[k], ask.x0, f, cfg);
        }
    }
    Ok(runs
        .into_iter()
        .map(|r| r.done.expect("every run ended"))
        .collect())
}

impl Newton {
    /// The state whose flow this run needs next: the start, or the trial step.
    fn trial(&self) -> State {
        match self.f {
            None => self.x,
            Some(_) => std::array::from_fn(|i| self.x[i] + self.step * self.dx[i]),
        }
    }

    /// Takes the flow `f` from `trial` (the state [`Newton::trial`] gave).
    fn take(&mut self, s: &Start, trial: State, f: Flow, cfg: &ShootConfig) {
        let (omega, period) = (s.omega, s.period);
        let rt = residual(&trial, &f, omega);
        if self.f.is_some() && !(rt < self.res || self.step < 1.0 / 4096.0) {
            self.step *= 0.5;
            return;
        }
        // The first flow, or an accepted step.
        self.x = trial;
        self.res = rt;
        self.f = Some(f);
        let f = self.f.as_ref().expect("just set");
        if self.res <= cfg.tol {
            let monodromy = *f.jacobian().expect("a finite flow");
            self.done = Some(Ok(Orbit {
                omega,
                period,
                x: self.x,
                residual: self.res,
                iterations: self.it,
                monodromy,
                multipliers: multipliers(&monodromy),
                min_clearance: f.min_clearance,
            }));
            return;
        }
        if self.it == cfg.max_iter || !self.res.is_finite() {
            self.done = Some(Err(Error::invalid(
                "start",
                format!("{:?}", s.x0),
                format!(
                    "Newton shooting for a period-{period} orbit at W = {omega} rad/s did not \
                     converge: |P^n(x) - x| = {:.3e} m after {} iterations (tolerance \
                     {:.1e} m); start closer to the orbit (e.g. from an attractor)",
                    self.res, self.it, cfg.tol
                ),
            )));
            return;
        }
        self.it += 1;
        let m = f.jacobian().expect("a finite flow");
        let j = SMatrix::<f64, STATE_DIM, STATE_DIM>::from_fn(|r, c| {
            m[r][c] - if r == c { 1.0 } else { 0.0 }
        });
        let rhs = SVector::<f64, STATE_DIM>::from_fn(|r, _| self.x[r] - f.end[r]);
        match j.lu().solve(&rhs) {
            Some(dx) => {
                self.dx = std::array::from_fn(|i| dx[i]);
                self.step = 1.0;
            }
            None => {
                self.done = Some(Err(Error::invalid(
                    "start",
                    format!("{:?}", s.x0),
                    format!(
                        "M - I is singular at W = {omega} rad/s (a multiplier at +1: a fold); \
                         shooting cannot converge here"
                    ),
                )));
            }
        }
    }
}

/// |P^n(x) - x| in the classification metric (infinite for a flow that left the bound).
fn residual(x: &State, f: &Flow, omega: f64) -> f64 {
    if !f.finite {
        return f64::INFINITY;
    }
    let d: State = std::array::from_fn(|i| f.end[i] - x[i]);
    metric(&d, omega)
}
