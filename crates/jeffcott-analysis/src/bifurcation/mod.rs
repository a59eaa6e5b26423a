//! Bifurcation diagrams over the rotor speed W (MODEL.md 5), two ways:
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

use super::catalogue::{Catalogue, CatalogueBuilder, CatalogueConfig, LaneClass, classify_lane};
use crate::record::Span;
use crate::rub::RubEntry;
use crate::run::lanes::{Control, LaneUnits};
use crate::run::{Array, MemoryStore, Unit, UnitStore};
use jeffcott_core::ensemble::{Backend, EnsembleSpec, LaneSpec, Precision, RunInfo};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::{
    LAMBDA1_START, Lane, LaneConsts, Status, StepperConfig, Tangent, advance_period,
    advance_period_tangent, renormalise,
};
use jeffcott_core::model::{Params, STATE_DIM, State, VX_R, VY_R, X_R, Y_R};
use serde::Serialize;

/// Which quasistatic sweeps to run.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Sweep {
    /// W increasing.
    Up,
    /// W decreasing.
    Down,
    /// Both (concurrently).
    Both,
}

/// What a bifurcation study computes.
#[derive(Clone, Debug)]
pub struct BifurcationSpec {
    /// Model parameters.
    pub params: Params,
    /// Speeds, increasing [rad/s].
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
    pub recorded: u32,
    /// Seed of the random start states.
    pub seed: u64,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
    /// Precision of the brute-force lanes (sweeps are f64).
    pub precision: Precision,
    /// Backend of the brute-force ensembles.
    pub backend: Backend,
    /// Classification tolerances.
    pub catalogue: CatalogueConfig,
    /// Neighbour seeds per W in the second brute-force pass, at most.
    pub max_seeds: usize,
    /// Compute the largest Lyapunov exponent of every lane (sweeps and brute force).
    pub lyapunov: bool,
}

