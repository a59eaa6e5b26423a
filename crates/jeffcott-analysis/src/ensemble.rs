//! What an ensemble run reports beyond its arrays: the counters summed over lanes and
//! the `run.json` record (backend, speed, counters, status counts), the same for the
//! command line's `run.json` and the dictionary the Python package returns.

use jeffcott_core::ensemble::{EnsembleSpec, RunInfo, lane_table_columns};
use jeffcott_core::integrate::lane::{Counters, Status};
use serde::Serialize;

/// Lane counters summed over an ensemble (the largest penetration is the maximum).
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
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

    /// The totals as a work unit's metadata holds them.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::to_value(self).unwrap_or_default()
    }

    /// Reads the totals back from a unit's metadata (absent keys count 0).
    pub fn from_json(m: &serde_json::Value) -> Totals {
        let get = |k: &str| m[k].as_u64().unwrap_or(0);
        Totals {
            macro_steps: get("macro_steps"),
            contact_steps: get("contact_steps"),
            switches: get("switches"),
            extra_substeps: get("extra_substeps"),
            max_penetration_m: m["max_penetration_m"].as_f64().unwrap_or(0.0),
        }
    }
}

/// How many lanes ended with each status, by status name.
pub fn status_counts(codes: &[u32]) -> serde_json::Value {
    let count = |s: Status| codes.iter().filter(|&&c| c == s.code()).count();
    serde_json::json!({
        "ok": count(Status::Ok),
        "refinement_cap": count(Status::RefinementCap),
        "diverged": count(Status::Diverged),
        "non_finite": count(Status::NonFinite),
    })
}

/// The record of a finished ensemble as `run.json` holds it (the command line adds the
/// list of files and the version): backend, device, precision, sizes, wall time and
/// speed, the counters and the status counts.
pub fn run_record(
    spec: &EnsembleSpec,
    totals: &Totals,
    codes: &[u32],
    info: &RunInfo,
) -> serde_json::Value {
    let n = spec.lanes.len();
    serde_json::json!({
        "backend": info.backend,
        "device": info.device,
        "backend_reason": info.reason,
        "precision": info.precision,
        "lanes": n,
        "transient": spec.transient,
        "periods": spec.recorded,
        "steps_per_period": spec.stepper.steps_per_period,
        "wall_time_s": info.elapsed_s,
        "lane_steps_per_s": totals.macro_steps as f64 / info.elapsed_s,
        "forcing_periods_per_s": (n as f64 * (spec.transient + spec.recorded) as f64) / info.elapsed_s,
        "counters": totals,
        "status_counts": status_counts(codes),
        "status_codes": {"0": "ok", "1": "refinement_cap", "2": "diverged", "3": "non_finite"},
        "lanes_columns": lane_table_columns(),
        "params": spec.param_sets,
    })
}

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
