//! One quantity of every lane of a SIMD batch, with lane-by-lane arithmetic: the type
//! the batch stepper (`integrate::batch`) runs its tangent step in.
//!
//! The variational equations and the contact block of the Jacobian are written once
//! over [`Arith`] (`integrate/tangent.rs`, `model.rs`); the scalar stepper runs them on
//! `f32`/`f64`, the batch's tangent step on [`Wide`]. Each operation of a `Wide` is the
//! scalar operation in every lane, so a lane of a batch computes exactly what the scalar
//! stepper computes (Rust neither fuses nor reorders floating-point operations), and the
//! compiler sees whole-batch operations it turns into vector instructions. Written per
//! lane (a call per lane on that lane's values, transposed in and out), the tangent step
//! cost about 1.2x more (docs/performance.md, "Whole-batch tangent steps"). The state
//! step stays per lane: written this way it was slower in f32, as measured there.

use crate::model::Coeffs;
use crate::real::{Arith, Real};
use std::ops::{Add, Div, Index, IndexMut, Mul, Neg, Sub};

/// Lanes per batch: 8 fills a 256-bit register with f32 and two with f64.
pub const BATCH: usize = 8;

/// One value per lane of a batch.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(transparent)]
pub struct Wide<R>(pub [R; BATCH]);

impl<R: Copy> Wide<R> {
    /// The same value in every lane.
    #[inline(always)]
    pub fn same(x: R) -> Self {
        Wide([x; BATCH])
    }
}

impl<R: Real> Wide<R> {
    /// Each lane's value where `keep`, else `other`'s: a pick by bits per lane
    /// ([`Real::pick`]), which compiles to vector blends where a store under a branch per
    /// lane stayed scalar. A plain loop over the lanes, as in the arithmetic below.
    #[inline(always)]
    pub fn select(mut self, keep: &[bool; BATCH], other: Self) -> Self {
        #[allow(clippy::needless_range_loop)]
        for l in 0..BATCH {
            self.0[l] = R::pick(keep[l], self.0[l], other.0[l]);
        }
        self
    }
}

impl<R> Index<usize> for Wide<R> {
    type Output = R;
    #[inline(always)]
    fn index(&self, l: usize) -> &R {
        &self.0[l]
    }
}

impl<R> IndexMut<usize> for Wide<R> {
    #[inline(always)]
    fn index_mut(&mut self, l: usize) -> &mut R {
        &mut self.0[l]
    }
}

/// `Wide<R> op Wide<R>`, lane by lane.
macro_rules! lanewise {
    ($($tr:ident $f:ident),*) => {
        $(
            impl<R: Real> $tr for Wide<R> {
                type Output = Self;
                #[inline(always)]
                fn $f(mut self, o: Self) -> Self {
                    // A plain loop, which the compiler vectorises (built with
                    // `std::array::from_fn`, a closure call per operation stayed in
                    // the batch stepper's profile).
                    for l in 0..BATCH {
                        self.0[l] = self.0[l].$f(o.0[l]);
                    }
                    self
                }
            }
        )*
    };
}
lanewise!(Add add, Sub sub, Mul mul, Div div);

impl<R: Real> Neg for Wide<R> {
    type Output = Self;
    #[inline(always)]
    fn neg(mut self) -> Self {
        for l in 0..BATCH {
            self.0[l] = -self.0[l];
        }
        self
    }
}

impl<R: Real> Arith for Wide<R> {
    #[inline(always)]
    fn splat(x: f64) -> Self {
        Wide::same(R::splat(x))
    }
    #[inline(always)]
    fn root(mut self) -> Self {
        for l in 0..BATCH {
            self.0[l] = self.0[l].root();
        }
        self
    }
    #[inline(always)]
    fn abs(mut self) -> Self {
        for l in 0..BATCH {
            self.0[l] = Arith::abs(self.0[l]);
        }
        self
    }
    #[inline(always)]
    fn pow_half(mut self, m: Self) -> Self {
        for l in 0..BATCH {
            self.0[l] = self.0[l].pow_half(m.0[l]);
        }
        self
    }
    #[inline(always)]
    fn pow_whole(mut self, m: Self) -> Self {
        for l in 0..BATCH {
            self.0[l] = self.0[l].pow_whole(m.0[l]);
        }
        self
    }
}

impl<R: Copy> Coeffs<[R; BATCH]> {
    /// The same coefficients as `Wide`s, for whole-batch arithmetic.
    #[inline(always)]
    pub fn wide(&self) -> Coeffs<Wide<R>> {
        self.map(Wide)
    }
}
