// The lane kernel, part 3 of 8 (see integrate/lane_buffers.wgsl for the whole): the
// contact force and the right-hand side. Keep in sync with model.rs, beside this file:
// the functions below are relative_motion, penetration, contact_force_per_kc, pow_half,
// contact_force_per_kc_law, contact_force_lane, contact_partials, contact_block,
// contact_partials_law_off_centre and rhs_frozen of model.rs, in the same order, doing
// the same arithmetic in the same order (contact_law, Coeffs::contact_law there, and
// y_coeffs are the kernel's own).

// (dx, dy, dvx, dvy): the rotor's displacement and velocity relative to the stator.
fn relative_motion(x: array<Real, STATE_DIM>) -> vec4<Real> {
    return vec4<Real>(x[X_R] - x[X_S], x[Y_R] - x[Y_S], x[VX_R] - x[VX_S], x[VY_R] - x[VY_S]);
}

fn penetration(delta: Real, x: array<Real, STATE_DIM>) -> Real {
    let m = relative_motion(x);
    return sqrt_rn(m.x * m.x + m.y * m.y) - delta;
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
    let r = sqrt_rn(r2);
    if r <= Real(0.0) {
        return vec2<Real>(Real(0.0), Real(0.0));
    }
    let s = div_rn(r - delta, r);
    let nrm = s + tau_c * div_rn(dx * dvx + dy * dvy, r2);
    return vec2<Real>(-nrm * dx + mu * s * dy, -nrm * dy - mu * s * dx);
}

// a^m for a contact law's m = n - 1 in {0, 1/2, 1, 3/2, 2}: products and one sqrt_rn,
// each correctly rounded, so the CPU's bits (WGSL has no f64 pow).
fn pow_half(a: Real, m: Real) -> Real {
    // The whole part k of m from comparisons, as on the CPU (where floor is slow).
    var k = Real(0.0);
    var whole = Real(1.0);
    if m >= Real(2.0) {
        k = Real(2.0);
        whole = a * a;
    } else if m >= Real(1.0) {
        k = Real(1.0);
        whole = a;
    }
    if m != k {
        whole = whole * sqrt_rn(a);
    }
    return whole;
}

// The lane's contact is a power law or has Hunt-Crossley damping (model.rs'
// Coeffs::contact_law): decided per lane, so it takes the CPU's law whatever the others.
fn contact_law(c: Coeffs) -> bool {
    return c.n_c != Real(1.0) || c.hc != Real(0.0);
}

// The general law: normal force k_c P(g) (1 + hc dg/dt) + c_c dg/dt, P = g |g|^(n-1).
fn contact_force_per_kc_law(c: Coeffs, dx: Real, dy: Real, dvx: Real, dvy: Real) -> vec2<Real> {
    let r2 = dx * dx + dy * dy;
    let r = sqrt_rn(r2);
    if r <= Real(0.0) {
        return vec2<Real>(Real(0.0), Real(0.0));
    }
    let inv_r = div_rn(Real(1.0), r);
    let g = r - c.delta;
    let s = g * pow_half(abs(g), c.n_c - Real(1.0)) * inv_r;
    let rate = (dx * dvx + dy * dvy) * inv_r;
    let nrm = s + c.hc * s * rate + c.tau_c * (rate * inv_r);
    return vec2<Real>(-nrm * dx + c.mu * s * dy, -nrm * dy - c.mu * s * dx);
}

// The force of the lane's own law. With CONTACT_LAW (a kernel constant: some lane's
// contact is not the linear spring) as model.rs' contact_force_lane; without it only the
// linear spring is in the kernel.
fn contact_force_lane(c: Coeffs, dx: Real, dy: Real, dvx: Real, dvy: Real) -> vec2<Real> {
    // Nested: without CONTACT_LAW the lane's law is not even looked at.
    if CONTACT_LAW {
        if contact_law(c) {
            return contact_force_per_kc_law(c, dx, dy, dvx, dvy);
        }
    }
    return contact_force_per_kc(c.delta, c.mu, c.tau_c, dx, dy, dvx, dvy);
}

// d(fx, fy)/d(dx, dy, dvx, dvy) of contact_force_per_kc, as model::contact_partials:
// [fx_dx, fx_dy, fx_dvx, fx_dvy] in .a and [fy_dx, fy_dy, fy_dvx, fy_dvy] in .b.
struct Partials {
    a: vec4<Real>,
    b: vec4<Real>,
}

