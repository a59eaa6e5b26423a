//! The phase traces behind `bifurcation --portraits W`: at the grid speed nearest W,
//! one pass over each attractor the brute force catalogued there (the largest basins
//! first), or without a brute force one pass over each sweep's final cycle. Computed
//! here so that the command's writer only draws.

use super::{BifurcationResult, BifurcationSpec};
use crate::simulate::{AttractorTrace, Integrator, SimulateSpec, attractor_traces, simulate};
use jeffcott_core::error::{Error, Result};

/// Where a portrait's traces come from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PortraitSource {
    /// The brute force's catalogue at the speed: each trace's `id` is its attractor's.
    Brute,
    /// The sweeps' final cycles: each trace's `id` is 0 for the up sweep, 1 for the down.
    Sweeps,
}

/// The traces of one portrait.
#[derive(Clone, Debug)]
pub struct Portrait {
    /// Index of the grid speed nearest the one asked for.
    pub index: usize,
    /// That speed [rad/s].
    pub omega: f64,
    /// Where the traces come from.
    pub source: PortraitSource,
    /// The traces (none when nothing bounded was found there).
    pub traces: Vec<AttractorTrace>,
}

/// The portrait at the grid speed nearest `w` (field `portraits` in errors).
pub fn portrait(spec: &BifurcationSpec, res: &BifurcationResult, w: f64) -> Result<Portrait> {
    if !w.is_finite() {
        return Err(Error::invalid("portraits", w, "must be a finite speed"));
    }
    let index = (0..spec.omegas.len())
        .min_by(|&a, &b| {
            (spec.omegas[a] - w)
                .abs()
                .total_cmp(&(spec.omegas[b] - w).abs())
        })
        .unwrap_or(0);
    let omega = spec.omegas[index];
    if let Some(b) = res.brute.get(index) {
        return Ok(Portrait {
            index,
            omega,
            source: PortraitSource::Brute,
            traces: attractor_traces(
                &spec.lane.params,
                omega,
                &b.catalogue.attractors,
                crate::defaults::basin::TRACES,
            )?,
        });
    }
    let mut traces = Vec::new();
    for (k, sw) in [&res.up, &res.down].into_iter().enumerate() {
        let Some(p) = sw.get(index).filter(|p| !p.status.is_frozen()) else {
            continue;
        };
        let periods = p.class.class.period().unwrap_or(12).clamp(1, 32) as u32;
        let r = simulate(&SimulateSpec {
            params: spec.lane.params.clone(),
            omega,
            x0: p.points[p.points.len() - 1],
            transient: 0,
            periods,
            timeseries_periods: periods,
            integrator: Integrator::Lane,
            stepper: spec.lane.stepper,
            article: Default::default(),
            classify: spec.lane.catalogue.classify,
        })?;
        traces.push(AttractorTrace {
            id: k as u32,
            timeseries: r.timeseries,
            poincare: p.points.clone(),
        });
    }
    Ok(Portrait {
        index,
        omega,
        source: PortraitSource::Sweeps,
        traces,
    })
}
