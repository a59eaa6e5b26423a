//! The lane stepper for a batch of `BATCH` lanes at once, laid out structure-of-arrays
//! so the compiler vectorises across lanes (SIMD): the CPU mirror of what a GPU
//! subgroup does.
//!
//! Only the common case is batched: sub-steps with no contact switch (about 98% of the
//! macro steps at W = 133, `jeffcott bench`), one per macro step in free flight and R
//! per macro step in contact (contact refinement, `lane::trial_extent`; one pass of the
//! batch per sub-step, all lanes computed in every pass). Each lane's trial step and
//! switch search run here with exactly the operations, in exactly the order, of
//! `lane::rk4_substep` and `lane::find_switch` (Rust never fuses or reorders
//! floating-point operations, so vectorising does not change a bit); so do the tangent
//! steps of the lambda_1 variant, on the state step's own stages. A lane whose trial
//! step finds a crossing, or a grazing extremum to check, is handed to the scalar
//! `lane::finish_macro_step` where it stands (state and fraction of the macro step
//! done), which redoes that trial step bit for bit and then refines. So a batched run
//! equals the scalar run to the bit (tests/ensemble_cpu.rs), and the scalar stepper stays
//! the one definition of the algorithm that the WGSL kernel mirrors.

use crate::integrate::forcing::phasor_turns;
use crate::integrate::free_flight::{ExactFreeFlight, free_flight_step, free_flight_tangent};
use crate::integrate::lane::{
    Lane, LaneConsts, MacroStep, exact_trial, finish_macro_step, forcing_phasor, macro_step_begin,
    macro_step_end, macro_step_tangent, trial_extent,
};
use crate::integrate::switch::{GRAZE_SAMPLES, hermite_sq, search_needless};
use crate::integrate::tangent::{Tangent, jacobian_trace, tangent_rhs};
use crate::integrate::transpose;
use crate::integrate::wide::Wide;
use crate::model::{
    Coeffs, STATE_DIM, Terms, concentric, contact_partials_law_off_centre,
    contact_partials_off_centre, relative_motion, whole_part,
};
use crate::real::Real;

pub use crate::integrate::wide::BATCH;
pub use group::{GroupScratch, group_macro_step_tangent};

mod group;
mod rhs;

use rhs::rhs;

/// One value per lane of a batch.
type V<R> = [R; BATCH];

/// Builds a per-lane array from a function of the lane index. A plain loop, not
/// `std::array::from_fn` nor an iterator adapter: those are generic functions the
/// compiler may keep out of line, and out of line they are compiled without the
/// instruction set the batch stepper is built for (`cpu::run_batch`'s per-instruction-
/// set copies). perf found 14 % of the f64 bench's samples in such SSE2 copies
/// (`Map::fold`, `Iterator::try_fold`); written as loops, the same work ran 1-3 %
/// faster.
#[inline(always)]
fn lanes<R: Copy>(mut f: impl FnMut(usize) -> R) -> [R; BATCH] {
    let mut out = [f(0); BATCH];
    #[allow(clippy::needless_range_loop)]
    for l in 1..BATCH {
        out[l] = f(l);
    }
    out
}

/// Whether `f` holds for some lane, lanes in order, stopping at the first (a loop for
/// the reason of [`lanes`]).
#[inline(always)]
fn any_lane(mut f: impl FnMut(usize) -> bool) -> bool {
    for l in 0..BATCH {
        if f(l) {
            return true;
        }
    }
    false
}

/// The lane constants of a batch, structure-of-arrays.
#[derive(Clone, Copy, Debug)]
pub struct BatchConsts<'t, R> {
    /// The equation coefficients, one value per lane in each field.
    c: Coeffs<V<R>>,
    h: V<R>,
    inv_n: V<R>,
    phase0: V<R>,
    /// The forcing table, when it serves every lane of the batch.
    forcing: Option<&'t ForcingTable<R>>,
    /// The optional terms some lane uses (whether the tangent step computes the
    /// contact laws' partials).
    terms: Terms,
    /// Whether some lane uses an optional term: the batch then takes `rhs_lanes`'
    /// `MACHINE` code.
    machine: bool,
    /// Which lanes' contact is a law other than the linear spring
    /// (`model::Coeffs::contact_law`, decided once per lane in `LaneConsts::terms`).
    law: [bool; BATCH],
    /// Whether some lane's law has a half-integer exponent n - 1, whose power of the gap
    /// takes a square root (`model::pow_half`); without one the batch computes none.
    law_root: bool,
}

