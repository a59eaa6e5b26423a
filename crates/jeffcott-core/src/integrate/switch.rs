//! The switch search of one trial sub-step (MODEL.md 4.2; the lane module's docs, step
//! 2): the penetration g sampled on the cubic Hermite interpolant of the relative
//! displacement ([`hermite_gap`]), the first sample on the wrong side of g = 0 for the
//! contact mode ([`wrong_side`]), grazing extrema between samples, and the Illinois
//! iterations that locate the crossing ([`find_switch`]). `integrate/switch.wgsl`
//! mirrors this file function by function: keep in sync with it.

use super::lane::LaneConsts;
use crate::model::{STATE_DIM, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S};
use crate::real::Real;

/// Number of interior samples of g per trial step (the grazing check).
pub const GRAZE_SAMPLES: u32 = 8;
/// Iteration cap of the crossing search.
pub const ROOT_MAX_ITERS: u32 = 60;

/// Penetration g and its rate dg/dtheta at fraction `theta` of a sub-step of duration
/// `hs`, on the cubic Hermite interpolant of the relative displacement between the
/// sub-step's end states (exact at theta = 0 and 1).
#[inline(always)]
pub fn hermite_gap<R: Real>(
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
pub fn wrong_side<R: Real>(g: R, contact: bool) -> bool {
    if contact {
        g <= R::lit(0.0)
    } else {
        g > R::lit(0.0)
    }
}

/// Result of the switch search over one trial sub-step.
#[derive(Clone, Copy, Debug)]
pub struct Switch<R> {
    /// Fraction of the sub-step at which the mode must flip, or a value > 1 for none.
    pub theta: R,
    /// Largest g among the samples on the trajectory before the switch.
    pub max_g: R,
}

/// Looks for the first crossing of g = 0 along the trial sub-step x0 -> x1 (duration hs)
/// taken in mode `contact`; see the module docs. Between two samples on the mode's side,
/// an extremum of g heading to the other side (rates of opposite signs) is checked at
/// its estimated location: this catches contacts that enter and leave (or separations
/// that leave and re-enter) between samples, which would otherwise cost order.
#[inline(always)]
pub fn find_switch<R: Real>(
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
