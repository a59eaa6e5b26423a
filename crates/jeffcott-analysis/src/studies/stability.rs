//! Basin stability (Menck et al. 2013) over a speed or a range of speeds: a
//! continuation over W whose fresh start states are uniform draws in a box of start
//! coordinates, with 95 % Wilson intervals on every fraction. The work behind
//! `jeffcott basin-stability` and the Python package's `basin_stability`.

use crate::continuation::{
    ContinuationResult, ContinuationSpec, Direction, Fields, Ramp, parse_box,
};
use crate::map::{MapAxis, MapVar};
use crate::record::{CoordRange, coord_box};
use crate::settings::LaneSettings;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::model::Params;
use serde::Serialize;

/// The 95 % Wilson score interval of a binomial fraction k/n (Wilson 1927), which keeps
/// its coverage near 0 and 1 where the normal interval does not.
pub fn wilson95(k: u64, n: u64) -> (f64, f64) {
    if n == 0 {
        return (0.0, 1.0);
    }
    let z = 1.959_963_984_540_054;
    let (n, p) = (n as f64, k as f64 / n as f64);
    let d = 1.0 + z * z / n;
    let c = (p + z * z / (2.0 * n)) / d;
    let h = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / d;
    ((c - h).max(0.0), (c + h).min(1.0))
}

/// What a basin-stability study is asked for, as the command line spells it.
pub struct StabilityRequest<'a> {
    /// Model, stepper, precision, backend, classification, lambda_1.
    pub lane: LaneSettings,
    /// A speed, or `a:b:n` [rad/s].
    pub omega: &'a str,
    /// Start states drawn per speed.
    pub sample: u32,
    /// The box, `NAME:lo:hi,...`.
    pub start_box: &'a str,
    /// Seed of the draws.
    pub seed: u64,
    /// Forcing periods integrated and discarded per lane.
    pub transient: u32,
    /// Forcing periods recorded per lane.
    pub periods: u32,
}

/// The study as a continuation over W of uniform draws in the box, validated; errors
/// name `omega`, `sample` or `box`.
pub fn spec(r: &StabilityRequest) -> Result<ContinuationSpec> {
    let range = jeffcott_core::ensemble::RangeSpec::parse("omega", r.omega)?;
    if range.n > 100_000 {
        return Err(Error::invalid("omega", r.omega, "at most 100000 speeds"));
    }
    let spec = ContinuationSpec {
        lane: r.lane.clone(),
        omega: None,
        param: MapAxis {
            var: MapVar::Omega,
            lo: range.a,
            hi: range.b,
            n: range.n as usize,
            log: false,
        },
        ics: r.sample,
        start_box: Some(parse_box(FIELDS.start_box, r.start_box)?),
        seed: r.seed,
        transient: r.transient,
        periods: r.periods,
        directions: vec![Direction::Up],
        match_threshold: f64::INFINITY,
        values_per_unit: None,
    };
    spec.validate_as(&FIELDS)?;
    Ok(spec)
}

/// The continuation's fields as basin stability names them: a speed range `omega`,
/// `sample` draws (at least 2: a fraction of one draw says nothing) in a `box`.
pub const FIELDS: Fields = Fields {
    param: "omega",
    ics: "sample",
    ics_min: 2,
    start_box: "box",
};

/// The fractions `[n, ids + 1]` of the ramp (last column diverged) and the lower and
/// upper ends of their 95 % Wilson intervals.
pub fn fractions_with_intervals(
    spec: &ContinuationSpec,
    ramp: &Ramp,
) -> (Vec<f64>, Vec<f64>, Vec<f64>) {
    let k = spec.ics as u64;
    let (f, _) = ramp.fractions();
    let count = |x: f64| (x * k as f64).round() as u64;
    let (lo, hi): (Vec<f64>, Vec<f64>) = f.iter().map(|&x| wilson95(count(x), k)).unzip();
    (f, lo, hi)
}

