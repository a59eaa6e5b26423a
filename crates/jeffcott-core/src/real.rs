//! The floating-point type a lane is integrated in.
//!
//! The ensemble stepper is generic over `f32` and `f64` so that the CPU path can run
//! exactly the arithmetic the WGSL kernel runs in either precision (docs/architecture.md, "the
//! precision is chosen the same way"). The trait exposes only what the kernel may use:
//! `+ - * /`, `sqrt`, `floor`, comparisons. No trigonometry: the forcing phasor is a
//! polynomial (see `integrate::forcing`), because f64 trigonometry is wrong on some
//! Vulkan drivers (docs/gpu.md).

use std::fmt::Debug;
use std::ops::{Add, AddAssign, Div, Mul, Neg, Sub};

/// The arithmetic of the equations of motion: one value (`f32`, `f64`, any [`Real`]) or
/// the lanes of a SIMD batch (`integrate::wide::Wide`, each operation lane by lane). The
/// variational equations (`tangent::tangent_rhs`) and the contact partials
/// (`model::contact_partials_off_centre`) are written once over this trait, so the batch
/// stepper's tangent step runs them on whole batches with exactly the scalar stepper's
/// operations per lane.
pub trait Arith:
    Copy
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + Neg<Output = Self>
{
    /// An `f64` constant in every lane (rounded to nearest for `f32`).
    fn splat(x: f64) -> Self;
    /// Square root (correctly rounded), lane by lane.
    fn root(self) -> Self;
    /// Absolute value, lane by lane.
    fn abs(self) -> Self;
    /// `self^m` for a contact law's m = n - 1 (`model::pow_half`), lane by lane.
    fn pow_half(self, m: Self) -> Self;
    /// `self^k` for the whole part k of m (`model::pow_whole`), lane by lane.
    fn pow_whole(self, m: Self) -> Self;
}

/// A real scalar usable by the lane stepper (`f32` or `f64`).
pub trait Real: Arith + Debug + PartialOrd + AddAssign + Send + Sync + 'static {
    /// Name of the type as WGSL spells it.
    const WGSL_NAME: &'static str;
    /// Machine epsilon (the distance from 1 to the next larger value), as `f64`.
    const EPSILON: f64;
    /// Converts an `f64` constant (rounding to nearest for `f32`).
    fn lit(x: f64) -> Self;
    /// Widens to `f64` (exact for both types).
    fn to_f64(self) -> f64;
    /// Square root (correctly rounded on IEEE hardware and in WGSL).
    fn sqrt(self) -> Self;
    /// Largest integer not greater than `self`.
    fn floor(self) -> Self;
    /// True when neither infinite nor NaN.
    fn is_finite(self) -> bool;
    /// Larger of two values (NaN-propagation is not relied upon).
    fn max(self, other: Self) -> Self {
        if other > self { other } else { self }
    }
    /// Smaller of two values.
    fn min(self, other: Self) -> Self {
        if other < self { other } else { self }
    }
    /// `x` where `c`, else `y`. For `f32` and `f64` chosen by the bits through a mask,
    /// so that a loop of picks over a batch's lanes compiles to vector blends: written
    /// as `if`s, the contact law's power of the gap stayed scalar branches per lane.
    #[inline(always)]
    fn pick(c: bool, x: Self, y: Self) -> Self {
        if c { x } else { y }
    }
}

/// The inherent methods of `$t` named `$f`, as trait methods of the same name.
macro_rules! forward {
    ($t:ty: $($f:ident),*) => {
        $(
            #[inline(always)]
            fn $f(self) -> Self {
                <$t>::$f(self)
            }
        )*
    };
}

macro_rules! impl_real {
    ($t:ty, $bits:ty, $name:literal) => {
        impl Arith for $t {
            #[inline(always)]
            fn splat(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn root(self) -> Self {
                <$t>::sqrt(self)
            }
            #[inline(always)]
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            #[inline(always)]
            fn pow_half(self, m: Self) -> Self {
                crate::model::pow_half(self, m)
            }
            #[inline(always)]
            fn pow_whole(self, m: Self) -> Self {
                crate::model::pow_whole(self, m)
            }
        }
        impl Real for $t {
            const WGSL_NAME: &'static str = $name;
            const EPSILON: f64 = <$t>::EPSILON as f64;
            #[inline(always)]
            fn lit(x: f64) -> Self {
                x as $t
            }
            #[inline(always)]
            fn to_f64(self) -> f64 {
                self as f64
            }
            forward!($t: sqrt, floor);
            #[inline(always)]
            fn is_finite(self) -> bool {
                <$t>::is_finite(self)
            }
            #[inline(always)]
            fn pick(c: bool, x: Self, y: Self) -> Self {
                let mask = <$bits>::from(c).wrapping_neg();
                <$t>::from_bits((x.to_bits() & mask) | (y.to_bits() & !mask))
            }
        }
    };
}

impl_real!(f32, u32, "f32");
impl_real!(f64, u64, "f64");
