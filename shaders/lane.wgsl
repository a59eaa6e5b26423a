// The ensemble lane stepper on the GPU: one invocation advances one lane (one
// trajectory of the rotor-stator system, MODEL.md 4.2) by a time slice of whole forcing
// periods, with the state held in registers for the whole slice.
//
// Keep in sync with src/integrate/lane.rs (and with penetration, contact_force_per_kc
// and rhs_frozen in src/model.rs, phasor_turns in src/integrate/forcing.rs): the
// functions below are those functions, with the same names, in the same order, doing
// the same arithmetic in the same order, so that the f64 variant reproduces the CPU f64
// lane bit for bit on an IEEE device (and the f32 variant the CPU f32 lane).
//
// This file is not valid WGSL on its own: src/gpu/shader.rs prepends a generated header
// that defines
//   alias Real = f32 | f64;                 the precision (DESIGN.md 1)
//   WORKGROUP_SIZE, STATE_DIM, X_R .. VY_S, GRAZE_SAMPLES, ROOT_MAX_ITERS, STATUS_*
//   REAL_MAX, TAU, SIXTH, SIN_C0 .. SIN_C8, COS_C0 .. COS_C8
// from the Rust constants. Every non-dyadic floating constant lives in that header as
// an abstract-float literal holding the exact f64 value Rust uses; naga converts it to
// Real with `as f32` semantics, exactly like `Real::lit`. The literals written inline
// below (0.0, 0.25, 0.5, 1.0, 2.0, 3.0, 4.0, 6.0) are exact in both precisions.
//
// Rules kept here (DESIGN.md 3): no trigonometry at all (the forcing phasor is a
// polynomial), no recursion, every loop bounded by a constant or a lane constant.
// Builtins whose NaN behaviour is implementation-defined (`max`, `min`) are not used:
// `rmax` spells out the CPU's comparison instead.

// ---- buffers ------------------------------------------------------------------------

// Equation coefficients of one lane (model::Coeffs).
struct Coeffs {
    wr2: Real,
    dr: Real,
    ws2: Real,
    ds: Real,
    unbalance: Real,
    a_g: Real,
    kc_mr: Real,
    kc_ms: Real,
    mu: Real,
    delta: Real,
}

// Constants of one lane (integrate::lane::LaneConsts).
struct LaneConsts {
    c: Coeffs,
    h: Real,
    inv_n: Real,
    phase0: Real,
    bound: Real,
    root_tol: Real,
    n: u32,
    max_segments: u32,
}

// integrate::lane::Counters, with u32 counts that saturate at 2^32 - 1 (the host widens
// them to u64) and the largest penetration in the lane's precision.
struct Counters {
    macro_steps: u32,
    contact_steps: u32,
    switches: u32,
    extra_substeps: u32,
    max_penetration: Real,
}

// integrate::lane::Lane: contact is 0/1, status is Status::code().
struct Lane {
    x: array<Real, STATE_DIM>,
    contact: u32,
    k: u32,
    status: u32,
    // Forcing periods completed (GPU only: where to resume after an interrupted slice).
    period: u32,
    counters: Counters,
}

// One dispatch advances lanes [0, n_lanes) of the bound chunk to the end of global
// period `period_end - 1`, from the slice start `period_begin` (or wherever an earlier
// dispatch of the same slice left them). The state after global period p is recorded
// when p >= record_from, at slot p - period_begin. `probe` is 2 (see loop_budget_left).
struct Params {
    n_lanes: u32,
    period_begin: u32,
    period_end: u32,
    record_from: u32,
    probe: u32,
    pad0: u32,
    pad1: u32,
    pad2: u32,
}

@group(0) @binding(0) var<uniform> params: Params;
@group(0) @binding(1) var<storage, read> consts: array<LaneConsts>;
@group(0) @binding(2) var<storage, read_write> lanes: array<Lane>;
// Poincare points of this slice: [slot][lane][STATE_DIM].
@group(0) @binding(3) var<storage, read_write> records: array<Real>;
// [0]: lanes that did not reach period_end in this dispatch; [1]: those of them that
// could not commit a single macro step (the host zeroes both first).
@group(0) @binding(4) var<storage, read_write> unfinished: array<atomic<u32>, 2>;

// ---- helpers standing in for the Real trait and u64 counters ----------------------

// Real::max: `if other > self { other } else { self }` (NaN keeps `a`).
fn rmax(a: Real, b: Real) -> Real {
    return select(a, b, b > a);
}

// Real::is_finite without bit tricks (WGSL has no f64 bitcast): NaN fails every ordered
// comparison and +-inf exceed REAL_MAX.
fn is_finite(v: Real) -> bool {
    return abs(v) <= REAL_MAX;
}

