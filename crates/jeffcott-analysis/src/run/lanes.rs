//! Runs a study's lane units on a resolved backend and commits each as it finishes.
//!
//! The CPU runs one unit at a time (rayon inside it). A GPU runs batches of consecutive
//! units as one ensemble, so dispatches stay large: the first batch is one unit, later
//! ones are sized from the measured speed to about [`GPU_BATCH_SECONDS`] of work, at
//! most 1/20 of the run (what a SIGKILL may lose) and a memory cap. Lanes are independent, so a lane's result does not depend on its batch:
//! the units committed are the same whatever the batching.

use super::{Unit, UnitStore};
use crate::backend::Engine;
use jeffcott_core::ensemble::{EnsembleResult, EnsembleSpec, RunInfo};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::STATE_DIM;

/// Seconds of work a GPU batch aims at: short enough that a SIGKILL loses little, long
/// enough to amortise dispatch and readback.
pub const GPU_BATCH_SECONDS: f64 = 10.0;

/// Bytes of Poincare records a GPU batch may hold at most.
const GPU_BATCH_RECORD_BYTES: usize = 512 << 20;

/// The units of one stage of a study.
pub struct LaneUnits<'a> {
    /// Stage name (unit files are `units/<stage>-NNNNNNN.unit`).
    pub stage: &'a str,
    /// Number of units.
    pub count: usize,
    /// The ensemble of unit `i` (deterministic; every unit with the same transient and
    /// recorded periods).
    pub ensemble: &'a (dyn Fn(usize) -> EnsembleSpec + Sync),
    /// The number of lanes of unit `i` (without building its ensemble).
    pub lanes: &'a (dyn Fn(usize) -> usize + Sync),
    /// Run the lambda_1 variant.
    pub lambda1: bool,
    /// Turns unit `i`'s ensemble and result into what is committed (its key is set by
    /// the engine).
    pub reduce: &'a (dyn Fn(usize, &EnsembleSpec, EnsembleResult) -> Result<Unit> + Sync),
}

pub use jeffcott_core::control::Control;

/// Concatenates unit ensembles into one batch (parameter sets re-indexed).
fn concat(specs: &[EnsembleSpec]) -> EnsembleSpec {
    let mut out = specs[0].clone();
    out.lanes.clear();
    out.param_sets.clear();
    for s in specs {
        let base = out.param_sets.len() as u32;
        out.param_sets.extend(s.param_sets.iter().cloned());
        out.lanes.extend(s.lanes.iter().map(|l| {
            let mut l = *l;
            l.param_set += base;
            l
        }));
    }
    out
}

/// Splits a batch result back into per-unit results of `counts` lanes each.
fn split(res: EnsembleResult, counts: &[usize]) -> Vec<EnsembleResult> {
    let per = res.recorded * STATE_DIM;
    let mut out = Vec::with_capacity(counts.len());
    let mut at = 0;
    for &n in counts {
        out.push(EnsembleResult {
            poincare: res.poincare[at * per..(at + n) * per].to_vec(),
            recorded: res.recorded,
            final_state: res.final_state[at..at + n].to_vec(),
            status: res.status[at..at + n].to_vec(),
            counters: res.counters[at..at + n].to_vec(),
            lambda1: res.lambda1.as_ref().map(|l| l[at..at + n].to_vec()),
        });
        at += n;
    }
    out
}

/// Computes and commits every unit of `units` not yet committed in `store`; returns how
/// the last batch was run (`None` when every unit was already committed).
pub fn run_units(
    store: &dyn UnitStore,
    engine: &Engine,
    units: &LaneUnits,
    ctl: Control,
) -> Result<Option<RunInfo>> {
    let done = store.committed(units.stage, units.count)?;
    if units.count == 0 {
        return Ok(None);
    }
    let probe = (units.ensemble)(0);
    let per_lane = (probe.transient + probe.recorded) as u64;
    let record_bytes = probe.recorded as usize * STATE_DIM * 8;
    drop(probe);
    let lanes_of: Vec<usize> = (0..units.count).map(units.lanes).collect();
    let work = |i: usize| lanes_of[i] as u64 * per_lane;
    let total: u64 = (0..units.count).map(work).sum();
    let mut base: u64 = (0..units.count).filter(|&i| done[i]).map(work).sum();
    (ctl.progress)(base, total);
    let pending: Vec<usize> = (0..units.count).filter(|&i| !done[i]).collect();
    let mut committed = units.count - pending.len();
    let gpu = engine.runner().is_some();
    let mut batch_work_target: u64 = 0; // 0: one unit (before a speed was measured)
    let mut info = None;
    let mut next = 0;
    while next < pending.len() {
        if ctl.cancel.is_set() {
            return Err(Error::Interrupted {
                committed,
                total: units.count,
            });
        }
        // Consecutive pending units up to the batch target (at least one).
        let mut batch = vec![pending[next]];
        let mut bw = work(pending[next]);
        let mut lanes = lanes_of[pending[next]];
        while gpu && next + batch.len() < pending.len() {
            let j = pending[next + batch.len()];
            let rec_bytes = (lanes + lanes_of[j]) * record_bytes;
            if bw + work(j) > batch_work_target || rec_bytes > GPU_BATCH_RECORD_BYTES {
                break;
            }
            bw += work(j);
            lanes += lanes_of[j];
            batch.push(j);
        }
        let specs: Vec<EnsembleSpec> = batch.iter().map(|&i| (units.ensemble)(i)).collect();
        let counts: Vec<usize> = specs.iter().map(|s| s.lanes.len()).collect();
        let spec = concat(&specs);
        let t = std::time::Instant::now();
        let b = base;
        let report = |d: u64, _t: u64| (ctl.progress)(b + d, total);
        let res = if spec.lanes.is_empty() {
            // A unit may have no lanes (a speed group without seeds): nothing to run.
            EnsembleResult {
                poincare: Vec::new(),
                recorded: spec.recorded as usize,
                final_state: Vec::new(),
                status: Vec::new(),
                counters: Vec::new(),
                lambda1: units.lambda1.then(Vec::new),
            }
        } else {
            let ctl_batch = Control {
                progress: &report,
                cancel: ctl.cancel,
            };
            let (res, i) = match engine.run(&spec, units.lambda1, ctl_batch) {
                // A cancel inside the batch: what is committed stays, as between batches.
                Err(Error::Interrupted { .. }) => {
                    return Err(Error::Interrupted {
                        committed,
                        total: units.count,
                    });
                }
                r => r?,
            };
            info = Some(i);
            res
        };
        let secs = t.elapsed().as_secs_f64().max(1e-3);
        // About GPU_BATCH_SECONDS of work, and never more than 1/MIN_UNITS of the run,
        // so a SIGKILL loses at most that much (a batch is committed as a whole).
        batch_work_target =
            (((bw as f64 / secs) * GPU_BATCH_SECONDS) as u64).min(total / super::MIN_UNITS as u64);
        for ((k, s), r) in batch.iter().zip(&specs).zip(split(res, &counts)) {
            let mut unit = (units.reduce)(*k, s, r)?;
            unit.key = super::dir::unit_key(units.stage, *k);
            store.commit(units.stage, *k, &unit)?;
            committed += 1;
        }
        base += bw;
        (ctl.progress)(base, total);
        next += batch.len();
    }
    Ok(info)
}
