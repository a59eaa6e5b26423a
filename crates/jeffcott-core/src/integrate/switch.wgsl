// The lane kernel, part 5 of 8 (see lane_buffers.wgsl for the whole): the switch search
// of one trial sub-step.
//
// Keep in sync with switch.rs, beside this file: the functions below are those of
// switch.rs, with the same names, in the same order, doing the same arithmetic in the
// same order. Where the kernel's control flow differs from switch.rs's for speed on
// lavapipe (find_switch), the comments say how, and the points evaluated and their
// bookkeeping are switch.rs's.

// Penetration g and its rate dg/dtheta (returned as (g, rate)) at fraction `theta` of
// a sub-step of duration `hs`, on the cubic Hermite interpolant of the relative
// displacement between the sub-step's end states (exact at theta = 0 and 1).
fn hermite_gap(
    delta: Real,
    x0: array<Real, STATE_DIM>,
    x1: array<Real, STATE_DIM>,
    hs: Real,
    theta: Real,
) -> vec2<Real> {
    let one = Real(1.0);
    let two = Real(2.0);
    let three = Real(3.0);
    let six = Real(6.0);
    let u = one - theta;
    let h00 = (one + two * theta) * u * u;
    let h10 = theta * u * u * hs;
    let h01 = theta * theta * (three - two * theta);
    let h11 = -theta * theta * u * hs;
    // d/dtheta of the basis.
    let d00 = six * theta * (theta - one);
    let d10 = (keep(three * theta * theta - Real(4.0) * theta) + one) * hs;
    let d01 = -d00;
    let d11 = (three * theta * theta - two * theta) * hs;
    let m0 = relative_motion(x0);
    let m1 = relative_motion(x1);
    let dx = h00 * m0.x + h10 * m0.z + h01 * m1.x + h11 * m1.z;
    let dy = h00 * m0.y + h10 * m0.w + h01 * m1.y + h11 * m1.w;
    let ddx = d00 * m0.x + d10 * m0.z + d01 * m1.x + d11 * m1.z;
    let ddy = d00 * m0.y + d10 * m0.w + d01 * m1.y + d11 * m1.w;
    let r = sqrt_rn(dx * dx + dy * dy);
    // r > 0 whenever g is near 0 (r ~ delta); the rate is only used there.
    var rate = Real(0.0);
    if r > Real(0.0) {
        rate = div_rn(dx * ddx + dy * ddy, r);
    }
    return vec2<Real>(r - delta, rate);
}

// True when penetration `g` is on the side of g = 0 that the mode does not hold.
fn wrong_side(g: Real, contact: bool) -> bool {
    if contact {
        return g <= Real(0.0);
    }
    return g > Real(0.0);
}

// switch.rs's control_points: the Bezier control points of the search's Hermite
// interpolant (d(theta) lies in their convex hull).
fn control_points(
    x0: array<Real, STATE_DIM>,
    x1: array<Real, STATE_DIM>,
    hs: Real,
) -> array<vec2<Real>, 4> {
    let m0 = relative_motion(x0);
    let m1 = relative_motion(x1);
    let t = div_rn(hs, Real(3.0));
    return array<vec2<Real>, 4>(
        vec2<Real>(m0.x, m0.y),
        vec2<Real>(m0.x + t * m0.z, m0.y + t * m0.w),
        vec2<Real>(m1.x - t * m1.z, m1.y - t * m1.w),
        vec2<Real>(m1.x, m1.y),
    );
}

// The largest |P_i|^2, NaN when any is NaN (switch.rs's hull_reach_sq; written out, no
// loop, which would count against llvmpipe's loop limit).
fn hull_reach_sq(p: array<vec2<Real>, 4>) -> Real {
    var b2 = Real(0.0);
    let n0 = p[0].x * p[0].x + p[0].y * p[0].y;
    b2 = select(n0, b2, n0 <= b2);
    let n1 = p[1].x * p[1].x + p[1].y * p[1].y;
    b2 = select(n1, b2, n1 <= b2);
    let n2 = p[2].x * p[2].x + p[2].y * p[2].y;
    b2 = select(n2, b2, n2 <= b2);
    let n3 = p[3].x * p[3].x + p[3].y * p[3].y;
    b2 = select(n3, b2, n3 <= b2);
    return b2;
}

// True when the free-flight trial sub-step x0 -> x1 (duration hs) certainly stays
// clear of the stator: the convex hull of the control points inside the clearance,
// with a 1024-ulp margin on the squares (switch.rs has the proof). Then find_switch
// would find no switch and only negative g.
fn free_flight_certain(
    lc: LaneConsts,
    x0: array<Real, STATE_DIM>,
    x1: array<Real, STATE_DIM>,
    hs: Real,
) -> bool {
    return clear_of_stator(lc.c.delta, x0, x1, hs);
}

