//! Attractor continuation over one parameter with basin fractions and tipping
//! probabilities: Attractors.jl's seeded "find and match" (Datseris et al. 2023,
//! `AttractorSeedContinueMatch`), run-up and run-down as an engineer ramps the machine.
//!
//! Two passes, as the brute-force bifurcation:
//!
//! 1. **fresh** (stage `fresh`, one unit per parameter value, independent, shardable):
//!    at every value, the same K start states (the static equilibrium of the value's
//!    parameters plus seeded draws, velocities scaled by a fixed speed so the draws do
//!    not change along an omega axis) are run and catalogued: a partial catalogue per
//!    value. These K lanes give the basin fractions (binomial standard errors) and,
//!    being the same start states at every value, the tipping probabilities.
//! 2. **seeded** (stages `up` and `down`, one unit per value, in ramp order): at each
//!    value, the attractors of the previous value seed one lane each (a Poincare point
//!    of the attractor); the seed lanes and the fresh partial catalogue are catalogued
//!    together (so an attractor that no fresh start state finds is still followed),
//!    then matched to the previous value's attractors by Poincare-set distance: pairs in
//!    increasing distance, each attractor at most once, within `match_threshold`
//!    (Attractors.jl's `MatchBySSSetDistance`, default threshold infinite). A matched
//!    attractor keeps its id; an unmatched one is born with a new id; a previous one
//!    left without a match has died.
//!
//! Tipping probability (Kaszas, Feudel and Tel 2019, Attractors.jl's
//! `tipping_probabilities`): P(i -> j) between consecutive values p_k -> p_{k+1} is the
//! fraction of attractor i's basin at p_k (among the K start states) that lies in
//! attractor j's basin at p_{k+1}; each row with a basin sums to 1 (diverged is a column).

mod matching;
mod ramp;
mod record;
mod seeded;
mod spec;

pub use matching::{match_attractors, set_distance};
pub use ramp::{Ramp, Step, Tracked};
pub use record::{Lifetime, RampRecord, Summary, id_name, summary};
pub use spec::{ContinuationSpec, Direction, Fields, directions, parse_box, uniform_in_box};

use crate::catalogue::CatalogueBuilder;
use crate::run::lanes::{Control, LaneUnits, Split};
use crate::run::{Unit, UnitStore, Units};
use jeffcott_core::ensemble::{EnsembleResult, EnsembleSpec, RunInfo};
use jeffcott_core::error::{Error, Result};
use serde::{Deserialize, Serialize};

/// A computed continuation.
#[derive(Clone, Debug)]
pub struct ContinuationResult {
    /// The parameter values, ascending.
    pub values: Vec<f64>,
    /// One ramp per direction asked for.
    pub ramps: Vec<Ramp>,
    /// Backend of the last batch of the fresh pass.
    pub info: Option<RunInfo>,
    /// What early exit saved in the fresh pass (`None`: it ran without).
    pub early_exit: Option<crate::early::EarlySaved>,
    /// Wall time [s].
    pub seconds: f64,
}

/// Stage of the fresh pass.
pub const FRESH: &str = "fresh";

/// Computes a continuation in memory; `ctl.progress` counts lane-periods of the fresh pass.
pub fn continuation(spec: &ContinuationSpec, ctl: Control) -> Result<ContinuationResult> {
    crate::run::in_memory(spec, ctl)
}

/// Runs a continuation (or a basin stability, the same study) under `host` (its units
/// committed to the host's store, its progress on the host's display as stage
/// `continuation`): the front ends' entry point.
pub fn run(
    spec: &ContinuationSpec,
    engine: &crate::backend::Engine,
    host: &impl crate::run::Host,
) -> Result<ContinuationResult> {
    crate::run::under_host(spec, engine, host)
}

