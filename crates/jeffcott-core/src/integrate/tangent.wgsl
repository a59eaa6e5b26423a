// The lane kernel, part 4 of 8 (see lane_buffers.wgsl for the whole): tangent vectors
// and saltation.
//
// Keep in sync with tangent.rs, beside this file: the functions below are those of
// tangent.rs, with the same names, in the same order, doing the same arithmetic in the
// same order.

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
    let cy = y_coeffs(c);
    return array<Real, STATE_DIM>(
        v[VX_R],
        -c.wr2x * v[X_R] - c.drx * v[VX_R] + c.kc_mr * dfx,
        v[VY_R],
        -cy.wr2 * v[Y_R] - cy.dr * v[VY_R] + c.kc_mr * dfy,
        v[VX_S],
        -c.ws2x * v[X_S] - c.dsx * v[VX_S] - c.kc_ms * dfx,
        v[VY_S],
        -cy.ws2 * v[Y_S] - cy.ds * v[VY_S] - c.kc_ms * dfy,
    );
}

// Advances the tangent vector over the sub-step that rk4_substep takes from `x` with
// the same arguments: the state stages recomputed with rk4_substep's operations, the
// RK4 step of dv/dt = J v on them. (tangent.rs also integrates the Jacobian's trace here,
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
// in tangent.rs.
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
    let r = sqrt_rn(dx * dx + dy * dy);
    if r <= Real(0.0) || !is_finite(r) {
        return;
    }
    let scale = div_rn(lc.c.delta, r);
    var xs = x;
    // keep: rhs_frozen takes xs[X_R] - xs[X_S], which Mesa's NIR would simplify from
    // (x_s + dx scale) - x_s to dx scale without the rounding of the sum (an inexact
    // rewrite, (a + b) - a -> b), so that f+ - f- and the tangent vector differed from
    // tangent.rs in the last bits (tests/mirror, saltation and macro_step).
    xs[X_R] = keep(x[X_S] + dx * scale);
    xs[Y_R] = keep(x[Y_S] + dy * scale);
    let ph = forcing_phasor(lc, k, s);
    let fm = rhs_frozen(lc.c, xs, ph.x, ph.y, from_contact);
    let fp = rhs_frozen(lc.c, xs, ph.x, ph.y, !from_contact);
    let nx = div_rn(dx, r);
    let ny = div_rn(dy, r);
    let nf = nx * (fm[X_R] - fm[X_S]) + ny * (fm[Y_R] - fm[Y_S]);
    if nf == Real(0.0) || !is_finite(nf) {
        return;
    }
    let w = div_rn(nx * ((*v)[X_R] - (*v)[X_S]) + ny * ((*v)[Y_R] - (*v)[Y_S]), nf);
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
    let n = sqrt_rn(sq);
    if n > Real(0.0) && is_finite(n) {
        (*v)[0] = div_rn((*v)[0], n);
        (*v)[1] = div_rn((*v)[1], n);
        (*v)[2] = div_rn((*v)[2], n);
        (*v)[3] = div_rn((*v)[3], n);
        (*v)[4] = div_rn((*v)[4], n);
        (*v)[5] = div_rn((*v)[5], n);
        (*v)[6] = div_rn((*v)[6], n);
        (*v)[7] = div_rn((*v)[7], n);
    }
    return n;
}
