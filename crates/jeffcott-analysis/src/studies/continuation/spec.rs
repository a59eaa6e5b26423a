//! What a continuation computes: the ramp directions, [`ContinuationSpec`] with its
//! checks and per-value parameters, and the fresh start states (a seeded box or the
//! brute-force draws).

use crate::map::{MapAxis, MapVar};
use crate::settings::LaneSettings;
use jeffcott_core::ensemble::EnsembleSpec;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::{Params, State};
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

/// What a continuation computes. It is its own record: `run.json` holds it as
/// [`ContinuationSpec::resolved`] serializes it (not the backend), and it reads back
/// from there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ContinuationSpec {
    /// Model, stepper, precision, backend, classification, lambda_1.
    #[serde(flatten)]
    pub lane: LaneSettings,
    /// Rotor speed when the parameter is not omega [rad/s].
    pub omega: Option<f64>,
    /// The continued parameter and its values (omega or a model parameter; evenly
    /// spaced, so recorded without `log`).
    #[serde(with = "linear_axis")]
    pub param: MapAxis,
    /// Fresh start states per value.
    pub ics: u32,
    /// Draw the fresh start states uniformly in this box of start coordinates
    /// (coordinate index, lo, hi), the others at the static equilibrium; `None`: the
    /// static equilibrium plus the brute-force draws.
    #[serde(rename = "box")]
    pub start_box: Option<Vec<(usize, f64, f64)>>,
    /// Seed of the fresh start states.
    pub seed: u64,
    /// Forcing periods integrated and discarded.
    pub transient: u32,
    /// Forcing periods recorded per lane.
    pub periods: u32,
    /// Ramp directions.
    pub directions: Vec<Direction>,
    /// Largest Poincare-set distance at which two attractors of consecutive values are
    /// the same one [m in positions, m/s / W in velocities]; infinite by default.
    #[serde(with = "super::record::threshold")]
    pub match_threshold: f64,
    /// Values per unit of the fresh pass (`None`: [`crate::run::unit_lanes`] counted in
    /// values; recorded resolved, as units of another size do not combine).
    #[serde(rename = "unit_values")]
    pub values_per_unit: Option<usize>,
}

crate::record::unit_sized_spec!(
    ContinuationSpec,
    values_per_unit,
    unit_values,
    "continuation",
    super::ContinuationResult,
    super::continuation_units
);

/// The continued parameter as `run.json` records it: name and range, no spacing (a
/// continuation's values are evenly spaced): `#[serde(with = "linear_axis")]`.
mod linear_axis {
    use crate::map::{MapAxis, MapVar};
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Serialize, Deserialize)]
    struct Linear {
        var: MapVar,
        lo: f64,
        hi: f64,
        n: usize,
    }

    pub fn serialize<S: Serializer>(a: &MapAxis, s: S) -> Result<S::Ok, S::Error> {
        let MapAxis { var, lo, hi, n, .. } = *a;
        Linear { var, lo, hi, n }.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<MapAxis, D::Error> {
        let Linear { var, lo, hi, n } = Linear::deserialize(d)?;
        Ok(MapAxis {
            var,
            lo,
            hi,
            n,
            log: false,
        })
    }
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
        self.lane.validate()?;
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
        if !(f.ics_min..=crate::map::MAX_ICS).contains(&self.ics) {
            return Err(Error::invalid(
                f.ics,
                self.ics,
                format!("must be in {}..={}", f.ics_min, crate::map::MAX_ICS),
            ));
        }
        jeffcott_core::limits::check_periods("transient", self.transient, 0)?;
        jeffcott_core::limits::check_periods("periods", self.periods, 2)?;
        if let Some(b) = &self.start_box {
            let bound = self.lane.stepper.divergence_bound;
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
        if self.values_per_unit == Some(0) {
            return Err(Error::invalid("unit_values", 0, "must be >= 1 value"));
        }
        Ok(())
    }

    /// Parameters and speed at value `i`.
    pub fn value_params(&self, i: usize) -> (Params, f64) {
        let mut p = self.lane.params.clone();
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
            None => crate::bifurcation::start_states(&p, self.ics, self.w_ref(), self.seed),
            Some(b) => uniform_in_box(&p.static_equilibrium(), b, self.ics, self.seed),
        }
    }

    /// Values per unit of the fresh pass: [`crate::run::unit_lanes`] counted in values.
    pub fn unit_values(&self) -> usize {
        let per_value = self.ics as u64
            * (self.transient + self.periods) as u64
            * self.lane.stepper.steps_per_period as u64
            * if self.lane.lyapunov { 2 } else { 1 };
        self.values_per_unit
            .unwrap_or_else(|| crate::run::unit_lanes(self.param.n, per_value))
    }

    /// Lane-periods of the fresh pass (the bulk of the work).
    pub fn lane_periods(&self) -> u64 {
        self.param.n as u64 * self.ics as u64 * (self.transient + self.periods) as u64
    }

    pub(super) fn ensemble(&self, i: usize, starts: Vec<State>) -> EnsembleSpec {
        let (p, w) = self.value_params(i);
        self.lane
            .ensemble_at(p, w, starts, self.transient, self.periods)
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
                let u = 0.5 * (crate::bifurcation::unit(i, seed.wrapping_mul(16) + d as u64) + 1.0);
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
        let (name, lo, hi) = crate::basin::parse_name_bounds(option, part, "x_r:-0.006:0.006")?;
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