// free_flight_certain for clearance `delta`, the test search_needless makes in free
// flight (switch.rs's clear_of_stator).
fn clear_of_stator(
    delta: Real,
    x0: array<Real, STATE_DIM>,
    x1: array<Real, STATE_DIM>,
    hs: Real,
) -> bool {
    let b2 = hull_reach_sq(control_points(x0, x1, hs));
    return b2 * CERTIFICATE_SAFETY < delta * delta;
}

// True when the contact trial sub-step certainly stays in contact and no g the search
// would compute exceeds max_pen (switch.rs's in_contact_certain has the proof).
fn in_contact_certain(
    delta: Real,
    x0: array<Real, STATE_DIM>,
    x1: array<Real, STATE_DIM>,
    hs: Real,
    max_pen: Real,
) -> bool {
    let zero = Real(0.0);
    let p = control_points(x0, x1, hs);
    let b2 = hull_reach_sq(p);
    let safety = CERTIFICATE_SAFETY;
    let mx = p[0].x + p[3].x;
    let my = p[0].y + p[3].y;
    let floor = (mx * mx + my * my) * (delta * delta + (safety - Real(1.0)) * b2);
    let a0 = mx * p[0].x + my * p[0].y;
    let a1 = mx * p[1].x + my * p[1].y;
    let a2 = mx * p[2].x + my * p[2].y;
    let a3 = mx * p[3].x + my * p[3].y;
    var inside = (a0 > zero) & (a0 * a0 > floor);
    inside = inside & (a1 > zero) & (a1 * a1 > floor);
    inside = inside & (a2 > zero) & (a2 * a2 > floor);
    inside = inside & (a3 > zero) & (a3 * a3 > floor);
    let reach = max_pen + delta;
    let below = (max_pen >= zero) & (b2 * safety < reach * reach);
    return inside & below;
}

// True when the search of the trial sub-step in mode `contact` would change no output
// bit (switch.rs's search_needless): clear of the stator in free flight, held in
// contact below the lane's largest penetration so far (`max_pen`).
fn search_needless(
    delta: Real,
    x0: array<Real, STATE_DIM>,
    x1: array<Real, STATE_DIM>,
    hs: Real,
    contact: bool,
    max_pen: Real,
) -> bool {
    let clear = clear_of_stator(delta, x0, x1, hs) & (max_pen >= Real(0.0));
    let held = in_contact_certain(delta, x0, x1, hs, max_pen);
    return (!contact & clear) | (contact & held);
}

// Result of the switch search over one trial sub-step.
struct Switch {
    // Fraction of the sub-step at which the mode must flip, or a value > 1 for none.
    theta: Real,
    // Largest g among the samples on the trajectory before the switch.
    max_g: Real,
}

// Kernel-only control structure (lavapipe, see find_switch and macro_step).
//
// Mesa's llvmpipe (lavapipe) up to at least Mesa 22.3 runs 8 invocations (one AVX2
// register of f32, two of f64) in lock-step and compiles every `if` to masked code
// without a branch: both arms of every `if` are executed, whatever the lanes decide.
// Only loops branch: a loop iterates while any of the 8 lanes is still in it, and its
// body runs at least once (the exit test is at the end). So what a SIMD group pays per
// macro step is the code of every `if` arm in the loop bodies it passes through, not
// what a lane needs. switch.rs's find_switch written as it is (a sample loop with an
// extremum evaluation and an Illinois loop inside each sample) costs 25 hermite_gap
// evaluations per trial step even when no lane is near contact, and macro_step's
// re-step and refinement-cap sub-steps cost two more RK4 steps per macro step. The
// kernel therefore evaluates the samples of find_switch up front, then runs one loop
// with one hermite_gap call per pass for the data-dependent points (extrema, Illinois
// iterates), and macro_step as one loop with one rk4_substep call per iteration, the
// phase of each lane choosing the arguments. Every lane's result is switch.rs's bit for
// bit (same points evaluated with the same arguments, same bookkeeping in the same
// order; extra evaluations whose results are not used change nothing), and a group
// pays one trial step and 10 hermite_gap calls per macro step in free flight.

// What a pass of find_switch's loop does for a lane.
const FS_SCAN: u32 = 0u; // look for the next sample with a crossing or an extremum before it
const FS_EXTREMUM: u32 = 1u; // check the estimated extremum before sample `je`
const FS_ROOT: u32 = 2u; // an Illinois iterate
const FS_DONE: u32 = 3u;
// Passes at most: the first scan, an extremum check per sample, the Illinois iterations.
const FS_MAX_PASSES: u32 = 1u + GRAZE_SAMPLES + ROOT_MAX_ITERS;

