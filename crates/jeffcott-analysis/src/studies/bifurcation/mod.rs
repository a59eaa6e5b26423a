//! Bifurcation diagrams over the rotor speed W (docs/model.md 5), two ways:
//!
//! - **quasistatic sweeps**: the final state at one W is the start state of the next, W
//!   increasing (up) and decreasing (down), so hysteresis shows. A sweep is serial in W
//!   and is one lane, so it runs on the CPU lane stepper in f64; the up and down sweeps
//!   run concurrently.
//! - **brute force**: K start states per W (the static equilibrium plus a seeded random
//!   set, the same at every W) run as one ensemble on the chosen backend; then a second
//!   ensemble starts, at every W, from the attractors found at the neighbouring W (the
//!   brute-force catalogues and the quasistatic sweeps), so branches that the random set
//!   misses are continued. Each W gets an attractor catalogue.
//!
//! With `lyapunov` every lane also carries one tangent vector and gives its largest
//! Lyapunov exponent lambda_1 over the recorded periods: the sweeps through the lane
//! stepper's tangent variant ([`advance_period_tangent`], renormalised every period, a
//! fresh vector along (1, ..., 1)/sqrt(8) at the start of each W's transient, which
//! aligns it), the brute force through the ensembles' lambda_1 variant on either backend
//! (the same arithmetic). Aperiodic lanes then classify as quasiperiodic or chaotic.
//!
//! [`advance_period_tangent`]: jeffcott_core::integrate::lane::advance_period_tangent

mod brute;
pub mod portrait;
mod record;
mod sweeps;

pub use brute::start_states;
pub(crate) use brute::unit;
pub use record::{
    BifurcationArrays, BruteAttractor, BruteRecord, SpeedRecord, Summary, SweepRecord, arrays,
    summary, sweep_id,
};
pub use sweeps::sweep_unit;

use crate::catalogue::{Catalogue, LaneClass};
use crate::run::lanes::Control;
use crate::run::{MemoryStore, UnitStore};
use crate::settings::LaneSettings;
use brute::{brute_force, brute_stage};
use jeffcott_core::ensemble::{Backend, EnsembleSpec, RunInfo};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::Status;
use jeffcott_core::model::{STATE_DIM, State};
use serde::{Deserialize, Serialize};
use sweeps::sweep;

/// Which quasistatic sweeps to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Sweep {
    /// W increasing.
    Up,
    /// W decreasing.
    Down,
    /// Both (concurrently).
    Both,
}

/// What a bifurcation study computes. It is its own record: `run.json` holds it as it
/// serializes (not the backend: units computed on any backend may be combined), and it
/// reads back from there.
///
/// # Example
///
/// An up sweep and a brute force of two start states per speed at three speeds, on the
/// CPU, run in memory with [`bifurcation()`]:
///
/// ```
/// use jeffcott_analysis::bifurcation::{BifurcationSpec, Sweep, bifurcation};
/// use jeffcott_analysis::settings::LaneSettings;
/// use jeffcott_core::control::Control;
/// use jeffcott_core::ensemble::{Backend, Precision};
///
/// let spec = BifurcationSpec {
///     lane: LaneSettings {
///         backend: Backend::Cpu,
///         ..LaneSettings::new(Precision::F64)
///     },
///     omegas: vec![131.0, 132.0, 133.0],
///     sweep: Some(Sweep::Up),
///     transient_first: 50,
///     transient: 20,
///     ics: 2,
///     brute_transient: 50,
///     periods: 8,
///     seed: 1,
///     max_seeds: 2,
/// };
/// spec.validate()?;
/// let res = bifurcation(&spec, Control::none())?;
/// // The up sweep: one point per speed, by increasing W, each with its record.
/// assert_eq!(res.up.iter().map(|p| p.omega).collect::<Vec<_>>(), spec.omegas);
/// assert!(res.up.iter().all(|p| p.points.len() == 8));
/// assert!(res.down.is_empty());
/// // The brute force: per speed, every lane labelled with an attractor of its catalogue
/// // (or -1, diverged).
/// assert_eq!(res.brute.len(), 3);
/// for b in &res.brute {
///     assert_eq!(b.catalogue.labels.len(), b.starts.len());
///     assert!(b.catalogue.labels.iter().all(|&l| l < b.catalogue.attractors.len() as i32));
/// }
/// # Ok::<(), jeffcott_core::Error>(())
/// ```
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BifurcationSpec {
    /// Model, stepper, precision, backend, classification, lambda_1.
    #[serde(flatten)]
    pub lane: LaneSettings,
    /// Speeds, increasing [rad/s].
    #[serde(with = "crate::record::speeds")]
    pub omegas: Vec<f64>,
    /// Quasistatic sweeps to run (`None`: none).
    pub sweep: Option<Sweep>,
    /// Transient at the first W of a sweep (from the static equilibrium) [periods].
    pub transient_first: u32,
    /// Transient at every later W of a sweep [periods].
    pub transient: u32,
    /// Start states per W of the brute-force ensemble (0: no brute force).
    pub ics: u32,
    /// Transient of the brute-force lanes [periods].
    pub brute_transient: u32,
    /// Recorded periods (Poincare points) per lane, sweeps and brute force alike.
    pub periods: u32,
    /// Seed of the random start states.
    pub seed: u64,
    /// Neighbour seeds per W in the second brute-force pass, at most.
    pub max_seeds: usize,
}

