//! The CPU backend: rayon over batches of lanes, each batch advanced by the SIMD batch
//! stepper (`integrate::batch`, which falls back to the scalar lane stepper that the
//! GPU kernel mirrors for every step with a contact switch, and equals it to the bit).
//! Lanes are independent and each batch is integrated by one thread from start to
//! end, so the result is bit-identical for any number of threads. Where the CPU has
//! AVX2 the batch code is compiled a second time for it and chosen at run time.

use super::{EnsembleResult, EnsembleSpec, Precision};
use crate::error::Result;
use crate::integrate::batch::{BATCH, BatchConsts, batch_macro_step};
use crate::integrate::lane::{Counters, Lane, LaneConsts, Status, advance_period};
use crate::model::{STATE_DIM, State};
use crate::real::Real;
use rayon::prelude::*;

/// What one lane produced.
struct Outcome {
    points: Vec<f64>,
    final_state: State,
    status: Status,
    counters: Counters,
}

fn run_lane<R: Real>(spec: &EnsembleSpec, i: usize) -> Outcome {
    let lc = spec.lane_consts::<R>(i);
    let mut lane = spec.initial_lane::<R>(i);
    for _ in 0..spec.transient {
        if lane.status.is_frozen() {
            break;
        }
        advance_period(&lc, &mut lane);
    }
    let mut points = Vec::with_capacity(spec.recorded as usize * STATE_DIM);
    for _ in 0..spec.recorded {
        advance_period(&lc, &mut lane);
        // A frozen lane repeats the state it froze at, as on the GPU.
        points.extend(lane.x.iter().map(|v| v.to_f64()));
    }
    Outcome {
        points,
        final_state: lane.state_f64(),
        status: lane.status,
        counters: lane.counters,
    }
}

/// Lanes `first..first + BATCH` through the batch stepper.
#[inline(always)]
fn run_batch_inner<R: Real>(spec: &EnsembleSpec, first: usize) -> Vec<Outcome> {
    let lc: [LaneConsts<R>; BATCH] = std::array::from_fn(|l| spec.lane_consts(first + l));
    let bc = BatchConsts::new(&lc);
    let mut lanes: [Lane<R>; BATCH] = std::array::from_fn(|l| spec.initial_lane(first + l));
    let n = spec.stepper.steps_per_period;
    for _ in 0..spec.transient {
        if lanes.iter().all(|l| l.status.is_frozen()) {
            break;
        }
        for _ in 0..n {
            batch_macro_step(&bc, &lc, &mut lanes);
        }
    }
    let mut points: Vec<Vec<f64>> = (0..BATCH)
        .map(|_| Vec::with_capacity(spec.recorded as usize * STATE_DIM))
        .collect();
    for _ in 0..spec.recorded {
        for _ in 0..n {
            batch_macro_step(&bc, &lc, &mut lanes);
        }
        for (p, lane) in points.iter_mut().zip(&lanes) {
            p.extend(lane.x.iter().map(|v| v.to_f64()));
        }
    }
    points
        .into_iter()
        .zip(lanes)
        .map(|(points, lane)| Outcome {
            points,
            final_state: lane.state_f64(),
            status: lane.status,
            counters: lane.counters,
        })
        .collect()
}

/// The batch code compiled for AVX2 (no FMA: fusing would change the rounding).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx2")]
fn run_batch_avx2<R: Real>(spec: &EnsembleSpec, first: usize) -> Vec<Outcome> {
    run_batch_inner::<R>(spec, first)
}

/// Lanes `first..first + BATCH`, with the widest vector unit this CPU has.
fn run_batch<R: Real>(spec: &EnsembleSpec, first: usize) -> Vec<Outcome> {
    #[cfg(target_arch = "x86_64")]
    if std::is_x86_feature_detected!("avx2") {
        // SAFETY: the CPU has just been found to support AVX2.
        return unsafe { run_batch_avx2::<R>(spec, first) };
    }
    run_batch_inner::<R>(spec, first)
}

/// Runs the ensemble on the CPU with rayon's global pool; `progress` is called with the
/// number of lanes finished so far (from worker threads).
pub fn run(spec: &EnsembleSpec, progress: &(dyn Fn(usize) + Sync)) -> Result<EnsembleResult> {
    spec.validate()?;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let n = spec.lanes.len();
    // Whole batches through the batch stepper, the remainder lane by lane.
    let batches = n / BATCH;
    let tasks: Vec<(usize, bool)> = (0..batches)
        .map(|b| (b * BATCH, true))
        .chain((batches * BATCH..n).map(|i| (i, false)))
        .collect();
    let outcomes: Vec<Outcome> = tasks
        .into_par_iter()
        .with_min_len(2)
        .flat_map_iter(|(first, batched)| {
            let o = match (spec.precision, batched) {
                (Precision::F32, true) => run_batch::<f32>(spec, first),
                (Precision::F64, true) => run_batch::<f64>(spec, first),
                (Precision::F32, false) => vec![run_lane::<f32>(spec, first)],
                (Precision::F64, false) => vec![run_lane::<f64>(spec, first)],
            };
            let k = o.len();
            progress(done.fetch_add(k, std::sync::atomic::Ordering::Relaxed) + k);
            o
        })
        .collect();
    let mut res = EnsembleResult {
        poincare: Vec::with_capacity(spec.lanes.len() * spec.recorded as usize * STATE_DIM),
        recorded: spec.recorded as usize,
        final_state: Vec::with_capacity(spec.lanes.len()),
        status: Vec::with_capacity(spec.lanes.len()),
        counters: Vec::with_capacity(spec.lanes.len()),
    };
    for o in outcomes {
        res.poincare.extend_from_slice(&o.points);
        res.final_state.push(o.final_state);
        res.status.push(o.status);
        res.counters.push(o.counters);
    }
    Ok(res)
}
