//! Pieces shared by the records the JSON files hold (`run.json`'s specifications,
//! `summary.json`, `map.json`, ...): a speed range, a box of start coordinates, a state
//! by coordinate name. Every file is a `#[derive(Serialize)]` struct of its study's
//! module built from these; [`crate::output::write_json`] writes each object's keys
//! sorted, so a file does not depend on the order a struct declares its fields in.

use jeffcott_core::model::{COORD_NAMES, State};
use serde::{Deserialize, Serialize};

/// A range of values as the files record it: first, last and how many.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Span {
    /// First value.
    pub first: f64,
    /// Last value.
    pub last: f64,
    /// Number of values.
    pub count: usize,
}

impl Span {
    /// The span of `values` (NaN ends for an empty list, which no study accepts).
    pub fn of(values: &[f64]) -> Self {
        Span {
            first: values.first().copied().unwrap_or(f64::NAN),
            last: values.last().copied().unwrap_or(f64::NAN),
            count: values.len(),
        }
    }
}

/// A state coordinate held as its index and recorded by its name (`x_r`, `vy_s`, ...):
/// `#[serde(with = "crate::record::coord_name")]`.
pub mod coord_name {
    use jeffcott_core::model::COORD_NAMES;
    use serde::{Deserialize, Deserializer, Serializer};

    /// Writes the coordinate's name.
    pub fn serialize<S: Serializer>(c: &usize, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(COORD_NAMES.get(*c).copied().unwrap_or("?"))
    }

    /// Reads a coordinate name back into its index; an unknown name is an error.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<usize, D::Error> {
        let name = String::deserialize(d)?;
        COORD_NAMES
            .iter()
            .position(|n| *n == name)
            .ok_or_else(|| serde::de::Error::custom(format!("unknown coordinate `{name}`")))
    }
}

/// A study's specification as its run records it: serialized, it is run.json's `spec`
/// (the run's identity), and it reads back from there for `merge`.
pub trait StudySpec: Serialize + serde::de::DeserializeOwned + Clone {
    /// The specification with its defaults resolved (the unit size), as recorded.
    fn resolved(&self) -> Self {
        self.clone()
    }
    /// Sets the backend, which is not recorded (units computed on any backend combine).
    fn set_backend(&mut self, backend: jeffcott_core::ensemble::Backend);
}

/// Implements [`StudySpec`] for `$spec`, whose `backend` field is set and whose unit
/// size `$field` (an `Option`, `None` for the default) is recorded resolved by its
/// method `$unit` (units of another size do not combine, so a resumed or merged run
/// checks it); and [`crate::run::UnitStudy`], computed by `$compute` into `$output`
/// under stage `$stage` (work: its `lane_periods`, `transient + periods` per lane).
macro_rules! unit_sized_spec {
    ($spec:ty, $field:ident, $unit:ident, $stage:expr, $output:ty, $compute:path) => {
        impl $crate::run::UnitStudy for $spec {
            type Output = $output;
            const STAGE: &'static str = $stage;
            fn lane_settings(&self) -> &$crate::settings::LaneSettings {
                &self.lane
            }
            fn work(&self) -> (u64, u64) {
                (self.lane_periods(), (self.transient + self.periods) as u64)
            }
            fn compute(&self, at: $crate::run::Units<'_>) -> jeffcott_core::error::Result<$output> {
                $compute(self, at)
            }
        }
        impl $crate::record::StudySpec for $spec {
            fn resolved(&self) -> Self {
                let $field = Some(self.$unit());
                Self {
                    $field,
                    ..self.clone()
                }
            }
            fn set_backend(&mut self, backend: jeffcott_core::ensemble::Backend) {
                self.lane.backend = backend;
            }
        }
    };
}
pub(crate) use unit_sized_spec;

/// A list of speeds recorded as a [`Span`] when it is the range `a:b:n` makes
/// ([`jeffcott_core::ensemble::range_value`], bit for bit), else value by value, so the
/// record always gives the list back: `#[serde(with = "crate::record::speeds")]`.
pub mod speeds {
    use super::Span;
    use jeffcott_core::ensemble::range_value;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    /// `values` as a span when a range gives them, else as a list.
    pub fn serialize<S: Serializer>(values: &[f64], s: S) -> Result<S::Ok, S::Error> {
        let span = Span::of(values);
        let is_range = !values.is_empty()
            && values.iter().enumerate().all(|(i, v)| {
                v.to_bits()
                    == range_value(span.first, span.last, span.count as u64, i as u64).to_bits()
            });
        if is_range {
            span.serialize(s)
        } else {
            values.serialize(s)
        }
    }

    #[derive(Deserialize)]
    #[serde(untagged)]
    enum Recorded {
        Span { first: f64, last: f64, count: usize },
        List(Vec<f64>),
    }

    /// The list back from a span or a list.
    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
        Ok(match Recorded::deserialize(d)? {
            Recorded::Span { first, last, count } => (0..count as u64)
                .map(|i| range_value(first, last, count as u64, i))
                .collect(),
            Recorded::List(v) => v,
        })
    }
}

/// One side of a box of start states: a coordinate and its interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct CoordRange {
    /// Coordinate name (`x_r`, `vy_s`, ...).
    pub coord: &'static str,
    /// Lower end [m or m/s].
    pub lo: f64,
    /// Upper end [m or m/s].
    pub hi: f64,
}

/// The sides of a box given as (coordinate index, lo, hi).
pub fn coord_box(sides: &[(usize, f64, f64)]) -> Vec<CoordRange> {
    sides
        .iter()
        .map(|&(c, lo, hi)| CoordRange {
            coord: COORD_NAMES[c],
            lo,
            hi,
        })
        .collect()
}

/// A state written as an object keyed by coordinate name.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct NamedState(pub State);

impl Serialize for NamedState {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        s.collect_map(COORD_NAMES.iter().zip(self.0.iter()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_named_state_is_an_object_of_the_eight_coordinates_and_nan_is_null() {
        let mut x = [0.0; 8];
        x[0] = 1.5;
        x[7] = f64::NAN;
        let v = serde_json::to_value(NamedState(x)).unwrap();
        assert_eq!(v["x_r"], serde_json::json!(1.5));
        assert_eq!(v["vy_s"], serde_json::Value::Null);
        assert_eq!(v.as_object().unwrap().len(), 8);
    }

    #[test]
    fn a_span_records_the_ends_and_the_count() {
        let v = serde_json::to_value(Span::of(&[1.0, 2.0, 3.0])).unwrap();
        assert_eq!(
            v,
            serde_json::json!({"first": 1.0, "last": 3.0, "count": 3})
        );
    }
}
