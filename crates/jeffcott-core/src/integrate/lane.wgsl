// The lane kernel, part 4 of 5 (see lane_buffers.wgsl for the whole): the lane stepper.
//
// Keep in sync with lane.rs, beside this file: the functions below are those of lane.rs,
// with the same names, in the same order, doing the same arithmetic in the same order
// (they call penetration, contact_partials and rhs_frozen of model.wgsl and phasor_turns
// of forcing.wgsl). Where the kernel's control flow differs from lane.rs's for speed on
// lavapipe (find_switch, macro_step), the comments say how, and the points evaluated and
// their bookkeeping are lane.rs's.

// Unbalance phasor at fraction `sigma` of macro step `k`.
fn forcing_phasor(lc: LaneConsts, k: u32, sigma: Real) -> vec2<Real> {
    return phasor_turns((Real(k) + sigma) * lc.inv_n - lc.phase0);
}

// One classical RK4 step over the fraction [s0, s0 + ds] of macro step k, contact mode
// held fixed.
fn rk4_substep(
    lc: LaneConsts,
    x: array<Real, STATE_DIM>,
    k: u32,
    s0: Real,
    ds: Real,
    contact: bool,
) -> array<Real, STATE_DIM> {
    let hs = ds * lc.h;
    let half = Real(0.5);
    let p0 = forcing_phasor(lc, k, s0);
    let pm = forcing_phasor(lc, k, s0 + half * ds);
    let p1 = forcing_phasor(lc, k, s0 + ds);
    let k1 = rhs_frozen(lc.c, x, p0.x, p0.y, contact);
    var xt: array<Real, STATE_DIM>;
    for (var i = 0u; i < STATE_DIM; i++) {
        xt[i] = x[i] + half * hs * k1[i];
    }
    let k2 = rhs_frozen(lc.c, xt, pm.x, pm.y, contact);
    for (var i = 0u; i < STATE_DIM; i++) {
        xt[i] = x[i] + half * hs * k2[i];
    }
    let k3 = rhs_frozen(lc.c, xt, pm.x, pm.y, contact);
    for (var i = 0u; i < STATE_DIM; i++) {
        xt[i] = x[i] + hs * k3[i];
    }
    let k4 = rhs_frozen(lc.c, xt, p1.x, p1.y, contact);
    var out: array<Real, STATE_DIM>;
    for (var i = 0u; i < STATE_DIM; i++) {
        out[i] = x[i] + hs * SIXTH * (k1[i] + Real(2.0) * (k2[i] + k3[i]) + k4[i]);
    }
    return out;
}

// The contact block of the Jacobian in mode `contact` (zero out of contact).
fn stage_partials(c: Coeffs, x: array<Real, STATE_DIM>, contact: bool) -> Partials {
    if contact {
        return contact_partials(c, x);
    }
    let z = Real(0.0);
    return Partials(vec4<Real>(z, z, z, z), vec4<Real>(z, z, z, z));
}

// J v for one tangent vector, the contact block given.
fn tangent_rhs(c: Coeffs, pc: Partials, v: array<Real, STATE_DIM>) -> array<Real, STATE_DIM> {
    let ddx = v[X_R] - v[X_S];
    let ddy = v[Y_R] - v[Y_S];
    let ddvx = v[VX_R] - v[VX_S];
    let ddvy = v[VY_R] - v[VY_S];
    let dfx = pc.a.x * ddx + pc.a.y * ddy + pc.a.z * ddvx + pc.a.w * ddvy;
    let dfy = pc.b.x * ddx + pc.b.y * ddy + pc.b.z * ddvx + pc.b.w * ddvy;
    return array<Real, STATE_DIM>(
        v[VX_R],
        -c.wr2 * v[X_R] - c.dr * v[VX_R] + c.kc_mr * dfx,
        v[VY_R],
        -c.wr2 * v[Y_R] - c.dr * v[VY_R] + c.kc_mr * dfy,
        v[VX_S],
        -c.ws2 * v[X_S] - c.ds * v[VX_S] - c.kc_ms * dfx,
        v[VY_S],
        -c.ws2 * v[Y_S] - c.ds * v[VY_S] - c.kc_ms * dfy,
    );
}

