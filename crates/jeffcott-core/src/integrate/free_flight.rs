//! Exact free flight (`--exact-free-flight`): between contacts the model is
//! four uncoupled damped oscillators (docs/model.md 2 with f = 0), the rotor's forced by the
//! unbalance at the rotor speed and both by gravity, so a macro step spent wholly in
//! free flight has an exact flow map: per oscillator the particular (steady forced)
//! solution, and a 2x2 transition of the homogeneous rest over h.
//!
//! For q'' + c q' + w^2 q = F + A cos(th) + B sin(th), th = W t - phi0:
//!   q_p = F / w^2 + P cos th + Q sin th, v_p = W (Q cos th - P sin th),
//!   (w^2 - W^2) P + c W Q = A, -c W P + (w^2 - W^2) Q = B;
//! e = q - q_p evolves as e(h) = exp(-a h) [(C + a/wd S) e0 + S/wd e0'],
//! e'(h) = exp(-a h) [-w^2/wd S e0 + (C - a/wd S) e0'], a = c/2, wd = sqrt(w^2 - a^2),
//! C = cos(wd h), S = sin(wd h) (underdamped; otherwise no exact map is built).

use crate::integrate::lane::{LaneConsts, forcing_phasor};
use crate::integrate::tangent::{Tangent, jacobian_trace};
use crate::model::{Params, STATE_DIM};
use crate::real::Real;

/// The exact free-flight map of one lane's macro step. `#[repr(C)]`, every field `R`:
/// the GPU lane constants carry it as it is (WGSL `FreeFlight`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ExactFreeFlight<R> {
    /// Per oscillator j (x_r, y_r, x_s, y_s), entries 4j..4j+4: the transition
    /// [q<-q, q<-v, v<-q, v<-v].
    pub phi: [R; 16],
    /// Per oscillator: its rest, o + F / w^2 (o the stator's offset, 0 for the rotor).
    pub off: [R; 4],
    /// Per oscillator: P (the cosine part of the forced response).
    pub p: [R; 4],
    /// Per oscillator: Q (the sine part).
    pub q: [R; 4],
    /// The rotor speed W.
    pub omega: R,
}

// SAFETY: `#[repr(C)]` with every field an array of `R` or `R`: the size of `[R; 29]`,
// no padding, every bit pattern valid when `R: Pod`, all-zero `R`s when zeroed.
unsafe impl<R: bytemuck::Zeroable> bytemuck::Zeroable for ExactFreeFlight<R> {}
// SAFETY: as above.
unsafe impl<R: bytemuck::Pod> bytemuck::Pod for ExactFreeFlight<R> {}

impl<R: Real> ExactFreeFlight<R> {
    /// The map for parameters `p` at speed `omega` and N macro steps per period, in f64
    /// and rounded once; `None` (the lane takes RK4) when an oscillator is not
    /// underdamped, or is undamped and forced exactly at its resonance (no steady
    /// response), or anything comes out non-finite.
    pub fn new(p: &Params, omega: f64, n: u32) -> Option<Self> {
        let h = std::f64::consts::TAU / omega / n as f64;
        let u = p.e * omega * omega;
        // (w^2, c, F, A, B, rest centre) per oscillator, each direction its own
        // support (docs/model.md 7), the stator's springs about its offset centre.
        let ((wrx, wry), (xrx, xry)) = (p.omega_r_xy(), p.xi_r_xy());
        let ((wsx, wsy), (xsx, xsy)) = (p.omega_s_xy(), p.xi_s_xy());
        let osc = [
            (wrx * wrx, 2.0 * xrx * wrx, 0.0, u, 0.0, 0.0),
            (wry * wry, 2.0 * xry * wry, -p.a_g, 0.0, u, 0.0),
            (wsx * wsx, 2.0 * xsx * wsx, 0.0, 0.0, 0.0, p.o_x),
            (wsy * wsy, 2.0 * xsy * wsy, -p.a_g, 0.0, 0.0, p.o_y),
        ];
        let zero = R::lit(0.0);
        let mut m = ExactFreeFlight {
            phi: [zero; 16],
            off: [zero; 4],
            p: [zero; 4],
            q: [zero; 4],
            omega: R::lit(omega),
        };
        for (j, &(w2, c, f, a_, b_, o)) in osc.iter().enumerate() {
            let a = c / 2.0;
            // Underdamped only (also refuses NaN parameters).
            if w2.partial_cmp(&(a * a)) != Some(std::cmp::Ordering::Greater) {
                return None;
            }
            let wd = (w2 - a * a).sqrt();
            let (e, cs, sn) = ((-a * h).exp(), (wd * h).cos(), (wd * h).sin());
            let t = [
                e * (cs + a / wd * sn),
                e * sn / wd,
                -e * w2 / wd * sn,
                e * (cs - a / wd * sn),
            ];
            for (i, v) in t.iter().enumerate() {
                m.phi[4 * j + i] = R::lit(*v);
            }
            let (aa, bb) = (w2 - omega * omega, c * omega);
            let det = aa * aa + bb * bb;
            if det.partial_cmp(&0.0) != Some(std::cmp::Ordering::Greater) {
                return None;
            }
            // o + F / w^2 is F / w^2 itself for a centred stator.
            m.off[j] = R::lit(o + f / w2);
            m.p[j] = R::lit((aa * a_ - bb * b_) / det);
            m.q[j] = R::lit((bb * a_ + aa * b_) / det);
        }
        let finite = |v: &[R]| v.iter().all(|x| x.is_finite());
        (finite(&m.phi) && finite(&m.off) && finite(&m.p) && finite(&m.q)).then_some(m)
    }
}

