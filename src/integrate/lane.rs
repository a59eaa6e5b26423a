//! The ensemble lane stepper (MODEL.md 4.2): one trajectory, advanced one macro step at
//! a time on a fixed grid of N steps per forcing period, with the contact crossings
//! located and the step split there.
//!
//! Why crossing location rather than error-controlled sub-stepping: the vector field is
//! only C0 at g = 0 (MODEL.md 2), and a kink inside an RK4 step drops the method to low
//! order. Holding the contact state fixed over each RK4 stage sequence (the contact
//! formula is continued analytically across g = 0) and splitting the step at the located
//! crossing restores fourth order; the convergence study (docs/convergence.md) measured
//! the cost and error of both choices.
//!
//! The structure is written for the GPU: no recursion, every loop bounded by a constant
//! or a lane constant, no allocation, no trigonometry. `shaders/lane.wgsl` mirrors this
//! file function by function: keep in sync with it.
//!
//! One macro step:
//! 1. trial RK4 step from the current sub-step start s to the macro step's end, in the
//!    current contact mode;
//! 2. `find_switch`: sample the penetration g along the step on the cubic Hermite
//!    interpolant of the relative displacement (exact at both ends, O(H^4) inside) and
//!    take the first sample on the wrong side of g = 0 for the mode; this catches
//!    grazing contacts that enter and leave inside one step. Locate the crossing by the
//!    Illinois method on the interpolant;
//! 3. no crossing: accept. Crossing at fraction theta: re-step from s to the crossing,
//!    flip the mode, continue from there. At most `max_segments` segments per macro
//!    step; a lane that needs more is finished without switching and flagged.

use crate::integrate::forcing::phasor_turns;
use crate::model::{
    Coeffs, STATE_DIM, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S, penetration, rhs_frozen,
};
use crate::real::Real;
use serde::Serialize;

/// Number of interior samples of g per trial step (the grazing check).
pub const GRAZE_SAMPLES: u32 = 8;
/// Iteration cap of the crossing search.
pub const ROOT_MAX_ITERS: u32 = 60;

/// Per-lane outcome (DESIGN.md 2.5). Ordered by severity: a worse status replaces a
/// milder one, never the reverse.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
#[repr(u32)]
pub enum Status {
    /// Integrated as specified.
    Ok = 0,
    /// Some macro step needed more than `max_segments` contact switches; those steps
    /// were finished without switching, so the result is less accurate than specified.
    RefinementCap = 1,
    /// The state left the divergence bound; the lane is frozen at the last good state.
    Diverged = 2,
    /// The state became NaN or infinite; the lane is frozen at the last finite state.
    NonFinite = 3,
}

impl Status {
    /// True when the lane no longer advances.
    pub fn is_frozen(self) -> bool {
        matches!(self, Status::Diverged | Status::NonFinite)
    }

    /// The status code stored in files (`status.npy`) and on the GPU.
    pub fn code(self) -> u32 {
        self as u32
    }

    /// The status for a code (`None` for an unknown code, e.g. a corrupt GPU buffer).
    pub fn from_code(code: u32) -> Option<Status> {
        [
            Status::Ok,
            Status::RefinementCap,
            Status::Diverged,
            Status::NonFinite,
        ]
        .into_iter()
        .find(|s| s.code() == code)
    }
}

/// Constants of one lane, in the lane's precision.
#[derive(Clone, Copy, Debug)]
pub struct LaneConsts<R> {
    /// Equation coefficients for this lane's parameters and speed.
    pub c: Coeffs<R>,
    /// Macro step h = T/N [s].
    pub h: R,
    /// 1/N.
    pub inv_n: R,
    /// phi0 / (2 pi) [turns].
    pub phase0: R,
    /// Divergence bound on every position coordinate [m].
    pub bound: R,
    /// Width at which the crossing search stops, as a fraction of the sub-step.
    pub root_tol: R,
    /// Macro steps per forcing period N.
    pub n: u32,
    /// Cap on segments (contact switches + 1) per macro step.
    pub max_segments: u32,
}

