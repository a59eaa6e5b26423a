//! The ensemble study (`jeffcott ensemble`): its recorded specification, its run in
//! work units that keep their own lanes (so the files, a merge's included, are
//! assembled from the units and the record alone), and what a run reports beyond its
//! arrays: the counters summed over lanes and the `run.json` record (backend, speed,
//! counters, status counts), the same for the command line's `run.json` and the
//! dictionary the Python package returns.

use crate::record::Span;
use crate::run::lanes::{Control, LaneUnits, Split};
use crate::run::{Array, Host, Stage, Unit};
use jeffcott_core::ensemble::{
    Backend, EnsembleResult, EnsembleSpec, LaneSpec, Precision, RunInfo, lane_table_columns,
};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::{Counters, Status, StepperConfig};
use jeffcott_core::model::{Params, State};
use serde::{Deserialize, Serialize};

/// Stage name of an ensemble's units.
pub const STAGE: &str = "ensemble";

/// Where an ensemble's lanes come from, as its run records them: a speed range from one
/// start state, or a table (named, with a checksum of the lanes read from it).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(untagged)]
pub enum LanesRecord {
    /// Lanes from a table.
    Table {
        /// The table, its columns, its rows and a checksum of the lanes read.
        lanes: TableRecord,
    },
    /// A speed range.
    Range {
        /// The speeds.
        omega: Span,
        /// The start state of every lane.
        x0: State,
    },
}

/// A lane table as `run.json` records it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TableRecord {
    /// Its path as given.
    pub table: String,
    /// Its columns.
    pub columns: Vec<String>,
    /// Its rows.
    pub count: usize,
    /// [`jeffcott_core::ensemble::table::lanes_checksum`] of the lanes and parameter
    /// sets read.
    pub checksum: String,
}

/// An ensemble as its run records it (run.json's `spec`, the run's identity): how its
/// lanes run, their parameter sets and where they come from. The lanes themselves
/// (`given`) are not recorded (a table's would be as large as the run); each unit keeps
/// its own, so a merge, or a run whose units are all committed, needs none.
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct EnsembleStudy {
    /// Forcing periods integrated and discarded.
    pub transient: u32,
    /// Forcing periods recorded per lane.
    pub periods: u32,
    /// The lane stepper.
    pub stepper: StepperConfig,
    /// Lane precision.
    pub precision: Precision,
    /// Whether each lane computes lambda_1.
    pub lyapunov: bool,
    /// Lanes per work unit.
    pub unit_lanes: usize,
    /// The parameter sets the lanes index.
    pub params: Vec<Params>,
    /// Where the lanes come from.
    #[serde(flatten)]
    pub lanes: LanesRecord,
    /// The backend (not recorded: units computed on any backend combine).
    #[serde(skip)]
    pub backend: Backend,
    /// The lanes, in order (not recorded; empty when read from a record).
    #[serde(skip)]
    pub given: std::sync::Arc<Vec<LaneSpec>>,
}

impl crate::record::StudySpec for EnsembleStudy {
    fn set_backend(&mut self, backend: Backend) {
        self.backend = backend;
    }
}

impl EnsembleStudy {
    /// The study of `spec`'s lanes (recorded as `lanes`) with lambda_1 where `lyapunov`,
    /// in units of the engine's default size.
    pub fn of(spec: EnsembleSpec, lanes: LanesRecord, lyapunov: bool, backend: Backend) -> Self {
        let per_lane = (spec.transient + spec.recorded) as u64;
        EnsembleStudy {
            transient: spec.transient,
            periods: spec.recorded,
            stepper: spec.stepper,
            precision: spec.precision,
            lyapunov,
            unit_lanes: crate::run::unit_lanes(
                spec.lanes.len(),
                per_lane * spec.stepper.steps_per_period as u64 * if lyapunov { 2 } else { 1 },
            ),
            params: spec.param_sets,
            lanes,
            backend,
            given: std::sync::Arc::new(spec.lanes),
        }
    }

