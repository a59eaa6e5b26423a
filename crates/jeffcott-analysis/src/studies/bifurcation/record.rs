//! The study as its files hold it: the specification for `run.json`, the flat arrays of
//! the `.npy` files and the `summary.json` records (with each attractor's rub figures).

use super::{BifurcationResult, BifurcationSpec, Sweep, SweepPoint};
use crate::catalogue::CatalogueConfig;
use crate::rub::RubEntry;
use jeffcott_core::error::Result;
use jeffcott_core::integrate::lane::Status;
use jeffcott_core::model::Params;
use serde::Serialize;

/// The flat arrays of a study, as `bifurcation_rows.npy`, `bifurcation.npy` and
/// `bifurcation_lambda1.npy` hold them: rows of the up sweep, the down sweep, then every
/// brute-force lane, each W in order.
pub struct BifurcationArrays {
    /// `[rows, 4]`: W, sweep (0 up, 1 down, 2 brute force), lane, attractor id (-1 none).
    pub rows: Vec<f64>,
    /// `[rows, recorded, 8]`: the Poincare points of each row's lane.
    pub points: Vec<f64>,
    /// `[rows]`: lambda_1 of each row's lane (NaN where not computed or frozen).
    pub lambda1: Vec<f64>,
}

/// The arrays of a study (see [`BifurcationArrays`]).
pub fn arrays(res: &BifurcationResult) -> BifurcationArrays {
    let mut rows: Vec<f64> = Vec::new();
    let mut pts: Vec<f64> = Vec::new();
    let mut l1: Vec<f64> = Vec::new();
    for (code, sw) in [(0.0, &res.up), (1.0, &res.down)] {
        for (wi, p) in sw.iter().enumerate() {
            let id = sweep_id(res, wi, p).map_or(-1.0, |i| i as f64);
            rows.extend_from_slice(&[p.omega, code, 0.0, id]);
            pts.extend(p.points.iter().flatten());
            l1.push(p.lambda1);
        }
    }
    for b in &res.brute {
        for (li, &l) in b.catalogue.labels.iter().enumerate() {
            rows.extend_from_slice(&[b.omega, 2.0, li as f64, l as f64]);
            l1.push(b.lambda1.as_ref().map_or(f64::NAN, |v| v[li]));
        }
        pts.extend_from_slice(&b.points);
    }
    BifurcationArrays {
        rows,
        points: pts,
        lambda1: l1,
    }
}

/// The brute-force attractor id a sweep point lies on, if brute force ran.
pub fn sweep_id(res: &BifurcationResult, wi: usize, p: &SweepPoint) -> Option<u32> {
    res.brute
        .get(wi)
        .and_then(|b| b.catalogue.identify(&p.class))
}

/// A sweep point as `summary.json` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct SweepRecord {
    /// Class label.
    pub class: String,
    /// The period, for a periodic class.
    pub period: Option<usize>,
    /// Lane status.
    pub status: Status,
    /// The brute-force attractor the point lies on, if brute force ran and found it.
    pub attractor: Option<u32>,
    /// Largest Lyapunov exponent [1/s], null when not computed or not finite.
    pub lambda1: Option<f64>,
}

fn sweep_record(res: &BifurcationResult, wi: usize, p: Option<&SweepPoint>) -> Option<SweepRecord> {
    p.map(|p| SweepRecord {
        class: p.class.class.label(),
        period: p.class.class.period(),
        status: p.status,
        attractor: sweep_id(res, wi, p),
        lambda1: finite(p.lambda1),
    })
}

/// `Some(v)` for a finite value (JSON null otherwise).
fn finite(v: f64) -> Option<f64> {
    v.is_finite().then_some(v)
}

/// A brute-force attractor as `summary.json` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct BruteAttractor<'a> {
    /// Attractor id at its speed.
    pub id: u32,
    /// Class label.
    pub class: &'a str,
    /// The period, for a periodic class.
    pub period: Option<usize>,
    /// Start states that ended on it.
    pub lanes: u64,
    /// Their fraction of the start states.
    pub basin_fraction: f64,
    /// Largest Lyapunov exponent [1/s], if computed.
    pub lambda1: Option<f64>,
    /// Rub figures on the attractor.
    pub rub: RubEntry,
}

/// The brute force at one speed as `summary.json` lists it.
#[derive(Clone, Debug, Serialize)]
pub struct BruteRecord<'a> {
    /// Start states run.
    pub lanes: u64,
    /// Of them, diverged.
    pub diverged: u64,
    /// The attractors found.
    pub attractors: Vec<BruteAttractor<'a>>,
}

