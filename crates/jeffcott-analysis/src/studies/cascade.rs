//! Full-spectrum cascades: the full spectrum of the rotor's (and stator's) orbit at each
//! speed of a quasistatic run-up and run-down (each speed starts from the state the
//! previous one ended in, as a machine ramped slowly), the rotordynamics engineer's
//! waterfall of rub signatures (docs/rub.md).
//!
//! The sweep is sequential, so it runs in units of consecutive speeds, each committed
//! with its spectra, rub regimes and the state the next unit starts from: an interrupted
//! cascade resumes where it stopped, bit for bit.

use crate::record::Span;
use crate::rub::{RubRegime, rub_figures};
use crate::run::{Array, Cancel, MemoryStore, Unit, UnitStore};
use crate::simulate::{Integrator, SimulateSpec, simulate};
use crate::spectrum::{full_spectrum, orbit};
use jeffcott_core::control::Control;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::StepperConfig;
use jeffcott_core::model::{Params, STATE_DIM, State};
use serde::{Deserialize, Serialize};

/// What a cascade computes; `run.json` records it as it serializes, and it reads back
/// from there.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct CascadeSpec {
    /// Model parameters.
    pub params: Params,
    /// The speeds, ascending [rad/s].
    #[serde(rename = "omega", with = "crate::record::speeds")]
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

impl crate::record::StudySpec for CascadeSpec {
    /// A cascade runs on the CPU: no backend to set.
    fn set_backend(&mut self, _: jeffcott_core::ensemble::Backend) {}
}

/// Speeds per unit at most.
const UNIT_SPEEDS: usize = 25;

/// Speeds of a cascade at most.
pub const MAX_SPEEDS: u64 = 100_000;

impl CascadeSpec {
    /// The speeds of `a:b:n` (field `omega`), refused before they are allocated when
    /// there are more than [`MAX_SPEEDS`].
    pub fn speeds(text: &str) -> Result<Vec<f64>> {
        let r = jeffcott_core::ensemble::RangeSpec::parse("omega", text)?;
        if r.a > r.b {
            return Err(Error::invalid(
                "omega",
                text,
                "a cascade's range runs upward, a < b (the run-down is --direction down or both)",
            ));
        }
        if r.n > MAX_SPEEDS {
            return Err(Error::invalid(
                "omega",
                text,
                format!("at most {MAX_SPEEDS} speeds"),
            ));
        }
        Ok(r.values())
    }

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

    /// How many orders [`CascadeSpec::orders`] keeps, counted without allocating them.
    fn bins(&self) -> u64 {
        let kmax = (self.max_order * self.periods as f64).floor().max(0.0) as u64;
        kmax.saturating_mul(2).saturating_add(1)
    }

    /// Bytes a cascade holds at its peak, an upper estimate: each sweep's rotor and
    /// stator amplitudes (speeds x orders) three times (the sweep, its committed units,
    /// the arrays returned or written), and per sweep (they run at once) a simulation's
    /// time series and its spectra.
    pub fn memory_estimate(&self) -> u64 {
        use jeffcott_core::limits::product;
        let sweeps = self.up as u64 + self.down as u64;
        let amplitudes = product(&[sweeps, self.omegas.len() as u64, self.bins(), 8, 2, 3]);
        let x0 = self.params.static_equilibrium();
        let run = SimulateSpec::stretch(&self.params, 1.0, &x0, self.periods, &self.stepper)
            .memory_estimate();
        amplitudes.saturating_add(product(&[sweeps, run, 2]))
    }

