//! The Lyapunov spectrum study: the full spectrum of one speed (with its running
//! estimates), or of a range of speeds in resumable work units. The numerics are
//! [`jeffcott_core::lyapunov`]'s (QR re-orthonormalisation with saltation matrices at
//! the switches, docs/model.md); this module sets a run up once for every front end (the
//! command line, Python) and runs it on a [`Host`].

use crate::record::{Span, StudySpec};
use crate::run::{Array, Host, Stage, Unit, unit_count, unit_lanes};
use jeffcott_core::ensemble::RangeSpec;
use jeffcott_core::error::{Error, Result};
use jeffcott_core::integrate::lane::{Status, StepperConfig};
use jeffcott_core::lyapunov::{
    Spectrum, SpectrumConfig, StopReason, SweepStart, spectrum_with, sweep_starts,
};
use jeffcott_core::model::{Params, STATE_DIM, State};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The work-unit stage of a range.
pub const STAGE: &str = "lyapunov";

/// The settings of the stopping rule and the transients as a user gives them:
/// `min_time` `None` is the default 20 s, or `max_time` if that is shorter.
#[derive(Clone, Debug)]
pub struct SpectrumOptions {
    /// Forcing periods of the state alone.
    pub transient: u32,
    /// Forcing periods in which the tangent vectors align, not accumulated.
    pub tangent_transient: u32,
    /// Largest accumulation time [s] (`time`).
    pub max_time: f64,
    /// Accumulation time before the stopping rule may stop [s].
    pub min_time: Option<f64>,
    /// Stopping tolerance [1/s].
    pub tol: f64,
    /// Window of the stopping rule [forcing periods].
    pub window: u32,
    /// Saltation matrices at the switches (`false` only to show what they change).
    pub saltation: bool,
    /// The lane stepper.
    pub stepper: StepperConfig,
}

impl SpectrumOptions {
    /// The spectrum's configuration; refuses a `min_time` beyond `max_time` (the
    /// stopping rule may act only within the maximum time) and whatever
    /// [`SpectrumConfig::validate`] refuses.
    pub fn config(&self) -> Result<SpectrumConfig> {
        let time = self.max_time;
        let min_time = self
            .min_time
            .unwrap_or(SpectrumConfig::DEFAULT.min_time.min(time));
        if min_time.is_finite() && time.is_finite() && min_time > time {
            return Err(Error::invalid(
                "min-time",
                min_time,
                format!(
                    "must be in 0..=time ({time} s): the stopping rule may act only within the maximum time"
                ),
            ));
        }
        let cfg = SpectrumConfig {
            transient: self.transient,
            tangent_transient: self.tangent_transient,
            min_time,
            max_time: time,
            window: self.window,
            tol: self.tol,
            saltation: self.saltation,
            stepper: self.stepper,
            ..SpectrumConfig::DEFAULT
        };
        cfg.validate()?;
        Ok(cfg)
    }
}

/// A spectrum study: its speeds, its configuration, where each speed starts, the model.
/// It is its own record (run.json's `spec`).
#[derive(Clone, Debug, Serialize, Deserialize)]
pub struct LyapunovStudy {
    /// The speeds W [rad/s], equally spaced.
    pub omegas: Span,
    /// The spectrum's settings.
    pub config: SpectrumConfig,
    /// Where each speed of a range starts.
    pub start: SweepStart,
    /// The start state.
    pub initial_state: State,
    /// The model's parameters.
    pub params: Params,
}

impl StudySpec for LyapunovStudy {
    /// The spectra run on the CPU only.
    fn set_backend(&mut self, _: jeffcott_core::ensemble::Backend) {}
}

impl LyapunovStudy {
    /// The study of the speeds `omegas` (`field` = `text` as the user gave them, named
    /// in errors) from `x0`; checks everything before anything is allocated or runs: the
    /// model, the start state within the divergence bound, the speeds, and the
    /// accumulated periods against the cap.
    pub fn new(
        (field, text): (&str, &str),
        omegas: RangeSpec,
        x0: State,
        start: SweepStart,
        params: Params,
        config: SpectrumConfig,
    ) -> Result<Self> {
        params.validate()?;
        jeffcott_core::inputs::check_start_within_bound(
            "init",
            &x0,
            config.stepper.divergence_bound,
        )?;
        if omegas.n == 0 {
            return Err(Error::invalid(field, text, "no speeds"));
        }
        // Evenly spaced: the ends bound every speed.
        jeffcott_core::model::validate_omega(omegas.a)?;
        jeffcott_core::model::validate_omega(omegas.b)?;
        // The accumulation is counted in forcing periods like every transient: the same
        // cap.
        config.check_size(field, text, omegas.len(), omegas.a.max(omegas.b))?;
        Ok(LyapunovStudy {
            // The range as given (its last value is `b`, whose speeds are
            // `range_value(a, b, n, i)`), so a merge regenerates the shards' speeds bit
            // for bit.
            omegas: Span {
                first: omegas.a,
                last: omegas.b,
                count: omegas.n as usize,
            },
            config,
            start,
            initial_state: x0,
            params,
        })
    }

