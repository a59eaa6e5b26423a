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

use super::catalogue::{CatalogueBuilder, CatalogueConfig, PartAttractor, classify_lane};
use super::classify::distance;
use super::map::{AxisRecord, MapAxis, MapVar};
use crate::record::{CoordRange, coord_box};
use crate::run::lanes::{Control, LaneUnits};
use crate::run::{Array, Unit, UnitStore};
use jeffcott_core::ensemble::{
    Backend, EnsembleResult, EnsembleSpec, LaneSpec, Precision, RunInfo,
};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM, State};
use serde::{Deserialize, Serialize};

/// A ramp direction.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Direction {
    /// From the first value to the last (run-up).
    Up,
    /// From the last value to the first (run-down).
    Down,
}

impl Direction {
    /// `up` or `down`.
    pub fn name(self) -> &'static str {
        match self {
            Direction::Up => "up",
            Direction::Down => "down",
        }
    }
}

/// The ramps named by `text` (field `direction`): `up`, `down` or `both` (up first).
pub fn directions(text: &str) -> Result<Vec<Direction>> {
    match text {
        "up" => Ok(vec![Direction::Up]),
        "down" => Ok(vec![Direction::Down]),
        "both" => Ok(vec![Direction::Up, Direction::Down]),
        other => Err(Error::invalid(
            "direction",
            other,
            "must be up, down or both",
        )),
    }
}

/// What a continuation computes.
#[derive(Clone, Debug)]
pub struct ContinuationSpec {
    /// Model parameters before the continued one is set.
    pub params: Params,
    /// Rotor speed when the parameter is not omega [rad/s].
    pub omega: Option<f64>,
    /// The continued parameter and its values (omega or a model parameter).
    pub param: MapAxis,
    /// Fresh start states per value.
    pub ics: u32,
    /// Draw the fresh start states uniformly in this box of start coordinates
    /// (coordinate index, lo, hi), the others at the static equilibrium; `None`: the
    /// static equilibrium plus the brute-force draws.
    pub start_box: Option<Vec<(usize, f64, f64)>>,
    /// Seed of the fresh start states.
    pub seed: u64,
    /// Forcing periods integrated and discarded.
    pub transient: u32,
    /// Forcing periods recorded per lane.
    pub recorded: u32,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
    /// Lane precision.
    pub precision: Precision,
    /// Backend.
    pub backend: Backend,
    /// Classification tolerances.
    pub catalogue: CatalogueConfig,
    /// lambda_1 per lane (quasiperiodic and chaotic told apart).
    pub lyapunov: bool,
    /// Ramp directions.
    pub directions: Vec<Direction>,
    /// Largest Poincare-set distance at which two attractors of consecutive values are
    /// the same one [m in positions, m/s / W in velocities]; infinite by default.
    pub match_threshold: f64,
}

/// The names a study gives the fields of a [`ContinuationSpec`] in its errors.
#[derive(Clone, Copy, Debug)]
pub struct Fields {
    /// The continued parameter's range.
    pub param: &'static str,
    /// The fresh start states per value.
    pub ics: &'static str,
    /// The fewest fresh start states allowed.
    pub ics_min: u32,
    /// The box of start coordinates.
    pub start_box: &'static str,
}

impl Fields {
    /// `jeffcott continuation`'s names (`--param`, `--ics`, `--box`).
    pub const CONTINUATION: Fields = Fields {
        param: "param",
        ics: "ics",
        ics_min: 1,
        start_box: "box",
    };
}