    /// Refuses, before anything is allocated, a cascade (its speeds given as `omega`,
    /// named in the error) whose amplitudes and time series would not fit in memory. The
    /// one check of the command line and Python.
    pub fn check_size(&self, omega: &str) -> Result<()> {
        let sweeps = self.up as u64 + self.down as u64;
        jeffcott_core::limits::check_memory(
            "omega",
            omega,
            self.memory_estimate(),
            &format!(
                "{} speeds x {sweeps} sweeps x {} orders, and {} periods x {} steps of time series",
                self.omegas.len(),
                self.bins(),
                self.periods,
                self.stepper.steps_per_period
            ),
            "ask for fewer speeds (a smaller n in a:b:n), fewer periods or a smaller max order",
        )
    }
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
    /// Rub regime code per speed ([`crate::rub::RubRegime::code`]).
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

/// A cascade's arrays as `cascade.npy`, `cascade_stator.npy` and `regime.npy` hold them:
/// one block per computed sweep (up, then down), its rows in ascending speed.
#[derive(Clone, Debug, PartialEq)]
pub struct Arrays {
    /// The sweeps, in block order (`up`, `down`).
    pub sweeps: Vec<&'static str>,
    /// Rotor amplitudes [sweeps, speeds, orders] [m].
    pub rotor: Vec<f64>,
    /// Stator amplitudes [sweeps, speeds, orders] [m].
    pub stator: Vec<f64>,
    /// Rub regime codes [sweeps, speeds].
    pub regime: Vec<i32>,
}

/// The computed sweeps with their names.
fn sweeps(res: &CascadeResult) -> Vec<(&'static str, &Sweep)> {
    [("up", &res.up), ("down", &res.down)]
        .into_iter()
        .filter_map(|(d, s)| s.as_ref().map(|s| (d, s)))
        .collect()
}

/// The arrays of a cascade.
pub fn arrays(res: &CascadeResult) -> Arrays {
    let nb = res.orders.len();
    let sw = sweeps(res);
    // A sweep's rows in ascending speed order (a run-down is computed descending).
    let order = |s: &Sweep| {
        let mut idx: Vec<usize> = (0..s.omegas.len()).collect();
        idx.sort_by(|&a, &b| s.omegas[a].total_cmp(&s.omegas[b]));
        idx
    };
    let rows = |s: &Sweep, v: &[f64]| -> Vec<f64> {
        order(s)
            .into_iter()
            .flat_map(|i| v[i * nb..(i + 1) * nb].iter().copied())
            .collect()
    };
    Arrays {
        sweeps: sw.iter().map(|(d, _)| *d).collect(),
        rotor: sw.iter().flat_map(|(_, s)| rows(s, &s.rotor)).collect(),
        stator: sw.iter().flat_map(|(_, s)| rows(s, &s.stator)).collect(),
        regime: sw
            .iter()
            .flat_map(|(_, s)| order(s).into_iter().map(|i| s.regime[i]))
            .collect(),
    }
}

/// Where each regime was found, per sweep: "run-up: partial_rub at 131.0..140.2 rad/s"
/// (cascade.json's `regimes`).
pub fn regime_summary(res: &CascadeResult) -> String {
    let mut parts = Vec::new();
    for (name, s) in [("run-up", &res.up), ("run-down", &res.down)] {
        let Some(s) = s else { continue };
        // Per regime, its count and the stretches of consecutive speeds it holds, so that
        // a regime interrupted by another is not read as one range.
        let mut by: std::collections::BTreeMap<i32, (usize, Vec<(f64, f64)>)> = Default::default();
        let mut prev = None;
        for (w, r) in s.omegas.iter().zip(&s.regime) {
            let e = by.entry(*r).or_default();
            e.0 += 1;
            match e.1.last_mut() {
                Some(run) if prev == Some(*r) => *run = (run.0.min(*w), run.1.max(*w)),
                _ => e.1.push((*w, *w)),
            }
            prev = Some(*r);
        }
        let text: Vec<String> = by
            .iter_mut()
            .map(|(r, (count, runs))| {
                runs.sort_by(|a, b| a.0.total_cmp(&b.0));
                let spans: Vec<String> = runs
                    .iter()
                    .map(|(lo, hi)| format!("{lo:.2}..{hi:.2}"))
                    .collect();
                format!(
                    "{} at {count} speed(s) in {} rad/s",
                    RubRegime::from_code(*r).map_or("unknown", |r| r.label()),
                    spans.join(" and ")
                )
            })
            .collect();
        parts.push(format!("{name}: {}", text.join(", ")));
    }
    parts.join("; ")
}

/// A natural frequency of the linearised system, as cascade.json lists it.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct NaturalFrequency {
    /// What vibrates (rotor, stator, a coupled contact mode).
    pub name: String,
    /// [rad/s].
    pub rad_s: f64,
    /// [Hz].
    pub hz: f64,
}

/// The cascade as `cascade.json` holds it (the command line adds the list of files and
/// the version): the speeds, the sweeps, the settings, the natural frequencies drawn on
/// the pictures and the regimes met. The Python package returns the same dictionary.
#[derive(Clone, Debug, Serialize)]
pub struct Summary<'a> {
    /// The speeds.
    pub omega: Span,
    /// The sweeps computed, in the arrays' block order.
    pub sweeps: Vec<&'static str>,
    /// Transient at the first speed.
    pub transient_first: u32,
    /// Transient at every later speed.
    pub transient: u32,
    /// Periods of each spectrum.
    pub periods: u32,
    /// Largest order kept.
    pub max_order: f64,
    /// The natural frequencies.
    pub natural_frequencies_rad_s: Vec<NaturalFrequency>,
    /// [`regime_summary`].
    pub regimes: String,
    /// Model parameters.
    pub params: &'a Params,
}