// Status::is_frozen.
fn is_frozen(status: u32) -> bool {
    return status == STATUS_DIVERGED || status == STATUS_NON_FINITE;
}

// Returns `v`. An evaluation-order barrier: SPIR-V from naga carries no NoContraction
// decoration, so Mesa's NIR may apply inexact rewrites to + and *, among them
// "reassociate add chains for more MAD/FMA-friendly code", (p*q + r*s) + c ->
// (p*q + c) + r*s, which changes the rounding. `params.n_lanes` is never 0 in an
// invocation that computes anything (see `advance_lanes`), but the compiler cannot
// know that, so it cannot see through the select and keeps Rust's order. Used exactly
// where such a rewrite applies; tests/gpu.rs checks the CPU f64 lane bit for bit.
fn keep(v: Real) -> Real {
    return select(v, Real(0.0), params.n_lanes == 0u);
}

// Counter addition that sticks at u32::MAX instead of wrapping (CPU counters are u64).
fn sat_add(a: u32, b: u32) -> u32 {
    let s = a + b;
    return select(s, 0xffffffffu, s < a);
}

// ---- forcing.rs ---------------------------------------------------------------------

// (cos(2 pi turns), sin(2 pi turns)) from + - * and floor only. Horner in a^2 from the
// highest term, the loop of forcing.rs unrolled: SIN_Cn = (-1)^n / (2n+1)!,
// COS_Cn = (-1)^n / (2n)!.
fn phasor_turns(turns: Real) -> vec2<Real> {
    let t = turns - floor(turns); // [0, 1)
    let q = floor(t * Real(4.0) + Real(0.5)); // quadrant 0..=4
    let f = t - q * Real(0.25); // [-1/8, 1/8] turns, exact
    let a = f * TAU; // [-pi/4, pi/4]
    let a2 = a * a;
    var s = SIN_C8;
    var c = COS_C8;
    s = SIN_C7 + a2 * s;
    c = COS_C7 + a2 * c;
    s = SIN_C6 + a2 * s;
    c = COS_C6 + a2 * c;
    s = SIN_C5 + a2 * s;
    c = COS_C5 + a2 * c;
    s = SIN_C4 + a2 * s;
    c = COS_C4 + a2 * c;
    s = SIN_C3 + a2 * s;
    c = COS_C3 + a2 * c;
    s = SIN_C2 + a2 * s;
    c = COS_C2 + a2 * c;
    s = SIN_C1 + a2 * s;
    c = COS_C1 + a2 * c;
    s = SIN_C0 + a2 * s;
    c = COS_C0 + a2 * c;
    s = a * s;
    // Quadrant rotation as selects, as in forcing.rs (no divergent branch).
    let quadrant = i32(q) & 3;
    let ab = select(vec2<Real>(c, s), vec2<Real>(s, c), (quadrant & 1) == 1);
    let ra = select(ab.x, -ab.x, quadrant == 1 || quadrant == 2);
    let rb = select(ab.y, -ab.y, quadrant >= 2);
    return vec2<Real>(ra, rb);
}

// ---- model.rs -----------------------------------------------------------------------

fn penetration(delta: Real, x: array<Real, STATE_DIM>) -> Real {
    let dx = x[X_R] - x[X_S];
    let dy = x[Y_R] - x[Y_S];
    return sqrt(dx * dx + dy * dy) - delta;
}

fn contact_force_per_kc(delta: Real, mu: Real, dx: Real, dy: Real) -> vec2<Real> {
    let r = sqrt(dx * dx + dy * dy);
    if r <= Real(0.0) {
        return vec2<Real>(Real(0.0), Real(0.0));
    }
    let s = (r - delta) / r;
    return vec2<Real>(-s * dx + mu * s * dy, -s * dy - mu * s * dx);
}

fn rhs_frozen(
    c: Coeffs,
    x: array<Real, STATE_DIM>,
    cos_phase: Real,
    sin_phase: Real,
    contact: bool,
) -> array<Real, STATE_DIM> {
    var fx = Real(0.0);
    var fy = Real(0.0);
    if contact {
        let kf = contact_force_per_kc(c.delta, c.mu, x[X_R] - x[X_S], x[Y_R] - x[Y_S]);
        fx = kf.x;
        fy = kf.y;
    }
    return array<Real, STATE_DIM>(
        x[VX_R],
        -c.wr2 * x[X_R] - c.dr * x[VX_R] + c.unbalance * cos_phase + c.kc_mr * fx,
        x[VY_R],
        -c.wr2 * x[Y_R] - c.dr * x[VY_R] + c.unbalance * sin_phase - c.a_g + c.kc_mr * fy,
        x[VX_S],
        -c.ws2 * x[X_S] - c.ds * x[VX_S] - c.kc_ms * fx,
        x[VY_S],
        keep(-c.ws2 * x[Y_S] - c.ds * x[VY_S]) - c.a_g - c.kc_ms * fy,
    );
}