    /// Number of lanes.
    pub fn lane_count(&self) -> usize {
        match &self.lanes {
            LanesRecord::Table { lanes } => lanes.count,
            LanesRecord::Range { omega, .. } => omega.count,
        }
    }

    /// Its units.
    pub fn split(&self) -> Split {
        Split::new(self.lane_count(), self.unit_lanes)
    }

    /// The sizes its record states.
    pub fn sizes(&self) -> Sizes<'_> {
        Sizes {
            lanes: self.lane_count(),
            transient: self.transient,
            periods: self.periods,
            steps_per_period: self.stepper.steps_per_period,
            params: &self.params,
        }
    }
}

/// Runs `study` on `engine` under `host`: its lanes (`given`; none needed when every
/// unit is committed, as in a merge) in units of `study.unit_lanes`, each committing its Poincare records, status codes, counter
/// totals, lambda_1 where asked, and its lanes as rows of [`lanes_table`]. Returns how
/// the last batch ran (for a run whose units were all committed: the engine, nothing
/// run).
pub fn run(
    study: &EnsembleStudy,
    engine: &crate::backend::Engine,
    host: &impl Host,
) -> Result<RunInfo> {
    let lanes = &study.given[..];
    let n = study.lane_count();
    let split = study.split();
    let store = host.store();
    let pending = store.committed(STAGE, split.count())?.iter().any(|&c| !c);
    if pending && lanes.len() != n {
        return Err(Error::invalid(
            "lanes",
            lanes.len(),
            format!("the ensemble's record names {n} lanes and units are left to compute"),
        ));
    }
    let spec = EnsembleSpec {
        lanes: Vec::new(),
        param_sets: study.params.clone(),
        transient: study.transient,
        recorded: study.periods,
        stepper: study.stepper,
        precision: study.precision,
    };
    let ensemble = |u: usize| EnsembleSpec {
        lanes: lanes[split.range(u)].to_vec(),
        ..spec.clone()
    };
    let reduce = |_u: usize, e: &EnsembleSpec, r: EnsembleResult| {
        let mut out = Unit::new("")
            .with("poincare", Array::F64(r.poincare))
            .with(
                "status",
                Array::U32(r.status.iter().map(|s| s.code()).collect()),
            )
            .with("lanes", Array::F64(lanes_table(&e.lanes)))
            .with_meta(&Totals::of(&r.counters));
        if let Some(l) = r.lambda1 {
            out = out.with("lambda1", Array::F64(l));
        }
        Ok(out)
    };
    let per_lane = (study.transient + study.periods) as u64;
    let ran = host.progress(
        Stage::new(STAGE, n as u64 * per_lane, per_lane),
        |ctl: Control| {
            LaneUnits::new(STAGE, split, &ensemble, &reduce)
                .lambda1(study.lyapunov)
                .run(store, engine, ctl)
        },
    )?;
    // A shard's work ends here: the assembly, which reads the units, is the merge's
    // (a shard's store answers ShardDone).
    store.load(STAGE, 0)?;
    Ok(ran.unwrap_or(RunInfo {
        backend: if engine.runner().is_some() {
            "gpu"
        } else {
            "cpu"
        },
        device: String::new(),
        reason: "every unit was already committed".into(),
        precision: study.precision,
        elapsed_s: 0.0,
        setup_s: 0.0,
    }))
}

/// Lane counters summed over an ensemble (the largest penetration is the maximum); a
/// work unit's metadata (absent keys, from units of earlier versions, count 0).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, serde::Deserialize)]
#[serde(default)]
pub struct Totals {
    /// Macro steps integrated.
    pub macro_steps: u64,
    /// Macro steps in contact.
    pub contact_steps: u64,
    /// Located contact switches.
    pub switches: u64,
    /// RK4 sub-steps beyond one per macro step.
    pub extra_substeps: u64,
    /// Largest penetration seen [m].
    pub max_penetration_m: f64,
}