// Advances the tangent vector over the sub-step that rk4_substep takes from `x` with
// the same arguments: the state stages recomputed with rk4_substep's operations, the
// RK4 step of dv/dt = J v on them. (lane.rs also integrates the Jacobian's trace here,
// for the full spectrum; the kernel has no use for it.)
fn rk4_tangent_substep(
    lc: LaneConsts,
    x: array<Real, STATE_DIM>,
    k: u32,
    s0: Real,
    ds: Real,
    contact: bool,
    v: ptr<function, array<Real, STATE_DIM>>,
) {
    let hs = ds * lc.h;
    let half = Real(0.5);
    let p0 = forcing_phasor(lc, k, s0);
    let pm = forcing_phasor(lc, k, s0 + half * ds);
    let k1 = rhs_frozen(lc.c, x, p0.x, p0.y, contact);
    let q1 = stage_partials(lc.c, x, contact);
    var xt: array<Real, STATE_DIM>;
    for (var i = 0u; i < STATE_DIM; i++) {
        xt[i] = x[i] + half * hs * k1[i];
    }
    let k2 = rhs_frozen(lc.c, xt, pm.x, pm.y, contact);
    let q2 = stage_partials(lc.c, xt, contact);
    for (var i = 0u; i < STATE_DIM; i++) {
        xt[i] = x[i] + half * hs * k2[i];
    }
    let k3 = rhs_frozen(lc.c, xt, pm.x, pm.y, contact);
    let q3 = stage_partials(lc.c, xt, contact);
    for (var i = 0u; i < STATE_DIM; i++) {
        xt[i] = x[i] + hs * k3[i];
    }
    let q4 = stage_partials(lc.c, xt, contact);
    let v0 = *v;
    let a1 = tangent_rhs(lc.c, q1, v0);
    var vt: array<Real, STATE_DIM>;
    for (var i = 0u; i < STATE_DIM; i++) {
        vt[i] = v0[i] + half * hs * a1[i];
    }
    let a2 = tangent_rhs(lc.c, q2, vt);
    for (var i = 0u; i < STATE_DIM; i++) {
        vt[i] = v0[i] + half * hs * a2[i];
    }
    let a3 = tangent_rhs(lc.c, q3, vt);
    for (var i = 0u; i < STATE_DIM; i++) {
        vt[i] = v0[i] + hs * a3[i];
    }
    let a4 = tangent_rhs(lc.c, q4, vt);
    for (var i = 0u; i < STATE_DIM; i++) {
        (*v)[i] = v0[i] + hs * SIXTH * (a1[i] + Real(2.0) * (a2[i] + a3[i]) + a4[i]);
    }
}

// Mueller's saltation matrix S = I + (f+ - f-) n^T / (n^T f-) applied to the tangent
// vector at a switch away from mode `from_contact` at state `x`, fraction `s` of macro step k;
// both fields evaluated at the point of g = 0 radially nearest to `x`. See `saltation`
// in lane.rs.
fn saltation(
    lc: LaneConsts,
    x: array<Real, STATE_DIM>,
    k: u32,
    s: Real,
    from_contact: bool,
    v: ptr<function, array<Real, STATE_DIM>>,
) {
    let dx = x[X_R] - x[X_S];
    let dy = x[Y_R] - x[Y_S];
    let r = sqrt(dx * dx + dy * dy);
    if r <= Real(0.0) || !is_finite(r) {
        return;
    }
    let scale = lc.c.delta / r;
    var xs = x;
    // keep: rhs_frozen takes xs[X_R] - xs[X_S], which Mesa's NIR would simplify from
    // (x_s + dx scale) - x_s to dx scale without the rounding of the sum (an inexact
    // rewrite, (a + b) - a -> b), so that f+ - f- and the tangent vector differed from
    // lane.rs in the last bits (tests/mirror.rs, saltation and macro_step).
    xs[X_R] = keep(x[X_S] + dx * scale);
    xs[Y_R] = keep(x[Y_S] + dy * scale);
    let ph = forcing_phasor(lc, k, s);
    let fm = rhs_frozen(lc.c, xs, ph.x, ph.y, from_contact);
    let fp = rhs_frozen(lc.c, xs, ph.x, ph.y, !from_contact);
    let nx = dx / r;
    let ny = dy / r;
    let nf = nx * (fm[X_R] - fm[X_S]) + ny * (fm[Y_R] - fm[Y_S]);
    if nf == Real(0.0) || !is_finite(nf) {
        return;
    }
    let w = (nx * ((*v)[X_R] - (*v)[X_S]) + ny * ((*v)[Y_R] - (*v)[Y_S])) / nf;
    for (var i = 0u; i < STATE_DIM; i++) {
        (*v)[i] += (fp[i] - fm[i]) * w;
    }
}