impl<'t, R: Real> BatchConsts<'t, R> {
    /// Transposes the constants of `BATCH` lanes; `forcing` is kept when it serves all
    /// of them ([`ForcingTable::serves`]).
    ///
    /// Inlined and written as loops (see [`lanes`]): the group stepper builds one per
    /// packed pass, and out of line, without the batch code's instruction set, this
    /// held 2 % of the 1k-lane bench row's samples (perf).
    #[inline(always)]
    pub fn new(lc: &[LaneConsts<R>; BATCH], forcing: Option<&'t ForcingTable<R>>) -> Self {
        let terms = batch_terms(|l| lc[l].terms);
        let law = lanes(|l| lc[l].terms.contact_law);
        BatchConsts {
            c: Coeffs::transpose(&lanes(|l| lc[l].c)),
            h: lanes(|l| lc[l].h),
            inv_n: lanes(|l| lc[l].inv_n),
            phase0: lanes(|l| lc[l].phase0),
            forcing: serving(forcing, &lanes(|l| &lc[l])),
            terms,
            machine: terms != Terms::NONE,
            law,
            law_root: terms.contact_law && law_root(&law, |l| lc[l].c.n_c),
        }
    }

    /// The batch constants of lane `slot[i].1` of batch `slot[i].0` of `bcs`, lane by
    /// lane (whose constants are `lc`): [`BatchConsts::new`] of those lanes, picked from
    /// the batches' rows. The forcing table is the first one the batches hold, kept when
    /// it serves every slot's lane, as `new` decides.
    #[inline(always)]
    pub fn pick(
        bcs: &[BatchConsts<'t, R>],
        slot: &[(usize, usize); BATCH],
        lc: &[&LaneConsts<R>; BATCH],
    ) -> Self {
        let terms = batch_terms(|i| lc[i].terms);
        let law = lanes(|i| lc[i].terms.contact_law);
        BatchConsts {
            c: Coeffs::transpose(&lanes(|i| bcs[slot[i].0].c.lane(slot[i].1))),
            h: lanes(|i| bcs[slot[i].0].h[slot[i].1]),
            inv_n: lanes(|i| bcs[slot[i].0].inv_n[slot[i].1]),
            phase0: lanes(|i| bcs[slot[i].0].phase0[slot[i].1]),
            forcing: serving(bcs.iter().find_map(|b| b.forcing), lc),
            terms,
            machine: terms != Terms::NONE,
            law,
            law_root: terms.contact_law && law_root(&law, |i| lc[i].c.n_c),
        }
    }
}

/// Whether some lane with a contact law (`law`) has a half-integer exponent m = n - 1,
/// lane `l`'s n being `n_c(l)` ([`BatchConsts::law_root`]; asked only for a batch with a
/// law, as a batch is built every pass).
#[inline(always)]
fn law_root<R: Real>(law: &[bool; BATCH], n_c: impl Fn(usize) -> R) -> bool {
    any_lane(|l| {
        let m = n_c(l) - R::lit(1.0);
        law[l] && m != whole_part(m)
    })
}

/// The terms some lane of a batch uses, lane `l`'s being `of(l)`.
#[inline(always)]
fn batch_terms(of: impl Fn(usize) -> Terms) -> Terms {
    let mut t = Terms::default();
    for l in 0..BATCH {
        t = t.or(of(l));
    }
    t
}

/// `forcing` where it serves every lane of `lc` ([`ForcingTable::serves`]), else none.
#[inline(always)]
fn serving<'t, R: Real>(
    forcing: Option<&'t ForcingTable<R>>,
    lc: &[&LaneConsts<R>; BATCH],
) -> Option<&'t ForcingTable<R>> {
    let mut serves = true;
    for l in lc {
        serves &= forcing.is_some_and(|t| t.serves(l));
    }
    if serves { forcing } else { None }
}

/// The unbalance phasor at every fraction a batch pass asks for, tabulated:
/// `lane::forcing_phasor` at sigma = j/(2R), j = 0..=2R, for every macro step
/// k < N. A pass starts its sub-steps at multiples of 1/R (a lane that meets a switch
/// leaves the batch), so its stages sit at such fractions, and a lookup replaces three
/// ~40-flop polynomials per sub-step. The phasor's argument, (k + sigma)/N - phi0/(2 pi)
/// turns, does not depend on W, so one table serves every lane with the same N, phi0
/// and R, whatever its speed or parameters. Each entry is `forcing_phasor` of exactly
/// the argument the polynomial path computes (j/(2R) is exact for R a power of two), so
/// a lookup gives the polynomial's bits: the batch still equals the scalar stepper and
/// the GPU kernel to the bit. Anything else (another phi0, a fraction off the grid, R
/// not a power of two) takes the polynomial.
#[derive(Clone)]
pub struct ForcingTable<R> {
    inv_n: R,
    phase0: R,
    inv_r: R,
    n: u32,
    /// 2R: the fractions per macro step.
    two_r: u32,
    /// (cos, sin) at [k][j], j = 0..=2R, flat.
    values: Vec<[R; 2]>,
}

impl<R: Real> ForcingTable<R> {
    /// Most entries a table holds (4 MiB in f64); a finer stepper takes the polynomial.
    pub const MAX_ENTRIES: usize = 1 << 18;