impl BifurcationSpec {
    /// Checks the inputs; errors name the option and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.params.validate()?;
        self.stepper.validate()?;
        self.catalogue.validate()?;
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
        if self.recorded < 2 {
            return Err(Error::invalid(
                "periods",
                self.recorded,
                "at least 2 periods must be recorded",
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
        jeffcott_core::limits::check_periods("periods", self.recorded, 2)?;
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
            self.recorded as u64,
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

/// A bifurcation study's specification as `run.json` records it (not the backend: units
/// computed on any backend may be combined).
#[derive(Clone, Debug, Serialize)]
pub struct SpecRecord<'a> {
    /// The speeds.
    pub omegas: Span,
    /// Which sweeps ran.
    pub sweep: Option<Sweep>,
    /// Transient at the first speed of a sweep.
    pub transient_first: u32,
    /// Transient at every later speed of a sweep.
    pub transient: u32,
    /// Brute-force start states per speed.
    pub ics: u32,
    /// Brute-force transient.
    pub brute_transient: u32,
    /// Recorded periods.
    pub periods: u32,
    /// Seed of the brute-force start states.
    pub seed: u64,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
    /// Lane precision.
    pub precision: Precision,
    /// Catalogue settings.
    pub catalogue: &'a CatalogueConfig,
    /// Neighbour seeds at most per speed.
    pub max_seeds: usize,
    /// Whether lambda_1 is computed.
    pub lyapunov: bool,
    /// Model parameters.
    pub params: &'a Params,
}

impl BifurcationSpec {
    /// The specification as `run.json` records it.
    pub fn record(&self) -> SpecRecord<'_> {
        SpecRecord {
            omegas: Span::of(&self.omegas),
            sweep: self.sweep,
            transient_first: self.transient_first,
            transient: self.transient,
            ics: self.ics,
            brute_transient: self.brute_transient,
            periods: self.recorded,
            seed: self.seed,
            stepper: self.stepper,
            precision: self.precision,
            catalogue: &self.catalogue,
            max_seeds: self.max_seeds,
            lyapunov: self.lyapunov,
            params: &self.params,
        }
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
    let per_w = (spec.transient + spec.recorded) as u64;
    let sweep = (spec.transient_first + spec.recorded) as u64 + n.saturating_sub(1) * per_w;
    sweeps * sweep
        + n * spec.ics as u64 * (spec.brute_transient + spec.recorded) as u64
        + n * spec.max_seeds as u64 * (spec.brute_transient + spec.recorded) as u64
}

/// W steps per unit of a quasistatic sweep: at most 1/20 of the sweep and about 25 s
/// of one core (a sweep is one lane, stepped at about a quarter of the batched
/// ensemble rate that [`crate::run::MAX_UNIT_LANE_STEPS`] assumes).
pub fn sweep_unit(spec: &BifurcationSpec) -> usize {
    let per_w = (spec.transient.max(spec.transient_first) + spec.recorded) as u64
        * spec.stepper.steps_per_period as u64
        * if spec.lyapunov { 2 } else { 1 };
    crate::run::unit_lanes(spec.omegas.len(), 4 * per_w)
}

/// One W of a sweep, from start state `x`: the point and the state the next W starts
/// from (the static equilibrium again after a diverged lane).
fn sweep_step(spec: &BifurcationSpec, omega: f64, first: bool, x: &State) -> (SweepPoint, State) {
    let lc = LaneConsts::<f64>::new(&spec.params, omega, &spec.stepper);
    let mut lane = Lane::<f64>::new(x, spec.params.delta);
    let transient = if first {
        spec.transient_first
    } else {
        spec.transient
    };
    // The tangent vector (with `lyapunov`) starts afresh at each W and aligns during
    // the transient, as the ensembles' lambda_1 does.
    let mut tan = Tangent::<f64, 1>::new([[LAMBDA1_START; STATE_DIM]]);
    let mut step = |lane: &mut Lane<f64>| -> f64 {
        if spec.lyapunov {
            advance_period_tangent(&lc, lane, &mut tan);
            if lane.status.is_frozen() {
                1.0
            } else {
                renormalise(&mut tan.v[0])
            }
        } else {
            advance_period(&lc, lane);
            1.0
        }
    };
    for _ in 0..transient {
        if lane.status.is_frozen() {
            break;
        }
        step(&mut lane);
    }
    let mut points = Vec::with_capacity(spec.recorded as usize);
    let mut norms = Vec::with_capacity(spec.recorded as usize);
    for _ in 0..spec.recorded {
        norms.push(step(&mut lane));
        // As in the ensembles (`ensemble::mask_frozen_records`): from the period in which
        // the lane froze on, its records are NaN, not its last finite state.
        points.push(if lane.status.is_frozen() {
            [f64::NAN; STATE_DIM]
        } else {
            lane.x
        });
    }
    let lambda1 = if spec.lyapunov && !lane.status.is_frozen() {
        jeffcott_core::lyapunov::lambda1_from_norms(&norms, omega)
    } else {
        f64::NAN
    };
    let next = if lane.status.is_frozen() {
        spec.params.static_equilibrium()
    } else {
        lane.x
    };
    (sweep_point(spec, omega, points, lane.status, lambda1), next)
}

fn sweep_point(
    spec: &BifurcationSpec,
    omega: f64,
    points: Vec<State>,
    status: Status,
    lambda1: f64,
) -> SweepPoint {
    let class = classify_lane(
        &points,
        omega,
        status.is_frozen(),
        spec.lyapunov.then_some(lambda1),
        &spec.catalogue,
    );
    SweepPoint {
        omega,
        points,
        status,
        class,
        lambda1,
    }
}

/// One quasistatic sweep over `omegas` in the given order, unit by unit into `store`
/// under `stage` (a unit: [`sweep_unit`] consecutive speeds, with the state the next
/// unit starts from); committed units are read back, not recomputed.
fn sweep(
    spec: &BifurcationSpec,
    omegas: &[f64],
    stage: &str,
    store: &dyn UnitStore,
    done_work: &std::sync::atomic::AtomicU64,
    ctl: Control,
    total: u64,
) -> Result<Vec<SweepPoint>> {
    let per = sweep_unit(spec);
    let count = crate::run::unit_count(omegas.len(), per);
    let done = store.committed(stage, count)?;
    let rec = spec.recorded as usize;
    let mut x = spec.params.static_equilibrium();
    let mut out = Vec::with_capacity(omegas.len());
    let add = |periods: u64| {
        let d = done_work.fetch_add(periods, std::sync::atomic::Ordering::Relaxed) + periods;
        (ctl.progress)(d, total);
    };
    for (u, &is_done) in done.iter().enumerate() {
        let range = u * per..((u + 1) * per).min(omegas.len());
        let periods: u64 = range
            .clone()
            .map(|k| {
                (if k == 0 {
                    spec.transient_first
                } else {
                    spec.transient
                } + spec.recorded) as u64
            })
            .sum();
        if is_done {
            let unit = store.load(stage, u)?;
            let pts = unit.f64s("points")?;
            let codes = unit.u32s("status")?;
            let l1 = unit.f64s("lambda1")?;
            for (j, k) in range.clone().enumerate() {
                let points: Vec<State> = pts[j * rec * STATE_DIM..(j + 1) * rec * STATE_DIM]
                    .chunks_exact(STATE_DIM)
                    .map(|c| c.try_into().unwrap_or([f64::NAN; STATE_DIM]))
                    .collect();
                let status = Status::from_code(codes[j]).unwrap_or(Status::NonFinite);
                out.push(sweep_point(spec, omegas[k], points, status, l1[j]));
            }
            x = unit
                .f64s("carry")?
                .try_into()
                .unwrap_or([f64::NAN; STATE_DIM]);
            add(periods);
            continue;
        }
        if ctl.cancel.is_set() {
            return Err(Error::Interrupted {
                committed: u,
                total: count,
            });
        }
        let mut pts = Vec::with_capacity(range.len() * rec * STATE_DIM);
        let mut codes = Vec::with_capacity(range.len());
        let mut l1 = Vec::with_capacity(range.len());
        for k in range.clone() {
            let (p, next) = sweep_step(spec, omegas[k], k == 0, &x);
            pts.extend(p.points.iter().flatten());
            codes.push(p.status.code());
            l1.push(p.lambda1);
            x = next;
            out.push(p);
        }
        let unit = Unit::new(crate::run::dir::unit_key(stage, u))
            .with("points", Array::F64(pts))
            .with("status", Array::U32(codes))
            .with("lambda1", Array::F64(l1))
            .with("carry", Array::F64(x.to_vec()));
        store.commit(stage, u, &unit)?;
        add(periods);
    }
    Ok(out)
}

/// A deterministic hash in [-1, 1) (splitmix64).
pub(crate) fn unit(i: u64, salt: u64) -> f64 {
    let mut z = i
        .wrapping_add(salt.wrapping_mul(0x9E37_79B9_7F4A_7C15))
        .wrapping_mul(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^= z >> 31;
    (z >> 11) as f64 / (1u64 << 52) as f64 - 1.0
}

/// The K brute-force start states: the static equilibrium, then rotor states drawn
/// (seeded) with positions within the gap `delta` of the static deflection and
/// velocities within `w_ref * delta`; the stator starts at rest at its static deflection.
pub fn start_states(params: &Params, k: u32, w_ref: f64, seed: u64) -> Vec<State> {
    let eq = params.static_equilibrium();
    (0..k as u64)
        .map(|i| {
            let mut x = eq;
            if i > 0 {
                let d = params.delta;
                x[X_R] += d * unit(i, seed.wrapping_mul(4));
                x[Y_R] += d * unit(i, seed.wrapping_mul(4) + 1);
                x[VX_R] += w_ref * d * unit(i, seed.wrapping_mul(4) + 2);
                x[VY_R] += w_ref * d * unit(i, seed.wrapping_mul(4) + 3);
            }
            x
        })
        .collect()
}

/// Runs the study in memory; `ctl.progress` counts lane-periods (see [`work`]).
pub fn bifurcation(spec: &BifurcationSpec, ctl: Control) -> Result<BifurcationResult> {
    bifurcation_with(spec, &MemoryStore::new(), ctl)
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
        let engine = crate::backend::Engine::new(spec.backend, spec.precision)?;
        let w_mid = 0.5 * (spec.omegas[0] + spec.omegas[spec.omegas.len() - 1]);
        let common = start_states(&spec.params, spec.ics, w_mid, spec.seed);
        let (res1, info1) =
            brute_stage(spec, &engine, "bf1", &|_| common.clone(), store, ctl_bf1, 0)?;
        Some((engine, common, res1, info1))
    } else {
        None
    };
    let pass1 =
        spec.omegas.len() as u64 * spec.ics as u64 * (spec.brute_transient + spec.recorded) as u64;
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
    let sweep_seconds = t0.elapsed().as_secs_f64();
    let t1 = std::time::Instant::now();
    let mut brute = Vec::new();
    let mut brute_info = None;
    if let Some(first) = first_pass {
        let offset = done_work.load(std::sync::atomic::Ordering::Relaxed);
        let progress = |d: u64, _t: u64| (ctl.progress)(offset + d, total);
        let ctl2 = Control {
            progress: &progress,
            cancel: ctl.cancel,
        };
        let (b, info) = brute_force(spec, &up, &down, first, store, ctl2)?;
        brute = b;
        brute_info = info;
    }
    Ok(BifurcationResult {
        up,
        down,
        brute,
        sweep_seconds,
        brute_seconds: t1.elapsed().as_secs_f64(),
        brute_info,
    })
}

/// Concatenated results of all units of a brute-force stage.
struct StageResult {
    poincare: Vec<f64>,
    status: Vec<Status>,
    lambda1: Option<Vec<f64>>,
}

/// Runs (or resumes) one brute-force stage: `lanes_of(wi)` are the lanes at speed index
/// wi; a unit holds consecutive speeds (at most 1/20 of them and ~25 s of work).
fn brute_stage(
    spec: &BifurcationSpec,
    engine: &crate::backend::Engine,
    stage: &str,
    lanes_of: &(dyn Fn(usize) -> Vec<State> + Sync),
    store: &dyn UnitStore,
    ctl: Control,
    base: u64,
) -> Result<(StageResult, Option<RunInfo>)> {
    let n = spec.omegas.len();
    let per_w = spec.ics.max(1) as u64
        * (spec.brute_transient + spec.recorded) as u64
        * spec.stepper.steps_per_period as u64
        * if spec.lyapunov { 2 } else { 1 };
    let per = crate::run::unit_lanes(n, per_w);
    let count = crate::run::unit_count(n, per);
    let ensemble = |u: usize| EnsembleSpec {
        param_sets: vec![spec.params.clone()],
        lanes: (u * per..((u + 1) * per).min(n))
            .flat_map(|wi| {
                let omega = spec.omegas[wi];
                lanes_of(wi).into_iter().map(move |x0| LaneSpec {
                    omega,
                    x0,
                    param_set: 0,
                })
            })
            .collect(),
        transient: spec.brute_transient,
        recorded: spec.recorded,
        stepper: spec.stepper,
        precision: spec.precision,
    };
    let reduce = |_u: usize, _e: &EnsembleSpec, r: jeffcott_core::ensemble::EnsembleResult| {
        let mut unit = Unit::new("").with("poincare", Array::F64(r.poincare)).with(
            "status",
            Array::U32(r.status.iter().map(|s| s.code()).collect()),
        );
        if let Some(l) = r.lambda1 {
            unit = unit.with("lambda1", Array::F64(l));
        }
        Ok(unit)
    };
    let progress = |d: u64, _t: u64| (ctl.progress)(base + d, 0);
    let info = crate::run::lanes::run_units(
        store,
        engine,
        &LaneUnits {
            stage,
            count,
            ensemble: &ensemble,
            lanes: &|u| {
                (u * per..((u + 1) * per).min(n))
                    .map(|wi| lanes_of(wi).len())
                    .sum()
            },
            lambda1: spec.lyapunov,
            reduce: &reduce,
        },
        Control {
            progress: &progress,
            cancel: ctl.cancel,
        },
    )?;
    let mut out = StageResult {
        poincare: Vec::new(),
        status: Vec::new(),
        lambda1: spec.lyapunov.then(Vec::new),
    };
    for u in 0..count {
        let unit = store.load(stage, u)?;
        out.poincare.extend_from_slice(unit.f64s("poincare")?);
        out.status.extend(
            unit.u32s("status")?
                .iter()
                .map(|&c| Status::from_code(c).unwrap_or(Status::NonFinite)),
        );
        if let Some(l) = out.lambda1.as_mut() {
            l.extend_from_slice(unit.f64s("lambda1")?);
        }
    }
    Ok((out, info))
}

/// The first brute-force pass as [`brute_force`] continues it: the engine, the common
/// start states, the pass's lanes and how it ran.
type FirstPass = (
    crate::backend::Engine,
    Vec<State>,
    StageResult,
    Option<RunInfo>,
);

fn brute_force(
    spec: &BifurcationSpec,
    up: &[SweepPoint],
    down: &[SweepPoint],
    first: FirstPass,
    store: &dyn UnitStore,
    ctl: Control,
) -> Result<(Vec<BrutePoint>, Option<RunInfo>)> {
    let (engine, common, res1, info1) = first;
    let n = spec.omegas.len();
    let k = spec.ics as usize;
    let rec = spec.recorded as usize;
    let lane_len = rec * STATE_DIM;
    // First-pass catalogues, to know what to seed from.
    let mut builders: Vec<CatalogueBuilder> = Vec::with_capacity(n);
    let mut labels: Vec<Vec<i32>> = Vec::with_capacity(n);
    for (wi, &omega) in spec.omegas.iter().enumerate() {
        let mut b = CatalogueBuilder::new(omega, spec.catalogue);
        let frozen: Vec<bool> = res1.status[wi * k..(wi + 1) * k]
            .iter()
            .map(|s| s.is_frozen())
            .collect();
        labels.push(b.add_block(
            &res1.poincare[wi * k * lane_len..(wi + 1) * k * lane_len],
            rec,
            &frozen,
            res1.lambda1.as_ref().map(|l| &l[wi * k..(wi + 1) * k]),
        ));
        builders.push(b);
    }
    // Second pass: at each W, start from the attractors of the neighbouring W (one point
    // of each, a state at t = kT) and from the sweeps' states there.
    let mut seeds: Vec<Vec<State>> = vec![Vec::new(); n];
    for (wi, s) in seeds.iter_mut().enumerate() {
        // The sweeps' states first (they are the branches a continuation follows), then
        // one point of every attractor found at the neighbouring W.
        let mut cand: Vec<State> = Vec::new();
        let neighbours = [wi.wrapping_sub(1), wi + 1];
        for &nj in &neighbours {
            for sw in [up, down] {
                if let Some(p) = sw.get(nj)
                    && !p.status.is_frozen()
                {
                    cand.push(p.points[p.points.len() - 1]);
                }
            }
        }
        for &nj in &neighbours {
            if nj < n {
                for a in builders[nj].attractors() {
                    cand.push(a.points[a.points.len() - 1]);
                }
            }
        }
        cand.truncate(spec.max_seeds);
        *s = cand;
    }
    let (res2, info2) = if seeds.iter().all(|s| s.is_empty()) {
        (None, None)
    } else {
        let (r, i) = brute_stage(spec, &engine, "bf2", &|wi| seeds[wi].clone(), store, ctl, 0)?;
        (Some(r), i)
    };
    let mut out = Vec::with_capacity(n);
    let mut off2 = 0usize;
    for (wi, (mut b, mut lab)) in builders.into_iter().zip(labels).enumerate() {
        let m = seeds[wi].len();
        let mut points = res1.poincare[wi * k * lane_len..(wi + 1) * k * lane_len].to_vec();
        let mut lambda1 = res1
            .lambda1
            .as_ref()
            .map(|l| l[wi * k..(wi + 1) * k].to_vec());
        if let Some(r2) = &res2 {
            let frozen: Vec<bool> = r2.status[off2..off2 + m]
                .iter()
                .map(|s| s.is_frozen())
                .collect();
            let p2 = &r2.poincare[off2 * lane_len..(off2 + m) * lane_len];
            let l2 = r2.lambda1.as_ref().map(|l| &l[off2..off2 + m]);
            lab.extend(b.add_block(p2, rec, &frozen, l2));
            points.extend_from_slice(p2);
            if let (Some(l), Some(l2)) = (lambda1.as_mut(), l2) {
                l.extend_from_slice(l2);
            }
        }
        off2 += m;
        let mut starts = common.clone();
        starts.extend_from_slice(&seeds[wi]);
        out.push(BrutePoint {
            omega: spec.omegas[wi],
            starts,
            points,
            catalogue: b.finish(lab),
            lambda1,
        });
    }
    Ok((out, info2.or(info1)))
}

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
                    .map(
                        |at| Ok(crate::rub::attractor_rub(&spec.params, at, &spec.stepper)?.into()),
                    )
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
        periods: spec.recorded,
        max_seeds: spec.max_seeds,
        lyapunov: spec.lyapunov,
        steps_per_period: spec.stepper.steps_per_period,
        catalogue: &spec.catalogue,
        up_down_differ_at,
        per_omega,
        params: &spec.params,
    })
}
