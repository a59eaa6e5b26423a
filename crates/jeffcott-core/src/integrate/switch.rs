//! The switch search of one trial sub-step (MODEL.md 4.2; the lane module's docs, step
//! 2): the penetration g sampled on the cubic Hermite interpolant of the relative
//! displacement ([`hermite_gap`]), the first sample on the wrong side of g = 0 for the
//! contact mode ([`wrong_side`]), grazing extrema between samples, and the Illinois
//! iterations that locate the crossing ([`find_switch`]). `integrate/switch.wgsl`
//! mirrors this file function by function: keep in sync with it.

use super::lane::LaneConsts;
use crate::model::{STATE_DIM, relative_motion};
use crate::real::Real;

/// Number of interior samples of g per trial step (the grazing check).
pub const GRAZE_SAMPLES: u32 = 8;
/// Iteration cap of the crossing search.
pub const ROOT_MAX_ITERS: u32 = 60;

/// Largest |h10| and |h11| of the cubic Hermite basis on [0, 1] per unit of `hs`:
/// theta (1 - theta)^2 and theta^2 (1 - theta) peak at 4/27 (theta = 1/3, 2/3).
pub const HERMITE_SLOPE_BOUND: f64 = 4.0 / 27.0;

/// Relative safety factor of [`free_flight_certain`] over its bound, 64 ulp: covers the
/// roundings of the bound and of every g the search computes (fewer than 25 of them
/// compound in either, see its docs), with room for drivers whose sqrt is a few ulp off.
pub fn free_flight_safety<R: Real>() -> f64 {
    1.0 + 64.0 * R::EPSILON
}

/// The squared relative displacement |d|^2 and d . dd/dtheta at fraction `theta` of a
/// sub-step of duration `hs`, on the cubic Hermite interpolant of the relative
/// displacement between the sub-step's end states: what [`hermite_gap`] takes its g and
/// rate from (g = sqrt(|d|^2) - delta, rate = (d . dd/dtheta) / |d|). The batch stepper
/// decides "no switch" from these alone (`integrate::batch`, the search): sqrt and g
/// are monotone, so the samples' largest g is that of their largest |d|^2, and a rate's
/// sign is that of d . dd/dtheta. The WGSL `hermite_gap` computes the same inline.
#[inline(always)]
pub fn hermite_sq<R: Real>(x0: &[R; STATE_DIM], x1: &[R; STATE_DIM], hs: R, theta: R) -> (R, R) {
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
    let [px0, py0, vx0, vy0] = relative_motion(x0);
    let [px1, py1, vx1, vy1] = relative_motion(x1);
    let dx = h00 * px0 + h10 * vx0 + h01 * px1 + h11 * vx1;
    let dy = h00 * py0 + h10 * vy0 + h01 * py1 + h11 * vy1;
    let ddx = d00 * px0 + d10 * vx0 + d01 * px1 + d11 * vx1;
    let ddy = d00 * py0 + d10 * vy0 + d01 * py1 + d11 * vy1;
    (dx * dx + dy * dy, dx * ddx + dy * ddy)
}

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
    let (sq, dot) = hermite_sq(x0, x1, hs, theta);
    gap_and_rate(delta, sq, dot)
}

