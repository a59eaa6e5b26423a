//! Full-spectrum cascades: the full spectrum of the rotor's (and stator's) orbit at each
//! speed of a quasistatic run-up and run-down (each speed starts from the state the
//! previous one ended in, as a machine ramped slowly), the rotordynamics engineer's
//! waterfall of rub signatures (docs/rub.md).
//!
//! The sweep is sequential, so it runs in units of consecutive speeds, each committed
//! with its spectra, rub regimes and the state the next unit starts from: an interrupted
//! cascade resumes where it stopped, bit for bit.

use super::rub::rub_figures;
use super::spectrum::{full_spectrum, orbit};
use crate::record::Span;
use crate::run::{Array, Cancel, MemoryStore, Unit, UnitStore};
use crate::simulate::{Integrator, SimulateSpec, simulate};
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM, State};
use serde::Serialize;

/// What a cascade computes.
#[derive(Clone, Debug)]
pub struct CascadeSpec {
    /// Model parameters.
    pub params: Params,
    /// The speeds, ascending [rad/s].
    pub omegas: Vec<f64>,
    /// Forcing periods integrated at the first speed from the static equilibrium.
    pub transient_first: u32,
    /// Forcing periods integrated at each later speed before recording.
    pub transient: u32,
    /// Forcing periods of each spectrum (a multiple of 6 puts 1/2X, 1/3X, 2/3X on bins).
    pub periods: u32,
    /// Orders kept, -max_order..=max_order.
    pub max_order: f64,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
    /// Run-up, run-down or both.
    pub up: bool,
    /// See `up`.
    pub down: bool,
}

/// Speeds per unit at most.
const UNIT_SPEEDS: usize = 25;

impl CascadeSpec {
    /// Checks the inputs.
    pub fn validate(&self) -> Result<()> {
        self.params.validate()?;
        self.stepper.validate()?;
        if self.omegas.len() < 2 {
            return Err(Error::invalid(
                "omega",
                self.omegas.len(),
                "a cascade needs at least 2 speeds (a:b:n with n >= 2)",
            ));
        }
        for w in &self.omegas {
            jeffcott_core::model::validate_omega(*w)?;
        }
        jeffcott_core::limits::check_periods("transient", self.transient, 0)?;
        jeffcott_core::limits::check_periods("transient-first", self.transient_first, 0)?;
        if !(1..=10_000).contains(&self.periods) {
            return Err(Error::invalid(
                "periods",
                self.periods,
                "must be in 1..=10000",
            ));
        }
        if !(self.max_order > 0.0 && self.max_order <= self.stepper.steps_per_period as f64 / 2.0) {
            return Err(Error::invalid(
                "max-order",
                self.max_order,
                format!(
                    "must be in (0, N/2 = {}]",
                    self.stepper.steps_per_period / 2
                ),
            ));
        }
        if !(self.up || self.down) {
            return Err(Error::invalid("direction", "none", "give up, down or both"));
        }
        Ok(())
    }

    /// Bins per spectrum kept: orders k / periods for |k| <= max_order * periods.
    pub fn orders(&self) -> Vec<f64> {
        let kmax = (self.max_order * self.periods as f64).floor() as i64;
        (-kmax..=kmax)
            .map(|k| k as f64 / self.periods as f64)
            .collect()
    }

    /// The specification as `run.json` records it.
    pub fn record(&self) -> SpecRecord<'_> {
        SpecRecord {
            omega: Span::of(&self.omegas),
            transient_first: self.transient_first,
            transient: self.transient,
            periods: self.periods,
            max_order: self.max_order,
            stepper: self.stepper,
            up: self.up,
            down: self.down,
            params: &self.params,
        }
    }
}

/// A cascade's specification as `run.json` records it.
#[derive(Clone, Debug, Serialize)]
pub struct SpecRecord<'a> {
    /// The speeds.
    pub omega: Span,
    /// Transient at the first speed.
    pub transient_first: u32,
    /// Transient at every later speed.
    pub transient: u32,
    /// Periods of each spectrum.
    pub periods: u32,
    /// Largest order kept.
    pub max_order: f64,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
    /// Whether the run-up is computed.
    pub up: bool,
    /// Whether the run-down is computed.
    pub down: bool,
    /// Model parameters.
    pub params: &'a Params,
}

/// One sweep's cascade, speeds in sweep order.
#[derive(Clone, Debug)]
pub struct Sweep {
    /// The speeds in sweep order.
    pub omegas: Vec<f64>,
    /// Rotor amplitudes [speeds, orders] [m] (NaN after a divergence).
    pub rotor: Vec<f64>,
    /// Stator amplitudes [speeds, orders] [m].
    pub stator: Vec<f64>,
    /// Rub regime code per speed ([`super::rub::RubRegime::code`]).
    pub regime: Vec<i32>,
}

/// A computed cascade.
#[derive(Clone, Debug)]
pub struct CascadeResult {
    /// Orders of the kept bins.
    pub orders: Vec<f64>,
    /// Run-up, when asked for.
    pub up: Option<Sweep>,
    /// Run-down, when asked for.
    pub down: Option<Sweep>,
}