// ---- lane.rs ------------------------------------------------------------------------

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

// Looks for the first crossing of g = 0 along the trial sub-step x0 -> x1 (duration hs)
// taken in mode `contact`; see the docs of src/integrate/lane.rs. Between two samples on
// the mode's side, an extremum of g heading to the other side (rates of opposite signs)
// is checked at its estimated location.
fn find_switch(
    lc: LaneConsts,
    x0: array<Real, STATE_DIM>,
    x1: array<Real, STATE_DIM>,
    hs: Real,
    contact: bool,
) -> Switch {
    let delta = lc.c.delta;
    let zero = Real(0.0);
    var lo = zero;
    let gr0 = hermite_gap(delta, x0, x1, hs, zero);
    var g_lo = gr0.x;
    var rate_lo = gr0.y;
    var max_g = g_lo;
    for (var j = 1u; j <= GRAZE_SAMPLES; j++) {
        // j / GRAZE_SAMPLES: the quotient of two small integers is correctly rounded,
        // equal to Rust's f64 quotient rounded to Real.
        let th = Real(j) / Real(GRAZE_SAMPLES);
        let gr_th = hermite_gap(delta, x0, x1, hs, th);
        let g_th = gr_th.x;
        let rate_th = gr_th.y;
        var hi = th;
        var g_hi = g_th;
        var crossing = wrong_side(g_th, contact);
        var toward: bool;
        if contact {
            toward = rate_lo < zero && rate_th > zero;
        } else {
            toward = rate_lo > zero && rate_th < zero;
        }
        if !crossing && toward {
            // Extremum where the linearly interpolated rate vanishes.
            let tp = lo + (th - lo) * rate_lo / (rate_lo - rate_th);
            let g_p = hermite_gap(delta, x0, x1, hs, tp).x;
            if wrong_side(g_p, contact) {
                hi = tp;
                g_hi = g_p;
                crossing = true;
            } else {
                max_g = rmax(max_g, g_p);
            }
        }
        if crossing {
            if wrong_side(g_lo, contact) {
                // Only at the start (j = 1): the lane sits on the switching surface and
                // its mode's flow leaves to the other side; flip now.
                return Switch(lo, max_g);
            }
            // Illinois (modified regula falsi) on [lo, hi]; `a` stays on the mode's
            // side, `b` on the other. Returns `b`.
            var a = lo;
            var ga = g_lo;
            var b = hi;
            var gb = g_hi;
            var last_kept_a = false;
            var last_kept_b = false;
            for (var it = 0u; it < ROOT_MAX_ITERS; it++) {
                if b - a <= lc.root_tol {
                    break;
                }
                var m = b - gb * (b - a) / (gb - ga);
                if !(m > a && m < b) {
                    m = Real(0.5) * (a + b);
                }
                let gm = hermite_gap(delta, x0, x1, hs, m).x;
                if wrong_side(gm, contact) {
                    b = m;
                    gb = gm;
                    if last_kept_a {
                        ga = Real(0.5) * ga;
                    }
                    last_kept_a = true;
                    last_kept_b = false;
                } else {
                    a = m;
                    ga = gm;
                    max_g = rmax(max_g, gm);
                    if last_kept_b {
                        gb = Real(0.5) * gb;
                    }
                    last_kept_b = true;
                    last_kept_a = false;
                }
            }
            return Switch(b, max_g);
        }
        max_g = rmax(max_g, g_th);
        lo = th;
        g_lo = g_th;
        rate_lo = rate_th;
    }
    return Switch(Real(2.0), max_g);
}

