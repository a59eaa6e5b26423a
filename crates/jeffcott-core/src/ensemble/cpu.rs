//! The CPU backend: rayon over batches of lanes, each batch advanced by the SIMD batch
//! stepper (`integrate::batch`, which falls back to the scalar lane stepper that the
//! GPU kernel mirrors for every step with a contact switch, and equals it to the bit).
//! Lanes are independent and each batch is integrated by one thread from start to
//! end, so the result is bit-identical for any number of threads. The batch code is
//! compiled again for AVX2 and for AVX-512 and the copy to run chosen at run time
//! (`crate::dispatch`); every copy gives the same bits.

use super::early::{EarlyExit, EarlyResult};
use super::refill::{Ended, Refill, SlotLane, early_result};
use super::{EnsembleResult, EnsembleSpec, LaneResult, Precision};
use crate::control::{Cancel, Control};
use crate::error::{Error, Result};
use crate::integrate::batch::{
    BATCH, BatchConsts, ForcingTable, GroupScratch, batch_macro_step_tangent,
    group_macro_step_tangent,
};
use crate::integrate::lane::{
    LAMBDA1_START, Lane, LaneConsts, Tangent, advance_period, advance_period_tangent, renormalise,
};
use crate::model::STATE_DIM;
use crate::real::Real;
use rayon::prelude::*;

fn run_lane<R: Real>(spec: &EnsembleSpec, i: usize, cancel: &Cancel) -> Option<LaneResult> {
    let lc = spec.lane_consts::<R>(i);
    let mut lane = spec.initial_lane::<R>(i);
    for _ in 0..spec.transient {
        if lane.status.is_frozen() {
            break;
        }
        if cancel.is_set() {
            return None;
        }
        advance_period(&lc, &mut lane);
    }
    let mut points = Vec::with_capacity(spec.recorded as usize * STATE_DIM);
    for _ in 0..spec.recorded {
        if cancel.is_set() {
            return None;
        }
        advance_period(&lc, &mut lane);
        // A frozen lane repeats the state it froze at, as on the GPU; the host replaces
        // those rows by NaN afterwards (`mask_frozen_records`).
        points.extend(lane.x.iter().map(|v| v.to_f64()));
    }
    Some(LaneResult {
        points,
        final_state: lane.state_f64(),
        status: lane.status,
        counters: lane.counters,
        lambda1: f64::NAN,
    })
}

/// `run_lane` with a tangent vector, as the kernel's lambda_1 variant: renormalised at
/// the end of every period the lane completes, its growth kept over recorded periods.
fn run_lane_lambda1<R: Real>(spec: &EnsembleSpec, i: usize, cancel: &Cancel) -> Option<LaneResult> {
    let lc = spec.lane_consts::<R>(i);
    let mut lane = spec.initial_lane::<R>(i);
    let mut tan = fresh_tangent::<R, 1>();
    let mut points = Vec::with_capacity(spec.recorded as usize * STATE_DIM);
    let mut norms = Vec::with_capacity(spec.recorded as usize);
    // The tangent starts (untouched until then) `lyapunov_align` periods before the
    // record; the state's arithmetic is the same with it or without.
    let from = spec.stepper.tangent_from(spec.transient);
    for p in 0..spec.transient + spec.recorded {
        if p < spec.transient && lane.status.is_frozen() {
            continue;
        }
        if cancel.is_set() {
            return None;
        }
        if p < from {
            advance_period(&lc, &mut lane);
            continue;
        }
        advance_period_tangent(&lc, &mut lane, &mut tan);
        let norm = if lane.status.is_frozen() {
            1.0
        } else {
            renormalise(&mut tan.v[0]).to_f64()
        };
        if p >= spec.transient {
            points.extend(lane.x.iter().map(|v| v.to_f64()));
            norms.push(norm);
        }
    }
    Some(LaneResult {
        points,
        final_state: lane.state_f64(),
        status: lane.status,
        counters: lane.counters,
        lambda1: super::lane_lambda1(&norms, spec.lanes[i].omega, lane.status),
    })
}