impl ContinuationSpec {
    /// Checks the inputs; errors name the option and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.validate_as(&Fields::CONTINUATION)
    }

    /// [`ContinuationSpec::validate`] with errors naming the fields as the study that
    /// built this specification spells them (`basin-stability` continues over `omega`
    /// with `sample` draws in a `box`).
    pub fn validate_as(&self, f: &Fields) -> Result<()> {
        self.params.validate()?;
        self.stepper.validate()?;
        self.catalogue.validate()?;
        self.param.validate(f.param)?;
        if let MapVar::Coord(_) = self.param.var {
            return Err(Error::invalid(
                f.param,
                self.param.var.name(),
                "a continuation follows attractors over omega or a model parameter, not a start coordinate",
            ));
        }
        if self.param.var == MapVar::Omega
            && let Some(w) = self.omega
        {
            return Err(Error::invalid(
                "omega",
                w,
                format!(
                    "the continued parameter is omega (`{}`), which sets the speed of every value; leave omega out",
                    f.param
                ),
            ));
        }
        if self.param.var != MapVar::Omega {
            match self.omega {
                Some(w) => jeffcott_core::model::validate_omega(w)?,
                None => {
                    return Err(Error::invalid(
                        "omega",
                        "none",
                        "give --omega W when the continued parameter is not omega",
                    ));
                }
            }
        }
        for i in [0, self.param.n.saturating_sub(1)] {
            let (p, w) = self.value_params(i);
            jeffcott_core::model::validate_omega(w)
                .and_then(|_| p.validate())
                .map_err(|e| {
                    Error::invalid(
                        f.param,
                        format!("{} = {}", self.param.var.name(), self.param.value(i)),
                        format!("an end of the range is invalid: {e}"),
                    )
                })?;
        }
        if !(f.ics_min..=super::map::MAX_ICS).contains(&self.ics) {
            return Err(Error::invalid(
                f.ics,
                self.ics,
                format!("must be in {}..={}", f.ics_min, super::map::MAX_ICS),
            ));
        }
        jeffcott_core::limits::check_periods("transient", self.transient, 0)?;
        jeffcott_core::limits::check_periods("periods", self.recorded, 2)?;
        if let Some(b) = &self.start_box {
            let bound = self.stepper.divergence_bound;
            for &(c, lo, hi) in b {
                if c % 2 == 0 && lo.abs().max(hi.abs()) > bound {
                    return Err(Error::invalid(
                        f.start_box,
                        format!("{}:{lo}:{hi}", jeffcott_core::model::COORD_NAMES[c]),
                        format!("start positions must lie within --divergence-bound {bound} m"),
                    ));
                }
            }
        }
        if self.directions.is_empty() {
            return Err(Error::invalid("direction", "none", "give up, down or both"));
        }
        if self.match_threshold.is_nan() || self.match_threshold <= 0.0 {
            return Err(Error::invalid(
                "match-threshold",
                self.match_threshold,
                "must be > 0 (inf: always match the nearest)",
            ));
        }
        Ok(())
    }

    /// Parameters and speed at value `i`.
    pub fn value_params(&self, i: usize) -> (Params, f64) {
        let mut p = self.params.clone();
        let mut w = self.omega.unwrap_or(f64::NAN);
        match self.param.var {
            MapVar::Omega => w = self.param.value(i),
            MapVar::Param(k) => {
                p.set(k, self.param.value(i))
                    .expect("MapVar::Param holds a known key");
            }
            MapVar::Coord(_) => {}
        }
        (p, w)
    }

    /// The speed the fresh draws scale velocities by: fixed along the range (the middle
    /// of an omega range), so the start states are the same at every value.
    fn w_ref(&self) -> f64 {
        match self.param.var {
            MapVar::Omega => 0.5 * (self.param.lo + self.param.hi),
            _ => self.omega.unwrap_or(f64::NAN),
        }
    }

    /// The K fresh start states at value `i` (the same draws at every value).
    pub fn fresh_starts(&self, i: usize) -> Vec<State> {
        let (p, _) = self.value_params(i);
        match &self.start_box {
            None => super::bifurcation::start_states(&p, self.ics, self.w_ref(), self.seed),
            Some(b) => uniform_in_box(&p.static_equilibrium(), b, self.ics, self.seed),
        }
    }

    /// The specification as `run.json` records it (not the backend).
    pub fn record(&self) -> SpecRecord<'_> {
        SpecRecord {
            param: AxisRecord {
                unit: None,
                log: None,
                ..self.param.spec_record()
            },
            omega: self.omega,
            ics: self.ics,
            start_box: self.start_box.as_deref(),
            seed: self.seed,
            transient: self.transient,
            periods: self.recorded,
            stepper: self.stepper,
            precision: self.precision,
            catalogue: &self.catalogue,
            lyapunov: self.lyapunov,
            directions: &self.directions,
            match_threshold: Threshold::of(self.match_threshold),
            unit_values: self.unit_values(),
            params: &self.params,
        }
    }

    /// Values per unit of the fresh pass: [`crate::run::unit_lanes`] counted in values.
    pub fn unit_values(&self) -> usize {
        let per_value = self.ics as u64
            * (self.transient + self.recorded) as u64
            * self.stepper.steps_per_period as u64
            * if self.lyapunov { 2 } else { 1 };
        crate::run::unit_lanes(self.param.n, per_value)
    }

    /// Lane-periods of the fresh pass (the bulk of the work).
    pub fn lane_periods(&self) -> u64 {
        self.param.n as u64 * self.ics as u64 * (self.transient + self.recorded) as u64
    }

    fn ensemble(&self, i: usize, starts: Vec<State>) -> EnsembleSpec {
        let (p, w) = self.value_params(i);
        EnsembleSpec {
            param_sets: vec![p],
            lanes: starts
                .into_iter()
                .map(|x0| LaneSpec {
                    omega: w,
                    x0,
                    param_set: 0,
                })
                .collect(),
            transient: self.transient,
            recorded: self.recorded,
            stepper: self.stepper,
            precision: self.precision,
        }
    }
}

