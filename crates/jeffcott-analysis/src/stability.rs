//! Basin stability (Menck et al. 2013) over a speed or a range of speeds: a
//! continuation over W whose fresh start states are uniform draws in a box of start
//! coordinates, with 95 % Wilson intervals on every fraction. The work behind
//! `jeffcott basin-stability` and the Python package's `basin_stability`.

use crate::catalogue::CatalogueConfig;
use crate::continuation::{ContinuationResult, ContinuationSpec, Direction, Ramp, parse_box};
use crate::map::{MapAxis, MapVar};
use jeffcott_core::ensemble::{Backend, Precision};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::Params;

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
    /// Model parameters.
    pub params: Params,
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
    pub recorded: u32,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
    /// Lane precision.
    pub precision: Precision,
    /// Backend.
    pub backend: Backend,
    /// Classification tolerances.
    pub catalogue: CatalogueConfig,
    /// Compute lambda_1 per lane.
    pub lyapunov: bool,
}

/// The study as a continuation over W of uniform draws in the box, validated; errors
/// name `omega`, `sample` or `box`.
pub fn spec(r: &StabilityRequest) -> Result<ContinuationSpec> {
    let range = jeffcott_core::ensemble::RangeSpec::parse("omega", r.omega)?;
    if range.n > 100_000 {
        return Err(Error::invalid("omega", r.omega, "at most 100000 speeds"));
    }
    if !(2..=100_000_000).contains(&r.sample) {
        return Err(Error::invalid(
            "sample",
            r.sample,
            "must be in 2..=100000000",
        ));
    }
    let spec = ContinuationSpec {
        params: r.params.clone(),
        omega: None,
        param: MapAxis {
            var: MapVar::Omega,
            lo: range.a,
            hi: range.b,
            n: range.n as usize,
            log: false,
        },
        ics: r.sample,
        start_box: Some(parse_box("box", r.start_box)?),
        seed: r.seed,
        transient: r.transient,
        recorded: r.recorded,
        stepper: r.stepper,
        precision: r.precision,
        backend: r.backend,
        catalogue: r.catalogue,
        lyapunov: r.lyapunov,
        directions: vec![Direction::Up],
        match_threshold: f64::INFINITY,
    };
    spec.validate()?;
    Ok(spec)
}

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

/// The study as `basin_stability.json` holds it (the command line adds the list of
/// files and the version).
pub fn summary(spec: &ContinuationSpec, res: &ContinuationResult) -> serde_json::Value {
    let ramp = &res.ramps[0];
    let g = ramp.ids + 1;
    let (_, lo, hi) = fractions_with_intervals(spec, ramp);
    let steps: Vec<serde_json::Value> = ramp
        .steps
        .iter()
        .enumerate()
        .map(|(s, st)| {
            let list: Vec<serde_json::Value> = st
                .attractors
                .iter()
                .map(|a| {
                    let i = s * g + a.id as usize;
                    serde_json::json!({
                        "id": a.id, "class": a.class, "period": a.period, "lambda1": a.lambda1,
                        "fraction": a.fraction, "standard_error": a.error,
                        "ci95": [lo[i], hi[i]], "found_only_from_a_seed": a.seeded_only,
                    })
                })
                .collect();
            serde_json::json!({
                "omega": st.value, "attractors": list,
                "diverged_fraction": st.diverged_fraction,
                "diverged_ci95": [lo[s * g + ramp.ids], hi[s * g + ramp.ids]],
            })
        })
        .collect();
    let boxed: Vec<serde_json::Value> = spec
        .start_box
        .iter()
        .flatten()
        .map(|&(c, lo, hi)| serde_json::json!({"coord": jeffcott_core::model::COORD_NAMES[c], "lo": lo, "hi": hi}))
        .collect();
    serde_json::json!({
        "box": boxed,
        "sample": spec.ics,
        "seed": spec.seed,
        "transient": spec.transient,
        "periods": spec.recorded,
        "lyapunov": spec.lyapunov,
        "per_omega": steps,
        "params": spec.params,
        "definition": "basin stability (Menck et al. 2013): the fraction of start states drawn uniformly in the box that end on each attractor; standard error sqrt(f (1 - f) / N), 95 % Wilson score interval; attractor ids follow attractors from speed to speed (docs/maps.md, continuation)",
    })
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
