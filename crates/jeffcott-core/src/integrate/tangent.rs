//! Tangent vectors along a lane (docs/model.md 5 and 6): the variational equations
//! dV/dt = J(x(t)) V advanced by RK4 on the state's own stages in the same frozen
//! contact mode ([`rk4_tangent_substep`]), Mueller's saltation matrix at every located
//! switch ([`saltation`]) and the renormalisation behind lambda_1 ([`renormalise`]).
//! What [`super::lane::macro_step_tangent`] carries; with no tangent vectors it compiles
//! away. `integrate/tangent.wgsl` mirrors this file function by function: keep in sync
//! with it.

use super::lane::LaneConsts;
use super::lane::forcing_phasor;
use crate::model::{
    Coeffs, STATE_DIM, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S, contact_partials, rhs_frozen,
};
use crate::real::{Arith, Real};

/// Tangent vectors carried along a lane, with what the Lyapunov spectrum needs to
/// account for them (docs/model.md 5 and 6). `M = 0` is the plain lane.
#[derive(Clone, Copy, Debug)]
pub struct Tangent<R, const M: usize> {
    /// The tangent vectors, each a state-space direction.
    pub v: [[R; STATE_DIM]; M],
    /// Apply the saltation matrix at switches (`false` only to show what it changes).
    pub saltation: bool,
    /// Integral of the Jacobian's trace along the accepted sub-steps (RK4 quadrature on
    /// the stages) [-].
    pub trace_integral: f64,
    /// Sum of ln|det S| over the saltation matrices applied [-].
    pub saltation_log_det: f64,
    /// Saltation matrices applied (located switches).
    pub saltations: u64,
    /// Largest |S_ij - I_ij| among them (0 when S = I).
    pub max_saltation_deviation: f64,
}

impl<R: Real, const M: usize> Tangent<R, M> {
    /// Tangent vectors `v`, saltation on, accumulators zero.
    pub fn new(v: [[R; STATE_DIM]; M]) -> Self {
        Tangent {
            v,
            saltation: true,
            trace_integral: 0.0,
            saltation_log_det: 0.0,
            saltations: 0,
            max_saltation_deviation: 0.0,
        }
    }
}

/// The contact block of the Jacobian in mode `contact` (zero out of contact).
#[inline(always)]
pub fn stage_partials<R: Real>(c: &Coeffs<R>, x: &[R; STATE_DIM], contact: bool) -> [R; 8] {
    if contact {
        contact_partials(c, x)
    } else {
        [R::lit(0.0); 8]
    }
}

/// J v: the variational right-hand side for one tangent vector, the contact block given.
/// Keep in sync with `tangent_rhs` in `integrate/lane.wgsl`.
#[inline(always)]
pub fn tangent_rhs<T: Arith>(c: &Coeffs<T>, pc: &[T; 8], v: &[T; STATE_DIM]) -> [T; STATE_DIM] {
    let ddx = v[X_R] - v[X_S];
    let ddy = v[Y_R] - v[Y_S];
    let ddvx = v[VX_R] - v[VX_S];
    let ddvy = v[VY_R] - v[VY_S];
    let dfx = pc[0] * ddx + pc[1] * ddy + pc[2] * ddvx + pc[3] * ddvy;
    let dfy = pc[4] * ddx + pc[5] * ddy + pc[6] * ddvx + pc[7] * ddvy;
    [
        v[VX_R],
        -c.wr2x * v[X_R] - c.drx * v[VX_R] + c.kc_mr * dfx,
        v[VY_R],
        -c.wr2y * v[Y_R] - c.dry * v[VY_R] + c.kc_mr * dfy,
        v[VX_S],
        -c.ws2x * v[X_S] - c.dsx * v[VX_S] - c.kc_ms * dfx,
        v[VY_S],
        -c.ws2y * v[Y_S] - c.dsy * v[VY_S] - c.kc_ms * dfy,
    ]
}

/// Trace of the Jacobian given its contact block: only the velocity diagonal counts.
/// The dampings summed in pairs: for an isotropic machine (drx = dry, dsx = dsy) that is
/// -2 (dr + ds) to the bit, as doubling is exact.
#[inline(always)]
pub(crate) fn jacobian_trace<R: Real>(c: &Coeffs<R>, pc: &[R; 8]) -> R {
    -((c.drx + c.dry) + (c.dsx + c.dsy)) + (c.kc_mr + c.kc_ms) * (pc[2] + pc[7])
}

