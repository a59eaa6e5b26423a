//! The uncertainty exponent by re-integration, the original method of Grebogi, McDonald,
//! Ott and Yorke (Phys. Lett. A 99, 415 (1983)): start states drawn uniformly in the
//! basin's box, each integrated as it is and displaced by +-eps along each grid axis
//! (eps relative to that axis' side), every end state labelled with the basin's
//! catalogue; f(eps) is the fraction of draws whose label changes under some displacement,
//! f(eps) ~ eps^alpha, and the boundary's dimension is D = 2 - alpha. Unlike the grid
//! estimate it reaches eps far below one cell (here 1e-1 .. 1e-7 of the box side, seven
//! decades), so it sees the boundary's fine structure; its floor is 1/M for M draws.
//!
//! The lanes run on the run engine (stage `uncertainty`, resumable) after the basin is
//! assembled, since they are labelled by its catalogue; with early exit a lane
//! recognised on one of its cycles retires with that label ([`crate::early::label_lanes`]).

use crate::basin::BasinSpec;
use crate::catalogue::Catalogue;
use crate::run::lanes::{Control, LaneUnits, Split};
use crate::run::{Array, Unit, UnitStore};
use jeffcott_core::ensemble::{EnsembleResult, EnsembleSpec};
use jeffcott_core::error::Result;
use jeffcott_core::model::State;
use serde::Serialize;

/// The displacements, relative to the box side: 1e-1 .. 1e-7, one per decade.
pub const EPS: [f64; 7] = [1e-1, 1e-2, 1e-3, 1e-4, 1e-5, 1e-6, 1e-7];

/// Lanes per draw: the draw itself and +-eps along x and y for every eps.
const PER_DRAW: usize = 1 + 4 * EPS.len();

/// Draws at most: 1e6 draws are 2.9e7 lanes, more than a 5000 x 5000 basin, and put
/// the floor of f(eps) at 1e-6, below any boundary this model has shown.
pub const MAX_SAMPLES: usize = 1_000_000;

/// Checks a number of draws (`uncertainty-samples`): 0 (none) ..= [`MAX_SAMPLES`].
pub fn check_samples(samples: usize) -> Result<()> {
    if samples <= MAX_SAMPLES {
        Ok(())
    } else {
        Err(jeffcott_core::error::Error::invalid(
            "uncertainty-samples",
            samples,
            format!("must be in 0..={MAX_SAMPLES} draws (0 skips the re-integration)"),
        ))
    }
}

/// Stage name of the lanes.
pub const STAGE: &str = "uncertainty";

/// What the re-integration found.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Reintegration {
    /// Draws.
    pub samples: usize,
    /// (eps, f(eps)) for every eps of [`EPS`].
    pub points: Vec<(f64, f64)>,
    /// alpha: the slope of log f against log eps over the points with f > 0.
    pub alpha: Option<f64>,
    /// Its standard error from the residuals.
    pub alpha_std_error: Option<f64>,
    /// D = 2 - alpha.
    pub dimension: Option<f64>,
    /// The eps range fitted (smallest, largest) and the number of points.
    pub fit_range: Option<(f64, f64, usize)>,
    /// Why there is no fit (fewer than 3 eps with an uncertain draw).
    pub not_fitted: Option<String>,
    /// What early exit saved (`None`: it ran without); run.json records it.
    #[serde(skip)]
    pub early_exit: Option<crate::early::EarlySaved>,
}

impl Reintegration {
    /// One line for summaries.
    pub fn summary(&self) -> String {
        match (self.alpha, self.alpha_std_error, self.fit_range) {
            (Some(a), Some(se), Some((lo, hi, k))) => format!(
                "alpha by re-integration ({} draws) = {a:.3} +- {se:.3}, D = {:.3} (eps {lo:.0e}..{hi:.0e}, {k} points)",
                self.samples,
                2.0 - a
            ),
            _ => format!(
                "alpha by re-integration ({} draws): not fitted ({})",
                self.samples,
                self.not_fitted.as_deref().unwrap_or("")
            ),
        }
    }
}

/// The start state of lane `l` (draw l / PER_DRAW, displacement l % PER_DRAW).
fn lane_start(spec: &BasinSpec, seed: u64, l: usize) -> State {
    let (d, k) = (l / PER_DRAW, l % PER_DRAW);
    let u =
        |salt: u64| 0.5 * (crate::bifurcation::unit(d as u64, seed.wrapping_mul(8) + salt) + 1.0);
    let (sx, sy) = (spec.x.hi - spec.x.lo, spec.y.hi - spec.y.lo);
    let mut x = spec.base;
    // Draws keep a margin of the largest displacement inside the box.
    let m = EPS[0];
    x[spec.x.coord] = spec.x.lo + sx * (m + (1.0 - 2.0 * m) * u(0));
    x[spec.y.coord] = spec.y.lo + sy * (m + (1.0 - 2.0 * m) * u(1));
    if k > 0 {
        let e = EPS[(k - 1) / 4];
        match (k - 1) % 4 {
            0 => x[spec.x.coord] += e * sx,
            1 => x[spec.x.coord] -= e * sx,
            2 => x[spec.y.coord] += e * sy,
            _ => x[spec.y.coord] -= e * sy,
        }
    }
    x
}

