//! The basin study, whole: the grid ([`BasinSpec`]), then every stage the command line's
//! `basin`, Python's `basin()` and `reproduce`'s Fig. 7 ask for: the boundary
//! refinement ([`crate::refine`]), the uncertainty exponent by re-integration
//! ([`crate::uncertainty`]), the rub figures on each attractor ([`crate::rub`]), the
//! phase traces the attractor portrait draws, and the basin measures
//! ([`crate::measures`]). One [`run`] computes them all, so the three front ends only
//! build a [`BasinStudy`] and write or return the [`BasinOutcome`]; writers never
//! integrate.

use super::{BasinResult, BasinSpec};
use crate::backend::Engine;
use crate::measures::{BasinMetrics, MetricsRecord};
use crate::refine::Refined;
use crate::rub::{AttractorWithRub, RubEntry};
use crate::run::Host;
use crate::simulate::AttractorTrace;
use crate::uncertainty::Reintegration;
use jeffcott_core::error::Result;

/// A basin and the stages computed from it. `run.json` records it as
/// [`BasinStudy::resolved`] serializes it: what the units depend on (the grid, the
/// refinement, the re-integration); the entropy box and the traces are computed from
/// the units on every run and are not part of a run's identity.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BasinStudy {
    /// The grid as asked (the coarse grid when refined).
    #[serde(flatten)]
    pub basin: BasinSpec,
    /// Levels of boundary refinement (0: none; not with lambda_1).
    pub refine: u32,
    /// Draws of the uncertainty exponent by re-integration (0: none).
    pub uncertainty_samples: usize,
    /// Side of the basin entropy's boxes in cells (`None`:
    /// [`crate::measures::DEFAULT_ENTROPY_BOX`], capped by the finest grid's shorter
    /// side).
    #[serde(skip)]
    pub entropy_box: Option<usize>,
    /// Attractors whose phase traces are computed, the largest basins first (0: none;
    /// the command line asks for 8 when it draws `attractors.png`).
    #[serde(skip)]
    pub traces: usize,
}

impl BasinStudy {
    /// The grid alone: no refinement, re-integration or traces, the default entropy box.
    pub fn new(basin: BasinSpec) -> Self {
        BasinStudy {
            basin,
            refine: 0,
            uncertainty_samples: 0,
            entropy_box: None,
            traces: 0,
        }
    }

    /// Checks every input before anything is allocated or integrated; errors name the
    /// option and the allowed range.
    pub fn validate(&self) -> Result<()> {
        let b = &self.basin;
        b.check_size()?;
        b.validate()?;
        crate::uncertainty::check_samples(self.uncertainty_samples)?;
        crate::measures::entropy_box(self.entropy_box, b.x.n, b.y.n)?;
        crate::refine::check_levels(self.refine, b.lane.lyapunov, b.x.n, b.y.n)
    }
}

impl crate::record::StudySpec for BasinStudy {
    /// The grid's unit size resolved.
    fn resolved(&self) -> BasinStudy {
        BasinStudy {
            basin: self.basin.resolved(),
            ..self.clone()
        }
    }
    fn set_backend(&mut self, backend: jeffcott_core::ensemble::Backend) {
        self.basin.lane.backend = backend;
    }
}

/// Everything a basin study computed.
#[derive(Clone, Debug)]
pub struct BasinOutcome {
    /// The grid asked for.
    pub coarse: BasinSpec,
    /// The grid the labels are on: the finest level when refined, else the one asked for.
    pub spec: BasinSpec,
    /// Labels, catalogue, lambda_1, backend and wall time of the basin (on `spec`'s grid).
    pub result: BasinResult,
    /// The refinement, when asked for.
    pub refined: Option<Refined>,
    /// The re-integration estimate, when asked for.
    pub reintegration: Option<Reintegration>,
    /// The basin measures of the labels.
    pub metrics: BasinMetrics,
    /// Each catalogued attractor's rub figures, in catalogue order.
    pub rub: Vec<RubEntry>,
    /// Phase traces of the largest attractors ([`BasinStudy::traces`] at most).
    pub traces: Vec<AttractorTrace>,
}

impl BasinOutcome {
    /// The catalogue's attractors with their rub figures, as `attractors.json` lists them.
    pub fn attractors(&self) -> Vec<AttractorWithRub<'_>> {
        self.result
            .catalogue
            .attractors
            .iter()
            .zip(&self.rub)
            .map(|(attractor, &rub)| AttractorWithRub { attractor, rub })
            .collect()
    }

    /// The measures as `basin_metrics.json` records them, with the re-integration
    /// estimate when computed.
    pub fn metrics_record(&self) -> MetricsRecord<'_> {
        MetricsRecord::new(&self.metrics, self.reintegration.as_ref())
    }
}

/// Runs every stage of `study` on `engine`, each committing its units to the host's
/// store (stages `basin`, `refine`, `uncertainty`) under the host's progress display:
/// an interrupted study resumes stage by stage. A shard's run ends with
/// [`crate::run::ShardDone`] after its basin units (the merge assembles).
pub fn run(study: &BasinStudy, engine: &Engine, host: &impl Host) -> Result<BasinOutcome> {
    study.validate()?;
    let coarse = &study.basin;
    let per_lane = (coarse.transient + coarse.periods) as u64;
    let cells = (coarse.x.n * coarse.y.n) as u64;
    let store = host.store();
    let res = crate::run::under_host(coarse, engine, host)?;
    let (spec, result, refined) = if study.refine > 0 {
        // The boundary's lanes are not known in advance: the display counts the coarse
        // grid's size per level as a scale.
        let total = cells * per_lane * study.refine as u64;
        let f = host.progress(crate::run::Stage::new("refine", total, per_lane), |ctl| {
            crate::refine::refine(
                coarse,
                &res.catalogue,
                &res.labels,
                study.refine,
                engine,
                store,
                ctl,
            )
        })?;
        let (s, r) = crate::refine::refined_basin(coarse, res, &f);
        (s, r, Some(f))
    } else {
        (coarse.clone(), res, None)
    };
    let reintegration = if study.uncertainty_samples > 0 {
        let m = study.uncertainty_samples;
        let lanes = (m * (1 + 4 * crate::uncertainty::EPS.len())) as u64;
        Some(host.progress(
            crate::run::Stage::new("uncertainty", lanes * per_lane, per_lane),
            |ctl| {
                crate::uncertainty::reintegration(
                    &spec,
                    &result.catalogue,
                    m,
                    1,
                    engine,
                    store,
                    ctl,
                )
            },
        )?)
    } else {
        None
    };
    let attractors = &result.catalogue.attractors;
    let rub = crate::rub::attractors_with_rub(&spec.lane.params, attractors, &spec.lane.stepper)?
        .into_iter()
        .map(|a| a.rub)
        .collect();
    let traces = if study.traces > 0 && !attractors.is_empty() {
        crate::simulate::attractor_traces(&spec.lane.params, spec.omega, attractors, study.traces)?
    } else {
        Vec::new()
    };
    let (nx, ny) = (spec.x.n, spec.y.n);
    let eps = crate::measures::entropy_box(study.entropy_box, nx, ny)?;
    let metrics = crate::measures::basin_labels_metrics(&result.labels, nx, ny, eps)?;
    Ok(BasinOutcome {
        coarse: coarse.clone(),
        spec,
        result,
        refined,
        reintegration,
        metrics,
        rub,
        traces,
    })
}