/// Lanes `first..first + batches * BATCH` through the batch stepper, `batches` batches
/// stepped as one group (`group_macro_step_tangent`: full batches for the sub-steps
/// after the first); with `M = 1` also a tangent vector per lane for lambda_1,
/// renormalised after every period exactly as `run_lane_lambda1` does (same bits:
/// `tests/ensemble_cpu.rs`).
#[inline(always)]
fn run_batch_inner<R: Real, const M: usize, const AVX512: bool>(
    spec: &EnsembleSpec,
    first: usize,
    batches: usize,
    cancel: &Cancel,
) -> Vec<LaneResult> {
    let lane_of = |b: usize, l: usize| first + b * BATCH + l;
    let lc: Vec<[LaneConsts<R>; BATCH]> = (0..batches)
        .map(|b| std::array::from_fn(|l| spec.lane_consts(lane_of(b, l))))
        .collect();
    // The forcing table of the group's first lane (f64; the process's shared one), for
    // every batch it serves.
    let forcing = ForcingTable::for_batches(&lc[0][0]);
    let bc: Vec<BatchConsts<R>> = lc.iter().map(|l| BatchConsts::new(l, forcing)).collect();
    let mut lanes: Vec<[Lane<R>; BATCH]> = (0..batches)
        .map(|b| std::array::from_fn(|l| spec.initial_lane(lane_of(b, l))))
        .collect();
    let mut tan: Vec<[Tangent<R, M>; BATCH]> = (0..batches)
        .map(|_| std::array::from_fn(|_| fresh_tangent()))
        .collect();
    let mut scratch = GroupScratch::default();
    let n = spec.stepper.steps_per_period;
    let count = batches * BATCH;
    let mut points: Vec<Vec<f64>> = (0..count)
        .map(|_| Vec::with_capacity(spec.recorded as usize * STATE_DIM))
        .collect();
    let mut norms: Vec<Vec<f64>> = vec![Vec::new(); count];
    // With lambda_1 the tangents start (untouched until then, so fresh) `lyapunov_align`
    // periods before the record, as in `run_lane_lambda1`; before that the group steps
    // without them.
    let from = if M > 0 {
        spec.stepper.tangent_from(spec.transient)
    } else {
        0
    };
    let mut no_tan: Vec<[Tangent<R, 0>; BATCH]> = (0..batches)
        .map(|_| std::array::from_fn(|_| Tangent::new([])))
        .collect();
    for p in 0..spec.transient + spec.recorded {
        let recording = p >= spec.transient;
        if !recording && lanes.iter().flatten().all(|l| l.status.is_frozen()) {
            continue;
        }
        // Once per period (500 macro steps of the group's lanes): a cancelled group
        // stops within a period and returns nothing.
        if cancel.is_set() {
            return Vec::new();
        }
        if p < from {
            for _ in 0..n {
                group_macro_step_tangent::<R, 0, AVX512>(
                    &bc,
                    &lc,
                    &mut lanes,
                    &mut no_tan,
                    &mut scratch,
                );
            }
            continue;
        }
        for _ in 0..n {
            group_macro_step_tangent::<R, M, AVX512>(&bc, &lc, &mut lanes, &mut tan, &mut scratch);
        }
        period_end(&lanes, &mut tan, recording, &mut norms, &mut points);
    }
    lane_results::<R, M>(spec, first, lanes, points, norms)
}

/// The end of a period of [`run_batch_inner`]: each lane's tangent renormalised (its
/// norm kept while recording) and, while recording, its Poincare point.
#[inline(always)]
fn period_end<R: Real, const M: usize>(
    lanes: &[[Lane<R>; BATCH]],
    tan: &mut [[Tangent<R, M>; BATCH]],
    recording: bool,
    norms: &mut [Vec<f64>],
    points: &mut [Vec<f64>],
) {
    for (i, (lane, t)) in lanes
        .iter()
        .flatten()
        .zip(tan.iter_mut().flatten())
        .enumerate()
    {
        if M > 0 {
            // A lane frozen before this period is skipped by `run_lane_lambda1` in
            // the transient; it is frozen now too, so it is not renormalised here
            // either, and its 1.0 is kept only when recording, as there.
            let norm = if lane.status.is_frozen() {
                1.0
            } else {
                renormalise(&mut t.v[0]).to_f64()
            };
            if recording {
                norms[i].push(norm);
            }
        }
        if recording {
            points[i].extend(lane.x.iter().map(|v| v.to_f64()));
        }
    }
}

