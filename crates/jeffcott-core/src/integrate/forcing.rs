//! The unbalance phasor (cos, sin) of 2 pi * turns, from + - * and `floor` only.
//!
//! Why not `cos`/`sin`: f64 trigonometry is silently wrong on Vulkan (docs/gpu.md), and
//! the CPU lane must compute exactly what the kernel computes. The argument is reduced in
//! turns (exact: subtracting a multiple of 1/4 from a number in [0, 1) is exact in binary
//! floating point) to an angle in [-pi/4, pi/4], where Taylor polynomials of degree 17
//! (sin) and 16 (cos) are accurate to 1e-17, then rotated by the quadrant.
//!
//! Keep in sync with `phasor_turns` in `integrate/forcing.wgsl` (its WGSL mirror, beside
//! this file; `forcing_phasor` of `integrate/lane.wgsl` calls it).

use crate::real::Real;

/// The WGSL mirror of this module (`forcing.wgsl`, beside this file), a part of the lane
/// kernel (`integrate::lane::WGSL_FILES`).
pub const WGSL: &str = include_str!("forcing.wgsl");

/// 1/n! for the Taylor coefficients, n = 0..=17.
const INV_FACT: [f64; 18] = [
    1.0,
    1.0,
    1.0 / 2.0,
    1.0 / 6.0,
    1.0 / 24.0,
    1.0 / 120.0,
    1.0 / 720.0,
    1.0 / 5040.0,
    1.0 / 40320.0,
    1.0 / 362880.0,
    1.0 / 3628800.0,
    1.0 / 39916800.0,
    1.0 / 479001600.0,
    1.0 / 6227020800.0,
    1.0 / 87178291200.0,
    1.0 / 1307674368000.0,
    1.0 / 20922789888000.0,
    1.0 / 355687428096000.0,
];

/// The signed Taylor coefficients [`phasor_turns`] uses, as `f64` before rounding to
/// the lane precision: `sin[n] = (-1)^n / (2n+1)!`, `cos[n] = (-1)^n / (2n)!`, n = 0..=8.
/// The GPU kernel's generated header is written from these (`gpu::shader`).
pub fn phasor_coefficients() -> ([f64; 9], [f64; 9]) {
    let mut sin = [0.0; 9];
    let mut cos = [0.0; 9];
    for n in 0..9 {
        let sign = if n % 2 == 0 { 1.0 } else { -1.0 };
        sin[n] = sign * INV_FACT[2 * n + 1];
        cos[n] = sign * INV_FACT[2 * n];
    }
    (sin, cos)
}

/// Returns (cos(2 pi turns), sin(2 pi turns)) for any finite `turns`.
#[inline(always)]
pub fn phasor_turns<R: Real>(turns: R) -> (R, R) {
    let t = turns - turns.floor(); // [0, 1)
    let q = (t * R::lit(4.0) + R::lit(0.5)).floor(); // quadrant 0..=4
    let f = t - q * R::lit(0.25); // [-1/8, 1/8] turns, exact
    let a = f * R::lit(std::f64::consts::TAU); // [-pi/4, pi/4]
    let a2 = a * a;
    // Horner in a^2, highest term first.
    let mut s = R::lit(INV_FACT[17]);
    let mut c = R::lit(INV_FACT[16]);
    let mut sign = -1.0;
    for n in (0..8).rev() {
        s = R::lit(sign * INV_FACT[2 * n + 1]) + a2 * s;
        c = R::lit(sign * INV_FACT[2 * n]) + a2 * c;
        sign = -sign;
    }
    // After the loop s = sum (-1)^n a^(2n)/(2n+1)! and c = sum (-1)^n a^(2n)/(2n)!.
    let s = a * s;
    // Rotate by q quarter turns: quadrant 0 (c, s), 1 (-s, c), 2 (-c, -s), 3 (s, -c).
    // Written as selects rather than a `match` so a loop over lanes vectorises
    // (integrate::batch); negation is exact, so the values are those of the match.
    let quadrant = (q.to_f64() as i32) & 3;
    let (a, b) = if quadrant & 1 == 1 { (s, c) } else { (c, s) };
    let a = if quadrant == 1 || quadrant == 2 {
        -a
    } else {
        a
    };
    let b = if quadrant >= 2 { -b } else { b };
    (a, b)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn phasor_matches_std_trigonometry_to_rounding() {
        let mut worst: f64 = 0.0;
        for i in 0..20_000 {
            let turns = -3.0 + i as f64 * 3.7e-4;
            let (c, s) = phasor_turns(turns);
            let ang = std::f64::consts::TAU * turns;
            worst = worst.max((c - ang.cos()).abs()).max((s - ang.sin()).abs());
        }
        assert!(worst < 4e-15, "worst phasor error {worst:e}");
        let (c, s) = phasor_turns(0.123_f32);
        let ang = std::f64::consts::TAU * 0.123_f32 as f64;
        assert!((c as f64 - ang.cos()).abs() < 3e-7 && (s as f64 - ang.sin()).abs() < 3e-7);
    }
}