    /// The table the batch stepper uses for lanes like `lc`: in f64 only. Back to back
    /// on the 2-core VM (`jeffcott bench --backend cpu --lanes 16384`, two rounds) the
    /// table took f64 from 2.43-2.45e7 to 2.72-2.85e7 lane-steps/s, and f32 (given
    /// the table too) from 3.66-3.68e7 down to 3.40-3.44e7: eight f32 lanes fill one
    /// AVX2 register, so the polynomial costs less than eight scalar look-ups. It is
    /// the table `lc` already carries for the scalar stepper (`LaneConsts::forcing`).
    pub fn for_batches(lc: &LaneConsts<R>) -> Option<&'static Self> {
        if R::WGSL_NAME == "f64" {
            lc.forcing
        } else {
            None
        }
    }

    /// The table for lanes with `lc`'s N, phi0 and R; `None` when R is not a power of
    /// two or the table would exceed [`ForcingTable::MAX_ENTRIES`].
    pub fn for_lane(lc: &LaneConsts<R>) -> Option<Self> {
        let r = (1.0 / lc.inv_r.to_f64()).round();
        if !(1.0..=65536.0).contains(&r) {
            return None;
        }
        let r = r as u32;
        if !r.is_power_of_two() || R::lit(1.0 / r as f64).to_f64() != lc.inv_r.to_f64() {
            return None;
        }
        let two_r = 2 * r;
        if lc.n as usize * (two_r as usize + 1) > Self::MAX_ENTRIES {
            return None;
        }
        let values = (0..lc.n)
            .flat_map(|k| {
                (0..=two_r).map(move |j| {
                    let (c, s) = forcing_phasor(lc, k, R::lit(j as f64 / two_r as f64));
                    [c, s]
                })
            })
            .collect();
        Some(ForcingTable {
            inv_n: lc.inv_n,
            phase0: lc.phase0,
            inv_r: lc.inv_r,
            n: lc.n,
            two_r,
            values,
        })
    }

    /// The table for lanes like `lc` shared for the whole process (built on first use,
    /// never freed): what `LaneConsts::new` gives each lane, so that the scalar stepper
    /// (`lane::forcing_phasor`) looks its phasors up too. At most
    /// [`ForcingTable::INTERNED_BYTES`] of tables per process (40 KB for N = 500, R = 2 in
    /// f64); lanes of further (N, phi0, R) evaluate the polynomial.
    pub fn interned(lc: &LaneConsts<R>) -> Option<&'static Self> {
        use std::any::{Any, TypeId};
        use std::collections::HashMap;
        use std::sync::{Mutex, OnceLock};
        type Key = (TypeId, u32, u64, u64);
        type Tables = (
            usize,
            HashMap<Key, Option<&'static (dyn Any + Send + Sync)>>,
        );
        static TABLES: OnceLock<Mutex<Tables>> = OnceLock::new();
        let key = (
            TypeId::of::<R>(),
            lc.n,
            lc.phase0.to_f64().to_bits(),
            lc.inv_r.to_f64().to_bits(),
        );
        let mut guard = TABLES.get_or_init(Default::default).lock().ok()?;
        let (bytes, tables) = &mut *guard;
        if let Some(t) = tables.get(&key) {
            return t.and_then(|t| t.downcast_ref::<Self>());
        }
        // Built once per key, kept where it fits the budget (a refusal is kept too, so
        // the lanes of that key do not build it again).
        let bytes_of = |t: &Self| t.values.len() * std::mem::size_of::<[R; 2]>();
        let table: Option<&'static Self> = Self::for_lane(lc)
            .filter(|t| *bytes + bytes_of(t) <= Self::INTERNED_BYTES)
            .map(|t| &*Box::leak(Box::new(t)));
        *bytes += table.map_or(0, bytes_of);
        tables.insert(key, table.map(|t| t as &'static (dyn Any + Send + Sync)));
        table
    }

    /// Bytes of tables [`ForcingTable::interned`] keeps at most (each kept for the
    /// process's life: a study uses one or a few).
    pub const INTERNED_BYTES: usize = 64 << 20;

    /// The phasor of macro step `k` at fraction `sigma` (scalar), when the table holds it.
    #[inline(always)]
    pub fn get(&self, k: u32, sigma: R) -> Option<(R, R)> {
        if k >= self.n {
            return None;
        }
        let j = self.index(sigma)?;
        let [c, s] = self.values[k as usize * (self.two_r as usize + 1) + j];
        Some((c, s))
    }

    /// Whether the table holds `lc`'s phasors: the same N, phi0 and R, to the bit.
    #[inline(always)]
    pub fn serves(&self, lc: &LaneConsts<R>) -> bool {
        let same = |a: R, b: R| a.to_f64().to_bits() == b.to_f64().to_bits();
        lc.n == self.n
            && same(lc.inv_n, self.inv_n)
            && same(lc.phase0, self.phase0)
            && same(lc.inv_r, self.inv_r)
    }

    /// The phasors of macro step `k` at each lane's fraction `sigma`, when every
    /// fraction is one of the table's (else `None`: the caller evaluates them).
    #[inline(always)]
    pub fn lookup(&self, k: u32, sigma: &V<R>) -> Option<(V<R>, V<R>)> {
        if k >= self.n {
            return None;
        }
        let base = k as usize * (self.two_r as usize + 1);
        // Usually every lane of a pass asks for the same fraction (all begin their
        // sub-steps at multiples of 1/R): one index for all, broadcast (2.67e7 to
        // 2.77e7 lane-steps/s on the bench above, with the search below).
        if sigma
            .iter()
            .all(|&s| s.to_f64().to_bits() == sigma[0].to_f64().to_bits())
        {
            let [c, s] = self.values[base + self.index(sigma[0])?];
            return Some(([c; BATCH], [s; BATCH]));
        }
        // Each lane's own entry, its index found without a branch (`slot`), so that the
        // loop vectorises. A pass whose lanes begin in both modes asks for two
        // fractions (a contact lane's sub-step is 1/R, a free lane's the whole macro
        // step); with a branch per lane (`index`'s `?`) these look-ups held 5-10 % of
        // the basin's samples (perf).
        let mut held = true;
        let mut at = [0usize; BATCH];
        for l in 0..BATCH {
            let (j, h) = self.slot(sigma[l]);
            held &= h;
            at[l] = base + j;
        }
        if !held {
            return None;
        }
        Some((
            lanes(|l| self.values[at[l]][0]),
            lanes(|l| self.values[at[l]][1]),
        ))
    }

    /// The table's index j of fraction `sigma` = j / (2R) within a macro step, `None`
    /// for a fraction the table does not hold.
    #[inline(always)]
    fn index(&self, sigma: R) -> Option<usize> {
        let (at, held) = self.slot(sigma);
        held.then_some(at)
    }

    /// [`ForcingTable::index`] without a branch, so that a loop over lanes vectorises:
    /// the index (clamped into the table's row, whatever `sigma` is) and whether the
    /// table holds `sigma`.
    #[inline(always)]
    fn slot(&self, sigma: R) -> (usize, bool) {
        // Exact: 2R is a power of two, so sigma * 2R is an integer only when sigma is
        // exactly j / (2R); j <= 2R, so the conversion to an integer and back is exact
        // too (tested without `floor`, a libm call in the batch code's profile). A NaN
        // converts to 0 and fails the comparison.
        let two_r = self.two_r as f64;
        let j = sigma.to_f64() * two_r;
        let whole = j as u32;
        let held = (j >= 0.0) & (j <= two_r) & (whole as f64 == j);
        (whole.min(self.two_r) as usize, held)
    }
}

