// The ensemble lane stepper on the GPU: one invocation advances one lane (one
// trajectory of the rotor-stator system, MODEL.md 4.2) by a time slice of whole forcing
// periods, with the state held in registers for the whole slice.
//
// Keep in sync with lane.rs (and with penetration, contact_force_per_kc
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
//   LYAPUNOV (bool), RECORD_DIM                the pipeline variant (below)
// from the Rust constants. Every non-dyadic floating constant lives in that header as
// an abstract-float literal holding the exact f64 value Rust uses; naga converts it to
// Real with `as f32` semantics, exactly like `Real::lit`. The literals written inline
// below (0.0, 0.25, 0.5, 1.0, 2.0, 3.0, 4.0, 6.0) are exact in both precisions.
//
// Two pipeline variants per precision. With LYAPUNOV = false (the plain kernel) every
// `if LYAPUNOV` block is dead code the compiler removes. With LYAPUNOV = true each lane
// carries one tangent vector (in `tangents`), advanced with the state over every accepted
// sub-step (rk4_tangent_substep), mapped by the saltation matrix at every located
// switch (saltation), and renormalised at the end of every forcing period; its length
// before renormalisation is written after the state in each record (RECORD_DIM = 9)
// and the host sums the logarithms (no f64 `log` on the GPU, DESIGN.md 3).
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
    tau_c: Real,
}

