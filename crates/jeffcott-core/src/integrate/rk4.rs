//! Classical fourth-order Runge-Kutta on the reference `f64` right-hand side.
//! Used by the article's variable-step scheme and by tests; the ensemble lane has its own
//! copy (`lane::rk4_substep`) because it must mirror the kernel.

use crate::model::STATE_DIM;

/// One RK4 step of size `h` from (t, x) for dx/dt = f(t, x).
pub fn rk4_step<F>(f: &mut F, t: f64, x: &[f64; STATE_DIM], h: f64) -> [f64; STATE_DIM]
where
    F: FnMut(f64, &[f64; STATE_DIM]) -> [f64; STATE_DIM],
{
    let axpy = |a: f64, k: &[f64; STATE_DIM]| {
        let mut y = *x;
        for i in 0..STATE_DIM {
            y[i] += a * k[i];
        }
        y
    };
    let k1 = f(t, x);
    let k2 = f(t + 0.5 * h, &axpy(0.5 * h, &k1));
    let k3 = f(t + 0.5 * h, &axpy(0.5 * h, &k2));
    let k4 = f(t + h, &axpy(h, &k3));
    let mut out = *x;
    for i in 0..STATE_DIM {
        out[i] += h / 6.0 * (k1[i] + 2.0 * (k2[i] + k3[i]) + k4[i]);
    }
    out
}