/// Settings of the lane stepper that are not model parameters.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, serde::Deserialize)]
pub struct StepperConfig {
    /// Macro steps per forcing period N.
    pub steps_per_period: u32,
    /// Cap on segments per macro step.
    pub max_segments: u32,
    /// Divergence bound on every position coordinate [m].
    pub divergence_bound: f64,
}

impl Default for StepperConfig {
    fn default() -> Self {
        StepperConfig {
            steps_per_period: DEFAULT_STEPS_PER_PERIOD,
            max_segments: 16,
            divergence_bound: 1.0,
        }
    }
}

/// Default N, fixed by the convergence study (docs/convergence.md).
pub const DEFAULT_STEPS_PER_PERIOD: u32 = 500;

impl StepperConfig {
    /// Checks the settings; errors name the option and the allowed range.
    pub fn validate(&self) -> crate::Result<()> {
        use crate::Error;
        if !(8..=1_000_000).contains(&self.steps_per_period) {
            return Err(Error::invalid(
                "steps_per_period",
                self.steps_per_period,
                "must be in 8..=1000000",
            ));
        }
        // The GPU kernel runs a macro step within one invocation; Mesa's llvmpipe stops
        // loops after 65535 iterations in total (~130 per segment), so the cap stays well
        // inside that.
        if !(2..=256).contains(&self.max_segments) {
            return Err(Error::invalid(
                "max_segments",
                self.max_segments,
                "must be in 2..=256",
            ));
        }
        if !(self.divergence_bound.is_finite() && self.divergence_bound > 0.0) {
            return Err(Error::invalid(
                "divergence_bound",
                self.divergence_bound,
                "must be finite and > 0 m",
            ));
        }
        Ok(())
    }
}

impl<R: Real> LaneConsts<R> {
    /// Builds the constants for one lane from `f64` inputs (rounded once, here).
    pub fn new(p: &crate::model::Params, omega: f64, cfg: &StepperConfig) -> Self {
        let period = std::f64::consts::TAU / omega;
        let n = cfg.steps_per_period;
        // The search stops near the precision's resolution of a fraction in [0, 1].
        let root_tol = if R::WGSL_NAME == "f64" { 1e-13 } else { 2e-6 };
        LaneConsts {
            c: Coeffs::new(p, omega),
            h: R::lit(period / n as f64),
            inv_n: R::lit(1.0 / n as f64),
            phase0: R::lit(p.phi0 / std::f64::consts::TAU),
            bound: R::lit(cfg.divergence_bound),
            root_tol: R::lit(root_tol),
            n,
            max_segments: cfg.max_segments,
        }
    }
}

/// Counters of one lane (summed over everything it integrated).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct Counters {
    /// Macro steps integrated.
    pub macro_steps: u64,
    /// Macro steps in which the rotor touched the stator.
    pub contact_steps: u64,
    /// Located contact switches (entries plus exits).
    pub switches: u64,
    /// RK4 sub-steps beyond one per macro step (the cost of refinement).
    pub extra_substeps: u64,
    /// Largest penetration g seen at the sampled points [m] (0 if never in contact).
    pub max_penetration: f64,
}

/// The state of one lane between macro steps.
#[derive(Clone, Copy, Debug)]
pub struct Lane<R> {
    /// The state vector.
    pub x: [R; STATE_DIM],
    /// The contact mode carried across steps (not recomputed from the sign of g, which
    /// roundoff could flip at a located crossing).
    pub contact: bool,
    /// Index of the next macro step within the current period, 0..N.
    pub k: u32,
    /// Outcome so far.
    pub status: Status,
    /// Counters.
    pub counters: Counters,
}