// State of one scan of find_switch over the samples: switch.rs's sample loop up to the
// first sample on the wrong side or with an extremum heading there before it (sample
// `je`), its running max_g and its last sample passed (lo, g_lo).
struct Scan {
    found: bool,
    crossing: bool,
    je: u32,
    g_th: Real,
    rate_lo: Real,
    rate_th: Real,
    max_g: Real,
    lo: Real,
    g_lo: Real,
}

// One sample of the scan: sample j (g_j and its rate rate_th; rate_lo that of sample
// j - 1), if the scan has not stopped yet and the lane's scan starts at or before j.
// Called with constant j: straight-line code on values held in registers.
fn scan_sample(
    sc: ptr<function, Scan>,
    jn: u32,
    j: u32,
    g_j: Real,
    rate_lo: Real,
    rate_th: Real,
    contact: bool,
) {
    if (*sc).found || j < jn {
        return;
    }
    let zero = Real(0.0);
    let crossing = wrong_side(g_j, contact);
    var toward: bool;
    if contact {
        toward = rate_lo < zero && rate_th > zero;
    } else {
        toward = rate_lo > zero && rate_th < zero;
    }
    if crossing || toward {
        (*sc).found = true;
        (*sc).crossing = crossing;
        (*sc).je = j;
        (*sc).g_th = g_j;
        (*sc).rate_lo = rate_lo;
        (*sc).rate_th = rate_th;
    } else {
        (*sc).max_g = rmax((*sc).max_g, g_j);
        (*sc).lo = div_rn(Real(j), Real(GRAZE_SAMPLES));
        (*sc).g_lo = g_j;
    }
}