// Constants of one lane (integrate::lane::LaneConsts).
struct LaneConsts {
    c: Coeffs,
    h: Real,
    inv_n: Real,
    phase0: Real,
    bound: Real,
    root_tol: Real,
    // 1/R: the longest sub-step in contact (contact refinement).
    inv_r: Real,
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
// Poincare points of this slice: [slot][lane][RECORD_DIM] (the state, then with
// LYAPUNOV the tangent's growth over the period).
@group(0) @binding(3) var<storage, read_write> records: array<Real>;
// [0]: lanes that did not reach period_end in this dispatch; [1]: those of them that
// could not commit a single macro step (the host zeroes both first).
@group(0) @binding(4) var<storage, read_write> unfinished: array<atomic<u32>, 2>;
// The lambda_1 variant's tangent vector of each lane (one element, untouched, in the
// plain kernel; the host's explicit bind group layout has it in both variants).
@group(0) @binding(5) var<storage, read_write> tangents: array<array<Real, STATE_DIM>>;

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

// `params.probe`, copied once per invocation by `advance_lanes` (see
// `loop_budget_left`): lavapipe reloads a uniform at every use inside a loop, as a
// gather of 8 scalar loads (perf: the probe's bound alone took 5% of a run). `keep`
// reads `params.n_lanes` itself: a private copy would be a known constant in any other
// entry point (tests/gpu.rs has one), and the barrier would vanish there.
var<private> probe_n: u32;

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

fn contact_force_per_kc(
    delta: Real,
    mu: Real,
    tau_c: Real,
    dx: Real,
    dy: Real,
    dvx: Real,
    dvy: Real,
) -> vec2<Real> {
    // r2, not r * r: Mesa's NIR rewrites sqrt(a) * sqrt(a) to a, which rounds
    // differently from the CPU's r * r.
    let r2 = dx * dx + dy * dy;
    let r = sqrt(r2);
    if r <= Real(0.0) {
        return vec2<Real>(Real(0.0), Real(0.0));
    }
    let s = (r - delta) / r;
    let nrm = s + tau_c * ((dx * dvx + dy * dvy) / r2);
    return vec2<Real>(-nrm * dx + mu * s * dy, -nrm * dy - mu * s * dx);
}

// d(fx, fy)/d(dx, dy, dvx, dvy) of contact_force_per_kc, as model::contact_partials:
// [fx_dx, fx_dy, fx_dvx, fx_dvy] in .a and [fy_dx, fy_dy, fy_dvx, fy_dvy] in .b.
struct Partials {
    a: vec4<Real>,
    b: vec4<Real>,
}

fn contact_partials(c: Coeffs, x: array<Real, STATE_DIM>) -> Partials {
    let dx = x[X_R] - x[X_S];
    let dy = x[Y_R] - x[Y_S];
    let dvx = x[VX_R] - x[VX_S];
    let dvy = x[VY_R] - x[VY_S];
    let r2 = dx * dx + dy * dy;
    let r = sqrt(r2);
    let z = Real(0.0);
    if r <= z {
        return Partials(vec4<Real>(z, z, z, z), vec4<Real>(z, z, z, z));
    }
    let s = (r - c.delta) / r;
    let q = (dx * dvx + dy * dvy) / r2;
    let nrm = s + c.tau_c * q;
    let r3 = r2 * r;
    let sx = c.delta * dx / r3;
    let sy = c.delta * dy / r3;
    let two = Real(2.0);
    let nx = sx + c.tau_c * (dvx - two * q * dx) / r2;
    let ny = sy + c.tau_c * (dvy - two * q * dy) / r2;
    let nvx = c.tau_c * dx / r2;
    let nvy = c.tau_c * dy / r2;
    let mu = c.mu;
    return Partials(
        vec4<Real>(
            -nx * dx - nrm + mu * sx * dy,
            -ny * dx + mu * sy * dy + mu * s,
            -nvx * dx,
            -nvy * dx,
        ),
        vec4<Real>(
            -nx * dy - mu * sx * dx - mu * s,
            -ny * dy - nrm - mu * sy * dx,
            -nvx * dy,
            -nvy * dy,
        ),
    );
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
        let kf = contact_force_per_kc(
            c.delta,
            c.mu,
            c.tau_c,
            x[X_R] - x[X_S],
            x[Y_R] - x[Y_S],
            x[VX_R] - x[VX_S],
            x[VY_R] - x[VY_S],
        );
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
    xs[X_R] = x[X_S] + dx * scale;
    xs[Y_R] = x[Y_S] + dy * scale;
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
// below runs the same N macro steps per period, but one at a time so that it can stop
// and resume between any two of them.

// ---- entry point --------------------------------------------------------------------

// True when this invocation may still run loops. Mesa's llvmpipe (lavapipe) ends every
// loop of an invocation once the loops together have iterated 65535 times
// (LP_MAX_TGSI_LOOP_ITERATIONS, shared by all loops of a shader) and carries on after
// them as if they had finished, which would corrupt a macro step silently. This loop
// runs `params.probe` (= 2, in `probe_n`) times unless that limit has been reached, so
// a failed probe right after a macro step says the step may be corrupt.
fn loop_budget_left() -> bool {
    var n = 0u;
    for (var q = 0u; q < probe_n; q++) {
        n += 1u;
    }
    return n == probe_n;
}

// Writes the Poincare point of global period `period` (the state at its end) if it is
// recorded, and with LYAPUNOV the tangent's growth `norm` over the period after it.
// Straight-line stores: no loop, so no loop-limit check can cut a record.
fn record(period: u32, i: u32, x: array<Real, STATE_DIM>, norm: Real) {
    if period < params.record_from {
        return;
    }
    let base = ((period - params.period_begin) * params.n_lanes + i) * RECORD_DIM;
    if LYAPUNOV {
        records[base + STATE_DIM] = norm;
    }
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
// one sub-step of a macro step per iteration (see macro_step), a macro step committed
// only when the loop budget held after each of its sub-steps (see
// `loop_budget_left`). The Poincare point is written at the end of each recorded
// period; a frozen lane (or one with N = 0) records its frozen state for each remaining
// period, as the CPU's `advance_period` loop does. A lane that could not finish counts
// itself in `unfinished`, and the host dispatches the slice again: the lane resumes at
// its last committed macro step, so the result does not depend on where it stopped.
//
// Everything happens inside the one loop, on purpose. lavapipe runs the masked stores
// of `record` at every iteration (about 12% of a run, perf), and an inner loop over a
// period's macro steps with the record after it would run them once per period, but
// when llvmpipe's loop limit ends a loop it leaves without taking any `break`, so a
// value that only a `break` sets (such as "the period is complete") is stale after
// it: tried, and it recorded mid-period states after a cut.
@compute @workgroup_size(WORKGROUP_SIZE)
fn advance_lanes(@builtin(global_invocation_id) gid: vec3<u32>) {
    let i = gid.x;
    if i >= params.n_lanes {
        return;
    }
    probe_n = params.probe;
    let period_end = params.period_end;
    let lc = consts[i];
    var lane = lanes[i];
    var tv: array<Real, STATE_DIM>;
    if LYAPUNOV {
        tv = tangents[i];
    }
    var committed = false;
    // The lane's macro step in progress (`busy`) and its tangent vector.
    var ms = macro_step_begin(lc, lane);
    var busy = false;
    var vw = tv;
    loop {
        if lane.period >= period_end {
            break;
        }
        // One call site of `record` for both cases (its stores would run twice per
        // iteration on lavapipe, which executes both arms of every `if`).
        var recorded = false;
        var norm = Real(1.0);
        if is_frozen(lane.status) || lc.n == 0u {
            recorded = true;
        } else {
            if !busy {
                ms = macro_step_begin(lc, lane);
                vw = tv;
                busy = true;
            }
            macro_step(lc, lane.k, &ms, &vw);
            if !loop_budget_left() {
                break;
            }
            if ms.done {
                var next = lane;
                macro_step_end(lc, &next, ms);
                lane = next;
                tv = vw;
                committed = true;
                busy = false;
                if lane.k == 0u && !is_frozen(lane.status) {
                    if LYAPUNOV {
                        norm = renormalise(&tv);
                    }
                    recorded = true;
                }
            }
        }
        if recorded {
            record(lane.period, i, lane.x, norm);
            lane.period += 1u;
            committed = true;
        }
    }
    lanes[i] = lane;
    if LYAPUNOV {
        tangents[i] = tv;
    }
    if lane.period < period_end {
        atomicAdd(&unfinished[0], 1u);
        if !committed {
            atomicAdd(&unfinished[1], 1u);
        }
    }
}