/// Advances the tangent vectors over the sub-step [s0, s0 + ds] of macro step k that
/// `rk4_substep` takes from `x` in mode `contact`: the state stages are recomputed with
/// exactly `rk4_substep`'s operations, and each vector takes the RK4 step of
/// dV/dt = J V on them. Also adds the trace integral over the sub-step.
#[inline(always)]
pub fn rk4_tangent_substep<R: Real, const M: usize>(
    lc: &LaneConsts<R>,
    x: &[R; STATE_DIM],
    k: u32,
    s0: R,
    ds: R,
    contact: bool,
    tan: &mut Tangent<R, M>,
) {
    let hs = ds * lc.h;
    let half = R::lit(0.5);
    let (c0, s0p) = forcing_phasor(lc, k, s0);
    let (cm, sm) = forcing_phasor(lc, k, s0 + half * ds);
    let k1 = rhs_frozen(&lc.c, x, c0, s0p, contact);
    let p1 = stage_partials(&lc.c, x, contact);
    let mut xt = [R::lit(0.0); STATE_DIM];
    for i in 0..STATE_DIM {
        xt[i] = x[i] + half * hs * k1[i];
    }
    let k2 = rhs_frozen(&lc.c, &xt, cm, sm, contact);
    let p2 = stage_partials(&lc.c, &xt, contact);
    for i in 0..STATE_DIM {
        xt[i] = x[i] + half * hs * k2[i];
    }
    let k3 = rhs_frozen(&lc.c, &xt, cm, sm, contact);
    let p3 = stage_partials(&lc.c, &xt, contact);
    for i in 0..STATE_DIM {
        xt[i] = x[i] + hs * k3[i];
    }
    let p4 = stage_partials(&lc.c, &xt, contact);
    let sixth = R::lit(1.0 / 6.0);
    let two = R::lit(2.0);
    for v in tan.v.iter_mut() {
        let a1 = tangent_rhs(&lc.c, &p1, v);
        let mut vt = [R::lit(0.0); STATE_DIM];
        for i in 0..STATE_DIM {
            vt[i] = v[i] + half * hs * a1[i];
        }
        let a2 = tangent_rhs(&lc.c, &p2, &vt);
        for i in 0..STATE_DIM {
            vt[i] = v[i] + half * hs * a2[i];
        }
        let a3 = tangent_rhs(&lc.c, &p3, &vt);
        for i in 0..STATE_DIM {
            vt[i] = v[i] + hs * a3[i];
        }
        let a4 = tangent_rhs(&lc.c, &p4, &vt);
        for i in 0..STATE_DIM {
            v[i] += hs * sixth * (a1[i] + two * (a2[i] + a3[i]) + a4[i]);
        }
    }
    let tr = |pc: &[R; 8]| jacobian_trace(&lc.c, pc).to_f64();
    tan.trace_integral += hs.to_f64() / 6.0 * (tr(&p1) + 2.0 * (tr(&p2) + tr(&p3)) + tr(&p4));
}

/// Mueller's transition condition at a switch of the contact mode away from `from_contact`
/// at state `x`, fraction `s` of macro step `k`: every tangent vector v becomes S v with
/// S = I + (f+ - f-) n^T / (n^T f-), n = grad g = (d/r, 0, -d/r, 0) over
/// (rotor position, velocity, stator position, velocity), f- and f+ the fields of the
/// old and new modes. Both fields are evaluated at the point of the switching surface
/// g = 0 radially nearest to `x` (the located crossing lies within the search tolerance
/// of it), so that for the model as specified, whose force vanishes at g = 0, f+ = f-
/// to the last bit of the continuation and S = I; with contact damping the force jumps
/// by c_c dg/dt and S != I. Since g depends on positions only and both fields share
/// their position rows (the velocities), n^T f+ = n^T f- and det S = n^T f+ / n^T f- = 1:
/// a force discontinuity shears tangent space without changing its volume. A grazing
/// switch (n^T f- = 0) leaves the vectors alone.
#[inline(always)]
pub fn saltation<R: Real, const M: usize>(
    lc: &LaneConsts<R>,
    x: &[R; STATE_DIM],
    k: u32,
    s: R,
    from_contact: bool,
    tan: &mut Tangent<R, M>,
) {
    let dx = x[X_R] - x[X_S];
    let dy = x[Y_R] - x[Y_S];
    let r = (dx * dx + dy * dy).sqrt();
    if r <= R::lit(0.0) || !r.is_finite() {
        return;
    }
    let scale = lc.c.delta / r;
    let mut xs = *x;
    xs[X_R] = x[X_S] + dx * scale;
    xs[Y_R] = x[Y_S] + dy * scale;
    let (cph, sph) = forcing_phasor(lc, k, s);
    let fm = rhs_frozen(&lc.c, &xs, cph, sph, from_contact);
    let fp = rhs_frozen(&lc.c, &xs, cph, sph, !from_contact);
    let (nx, ny) = (dx / r, dy / r);
    let nf = nx * (fm[X_R] - fm[X_S]) + ny * (fm[Y_R] - fm[Y_S]);
    if nf == R::lit(0.0) || !nf.is_finite() {
        return;
    }
    for v in tan.v.iter_mut() {
        let w = (nx * (v[X_R] - v[X_S]) + ny * (v[Y_R] - v[Y_S])) / nf;
        for i in 0..STATE_DIM {
            v[i] += (fp[i] - fm[i]) * w;
        }
    }
    let nfp = nx * (fp[X_R] - fp[X_S]) + ny * (fp[Y_R] - fp[Y_S]);
    let det = (nfp / nf).to_f64();
    tan.saltation_log_det += det.abs().ln();
    tan.saltations += 1;
    // |n_j| <= 1, so max |S - I| = max_i |f+_i - f-_i| / |n^T f-| * max_j |n_j|.
    let nmax = nx.abs().max(ny.abs()).to_f64();
    for i in 0..STATE_DIM {
        let d = ((fp[i] - fm[i]) / nf).abs().to_f64() * nmax;
        tan.max_saltation_deviation = tan.max_saltation_deviation.max(d);
    }
}

/// Component of the unit tangent vector (1, ..., 1)/sqrt(8) that the ensembles start
/// their lambda_1 tangent from.
pub const LAMBDA1_START: f64 = 0.353_553_390_593_273_8;

/// Renormalises one tangent vector to unit length and returns its length before (the
/// growth since the last renormalisation). A zero or non-finite length leaves the vector
/// alone. Keep in sync with `renormalise` in `integrate/lane.wgsl` (unrolled there).
#[inline(always)]
pub fn renormalise<R: Real>(v: &mut [R; STATE_DIM]) -> R {
    let mut sq = R::lit(0.0);
    for c in v.iter() {
        sq += *c * *c;
    }
    let n = sq.sqrt();
    if n > R::lit(0.0) && n.is_finite() {
        for c in v.iter_mut() {
            *c = *c / n;
        }
    }
    n
}
