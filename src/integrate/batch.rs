//! The lane stepper for a batch of `BATCH` lanes at once, laid out structure-of-arrays
//! so the compiler vectorises across lanes (SIMD): the CPU mirror of what a GPU
//! subgroup does.
//!
//! Only the common case is batched: a macro step whose trial RK4 step has no contact
//! switch (about 98% of the steps at W = 133, `jeffcott bench`). Each lane's trial
//! step and switch search run here with exactly the operations, in exactly the order,
//! of `lane::rk4_substep` and `lane::find_switch` (Rust never fuses or reorders
//! floating-point operations, so vectorising does not change a bit). A lane whose trial
//! step finds a crossing, or a grazing extremum to check, is handed back to the scalar
//! `lane::macro_step` from its unchanged start state, which redoes the trial step
//! bit for bit and then refines. So a batched run equals the scalar run to the bit
//! (tests/ensemble_cpu.rs), and the scalar stepper stays the one definition of the
//! algorithm that the WGSL kernel mirrors.

use crate::integrate::forcing::phasor_turns;
use crate::integrate::lane::{
    GRAZE_SAMPLES, Lane, LaneConsts, Status, Tangent, hermite_gap, macro_step_tangent,
    rk4_tangent_substep, wrong_side,
};
use crate::model::{STATE_DIM, VX_R, VX_S, VY_R, VY_S, X_R, X_S, Y_R, Y_S, contact_force_per_kc};
use crate::real::Real;

/// Lanes per batch: 8 fills a 256-bit register with f32 and two with f64.
pub const BATCH: usize = 8;

/// One value per lane of a batch.
type V<R> = [R; BATCH];

/// Builds a per-lane array from a function of the lane index.
#[inline(always)]
fn lanes<R: Copy>(f: impl FnMut(usize) -> R) -> [R; BATCH] {
    std::array::from_fn(f)
}

/// The lane constants of a batch, structure-of-arrays.
#[derive(Clone, Copy, Debug)]
pub struct BatchConsts<R> {
    wr2: V<R>,
    dr: V<R>,
    ws2: V<R>,
    ds: V<R>,
    unbalance: V<R>,
    a_g: V<R>,
    kc_mr: V<R>,
    kc_ms: V<R>,
    mu: V<R>,
    delta: V<R>,
    tau_c: V<R>,
    h: V<R>,
    inv_n: V<R>,
    phase0: V<R>,
}

impl<R: Real> BatchConsts<R> {
    /// Transposes the constants of `BATCH` lanes.
    pub fn new(lc: &[LaneConsts<R>; BATCH]) -> Self {
        BatchConsts {
            wr2: lanes(|l| lc[l].c.wr2),
            dr: lanes(|l| lc[l].c.dr),
            ws2: lanes(|l| lc[l].c.ws2),
            ds: lanes(|l| lc[l].c.ds),
            unbalance: lanes(|l| lc[l].c.unbalance),
            a_g: lanes(|l| lc[l].c.a_g),
            kc_mr: lanes(|l| lc[l].c.kc_mr),
            kc_ms: lanes(|l| lc[l].c.kc_ms),
            mu: lanes(|l| lc[l].c.mu),
            delta: lanes(|l| lc[l].c.delta),
            tau_c: lanes(|l| lc[l].c.tau_c),
            h: lanes(|l| lc[l].h),
            inv_n: lanes(|l| lc[l].inv_n),
            phase0: lanes(|l| lc[l].phase0),
        }
    }
}

/// `lane::forcing_phasor` for every lane at fraction `sigma` of macro step `k`.
#[inline(always)]
fn phasor<R: Real>(bc: &BatchConsts<R>, k: u32, sigma: R) -> (V<R>, V<R>) {
    let mut c = [R::lit(0.0); BATCH];
    let mut s = [R::lit(0.0); BATCH];
    for l in 0..BATCH {
        (c[l], s[l]) = phasor_turns((R::lit(k as f64) + sigma) * bc.inv_n[l] - bc.phase0[l]);
    }
    (c, s)
}