/// Computes a cascade in memory.
pub fn cascade(spec: &CascadeSpec) -> Result<CascadeResult> {
    cascade_with(spec, &MemoryStore::new(), &Cancel::new(), &|_, _| {})
}

/// Computes a cascade unit by unit into `store`, resuming from the units it holds;
/// `progress(done, total)` counts speeds.
pub fn cascade_with(
    spec: &CascadeSpec,
    store: &dyn UnitStore,
    cancel: &Cancel,
    progress: &(dyn Fn(u64, u64) + Sync),
) -> Result<CascadeResult> {
    spec.validate()?;
    let orders = spec.orders();
    let total = spec.omegas.len() as u64 * (spec.up as u64 + spec.down as u64);
    let done = std::sync::atomic::AtomicU64::new(0);
    let sweep = |stage: &str, omegas: Vec<f64>| -> Result<Sweep> {
        sweep_units(spec, store, cancel, stage, omegas, &orders, &|| {
            let d = done.fetch_add(1, std::sync::atomic::Ordering::Relaxed) + 1;
            progress(d, total);
        })
    };
    let rev: Vec<f64> = spec.omegas.iter().rev().copied().collect();
    let (up, down) = rayon::join(
        || {
            spec.up
                .then(|| sweep("up", spec.omegas.clone()))
                .transpose()
        },
        || spec.down.then(|| sweep("down", rev.clone())).transpose(),
    );
    Ok(CascadeResult {
        orders,
        up: up?,
        down: down?,
    })
}

fn sweep_units(
    spec: &CascadeSpec,
    store: &dyn UnitStore,
    cancel: &Cancel,
    stage: &str,
    omegas: Vec<f64>,
    orders: &[f64],
    tick: &(dyn Fn() + Sync),
) -> Result<Sweep> {
    let n = omegas.len();
    let count = n.div_ceil(UNIT_SPEEDS);
    let committed = store.committed(stage, count)?;
    let nb = orders.len();
    let kmax = (nb / 2) as i64;
    let mut out = Sweep {
        omegas: omegas.clone(),
        rotor: Vec::with_capacity(n * nb),
        stator: Vec::with_capacity(n * nb),
        regime: Vec::with_capacity(n),
    };
    let mut state: State = spec.params.static_equilibrium();
    for (u, &was_committed) in committed.iter().enumerate() {
        let range = u * UNIT_SPEEDS..((u + 1) * UNIT_SPEEDS).min(n);
        let unit = if was_committed {
            store.load(stage, u)?
        } else {
            if cancel.is_set() {
                return Err(Error::Interrupted {
                    committed: u,
                    total: count,
                });
            }
            let (mut rotor, mut stator, mut regime) = (Vec::new(), Vec::new(), Vec::new());
            for (j, &w) in omegas[range.clone()].iter().enumerate() {
                let first = u == 0 && j == 0;
                let r = if state.iter().all(|v| v.is_finite()) {
                    Some(simulate(&SimulateSpec {
                        params: spec.params.clone(),
                        omega: w,
                        x0: state,
                        transient: if first {
                            spec.transient_first
                        } else {
                            spec.transient
                        },
                        periods: spec.periods,
                        timeseries_periods: spec.periods,
                        integrator: Integrator::Lane,
                        stepper: spec.stepper,
                        article: Default::default(),
                        classify: Default::default(),
                    })?)
                } else {
                    None
                };
                match r.filter(|r| !r.status.is_frozen()) {
                    Some(r) => {
                        let m = full_spectrum(&orbit(&r.timeseries, false), spec.periods, w);
                        let s = full_spectrum(&orbit(&r.timeseries, true), spec.periods, w);
                        // Bins of order k / P sit at index k + M/2 of the shifted spectrum.
                        let half = (m.order.len() / 2) as i64;
                        for k in -kmax..=kmax {
                            let idx = (k + half) as usize;
                            rotor.push(m.amplitude.get(idx).copied().unwrap_or(f64::NAN));
                            stator.push(s.amplitude.get(idx).copied().unwrap_or(f64::NAN));
                        }
                        regime.push(
                            rub_figures(&spec.params, w, &r.timeseries, spec.periods)
                                .regime
                                .code(),
                        );
                        state = r.final_state;
                    }
                    None => {
                        rotor.extend(std::iter::repeat_n(f64::NAN, nb));
                        stator.extend(std::iter::repeat_n(f64::NAN, nb));
                        regime.push(super::rub::RubRegime::Diverged.code());
                        state = [f64::NAN; STATE_DIM];
                    }
                }
                tick();
            }
            let unit = Unit::new("")
                .with("rotor", Array::F64(rotor))
                .with("stator", Array::F64(stator))
                .with("regime", Array::I32(regime))
                .with("state", Array::F64(state.to_vec()));
            store.commit(stage, u, &unit)?;
            unit
        };
        if was_committed {
            for _ in range.clone() {
                tick();
            }
        }
        out.rotor.extend_from_slice(unit.f64s("rotor")?);
        out.stator.extend_from_slice(unit.f64s("stator")?);
        out.regime.extend_from_slice(unit.i32s("regime")?);
        let s = unit.f64s("state")?;
        state = s.try_into().unwrap_or([f64::NAN; STATE_DIM]);
    }
    Ok(out)
}