/// Runs the continuation unit by unit into `store` (resuming from what it holds).
pub(super) fn continuation_units(
    spec: &ContinuationSpec,
    Units { engine, store, ctl }: Units,
) -> Result<ContinuationResult> {
    spec.validate()?;
    let t0 = std::time::Instant::now();
    let n = spec.param.n;
    let k = spec.ics as usize;
    let per_unit = spec.unit_values();
    let split = Split::new(n, per_unit);
    let ensemble = |u: usize| {
        let mut e = spec.ensemble(u * per_unit, spec.fresh_starts(u * per_unit));
        for i in split.range(u).skip(1) {
            let next = spec.ensemble(i, spec.fresh_starts(i));
            let set = e.param_sets.len() as u32;
            e.param_sets.extend(next.param_sets);
            e.lanes.extend(next.lanes.into_iter().map(|mut l| {
                l.param_set = set;
                l
            }));
        }
        e
    };
    let reduce = |u: usize, _e: &EnsembleSpec, res: EnsembleResult| {
        let values = split.range(u).enumerate().map(|(j, i)| {
            let lanes = j * k..(j + 1) * k;
            let (_, w) = spec.value_params(i);
            let mut b = CatalogueBuilder::new(w, spec.lane.catalogue);
            let labels = b.add_result_lanes(&res, lanes);
            (b, labels)
        });
        Ok(fresh_unit(values))
    };
    // Early exit (crate::early): each value's lanes catalogued in rounds, all values of
    // the unit together; recognised lanes retire. Only with enough lanes per value for
    // rounds to pay (`early::MIN_GROUP`).
    let early_on = spec.lane.early_exit() && k >= crate::early::MIN_GROUP;
    let early = |u: usize, e: &EnsembleSpec, engine: &crate::backend::Engine, c: Control| {
        let values: Vec<usize> = split.range(u).collect();
        let groups: Vec<std::ops::Range<usize>> =
            (0..values.len()).map(|j| j * k..(j + 1) * k).collect();
        let omegas: Vec<f64> = values.iter().map(|&i| spec.value_params(i).1).collect();
        let all = crate::early::catalogue_groups(
            e,
            &groups,
            &omegas,
            spec.lane.catalogue,
            spec.lane.lyapunov,
            engine,
            c,
        )?;
        let mut saved = crate::early::EarlySaved::default();
        all.iter().for_each(|r| saved.add(&r.saved));
        let info = all.first().and_then(|r| r.info.clone());
        let unit = fresh_unit(all.into_iter().map(|r| (r.builder, r.labels)))
            .with("early", crate::run::Array::F64(saved.to_array()));
        Ok((unit, info))
    };
    let info = LaneUnits::new(FRESH, split, &ensemble, &reduce)
        .lanes_per_item(k)
        .lambda1(spec.lane.lyapunov)
        .computed_by(early_on.then_some(&early as &crate::run::lanes::ComputeUnit))
        .run(store, engine, ctl)?;
    // A shard's work ends here: reading the fresh pass is the merge's (ShardDone), and
    // the ramps' stages must not be asked about before, so a shard never lists them.
    fresh_value(spec, store, 0)?;
    let mut early_exit = None;
    if early_on {
        for u in 0..split.count() {
            let s = crate::early::unit_saved(&store.load(FRESH, u)?)?;
            crate::early::EarlySaved::accumulate(&mut early_exit, s);
        }
    }
    // The directions' ramps are independent (each its own stage of units, each value
    // seeded from the one before in its own order) and each is a chain of small
    // ensembles of a few batches, which leave cores idle: they run side by side.
    let ramps = {
        use rayon::prelude::*;
        spec.directions
            .par_iter()
            .map(|&d| seeded::ramp(spec, engine, store, d, ctl))
            .collect::<Result<Vec<_>>>()?
    };
    Ok(ContinuationResult {
        values: spec.param.values(),
        ramps,
        info,
        early_exit,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// A fresh-pass unit from each of its values' catalogue and labels, in order: one
/// partial catalogue per value, arrays `labels.j`, `points.j` and the j-th entry of
/// `values` in its meta (see `fresh_value`).
fn fresh_unit(values: impl Iterator<Item = (CatalogueBuilder, Vec<i32>)>) -> Unit {
    let mut unit = Unit::new("");
    let mut metas = Vec::new();
    for (j, (b, labels)) in values.enumerate() {
        let (parts, labels, diverged) = b.finish_part(labels);
        let part = crate::catalogue::part_unit(labels, &parts, diverged);
        for (name, a) in part.arrays {
            unit = unit.with(&format!("{name}.{j}"), a);
        }
        metas.push(part.meta);
    }
    unit.with_meta(&FreshMeta { values: metas })
}

/// The partial catalogue of the fresh lanes at value `i`, as a unit of its own.
fn fresh_value(spec: &ContinuationSpec, store: &dyn UnitStore, i: usize) -> Result<Unit> {
    let per_unit = spec.unit_values();
    let (u, j) = (i / per_unit, i % per_unit);
    let unit = store.load(FRESH, u)?;
    let values = unit.meta_as::<FreshMeta>()?.values;
    let meta = values.get(j).ok_or_else(|| Error::Io {
        path: format!("unit {}", unit.key).into(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("no value {j}")),
    })?;
    let mut one = Unit::new(unit.key.clone()).with_meta(meta);
    for name in ["labels", "points"] {
        let key = format!("{name}.{j}");
        let a = unit
            .arrays
            .iter()
            .find(|(n, _)| *n == key)
            .map(|(_, a)| a.clone())
            .ok_or_else(|| Error::Io {
                path: format!("unit {}", unit.key).into(),
                source: std::io::Error::new(std::io::ErrorKind::InvalidData, format!("no {key}")),
            })?;
        one = one.with(name, a);
    }
    Ok(one)
}

/// The metadata of a fresh-pass unit: per value, its partial catalogue's metadata
/// (`catalogue::part_unit`), the arrays of value j named `labels.j`, `points.j`.
#[derive(Serialize, Deserialize)]
struct FreshMeta {
    values: Vec<serde_json::Value>,
}