/// [`hermite_gap`]'s g and rate from its |d|^2 and d . dd/dtheta ([`hermite_sq`]).
#[inline(always)]
fn gap_and_rate<R: Real>(delta: R, sq: R, dot: R) -> (R, R) {
    let r = sq.sqrt();
    // r > 0 whenever g is near 0 (r ~ delta); the rate is only used there. The
    // quotient is formed whatever r is and then selected, without a branch, so that
    // `find_switch`'s samples vectorise.
    let q = dot / r;
    let rate = if r > R::lit(0.0) { q } else { R::lit(0.0) };
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

/// True when the free-flight trial sub-step x0 -> x1 (duration hs) certainly stays
/// clear of the stator, so that [`find_switch`] in free flight would find no switch
/// (issue 28: no switch search where no switch can happen).
///
/// The search evaluates g only on the cubic Hermite interpolant d(theta) = h00 p0 +
/// h10 v0 + h01 p1 + h11 v1 of the relative displacement (see [`hermite_gap`]), at
/// fractions theta in [0, 1]. There h00, h01 >= 0 with h00 + h01 = 1, and |h10|,
/// |h11| <= (4/27) |hs|, so by the triangle inequality (on the vectors p0, v0, ...)
///
///   |d(theta)| <= max(|p0|, |p1|) + (4/27) |hs| (|v0| + |v1|) =: reach.
///
/// In floating point each computed basis value and each computed g carries fewer than
/// 25 roundings of relative size eps (the basis 4, the two sums of four products 7,
/// the norm 3, and the bound's own norms, sums and products 8), so computed |d| <=
/// reach_computed (1 + 25 eps) < reach_computed * (1 + 64 eps). When that is below
/// delta, every g the search computes (samples, extremum estimates, Illinois iterates,
/// all at theta in [0, 1]) is r - delta with r < delta, so g <= 0, which is never the
/// wrong side in free flight: the search returns "no switch". A NaN anywhere makes the
/// comparison false and the search runs. Tested against the full search on thousands
/// of steps around grazing (here and in tests/mirror.rs).
///
/// The caller uses it only in a macro step not touched by contact so far, where the
/// search's `max_g` is never used (lane.rs, `finish_macro_step`), so a skipped search
/// changes no output bit.
#[inline(always)]
pub fn free_flight_certain<R: Real>(
    lc: &LaneConsts<R>,
    x0: &[R; STATE_DIM],
    x1: &[R; STATE_DIM],
    hs: R,
) -> bool {
    clear_of_stator(lc.c.delta, x0, x1, hs)
}

/// [`free_flight_certain`] for clearance `delta`: the batch stepper calls it for every
/// lane of a batch on its row of clearances, in a loop without branches that the
/// compiler vectorises across the lanes (the same operations per lane).
#[inline(always)]
pub fn clear_of_stator<R: Real>(delta: R, x0: &[R; STATE_DIM], x1: &[R; STATE_DIM], hs: R) -> bool {
    let [px0, py0, vx0, vy0] = relative_motion(x0);
    let [px1, py1, vx1, vy1] = relative_motion(x1);
    let a0 = (px0 * px0 + py0 * py0).sqrt();
    let a1 = (px1 * px1 + py1 * py1).sqrt();
    let w0 = (vx0 * vx0 + vy0 * vy0).sqrt();
    let w1 = (vx1 * vx1 + vy1 * vy1).sqrt();
    let reach = a0.max(a1) + R::lit(HERMITE_SLOPE_BOUND) * hs.abs() * (w0 + w1);
    reach * R::lit(free_flight_safety::<R>()) < delta
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
    // Every sample first, then the walk over them: independent evaluations, written
    // as two branch-free loops over the samples so that the compiler vectorises them
    // (the square roots and divisions of 4 or 8 samples in one instruction each),
    // where evaluating each sample as the walk reaches it waited on its square root
    // and division in turn (the scalar stepper's profile, 2026-11-27). A sample past
    // the walk's end is not used, so nothing else changes; the WGSL find_switch
    // evaluates them first too.
    const S: usize = GRAZE_SAMPLES as usize + 1;
    let mut th_s = [zero; S];
    let mut sq = [zero; S];
    let mut dot = [zero; S];
    for j in 0..S {
        th_s[j] = R::lit(j as f64 / GRAZE_SAMPLES as f64);
        (sq[j], dot[j]) = hermite_sq(x0, x1, hs, th_s[j]);
    }
    let mut g_s = [zero; S];
    let mut rate_s = [zero; S];
    for j in 0..S {
        (g_s[j], rate_s[j]) = gap_and_rate(delta, sq[j], dot[j]);
    }
    let mut lo = zero;
    let (mut g_lo, mut rate_lo) = (g_s[0], rate_s[0]);
    let mut max_g = g_lo;
    for j in 1..S {
        let (th, g_th, rate_th) = (th_s[j], g_s[j], rate_s[j]);
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