/// `k` start states drawn uniformly (seeded, splitmix64) in a box of start coordinates
/// (index, lo, hi), the other coordinates from `base`: a basin-stability sample
/// (Menck et al. 2013).
pub fn uniform_in_box(base: &State, b: &[(usize, f64, f64)], k: u32, seed: u64) -> Vec<State> {
    (0..k as u64)
        .map(|i| {
            let mut x = *base;
            for (d, &(c, lo, hi)) in b.iter().enumerate() {
                let u = 0.5 * (super::bifurcation::unit(i, seed.wrapping_mul(16) + d as u64) + 1.0);
                x[c] = lo + (hi - lo) * u;
            }
            x
        })
        .collect()
}

/// Parses a box `NAME:lo:hi,NAME:lo:hi,...` of start coordinates; `option` names it.
pub fn parse_box(option: &str, text: &str) -> Result<Vec<(usize, f64, f64)>> {
    let mut out: Vec<(usize, f64, f64)> = Vec::new();
    for part in text.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        let f: Vec<&str> = part.split(':').map(str::trim).collect();
        let [name, lo, hi] = f.as_slice() else {
            return Err(Error::invalid(
                option,
                part,
                "expected NAME:lo:hi, e.g. x_r:-0.006:0.006",
            ));
        };
        let c = jeffcott_core::model::coord_index(name).ok_or_else(|| {
            Error::invalid(
                option,
                name,
                format!(
                    "unknown coordinate; valid names: {}",
                    jeffcott_core::model::COORD_NAMES.join(", ")
                ),
            )
        })?;
        let num = |s: &str| {
            s.parse::<f64>()
                .ok()
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    Error::invalid(option, part, format!("`{s}` is not a finite number"))
                })
        };
        let (lo, hi) = (num(lo)?, num(hi)?);
        if lo > hi {
            return Err(Error::invalid(option, part, "need lo <= hi"));
        }
        if out.iter().any(|b| b.0 == c) {
            return Err(Error::invalid(option, name, "is given twice"));
        }
        out.push((c, lo, hi));
    }
    if out.is_empty() {
        return Err(Error::invalid(option, text, "expected NAME:lo:hi,..."));
    }
    Ok(out)
}

/// An attractor at one value of a continuation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Tracked {
    /// Continuation id (kept while the attractor is matched from value to value).
    pub id: u32,
    /// Class at this value.
    pub class: String,
    /// Period at this value, when periodic.
    pub period: Option<usize>,
    /// Basin fraction among the K fresh start states.
    pub fraction: f64,
    /// Its binomial standard error sqrt(f (1 - f) / K).
    pub error: f64,
    /// Mean lambda_1 of its lanes [1/s].
    pub lambda1: Option<f64>,
    /// Diameter of its Poincare set [m].
    pub size_m: f64,
    /// Found only from a seed (no fresh start state reaches it).
    pub seeded_only: bool,
    /// Representative Poincare points (seeds and matching), not in the JSON.
    #[serde(skip)]
    pub points: Vec<State>,
}

/// One value of one direction.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Step {
    /// Parameter value.
    pub value: f64,
    /// Attractors present.
    pub attractors: Vec<Tracked>,
    /// Fraction of fresh start states that diverged.
    pub diverged_fraction: f64,
    /// Continuation id of each fresh start state's attractor (-1 diverged).
    #[serde(skip)]
    pub labels: Vec<i32>,
}

/// One direction's result.
#[derive(Clone, Debug)]
pub struct Ramp {
    /// Which way.
    pub direction: Direction,
    /// Steps in ramp order.
    pub steps: Vec<Step>,
    /// Number of continuation ids used.
    pub ids: usize,
}

