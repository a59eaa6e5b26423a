//! The switch search of one trial sub-step (docs/numerics.md; the lane module's docs, step
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

/// Relative safety factor of the certificates ([`clear_of_stator`],
/// [`in_contact_certain`]) on the squares they compare, 1024 ulp: covers the roundings
/// of the certificates themselves and of every g the search computes (fewer than 25
/// roundings compound in a sample, each of relative size eps against magnitudes below
/// four times the bound, see [`clear_of_stator`]), with room for drivers whose sqrt is a
/// few ulp off.
pub fn certificate_safety<R: Real>() -> f64 {
    1.0 + 1024.0 * R::EPSILON
}

/// The Bezier control points of the search's cubic Hermite interpolant of the relative
/// displacement over a sub-step x0 -> x1 of duration `hs` ([`hermite_sq`]): with the
/// Bernstein basis B_i, h00 = B0 + B1, h10 = hs B1 / 3, h01 = B2 + B3, h11 = -hs B2 / 3,
/// so d(theta) = sum B_i(theta) P_i with P0 = p0, P1 = p0 + hs v0 / 3, P2 = p1 - hs v1 / 3,
/// P3 = p1: d(theta) lies in the convex hull of the P_i for every theta in [0, 1].
#[inline(always)]
pub fn control_points<R: Real>(x0: &[R; STATE_DIM], x1: &[R; STATE_DIM], hs: R) -> [[R; 2]; 4] {
    let [px0, py0, vx0, vy0] = relative_motion(x0);
    let [px1, py1, vx1, vy1] = relative_motion(x1);
    let t = hs / R::lit(3.0);
    [
        [px0, py0],
        [px0 + t * vx0, py0 + t * vy0],
        [px1 - t * vx1, py1 - t * vy1],
        [px1, py1],
    ]
}

/// The largest |P_i|^2 of the control points, NaN when any is NaN (then no certificate
/// holds and the search runs).
#[inline(always)]
pub fn hull_reach_sq<R: Real>(p: &[[R; 2]; 4]) -> R {
    let mut b2 = R::lit(0.0);
    for q in p {
        let n2 = q[0] * q[0] + q[1] * q[1];
        // Not `max`, which skips a NaN: a NaN must fail the certificate.
        b2 = if n2 <= b2 { b2 } else { n2 };
    }
    b2
}

/// True when the free-flight trial sub-step x0 -> x1 (duration hs) certainly stays
/// clear of the stator, so that [`find_switch`] in free flight would find no switch
/// and every g it computes is negative: no switch search where no switch can happen.
///
/// The search evaluates g only on the cubic Hermite interpolant d(theta) of the relative
/// displacement (see [`hermite_gap`]), at fractions theta in [0, 1]; d(theta) is a convex
/// combination of the control points P_i ([`control_points`]), so |d(theta)| <= B =
/// max |P_i| (the norm is convex). Where the rotor moves along the clearance circle this
/// bound exceeds |d| by second-order terms only ((hs |v|)^2 / (18 |p|)), where the
/// first bound used here, max(|p0|, |p1|) + (4/27) |hs| (|v0| + |v1|), exceeded it by
/// first-order ones: on the W = 133 bench it certifies 87 % of the lane-steps against
/// 80 % (the rest are in contact, or truly near the stator).
///
/// In floating point each computed sample's components carry fewer than 25 roundings
/// of relative size eps on terms (h00 p0, h10 v0, ...) whose magnitudes sum to less than
/// 4 B (|hs v0| = 3 |P1 - P0| <= 6 B, and h00, h01 <= 1, |h10|, |h11| <= (4/27) |hs|),
/// so a computed |d| is below B (1 + 110 eps), and the computed B^2 is within 4 eps of
/// the exact one. The certificate B^2 (1 + 1024 eps) < delta^2 therefore makes every g
/// the search computes (samples, extremum estimates, Illinois iterates, all at theta in
/// [0, 1]) r - delta with r < delta, so g < 0, which is never the wrong side in free
/// flight: the search returns "no switch", and its max_g is negative, below any lane's
/// largest penetration so far (which starts at 0). A NaN anywhere fails the test and
/// the search runs. Tested against the full search on thousands of steps around
/// grazing (tests/free_flight_certain.rs, and tests/mirror on the GPU).
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
    let b2 = hull_reach_sq(&control_points(x0, x1, hs));
    b2 * R::lit(certificate_safety::<R>()) < delta * delta
}