fn contact_partials(c: Coeffs, x: array<Real, STATE_DIM>) -> Partials {
    let m = relative_motion(x);
    let dx = m.x;
    let dy = m.y;
    let dvx = m.z;
    let dvy = m.w;
    let r2 = dx * dx + dy * dy;
    let r = sqrt_rn(r2);
    let z = Real(0.0);
    if r <= z {
        return Partials(vec4<Real>(z, z, z, z), vec4<Real>(z, z, z, z));
    }
    if CONTACT_LAW {
        if contact_law(c) {
            return contact_partials_law_off_centre(c, m);
        }
    }
    let s = div_rn(r - c.delta, r);
    let q = div_rn(dx * dvx + dy * dvy, r2);
    let nrm = s + c.tau_c * q;
    let r3 = r2 * r;
    let sx = div_rn(c.delta * dx, r3);
    let sy = div_rn(c.delta * dy, r3);
    let two = Real(2.0);
    let nx = sx + div_rn(c.tau_c * (dvx - two * q * dx), r2);
    let ny = sy + div_rn(c.tau_c * (dvy - two * q * dy), r2);
    let nvx = div_rn(c.tau_c * dx, r2);
    let nvy = div_rn(c.tau_c * dy, r2);
    return contact_block(dx, dy, c.mu, NormalPartials(s, nrm, sx, sy, nx, ny, nvx, nvy));
}

// The normal force per k_c and r, its spring part and their partials, and the contact
// block they give for any law (model.rs' NormalPartials and contact_block).
struct NormalPartials {
    s: Real,
    nrm: Real,
    sx: Real,
    sy: Real,
    nx: Real,
    ny: Real,
    nvx: Real,
    nvy: Real,
}

fn contact_block(dx: Real, dy: Real, mu: Real, n: NormalPartials) -> Partials {
    let s = n.s;
    let nrm = n.nrm;
    let sx = n.sx;
    let sy = n.sy;
    let nx = n.nx;
    let ny = n.ny;
    let nvx = n.nvx;
    let nvy = n.nvy;
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

// contact_partials of the general law (model.rs' contact_partials_law_off_centre).
fn contact_partials_law_off_centre(c: Coeffs, m: vec4<Real>) -> Partials {
    let dx = m.x;
    let dy = m.y;
    let dvx = m.z;
    let dvy = m.w;
    let one = Real(1.0);
    let r2 = dx * dx + dy * dy;
    let r = sqrt_rn(r2);
    let g = r - c.delta;
    let a = pow_half(abs(g), c.n_c - one);
    let s = div_rn(g * a, r);
    let dv = dx * dvx + dy * dvy;
    let q = div_rn(dv, r2);
    let gd = div_rn(dv, r);
    let nrm = s + c.hc * s * gd + c.tau_c * q;
    let r3 = r2 * r;
    let num = a * ((c.n_c - one) * r + c.delta);
    let sx = div_rn(num * dx, r3);
    let sy = div_rn(num * dy, r3);
    let gx = div_rn(dvx - q * dx, r);
    let gy = div_rn(dvy - q * dy, r);
    let two = Real(2.0);
    let nx = sx + c.hc * (sx * gd + s * gx) + div_rn(c.tau_c * (dvx - two * q * dx), r2);
    let ny = sy + c.hc * (sy * gd + s * gy) + div_rn(c.tau_c * (dvy - two * q * dy), r2);
    let nvx = div_rn(c.hc * s * dx, r) + div_rn(c.tau_c * dx, r2);
    let nvy = div_rn(c.hc * s * dy, r) + div_rn(c.tau_c * dy, r2);
    return contact_block(dx, dy, c.mu, NormalPartials(s, nrm, sx, sy, nx, ny, nvx, nvy));
}

// The y coefficients of the supports: with ANISOTROPIC (a kernel constant: some lane's
// supports differ by direction) each lane's own; without it the x ones, which are the
// same bits for an isotropic lane (model.rs' Coeffs), so they are not read at all.
struct YCoeffs {
    wr2: Real,
    dr: Real,
    ws2: Real,
    ds: Real,
}

fn y_coeffs(c: Coeffs) -> YCoeffs {
    if ANISOTROPIC {
        return YCoeffs(c.wr2y, c.dry, c.ws2y, c.dsy);
    }
    return YCoeffs(c.wr2x, c.drx, c.ws2x, c.dsx);
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
        let m = relative_motion(x);
        let kf = contact_force_lane(c, m.x, m.y, m.z, m.w);
        fx = kf.x;
        fy = kf.y;
    }
    // With STATOR_OFFSET (a kernel constant: some lane's stator is off the axis) the
    // springs pull towards (ox, oy); without it the subtraction of a zero centre is not
    // in the kernel (model.rs' rhs_with_force's OFFSET: the same bits).
    var xs = x[X_S];
    var ys = x[Y_S];
    if STATOR_OFFSET {
        xs = x[X_S] - c.ox;
        ys = x[Y_S] - c.oy;
    }
    let cy = y_coeffs(c);
    return array<Real, STATE_DIM>(
        x[VX_R],
        -c.wr2x * x[X_R] - c.drx * x[VX_R] + c.unbalance * cos_phase + c.kc_mr * fx,
        x[VY_R],
        -cy.wr2 * x[Y_R] - cy.dr * x[VY_R] + c.unbalance * sin_phase - c.a_g + c.kc_mr * fy,
        x[VX_S],
        -c.ws2x * xs - c.dsx * x[VX_S] - c.kc_ms * fx,
        x[VY_S],
        keep(-cy.ws2 * ys - cy.ds * x[VY_S]) - c.a_g - c.kc_ms * fy,
    );
}