/// An attractor at one speed as `basin_stability.json` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct AttractorRecord<'a> {
    /// Attractor id (followed from speed to speed).
    pub id: u32,
    /// Class label.
    pub class: &'a str,
    /// The period, for a periodic class.
    pub period: Option<usize>,
    /// Largest Lyapunov exponent [1/s], if computed.
    pub lambda1: Option<f64>,
    /// Basin stability: the fraction of the draws that end on it.
    pub fraction: f64,
    /// Its standard error sqrt(f (1 - f) / N).
    pub standard_error: f64,
    /// 95 % Wilson score interval.
    pub ci95: [f64; 2],
    /// Whether only a seeded lane (none of the draws) found it.
    pub found_only_from_a_seed: bool,
}

/// One speed of `basin_stability.json`.
#[derive(Clone, Debug, Serialize)]
pub struct SpeedRecord<'a> {
    /// Rotor speed [rad/s].
    pub omega: f64,
    /// The attractors found.
    pub attractors: Vec<AttractorRecord<'a>>,
    /// Fraction of the draws that diverged.
    pub diverged_fraction: f64,
    /// Its 95 % Wilson score interval.
    pub diverged_ci95: [f64; 2],
}

/// The study as `basin_stability.json` holds it (the command line adds the list of
/// files and the version).
#[derive(Clone, Debug, Serialize)]
pub struct Summary<'a> {
    /// The box the start states are drawn in.
    #[serde(rename = "box")]
    pub start_box: Vec<CoordRange>,
    /// Draws per speed.
    pub sample: u32,
    /// Seed of the draws.
    pub seed: u64,
    /// Transient periods.
    pub transient: u32,
    /// Recorded periods.
    pub periods: u32,
    /// Whether lambda_1 was computed.
    pub lyapunov: bool,
    /// Per speed.
    pub per_omega: Vec<SpeedRecord<'a>>,
    /// Model parameters.
    pub params: &'a Params,
    /// What the fractions and intervals are.
    pub definition: &'static str,
}

/// The summary `basin_stability.json` holds.
pub fn summary<'a>(spec: &'a ContinuationSpec, res: &'a ContinuationResult) -> Summary<'a> {
    let ramp = &res.ramps[0];
    let g = ramp.ids + 1;
    let (_, lo, hi) = fractions_with_intervals(spec, ramp);
    let per_omega = ramp
        .steps
        .iter()
        .enumerate()
        .map(|(s, st)| SpeedRecord {
            omega: st.value,
            attractors: st
                .attractors
                .iter()
                .map(|a| {
                    let i = s * g + a.id as usize;
                    AttractorRecord {
                        id: a.id,
                        class: &a.class,
                        period: a.period,
                        lambda1: a.lambda1,
                        fraction: a.fraction,
                        standard_error: a.error,
                        ci95: [lo[i], hi[i]],
                        found_only_from_a_seed: a.seeded_only,
                    }
                })
                .collect(),
            diverged_fraction: st.diverged_fraction,
            diverged_ci95: [lo[s * g + ramp.ids], hi[s * g + ramp.ids]],
        })
        .collect();
    Summary {
        start_box: coord_box(spec.start_box.as_deref().unwrap_or_default()),
        sample: spec.ics,
        seed: spec.seed,
        transient: spec.transient,
        periods: spec.periods,
        lyapunov: spec.lane.lyapunov,
        per_omega,
        params: &spec.lane.params,
        definition: "basin stability (Menck et al. 2013): the fraction of start states drawn uniformly in the box that end on each attractor; standard error sqrt(f (1 - f) / N), 95 % Wilson score interval; attractor ids follow attractors from speed to speed (docs/maps.md, continuation)",
    }
}

#[cfg(test)]
mod tests {
    use super::wilson95;

    #[test]
    fn wilson_intervals_match_published_values() {
        // Newcombe (1998), Table I: 81/263 -> 0.2553..0.3662.
        let (lo, hi) = wilson95(81, 263);
        assert!(
            (lo - 0.2553).abs() < 5e-5 && (hi - 0.3662).abs() < 5e-5,
            "{lo} {hi}"
        );
        // 0/10 -> 0..0.2775 (Wilson), never below 0.
        let (lo, hi) = wilson95(0, 10);
        assert_eq!(lo, 0.0);
        assert!((hi - 0.2775).abs() < 5e-5, "{hi}");
    }
}