    /// The speeds, first to last, as [`RangeSpec::values`] gives them.
    pub fn speeds(&self) -> Vec<f64> {
        let Span { first, last, count } = self.omegas;
        RangeSpec {
            a: first,
            b: last,
            n: count as u64,
        }
        .values()
    }
}

/// What a range keeps of each speed's spectrum (a unit's row): the fields of
/// [`Spectrum`] of the same names.
#[derive(Clone, Debug)]
#[allow(missing_docs)]
pub struct SpeedSpectrum {
    pub omega: f64,
    pub exponents: [f64; STATE_DIM],
    pub errors: [f64; STATE_DIM],
    pub sum: f64,
    pub trace_average: f64,
    pub saltation_log_det_rate: f64,
    pub integration_time: f64,
    pub stop: StopReason,
    pub status: Status,
}

/// What the study computed.
pub enum LyapunovOutcome {
    /// One speed: the whole spectrum, its running estimates included.
    One(Box<Spectrum>),
    /// A range: each speed's spectrum in the order of the speeds, and the wall time [s].
    Range(Vec<SpeedSpectrum>, f64),
}

/// Runs `study` on `host`: one speed directly (stopped by the host's cancel flag), a
/// range in work units ([`STAGE`]) committed to the host's store, so a resumed run keeps
/// the speeds already computed and a shard computes its own units only.
pub fn run(study: &LyapunovStudy, host: &impl Host) -> Result<LyapunovOutcome> {
    let omegas = study.speeds();
    if let [omega] = omegas[..] {
        let s = host.progress(Stage::new("spectrum", 1, 1), |ctl| {
            spectrum_with(
                &study.params,
                omega,
                &study.initial_state,
                &study.config,
                ctl.cancel,
            )
        })?;
        return Ok(LyapunovOutcome::One(Box::new(s)));
    }
    let start = std::time::Instant::now();
    let rows = range_units(study, &omegas, host)?;
    Ok(LyapunovOutcome::Range(rows, start.elapsed().as_secs_f64()))
}

/// The stop reasons by their code in a unit.
const STOPS: [StopReason; 3] = [
    StopReason::Converged,
    StopReason::MaxTime,
    StopReason::LaneFrozen,
];

/// The spectra of a range, unit by unit into the host's store (a unit: consecutive
/// speeds, at most 1/20 of them, computed in parallel). The quasistatic transients that
/// give every speed its start state run first, in sequence, and are cheap beside the
/// spectra; they are recomputed on resume (deterministic).
fn range_units(
    study: &LyapunovStudy,
    omegas: &[f64],
    host: &impl Host,
) -> Result<Vec<SpeedSpectrum>> {
    let store = host.store();
    let params = &study.params;
    let n = omegas.len();
    let per = unit_lanes(n, 1).min(rayon::current_num_threads().max(1) * 4);
    let count = unit_count(n, per);
    let speeds = |u: usize| u * per..((u + 1) * per).min(n);
    let done = store.committed(STAGE, count)?;
    if done.iter().any(|d| !d) {
        let (starts, per_cfg) = sweep_starts(
            params,
            omegas,
            &study.initial_state,
            study.start,
            &study.config,
        )?;
        host.progress(Stage::new(STAGE, n as u64, 1), |ctl| {
            let mut finished = (0..count).filter(|&u| done[u]).map(|u| speeds(u).len());
            let mut computed = finished.by_ref().sum::<usize>() as u64;
            (ctl.progress)(computed, n as u64);
            for u in (0..count).filter(|&u| !done[u]) {
                let spectra: Vec<Spectrum> = speeds(u)
                    .into_par_iter()
                    .map(|i| spectrum_with(params, omegas[i], &starts[i], &per_cfg, ctl.cancel))
                    .collect::<Result<_>>()?;
                store.commit(STAGE, u, &unit_of(u, &spectra))?;
                computed += spectra.len() as u64;
                (ctl.progress)(computed, n as u64);
            }
            Ok(())
        })?;
    }
    let mut rows = Vec::with_capacity(n);
    for u in 0..count {
        let unit = store.load(STAGE, u)?;
        for (j, i) in speeds(u).enumerate() {
            rows.push(row_of(&unit, j, omegas[i])?);
        }
    }
    Ok(rows)
}