/// The results of the lanes of [`run_batch_inner`] from lane `first` on: their points,
/// final states and counters, and lambda_1 from their tangents' norms when `M > 0`.
#[inline(always)]
fn lane_results<R: Real, const M: usize>(
    spec: &EnsembleSpec,
    first: usize,
    lanes: Vec<[Lane<R>; BATCH]>,
    points: Vec<Vec<f64>>,
    norms: Vec<Vec<f64>>,
) -> Vec<LaneResult> {
    points
        .into_iter()
        .zip(lanes.into_iter().flatten())
        .zip(norms)
        .enumerate()
        .map(|(i, ((points, lane), norms))| LaneResult {
            points,
            final_state: lane.state_f64(),
            status: lane.status,
            counters: lane.counters,
            lambda1: if M > 0 {
                super::lane_lambda1(&norms, spec.lanes[first + i].omega, lane.status)
            } else {
                f64::NAN
            },
        })
        .collect()
}

/// Batches stepped together at most (`group_macro_step_tangent`): 16 x 8 lanes, so that
/// the lanes still in contact after a first pass fill whole batches. On the 2-core VM's
/// bench (16k lanes) groups of 16 were 3 % faster than of 8, and 32 another 1-2 %.
const GROUP_BATCHES: usize = 16;

per_instruction_set! {
    /// Lanes `first..first + batches * BATCH`, with AVX2 where the CPU has it (AVX-512
    /// on an AMD CPU or on request).
    fn run_batch[R: Real, const M: usize][R, M](
        spec: &EnsembleSpec,
        first: usize,
        batches: usize,
        cancel: &Cancel,
    ) -> Vec<LaneResult> = run_batch_inner, avx512_on_amd: true, tells_avx512
}

/// Runs the ensemble on the CPU with rayon's global pool, with each lane's largest
/// Lyapunov exponent (`EnsembleResult::lambda1`, exactly as the GPU kernel's lambda_1
/// variant computes it) when `lambda1`. `ctl.progress` is called with the lane-periods
/// finished so far (from worker threads); `ctl.cancel` is checked before every batch of
/// [`BATCH`] lanes and by every batch once per forcing period, so a cancelled run
/// returns [`Error::Interrupted`] within about a period's time of one batch
/// (milliseconds).
pub fn run(spec: &EnsembleSpec, lambda1: bool, ctl: Control) -> Result<EnsembleResult> {
    spec.validate()?;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let n = spec.lanes.len();
    let per_lane = (spec.transient + spec.recorded) as u64;
    let total = n as u64 * per_lane;
    // Whole batches through the batch stepper in groups (at most GROUP_BATCHES, fewer
    // when there would be fewer than 8 groups per thread: with 4, the bifurcation
    // diagram's 50 batches left a thread idle at the end, 175 % CPU against 183 %), the
    // remainder lane by lane (0 batches).
    let batches = n / BATCH;
    let group = (batches / (8 * rayon::current_num_threads())).clamp(1, GROUP_BATCHES);
    let tasks: Vec<(usize, usize)> = (0..batches)
        .step_by(group)
        .map(|b| (b * BATCH, group.min(batches - b)))
        .chain((batches * BATCH..n).map(|i| (i, 0)))
        .collect();
    let task_count = tasks.len();
    // Every task may go to its own thread: a small ensemble (a map's unit of 3 cells x 8
    // start states is 3 batches) ran on one core while rayon kept pairs of tasks
    // together (`with_min_len(2)`, removed: a map of 48 cells took 20.8 s at 100 % CPU).
    let outcomes: Vec<Vec<LaneResult>> = tasks
        .into_par_iter()
        .map(|(first, batches)| {
            let c = ctl.cancel;
            if c.is_set() {
                return Vec::new();
            }
            let o = match (spec.precision, batches > 0, lambda1) {
                (Precision::F32, true, false) => run_batch::<f32, 0>(spec, first, batches, c),
                (Precision::F64, true, false) => run_batch::<f64, 0>(spec, first, batches, c),
                (Precision::F32, true, true) => run_batch::<f32, 1>(spec, first, batches, c),
                (Precision::F64, true, true) => run_batch::<f64, 1>(spec, first, batches, c),
                (Precision::F32, _, false) => run_lane::<f32>(spec, first, c).into_iter().collect(),
                (Precision::F64, _, false) => run_lane::<f64>(spec, first, c).into_iter().collect(),
                (Precision::F32, _, true) => run_lane_lambda1::<f32>(spec, first, c)
                    .into_iter()
                    .collect(),
                (Precision::F64, _, true) => run_lane_lambda1::<f64>(spec, first, c)
                    .into_iter()
                    .collect(),
            };
            let k = o.len();
            let lanes = done.fetch_add(k, std::sync::atomic::Ordering::Relaxed) + k;
            (ctl.progress)(lanes as u64 * per_lane, total);
            o
        })
        .collect();
    let finished = outcomes.iter().filter(|o| !o.is_empty()).count();
    if finished < task_count {
        // Some batch was skipped: the flag was set. Nothing of this ensemble is kept
        // (its lanes are one unit of work to the run engine).
        return Err(Error::Interrupted {
            committed: 0,
            total: 1,
        });
    }
    let outcomes = outcomes.into_iter().flatten();
    let mut res = EnsembleResult::with_capacity(spec.lanes.len(), spec.recorded, lambda1);
    for o in outcomes {
        o.append_to(&mut res);
    }
    super::mask_frozen_records(spec, &mut res);
    Ok(res)
}