impl Totals {
    /// The sums over `counters`.
    pub fn of(counters: &[Counters]) -> Totals {
        let mut t = Totals::default();
        for c in counters {
            t.add(&Totals {
                macro_steps: c.macro_steps,
                contact_steps: c.contact_steps,
                switches: c.switches,
                extra_substeps: c.extra_substeps,
                max_penetration_m: c.max_penetration,
            });
        }
        t
    }

    /// Adds another part's totals.
    pub fn add(&mut self, o: &Totals) {
        self.macro_steps += o.macro_steps;
        self.contact_steps += o.contact_steps;
        self.switches += o.switches;
        self.extra_substeps += o.extra_substeps;
        self.max_penetration_m = self.max_penetration_m.max(o.max_penetration_m);
    }
}

/// How many lanes ended with each status, by status name.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize)]
pub struct StatusCounts {
    /// Lanes that ran to the end.
    pub ok: usize,
    /// Lanes that hit the refinement cap.
    pub refinement_cap: usize,
    /// Lanes that left the divergence bound.
    pub diverged: usize,
    /// Lanes whose state became non-finite.
    pub non_finite: usize,
}

/// The counts of the status codes `codes`.
pub fn status_counts(codes: &[u32]) -> StatusCounts {
    let count = |s: Status| codes.iter().filter(|&&c| c == s.code()).count();
    StatusCounts {
        ok: count(Status::Ok),
        refinement_cap: count(Status::RefinementCap),
        diverged: count(Status::Diverged),
        non_finite: count(Status::NonFinite),
    }
}

/// The record of a finished ensemble as `run.json` holds it (the command line adds the
/// list of files and the version): backend, device, precision, sizes, wall time and
/// speed, the counters and the status counts.
#[derive(Clone, Debug, Serialize)]
pub struct RunRecord<'a> {
    /// Backend that ran the lanes (`cpu`, `gpu`).
    pub backend: &'static str,
    /// The device (CPU threads or the adapter).
    pub device: &'a str,
    /// Why this backend (e.g. `auto` found no adapter).
    pub backend_reason: &'a str,
    /// Lane precision.
    pub precision: Precision,
    /// Number of lanes.
    pub lanes: usize,
    /// Transient periods.
    pub transient: u32,
    /// Recorded periods.
    pub periods: u32,
    /// Macro steps per forcing period.
    pub steps_per_period: u32,
    /// Wall time [s].
    pub wall_time_s: f64,
    /// The part of the wall time spent opening the device and building its pipelines [s].
    pub setup_time_s: f64,
    /// Macro steps per second, summed over lanes.
    pub lane_steps_per_s: f64,
    /// Forcing periods per second, summed over lanes.
    pub forcing_periods_per_s: f64,
    /// The counters summed over lanes.
    pub counters: Totals,
    /// Lanes per status.
    pub status_counts: StatusCounts,
    /// What each code of `status.npy` means.
    pub status_codes: std::collections::BTreeMap<&'static str, &'static str>,
    /// The columns of `lanes.npy`.
    pub lanes_columns: Vec<String>,
    /// The parameter sets.
    pub params: &'a [Params],
}

/// An ensemble's sizes as its record states them.
#[derive(Clone, Copy, Debug)]
pub struct Sizes<'a> {
    /// Number of lanes.
    pub lanes: usize,
    /// Transient periods.
    pub transient: u32,
    /// Recorded periods.
    pub periods: u32,
    /// Macro steps per forcing period.
    pub steps_per_period: u32,
    /// The parameter sets.
    pub params: &'a [Params],
}

impl<'a> Sizes<'a> {
    /// The sizes of `spec`.
    pub fn of(spec: &'a EnsembleSpec) -> Self {
        Sizes {
            lanes: spec.lanes.len(),
            transient: spec.transient,
            periods: spec.recorded,
            steps_per_period: spec.stepper.steps_per_period,
            params: &spec.param_sets,
        }
    }
}