impl Ramp {
    /// Basin fractions [steps, ids + 1] in ramp order (last column: diverged), with
    /// their standard errors.
    pub fn fractions(&self) -> (Vec<f64>, Vec<f64>) {
        let g = self.ids + 1;
        let mut f = vec![0.0; self.steps.len() * g];
        let mut e = vec![0.0; self.steps.len() * g];
        for (k, s) in self.steps.iter().enumerate() {
            for a in &s.attractors {
                f[k * g + a.id as usize] = a.fraction;
                e[k * g + a.id as usize] = a.error;
            }
            let n = s.labels.len().max(1) as f64;
            f[k * g + self.ids] = s.diverged_fraction;
            e[k * g + self.ids] = (s.diverged_fraction * (1.0 - s.diverged_fraction) / n).sqrt();
        }
        (f, e)
    }

    /// Tipping probabilities [steps - 1, ids + 1, ids + 1] between consecutive steps in
    /// ramp order (index `ids` is diverged); rows of attractors without a basin at the
    /// earlier step are NaN.
    pub fn tipping(&self) -> Vec<f64> {
        let g = self.ids + 1;
        let idx = |l: i32| if l < 0 { self.ids } else { l as usize };
        let mut t = vec![f64::NAN; self.steps.len().saturating_sub(1) * g * g];
        for k in 0..self.steps.len().saturating_sub(1) {
            let (a, b) = (&self.steps[k].labels, &self.steps[k + 1].labels);
            let mut counts = vec![0u64; g * g];
            for (&i, &j) in a.iter().zip(b) {
                counts[idx(i) * g + idx(j)] += 1;
            }
            for i in 0..g {
                let row: u64 = counts[i * g..(i + 1) * g].iter().sum();
                if row > 0 {
                    for j in 0..g {
                        t[(k * g + i) * g + j] = counts[i * g + j] as f64 / row as f64;
                    }
                }
            }
        }
        t
    }

    /// (id, value where first present, value where last present) in id order.
    pub fn lifetimes(&self) -> Vec<(u32, f64, f64)> {
        (0..self.ids as u32)
            .filter_map(|id| {
                let present: Vec<f64> = self
                    .steps
                    .iter()
                    .filter(|s| s.attractors.iter().any(|a| a.id == id))
                    .map(|s| s.value)
                    .collect();
                Some((id, *present.first()?, *present.last()?))
            })
            .collect()
    }
}

/// A computed continuation.
#[derive(Clone, Debug)]
pub struct ContinuationResult {
    /// The parameter values, ascending.
    pub values: Vec<f64>,
    /// One ramp per direction asked for.
    pub ramps: Vec<Ramp>,
    /// Backend of the last batch of the fresh pass.
    pub info: Option<RunInfo>,
    /// Wall time [s].
    pub seconds: f64,
}

/// Stage of the fresh pass.
pub const FRESH: &str = "fresh";

/// Computes a continuation in memory; `ctl.progress` counts lane-periods of the fresh pass.
pub fn continuation(spec: &ContinuationSpec, ctl: Control) -> Result<ContinuationResult> {
    crate::run::in_memory(spec.backend, spec.precision, ctl, |e, store, ctl| {
        continuation_with(spec, e, store, ctl)
    })
}