impl crate::record::StudySpec for BifurcationSpec {
    fn set_backend(&mut self, backend: Backend) {
        self.lane.backend = backend;
    }
}

impl BifurcationSpec {
    /// Checks the inputs; errors name the option and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.lane.validate()?;
        if self.omegas.is_empty() {
            return Err(Error::invalid("omega", 0, "at least one speed is needed"));
        }
        for &w in &self.omegas {
            jeffcott_core::model::validate_omega(w)?;
        }
        if self.omegas.windows(2).any(|p| p[1] <= p[0]) {
            return Err(Error::invalid(
                "omega",
                format!("{:?}..", &self.omegas[..2.min(self.omegas.len())]),
                "speeds must increase (write a:b:n with a < b)",
            ));
        }
        if self.sweep.is_none() && self.ics == 0 {
            return Err(Error::invalid(
                "ics",
                0,
                "with no quasistatic sweep, at least one brute-force start state is needed",
            ));
        }
        if self.ics > 100_000 {
            return Err(Error::invalid("ics", self.ics, "must be in 0..=100000"));
        }
        jeffcott_core::limits::check_periods("transient-first", self.transient_first, 0)?;
        jeffcott_core::limits::check_periods("transient", self.transient, 0)?;
        jeffcott_core::limits::check_periods("brute-transient", self.brute_transient, 0)?;
        jeffcott_core::limits::check_periods("periods", self.periods, 2)?;
        Ok(())
    }

    /// Bytes the study holds at its peak, an upper estimate:
    /// [`BifurcationSpec::memory_estimate_for`] of this spec.
    pub fn memory_estimate(&self) -> u64 {
        let sweeps = match self.sweep {
            None => 0,
            Some(Sweep::Both) => 2,
            Some(_) => 1,
        };
        Self::memory_estimate_for(
            self.omegas.len() as u64,
            sweeps,
            self.ics as u64,
            self.max_seeds as u64,
            self.periods as u64,
        )
    }

    /// The memory estimate from the sizes alone, so it can be checked before the speeds
    /// are allocated: every sweep point keeps its records; the brute force runs all
    /// `ics` lanes of every W as one ensemble, then up to `max_seeds` more per W, each
    /// ensemble at [`EnsembleSpec::memory_estimate_for`], and copies both into the
    /// per-W results; writing `bifurcation.npy` gathers every row once more.
    /// Refuses, before any speed is allocated, a diagram whose records would not fit
    /// in memory: `n_omegas` speeds (given as `omega`, named in the error), `sweeps`
    /// quasistatic sweeps, `ics` start states per speed, up to `max_seeds` seeds, each
    /// recording `recorded` periods. The one check of the command line and Python.
    pub fn check_size(
        omega: &str,
        n_omegas: u64,
        sweeps: u64,
        ics: u32,
        max_seeds: usize,
        recorded: u32,
    ) -> Result<()> {
        let (ics, seeds) = (ics.min(100_000) as u64, max_seeds as u64);
        jeffcott_core::limits::check_memory(
            "omega",
            omega,
            Self::memory_estimate_for(n_omegas, sweeps, ics, seeds, recorded as u64),
            &format!(
                "{n_omegas} speeds x ({sweeps} sweeps + {ics} start states + up to {seeds} seeds) x {recorded} recorded periods"
            ),
            "ask for fewer speeds (a smaller n in a:b:n), fewer start states (ics) or seeds (max-seeds), or fewer periods",
        )
    }

    /// Bytes a diagram's records need at most (see [`BifurcationSpec::check_size`]).
    pub fn memory_estimate_for(
        n_omegas: u64,
        sweeps: u64,
        ics: u64,
        max_seeds: u64,
        recorded: u64,
    ) -> u64 {
        use jeffcott_core::limits::product;
        let record = (STATE_DIM * 8) as u64;
        let rows = sweeps.saturating_add(ics.min(1).saturating_mul(ics.saturating_add(max_seeds)));
        let lanes = product(&[n_omegas, rows]);
        let brute_lanes = product(&[n_omegas, ics.min(1) * ics.saturating_add(max_seeds)]);
        EnsembleSpec::memory_estimate_for(brute_lanes, recorded)
            .saturating_add(product(&[lanes, recorded, record, 2]))
            .saturating_add(product(&[
                n_omegas,
                jeffcott_core::ensemble::PER_LANE_BYTES,
            ]))
    }
}