/// The summary `cascade.json` holds.
pub fn summary<'a>(spec: &'a CascadeSpec, res: &CascadeResult) -> Summary<'a> {
    let tau = std::f64::consts::TAU;
    Summary {
        omega: Span::of(&spec.omegas),
        sweeps: sweeps(res).iter().map(|(d, _)| *d).collect(),
        transient_first: spec.transient_first,
        transient: spec.transient,
        periods: spec.periods,
        max_order: spec.max_order,
        natural_frequencies_rad_s: crate::rub::natural_frequencies(&spec.params)
            .into_iter()
            .map(|(name, w)| NaturalFrequency {
                name,
                rad_s: w,
                hz: w / tau,
            })
            .collect(),
        regimes: regime_summary(res),
        params: &spec.params,
    }
}

/// Computes a cascade in memory; `ctl.progress` counts speeds.
pub fn cascade(spec: &CascadeSpec, ctl: Control) -> Result<CascadeResult> {
    cascade_with(spec, &MemoryStore::new(), ctl)
}

/// Runs a cascade under `host` (its units committed to the host's store, its progress,
/// in speeds, on the host's display as stage `cascade`): the front ends' entry point.
pub fn run(spec: &CascadeSpec, host: &impl crate::run::Host) -> Result<CascadeResult> {
    let speeds = spec.omegas.len() as u64 * (spec.up as u64 + spec.down as u64);
    host.progress(crate::run::Stage::new("cascade", speeds, 1), |ctl| {
        cascade_with(spec, host.store(), ctl)
    })
}

/// Computes a cascade unit by unit into `store`, resuming from the units it holds;
/// `ctl.progress(done, total)` counts speeds; `ctl.cancel` is checked between speeds.
pub fn cascade_with(
    spec: &CascadeSpec,
    store: &dyn UnitStore,
    ctl: Control,
) -> Result<CascadeResult> {
    let (cancel, progress) = (ctl.cancel, ctl.progress);
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
            let unit = sweep_unit(spec, &omegas[range.clone()], u == 0, &mut state, nb, tick)?;
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

/// The unit of the sweep's speeds `omegas` from `state` (the unit's first speed the
/// sweep's first when `first_unit`): each speed's full spectra of the rotor's and
/// stator's orbits (`nb` orders), its rub regime, and `state` left at its final state
/// for the next (not finite once a speed diverged).
fn sweep_unit(
    spec: &CascadeSpec,
    omegas: &[f64],
    first_unit: bool,
    state: &mut State,
    nb: usize,
    tick: &(dyn Fn() + Sync),
) -> Result<Unit> {
    let kmax = (nb / 2) as i64;
    let (mut rotor, mut stator, mut regime) = (Vec::new(), Vec::new(), Vec::new());
    for (j, &w) in omegas.iter().enumerate() {
        let first = first_unit && j == 0;
        let r = if state.iter().all(|v| v.is_finite()) {
            Some(simulate(&SimulateSpec {
                params: spec.params.clone(),
                omega: w,
                x0: *state,
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
                *state = r.final_state;
            }
            None => {
                rotor.extend(std::iter::repeat_n(f64::NAN, nb));
                stator.extend(std::iter::repeat_n(f64::NAN, nb));
                regime.push(crate::rub::RubRegime::Diverged.code());
                *state = [f64::NAN; STATE_DIM];
            }
        }
        tick();
    }
    Ok(Unit::new("")
        .with("rotor", Array::F64(rotor))
        .with("stator", Array::F64(stator))
        .with("regime", Array::I32(regime))
        .with("state", Array::F64(state.to_vec())))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_regime_interrupted_by_another_is_summarised_as_its_separate_stretches() {
        let (free, partial, annular) = (
            RubRegime::NoContact.code(),
            RubRegime::PartialRub.code(),
            RubRegime::FullAnnularRub.code(),
        );
        let sweep = |omegas: Vec<f64>, regime: Vec<i32>| Sweep {
            rotor: vec![0.0; omegas.len()],
            stator: vec![0.0; omegas.len()],
            omegas,
            regime,
        };
        let res = CascadeResult {
            orders: vec![1.0],
            up: Some(sweep(
                vec![100.0, 110.0, 120.0, 130.0, 140.0, 150.0],
                vec![free, partial, annular, partial, partial, free],
            )),
            down: Some(sweep(vec![150.0, 140.0, 130.0], vec![free, free, partial])),
        };
        assert_eq!(
            regime_summary(&res),
            "run-up: no_contact at 2 speed(s) in 100.00..100.00 and 150.00..150.00 rad/s, \
             partial_rub at 3 speed(s) in 110.00..110.00 and 130.00..140.00 rad/s, \
             full_annular_rub at 1 speed(s) in 120.00..120.00 rad/s; \
             run-down: no_contact at 2 speed(s) in 140.00..150.00 rad/s, \
             partial_rub at 1 speed(s) in 130.00..130.00 rad/s"
        );
    }
}
