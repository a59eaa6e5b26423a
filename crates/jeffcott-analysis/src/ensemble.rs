//! What an ensemble run reports beyond its arrays: the counters summed over lanes and
//! the `run.json` record (backend, speed, counters, status counts), the same for the
//! command line's `run.json` and the dictionary the Python package returns.

use jeffcott_core::ensemble::{EnsembleSpec, Precision, RunInfo, lane_table_columns};
use jeffcott_core::integrate::lane::{Counters, Status};
use jeffcott_core::model::Params;
use serde::Serialize;

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

/// The record `run.json` holds.
pub fn run_record<'a>(
    spec: &'a EnsembleSpec,
    totals: &Totals,
    codes: &[u32],
    info: &'a RunInfo,
) -> RunRecord<'a> {
    let n = spec.lanes.len();
    RunRecord {
        backend: info.backend,
        device: &info.device,
        backend_reason: &info.reason,
        precision: info.precision,
        lanes: n,
        transient: spec.transient,
        periods: spec.recorded,
        steps_per_period: spec.stepper.steps_per_period,
        wall_time_s: info.elapsed_s,
        lane_steps_per_s: totals.macro_steps as f64 / info.elapsed_s,
        forcing_periods_per_s: (n as f64 * (spec.transient + spec.recorded) as f64)
            / info.elapsed_s,
        counters: *totals,
        status_counts: status_counts(codes),
        status_codes: STATUS_CODE_NAMES.into_iter().collect(),
        lanes_columns: lane_table_columns(),
        params: &spec.param_sets,
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

/// `lanes.npy` of an ensemble: per lane W, its parameter set and its start state,
/// `[lanes, 10]` flat.
pub fn lanes_table(spec: &EnsembleSpec) -> Vec<f64> {
    let mut table = Vec::with_capacity(spec.lanes.len() * (2 + jeffcott_core::model::STATE_DIM));
    for l in &spec.lanes {
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