impl<R> std::fmt::Debug for ForcingTable<R> {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "ForcingTable(N = {}, 2R = {})", self.n, self.two_r)
    }
}

/// Sets lane `l` of a structure-of-arrays state.
#[inline(always)]
fn set_lane<R: Copy>(x: &mut [V<R>; STATE_DIM], l: usize, v: [R; STATE_DIM]) {
    for (xi, vi) in x.iter_mut().zip(v) {
        xi[l] = vi;
    }
}

/// Lane `l` of a structure-of-arrays state.
#[inline(always)]
fn lane_of<R: Copy>(x: &[V<R>; STATE_DIM], l: usize) -> [R; STATE_DIM] {
    let mut out = [x[0][l]; STATE_DIM];
    #[allow(clippy::needless_range_loop)]
    for i in 1..STATE_DIM {
        out[i] = x[i][l];
    }
    out
}

/// `lane::forcing_phasor` for every lane at its fraction `sigma` of macro step `k`:
/// from the batch's [`ForcingTable`] where it holds them, else evaluated.
#[inline(always)]
fn phasor<R: Real>(bc: &BatchConsts<R>, k: u32, sigma: &V<R>) -> (V<R>, V<R>) {
    if let Some(found) = bc.forcing.and_then(|t| t.lookup(k, sigma)) {
        return found;
    }
    let mut c = [R::lit(0.0); BATCH];
    let mut s = [R::lit(0.0); BATCH];
    for l in 0..BATCH {
        (c[l], s[l]) = phasor_turns((R::lit(k as f64) + sigma[l]) * bc.inv_n[l] - bc.phase0[l]);
    }
    (c, s)
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
    // Lanes outside, components inside (see the update in `rk4_step`).
    let mut out = [[R::lit(0.0); BATCH]; STATE_DIM];
    for l in 0..BATCH {
        for i in 0..STATE_DIM {
            out[i][l] = x[i][l] + factor * hs[l] * k[i][l];
        }
    }
    out
}

/// The stage states of one RK4 sub-step for every lane: x, then the states at which k2,
/// k3 and k4 are evaluated.
type Stages<R> = [[V<R>; STATE_DIM]; 4];