/// `model::rhs_frozen` for every lane (contact mode per lane).
#[inline(always)]
fn rhs<R: Real>(
    bc: &BatchConsts<R>,
    x: &[V<R>; STATE_DIM],
    cos_phase: &V<R>,
    sin_phase: &V<R>,
    contact: &[bool; BATCH],
) -> [V<R>; STATE_DIM] {
    let mut f = [[R::lit(0.0); BATCH]; STATE_DIM];
    for l in 0..BATCH {
        let (kx, ky) = contact_force_per_kc(
            bc.delta[l],
            bc.mu[l],
            bc.tau_c[l],
            x[X_R][l] - x[X_S][l],
            x[Y_R][l] - x[Y_S][l],
            x[VX_R][l] - x[VX_S][l],
            x[VY_R][l] - x[VY_S][l],
        );
        let (fx, fy) = if contact[l] {
            (kx, ky)
        } else {
            (R::lit(0.0), R::lit(0.0))
        };
        f[X_R][l] = x[VX_R][l];
        f[VX_R][l] = -bc.wr2[l] * x[X_R][l] - bc.dr[l] * x[VX_R][l]
            + bc.unbalance[l] * cos_phase[l]
            + bc.kc_mr[l] * fx;
        f[Y_R][l] = x[VY_R][l];
        f[VY_R][l] = -bc.wr2[l] * x[Y_R][l] - bc.dr[l] * x[VY_R][l]
            + bc.unbalance[l] * sin_phase[l]
            - bc.a_g[l]
            + bc.kc_mr[l] * fy;
        f[X_S][l] = x[VX_S][l];
        f[VX_S][l] = -bc.ws2[l] * x[X_S][l] - bc.ds[l] * x[VX_S][l] - bc.kc_ms[l] * fx;
        f[Y_S][l] = x[VY_S][l];
        f[VY_S][l] = -bc.ws2[l] * x[Y_S][l] - bc.ds[l] * x[VY_S][l] - bc.a_g[l] - bc.kc_ms[l] * fy;
    }
    f
}

/// `x + a * k` per component and lane (the RK4 stage states), with `a = factor * hs`
/// grouped as in `lane::rk4_substep`.
#[inline(always)]
fn stage<R: Real>(
    x: &[V<R>; STATE_DIM],
    factor: R,
    hs: &V<R>,
    k: &[V<R>; STATE_DIM],
) -> [V<R>; STATE_DIM] {
    let mut out = [[R::lit(0.0); BATCH]; STATE_DIM];
    for i in 0..STATE_DIM {
        for l in 0..BATCH {
            out[i][l] = x[i][l] + factor * hs[l] * k[i][l];
        }
    }
    out
}

/// `lane::rk4_substep` over a whole macro step (s0 = 0, ds = 1) for every lane.
#[inline(always)]
fn rk4_step<R: Real>(
    bc: &BatchConsts<R>,
    x: &[V<R>; STATE_DIM],
    k: u32,
    contact: &[bool; BATCH],
) -> [V<R>; STATE_DIM] {
    let (s0, ds) = (R::lit(0.0), R::lit(1.0));
    let half = R::lit(0.5);
    let hs: V<R> = lanes(|l| ds * bc.h[l]);
    let (c0, s0p) = phasor(bc, k, s0);
    let (cm, sm) = phasor(bc, k, s0 + half * ds);
    let (c1, s1) = phasor(bc, k, s0 + ds);
    let k1 = rhs(bc, x, &c0, &s0p, contact);
    let xt = stage(x, half, &hs, &k1);
    let k2 = rhs(bc, &xt, &cm, &sm, contact);
    let xt = stage(x, half, &hs, &k2);
    let k3 = rhs(bc, &xt, &cm, &sm, contact);
    let xt = stage(x, R::lit(1.0), &hs, &k3);
    let k4 = rhs(bc, &xt, &c1, &s1, contact);
    let sixth = R::lit(1.0 / 6.0);
    let mut out = [[R::lit(0.0); BATCH]; STATE_DIM];
    for i in 0..STATE_DIM {
        for l in 0..BATCH {
            out[i][l] = x[i][l]
                + hs[l] * sixth * (k1[i][l] + R::lit(2.0) * (k2[i][l] + k3[i][l]) + k4[i][l]);
        }
    }
    out
}

/// `lane::hermite_gap` at `theta` for every lane (x0 -> x1 over each lane's h).
#[inline(always)]
fn gaps<R: Real>(
    bc: &BatchConsts<R>,
    x0: &[V<R>; STATE_DIM],
    x1: &[V<R>; STATE_DIM],
    theta: R,
) -> (V<R>, V<R>) {
    let mut g = [R::lit(0.0); BATCH];
    let mut rate = [R::lit(0.0); BATCH];
    for l in 0..BATCH {
        let a: [R; STATE_DIM] = std::array::from_fn(|i| x0[i][l]);
        let b: [R; STATE_DIM] = std::array::from_fn(|i| x1[i][l]);
        (g[l], rate[l]) = hermite_gap(bc.delta[l], &a, &b, R::lit(1.0) * bc.h[l], theta);
    }
    (g, rate)
}

