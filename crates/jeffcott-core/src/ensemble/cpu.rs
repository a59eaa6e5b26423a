//! The CPU backend: rayon over batches of lanes, each batch advanced by the SIMD batch
//! stepper (`integrate::batch`, which falls back to the scalar lane stepper that the
//! GPU kernel mirrors for every step with a contact switch, and equals it to the bit).
//! Lanes are independent and each batch is integrated by one thread from start to
//! end, so the result is bit-identical for any number of threads. Where the CPU has
//! AVX2 the batch code is compiled a second time for it and chosen at run time.

use super::early::{EarlyExit, EarlyResult, Retired, Then, Track};
use super::{EnsembleResult, EnsembleSpec, Precision};
use crate::control::{Cancel, Control};
use crate::error::{Error, Result};
use crate::integrate::batch::{
    BATCH, BatchConsts, ForcingTable, GroupScratch, batch_macro_step_tangent,
    group_macro_step_tangent,
};
use crate::integrate::lane::{
    Counters, LAMBDA1_START, Lane, LaneConsts, Status, Tangent, advance_period,
    advance_period_tangent, renormalise,
};
use crate::model::{STATE_DIM, State};
use crate::real::Real;
use rayon::prelude::*;

/// What one lane produced.
struct Outcome {
    points: Vec<f64>,
    final_state: State,
    status: Status,
    counters: Counters,
    lambda1: f64,
}

impl Outcome {
    /// Appends this lane to `res` (its lambda_1 where `res` keeps them).
    fn append_to(self, res: &mut EnsembleResult) {
        if let Some(l) = res.lambda1.as_mut() {
            l.push(self.lambda1);
        }
        res.poincare.extend_from_slice(&self.points);
        res.final_state.push(self.final_state);
        res.status.push(self.status);
        res.counters.push(self.counters);
    }
}

fn run_lane<R: Real>(spec: &EnsembleSpec, i: usize, cancel: &Cancel) -> Option<Outcome> {
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
    Some(Outcome {
        points,
        final_state: lane.state_f64(),
        status: lane.status,
        counters: lane.counters,
        lambda1: f64::NAN,
    })
}