/// `lane::rk4_substep` over each lane's fraction [s0, s0 + ds] of macro step `k`; also
/// returns the stage states (the tangent step reuses them, as
/// `lane::rk4_tangent_substep` recomputes exactly these).
#[inline(always)]
fn rk4_step<R: Real>(
    bc: &BatchConsts<R>,
    x: &[V<R>; STATE_DIM],
    k: u32,
    s0: &V<R>,
    ds: &V<R>,
    contact: &[bool; BATCH],
) -> ([V<R>; STATE_DIM], Stages<R>) {
    let half = R::lit(0.5);
    let hs: V<R> = lanes(|l| ds[l] * bc.h[l]);
    let (c0, s0p) = phasor(bc, k, s0);
    let (cm, sm) = phasor(bc, k, &lanes(|l| s0[l] + half * ds[l]));
    let (c1, s1) = phasor(bc, k, &lanes(|l| s0[l] + ds[l]));
    let k1 = rhs(bc, x, &c0, &s0p, contact);
    let xt2 = stage(x, half, &hs, &k1);
    let k2 = rhs(bc, &xt2, &cm, &sm, contact);
    let xt3 = stage(x, half, &hs, &k2);
    let k3 = rhs(bc, &xt3, &cm, &sm, contact);
    let xt4 = stage(x, R::lit(1.0), &hs, &k3);
    let k4 = rhs(bc, &xt4, &c1, &s1, contact);
    // The loop over lanes outside, the one over components inside: the compiler
    // unrolls the inner loop and vectorises the outer one, so with the lanes inside it
    // vectorised across the components (STATE_DIM = BATCH), reading and writing the
    // lane-major arrays through gathers and scatters: 23 % of the f64 bench's samples
    // (perf).
    let sixth = R::lit(1.0 / 6.0);
    let mut out = [[R::lit(0.0); BATCH]; STATE_DIM];
    for l in 0..BATCH {
        for i in 0..STATE_DIM {
            out[i][l] = x[i][l]
                + hs[l] * sixth * (k1[i][l] + R::lit(2.0) * (k2[i][l] + k3[i][l]) + k4[i][l]);
        }
    }
    (out, [*x, xt2, xt3, xt4])
}

/// [`stage`] in whole-batch arithmetic: `v + (factor * hs) * k`.
#[inline(always)]
fn wide_stage<R: Real>(
    v: &[Wide<R>; STATE_DIM],
    factor: Wide<R>,
    hs: Wide<R>,
    k: &[Wide<R>; STATE_DIM],
) -> [Wide<R>; STATE_DIM] {
    let a = factor * hs;
    let mut out = *v;
    // Lanes outside, components inside (see the update in `rk4_step`).
    for l in 0..BATCH {
        for i in 0..STATE_DIM {
            out[i][l] = v[i][l] + a[l] * k[i][l];
        }
    }
    out
}

/// `lane::rk4_tangent_substep` for the lanes `accept` of a batch at once, on the stage
/// states of the state's RK4 sub-step (`rk4_step`): the same operations in the same
/// order per lane, so the tangent vectors and trace integrals are the scalar stepper's
/// to the bit; the other lanes' tangents are left alone.
#[inline(always)]
fn tangent_step<R: Real, const M: usize>(
    bc: &BatchConsts<R>,
    lc: &[&LaneConsts<R>; BATCH],
    stages: &Stages<R>,
    hs: &V<R>,
    contact: &[bool; BATCH],
    accept: &[bool; BATCH],
    tan: &mut [Tangent<R, M>; BATCH],
) {
    // Whole-batch arithmetic (`integrate::wide`): `ensemble --omega 130:141:4096
    // --transient 40 --periods 10 --lyapunov` (2-core VM, back to back) took 9.5 s with
    // this step written per lane, 8.1 s this way, the same bits.
    let c = bc.c.wide();
    let zero = Wide::same(R::lit(0.0));
    let (half, one) = (Wide::same(R::lit(0.5)), Wide::same(R::lit(1.0)));
    let (sixth, two) = (Wide::same(R::lit(1.0 / 6.0)), Wide::same(R::lit(2.0)));
    let hs = Wide(*hs);
    // The contact block at each stage (`tangent::stage_partials`): zero out of contact
    // and at the concentric position; computed for the batch when a lane is in contact.
    let mut pc = [[zero; 8]; 4];
    if contact.iter().any(|&c| c) {
        for (st, p) in stages.iter().zip(pc.iter_mut()) {
            let st: [Wide<R>; STATE_DIM] = st.map(Wide);
            let [dx, dy, _, _] = relative_motion(&st);
            let mut keep = [false; BATCH];
            for l in 0..BATCH {
                keep[l] = contact[l] && !concentric(dx[l], dy[l]);
            }
            let mut q = contact_partials_off_centre(&c, &st);
            if bc.terms.contact_law {
                // Each lane's own law (`model::contact_partials`).
                let g = contact_partials_law_off_centre(&c, &st);
                for j in 0..8 {
                    q[j] = g[j].select(&bc.law, q[j]);
                }
            }
            for j in 0..8 {
                p[j] = q[j].select(&keep, zero);
            }
        }
    }
    for m in 0..M {
        let mut v = [zero; STATE_DIM];
        for (i, vi) in v.iter_mut().enumerate() {
            for (l, t) in tan.iter().enumerate() {
                vi[l] = t.v[m][i];
            }
        }
        let a1 = tangent_rhs(&c, &pc[0], &v);
        let a2 = tangent_rhs(&c, &pc[1], &wide_stage(&v, half, hs, &a1));
        let a3 = tangent_rhs(&c, &pc[2], &wide_stage(&v, half, hs, &a2));
        let a4 = tangent_rhs(&c, &pc[3], &wide_stage(&v, one, hs, &a3));
        // Loops, not `std::array::from_fn`: with the state step written that way, its
        // closure was compiled out of line, without the caller's AVX2. Lanes outside,
        // components inside (see the update in `rk4_step`).
        let mut out = v;
        for l in 0..BATCH {
            for i in 0..STATE_DIM {
                out[i][l] = v[i][l]
                    + hs[l] * sixth[l] * (a1[i][l] + two[l] * (a2[i][l] + a3[i][l]) + a4[i][l]);
            }
        }
        for (l, t) in tan.iter_mut().enumerate() {
            if accept[l] {
                for (ti, o) in t.v[m].iter_mut().zip(&out) {
                    *ti = o[l];
                }
            }
        }
    }
    for l in 0..BATCH {
        if accept[l] {
            let c = &lc[l].c;
            let tr = |s: usize| {
                let q: [R; 8] = std::array::from_fn(|j| pc[s][j][l]);
                jacobian_trace(c, &q).to_f64()
            };
            tan[l].trace_integral += hs[l].to_f64() / 6.0 * (tr(0) + 2.0 * (tr(1) + tr(2)) + tr(3));
        }
    }
}

