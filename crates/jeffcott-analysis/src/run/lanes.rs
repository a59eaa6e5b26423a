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

/// A stage's items (cells, lanes, parameter values, speeds) in units of `per_unit`
/// consecutive items, the last one shorter.
#[derive(Clone, Copy, Debug)]
pub struct Split {
    /// Number of items.
    pub items: usize,
    /// Items per unit (at least 1).
    pub per_unit: usize,
}

impl Split {
    /// `items` in units of `per_unit` (at least 1).
    pub fn new(items: usize, per_unit: usize) -> Split {
        Split {
            items,
            per_unit: per_unit.max(1),
        }
    }

    /// Number of units.
    pub fn count(&self) -> usize {
        super::unit_count(self.items, self.per_unit)
    }

    /// The items of unit `u`.
    pub fn range(&self, u: usize) -> std::ops::Range<usize> {
        u * self.per_unit..((u + 1) * self.per_unit).min(self.items)
    }
}

/// How many lanes a unit has, known without building its ensemble.
#[derive(Clone, Copy)]
enum UnitLanes<'a> {
    /// A fixed number of lanes per item.
    PerItem(usize),
    /// Computed from the unit's index.
    Of(&'a (dyn Fn(usize) -> usize + Sync)),
}

/// The units of one stage of a study, built by [`LaneUnits::new`] and run by
/// [`LaneUnits::run`].
pub struct LaneUnits<'a> {
    /// Stage name (unit files are `units/<stage>-NNNNNNN.unit`).
    stage: &'a str,
    /// The stage's items and units.
    split: Split,
    /// The ensemble of unit `i` (deterministic; every unit with the same transient and
    /// recorded periods).
    ensemble: &'a (dyn Fn(usize) -> EnsembleSpec + Sync),
    /// The number of lanes of unit `i`.
    lanes: UnitLanes<'a>,
    /// Run the lambda_1 variant.
    lambda1: bool,
    /// Turns unit `i`'s ensemble and result into what is committed (its key is set by
    /// the engine).
    reduce: &'a (dyn Fn(usize, &EnsembleSpec, EnsembleResult) -> Result<Unit> + Sync),
    /// Computes unit `i` whole from its ensemble instead (early exit's rounds), one
    /// unit at a time.
    computed_by: Option<&'a ComputeUnit<'a>>,
}

/// A unit computed whole from its index and ensemble on an engine: the unit and how
/// its last run went.
pub type ComputeUnit<'a> =
    dyn Fn(usize, &EnsembleSpec, &Engine, Control) -> Result<(Unit, Option<RunInfo>)> + Sync + 'a;

impl<'a> LaneUnits<'a> {
    /// Stage `stage` over `split`'s units: unit `i` runs `ensemble(i)` and commits
    /// `reduce(i, ensemble, result)`; one lane per item, no lambda_1, unless said.
    pub fn new(
        stage: &'a str,
        split: Split,
        ensemble: &'a (dyn Fn(usize) -> EnsembleSpec + Sync),
        reduce: &'a (dyn Fn(usize, &EnsembleSpec, EnsembleResult) -> Result<Unit> + Sync),
    ) -> Self {
        LaneUnits {
            stage,
            split,
            ensemble,
            lanes: UnitLanes::PerItem(1),
            lambda1: false,
            reduce,
            computed_by: None,
        }
    }

    /// Each unit is computed by `compute` from its ensemble (instead of one run of the
    /// ensemble and `reduce`), when `Some`.
    pub fn computed_by(mut self, compute: Option<&'a ComputeUnit<'a>>) -> Self {
        self.computed_by = compute;
        self
    }

    /// Each item runs `k` lanes.
    pub fn lanes_per_item(mut self, k: usize) -> Self {
        self.lanes = UnitLanes::PerItem(k);
        self
    }

    /// Unit `i` runs `lanes(i)` lanes.
    pub fn lanes_of(mut self, lanes: &'a (dyn Fn(usize) -> usize + Sync)) -> Self {
        self.lanes = UnitLanes::Of(lanes);
        self
    }

    /// Whether the lanes compute lambda_1.
    pub fn lambda1(mut self, on: bool) -> Self {
        self.lambda1 = on;
        self
    }

    /// Number of units.
    pub fn count(&self) -> usize {
        self.split.count()
    }

    /// Lanes of unit `i`.
    fn unit_lanes(&self, i: usize) -> usize {
        match self.lanes {
            UnitLanes::PerItem(k) => self.split.range(i).len() * k,
            UnitLanes::Of(f) => f(i),
        }
    }