/// The record `run.json` holds.
pub fn run_record<'a>(
    spec: Sizes<'a>,
    totals: &Totals,
    codes: &[u32],
    info: &'a RunInfo,
) -> RunRecord<'a> {
    let n = spec.lanes;
    RunRecord {
        backend: info.backend,
        device: &info.device,
        backend_reason: &info.reason,
        precision: info.precision,
        lanes: n,
        transient: spec.transient,
        periods: spec.periods,
        steps_per_period: spec.steps_per_period,
        wall_time_s: info.elapsed_s,
        setup_time_s: info.setup_s,
        lane_steps_per_s: totals.macro_steps as f64 / info.elapsed_s,
        forcing_periods_per_s: (n as f64 * (spec.transient + spec.periods) as f64) / info.elapsed_s,
        counters: *totals,
        status_counts: status_counts(codes),
        status_codes: STATUS_CODE_NAMES.into_iter().collect(),
        lanes_columns: lane_table_columns(),
        params: spec.params,
    }
}

/// The status codes of `status.npy` and their names (the names [`Status`] serializes to;
/// a test holds them to it).
const STATUS_CODE_NAMES: [(&str, &str); 4] = [
    ("0", "ok"),
    ("1", "refinement_cap"),
    ("2", "diverged"),
    ("3", "non_finite"),
];

/// `lanes.npy` of an ensemble's `lanes`: per lane W, its parameter set and its start
/// state, `[lanes, 10]` flat.
pub fn lanes_table(lanes: &[LaneSpec]) -> Vec<f64> {
    let mut table = Vec::with_capacity(lanes.len() * (2 + jeffcott_core::model::STATE_DIM));
    for l in lanes {
        table.push(l.omega);
        table.push(l.param_set as f64);
        table.extend_from_slice(&l.x0);
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_ensemble_record_reads_back_as_the_same_study_and_the_same_json() {
        use jeffcott_core::ensemble::LaneSpec;
        let p = Params::default();
        let x0 = p.static_equilibrium();
        let omegas = jeffcott_core::ensemble::RangeSpec::parse("omega", "130:141:12")
            .unwrap()
            .values();
        let spec = |lanes: Vec<LaneSpec>| EnsembleSpec {
            lanes,
            param_sets: vec![p.clone()],
            transient: 40,
            recorded: 8,
            stepper: StepperConfig::DEFAULT,
            precision: Precision::F64,
        };
        let range = LanesRecord::Range {
            omega: Span::of(&omegas),
            x0,
        };
        let table = LanesRecord::Table {
            lanes: TableRecord {
                table: "lanes.csv".into(),
                columns: vec!["omega".into(), "x_r".into()],
                count: 12,
                checksum: "0123abcd".into(),
            },
        };
        for record in [range, table] {
            let study = EnsembleStudy::of(
                spec(LaneSpec::at_speeds(&omegas, x0)),
                record.clone(),
                true,
                Backend::Cpu,
            );
            let json = serde_json::to_value(&study).unwrap();
            let back: EnsembleStudy = serde_json::from_value(json.clone()).unwrap();
            assert_eq!(back.lanes, record);
            assert_eq!(back.lane_count(), 12);
            assert!(back.given.is_empty(), "the lanes are not recorded");
            assert_eq!(serde_json::to_value(&back).unwrap(), json);
        }
    }

    #[test]
    fn status_code_names_are_the_codes_and_names_status_has() {
        for s in [
            Status::Ok,
            Status::RefinementCap,
            Status::Diverged,
            Status::NonFinite,
        ] {
            let (code, name) = STATUS_CODE_NAMES[s.code() as usize];
            assert_eq!(code, s.code().to_string());
            assert_eq!(serde_json::to_value(s).unwrap(), serde_json::json!(name));
        }
    }
}