/// `switch::hermite_sq` at `theta` for every lane (x0 -> x1 over each lane's ds h):
/// |d|^2 and d . dd/dtheta, what `lane::hermite_gap` takes g and its rate from.
/// All lanes, also those that need no search: the loop vectorises across the batch, and
/// skipping lanes in it (tried) made the W = 133 bench 5-10 % slower.
#[inline(always)]
fn samples<R: Real>(
    bc: &BatchConsts<R>,
    x0: &[V<R>; STATE_DIM],
    x1: &[V<R>; STATE_DIM],
    ds: &V<R>,
    theta: R,
) -> (V<R>, V<R>) {
    // Per lane on `lane_of` its state: written on whole rows (`Wide`, the definition
    // made generic) the f64 bench ran 3-6 % slower.
    let mut sq = [R::lit(0.0); BATCH];
    let mut dot = [R::lit(0.0); BATCH];
    for l in 0..BATCH {
        (sq[l], dot[l]) = hermite_sq(&lane_of(x0, l), &lane_of(x1, l), ds[l] * bc.h[l], theta);
    }
    (sq, dot)
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
    batch_macro_step_tangent::<R, 0, false>(bc, lc, lane, &mut none);
}

/// [`batch_macro_step`] carrying `M` tangent vectors per lane, as
/// `lane::macro_step_tangent` does: on the batched path the tangent step over each
/// accepted sub-step is batched too (`tangent_step`, on the state step's own stages),
/// with the scalar `rk4_tangent_substep`'s operations per lane, so the tangents too are
/// bit for bit those of the scalar stepper; a lane that meets a switch goes on in
/// `lane::finish_macro_step` from where the batch left it.
#[inline(always)]
pub fn batch_macro_step_tangent<R: Real, const M: usize, const AVX512: bool>(
    bc: &BatchConsts<R>,
    lc: &[LaneConsts<R>; BATCH],
    lane: &mut [Lane<R>; BATCH],
    tan: &mut [Tangent<R, M>; BATCH],
) {
    let Some(k) = batch_k(lane) else {
        return;
    };
    let mut part: [MacroStep<R>; BATCH] = lanes(|l| macro_step_begin(&lane[l]));
    let mut trial = [[R::lit(0.0); STATE_DIM]; BATCH];
    // Lanes the batch still advances; a lane leaves when its macro step is done (s = 1)
    // or when its trial sub-step needs the scalar switch search.
    let mut active: [bool; BATCH] = lanes(|l| !lane[l].status.is_frozen() && lane[l].k == k);
    // One pass per sub-step: a lane in free flight needs one, a lane in contact R
    // (contact refinement, `lane::trial_extent`); every pass computes all lanes.
    while active.iter().any(|&a| a) {
        batch_pass::<R, M, AVX512>(
            bc,
            &lanes(|l| &lc[l]),
            k,
            &mut part,
            &mut active,
            tan,
            &mut trial,
        );
    }
    batch_finish(lc, lane, tan, k, &part, &trial);
}

/// The macro-step index of a batch's live lanes (they advance in lock step from k = 0;
/// frozen ones keep the index they froze at and are skipped), `None` when all froze.
#[inline(always)]
fn batch_k<R: Real>(lane: &[Lane<R>; BATCH]) -> Option<u32> {
    lane.iter().find(|l| !l.status.is_frozen()).map(|l| l.k)
}