/// `run_lane` with a tangent vector, as the kernel's lambda_1 variant: renormalised at
/// the end of every period the lane completes, its growth kept over recorded periods.
fn run_lane_lambda1<R: Real>(spec: &EnsembleSpec, i: usize, cancel: &Cancel) -> Option<Outcome> {
    let lc = spec.lane_consts::<R>(i);
    let mut lane = spec.initial_lane::<R>(i);
    let mut tan = Tangent::<R, 1>::new([[R::lit(LAMBDA1_START); STATE_DIM]]);
    let mut points = Vec::with_capacity(spec.recorded as usize * STATE_DIM);
    let mut norms = Vec::with_capacity(spec.recorded as usize);
    for p in 0..spec.transient + spec.recorded {
        if p < spec.transient && lane.status.is_frozen() {
            continue;
        }
        if cancel.is_set() {
            return None;
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
    Some(Outcome {
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
fn run_batch_inner<R: Real, const M: usize>(
    spec: &EnsembleSpec,
    first: usize,
    batches: usize,
    cancel: &Cancel,
) -> Vec<Outcome> {
    let lane_of = |b: usize, l: usize| first + b * BATCH + l;
    let lc: Vec<[LaneConsts<R>; BATCH]> = (0..batches)
        .map(|b| std::array::from_fn(|l| spec.lane_consts(lane_of(b, l))))
        .collect();
    // The forcing table of the group's first lane (f64), for every batch it serves (a
    // few thousand phasors, against three per lane-sub-step of the group's run).
    let forcing = ForcingTable::for_batches(&lc[0][0]);
    let bc: Vec<BatchConsts<R>> = lc
        .iter()
        .map(|l| BatchConsts::new(l, forcing.as_ref()))
        .collect();
    let mut lanes: Vec<[Lane<R>; BATCH]> = (0..batches)
        .map(|b| std::array::from_fn(|l| spec.initial_lane(lane_of(b, l))))
        .collect();
    let mut tan: Vec<[Tangent<R, M>; BATCH]> = (0..batches)
        .map(|_| std::array::from_fn(|_| Tangent::new([[R::lit(LAMBDA1_START); STATE_DIM]; M])))
        .collect();
    let mut scratch = GroupScratch::default();
    let n = spec.stepper.steps_per_period;
    let count = batches * BATCH;
    let mut points: Vec<Vec<f64>> = (0..count)
        .map(|_| Vec::with_capacity(spec.recorded as usize * STATE_DIM))
        .collect();
    let mut norms: Vec<Vec<f64>> = vec![Vec::new(); count];
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
        for _ in 0..n {
            group_macro_step_tangent(&bc, &lc, &mut lanes, &mut tan, &mut scratch);
        }
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
    points
        .into_iter()
        .zip(lanes.into_iter().flatten())
        .zip(norms)
        .enumerate()
        .map(|(i, ((points, lane), norms))| Outcome {
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

/// Declares `$name`, which runs `$inner` compiled for AVX-512 where asked for and the CPU
/// has it ([`use_avx512`]), else for AVX2 where the CPU has it, else as built: the same
/// code for each instruction set (no FMA: fusing would change the rounding), so the
/// lanes' arithmetic cannot drift between them. `[$gen]` are the generic parameters,
/// `[$arg]` the arguments `$inner` is instantiated with.
macro_rules! per_instruction_set {
    ($(#[$doc:meta])* fn $name:ident [$($gen:tt)*] [$($garg:tt)*]
     ($($arg:ident: $ty:ty),* $(,)?) -> $ret:ty = $inner:ident) => {
        $(#[$doc])*
        fn $name<$($gen)*>($($arg: $ty),*) -> $ret {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx512f,avx512dq,avx512vl")]
                fn avx512<$($gen)*>($($arg: $ty),*) -> $ret {
                    $inner::<$($garg)*>($($arg),*)
                }
                #[target_feature(enable = "avx2")]
                fn avx2<$($gen)*>($($arg: $ty),*) -> $ret {
                    $inner::<$($garg)*>($($arg),*)
                }
                if use_avx512() {
                    // SAFETY: the CPU has been found to support AVX-512 F, DQ and VL.
                    return unsafe { avx512::<$($garg)*>($($arg),*) };
                }
                if std::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has just been found to support AVX2.
                    return unsafe { avx2::<$($garg)*>($($arg),*) };
                }
            }
            $inner::<$($garg)*>($($arg),*)
        }
    };
}

/// Whether the AVX-512 batch code runs: asked for with `JEFFCOTT_AVX512=1`, and the CPU
/// has it. One 512-bit register then holds the 8 f64 lanes of a batch; on the 2-core
/// Xeon it was measured on it was 8 % slower than AVX2 on `jeffcott bench`'s workload
/// and on a W sweep (docs/performance.md), so AVX2 stays the default.
#[cfg(target_arch = "x86_64")]
fn use_avx512() -> bool {
    static USE: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *USE.get_or_init(|| {
        std::is_x86_feature_detected!("avx512f")
            && std::is_x86_feature_detected!("avx512dq")
            && std::is_x86_feature_detected!("avx512vl")
            && std::env::var_os("JEFFCOTT_AVX512").is_some_and(|v| v == "1")
    })
}

per_instruction_set! {
    /// Lanes `first..first + batches * BATCH`, with AVX2 where the CPU has it (AVX-512
    /// on request).
    fn run_batch[R: Real, const M: usize][R, M](
        spec: &EnsembleSpec,
        first: usize,
        batches: usize,
        cancel: &Cancel,
    ) -> Vec<Outcome> = run_batch_inner
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
    let outcomes: Vec<Vec<Outcome>> = tasks
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

/// A lane that ended: its index, its outcome, whether it was recognised, and the periods
/// before its record (the transient, or fewer when recorded early).
type Ended = (usize, Outcome, Option<Retired>, u32);

/// A slot of a refilled batch: the lane in it and what that lane has gathered.
struct SlotLane {
    /// Index of the lane in the ensemble.
    lane: usize,
    /// Periods integrated.
    periods: u32,
    /// Its recognition so far.
    track: Track,
    /// Its recorded points.
    points: Vec<f64>,
    /// Periods before its record: the transient, or the period it was recognised at
    /// ([`Then::Record`]).
    record_from: u32,
    /// The attractor it was recognised on ([`Then::Record`]: it is recording).
    recognised: Option<u32>,
    /// The tangent's growth over each recorded period (with lambda_1).
    norms: Vec<f64>,
}

/// Lanes `lanes` of `spec` through one batch of [`BATCH`] slots, each slot refilled
/// with the next lane as soon as its lane retires (recognised by `early`), froze, or
/// finished its periods; empty slots hold a frozen placeholder, which the batch
/// stepper skips. Every lane starts at a period boundary (`Lane::k` = 0), so each
/// lane's arithmetic is that of `run_batch_inner` and `run_lane` to the bit; with
/// `M = 1` a tangent vector per slot gives each lane's lambda_1 over its record, renormalised
/// after every period as `run_lane_lambda1` does (a retired lane has none: NaN).
#[inline(always)]
fn run_refill_inner<R: Real, const M: usize>(
    spec: &EnsembleSpec,
    early: &EarlyExit,
    lanes: std::ops::Range<usize>,
    cancel: &Cancel,
) -> Option<Vec<Ended>> {
    let record_len = spec.recorded as usize * STATE_DIM;
    let mut queue = lanes.clone();
    let placeholder = || Lane::<R>::new(&[f64::NAN; STATE_DIM], 0.0);
    let mut lc: [LaneConsts<R>; BATCH] = std::array::from_fn(|_| spec.lane_consts(lanes.start));
    let mut state: [Lane<R>; BATCH] = std::array::from_fn(|_| placeholder());
    let mut slot: [Option<SlotLane>; BATCH] = std::array::from_fn(|_| None);
    let fresh = || Tangent::<R, M>::new([[R::lit(LAMBDA1_START); STATE_DIM]; M]);
    let mut tan: [Tangent<R, M>; BATCH] = std::array::from_fn(|_| fresh());
    let mut load = |l: usize,
                    lc: &mut [LaneConsts<R>; BATCH],
                    state: &mut [Lane<R>; BATCH],
                    tan: &mut [Tangent<R, M>; BATCH],
                    slot: &mut [Option<SlotLane>; BATCH]| {
        slot[l] = queue.next().map(|i| {
            lc[l] = spec.lane_consts(i);
            state[l] = spec.initial_lane(i);
            tan[l] = fresh();
            SlotLane {
                lane: i,
                periods: 0,
                track: Track::default(),
                points: Vec::with_capacity(record_len),
                record_from: spec.transient,
                recognised: None,
                norms: Vec::with_capacity(if M > 0 { spec.recorded as usize } else { 0 }),
            }
        });
        if slot[l].is_none() {
            state[l] = placeholder();
        }
    };
    for l in 0..BATCH {
        load(l, &mut lc, &mut state, &mut tan, &mut slot);
    }
    let forcing = ForcingTable::for_batches(&lc[0]);
    let mut bc = BatchConsts::new(&lc, forcing.as_ref());
    let mut out = Vec::with_capacity(lanes.len());
    let n = spec.stepper.steps_per_period;
    while slot.iter().any(Option::is_some) {
        if cancel.is_set() {
            return None;
        }
        for _ in 0..n {
            batch_macro_step_tangent(&bc, &lc, &mut state, &mut tan);
        }
        let mut refilled = false;
        for l in 0..BATCH {
            let Some(s) = slot[l].as_mut() else {
                continue;
            };
            s.periods += 1;
            let lane = &state[l];
            let x = lane.state_f64();
            if s.periods > s.record_from {
                s.points.extend_from_slice(&x);
            }
            if M > 0 {
                // As `run_batch_inner`: a frozen lane is not renormalised (it ends here).
                let norm = if lane.status.is_frozen() {
                    1.0
                } else {
                    renormalise(&mut tan[l].v[0]).to_f64()
                };
                if s.periods > s.record_from {
                    s.norms.push(norm);
                }
            }
            // Recognised at this period: retire now, or record from here on.
            let now = (s.recognised.is_none()
                && !lane.status.is_frozen()
                && early.looks_at(s.periods, spec.transient))
            .then(|| early.recognise.observe(s.lane, &mut s.track, &x))
            .flatten();
            if let (Some(a), Then::Record) = (now, early.then) {
                s.record_from = s.periods;
                s.recognised = Some(a);
            }
            // A lane recorded early counts the periods of its whole record, also when it
            // froze during it (as the replay of a GPU's records counts it).
            let recorded_early = |s: &SlotLane| {
                s.recognised.map(|a| Retired {
                    attractor: a,
                    periods: s.record_from + spec.recorded,
                })
            };
            let ended = if lane.status.is_frozen() {
                // A frozen lane repeats the state it froze at in every later record, as
                // in `run_lane` (the host masks those rows afterwards).
                while s.points.len() < record_len {
                    s.points.extend_from_slice(&x);
                }
                Some(recorded_early(s))
            } else if let (Some(a), Then::Retire) = (now, early.then) {
                Some(Some(Retired {
                    attractor: a,
                    periods: s.periods,
                }))
            } else {
                (s.periods == s.record_from + spec.recorded).then(|| recorded_early(s))
            };
            if let Some(retired) = ended {
                let s = slot[l].take().expect("occupied slot");
                let gone = retired.is_some() && early.then == Then::Retire;
                let points = if gone {
                    vec![f64::NAN; record_len]
                } else {
                    s.points
                };
                let lambda1 = if M > 0 && !gone {
                    super::lane_lambda1(&s.norms, spec.lanes[s.lane].omega, lane.status)
                } else {
                    f64::NAN
                };
                out.push((
                    s.lane,
                    Outcome {
                        points,
                        final_state: x,
                        status: lane.status,
                        counters: lane.counters,
                        lambda1,
                    },
                    retired,
                    s.record_from,
                ));
                load(l, &mut lc, &mut state, &mut tan, &mut slot);
                refilled = true;
            }
        }
        if refilled {
            bc = BatchConsts::new(&lc, forcing.as_ref());
        }
    }
    Some(out)
}

per_instruction_set! {
    /// Lanes `lanes` through a refilled batch, with AVX2 where the CPU has it (AVX-512 on
    /// request), as the batch code.
    fn run_refill[R: Real, const M: usize][R, M](
        spec: &EnsembleSpec,
        early: &EarlyExit,
        lanes: std::ops::Range<usize>,
        cancel: &Cancel,
    ) -> Option<Vec<Ended>> = run_refill_inner
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
    all.sort_unstable_by_key(|(i, _, _, _)| *i);
    let mut res = EnsembleResult::with_capacity(n, spec.recorded, lambda1);
    let mut retired = Vec::with_capacity(n);
    let mut record_from = Vec::with_capacity(n);
    for (_, o, r, from) in all {
        o.append_to(&mut res);
        retired.push(r);
        record_from.push(from);
    }
    super::mask_frozen_records_from(spec, &mut res, |i| record_from[i]);
    Ok(EarlyResult {
        result: res,
        retired,
    })
}