    /// Computes and commits every unit not yet committed in `store` ([`run_units`]).
    pub fn run(
        &self,
        store: &dyn UnitStore,
        engine: &Engine,
        ctl: Control,
    ) -> Result<Option<RunInfo>> {
        run_units(store, engine, self, ctl)
    }
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
fn run_units(
    store: &dyn UnitStore,
    engine: &Engine,
    units: &LaneUnits,
    ctl: Control,
) -> Result<Option<RunInfo>> {
    let count = units.count();
    let done = store.committed(units.stage, count)?;
    if done.iter().all(|&d| d) {
        // Nothing to run (a resumed run, a merge): no unit's ensemble is built.
        return Ok(None);
    }
    let probe = (units.ensemble)(0);
    let per_lane = (probe.transient + probe.recorded) as u64;
    let record_bytes = probe.recorded as usize * STATE_DIM * 8;
    drop(probe);
    let lanes_of: Vec<usize> = (0..count).map(|i| units.unit_lanes(i)).collect();
    let mut pass = Pass {
        store,
        engine,
        units,
        ctl,
        lanes_of,
        per_lane,
        count,
        committed: 0,
        total: 0,
        base: 0,
        info: None,
    };
    pass.total = (0..count).map(|i| pass.work(i)).sum();
    pass.base = (0..count).filter(|&i| done[i]).map(|i| pass.work(i)).sum();
    (ctl.progress)(pass.base, pass.total);
    let pending: Vec<usize> = (0..count).filter(|&i| !done[i]).collect();
    pass.committed = count - pending.len();
    let gpu = engine.runner().is_some();
    let mut batch_work_target: u64 = 0; // 0: one unit (before a speed was measured)
    let mut next = 0;
    // On the CPU every unit is computed whole, several at a time where one alone
    // leaves threads idle: a plain unit's lanes in one run of the engine (a small unit,
    // say 3 batches of 8 lanes, cannot keep the threads busy: a 48-cell map's units of
    // 3 cells ran at 150 % CPU of 200 %), an early-exit unit's in rounds that leave
    // threads idle at a round's end. A GPU batches plain units into one dispatch
    // (below) and takes early-exit units one at a time.
    let plain = |i: usize, spec: &EnsembleSpec, engine: &Engine, c: Control| {
        if spec.lanes.is_empty() {
            // A unit may have no lanes (a speed group without seeds): nothing to run.
            let res = EnsembleResult::with_capacity(0, spec.recorded, units.lambda1);
            return Ok(((units.reduce)(i, spec, res)?, None));
        }
        let (res, info) = engine.run(spec, units.lambda1, c)?;
        Ok(((units.reduce)(i, spec, res)?, Some(info)))
    };
    let whole: Option<&ComputeUnit> = match units.computed_by {
        Some(c) => Some(c),
        None if !gpu => Some(&plain),
        None => None,
    };
    while next < pending.len() {
        if ctl.cancel.is_set() {
            return Err(pass.interrupted());
        }
        next += match whole {
            Some(compute) => pass.run_whole(compute, &pending[next..], gpu)?,
            None => pass.run_batch(&pending[next..], record_bytes, &mut batch_work_target)?,
        };
    }
    Ok(pass.info)
}

/// Where [`run_units`] stands in a stage's units.
struct Pass<'p, 'u> {
    store: &'p dyn UnitStore,
    engine: &'p Engine,
    units: &'p LaneUnits<'u>,
    ctl: Control<'p>,
    /// Each unit's lanes.
    lanes_of: Vec<usize>,
    /// Lane-periods of one lane.
    per_lane: u64,
    /// Units in all.
    count: usize,
    /// Units committed.
    committed: usize,
    /// Lane-periods in all.
    total: u64,
    /// Lane-periods of the committed units.
    base: u64,
    /// How the last batch was run.
    info: Option<RunInfo>,
}

impl Pass<'_, '_> {
    /// Lane-periods of unit `i`.
    fn work(&self, i: usize) -> u64 {
        self.lanes_of[i] as u64 * self.per_lane
    }

    /// The error of a run stopped now: what is committed stays.
    fn interrupted(&self) -> Error {
        Error::Interrupted {
            committed: self.committed,
            total: self.count,
        }
    }