/// Unit `u` of spectra: the exponents and their errors (8 per speed), the sum rule's
/// terms, the accumulation time, the stop reason and the lane status per speed.
fn unit_of(u: usize, spectra: &[Spectrum]) -> Unit {
    let f = |g: &dyn Fn(&Spectrum) -> f64| Array::F64(spectra.iter().map(g).collect());
    let code = |s: &Spectrum| STOPS.iter().position(|x| *x == s.stop).unwrap_or(0) as u32;
    Unit::new(crate::run::dir::unit_key(STAGE, u))
        .with(
            "exponents",
            Array::F64(spectra.iter().flat_map(|s| s.exponents).collect()),
        )
        .with(
            "errors",
            Array::F64(spectra.iter().flat_map(|s| s.errors).collect()),
        )
        .with("sum", f(&|s| s.sum))
        .with("trace_average", f(&|s| s.trace_average))
        .with("saltation_log_det_rate", f(&|s| s.saltation_log_det_rate))
        .with("integration_time", f(&|s| s.integration_time))
        .with("stop", Array::U32(spectra.iter().map(code).collect()))
        .with(
            "status",
            Array::U32(spectra.iter().map(|s| s.status.code()).collect()),
        )
}

/// Speed `j` of `unit`, at W = `omega`.
fn row_of(unit: &Unit, j: usize, omega: f64) -> Result<SpeedSpectrum> {
    let eight = |v: &[f64]| -> [f64; STATE_DIM] {
        v.get(j * STATE_DIM..(j + 1) * STATE_DIM)
            .and_then(|s| s.try_into().ok())
            .unwrap_or([f64::NAN; STATE_DIM])
    };
    Ok(SpeedSpectrum {
        omega,
        exponents: eight(unit.f64s("exponents")?),
        errors: eight(unit.f64s("errors")?),
        sum: unit.f64s("sum")?[j],
        trace_average: unit.f64s("trace_average")?[j],
        saltation_log_det_rate: unit.f64s("saltation_log_det_rate")?[j],
        integration_time: unit.f64s("integration_time")?[j],
        stop: STOPS[(unit.u32s("stop")?[j] as usize).min(2)],
        status: Status::from_code(unit.u32s("status")?[j]).unwrap_or(Status::NonFinite),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_spectrum_record_reads_back_as_the_same_study_with_the_same_speeds_to_the_bit() {
        let p = Params::default();
        let cfg = SpectrumOptions {
            transient: 10,
            tangent_transient: 5,
            max_time: 3.0,
            min_time: None,
            tol: 1e-3,
            window: 20,
            saltation: true,
            stepper: StepperConfig::DEFAULT,
        }
        .config()
        .unwrap();
        // An end that a + (b - a) does not give back exactly.
        let range = RangeSpec::parse("omega", "130.1:140.3:7").unwrap();
        let x0 = p.static_equilibrium();
        let study = LyapunovStudy::new(
            ("omega", "130.1:140.3:7"),
            range,
            x0,
            SweepStart::Quasistatic,
            p,
            cfg,
        )
        .unwrap();
        let json = serde_json::to_value(&study).unwrap();
        let back: LyapunovStudy = serde_json::from_value(json.clone()).unwrap();
        assert_eq!(serde_json::to_value(&back).unwrap(), json);
        let (a, b) = (range.values(), back.speeds());
        assert_eq!(a.len(), b.len());
        assert!(a.iter().zip(&b).all(|(x, y)| x.to_bits() == y.to_bits()));
        // The default minimum time follows a maximum under 20 s.
        assert_eq!(back.config.min_time, 3.0);
    }

    #[test]
    fn a_minimum_time_beyond_the_maximum_is_refused_naming_both() {
        let o = SpectrumOptions {
            transient: 10,
            tangent_transient: 5,
            max_time: 1.0,
            min_time: Some(5.0),
            tol: 1e-3,
            window: 20,
            saltation: true,
            stepper: StepperConfig::DEFAULT,
        };
        let e = o.config().unwrap_err().to_string();
        assert!(
            e.contains("`min-time`: 5") && e.contains("0..=time (1 s)"),
            "{e}"
        );
    }
}