/// One W of a quasistatic sweep.
#[derive(Clone, Debug)]
pub struct SweepPoint {
    /// Rotor speed [rad/s].
    pub omega: f64,
    /// Recorded Poincare points.
    pub points: Vec<State>,
    /// Lane outcome.
    pub status: Status,
    /// Classification of the points.
    pub class: LaneClass,
    /// Largest Lyapunov exponent over the recorded periods [1/s] (NaN when not computed
    /// or the lane froze).
    pub lambda1: f64,
}

/// The brute-force lanes at one W and their catalogue.
#[derive(Clone, Debug)]
pub struct BrutePoint {
    /// Rotor speed [rad/s].
    pub omega: f64,
    /// Start states: the K common ones, then the neighbour seeds.
    pub starts: Vec<State>,
    /// Poincare points, [lanes, recorded, 8] flat.
    pub points: Vec<f64>,
    /// The attractor catalogue (labels per lane).
    pub catalogue: Catalogue,
    /// Largest Lyapunov exponent per lane [1/s], when computed (NaN for frozen lanes).
    pub lambda1: Option<Vec<f64>>,
}

/// Everything a bifurcation study produced.
#[derive(Clone, Debug)]
pub struct BifurcationResult {
    /// Up sweep, by increasing W (empty if not run).
    pub up: Vec<SweepPoint>,
    /// Down sweep, by increasing W (empty if not run; it ran in decreasing W).
    pub down: Vec<SweepPoint>,
    /// Brute force per W (empty if not run).
    pub brute: Vec<BrutePoint>,
    /// Wall time of the sweeps [s].
    pub sweep_seconds: f64,
    /// Wall time of the brute force [s].
    pub brute_seconds: f64,
    /// Backend information of the brute-force ensembles.
    pub brute_info: Option<RunInfo>,
    /// What early exit saved in the brute force (`None`: it ran without).
    pub brute_early_exit: Option<crate::early::EarlySaved>,
}

/// Lane-periods a study integrates (for progress bars): each sweep exactly (its first
/// speed with `transient_first`), both brute-force passes at their largest.
pub fn work(spec: &BifurcationSpec) -> u64 {
    let n = spec.omegas.len() as u64;
    let sweeps = match spec.sweep {
        None => 0,
        Some(Sweep::Both) => 2,
        Some(_) => 1,
    };
    let per_w = (spec.transient + spec.periods) as u64;
    let sweep = (spec.transient_first + spec.periods) as u64 + n.saturating_sub(1) * per_w;
    sweeps * sweep
        + n * spec.ics as u64 * (spec.brute_transient + spec.periods) as u64
        + n * spec.max_seeds as u64 * (spec.brute_transient + spec.periods) as u64
}