    /// Computes the first units of `pending` whole with `compute`, side by side, and
    /// commits them in order; returns how many it took. On a GPU one at a time; on the
    /// CPU up to 2 per thread, early-exit units always, plain units only as many as
    /// give every thread 8 batches of lanes (a large unit runs alone, so a kill loses
    /// no more than it did).
    fn run_whole(&mut self, compute: &ComputeUnit, pending: &[usize], gpu: bool) -> Result<usize> {
        let (units, ctl, total) = (self.units, self.ctl, self.total);
        let threads = rayon::current_num_threads().max(1);
        let width = if gpu {
            1
        } else if units.computed_by.is_some() {
            2 * threads
        } else {
            let fill = 8 * jeffcott_core::integrate::batch::BATCH * threads;
            fill.div_ceil(self.lanes_of[pending[0]].max(1))
                .clamp(1, 2 * threads)
        };
        let group: Vec<usize> = pending.iter().copied().take(width).collect();
        let done_in: Vec<std::sync::atomic::AtomicU64> =
            group.iter().map(|_| Default::default()).collect();
        let b = self.base;
        let report = |k: usize, d: u64| {
            done_in[k].store(d, std::sync::atomic::Ordering::Relaxed);
            let sum: u64 = done_in
                .iter()
                .map(|a| a.load(std::sync::atomic::Ordering::Relaxed))
                .sum();
            (ctl.progress)(b + sum, total);
        };
        use rayon::prelude::*;
        let engine = self.engine;
        let results: Vec<Result<(Unit, Option<RunInfo>)>> = group
            .par_iter()
            .enumerate()
            .map(|(k, &i)| {
                let spec = (units.ensemble)(i);
                let r = |d: u64, _t: u64| report(k, d);
                compute(
                    i,
                    &spec,
                    engine,
                    Control {
                        progress: &r,
                        cancel: ctl.cancel,
                    },
                )
            })
            .collect();
        for (&i, r) in group.iter().zip(results) {
            let (mut unit, i_info) = match r {
                Err(Error::Interrupted { .. }) => return Err(self.interrupted()),
                r => r?,
            };
            self.info = i_info.or(self.info.take());
            unit.key = super::dir::unit_key(units.stage, i);
            self.store.commit(units.stage, i, &unit)?;
            self.committed += 1;
            self.base += self.work(i);
        }
        (ctl.progress)(self.base, total);
        Ok(group.len())
    }

    /// Runs the first units of `pending` as one batch on the GPU, consecutive units up
    /// to the batch target (at least one), and commits them; returns how many it took.
    /// The target follows the measured speed (`batch_work_target`).
    fn run_batch(
        &mut self,
        pending: &[usize],
        record_bytes: usize,
        batch_work_target: &mut u64,
    ) -> Result<usize> {
        let (units, ctl, total) = (self.units, self.ctl, self.total);
        let mut batch = vec![pending[0]];
        let mut bw = self.work(pending[0]);
        let mut lanes = self.lanes_of[pending[0]];
        while batch.len() < pending.len() {
            let j = pending[batch.len()];
            let rec_bytes = (lanes + self.lanes_of[j]) * record_bytes;
            if bw + self.work(j) > *batch_work_target || rec_bytes > GPU_BATCH_RECORD_BYTES {
                break;
            }
            bw += self.work(j);
            lanes += self.lanes_of[j];
            batch.push(j);
        }
        let specs: Vec<EnsembleSpec> = batch.iter().map(|&i| (units.ensemble)(i)).collect();
        let counts: Vec<usize> = specs.iter().map(|s| s.lanes.len()).collect();
        let spec = concat(&specs);
        let t = std::time::Instant::now();
        let b = self.base;
        let report = |d: u64, _t: u64| (ctl.progress)(b + d, total);
        let res = if spec.lanes.is_empty() {
            // A unit may have no lanes (a speed group without seeds): nothing to run.
            EnsembleResult::with_capacity(0, spec.recorded, units.lambda1)
        } else {
            let ctl_batch = Control {
                progress: &report,
                cancel: ctl.cancel,
            };
            let (res, i) = match self.engine.run(&spec, units.lambda1, ctl_batch) {
                // A cancel inside the batch: what is committed stays, as between batches.
                Err(Error::Interrupted { .. }) => return Err(self.interrupted()),
                r => r?,
            };
            self.info = Some(i);
            res
        };
        let secs = t.elapsed().as_secs_f64().max(1e-3);
        // About GPU_BATCH_SECONDS of work, and never more than 1/MIN_UNITS of the run,
        // so a SIGKILL loses at most that much (a batch is committed as a whole).
        *batch_work_target =
            (((bw as f64 / secs) * GPU_BATCH_SECONDS) as u64).min(total / super::MIN_UNITS as u64);
        for ((k, s), r) in batch.iter().zip(&specs).zip(split(res, &counts)) {
            let mut unit = (units.reduce)(*k, s, r)?;
            unit.key = super::dir::unit_key(units.stage, *k);
            self.store.commit(units.stage, *k, &unit)?;
            self.committed += 1;
        }
        self.base += bw;
        (ctl.progress)(self.base, total);
        Ok(batch.len())
    }
}
