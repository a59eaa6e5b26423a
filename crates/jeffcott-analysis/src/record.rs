//! Pieces shared by the records the JSON files hold (`run.json`'s specifications,
//! `summary.json`, `map.json`, ...): a speed range, a box of start coordinates, a state
//! by coordinate name. Every file is a `#[derive(Serialize)]` struct of its study's
//! module built from these; [`crate::output::write_json`] writes each object's keys
//! sorted, so a file does not depend on the order a struct declares its fields in.

use jeffcott_core::model::{COORD_NAMES, State};
use serde::Serialize;

/// A range of values as the files record it: first, last and how many.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
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