/// One pass of a batch: every lane takes its next trial sub-step (all lanes computed,
/// the `active` ones kept); a lane whose step ends its macro step, or that needs the
/// scalar switch search, leaves `active` (the latter with its trial sub-step in
/// `trial`, which the scalar stepper takes up instead of computing it again).
#[inline(always)]
fn batch_pass<R: Real, const M: usize, const AVX512: bool>(
    bc: &BatchConsts<R>,
    lc: &[&LaneConsts<R>; BATCH],
    k: u32,
    part: &mut [MacroStep<R>; BATCH],
    active: &mut [bool; BATCH],
    tan: &mut [Tangent<R, M>; BATCH],
    trial: &mut [[R; STATE_DIM]; BATCH],
) {
    let zero = R::lit(0.0);
    let mut x: [V<R>; STATE_DIM] = [[zero; BATCH]; STATE_DIM];
    // SAFETY: only in the copy compiled for AVX-512 (`AVX512`, `per_instruction_set!`).
    if !(AVX512 && unsafe { transpose::rows_in(part, &mut x) }) {
        for (l, p) in part.iter().enumerate() {
            set_lane(&mut x, l, p.x);
        }
    }
    let contact: [bool; BATCH] = lanes(|l| part[l].contact);
    let s0: V<R> = lanes(|l| part[l].s);
    let extent: [(R, R); BATCH] = lanes(|l| trial_extent(lc[l], s0[l], contact[l]));
    let ds: V<R> = lanes(|l| extent[l].0);
    // Lanes whose macro step begins in free flight take the exact map where the
    // stepper has it (`lane::finish_macro_step`, the same choice and the same scalar
    // map); RK4 runs for the batch unless every live lane did.
    let exact: [Option<&ExactFreeFlight<R>>; BATCH] =
        lanes(|l| exact_trial(lc[l], s0[l], contact[l]));
    let (mut x1, stages) = if any_lane(|l| active[l] && exact[l].is_none()) {
        rk4_step(bc, &x, k, &s0, &ds, &contact)
    } else {
        (x, [x; 4])
    };
    for l in 0..BATCH {
        if let Some(ex) = exact[l] {
            set_lane(&mut x1, l, free_flight_step(ex, lc[l], &lane_of(&x, l), k));
        }
    }
    let (search, switch, max_g) = trial_switches(bc, part, active, &x, &x1, &ds, &contact);
    // No switch: accept the trial sub-step as `finish_macro_step` does.
    let accept: [bool; BATCH] = lanes(|l| active[l] && !switch[l]);
    if M > 0 {
        // RK4's tangent step on the stages, or the exact map's own (`lane::trial_tangent`).
        let by_rk4: [bool; BATCH] = lanes(|l| accept[l] && exact[l].is_none());
        if by_rk4.iter().any(|&a| a) {
            let hs: V<R> = lanes(|l| ds[l] * bc.h[l]);
            tangent_step(bc, lc, &stages, &hs, &contact, &by_rk4, tan);
        }
        for l in 0..BATCH {
            if let (true, Some(ex)) = (accept[l], exact[l]) {
                free_flight_tangent(ex, lc[l], &mut tan[l]);
            }
        }
    }
    let done = Trial {
        x1: &x1,
        extent: &extent,
        switch: &switch,
        accept: &accept,
        search,
        max_g: &max_g,
    };
    commit_trials::<R, AVX512>(&done, part, active, trial);
}

/// A pass's trial sub-steps and what the switch search made of them.
struct Trial<'a, R> {
    /// Each lane's state after its trial sub-step.
    x1: &'a [V<R>; STATE_DIM],
    /// Each lane's trial extent and the fraction of the macro step it ends at.
    extent: &'a [(R, R); BATCH],
    /// The lanes whose sub-step may hold a switch (handed to the scalar stepper).
    switch: &'a [bool; BATCH],
    /// The active lanes without a switch.
    accept: &'a [bool; BATCH],
    /// Whether the samples were computed at all (else every live lane is certified).
    search: bool,
    /// Each lane's largest g over the samples, where they were computed.
    max_g: &'a V<R>,
}

/// Ends a pass: an active lane with a switch leaves `active` with its trial sub-step in
/// `trial`; an accepted one takes its new state and fraction of the macro step, and
/// stays active while the macro step goes on.
#[inline(always)]
fn commit_trials<R: Real, const AVX512: bool>(
    t: &Trial<'_, R>,
    part: &mut [MacroStep<R>; BATCH],
    active: &mut [bool; BATCH],
    trial: &mut [[R; STATE_DIM]; BATCH],
) {
    let one = R::lit(1.0);
    // The accepted lanes' new states, by shuffles in the AVX-512 copy (f64), else
    // lane by lane below.
    // SAFETY: only in the copy compiled for AVX-512 (`AVX512`, `per_instruction_set!`).
    let shuffled = AVX512 && unsafe { transpose::rows_out(t.x1, part, t.accept) };
    for l in 0..BATCH {
        if !active[l] {
            continue;
        }
        if t.switch[l] {
            active[l] = false;
            trial[l] = lane_of(t.x1, l);
            continue;
        }
        let p = &mut part[l];
        p.substeps += 1;
        // Without a search every live lane is certified: its samples could not raise
        // its largest penetration, so max_g is left as it is.
        if t.search {
            p.max_g = p.max_g.max(t.max_g[l]);
        }
        if !shuffled {
            p.x = lane_of(t.x1, l);
        }
        p.s = t.extent[l].1;
        active[l] = p.s < one;
    }
}