/// Runs the continuation unit by unit into `store` (resuming from what it holds).
pub fn continuation_with(
    spec: &ContinuationSpec,
    engine: &crate::backend::Engine,
    store: &dyn UnitStore,
    ctl: Control,
) -> Result<ContinuationResult> {
    spec.validate()?;
    let t0 = std::time::Instant::now();
    let n = spec.param.n;
    let k = spec.ics as usize;
    let per_unit = spec.unit_values();
    let count = crate::run::unit_count(n, per_unit);
    let ensemble = |u: usize| {
        let mut e = spec.ensemble(u * per_unit, spec.fresh_starts(u * per_unit));
        for i in u * per_unit + 1..((u + 1) * per_unit).min(n) {
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
    // A unit keeps one partial catalogue per value: arrays `labels.j`, `points.j` and
    // the j-th entry of `values` in its meta (see `fresh_value`).
    let reduce = |u: usize, _e: &EnsembleSpec, res: EnsembleResult| {
        let mut unit = Unit::new("");
        let mut metas = Vec::new();
        let rec = res.recorded * STATE_DIM;
        for (j, i) in (u * per_unit..((u + 1) * per_unit).min(n)).enumerate() {
            let lanes = j * k..(j + 1) * k;
            let (_, w) = spec.value_params(i);
            let mut b = CatalogueBuilder::new(w, spec.catalogue);
            let frozen: Vec<bool> = res.status[lanes.clone()]
                .iter()
                .map(|s| s.is_frozen())
                .collect();
            let labels = b.add_block(
                &res.poincare[lanes.start * rec..lanes.end * rec],
                res.recorded,
                &frozen,
                res.lambda1.as_ref().map(|l| &l[lanes.clone()]),
            );
            let (parts, labels, diverged) = b.finish_part(labels);
            let part = super::catalogue::part_unit(labels, &parts, diverged);
            for (name, a) in part.arrays {
                unit = unit.with(&format!("{name}.{j}"), a);
            }
            metas.push(part.meta);
        }
        Ok(unit.with_meta(&FreshMeta { values: metas }))
    };
    let info = crate::run::lanes::run_units(
        store,
        engine,
        &LaneUnits {
            stage: FRESH,
            count,
            ensemble: &ensemble,
            lanes: &|u| per_unit.min(n - u * per_unit) * k,
            lambda1: spec.lyapunov,
            reduce: &reduce,
        },
        ctl,
    )?;
    // A shard's work ends here: reading the fresh pass is the merge's (NotInShard), and
    // the ramps' stages must not be asked about before, so a shard never lists them.
    fresh_value(spec, store, 0)?;
    let mut ramps = Vec::new();
    for &d in &spec.directions {
        ramps.push(ramp(spec, engine, store, d, ctl)?);
    }
    Ok(ContinuationResult {
        values: spec.param.values(),
        ramps,
        info,
        seconds: t0.elapsed().as_secs_f64(),
    })
}

/// Poincare-set distance between two attractors at speed `w`: the larger of the two
/// mean nearest-point distances (a mean Hausdorff distance, robust to a cloud's spread).
pub fn set_distance(a: &[State], b: &[State], w: f64) -> f64 {
    let one_way = |x: &[State], y: &[State]| {
        x.iter()
            .map(|p| {
                y.iter()
                    .map(|q| distance(p, q, w))
                    .fold(f64::INFINITY, f64::min)
            })
            .sum::<f64>()
            / x.len().max(1) as f64
    };
    if a.is_empty() || b.is_empty() {
        return f64::INFINITY;
    }
    one_way(a, b).max(one_way(b, a))
}

/// Matches `now` to `prev` (greedy in increasing set distance, each at most once, within
/// `threshold`); returns for each of `now` the index into `prev` it continues.
pub fn match_attractors(
    prev: &[Vec<State>],
    now: &[Vec<State>],
    w: f64,
    threshold: f64,
) -> Vec<Option<usize>> {
    let mut pairs: Vec<(f64, usize, usize)> = Vec::new();
    for (i, p) in prev.iter().enumerate() {
        for (j, q) in now.iter().enumerate() {
            let d = set_distance(p, q, w);
            if d <= threshold {
                pairs.push((d, i, j));
            }
        }
    }
    pairs.sort_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)).then(x.2.cmp(&y.2)));
    let mut out = vec![None; now.len()];
    let mut used = vec![false; prev.len()];
    for (_, i, j) in pairs {
        if !used[i] && out[j].is_none() {
            used[i] = true;
            out[j] = Some(i);
        }
    }
    out
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

/// Unit of step `s` of a ramp: the step and the next free id.
fn step_unit(step: &Step, next_id: u32) -> Unit {
    let counts: Vec<usize> = step.attractors.iter().map(|a| a.points.len()).collect();
    Unit::new("")
        .with("labels", Array::I32(step.labels.clone()))
        .with(
            "points",
            Array::F64(
                step.attractors
                    .iter()
                    .flat_map(|a| a.points.iter().flatten().copied())
                    .collect(),
            ),
        )
        .with_meta(&StepMeta {
            step,
            point_counts: counts,
            next_id,
        })
}

/// The metadata of a fresh-pass unit: per value, its partial catalogue's metadata
/// (`catalogue::part_unit`), the arrays of value j named `labels.j`, `points.j`.
#[derive(Serialize, Deserialize)]
struct FreshMeta {
    values: Vec<serde_json::Value>,
}