/// Runs `samples` draws (seeded) into `store` and computes f(eps) and alpha, every end
/// state labelled by `catalogue` (-1 diverged, -2 an attractor it does not hold).
pub fn reintegration(
    spec: &BasinSpec,
    catalogue: &Catalogue,
    samples: usize,
    seed: u64,
    engine: &crate::backend::Engine,
    store: &dyn UnitStore,
    ctl: Control,
) -> Result<Reintegration> {
    check_samples(samples)?;
    let lanes = samples * PER_DRAW;
    let per_lane =
        (spec.transient + spec.periods) as u64 * spec.lane.stepper.steps_per_period as u64;
    // Whole draws per unit.
    let unit = crate::run::unit_lanes(lanes, per_lane)
        .div_ceil(PER_DRAW)
        .max(1)
        * PER_DRAW;
    let split = Split::new(lanes, unit);
    let count = split.count();
    let ensemble = |u: usize| spec.ensemble(split.range(u).map(|l| lane_start(spec, seed, l)));
    let reduce = |_u: usize, _e: &EnsembleSpec, r: EnsembleResult| {
        let labels = catalogue.label_lanes(&r);
        Ok(Unit::new("").with("labels", Array::I32(labels)))
    };
    let early = |_u: usize, e: &EnsembleSpec, engine: &crate::backend::Engine, c: Control| {
        crate::early::labelled_unit(e, catalogue, engine, c)
    };
    LaneUnits::new(STAGE, split, &ensemble, &reduce)
        .lambda1(spec.lane.lyapunov)
        .computed_by(
            spec.early_exit()
                .then_some(&early as &crate::run::lanes::ComputeUnit),
        )
        .run(store, engine, ctl)?;
    let mut labels = Vec::with_capacity(lanes);
    let mut saved = None;
    for u in 0..count {
        let unit = store.load(STAGE, u)?;
        crate::early::EarlySaved::accumulate(&mut saved, crate::early::unit_saved(&unit)?);
        labels.extend_from_slice(unit.i32s("labels")?);
    }
    Ok(Reintegration {
        early_exit: saved,
        ..fit(&labels, samples)
    })
}

/// f(eps) and the fit from the labels of `samples` draws (PER_DRAW lanes each).
pub fn fit(labels: &[i32], samples: usize) -> Reintegration {
    let points: Vec<(f64, f64)> = EPS
        .iter()
        .enumerate()
        .map(|(j, &e)| {
            let uncertain = (0..samples)
                .filter(|&d| {
                    let b = d * PER_DRAW;
                    (0..4).any(|k| labels[b + 1 + 4 * j + k] != labels[b])
                })
                .count();
            (e, uncertain as f64 / samples.max(1) as f64)
        })
        .collect();
    let used: Vec<(f64, f64)> = points.iter().copied().filter(|p| p.1 > 0.0).collect();
    let x: Vec<f64> = used.iter().map(|p| p.0).collect();
    let y: Vec<f64> = used.iter().map(|p| p.1).collect();
    match crate::measures::log_log_line(&x, &y) {
        Some((slope, _, se)) => Reintegration {
            samples,
            points,
            alpha: Some(slope),
            alpha_std_error: Some(se),
            dimension: Some(2.0 - slope),
            fit_range: Some((x[x.len() - 1], x[0], x.len())),
            not_fitted: None,
            early_exit: None,
        },
        None => Reintegration {
            samples,
            points,
            alpha: None,
            alpha_std_error: None,
            dimension: None,
            fit_range: None,
            not_fitted: Some(format!(
                "{} of {} eps values have an uncertain draw; a fit needs 3 (draw more with --uncertainty-samples, the floor of f is 1/M)",
                used.len(),
                EPS.len()
            )),
            early_exit: None,
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn f_counts_draws_whose_label_changes_and_the_slope_is_fitted() {
        // 4 draws; draw d is uncertain at eps index j when j < 3 - d: f = 3/4, 2/4, 1/4, 0...
        let mut labels = vec![0i32; 4 * PER_DRAW];
        for d in 0..4 {
            for j in 0..EPS.len() {
                if j + d < 3 {
                    labels[d * PER_DRAW + 1 + 4 * j + 2] = 1;
                }
            }
        }
        let r = fit(&labels, 4);
        assert_eq!(r.points[0].1, 0.75);
        assert_eq!(r.points[1].1, 0.5);
        assert_eq!(r.points[2].1, 0.25);
        assert_eq!(r.points[3].1, 0.0);
        let a = r.alpha.unwrap();
        assert!(a > 0.1 && a < 0.5, "{a}");
        assert_eq!(r.fit_range.unwrap().2, 3);
    }
}