// Renormalises the tangent vector to unit length and returns its length before.
// Unrolled, without loops: it runs after the loop-budget check of a committed macro
// step (see `loop_budget_left`), where a loop could be cut short.
fn renormalise(v: ptr<function, array<Real, STATE_DIM>>) -> Real {
    var sq = Real(0.0);
    sq += (*v)[0] * (*v)[0];
    sq += (*v)[1] * (*v)[1];
    sq += (*v)[2] * (*v)[2];
    sq += (*v)[3] * (*v)[3];
    sq += (*v)[4] * (*v)[4];
    sq += (*v)[5] * (*v)[5];
    sq += (*v)[6] * (*v)[6];
    sq += (*v)[7] * (*v)[7];
    let n = sqrt(sq);
    if n > Real(0.0) && is_finite(n) {
        (*v)[0] = (*v)[0] / n;
        (*v)[1] = (*v)[1] / n;
        (*v)[2] = (*v)[2] / n;
        (*v)[3] = (*v)[3] / n;
        (*v)[4] = (*v)[4] / n;
        (*v)[5] = (*v)[5] / n;
        (*v)[6] = (*v)[6] / n;
        (*v)[7] = (*v)[7] / n;
    }
    return n;
}

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
    let px0 = x0[X_R] - x0[X_S];
    let py0 = x0[Y_R] - x0[Y_S];
    let vx0 = x0[VX_R] - x0[VX_S];
    let vy0 = x0[VY_R] - x0[VY_S];
    let px1 = x1[X_R] - x1[X_S];
    let py1 = x1[Y_R] - x1[Y_S];
    let vx1 = x1[VX_R] - x1[VX_S];
    let vy1 = x1[VY_R] - x1[VY_S];
    let dx = h00 * px0 + h10 * vx0 + h01 * px1 + h11 * vx1;
    let dy = h00 * py0 + h10 * vy0 + h01 * py1 + h11 * vy1;
    let ddx = d00 * px0 + d10 * vx0 + d01 * px1 + d11 * vx1;
    let ddy = d00 * py0 + d10 * vy0 + d01 * py1 + d11 * vy1;
    let r = sqrt(dx * dx + dy * dy);
    // r > 0 whenever g is near 0 (r ~ delta); the rate is only used there.
    var rate = Real(0.0);
    if r > Real(0.0) {
        rate = (dx * ddx + dy * ddy) / r;
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
// what a lane needs. lane.rs's find_switch written as it is (a sample loop with an
// extremum evaluation and an Illinois loop inside each sample) costs 25 hermite_gap
// evaluations per trial step even when no lane is near contact, and macro_step's
// re-step and refinement-cap sub-steps cost two more RK4 steps per macro step. The
// kernel therefore evaluates the samples of find_switch up front, then runs one loop
// with one hermite_gap call per pass for the data-dependent points (extrema, Illinois
// iterates), and macro_step as one loop with one rk4_substep call per iteration, the
// phase of each lane choosing the arguments. Every lane's result is lane.rs's bit for
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

// State of one scan of find_switch over the samples: lane.rs's sample loop up to the
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
        (*sc).lo = Real(j) / Real(GRAZE_SAMPLES);
        (*sc).g_lo = g_j;
    }
}