/// The switch search of a pass's trial sub-steps from `x` to `x1`: whether any active
/// lane needed one (`search`), which lanes may hold a switch, and each lane's largest
/// g over the samples.
#[inline(always)]
fn trial_switches<R: Real>(
    bc: &BatchConsts<R>,
    part: &[MacroStep<R>; BATCH],
    active: &[bool; BATCH],
    x: &[V<R>; STATE_DIM],
    x1: &[V<R>; STATE_DIM],
    ds: &V<R>,
    contact: &[bool; BATCH],
) -> (bool, [bool; BATCH], V<R>) {
    let zero = R::lit(0.0);
    // When no live lane's search could change a bit (`switch::search_needless`, the
    // test of `lane::finish_macro_step`: clear of the stator in free flight, held in
    // contact below the lane's largest penetration), the samples are not computed at
    // all. The test runs for all 8 lanes at once, in a loop without branches that the
    // compiler vectorises (stopping at the first lane that failed, a serial loop, held
    // 8 % of the 1k-lane bench row's samples in perf).
    let mut needless = [false; BATCH];
    for l in 0..BATCH {
        needless[l] = search_needless(
            bc.c.delta[l],
            &lane_of(x, l),
            &lane_of(x1, l),
            ds[l] * bc.h[l],
            contact[l],
            part[l].max_pen,
        );
    }
    let mut search = false;
    for l in 0..BATCH {
        search |= active[l] & !needless[l];
    }
    // The switch search of `lane::find_switch`, kept only as far as deciding that
    // there is no switch: any sample on the wrong side, or an extremum heading
    // there, sends the lane to the scalar path. Decided without a sqrt or a division
    // per sample (`switch::hermite_sq`): g = sqrt(|d|^2) - delta and both roundings are
    // monotone, so a sample is on the wrong side exactly when the largest (free flight)
    // or smallest (contact) |d|^2 of the samples is, and the samples' largest g,
    // `find_switch`'s max_g on a step without a switch, is that of their largest |d|^2
    // (NaNs are skipped by max and min as there). A rate (d . d')/|d| has the sign of
    // d . d' unless the quotient underflows to 0, where `toward` here holds and
    // `find_switch`'s does not: the lane is then handed over needlessly, never kept
    // wrongly. On the 2-core VM's bench (f64, 16k lanes, three rounds back to back)
    // this took 2.57e7 to 2.67e7 lane-steps/s.
    let mut max_g = [zero; BATCH];
    let mut switch = [false; BATCH];
    if search {
        let (sq0, mut dot_lo) = samples(bc, x, x1, ds, zero);
        let mut sq_hi = [R::lit(f64::NEG_INFINITY); BATCH];
        let mut sq_lo = [R::lit(f64::INFINITY); BATCH];
        for j in 1..=GRAZE_SAMPLES {
            let th = R::lit(j as f64 / GRAZE_SAMPLES as f64);
            let (sq_th, dot_th) = samples(bc, x, x1, ds, th);
            // Both headings formed and the mode's selected, without `&&` or a branch
            // per lane: written with them, this loop compiled to a compare and jump per
            // lane with |d|^2's extremes kept lane by lane in scalar registers.
            for l in 0..BATCH {
                // A largest |d| between the samples (free flight heads to the stator),
                // a smallest (contact heads away).
                let peak = (dot_lo[l] > zero) & (dot_th[l] < zero);
                let dip = (dot_lo[l] < zero) & (dot_th[l] > zero);
                switch[l] |= (contact[l] & dip) | (!contact[l] & peak);
                sq_hi[l] = sq_hi[l].max(sq_th[l]);
                sq_lo[l] = sq_lo[l].min(sq_th[l]);
            }
            dot_lo = dot_th;
        }
        for l in 0..BATCH {
            let delta = bc.c.delta[l];
            switch[l] |= if contact[l] {
                sq_lo[l].sqrt() <= delta
            } else {
                sq_hi[l].sqrt() > delta
            };
            max_g[l] = sq0[l].max(sq_hi[l]).sqrt() - delta;
        }
    }
    (search, switch, max_g)
}

/// The end of a batch's macro step: lanes done go through the checks and counters, lanes
/// handed over finish in the scalar stepper, lanes behind (frozen earlier) step alone.
#[inline(always)]
fn batch_finish<R: Real, const M: usize>(
    lc: &[LaneConsts<R>; BATCH],
    lane: &mut [Lane<R>; BATCH],
    tan: &mut [Tangent<R, M>; BATCH],
    k: u32,
    part: &[MacroStep<R>; BATCH],
    trial: &[[R; STATE_DIM]; BATCH],
) {
    for l in 0..BATCH {
        if lane[l].status.is_frozen() {
            continue;
        }
        if lane[l].k != k {
            macro_step_tangent(&lc[l], &mut lane[l], &mut tan[l]);
            continue;
        }
        if part[l].s >= R::lit(1.0) {
            // Done: only the checks and counters are left.
            macro_step_end(&lc[l], &mut lane[l], &part[l]);
        } else {
            // Handed over: the scalar stepper takes up the trial sub-step at s (the
            // batch's, the bits it would compute) and locates the switch.
            finish_macro_step(&lc[l], &mut lane[l], &mut tan[l], part[l], Some(trial[l]));
        }
    }
}