/// One refilled batch of [`BATCH`] slots (`run_refill_inner`): the slots' lanes, their
/// constants and tangents (`M` per lane), and the batch constants, rebuilt when a slot
/// takes another lane.
struct Bank<'t, R: Real, const M: usize> {
    lc: [LaneConsts<R>; BATCH],
    state: [Lane<R>; BATCH],
    slot: [Option<SlotLane>; BATCH],
    tan: [Tangent<R, M>; BATCH],
    bc: BatchConsts<'t, R>,
    forcing: Option<&'t ForcingTable<R>>,
    changed: bool,
}

impl<'t, R: Real, const M: usize> Bank<'t, R, M> {
    #[inline(always)]
    fn new(lc: LaneConsts<R>, forcing: Option<&'t ForcingTable<R>>) -> Self {
        let lc: [LaneConsts<R>; BATCH] = std::array::from_fn(|_| lc);
        Bank {
            bc: BatchConsts::new(&lc, forcing),
            lc,
            state: std::array::from_fn(|_| placeholder()),
            slot: std::array::from_fn(|_| None),
            tan: std::array::from_fn(|_| fresh_tangent()),
            forcing,
            changed: false,
        }
    }

    #[inline(always)]
    fn live(&self) -> usize {
        self.slot.iter().filter(|s| s.is_some()).count()
    }

    #[inline(always)]
    fn free(&self) -> Option<usize> {
        self.slot.iter().position(Option::is_none)
    }

    /// Puts `s` (constants `lc`, at `state`) into free slot `l` with a fresh tangent.
    #[inline(always)]
    fn load(&mut self, l: usize, (s, lc, state): Moving<R>) {
        self.slot[l] = Some(s);
        self.lc[l] = lc;
        self.state[l] = state;
        self.tan[l] = fresh_tangent();
        self.changed = true;
    }

    /// Empties slot `l`, handing back what it held.
    #[inline(always)]
    fn take(&mut self, l: usize) -> Option<Moving<R>> {
        let s = self.slot[l].take()?;
        let state = std::mem::replace(&mut self.state[l], placeholder());
        self.changed = true;
        Some((s, self.lc[l], state))
    }