// Looks for the first crossing of g = 0 along the trial sub-step x0 -> x1 (duration hs)
// taken in mode `contact`; see the docs of lane.rs. Between two samples on
// the mode's side, an extremum of g heading to the other side (rates of opposite signs)
// is checked at its estimated location.
//
// lane.rs walks the samples one at a time, evaluating each when it gets there. Here all
// samples are evaluated first (independent evaluations the CPU core overlaps, where a
// walk would wait on each sqrt and division in turn; lavapipe runs one SIMD group per
// thread, so latency is what it pays), then each pass of one loop scans the samples
// from where the lane is for the next event and evaluates the one point it needs (see
// the note above FS_SCAN). lane.rs's `lo`, `g_lo`, `rate_lo` are always the last sample
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
    let s1 = hermite_gap(delta, x0, x1, hs, Real(1u) / Real(GRAZE_SAMPLES));
    let s2 = hermite_gap(delta, x0, x1, hs, Real(2u) / Real(GRAZE_SAMPLES));
    let s3 = hermite_gap(delta, x0, x1, hs, Real(3u) / Real(GRAZE_SAMPLES));
    let s4 = hermite_gap(delta, x0, x1, hs, Real(4u) / Real(GRAZE_SAMPLES));
    let s5 = hermite_gap(delta, x0, x1, hs, Real(5u) / Real(GRAZE_SAMPLES));
    let s6 = hermite_gap(delta, x0, x1, hs, Real(6u) / Real(GRAZE_SAMPLES));
    let s7 = hermite_gap(delta, x0, x1, hs, Real(7u) / Real(GRAZE_SAMPLES));
    let s8 = hermite_gap(delta, x0, x1, hs, Real(8u) / Real(GRAZE_SAMPLES));
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
    // Illinois (modified regula falsi); `a` stays on the mode's side, `b` on the other.
    var a = zero;
    var ga = zero;
    var b = zero;
    var gb = zero;
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
                // lane.rs: the extremum's g, then sample je's, and on to the next sample.
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
                b = m;
                gb = gp;
                if last_kept_a {
                    ga = Real(0.5) * ga;
                }
                last_kept_a = true;
                last_kept_b = false;
            } else {
                a = m;
                ga = gp;
                max_g = rmax(max_g, gp);
                if last_kept_b {
                    gb = Real(0.5) * gb;
                }
                last_kept_b = true;
                last_kept_a = false;
            }
            it += 1u;
            if it == ROOT_MAX_ITERS {
                result = b;
                phase = FS_DONE;
            }
        }
        if phase == FS_SCAN {
            // lane.rs's sample loop from sample jn, up to the first sample on the wrong
            // side or with an extremum heading there before it.
            var sc = Scan(false, false, 0u, zero, zero, zero, max_g, lo, g_lo);
            scan_sample(&sc, jn, 1u, s1.x, s0.y, s1.y, contact);
            scan_sample(&sc, jn, 2u, s2.x, s1.y, s2.y, contact);
            scan_sample(&sc, jn, 3u, s3.x, s2.y, s3.y, contact);
            scan_sample(&sc, jn, 4u, s4.x, s3.y, s4.y, contact);
            scan_sample(&sc, jn, 5u, s5.x, s4.y, s5.y, contact);
            scan_sample(&sc, jn, 6u, s6.x, s5.y, s6.y, contact);
            scan_sample(&sc, jn, 7u, s7.x, s6.y, s7.y, contact);
            scan_sample(&sc, jn, 8u, s8.x, s7.y, s8.y, contact);
            max_g = sc.max_g;
            lo = sc.lo;
            g_lo = sc.g_lo;
            if !sc.found {
                phase = FS_DONE;
            } else {
                je = sc.je;
                th = Real(je) / Real(GRAZE_SAMPLES);
                g_th = sc.g_th;
                if sc.crossing {
                    hi = th;
                    g_hi = g_th;
                    crossing = true;
                } else {
                    // Extremum where the linearly interpolated rate vanishes.
                    theta = lo + (th - lo) * sc.rate_lo / (sc.rate_lo - sc.rate_th);
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
                a = lo;
                ga = g_lo;
                b = hi;
                gb = g_hi;
                phase = FS_ROOT;
            }
        }
        if phase == FS_ROOT {
            // lane.rs's Illinois loop head: stop at the tolerance, else the next iterate.
            if b - a <= lc.root_tol {
                result = b;
                phase = FS_DONE;
            } else {
                var m = b - gb * (b - a) / (gb - ga);
                if !(m > a && m < b) {
                    m = Real(0.5) * (a + b);
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

// lane.rs's trial_extent: length and end of the next trial sub-step from fraction s.
struct Extent {
    ds: Real,
    end: Real,
}

fn trial_extent(lc: LaneConsts, s: Real, contact: bool) -> Extent {
    let one = Real(1.0);
    if contact && one - s > lc.inv_r {
        return Extent(lc.inv_r, s + lc.inv_r);
    }
    return Extent(one - s, one);
}

// What the next sub-step of macro_step is.
const MS_TRIAL: u32 = 0u; // a trial step (trial_extent), then find_switch
const MS_RESTEP: u32 = 1u; // the step to the located switch
const MS_CAP: u32 = 2u; // the refinement cap's step to the end

// A macro step in progress: the local variables of lane.rs's macro_step, kept between
// the sub-steps (see macro_step).
struct MacroStep {
    x: array<Real, STATE_DIM>,
    contact: bool,
    touched: bool,
    // Sub-step start s, and this sub-step's length ds (set for a step to the switch).
    s: Real,
    ds: Real,
    done: bool,
    capped: bool,
    substeps: u32,
    switches: u32,
    max_g: Real,
    // Segments begun (lane.rs's loop counter) and the next sub-step.
    seg: u32,
    part: u32,
}

// lane.rs's macro_step up to its segment loop.
fn macro_step_begin(lc: LaneConsts, lane: Lane) -> MacroStep {
    let contact = lane.contact != 0u;
    // The CPU starts max_g from -inf; WGSL has no infinite literal. -REAL_MAX gives the
    // same result: the first `rmax` replaces it by any finite g, and a NaN g freezes
    // the lane before max_g is used.
    return MacroStep(
        lane.x,
        contact,
        contact,
        Real(0.0),
        Real(1.0),
        false,
        false,
        0u,
        0u,
        -REAL_MAX,
        0u,
        select(MS_TRIAL, MS_CAP, lc.max_segments == 0u),
    );
}

// Advances a macro step (1/N of a forcing period) by one sub-step. Keep in sync with
// `macro_step` in lane.rs: macro_step_begin, then this until `done`, then
// macro_step_end are lane.rs's macro_step.
//
// lane.rs's segment loop (a trial step, then perhaps the step to the switch) and the
// refinement-cap step after it are one sub-step per call here, `part` saying which
// (see the note above FS_SCAN), and the entry point calls this once per iteration of
// its one loop, starting the lane's next macro step as soon as one is done. So on
// lavapipe a SIMD group pays one RK4 step and one switch search per iteration, and a
// lane that needs more sub-steps in a macro step (a contact switch) does not hold the
// other 7 lanes of its group back: they carry on with their next macro steps. The
// sub-steps, their arguments and their order are lane.rs's for every lane.
fn macro_step(
    lc: LaneConsts,
    k: u32,
    ms: ptr<function, MacroStep>,
    v: ptr<function, array<Real, STATE_DIM>>,
) {
    // `v` is the tangent vector (lane.rs: macro_step_tangent with M = 1); every use is
    // dead code when LYAPUNOV is false.
    let one = Real(1.0);
    var x = (*ms).x;
    var s = (*ms).s;
    var ds = (*ms).ds;
    var contact = (*ms).contact;
    let part = (*ms).part;
    var end = one;
    if part == MS_TRIAL {
        let ext = trial_extent(lc, s, contact);
        ds = ext.ds;
        end = ext.end;
    } else if part == MS_CAP {
        ds = one - s;
    }
    let x1 = rk4_substep(lc, x, k, s, ds, contact);
    (*ms).substeps += 1u;
    var flip = false;
    var done = false;
    var next_part = part;
    if part == MS_TRIAL {
        let sw = find_switch(lc, x, x1, ds * lc.h, contact);
        (*ms).max_g = rmax((*ms).max_g, sw.max_g);
        if sw.theta > one {
            // No switch: the macro step is done, or a contact sub-step of 1/R is (and
            // the next trial follows).
            if LYAPUNOV {
                rk4_tangent_substep(lc, x, k, s, ds, contact, v);
            }
            x = x1;
            s = end;
            done = s >= one;
        } else if sw.theta >= one {
            if LYAPUNOV {
                rk4_tangent_substep(lc, x, k, s, ds, contact, v);
            }
            x = x1;
            s = end;
            flip = true;
        } else if sw.theta > Real(0.0) {
            // Step to the switch in the next sub-step.
            ds = ds * sw.theta;
            next_part = MS_RESTEP;
        } else {
            flip = true;
        }
    } else if part == MS_RESTEP {
        if LYAPUNOV {
            rk4_tangent_substep(lc, x, k, s, ds, contact, v);
        }
        x = x1;
        s += ds;
        flip = true;
    } else {
        // Refinement cap: finish the step in the current mode and say so.
        if LYAPUNOV {
            rk4_tangent_substep(lc, x, k, s, ds, contact, v);
        }
        x = x1;
        contact = penetration(lc.c.delta, x) > Real(0.0);
        (*ms).capped = true;
        done = true;
    }
    if flip {
        if LYAPUNOV {
            saltation(lc, x, k, s, contact, v);
        }
        contact = !contact;
        (*ms).touched = true;
        (*ms).switches += 1u;
        if s >= one {
            done = true;
        } else {
            (*ms).seg += 1u;
            next_part = select(MS_TRIAL, MS_CAP, (*ms).seg == lc.max_segments);
        }
    }
    (*ms).x = x;
    (*ms).s = s;
    (*ms).ds = ds;
    (*ms).contact = contact;
    (*ms).part = next_part;
    (*ms).done = done;
}

// lane.rs's macro_step after its segment loop and refinement cap: status checks and
// counters of the finished macro step `ms` of `lane`.
fn macro_step_end(lc: LaneConsts, lane: ptr<function, Lane>, ms: MacroStep) {
    if ms.capped && (*lane).status < STATUS_REFINEMENT_CAP {
        (*lane).status = STATUS_REFINEMENT_CAP;
    }
    let x = ms.x;
    let k = (*lane).k;
    // Status checks: freeze at the last good state rather than poison anything.
    var finite = true;
    for (var i = 0u; i < STATE_DIM; i++) {
        finite = finite && is_finite(x[i]);
    }
    if !finite {
        (*lane).status = STATUS_NON_FINITE;
        return;
    }
    let reach = rmax(rmax(rmax(abs(x[X_R]), abs(x[Y_R])), abs(x[X_S])), abs(x[Y_S]));
    if reach > lc.bound {
        (*lane).status = STATUS_DIVERGED;
        return;
    }
    (*lane).x = x;
    (*lane).contact = select(0u, 1u, ms.contact);
    (*lane).k = select(k + 1u, 0u, k + 1u == lc.n);
    (*lane).counters.macro_steps = sat_add((*lane).counters.macro_steps, 1u);
    (*lane).counters.contact_steps = sat_add(
        (*lane).counters.contact_steps,
        select(0u, 1u, ms.touched),
    );
    (*lane).counters.switches = sat_add((*lane).counters.switches, ms.switches);
    (*lane).counters.extra_substeps = sat_add(
        (*lane).counters.extra_substeps,
        ms.substeps - 1u,
    );
    if ms.touched {
        (*lane).counters.max_penetration = rmax((*lane).counters.max_penetration, ms.max_g);
    }
}

// `advance_period` of lane.rs (N macro steps) has no counterpart here: the entry point
// (lane_entry.wgsl) runs the same N macro steps per period, but one at a time so that it
// can stop and resume between any two of them.