/// True when the contact trial sub-step x0 -> x1 (duration hs) certainly stays in
/// contact and no g the search would compute exceeds `max_pen`, the lane's largest
/// penetration before this macro step: then [`find_switch`] in contact would find no
/// switch, and its max_g could not change the lane's counter (the macro step's end
/// takes the larger of the two), so the search changes no output bit and need not run.
///
/// With m = P0 + P3 and the control points P_i ([`control_points`]), m . d(theta) =
/// sum B_i m . P_i >= min m . P_i, so |d(theta)| >= min (m . P_i) / |m|. The test
/// (m . P_i)^2 > |m|^2 (delta^2 + 1024 eps B^2) with every m . P_i > 0 puts every exact
/// |d(theta)| above delta + 500 eps B (B = max |P_i| >= |d| > delta), and a computed
/// sample is within 110 eps B of it ([`clear_of_stator`]), so every computed g is
/// positive: never the wrong side in contact. And B^2 (1 + 1024 eps) < (max_pen +
/// delta)^2 puts every computed r below max_pen + delta, so every computed g = r - delta
/// is at most max_pen (rounding is monotone). A NaN, or a negative max_pen, fails the
/// test and the search runs. On the W = 133 bench 98 % of the contact sub-steps are
/// certified (the rest enter or leave contact, or set a new largest penetration).
#[inline(always)]
pub fn in_contact_certain<R: Real>(
    delta: R,
    x0: &[R; STATE_DIM],
    x1: &[R; STATE_DIM],
    hs: R,
    max_pen: R,
) -> bool {
    let zero = R::lit(0.0);
    let p = control_points(x0, x1, hs);
    let b2 = hull_reach_sq(&p);
    let safety = R::lit(certificate_safety::<R>());
    let (mx, my) = (p[0][0] + p[3][0], p[0][1] + p[3][1]);
    let floor = (mx * mx + my * my) * (delta * delta + (safety - R::lit(1.0)) * b2);
    let mut inside = true;
    for q in &p {
        let along = mx * q[0] + my * q[1];
        inside &= (along > zero) & (along * along > floor);
    }
    let reach = max_pen + delta;
    let below = (max_pen >= zero) & (b2 * safety < reach * reach);
    inside & below
}

/// True when the switch search of the trial sub-step x0 -> x1 (duration hs) in mode
/// `contact` would change no output bit: [`clear_of_stator`] in free flight (its g are
/// all negative, below `max_pen`, which is never negative: the test asks it),
/// [`in_contact_certain`] in contact. `max_pen` is the lane's largest penetration
/// before this macro step (`Counters::max_penetration`). Then the steppers accept the
/// trial sub-step without the search.
#[inline(always)]
pub fn search_needless<R: Real>(
    delta: R,
    x0: &[R; STATE_DIM],
    x1: &[R; STATE_DIM],
    hs: R,
    contact: bool,
    max_pen: R,
) -> bool {
    let clear = clear_of_stator(delta, x0, x1, hs) & (max_pen >= R::lit(0.0));
    let held = in_contact_certain(delta, x0, x1, hs, max_pen);
    (!contact & clear) | (contact & held)
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
    // and division in turn (the scalar stepper's profile). A sample past
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
            let theta = illinois(lc, x0, x1, hs, contact, (lo, g_lo), (hi, g_hi), &mut max_g);
            return Switch { theta, max_g };
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

/// The switch of [`find_switch`] located in the bracket from `(a, g(a))` on the mode's
/// side to `(b, g(b))` on the other, by Illinois (modified regula falsi): `a` stays on
/// the mode's side, `b` on the other. Returns `b`, so the next segment starts on its own
/// side; `max_g` takes the g of every iterate on the mode's side.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn illinois<R: Real>(
    lc: &LaneConsts<R>,
    x0: &[R; STATE_DIM],
    x1: &[R; STATE_DIM],
    hs: R,
    contact: bool,
    (mut a, mut ga): (R, R),
    (mut b, mut gb): (R, R),
    max_g: &mut R,
) -> R {
    let delta = lc.c.delta;
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
            *max_g = max_g.max(gm);
            if last_kept_b {
                gb = R::lit(0.5) * gb;
            }
            last_kept_b = true;
            last_kept_a = false;
        }
    }
    b
}