/// The metadata of a ramp step's unit: the step (its attractors' points in the unit's
/// `points` array, its labels in `labels`), how many points each attractor has, and the
/// next free continuation id.
#[derive(Serialize, Deserialize)]
struct StepMeta<S> {
    step: S,
    point_counts: Vec<usize>,
    next_id: u32,
}

fn unit_step(unit: &Unit) -> Result<(Step, u32)> {
    let bad = |what: String| Error::Io {
        path: format!("unit {}", unit.key).into(),
        source: std::io::Error::new(std::io::ErrorKind::InvalidData, what),
    };
    let StepMeta {
        mut step,
        point_counts: counts,
        next_id: next,
    } = unit.meta_as::<StepMeta<Step>>()?;
    step.labels = unit.i32s("labels")?.to_vec();
    let flat = unit.f64s("points")?;
    if counts.len() != step.attractors.len()
        || counts.iter().sum::<usize>() * STATE_DIM != flat.len()
    {
        return Err(bad("points do not match".into()));
    }
    let mut at = 0;
    for (a, &c) in step.attractors.iter_mut().zip(&counts) {
        a.points = flat[at * STATE_DIM..(at + c) * STATE_DIM]
            .chunks_exact(STATE_DIM)
            .map(|x| x.try_into().unwrap_or([f64::NAN; STATE_DIM]))
            .collect();
        at += c;
    }
    Ok((step, next))
}

/// The seeded pass in one direction: one unit per value, in ramp order, each needing the
/// previous one.
fn ramp(
    spec: &ContinuationSpec,
    engine: &crate::backend::Engine,
    store: &dyn UnitStore,
    dir: Direction,
    ctl: Control,
) -> Result<Ramp> {
    let n = spec.param.n;
    let order: Vec<usize> = match dir {
        Direction::Up => (0..n).collect(),
        Direction::Down => (0..n).rev().collect(),
    };
    let stage = dir.name();
    let done = store.committed(stage, n)?;
    let mut steps: Vec<Step> = Vec::with_capacity(n);
    let mut next_id = 0u32;
    for (s, &i) in order.iter().enumerate() {
        if done[s] {
            let (step, next) = unit_step(&store.load(stage, s)?)?;
            steps.push(step);
            next_id = next;
            continue;
        }
        if ctl.cancel.is_set() {
            return Err(Error::Interrupted {
                committed: s,
                total: n,
            });
        }
        let fresh = fresh_value(spec, store, i)?;
        let (parts, diverged) = super::catalogue::unit_parts(&fresh)?;
        let prev: &[Tracked] = steps.last().map(|p| p.attractors.as_slice()).unwrap_or(&[]);
        let step = seeded_step(
            spec,
            engine,
            i,
            &parts,
            diverged,
            fresh.i32s("labels")?,
            prev,
            &mut next_id,
        )?;
        store.commit(stage, s, &step_unit(&step, next_id))?;
        steps.push(step);
    }
    Ok(Ramp {
        direction: dir,
        steps,
        ids: next_id as usize,
    })
}