// Looks for the first crossing of g = 0 along the trial sub-step x0 -> x1 (duration hs)
// taken in mode `contact`; see the docs of switch.rs and lane.rs. Between two samples on
// the mode's side, an extremum of g heading to the other side (rates of opposite signs)
// is checked at its estimated location.
//
// switch.rs walks the samples one at a time, evaluating each when it gets there. Here all
// samples are evaluated first (independent evaluations the CPU core overlaps, where a
// walk would wait on each sqrt and division in turn; lavapipe runs one SIMD group per
// thread, so latency is what it pays), then each pass of one loop scans the samples
// from where the lane is for the next event and evaluates the one point it needs (see
// the note above FS_SCAN). switch.rs's `lo`, `g_lo`, `rate_lo` are always the last sample
// passed, i.e. sample j - 1 when sample j is examined.
fn find_switch(
    lc: LaneConsts,
    x0: array<Real, STATE_DIM>,
    x1: array<Real, STATE_DIM>,
    hs: Real,
    contact: bool,
) -> Switch {
    let delta = lc.c.delta;
    let zero = Real(0.0);
    // The samples, written out: a loop here is not unrolled by Mesa 22.3 and would keep
    // them in memory. j / GRAZE_SAMPLES: the quotient of two small integers is
    // correctly rounded, equal to Rust's f64 quotient rounded to Real.
    const_assert GRAZE_SAMPLES == 8u;
    let s0 = hermite_gap(delta, x0, x1, hs, Real(0u) / Real(GRAZE_SAMPLES));
    var s1 = s0;
    var s2 = s0;
    var s3 = s0;
    var s4 = s0;
    var s5 = s0;
    var s6 = s0;
    var s7 = s0;
    var s8 = s0;
    if !CONSTS_EACH_STEP {
        s1 = hermite_gap(delta, x0, x1, hs, Real(1u) / Real(GRAZE_SAMPLES));
        s2 = hermite_gap(delta, x0, x1, hs, Real(2u) / Real(GRAZE_SAMPLES));
        s3 = hermite_gap(delta, x0, x1, hs, Real(3u) / Real(GRAZE_SAMPLES));
        s4 = hermite_gap(delta, x0, x1, hs, Real(4u) / Real(GRAZE_SAMPLES));
        s5 = hermite_gap(delta, x0, x1, hs, Real(5u) / Real(GRAZE_SAMPLES));
        s6 = hermite_gap(delta, x0, x1, hs, Real(6u) / Real(GRAZE_SAMPLES));
        s7 = hermite_gap(delta, x0, x1, hs, Real(7u) / Real(GRAZE_SAMPLES));
        s8 = hermite_gap(delta, x0, x1, hs, Real(8u) / Real(GRAZE_SAMPLES));
    }
    var max_g = s0.x;
    var phase = FS_SCAN;
    // The next sample to examine; the sample whose extremum is checked.
    var jn = 1u;
    var je = 0u;
    var lo = zero;
    var g_lo = s0.x;
    var th = zero;
    var g_th = zero;
    // Where the pass evaluates (an extremum or an Illinois iterate).
    var theta = zero;
    // Illinois (modified regula falsi) keeps its bracket in the scan's variables, dead
    // once the root phase begins (only FS_DONE follows it): switch.rs's a and ga (on the
    // mode's side) in `lo` and `g_lo`, its b and gb (on the other side) in `th` and
    // `g_th`. Fewer values live across the loop, which a SIMT GPU holds in registers;
    // the same arithmetic.
    var last_kept_a = false;
    var last_kept_b = false;
    var it = 0u;
    var result = Real(2.0);
    for (var n = 0u; n < FS_MAX_PASSES; n++) {
        // The point this pass needs (unused in the first pass, which only scans).
        let gp = hermite_gap(delta, x0, x1, hs, theta).x;
        var crossing = false;
        var hi = zero;
        var g_hi = zero;
        if phase == FS_EXTREMUM {
            if wrong_side(gp, contact) {
                hi = theta;
                g_hi = gp;
                crossing = true;
            } else {
                // switch.rs: the extremum's g, then sample je's, and on to the next sample.
                max_g = rmax(max_g, gp);
                max_g = rmax(max_g, g_th);
                lo = th;
                g_lo = g_th;
                jn = je + 1u;
                phase = FS_SCAN;
            }
        } else if phase == FS_ROOT {
            let m = theta;
            if wrong_side(gp, contact) {
                th = m;
                g_th = gp;
                if last_kept_a {
                    g_lo = Real(0.5) * g_lo;
                }
                last_kept_a = true;
                last_kept_b = false;
            } else {
                lo = m;
                g_lo = gp;
                max_g = rmax(max_g, gp);
                if last_kept_b {
                    g_th = Real(0.5) * g_th;
                }
                last_kept_b = true;
                last_kept_a = false;
            }
            it += 1u;
            if it == ROOT_MAX_ITERS {
                result = th;
                phase = FS_DONE;
            }
        }
        if phase == FS_SCAN {
            // switch.rs's sample loop from sample jn, up to the first sample on the wrong
            // side or with an extremum heading there before it.
            var sc = Scan(false, false, 0u, zero, zero, zero, max_g, lo, g_lo);
            if CONSTS_EACH_STEP {
                var prev = hermite_gap(delta, x0, x1, hs, div_rn(Real(jn - 1u), Real(GRAZE_SAMPLES)));
                for (var j = jn; j <= GRAZE_SAMPLES; j++) {
                    let cur = hermite_gap(delta, x0, x1, hs, div_rn(Real(j), Real(GRAZE_SAMPLES)));
                    scan_sample(&sc, jn, j, cur.x, prev.y, cur.y, contact);
                    if sc.found {
                        break;
                    }
                    prev = cur;
                }
            } else {
                scan_sample(&sc, jn, 1u, s1.x, s0.y, s1.y, contact);
                scan_sample(&sc, jn, 2u, s2.x, s1.y, s2.y, contact);
                scan_sample(&sc, jn, 3u, s3.x, s2.y, s3.y, contact);
                scan_sample(&sc, jn, 4u, s4.x, s3.y, s4.y, contact);
                scan_sample(&sc, jn, 5u, s5.x, s4.y, s5.y, contact);
                scan_sample(&sc, jn, 6u, s6.x, s5.y, s6.y, contact);
                scan_sample(&sc, jn, 7u, s7.x, s6.y, s7.y, contact);
                scan_sample(&sc, jn, 8u, s8.x, s7.y, s8.y, contact);
            }
            max_g = sc.max_g;
            lo = sc.lo;
            g_lo = sc.g_lo;
            if !sc.found {
                phase = FS_DONE;
            } else {
                je = sc.je;
                th = div_rn(Real(je), Real(GRAZE_SAMPLES));
                g_th = sc.g_th;
                if sc.crossing {
                    hi = th;
                    g_hi = g_th;
                    crossing = true;
                } else {
                    // Extremum where the linearly interpolated rate vanishes.
                    theta = lo + div_rn((th - lo) * sc.rate_lo, sc.rate_lo - sc.rate_th);
                    phase = FS_EXTREMUM;
                }
            }
        }
        if crossing {
            if wrong_side(g_lo, contact) {
                // Only at the start (j = 1): the lane sits on the switching surface and
                // its mode's flow leaves to the other side; flip now.
                result = lo;
                phase = FS_DONE;
            } else {
                // a = lo and ga = g_lo already (see above).
                th = hi;
                g_th = g_hi;
                phase = FS_ROOT;
            }
        }
        if phase == FS_ROOT {
            // switch.rs's Illinois loop head: stop at the tolerance, else the next iterate.
            if th - lo <= lc.root_tol {
                result = th;
                phase = FS_DONE;
            } else {
                var m = th - div_rn(g_th * (th - lo), g_th - g_lo);
                if !(m > lo && m < th) {
                    m = Real(0.5) * (lo + th);
                }
                theta = m;
            }
        }
        if phase == FS_DONE {
            break;
        }
    }
    return Switch(result, max_g);
}