impl<R: Real> Lane<R> {
    /// A lane starting at `x0` (f64, rounded to the lane's precision) at t = 0.
    pub fn new(x0: &[f64; STATE_DIM], delta: f64) -> Self {
        let x = x0.map(R::lit);
        let finite = x.iter().all(|v| v.is_finite());
        Lane {
            x,
            contact: finite && penetration(R::lit(delta), &x) > R::lit(0.0),
            k: 0,
            status: if finite {
                Status::Ok
            } else {
                Status::NonFinite
            },
            counters: Counters::default(),
        }
    }

    /// The state widened to f64.
    pub fn state_f64(&self) -> [f64; STATE_DIM] {
        self.x.map(|v| v.to_f64())
    }
}

/// Unbalance phasor at fraction `sigma` of macro step `k`.
#[inline(always)]
fn forcing_phasor<R: Real>(lc: &LaneConsts<R>, k: u32, sigma: R) -> (R, R) {
    phasor_turns((R::lit(k as f64) + sigma) * lc.inv_n - lc.phase0)
}

/// One classical RK4 step over the fraction [s0, s0 + ds] of macro step k, contact mode
/// held fixed.
#[inline(always)]
fn rk4_substep<R: Real>(
    lc: &LaneConsts<R>,
    x: &[R; STATE_DIM],
    k: u32,
    s0: R,
    ds: R,
    contact: bool,
) -> [R; STATE_DIM] {
    let hs = ds * lc.h;
    let half = R::lit(0.5);
    let (c0, s0p) = forcing_phasor(lc, k, s0);
    let (cm, sm) = forcing_phasor(lc, k, s0 + half * ds);
    let (c1, s1) = forcing_phasor(lc, k, s0 + ds);
    let k1 = rhs_frozen(&lc.c, x, c0, s0p, contact);
    let mut xt = [R::lit(0.0); STATE_DIM];
    for i in 0..STATE_DIM {
        xt[i] = x[i] + half * hs * k1[i];
    }
    let k2 = rhs_frozen(&lc.c, &xt, cm, sm, contact);
    for i in 0..STATE_DIM {
        xt[i] = x[i] + half * hs * k2[i];
    }
    let k3 = rhs_frozen(&lc.c, &xt, cm, sm, contact);
    for i in 0..STATE_DIM {
        xt[i] = x[i] + hs * k3[i];
    }
    let k4 = rhs_frozen(&lc.c, &xt, c1, s1, contact);
    let sixth = R::lit(1.0 / 6.0);
    let mut out = [R::lit(0.0); STATE_DIM];
    for i in 0..STATE_DIM {
        out[i] = x[i] + hs * sixth * (k1[i] + R::lit(2.0) * (k2[i] + k3[i]) + k4[i]);
    }
    out
}

/// Penetration g and its rate dg/dtheta at fraction `theta` of a sub-step of duration
/// `hs`, on the cubic Hermite interpolant of the relative displacement between the
/// sub-step's end states (exact at theta = 0 and 1).
#[inline(always)]
pub(crate) fn hermite_gap<R: Real>(
    delta: R,
    x0: &[R; STATE_DIM],
    x1: &[R; STATE_DIM],
    hs: R,
    theta: R,
) -> (R, R) {
    let one = R::lit(1.0);
    let two = R::lit(2.0);
    let three = R::lit(3.0);
    let six = R::lit(6.0);
    let u = one - theta;
    let h00 = (one + two * theta) * u * u;
    let h10 = theta * u * u * hs;
    let h01 = theta * theta * (three - two * theta);
    let h11 = -theta * theta * u * hs;
    // d/dtheta of the basis.
    let d00 = six * theta * (theta - one);
    let d10 = (three * theta * theta - R::lit(4.0) * theta + one) * hs;
    let d01 = -d00;
    let d11 = (three * theta * theta - two * theta) * hs;
    let (px0, py0) = (x0[X_R] - x0[X_S], x0[Y_R] - x0[Y_S]);
    let (vx0, vy0) = (x0[VX_R] - x0[VX_S], x0[VY_R] - x0[VY_S]);
    let (px1, py1) = (x1[X_R] - x1[X_S], x1[Y_R] - x1[Y_S]);
    let (vx1, vy1) = (x1[VX_R] - x1[VX_S], x1[VY_R] - x1[VY_S]);
    let dx = h00 * px0 + h10 * vx0 + h01 * px1 + h11 * vx1;
    let dy = h00 * py0 + h10 * vy0 + h01 * py1 + h11 * vy1;
    let ddx = d00 * px0 + d10 * vx0 + d01 * px1 + d11 * vx1;
    let ddy = d00 * py0 + d10 * vy0 + d01 * py1 + d11 * vy1;
    let r = (dx * dx + dy * dy).sqrt();
    // r > 0 whenever g is near 0 (r ~ delta); the rate is only used there.
    let rate = if r > R::lit(0.0) {
        (dx * ddx + dy * ddy) / r
    } else {
        R::lit(0.0)
    };
    (r - delta, rate)
}