    /// The period end of every lane in the batch (`Refill::period_end`): lanes that end
    /// go into `out`; with `to_window`, lanes whose tangent window begins leave for it.
    #[inline(always)]
    fn period_ends(
        &mut self,
        refill: &Refill,
        out: &mut Vec<Ended>,
        mut to_window: Option<&mut std::collections::VecDeque<Moving<R>>>,
    ) {
        for l in 0..BATCH {
            let Some(s) = self.slot[l].as_mut() else {
                continue;
            };
            let lane = &self.state[l];
            let frozen = lane.status.is_frozen();
            // As `run_batch_inner`: a frozen lane is not renormalised (it ends here). A
            // batch without tangents keeps no growth: its lanes record none (their
            // window begins before their record).
            let norm = if M == 0 || frozen {
                1.0
            } else {
                renormalise(&mut self.tan[l].v[0]).to_f64()
            };
            let x = lane.state_f64();
            if let Some(retired) = refill.period_end(s, &x, frozen, norm) {
                let (s, _, lane) = self.take(l).expect("occupied slot");
                out.push(refill.ended(s, retired, x, lane.status, lane.counters));
            } else if let Some(w) = to_window.as_deref_mut()
                && refill.needs_tangent(s)
            {
                w.push_back(self.take(l).expect("occupied slot"));
            }
        }
    }

    /// One forcing period of the batch's lanes. Inlined into `run_refill_inner`, so
    /// that it is compiled for the instruction set its caller was (`per_instruction_set!`).
    #[inline(always)]
    fn step_period<const AVX512: bool>(&mut self, n: u32) {
        if self.changed {
            self.bc = BatchConsts::new(&self.lc, self.forcing);
            self.changed = false;
        }
        for _ in 0..n {
            batch_macro_step_tangent::<R, M, AVX512>(
                &self.bc,
                &self.lc,
                &mut self.state,
                &mut self.tan,
            );
        }
    }
}

/// A slot lane between slots: its bookkeeping, constants and state.
type Moving<R> = (SlotLane, LaneConsts<R>, Lane<R>);

/// An empty slot's lane: frozen, so the batch stepper skips it.
fn placeholder<R: Real>() -> Lane<R> {
    Lane::<R>::new(&[f64::NAN; STATE_DIM], 0.0)
}

/// `M` tangent vectors as every lambda_1 lane starts them, along (1, ..., 1).
fn fresh_tangent<R: Real, const M: usize>() -> Tangent<R, M> {
    Tangent::new([[R::lit(LAMBDA1_START); STATE_DIM]; M])
}

/// Lanes `lanes` of `spec` through refilled batches of [`BATCH`] slots, each slot
/// refilled with the next lane as soon as its lane retires (recognised by `early`),
/// froze, or finished its periods (`refill::Refill`, the bookkeeping a GPU's slot pool
/// shares); empty slots hold a frozen placeholder, which the batch stepper skips. Every
/// lane starts at a period boundary (`Lane::k` = 0), so each lane's arithmetic is that
/// of `run_batch_inner` and `run_lane` to the bit, whichever slot and batch it runs in.
/// With `M = 1` a tangent vector per slot gives each lane's lambda_1 over its record,
/// renormalised after every period as `run_lane_lambda1` does (a retired lane has
/// none: NaN). The tangent starts only `lyapunov_align` periods before a lane's record
/// (`Refill::needs_tangent`), and lanes start at different periods, so two batches run
/// side by side: one without tangents for lanes before their window, one with them,
/// which a lane enters (its tangent fresh) when its window begins. The one with
/// tangents steps when its slots are full or the other has no lane; so neither
/// computes tangents for lanes that need none.
#[inline(always)]
fn run_refill_inner<R: Real, const M: usize, const AVX512: bool>(
    spec: &EnsembleSpec,
    early: &EarlyExit,
    lanes: std::ops::Range<usize>,
    cancel: &Cancel,
) -> Option<Vec<Ended>> {
    let mut refill = Refill::new(spec, early, lanes.clone(), M > 0);
    let lc0 = spec.lane_consts::<R>(lanes.start);
    let forcing = ForcingTable::for_batches(&lc0);
    let mut plain = Bank::<R, 0>::new(lc0, forcing);
    let mut with = Bank::<R, M>::new(lc0, forcing);
    // Lanes whose window has begun, waiting for a slot with tangents.
    let mut waiting: std::collections::VecDeque<Moving<R>> = std::collections::VecDeque::new();
    let mut out = Vec::with_capacity(lanes.len());
    let n = spec.stepper.steps_per_period;
    let mut more = true;
    loop {
        if cancel.is_set() {
            return None;
        }
        while let Some(l) = with.free()
            && let Some(m) = waiting.pop_front()
        {
            with.load(l, m);
        }
        // At most a batch of lanes waits (a run whose lanes all start with their
        // tangent would otherwise draw every lane into the queue at once).
        while more && waiting.len() < BATCH {
            let Some(l) = plain.free() else { break };
            let Some(s) = refill.next_lane() else {
                more = false;
                break;
            };
            let i = s.lane;
            let m = (s, spec.lane_consts(i), spec.initial_lane(i));
            if refill.needs_tangent(&m.0) {
                // Window from period 0: straight to the batch with tangents.
                match with.free() {
                    Some(w) => with.load(w, m),
                    None => waiting.push_back(m),
                }
            } else {
                plain.load(l, m);
            }
        }
        let (p_live, w_live) = (plain.live(), with.live());
        if p_live == 0 && w_live == 0 && waiting.is_empty() && !more {
            break;
        }
        if w_live > 0 && (w_live == BATCH || p_live == 0) {
            with.step_period::<AVX512>(n);
            with.period_ends(&refill, &mut out, None);
        } else if p_live > 0 {
            plain.step_period::<AVX512>(n);
            plain.period_ends(&refill, &mut out, Some(&mut waiting));
        }
    }
    Some(out)
}