/// Runs the study in memory; `ctl.progress` counts lane-periods (see [`work`]).
pub fn bifurcation(spec: &BifurcationSpec, ctl: Control) -> Result<BifurcationResult> {
    bifurcation_with(spec, &MemoryStore::new(), ctl)
}

/// Runs a bifurcation study under `host` (its units committed to the host's store, its
/// progress on the host's display as stage `bifurcation`): the front ends' entry point.
pub fn run(spec: &BifurcationSpec, host: &impl crate::run::Host) -> Result<BifurcationResult> {
    let per_lane = (spec.brute_transient + spec.periods) as u64;
    host.progress(
        crate::run::Stage::new("bifurcation", work(spec), per_lane),
        |ctl| bifurcation_with(spec, host.store(), ctl),
    )
}

/// Runs the study unit by unit into `store`, resuming from the units it holds: the
/// first brute-force pass (`bf1`, independent of everything else, so it is the part a
/// shard computes), the sweeps (stages `up`, `down`), then the second brute-force pass
/// (`bf2`), whose seeds come from the assembled first pass and the sweeps.
pub fn bifurcation_with(
    spec: &BifurcationSpec,
    store: &dyn UnitStore,
    ctl: Control,
) -> Result<BifurcationResult> {
    spec.validate()?;
    let t0 = std::time::Instant::now();
    let (run_up, run_down) = match spec.sweep {
        None => (false, false),
        Some(Sweep::Up) => (true, false),
        Some(Sweep::Down) => (false, true),
        Some(Sweep::Both) => (true, true),
    };
    let total = work(spec);
    let progress = |d: u64, _t: u64| (ctl.progress)(d, total);
    let ctl_bf1 = Control {
        progress: &progress,
        cancel: ctl.cancel,
    };
    let first_pass = if spec.ics > 0 {
        let engine = crate::backend::Engine::new(spec.lane.backend, spec.lane.precision)?;
        let w_mid = 0.5 * (spec.omegas[0] + spec.omegas[spec.omegas.len() - 1]);
        let common = start_states(&spec.lane.params, spec.ics, w_mid, spec.seed);
        let (res1, info1) = brute_stage(
            spec,
            &engine,
            "bf1",
            &|_| common.clone(),
            Some(brute::BruteEarly::FirstLane),
            store,
            ctl_bf1,
            0,
        )?;
        Some((engine, common, res1, info1))
    } else {
        None
    };
    // The brute force's first pass (run first: it seeds the sweeps' neighbours) counts
    // as brute-force time, not as the sweeps'.
    let first_pass_seconds = t0.elapsed().as_secs_f64();
    let t_sweeps = std::time::Instant::now();
    let pass1 =
        spec.omegas.len() as u64 * spec.ics as u64 * (spec.brute_transient + spec.periods) as u64;
    let done_work = std::sync::atomic::AtomicU64::new(pass1);
    let rev: Vec<f64> = spec.omegas.iter().rev().copied().collect();
    let (up, down) = rayon::join(
        || {
            if run_up {
                sweep(spec, &spec.omegas, "up", store, &done_work, ctl, total)
            } else {
                Ok(Vec::new())
            }
        },
        || {
            if run_down {
                sweep(spec, &rev, "down", store, &done_work, ctl, total)
            } else {
                Ok(Vec::new())
            }
        },
    );
    let up = up?;
    let mut down = down?;
    down.reverse();
    let sweep_seconds = t_sweeps.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    let mut brute = Vec::new();
    let mut brute_info = None;
    let mut brute_early_exit = None;
    if let Some(first) = first_pass {
        let offset = done_work.load(std::sync::atomic::Ordering::Relaxed);
        let progress = |d: u64, _t: u64| (ctl.progress)(offset + d, total);
        let ctl2 = Control {
            progress: &progress,
            cancel: ctl.cancel,
        };
        let (b, info, saved) = brute_force(spec, &up, &down, first, store, ctl2)?;
        brute = b;
        brute_info = info;
        brute_early_exit = saved;
    }
    Ok(BifurcationResult {
        up,
        down,
        brute,
        sweep_seconds,
        brute_seconds: first_pass_seconds + t1.elapsed().as_secs_f64(),
        brute_info,
        brute_early_exit,
    })
}