/// True when penetration `g` is on the side of g = 0 that the mode does not hold.
#[inline(always)]
pub(crate) fn wrong_side<R: Real>(g: R, contact: bool) -> bool {
    if contact {
        g <= R::lit(0.0)
    } else {
        g > R::lit(0.0)
    }
}

/// Result of the switch search over one trial sub-step.
struct Switch<R> {
    /// Fraction of the sub-step at which the mode must flip, or a value > 1 for none.
    theta: R,
    /// Largest g among the samples on the trajectory before the switch.
    max_g: R,
}

/// Looks for the first crossing of g = 0 along the trial sub-step x0 -> x1 (duration hs)
/// taken in mode `contact`; see the module docs. Between two samples on the mode's side,
/// an extremum of g heading to the other side (rates of opposite signs) is checked at
/// its estimated location: this catches contacts that enter and leave (or separations
/// that leave and re-enter) between samples, which would otherwise cost order.
#[inline(always)]
fn find_switch<R: Real>(
    lc: &LaneConsts<R>,
    x0: &[R; STATE_DIM],
    x1: &[R; STATE_DIM],
    hs: R,
    contact: bool,
) -> Switch<R> {
    let delta = lc.c.delta;
    let zero = R::lit(0.0);
    let mut lo = zero;
    let (mut g_lo, mut rate_lo) = hermite_gap(delta, x0, x1, hs, zero);
    let mut max_g = g_lo;
    for j in 1..=GRAZE_SAMPLES {
        let th = R::lit(j as f64 / GRAZE_SAMPLES as f64);
        let (g_th, rate_th) = hermite_gap(delta, x0, x1, hs, th);
        let mut hi = th;
        let mut g_hi = g_th;
        let mut crossing = wrong_side(g_th, contact);
        let toward = if contact {
            rate_lo < zero && rate_th > zero
        } else {
            rate_lo > zero && rate_th < zero
        };
        if !crossing && toward {
            // Extremum where the linearly interpolated rate vanishes.
            let tp = lo + (th - lo) * rate_lo / (rate_lo - rate_th);
            let (g_p, _) = hermite_gap(delta, x0, x1, hs, tp);
            if wrong_side(g_p, contact) {
                hi = tp;
                g_hi = g_p;
                crossing = true;
            } else {
                max_g = max_g.max(g_p);
            }
        }
        if crossing {
            if wrong_side(g_lo, contact) {
                // Only at the start (j = 1): the lane sits on the switching surface and
                // its mode's flow leaves to the other side; flip now.
                return Switch { theta: lo, max_g };
            }
            // Illinois (modified regula falsi) on [lo, hi]; `a` stays on the mode's side,
            // `b` on the other. Returns `b`, so the next segment starts on its own side.
            let (mut a, mut ga, mut b, mut gb) = (lo, g_lo, hi, g_hi);
            let mut last_kept_a = false;
            let mut last_kept_b = false;
            for _ in 0..ROOT_MAX_ITERS {
                if b - a <= lc.root_tol {
                    break;
                }
                let mut m = b - gb * (b - a) / (gb - ga);
                if !(m > a && m < b) {
                    m = R::lit(0.5) * (a + b);
                }
                let (gm, _) = hermite_gap(delta, x0, x1, hs, m);
                if wrong_side(gm, contact) {
                    b = m;
                    gb = gm;
                    if last_kept_a {
                        ga = R::lit(0.5) * ga;
                    }
                    last_kept_a = true;
                    last_kept_b = false;
                } else {
                    a = m;
                    ga = gm;
                    max_g = max_g.max(gm);
                    if last_kept_b {
                        gb = R::lit(0.5) * gb;
                    }
                    last_kept_b = true;
                    last_kept_a = false;
                }
            }
            return Switch { theta: b, max_g };
        }
        max_g = max_g.max(g_th);
        lo = th;
        g_lo = g_th;
        rate_lo = rate_th;
    }
    Switch {
        theta: R::lit(2.0),
        max_g,
    }
}

