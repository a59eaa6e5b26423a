//! The batch pass's transposes between a lane's state (one lane's eight components,
//! contiguous) and the batch's rows (one component of the eight lanes), for f64 in the
//! copy of the batch code compiled for AVX-512: 8 x 8 transposes in 24 shuffles
//! (`unpacklo/hi_pd`, then `permutex2var_pd` twice over), each lane's state read or
//! written with one vector load or store. Written as loops, the compiler emits 64 scalar
//! moves each way, and the vector loads that follow wait on store forwarding (about 8 %
//! of the f64 bench's samples in perf); it makes no shuffles from any portable
//! form tried (docs/performance.md). Data movement only: the bits are those of the loops.

use crate::integrate::lane::MacroStep;
use crate::integrate::wide::BATCH;
use crate::model::STATE_DIM;
use crate::real::Real;

/// Whether the shuffles apply (on x86-64): f64 lanes (the batch holds 8 lanes of 8
/// components, one 512-bit register each).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn applies<R: Real>() -> bool {
    R::WGSL_NAME == "f64" && std::mem::size_of::<R>() == 8 && BATCH == 8 && STATE_DIM == 8
}

/// The rows of the lanes' states `part[l].x` into `x`, when [`applies`]; `false` (and
/// `x` untouched) otherwise.
///
/// # Safety
/// Only from code compiled with AVX-512 F on a CPU found to have it: the copy that
/// `per_instruction_set!` makes for AVX-512 and runs only after `dispatch::use_avx512`.
#[inline(always)]
pub(crate) unsafe fn rows_in<R: Real>(
    part: &[MacroStep<R>; BATCH],
    x: &mut [[R; BATCH]; STATE_DIM],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if applies::<R>() {
        use std::arch::x86_64::*;
        // SAFETY: AVX-512 F is there (the caller's contract).
        let mut r = [unsafe { _mm512_setzero_pd() }; 8];
        for (l, p) in part.iter().enumerate() {
            // SAFETY: R is f64 (`applies`), so a state is 8 contiguous f64; AVX-512 F
            // is there (the caller's contract).
            r[l] = unsafe { _mm512_loadu_pd(p.x.as_ptr().cast::<f64>()) };
        }
        // SAFETY: as above.
        let c = unsafe { transpose8(r) };
        for (row, v) in x.iter_mut().zip(c) {
            // SAFETY: a row is 8 contiguous f64 (`applies`).
            unsafe { _mm512_storeu_pd(row.as_mut_ptr().cast::<f64>(), v) };
        }
        return true;
    }
    let _ = (part, x);
    false
}

/// The states of the lanes `keep` from the rows `x1` into `part[l].x`, when [`applies`];
/// `false` (and `part` untouched) otherwise.
///
/// # Safety
/// As [`rows_in`].
#[inline(always)]
pub(crate) unsafe fn rows_out<R: Real>(
    x1: &[[R; BATCH]; STATE_DIM],
    part: &mut [MacroStep<R>; BATCH],
    keep: &[bool; BATCH],
) -> bool {
    #[cfg(target_arch = "x86_64")]
    if applies::<R>() {
        use std::arch::x86_64::*;
        // SAFETY: AVX-512 F is there (the caller's contract).
        let mut r = [unsafe { _mm512_setzero_pd() }; 8];
        for (i, row) in x1.iter().enumerate() {
            // SAFETY: a row is 8 contiguous f64 (`applies`); AVX-512 F is there.
            r[i] = unsafe { _mm512_loadu_pd(row.as_ptr().cast::<f64>()) };
        }
        // SAFETY: as above.
        let c = unsafe { transpose8(r) };
        for l in 0..BATCH {
            if keep[l] {
                // SAFETY: a state is 8 contiguous f64 (`applies`).
                unsafe { _mm512_storeu_pd(part[l].x.as_mut_ptr().cast::<f64>(), c[l]) };
            }
        }
        return true;
    }
    let _ = (x1, part, keep);
    false
}

/// The transpose of the 8 x 8 matrix whose rows are `r`.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
#[inline]
fn transpose8(r: [std::arch::x86_64::__m512d; 8]) -> [std::arch::x86_64::__m512d; 8] {
    use std::arch::x86_64::*;
    // Pairs of rows interleaved: a_k holds the even columns of rows 2k and 2k + 1, b_k
    // the odd ones.
    let a0 = _mm512_unpacklo_pd(r[0], r[1]);
    let b0 = _mm512_unpackhi_pd(r[0], r[1]);
    let a1 = _mm512_unpacklo_pd(r[2], r[3]);
    let b1 = _mm512_unpackhi_pd(r[2], r[3]);
    let a2 = _mm512_unpacklo_pd(r[4], r[5]);
    let b2 = _mm512_unpackhi_pd(r[4], r[5]);
    let a3 = _mm512_unpacklo_pd(r[6], r[7]);
    let b3 = _mm512_unpackhi_pd(r[6], r[7]);
    // Quadruples of rows: columns {0, 4}, {2, 6} (from a), {1, 5}, {3, 7} (from b).
    let lo2 = _mm512_set_epi64(13, 12, 5, 4, 9, 8, 1, 0);
    let hi2 = _mm512_set_epi64(15, 14, 7, 6, 11, 10, 3, 2);
    let c0 = _mm512_permutex2var_pd(a0, lo2, a1);
    let c1 = _mm512_permutex2var_pd(a0, hi2, a1);
    let d0 = _mm512_permutex2var_pd(b0, lo2, b1);
    let d1 = _mm512_permutex2var_pd(b0, hi2, b1);
    let c2 = _mm512_permutex2var_pd(a2, lo2, a3);
    let c3 = _mm512_permutex2var_pd(a2, hi2, a3);
    let d2 = _mm512_permutex2var_pd(b2, lo2, b3);
    let d3 = _mm512_permutex2var_pd(b2, hi2, b3);
    // All eight rows: the lower halves make columns 0-3, the upper ones 4-7.
    let lo4 = _mm512_set_epi64(11, 10, 9, 8, 3, 2, 1, 0);
    let hi4 = _mm512_set_epi64(15, 14, 13, 12, 7, 6, 5, 4);
    [
        _mm512_permutex2var_pd(c0, lo4, c2),
        _mm512_permutex2var_pd(d0, lo4, d2),
        _mm512_permutex2var_pd(c1, lo4, c3),
        _mm512_permutex2var_pd(d1, lo4, d3),
        _mm512_permutex2var_pd(c0, hi4, c2),
        _mm512_permutex2var_pd(d0, hi4, d2),
        _mm512_permutex2var_pd(c1, hi4, c3),
        _mm512_permutex2var_pd(d1, hi4, d3),
    ]
}