/// One speed of `summary.json`: the sweeps' points there and the brute force.
#[derive(Clone, Debug, Serialize)]
pub struct SpeedRecord<'a> {
    /// Rotor speed [rad/s].
    pub omega: f64,
    /// The run-up's point (null without one).
    pub up: Option<SweepRecord>,
    /// The run-down's point.
    pub down: Option<SweepRecord>,
    /// The brute force (null without one).
    pub brute_force: Option<BruteRecord<'a>>,
}

/// The study as `summary.json` holds it (the command line adds the list of files and
/// the version): settings, per W the sweeps' classes and the brute-force catalogue with
/// each attractor's rub figures, and where the up and down sweeps differ.
#[derive(Clone, Debug, Serialize)]
pub struct Summary<'a> {
    /// First and last speed.
    pub omega_range: [f64; 2],
    /// Number of speeds.
    pub speeds: usize,
    /// Which sweeps ran.
    pub sweep: Option<Sweep>,
    /// Transient at the first speed of a sweep.
    pub transient_first: u32,
    /// Transient at every later speed.
    pub transient: u32,
    /// Brute-force start states per speed.
    pub ics: u32,
    /// Seed of the brute-force start states.
    pub seed: u64,
    /// Brute-force transient.
    pub brute_transient: u32,
    /// Recorded periods.
    pub periods: u32,
    /// Neighbour seeds at most per speed.
    pub max_seeds: usize,
    /// Whether lambda_1 was computed.
    pub lyapunov: bool,
    /// Macro steps per forcing period.
    pub steps_per_period: u32,
    /// Catalogue settings.
    pub catalogue: &'a CatalogueConfig,
    /// Speeds where the up and down sweeps end on different attractors (hysteresis).
    pub up_down_differ_at: Vec<f64>,
    /// Per speed.
    pub per_omega: Vec<SpeedRecord<'a>>,
    /// Model parameters.
    pub params: &'a Params,
}

/// The summary `summary.json` holds; the rub figures of every brute-force attractor
/// (docs/rub.md) are computed here, all speeds in parallel.
pub fn summary<'a>(spec: &'a BifurcationSpec, res: &'a BifurcationResult) -> Result<Summary<'a>> {
    let rubs: Vec<Vec<RubEntry>> = {
        use rayon::prelude::*;
        res.brute
            .par_iter()
            .map(|b| {
                b.catalogue
                    .attractors
                    .iter()
                    .map(|at| {
                        Ok(
                            crate::rub::attractor_rub(&spec.lane.params, at, &spec.lane.stepper)?
                                .into(),
                        )
                    })
                    .collect::<Result<Vec<_>>>()
            })
            .collect::<Result<Vec<_>>>()?
    };
    let per_omega = spec
        .omegas
        .iter()
        .enumerate()
        .map(|(wi, &omega)| SpeedRecord {
            omega,
            up: sweep_record(res, wi, res.up.get(wi)),
            down: sweep_record(res, wi, res.down.get(wi)),
            brute_force: res.brute.get(wi).map(|b| BruteRecord {
                lanes: b.catalogue.lanes,
                diverged: b.catalogue.diverged,
                attractors: b
                    .catalogue
                    .attractors
                    .iter()
                    .zip(&rubs[wi])
                    .map(|(at, &rub)| BruteAttractor {
                        id: at.id,
                        class: &at.class,
                        period: at.period,
                        lanes: at.lanes,
                        basin_fraction: at.basin_fraction,
                        lambda1: at.lambda1,
                        rub,
                    })
                    .collect(),
            }),
        })
        .collect();
    let up_down_differ_at: Vec<f64> = res
        .up
        .iter()
        .zip(&res.down)
        .enumerate()
        .filter(|(wi, (u, d))| {
            u.class.class.unrefined() != d.class.class.unrefined() || {
                let (iu, id) = (sweep_id(res, *wi, u), sweep_id(res, *wi, d));
                iu.is_some() && id.is_some() && iu != id
            }
        })
        .map(|(_, (u, _))| u.omega)
        .collect();
    Ok(Summary {
        omega_range: [spec.omegas[0], spec.omegas[spec.omegas.len() - 1]],
        speeds: spec.omegas.len(),
        sweep: spec.sweep,
        transient_first: spec.transient_first,
        transient: spec.transient,
        ics: spec.ics,
        seed: spec.seed,
        brute_transient: spec.brute_transient,
        periods: spec.periods,
        max_seeds: spec.max_seeds,
        lyapunov: spec.lane.lyapunov,
        steps_per_period: spec.lane.stepper.steps_per_period,
        catalogue: &spec.lane.catalogue,
        up_down_differ_at,
        per_omega,
        params: &spec.lane.params,
    })
}