/// Advances the lane by one macro step (1/N of a forcing period). Frozen lanes do not
/// move. Keep in sync with `macro_step` in `shaders/lane.wgsl`.
pub fn macro_step<R: Real>(lc: &LaneConsts<R>, lane: &mut Lane<R>) {
    if lane.status.is_frozen() {
        return;
    }
    let one = R::lit(1.0);
    let k = lane.k;
    let mut x = lane.x;
    let mut contact = lane.contact;
    let mut touched = contact;
    let mut s = R::lit(0.0);
    let mut done = false;
    let mut substeps: u64 = 0;
    let mut switches: u64 = 0;
    let mut max_g = R::lit(f64::NEG_INFINITY);
    for _ in 0..lc.max_segments {
        let ds = one - s;
        let x1 = rk4_substep(lc, &x, k, s, ds, contact);
        substeps += 1;
        let sw = find_switch(lc, &x, &x1, ds * lc.h, contact);
        max_g = max_g.max(sw.max_g);
        if sw.theta > one {
            x = x1;
            done = true;
            break;
        }
        if sw.theta >= one {
            x = x1;
            s = one;
        } else if sw.theta > R::lit(0.0) {
            x = rk4_substep(lc, &x, k, s, ds * sw.theta, contact);
            substeps += 1;
            s += ds * sw.theta;
        }
        contact = !contact;
        touched = true;
        switches += 1;
        if s >= one {
            done = true;
            break;
        }
    }
    if !done {
        // Refinement cap: finish the step in the current mode and say so.
        x = rk4_substep(lc, &x, k, s, one - s, contact);
        substeps += 1;
        contact = penetration(lc.c.delta, &x) > R::lit(0.0);
        if lane.status < Status::RefinementCap {
            lane.status = Status::RefinementCap;
        }
    }
    // Status checks: freeze at the last good state rather than poison anything.
    let mut finite = true;
    for v in x.iter() {
        finite = finite && v.is_finite();
    }
    if !finite {
        lane.status = Status::NonFinite;
        return;
    }
    let reach = x[X_R]
        .abs()
        .max(x[Y_R].abs())
        .max(x[X_S].abs())
        .max(x[Y_S].abs());
    if reach > lc.bound {
        lane.status = Status::Diverged;
        return;
    }
    lane.x = x;
    lane.contact = contact;
    lane.k = if k + 1 == lc.n { 0 } else { k + 1 };
    let ct = &mut lane.counters;
    ct.macro_steps += 1;
    ct.contact_steps += touched as u64;
    ct.switches += switches;
    ct.extra_substeps += substeps - 1;
    if touched {
        ct.max_penetration = ct.max_penetration.max(max_g.to_f64());
    }
}

/// Advances the lane by one forcing period (N macro steps), from k = 0 to k = 0.
pub fn advance_period<R: Real>(lc: &LaneConsts<R>, lane: &mut Lane<R>) {
    for _ in 0..lc.n {
        macro_step(lc, lane);
    }
}