/// Advances `BATCH` lanes, all at the same macro-step index, by one macro step: the
/// batched fast path where no lane switches contact, the scalar `macro_step` for the
/// lanes that do (see the module docs). Frozen lanes do not move.
#[inline(always)]
pub fn batch_macro_step<R: Real>(
    bc: &BatchConsts<R>,
    lc: &[LaneConsts<R>; BATCH],
    lane: &mut [Lane<R>; BATCH],
) {
    let mut none: [Tangent<R, 0>; BATCH] = std::array::from_fn(|_| Tangent::new([]));
    batch_macro_step_tangent(bc, lc, lane, &mut none);
}

/// [`batch_macro_step`] carrying `M` tangent vectors per lane, as
/// `lane::macro_step_tangent` does: on the batched path each lane's tangent step is the
/// scalar `rk4_tangent_substep` over the whole macro step from the lane's start state
/// (the call the scalar stepper makes when there is no switch), so the tangents too are
/// bit for bit those of the scalar stepper; switching lanes go to
/// `macro_step_tangent`.
#[inline(always)]
pub fn batch_macro_step_tangent<R: Real, const M: usize>(
    bc: &BatchConsts<R>,
    lc: &[LaneConsts<R>; BATCH],
    lane: &mut [Lane<R>; BATCH],
    tan: &mut [Tangent<R, M>; BATCH],
) {
    // Live lanes advance in lock step (they all start at k = 0); frozen ones keep the
    // index they froze at and are skipped.
    let Some(k) = lane.iter().find(|l| !l.status.is_frozen()).map(|l| l.k) else {
        return;
    };
    let x: [V<R>; STATE_DIM] = std::array::from_fn(|i| lanes(|l| lane[l].x[i]));
    let contact: [bool; BATCH] = lanes(|l| lane[l].contact);
    let x1 = rk4_step(bc, &x, k, &contact);
    // The switch search of `lane::find_switch`, kept only as far as deciding that there
    // is no switch: any sample on the wrong side, or an extremum heading there, sends
    // the lane to the scalar path.
    let zero = R::lit(0.0);
    let (g0, mut rate_lo) = gaps(bc, &x, &x1, zero);
    let mut max_g = g0;
    let mut scalar = [false; BATCH];
    for j in 1..=GRAZE_SAMPLES {
        let th = R::lit(j as f64 / GRAZE_SAMPLES as f64);
        let (g_th, rate_th) = gaps(bc, &x, &x1, th);
        for l in 0..BATCH {
            let toward = if contact[l] {
                rate_lo[l] < zero && rate_th[l] > zero
            } else {
                rate_lo[l] > zero && rate_th[l] < zero
            };
            scalar[l] |= wrong_side(g_th[l], contact[l]) || toward;
            max_g[l] = max_g[l].max(g_th[l]);
        }
        rate_lo = rate_th;
    }
    for l in 0..BATCH {
        if lane[l].status.is_frozen() {
            continue;
        }
        if scalar[l] || lane[l].k != k {
            macro_step_tangent(&lc[l], &mut lane[l], &mut tan[l]);
            continue;
        }
        if M > 0 {
            let x0 = lane[l].x;
            rk4_tangent_substep(
                &lc[l],
                &x0,
                k,
                zero,
                R::lit(1.0) - zero,
                contact[l],
                &mut tan[l],
            );
        }
        // No switch: accept the trial step, then `macro_step`'s checks and counters.
        let xl: [R; STATE_DIM] = std::array::from_fn(|i| x1[i][l]);
        let finite = xl.iter().all(|v| v.is_finite());
        if !finite {
            lane[l].status = Status::NonFinite;
            continue;
        }
        let reach = xl[X_R]
            .abs()
            .max(xl[Y_R].abs())
            .max(xl[X_S].abs())
            .max(xl[Y_S].abs());
        if reach > lc[l].bound {
            lane[l].status = Status::Diverged;
            continue;
        }
        let ln = &mut lane[l];
        ln.x = xl;
        ln.k = if k + 1 == lc[l].n { 0 } else { k + 1 };
        let ct = &mut ln.counters;
        ct.macro_steps += 1;
        ct.contact_steps += contact[l] as u64;
        if contact[l] {
            let m = R::lit(f64::NEG_INFINITY).max(max_g[l]);
            ct.max_penetration = ct.max_penetration.max(m.to_f64());
        }
    }
}