/// One value of the seeded pass: the fresh partial catalogue absorbed, the previous
/// value's attractors seeded, everything catalogued and matched to the previous value.
#[allow(clippy::too_many_arguments)]
fn seeded_step(
    spec: &ContinuationSpec,
    engine: &crate::backend::Engine,
    i: usize,
    parts: &[PartAttractor],
    diverged: u64,
    fresh_labels: &[i32],
    prev: &[Tracked],
    next_id: &mut u32,
) -> Result<Step> {
    let (_, w) = spec.value_params(i);
    let k = fresh_labels.len();
    let mut b = CatalogueBuilder::new(w, spec.catalogue);
    let ids: Vec<i32> = parts.iter().map(|p| b.absorb(p, 0)).collect();
    b.add_lanes(k as u64, diverged);
    let mut labels: Vec<i32> = fresh_labels
        .iter()
        .map(|&l| if l >= 0 { ids[l as usize] } else { -1 })
        .collect();
    // One seed lane per previous attractor, from one of its Poincare points (a state at
    // t = kT, where every lane starts its forcing phase).
    let seeds: Vec<State> = prev
        .iter()
        .filter_map(|a| a.points.first().copied())
        .collect();
    if !seeds.is_empty() {
        let e = spec.ensemble(i, seeds);
        let (res, _) = engine.run(&e, spec.lyapunov, Control::none())?;
        for lane in 0..e.lanes.len() {
            let states = res.lane_states(lane);
            let lc = classify_lane(
                &states,
                w,
                res.status[lane].is_frozen(),
                res.lambda1.as_ref().map(|l| l[lane]),
                &spec.catalogue,
            );
            labels.push(b.add(lc));
        }
    }
    let cat = b.finish(labels);
    let fresh = &cat.labels[..k];
    let now: Vec<Vec<State>> = cat.attractors.iter().map(|a| a.points.clone()).collect();
    let before: Vec<Vec<State>> = prev.iter().map(|a| a.points.clone()).collect();
    let matched = match_attractors(&before, &now, w, spec.match_threshold);
    let gid: Vec<u32> = matched
        .iter()
        .map(|m| match m {
            Some(p) => prev[*p].id,
            None => {
                *next_id += 1;
                *next_id - 1
            }
        })
        .collect();
    let kf = k.max(1) as f64;
    let attractors = cat
        .attractors
        .iter()
        .zip(&gid)
        .map(|(a, &id)| {
            let hits = fresh.iter().filter(|&&l| l == a.id as i32).count();
            let f = hits as f64 / kf;
            Tracked {
                id,
                class: a.class.clone(),
                period: a.period,
                fraction: f,
                error: (f * (1.0 - f) / kf).sqrt(),
                lambda1: a.lambda1,
                size_m: a.size_m,
                seeded_only: hits == 0,
                points: a.points.iter().take(64).copied().collect(),
            }
        })
        .collect();
    let diverged = fresh.iter().filter(|&&l| l < 0).count();
    Ok(Step {
        value: spec.param.value(i),
        attractors,
        diverged_fraction: diverged as f64 / kf,
        labels: fresh
            .iter()
            .map(|&l| if l >= 0 { gid[l as usize] as i32 } else { -1 })
            .collect(),
    })
}

/// Legend name of continuation id `id` in a ramp: its class where it has the largest
/// basin, e.g. "#1 period-4".
pub fn id_name(r: &Ramp, id: u32) -> String {
    let best = r
        .steps
        .iter()
        .flat_map(|s| s.attractors.iter())
        .filter(|a| a.id == id)
        .max_by(|a, b| a.fraction.total_cmp(&b.fraction));
    match best {
        Some(a) => format!("#{id} {}", a.class),
        None => format!("#{id}"),
    }
}

/// A continuation's specification as `run.json` records it.
#[derive(Clone, Debug, Serialize)]
pub struct SpecRecord<'a> {
    /// The continued parameter (var, lo, hi, n).
    pub param: AxisRecord,
    /// Rotor speed when the parameter is not `omega` [rad/s].
    pub omega: Option<f64>,
    /// Fresh start states per value.
    pub ics: u32,
    /// The box of the fresh start states as (coordinate index, lo, hi).
    #[serde(rename = "box")]
    pub start_box: Option<&'a [(usize, f64, f64)]>,
    /// Seed of the start states.
    pub seed: u64,
    /// Transient periods.
    pub transient: u32,
    /// Recorded periods.
    pub periods: u32,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
    /// Lane precision.
    pub precision: Precision,
    /// Catalogue settings.
    pub catalogue: &'a CatalogueConfig,
    /// Whether lambda_1 is computed.
    pub lyapunov: bool,
    /// The ramps.
    pub directions: &'a [Direction],
    /// Largest matching distance.
    pub match_threshold: Threshold,
    /// Values per unit of the fresh pass.
    pub unit_values: usize,
    /// Model parameters.
    pub params: &'a Params,
}

/// The matching threshold as the files hold it: a number, or `"inf"` (JSON has no
/// infinity) for matching without one.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
#[serde(untagged)]
pub enum Threshold {
    /// A finite threshold [m].
    Value(f64),
    /// No threshold.
    Inf(&'static str),
}

impl Threshold {
    /// The record of `m`.
    pub fn of(m: f64) -> Self {
        if m.is_finite() {
            Threshold::Value(m)
        } else {
            Threshold::Inf("inf")
        }
    }
}

/// An attractor's life along a ramp, as `continuation.json` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct Lifetime {
    /// Continuation id.
    pub id: u32,
    /// Legend name ([`id_name`]).
    pub name: String,
    /// First value where it was found.
    pub first_value: f64,
    /// Last value where it was found.
    pub last_value: f64,
    /// Whether it appears after the ramp's first value.
    pub born_inside: bool,
    /// Whether it disappears before the ramp's last value.
    pub dies_inside: bool,
}