per_instruction_set! {
    /// Lanes `lanes` through a refilled batch, with AVX2 where the CPU has it (AVX-512 on
    /// an AMD CPU or on request), as the batch code.
    fn run_refill[R: Real, const M: usize][R, M](
        spec: &EnsembleSpec,
        early: &EarlyExit,
        lanes: std::ops::Range<usize>,
        cancel: &Cancel,
    ) -> Option<Vec<Ended>> = run_refill_inner, avx512_on_amd: true, tells_avx512
}

/// Runs the ensemble on the CPU with early exit (`super::early`): lanes recognised by
/// `early` retire and their slots take the next lanes. Lanes are dealt to rayon's
/// threads in runs of consecutive lanes, each run through one refilled batch, so the
/// result is bit-identical for any number of threads; a lane that is not recognised
/// gets exactly the record [`run`] gives it, and with `lambda1` its lambda_1 (a lane
/// recorded early, its lambda_1 over its own record; a retired lane, NaN).
/// `ctl.progress` counts a finished lane as its full periods, so the total is the run
/// without early exit; cancellation as in [`run`].
pub fn run_early(
    spec: &EnsembleSpec,
    early: &EarlyExit,
    lambda1: bool,
    ctl: Control,
) -> Result<EarlyResult> {
    spec.validate()?;
    let n = spec.lanes.len();
    let per_lane = (spec.transient + spec.recorded) as u64;
    let total = n as u64 * per_lane;
    // Long runs keep a batch's slots full (its slots empty only when its run is used up),
    // short ones share the lanes evenly: twice as many runs as threads, at least a batch.
    let threads = rayon::current_num_threads().max(1);
    let run_len = n.div_ceil(2 * threads).max(BATCH);
    let runs: Vec<std::ops::Range<usize>> = (0..n.div_ceil(run_len))
        .map(|r| r * run_len..((r + 1) * run_len).min(n))
        .collect();
    let done = std::sync::atomic::AtomicUsize::new(0);
    let outcomes: Vec<Option<Vec<Ended>>> = runs
        .into_par_iter()
        .map(|lanes| {
            let c = ctl.cancel;
            if c.is_set() {
                return None;
            }
            let o = match (spec.precision, lambda1) {
                (Precision::F32, false) => run_refill::<f32, 0>(spec, early, lanes, c),
                (Precision::F64, false) => run_refill::<f64, 0>(spec, early, lanes, c),
                (Precision::F32, true) => run_refill::<f32, 1>(spec, early, lanes, c),
                (Precision::F64, true) => run_refill::<f64, 1>(spec, early, lanes, c),
            }?;
            let k = o.len();
            let lanes = done.fetch_add(k, std::sync::atomic::Ordering::Relaxed) + k;
            (ctl.progress)(lanes as u64 * per_lane, total);
            Some(o)
        })
        .collect();
    let mut all: Vec<Ended> = Vec::with_capacity(n);
    for o in outcomes {
        let Some(o) = o else {
            return Err(Error::Interrupted {
                committed: 0,
                total: 1,
            });
        };
        all.extend(o);
    }
    Ok(early_result(spec, all, lambda1))
}
