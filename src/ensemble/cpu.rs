//! The CPU backend: rayon over lanes, each lane the Rust lane stepper
//! (`integrate::lane`), which the GPU kernel mirrors. Lanes are independent and each is
//! integrated by one thread from start to end, so the result is bit-identical for any
//! number of threads.

use super::{EnsembleResult, EnsembleSpec, Precision};
use crate::error::Result;
use crate::integrate::lane::{
    Counters, LAMBDA1_START, Status, Tangent, advance_period, advance_period_tangent, renormalise,
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
        lambda1: f64::NAN,
    }
}

/// `run_lane` with a tangent vector, as the kernel's lambda_1 variant: renormalised at
/// the end of every period the lane completes, its growth kept over recorded periods.
fn run_lane_lambda1<R: Real>(spec: &EnsembleSpec, i: usize) -> Outcome {
    let lc = spec.lane_consts::<R>(i);
    let mut lane = spec.initial_lane::<R>(i);
    let mut tan = Tangent::<R, 1>::new([[R::lit(LAMBDA1_START); STATE_DIM]]);
    let mut points = Vec::with_capacity(spec.recorded as usize * STATE_DIM);
    let mut norms = Vec::with_capacity(spec.recorded as usize);
    for p in 0..spec.transient + spec.recorded {
        if p < spec.transient && lane.status.is_frozen() {
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
    Outcome {
        points,
        final_state: lane.state_f64(),
        status: lane.status,
        counters: lane.counters,
        lambda1: super::lane_lambda1(&norms, spec.lanes[i].omega, lane.status),
    }
}

/// Runs the ensemble on the CPU with rayon's global pool; `progress` is called with the
/// number of lanes finished so far (from worker threads).
pub fn run(spec: &EnsembleSpec, progress: &(dyn Fn(usize) + Sync)) -> Result<EnsembleResult> {
    run_inner(spec, false, progress)
}

/// [`run`], also computing each lane's largest Lyapunov exponent
/// (`EnsembleResult::lambda1`) exactly as the GPU kernel's lambda_1 variant does.
pub fn run_with_lambda1(
    spec: &EnsembleSpec,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<EnsembleResult> {
    run_inner(spec, true, progress)
}

fn run_inner(
    spec: &EnsembleSpec,
    lambda1: bool,
    progress: &(dyn Fn(usize) + Sync),
) -> Result<EnsembleResult> {
    spec.validate()?;
    let done = std::sync::atomic::AtomicUsize::new(0);
    let outcomes: Vec<Outcome> = (0..spec.lanes.len())
        .into_par_iter()
        .with_min_len(16)
        .map(|i| {
            let o = match (spec.precision, lambda1) {
                (Precision::F32, false) => run_lane::<f32>(spec, i),
                (Precision::F64, false) => run_lane::<f64>(spec, i),
                (Precision::F32, true) => run_lane_lambda1::<f32>(spec, i),
                (Precision::F64, true) => run_lane_lambda1::<f64>(spec, i),
            };
            progress(done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1);
            o
        })
        .collect();
    let mut res = EnsembleResult {
        poincare: Vec::with_capacity(spec.lanes.len() * spec.recorded as usize * STATE_DIM),
        recorded: spec.recorded as usize,
        final_state: Vec::with_capacity(spec.lanes.len()),
        status: Vec::with_capacity(spec.lanes.len()),
        counters: Vec::with_capacity(spec.lanes.len()),
        lambda1: lambda1.then(|| outcomes.iter().map(|o| o.lambda1).collect()),
    };
    for o in outcomes {
        res.poincare.extend_from_slice(&o.points);
        res.final_state.push(o.final_state);
        res.status.push(o.status);
        res.counters.push(o.counters);
    }
    Ok(res)
}