/// One ramp of `continuation.json`.
#[derive(Clone, Debug, Serialize)]
pub struct RampRecord<'a> {
    /// How `steps` are ordered.
    pub order: &'static str,
    /// Every attractor's life along the ramp.
    pub attractors: Vec<Lifetime>,
    /// Every step's attractors.
    pub steps: &'a [Step],
}

/// The continuation as `continuation.json` holds it (the command line adds the list of
/// files and the version): the continued parameter, the settings, and per ramp every
/// attractor's first and last value and every step's attractors.
#[derive(Clone, Debug, Serialize)]
pub struct Summary<'a> {
    /// The continued parameter (var, unit, lo, hi, n).
    pub param: AxisRecord,
    /// Rotor speed when the parameter is not `omega` [rad/s].
    pub omega: Option<f64>,
    /// Fresh start states per value.
    pub ics: u32,
    /// The box of the fresh start states, if one was given.
    #[serde(rename = "box")]
    pub start_box: Option<Vec<CoordRange>>,
    /// Seed of the start states.
    pub seed: u64,
    /// Transient periods.
    pub transient: u32,
    /// Recorded periods.
    pub periods: u32,
    /// Whether lambda_1 was computed.
    pub lyapunov: bool,
    /// Largest matching distance.
    pub match_threshold: Threshold,
    /// The ramps by direction (`up`, `down`).
    pub ramps: std::collections::BTreeMap<&'static str, RampRecord<'a>>,
    /// Model parameters.
    pub params: &'a Params,
}

/// The summary `continuation.json` holds.
pub fn summary<'a>(spec: &'a ContinuationSpec, res: &'a ContinuationResult) -> Summary<'a> {
    let n = res.values.len();
    let ramps = res
        .ramps
        .iter()
        .map(|r| {
            let attractors = r
                .lifetimes()
                .into_iter()
                .map(|(id, first, last)| Lifetime {
                    id,
                    name: id_name(r, id),
                    first_value: first,
                    last_value: last,
                    born_inside: first != r.steps[0].value,
                    dies_inside: last != r.steps[n - 1].value,
                })
                .collect();
            let record = RampRecord {
                order: "steps in ramp order (up: ascending values, down: descending)",
                attractors,
                steps: &r.steps,
            };
            (r.direction.name(), record)
        })
        .collect();
    Summary {
        param: AxisRecord {
            log: None,
            ..spec.param.record()
        },
        omega: spec.omega,
        ics: spec.ics,
        start_box: spec.start_box.as_deref().map(coord_box),
        seed: spec.seed,
        transient: spec.transient,
        periods: spec.recorded,
        lyapunov: spec.lyapunov,
        match_threshold: Threshold::of(spec.match_threshold),
        ramps,
        params: &spec.params,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn pt(x: f64) -> State {
        let mut s = [0.0; STATE_DIM];
        s[0] = x;
        s
    }

    #[test]
    fn matching_pairs_nearest_sets_first_and_each_once() {
        let prev = vec![vec![pt(0.0)], vec![pt(1.0)]];
        let now = vec![vec![pt(1.1)], vec![pt(0.05)], vec![pt(5.0)]];
        let m = match_attractors(&prev, &now, 100.0, f64::INFINITY);
        assert_eq!(m, vec![Some(1), Some(0), None]);
        let m = match_attractors(&prev, &now, 100.0, 0.08);
        assert_eq!(m, vec![None, Some(0), None]);
    }

    #[test]
    fn tipping_rows_sum_to_one_and_follow_the_start_states() {
        let step = |labels: Vec<i32>| Step {
            value: 0.0,
            attractors: Vec::new(),
            diverged_fraction: 0.0,
            labels,
        };
        let r = Ramp {
            direction: Direction::Up,
            steps: vec![step(vec![0, 0, 1, 1]), step(vec![0, 1, 1, -1])],
            ids: 2,
        };
        let t = r.tipping();
        let g = 3;
        assert_eq!(&t[0..g], &[0.5, 0.5, 0.0]);
        assert_eq!(&t[g..2 * g], &[0.0, 0.5, 0.5]);
        assert!(t[2 * g].is_nan(), "no basin of diverged at the first step");
    }
}
