// The lane kernel, part 3 of 8 (see integrate/lane_buffers.wgsl for the whole): the
// contact force and the right-hand side. Keep in sync with model.rs, beside this file:
// the functions below are relative_motion, penetration, contact_force_per_kc,
// contact_partials and rhs_frozen of model.rs, in the same order, doing the same
// arithmetic in the same order (y_coeffs is the kernel's own).

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
        let kf = contact_force_per_kc(c.delta, c.mu, c.tau_c, m.x, m.y, m.z, m.w);
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