/// The state after macro step `k` of a lane in free flight throughout, from `x`, by the
/// map `ex` of the lane with constants `lc`. Keep in sync with `free_flight_step` in
/// `integrate/free_flight.wgsl`.
#[inline(always)]
pub fn free_flight_step<R: Real>(
    ex: &ExactFreeFlight<R>,
    lc: &LaneConsts<R>,
    x: &[R; STATE_DIM],
    k: u32,
) -> [R; STATE_DIM] {
    let (c0, s0) = forcing_phasor(lc, k, R::lit(0.0));
    let (c1, s1) = forcing_phasor(lc, k, R::lit(1.0));
    let mut out = [R::lit(0.0); STATE_DIM];
    for j in 0..4 {
        let (qi, vi) = (2 * j, 2 * j + 1);
        let (p, q) = (ex.p[j], ex.q[j]);
        let qp0 = ex.off[j] + p * c0 + q * s0;
        let vp0 = ex.omega * (q * c0 - p * s0);
        let (e, ev) = (x[qi] - qp0, x[vi] - vp0);
        let f = &ex.phi[4 * j..4 * j + 4];
        let (e1, ev1) = (f[0] * e + f[1] * ev, f[2] * e + f[3] * ev);
        out[qi] = e1 + (ex.off[j] + p * c1 + q * s1);
        out[vi] = ev1 + ex.omega * (q * c1 - p * s1);
    }
    out
}

/// The tangent vectors over the same step: the map's derivative, which is its
/// transition (the forced part does not depend on the state), and the trace integral
/// of the free-flight Jacobian (a constant) over h. Keep in sync with
/// `free_flight_tangent` in `integrate/free_flight.wgsl` (which has no trace integral).
#[inline(always)]
pub fn free_flight_tangent<R: Real, const M: usize>(
    ex: &ExactFreeFlight<R>,
    lc: &LaneConsts<R>,
    tan: &mut Tangent<R, M>,
) {
    for v in tan.v.iter_mut() {
        for j in 0..4 {
            let (qi, vi) = (2 * j, 2 * j + 1);
            let f = &ex.phi[4 * j..4 * j + 4];
            let (a, b) = (v[qi], v[vi]);
            v[qi] = f[0] * a + f[1] * b;
            v[vi] = f[2] * a + f[3] * b;
        }
    }
    if M > 0 {
        let free = [R::lit(0.0); 8];
        tan.trace_integral += lc.h.to_f64() * jacobian_trace(&lc.c, &free).to_f64();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::integrate::lane::{StepperConfig, rk4_substep};
    use crate::integrate::tangent::rk4_tangent_substep;

    /// Start states in free flight (well inside the gap), thrown about in every
    /// coordinate.
    fn starts() -> Vec<[f64; STATE_DIM]> {
        (0..24)
            .map(|i| {
                let u = |j: usize| ((i * 7 + j * 13) % 17) as f64 / 8.0 - 1.0;
                [
                    2e-4 * u(0),
                    0.05 * u(1),
                    2e-4 * u(2) - 1e-4,
                    0.05 * u(3),
                    1e-4 * u(4),
                    0.02 * u(5),
                    1e-4 * u(6),
                    0.02 * u(7),
                ]
            })
            .collect()
    }

    /// The exact map against RK4 taken with 2000 sub-steps over the same macro step
    /// (RK4's error there ~(h/2000)^4, far below rounding): they agree to rounding, at
    /// several macro steps of the period (the forcing's phase), speeds and N; and the
    /// map's tangent (its transition) agrees with RK4's tangent step likewise.
    #[test]
    fn the_exact_free_flight_map_is_the_converged_rk4_flow_and_its_derivative() {
        let p = Params::default();
        for (omega, n) in [(133.0, 350), (100.0, 64), (150.0, 1000)] {
            let cfg = StepperConfig {
                steps_per_period: n,
                exact_free_flight: true,
                ..Default::default()
            };
            let lc = LaneConsts::<f64>::new(&p, omega, &cfg);
            let ex = lc.exact.expect("the article's parameters are underdamped");
            let sub = 2000;
            for (i, x0) in starts().iter().enumerate() {
                let k = (i as u32 * 37) % n;
                let exact = free_flight_step(&ex, &lc, x0, k);
                let mut x = *x0;
                let mut tan =
                    Tangent::<f64, 2>::new([[1.0, 0.0, -0.5, 0.0, 0.3, 0.0, 0.0, 1.0]; 2]);
                tan.v[1] = [0.0, 1.0, 0.0, 0.2, 0.0, -1.0, 0.7, 0.0];
                let mut mapped = tan;
                for j in 0..sub {
                    let s0 = j as f64 / sub as f64;
                    rk4_tangent_substep(&lc, &x, k, s0, 1.0 / sub as f64, false, &mut tan);
                    x = rk4_substep(&lc, &x, k, s0, 1.0 / sub as f64, false);
                }
                for d in 0..STATE_DIM {
                    let scale = if d % 2 == 0 { 1e-4 } else { 1e-1 };
                    assert!(
                        (exact[d] - x[d]).abs() <= 1e-12 * scale,
                        "W {omega} N {n} start {i} coordinate {d}: exact {:e}, RK4 {:e}",
                        exact[d],
                        x[d]
                    );
                }
                free_flight_tangent(&ex, &lc, &mut mapped);
                for m in 0..2 {
                    for d in 0..STATE_DIM {
                        assert!(
                            (mapped.v[m][d] - tan.v[m][d]).abs() <= 1e-11,
                            "W {omega} N {n} tangent {m} coordinate {d}: {:e} against {:e}",
                            mapped.v[m][d],
                            tan.v[m][d]
                        );
                    }
                }
                let rel =
                    (mapped.trace_integral - tan.trace_integral).abs() / tan.trace_integral.abs();
                assert!(rel <= 1e-12, "trace integral {rel:e} off");
            }
        }
    }
}
