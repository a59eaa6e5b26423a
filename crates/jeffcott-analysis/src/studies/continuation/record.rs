//! The continuation as its files hold it: the specification for `run.json`, the
//! summary for `continuation.json` (each attractor's lifetime per ramp) and legend names.

use super::{ContinuationResult, ContinuationSpec, Ramp, Step};
use crate::map::AxisRecord;
use crate::record::{CoordRange, coord_box};
use jeffcott_core::model::Params;
use serde::Serialize;

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

/// The matching threshold as the files hold it: a number, or `"inf"` (JSON has no
/// infinity) for matching without one: `#[serde(with = "threshold")]`.
pub mod threshold {
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// A finite threshold as a number, an infinite one as `"inf"`.
    pub fn serialize<S: Serializer>(m: &f64, s: S) -> Result<S::Ok, S::Error> {
        if m.is_finite() {
            m.serialize(s)
        } else {
            s.serialize_str("inf")
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Recorded {
        Value(f64),
        Word(String),
    }

    /// The threshold back: a number, or infinity from `"inf"`.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
        match Recorded::deserialize(d)? {
            Recorded::Value(m) => Ok(m),
            Recorded::Word(w) if w == "inf" => Ok(f64::INFINITY),
            Recorded::Word(w) => Err(serde::de::Error::custom(format!(
                "match_threshold `{w}` is neither a number nor \"inf\""
            ))),
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
    #[serde(with = "threshold")]
    pub match_threshold: f64,
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
        periods: spec.periods,
        lyapunov: spec.lane.lyapunov,
        match_threshold: spec.match_threshold,
        ramps,
        params: &spec.lane.params,
    }
}
