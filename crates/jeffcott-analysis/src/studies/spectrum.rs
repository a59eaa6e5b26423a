//! Full spectra of orbits: the FFT of the complex displacement z = x + i y over an
//! integer number of forcing periods, Hann-windowed, positive frequencies (forward whirl,
//! in the sense of the unbalance's rotation e^{+i W t}) and negative ones (backward
//! whirl) kept apart, as rotordynamics engineers read them (Goldman and Muszynska, "Rotor
//! dynamic full spectrum", Bently Nevada; docs/rub.md).
//!
//! Amplitudes are calibrated for lines: a component A e^{i k W t / P} on a bin of the
//! P-period record reads A at that bin (the window's coherent gain divided out). A
//! circular forward orbit of radius r at 1X is a single line +1X of amplitude r; an
//! ellipse of half-axes a (x) and b (y) is (a + b)/2 at +1X and (a - b)/2 at -1X.

use jeffcott_core::model::STATE_DIM;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex64;
use serde::{Deserialize, Serialize};

/// A full spectrum: bins in increasing frequency, from -M/2 to M/2 - 1.
#[derive(Clone, Debug, PartialEq)]
pub struct FullSpectrum {
    /// Frequency of each bin as a multiple of the rotor speed W (order; < 0 backward).
    pub order: Vec<f64>,
    /// Frequency of each bin [Hz].
    pub hz: Vec<f64>,
    /// Amplitude of each bin [m] (line-calibrated, see the module docs).
    pub amplitude: Vec<f64>,
}

/// The unnormalised DFT (rustfft's forward transform, X_k = sum_n z_n e^{-2 pi i k n / M}).
pub fn dft(z: &[Complex64]) -> Vec<Complex64> {
    let mut buf = z.to_vec();
    FftPlanner::new()
        .plan_fft_forward(buf.len())
        .process(&mut buf);
    buf
}

/// The periodic Hann window of length m.
pub fn hann(m: usize) -> Vec<f64> {
    (0..m)
        .map(|n| 0.5 * (1.0 - (std::f64::consts::TAU * n as f64 / m as f64).cos()))
        .collect()
}

/// Full spectrum of `z` sampled uniformly over `periods` forcing periods of speed `omega`
/// (`z.len()` samples, a whole number per period).
pub fn full_spectrum(z: &[Complex64], periods: u32, omega: f64) -> FullSpectrum {
    let m = z.len();
    if m == 0 {
        return FullSpectrum {
            order: Vec::new(),
            hz: Vec::new(),
            amplitude: Vec::new(),
        };
    }
    let w = hann(m);
    let gain: f64 = w.iter().sum();
    let x = dft(&z.iter().zip(&w).map(|(v, w)| v * *w).collect::<Vec<_>>());
    let p = periods.max(1) as f64;
    let f1 = omega / std::f64::consts::TAU; // 1X in Hz
    let half = m as i64 / 2;
    let mut s = FullSpectrum {
        order: Vec::with_capacity(m),
        hz: Vec::with_capacity(m),
        amplitude: Vec::with_capacity(m),
    };
    for k in -half..(m as i64 - half) {
        let idx = k.rem_euclid(m as i64) as usize;
        let order = k as f64 / p;
        s.order.push(order);
        s.hz.push(order * f1);
        s.amplitude.push(x[idx].norm() / gain);
    }
    s
}

/// The rotor's (`stator = false`) or stator's complex displacement from time-series rows
/// `(t, state)`; the first row (the start of the record) is left out so that the samples
/// cover whole periods once.
pub fn orbit(rows: &[[f64; STATE_DIM + 1]], stator: bool) -> Vec<Complex64> {
    let (ix, iy) = if stator { (5, 7) } else { (1, 3) };
    rows.iter()
        .skip(1)
        .map(|r| Complex64::new(r[ix], r[iy]))
        .collect()
}

/// Whirl direction of an orbit.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Whirl {
    /// The largest non-static line turns with the unbalance.
    Forward,
    /// The largest non-static line turns against it.
    Backward,
    /// No line above the static one (a resting rotor).
    #[default]
    None,
}

/// Whirl read off a full spectrum: the sign of the largest line away from 0 (|order| >=
/// 0.05: the static sag under gravity is the 0X line), with the share of forward power
/// among all non-static power.
pub fn whirl(s: &FullSpectrum) -> (Whirl, f64) {
    let (mut best, mut at) = (0.0, 0.0);
    let (mut fwd, mut all) = (0.0, 0.0);
    for (o, a) in s.order.iter().zip(&s.amplitude) {
        if o.abs() < 0.05 {
            continue;
        }
        all += a * a;
        if *o > 0.0 {
            fwd += a * a;
        }
        if *a > best {
            best = *a;
            at = *o;
        }
    }
    let share = if all > 0.0 { fwd / all } else { f64::NAN };
    // Lines below a nanometre are roundoff of a resting orbit, not a whirl.
    let dir = if best < 1e-9 {
        Whirl::None
    } else if at > 0.0 {
        Whirl::Forward
    } else {
        Whirl::Backward
    };
    (dir, share)
}

/// The amplitude of the line nearest `order` (within half a bin).
pub fn line(s: &FullSpectrum, order: f64) -> f64 {
    s.order
        .iter()
        .zip(&s.amplitude)
        .min_by(|a, b| (a.0 - order).abs().total_cmp(&(b.0 - order).abs()))
        .map(|(_, a)| *a)
        .unwrap_or(0.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parseval_holds_for_the_transform() {
        let z: Vec<Complex64> = (0..240)
            .map(|n| Complex64::new((n as f64 * 0.37).sin(), (n as f64 * 0.11).cos() * 0.3))
            .collect();
        let x = dft(&z);
        let lhs: f64 = x.iter().map(|v| v.norm_sqr()).sum();
        let rhs: f64 = z.iter().map(|v| v.norm_sqr()).sum::<f64>() * z.len() as f64;
        assert!((lhs - rhs).abs() < 1e-9 * rhs);
    }
}