// Advances the lane by one macro step (1/N of a forcing period). Frozen lanes do not
// move. Keep in sync with `macro_step` in src/integrate/lane.rs.
fn macro_step(lc: LaneConsts, lane: ptr<function, Lane>) {
    if is_frozen((*lane).status) {
        return;
    }
    let one = Real(1.0);
    let k = (*lane).k;
    var x = (*lane).x;
    var contact = (*lane).contact != 0u;
    var touched = contact;
    var s = Real(0.0);
    var done = false;
    var substeps = 0u;
    var switches = 0u;
    // The CPU starts from -inf; WGSL has no infinite literal. -REAL_MAX gives the same
    // result: the first `rmax` below replaces it by any finite g, and a NaN g freezes
    // the lane before max_g is used.
    var max_g = -REAL_MAX;
    for (var seg = 0u; seg < lc.max_segments; seg++) {
        let ds = one - s;
        let x1 = rk4_substep(lc, x, k, s, ds, contact);
        substeps += 1u;
        let sw = find_switch(lc, x, x1, ds * lc.h, contact);
        max_g = rmax(max_g, sw.max_g);
        if sw.theta > one {
            x = x1;
            done = true;
            break;
        }
        if sw.theta >= one {
            x = x1;
            s = one;
        } else if sw.theta > Real(0.0) {
            x = rk4_substep(lc, x, k, s, ds * sw.theta, contact);
            substeps += 1u;
            s += ds * sw.theta;
        }
        contact = !contact;
        touched = true;
        switches += 1u;
        if s >= one {
            done = true;
            break;
        }
    }
    if !done {
        // Refinement cap: finish the step in the current mode and say so.
        x = rk4_substep(lc, x, k, s, one - s, contact);
        substeps += 1u;
        contact = penetration(lc.c.delta, x) > Real(0.0);
        if (*lane).status < STATUS_REFINEMENT_CAP {
            (*lane).status = STATUS_REFINEMENT_CAP;
        }
    }
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
    (*lane).contact = select(0u, 1u, contact);
    (*lane).k = select(k + 1u, 0u, k + 1u == lc.n);
    (*lane).counters.macro_steps = sat_add((*lane).counters.macro_steps, 1u);
    (*lane).counters.contact_steps = sat_add(
        (*lane).counters.contact_steps,
        select(0u, 1u, touched),
    );
    (*lane).counters.switches = sat_add((*lane).counters.switches, switches);
    (*lane).counters.extra_substeps = sat_add((*lane).counters.extra_substeps, substeps - 1u);
    if touched {
        (*lane).counters.max_penetration = rmax((*lane).counters.max_penetration, max_g);
    }
}

// `advance_period` of lane.rs (N macro steps) has no counterpart here: the entry point
// below runs the same N macro steps per period, but one at a time so that it can stop
// and resume between any two of them.

// ---- entry point --------------------------------------------------------------------

// True when this invocation may still run loops. Mesa's llvmpipe (lavapipe) ends every
// loop of an invocation once the loops together have iterated 65535 times
// (LP_MAX_TGSI_LOOP_ITERATIONS, shared by all loops of a shader) and carries on after
// them as if they had finished, which would corrupt a macro step silently. This loop
// runs `params.probe` (= 2) times unless that limit has been reached, so a failed probe
// right after a macro step says the step may be corrupt.
fn loop_budget_left() -> bool {
    var n = 0u;
    for (var q = 0u; q < params.probe; q++) {
        n += 1u;
    }
    return n == params.probe;
}

// Writes the Poincare point of global period `period` (the state at its end) if it is
// recorded. Straight-line stores: no loop, so no loop-limit check can cut a record.
fn record(period: u32, i: u32, x: array<Real, STATE_DIM>) {
    if period < params.record_from {
        return;
    }
    let base = ((period - params.period_begin) * params.n_lanes + i) * STATE_DIM;
    records[base + X_R] = x[X_R];
    records[base + VX_R] = x[VX_R];
    records[base + Y_R] = x[Y_R];
    records[base + VY_R] = x[VY_R];
    records[base + X_S] = x[X_S];
    records[base + VX_S] = x[VX_S];
    records[base + Y_S] = x[Y_S];
    records[base + VY_S] = x[VY_S];
}

// One time slice: every lane of the chunk goes from the period it has completed
// (`Lane.period`) to `params.period_end`, the state in registers (`lane`) throughout,
// one macro step at a time, each committed only when the loop budget held (see
// `loop_budget_left`). The Poincare point is written at the end of each recorded
// period; a frozen lane (or one with N = 0) records its frozen state for each remaining
// period, as the CPU's `advance_period` loop does. A lane that could not finish counts
// itself in `unfinished`, and the host dispatches the slice again: the lane resumes at
// its last committed macro step, so the result does not depend on where it stopped.
@compute @workgroup_size(WORKGROUP_SIZE)
fn advance_lanes(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= params.n_lanes {
        return;
    }
    let lc = consts[i];
    var lane = lanes[i];
    var committed = false;
    loop {
        if lane.period >= params.period_end {
            break;
        }
        if is_frozen(lane.status) || lc.n == 0u {
            record(lane.period, i, lane.x);
            lane.period += 1u;
            committed = true;
            continue;
        }
        var next = lane;
        macro_step(lc, &next);
        if !loop_budget_left() {
            break;
        }
        lane = next;
        committed = true;
        if lane.k == 0u && !is_frozen(lane.status) {
            record(lane.period, i, lane.x);
            lane.period += 1u;
        }
    }
    lanes[i] = lane;
    if lane.period < params.period_end {
        atomicAdd(&unfinished[0], 1u);
        if !committed {
            atomicAdd(&unfinished[1], 1u);
        }
    }
}
