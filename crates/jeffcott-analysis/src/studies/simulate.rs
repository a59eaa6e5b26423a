//! One trajectory from a start state: transient, recorded Poincare points, a dense time
//! series of the last periods, counters and the classification. The work behind
//! `jeffcott simulate`; f64 on the CPU.

use crate::classify::{Class, Classification, ClassifyConfig, classify};
use crate::record::NamedState;
use crate::rub::{RubFigures, normal_force, rub_figures};
use crate::spectrum::{FullSpectrum, full_spectrum, orbit};
use jeffcott_core::control::Cancel;
use jeffcott_core::error::Result;
use jeffcott_core::integrate::article::{ArticleConfig, ArticleCounters, ArticleStepper};
use jeffcott_core::integrate::lane::{
    Counters, Lane, LaneConsts, Status, StepperConfig, macro_step,
};
use jeffcott_core::model::{
    Params, STATE_DIM, State, X_R, X_S, Y_R, Y_S, penetration, validate_omega,
};
use serde::Serialize;
use std::time::{Duration, Instant};

/// Which integrator advances the trajectory.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Integrator {
    /// The ensemble lane stepper (docs/numerics.md), the default.
    Lane,
    /// The article's variable-step scheme (docs/numerics.md, the article's scheme), a cross-check.
    Article,
}

/// What to simulate.
#[derive(Clone, Debug, Serialize)]
pub struct SimulateSpec {
    /// Model parameters.
    pub params: Params,
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// Start state at t = 0.
    pub x0: State,
    /// Forcing periods integrated and discarded.
    pub transient: u32,
    /// Forcing periods recorded (one Poincare point each).
    pub periods: u32,
    /// How many of the last recorded periods go into the time series.
    pub timeseries_periods: u32,
    /// The integrator.
    pub integrator: Integrator,
    /// Lane stepper settings (recorded without the options of many-lane studies).
    #[serde(serialize_with = "StepperConfig::serialize_flow")]
    pub stepper: StepperConfig,
    /// Article scheme settings.
    pub article: ArticleConfig,
    /// Classifier tolerances.
    pub classify: ClassifyConfig,
}

impl SimulateSpec {
    /// Checks every input; errors name the field and the allowed range.
    pub fn validate(&self) -> Result<()> {
        use jeffcott_core::Error;
        self.params.validate()?;
        validate_omega(self.omega)?;
        self.stepper.validate()?;
        for (i, v) in self.x0.iter().enumerate() {
            if !v.is_finite() {
                return Err(Error::invalid(
                    jeffcott_core::model::COORD_NAMES[i],
                    v,
                    "initial coordinate must be finite",
                ));
            }
        }
        jeffcott_core::limits::check_periods("periods", self.periods, 1)?;
        jeffcott_core::limits::check_periods("transient", self.transient, 0)?;
        if self.timeseries_periods == 0 || self.timeseries_periods > self.periods {
            return Err(Error::invalid(
                "timeseries-periods",
                self.timeseries_periods,
                format!("must be in 1..=periods ({})", self.periods),
            ));
        }
        let a = &self.article;
        if !(8..=10_000_000).contains(&a.steps_per_period) {
            return Err(Error::invalid(
                "article-steps",
                a.steps_per_period,
                "must be in 8..=10000000",
            ));
        }
        if !(a.alpha.is_finite() && a.alpha > 0.0 && a.alpha <= 4.0) {
            return Err(Error::invalid(
                "article-alpha",
                a.alpha,
                "must be in (0, 4]",
            ));
        }
        self.classify.validate()?;
        // Start positions beyond the divergence bound would only report "diverged".
        jeffcott_core::inputs::check_start_within_bound(
            "init",
            &self.x0,
            self.stepper.divergence_bound,
        )?;
        Ok(())
    }
}

impl SimulateSpec {
    /// A stretch of `periods` forcing periods from `x0` (a state at t = kT), no
    /// transient, every period in the time series: what the rub figures and full
    /// spectra are taken over.
    pub fn stretch(
        params: &Params,
        omega: f64,
        x0: &State,
        periods: u32,
        stepper: &StepperConfig,
    ) -> SimulateSpec {
        SimulateSpec {
            params: params.clone(),
            omega,
            x0: *x0,
            transient: 0,
            periods,
            timeseries_periods: periods,
            integrator: Integrator::Lane,
            stepper: *stepper,
            article: ArticleConfig::DEFAULT,
            classify: ClassifyConfig::DEFAULT,
        }
    }
}

impl SimulateSpec {
    /// Bytes the run holds at its peak, an upper estimate: the Poincare points and the
    /// time series (one row per grid step of the last `timeseries_periods` periods),
    /// each twice (flattened for writing).
    pub fn memory_estimate(&self) -> u64 {
        let n = match self.integrator {
            Integrator::Lane => self.stepper.steps_per_period,
            Integrator::Article => self.article.steps_per_period,
        } as u64;
        let point = (STATE_DIM * 8) as u64;
        let row = ((STATE_DIM + 1) * 8) as u64;
        let poincare = 2 * jeffcott_core::limits::product(&[self.periods as u64, point]);
        let series = 2 * jeffcott_core::limits::product(&[self.timeseries_periods as u64, n, row]);
        poincare.saturating_add(series)
    }

    /// Checks the stretch of `spectrum_periods` periods continued from the final state
    /// that the rub figures and full spectrum are taken over ([`rub_outputs`]):
    /// `spectrum-periods` in 1..=10000 and its time series (each macro step of every
    /// period) within memory. The one check of the command line and Python.
    pub fn check_spectrum_periods(&self, spectrum_periods: u32) -> Result<()> {
        if !(1..=10_000).contains(&spectrum_periods) {
            return Err(jeffcott_core::error::Error::invalid(
                "spectrum-periods",
                spectrum_periods,
                "must be in 1..=10000",
            ));
        }
        let stretch = SimulateSpec::stretch(
            &self.params,
            self.omega,
            &self.x0,
            spectrum_periods,
            &self.stepper,
        );
        jeffcott_core::limits::check_memory(
            "spectrum-periods",
            spectrum_periods,
            stretch.memory_estimate(),
            &format!(
                "{spectrum_periods} periods of time series x {} steps",
                self.stepper.steps_per_period
            ),
            "ask for fewer spectrum periods or steps per period",
        )
    }

    /// Refuses, before anything is allocated, a run whose records
    /// ([`SimulateSpec::memory_estimate`]) would not fit in memory; names `periods`. The
    /// one check of the command line and Python.
    pub fn check_size(&self) -> Result<()> {
        jeffcott_core::limits::check_memory(
            "periods",
            self.periods,
            self.memory_estimate(),
            &format!(
                "{} recorded periods, {} of them in the time series",
                self.periods, self.timeseries_periods
            ),
            "ask for fewer periods or timeseries periods",
        )
    }
}

/// Counters of whichever integrator ran.
#[derive(Clone, Copy, Debug, Serialize)]
#[serde(untagged)]
pub enum RunCounters {
    /// Lane stepper counters.
    Lane(Counters),
    /// Article scheme counters.
    Article(ArticleCounters),
}

/// Everything a simulation produced.
#[derive(Clone, Debug)]
pub struct SimulateResult {
    /// Poincare points of the recorded periods, at t = (transient + i + 1) T.
    pub poincare: Vec<State>,
    /// Rows (t, state) on the integrator's grid over the last `timeseries_periods` periods.
    pub timeseries: Vec<[f64; STATE_DIM + 1]>,
    /// Final state.
    pub final_state: State,
    /// Lane outcome.
    pub status: Status,
    /// Counters over the whole run (transient included).
    pub counters: RunCounters,
    /// Fraction of recorded grid points in contact.
    pub contact_fraction: f64,
    /// Attractor class of the recorded Poincare points.
    pub classification: Classification,
    /// Wall time of the integration.
    pub elapsed: Duration,
}

/// Runs a simulation. Validates the spec first.
pub fn simulate(spec: &SimulateSpec) -> Result<SimulateResult> {
    simulate_with(spec, &Cancel::new())
}

/// [`simulate`], stopped within a forcing period once `cancel` is set
/// ([`Error::Interrupted`]; a Python caller's Ctrl-C). The result does not depend on
/// `cancel` otherwise.
pub fn simulate_with(spec: &SimulateSpec, cancel: &Cancel) -> Result<SimulateResult> {
    spec.validate()?;
    let stopped = || jeffcott_core::error::Error::Interrupted {
        committed: 0,
        total: 1,
    };
    let start = Instant::now();
    let p = &spec.params;
    let period = std::f64::consts::TAU / spec.omega;
    let total = spec.transient + spec.periods;
    let ts_from = total - spec.timeseries_periods;
    let mut poincare = Vec::with_capacity(spec.periods as usize);
    let mut timeseries = Vec::new();
    let mut in_contact = 0u64;
    let mut recorded = 0u64;
    let mut record = |q: u32, k: u32, n: u32, x: &State, ts: &mut Vec<[f64; STATE_DIM + 1]>| {
        if q >= ts_from {
            let mut row = [0.0; STATE_DIM + 1];
            row[0] = (q as f64 + k as f64 / n as f64) * period;
            row[1..].copy_from_slice(x);
            ts.push(row);
        }
        if q >= spec.transient {
            recorded += 1;
            in_contact += (penetration(p.delta, x) > 0.0) as u64;
        }
    };
    // The periods of either integrator: `n` steps a period from `x0`, `step` advancing
    // one step (`None` once the lane froze: the run stops there, that step unrecorded).
    let mut integrate =
        |n: u32, x0: State, step: &mut dyn FnMut() -> Option<State>| -> Result<()> {
            let mut x = x0;
            'periods: for q in 0..total {
                if cancel.is_set() {
                    return Err(stopped());
                }
                for k in 0..n {
                    if k == 0 && q == ts_from {
                        record(q, 0, n, &x, &mut timeseries);
                    }
                    match step() {
                        Some(next) => x = next,
                        None => break 'periods,
                    }
                    record(q, k + 1, n, &x, &mut timeseries);
                }
                if q >= spec.transient {
                    poincare.push(x);
                }
            }
            Ok(())
        };
    let (final_state, status, counters) = match spec.integrator {
        Integrator::Lane => {
            let lc = LaneConsts::<f64>::new(p, spec.omega, &spec.stepper);
            let mut lane = Lane::<f64>::new(&spec.x0, p.delta);
            integrate(lc.n, lane.x, &mut || {
                macro_step(&lc, &mut lane);
                (!lane.status.is_frozen()).then_some(lane.x)
            })?;
            (lane.x, lane.status, RunCounters::Lane(lane.counters))
        }
        Integrator::Article => {
            let mut st = ArticleStepper::new(p, spec.omega, spec.article, spec.x0);
            let mut status = Status::Ok;
            let bound = spec.stepper.divergence_bound;
            integrate(spec.article.steps_per_period, st.x, &mut || {
                article_step(&mut st, &mut status, bound)
            })?;
            if status == Status::Ok && st.counters.capped > 0 {
                status = Status::RefinementCap;
            }
            (st.x, status, RunCounters::Article(st.counters))
        }
    };
    let elapsed = start.elapsed();
    let classification = classify(&poincare, spec.omega, status.is_frozen(), &spec.classify);
    Ok(SimulateResult {
        poincare,
        timeseries,
        final_state,
        status,
        counters,
        contact_fraction: if recorded > 0 {
            in_contact as f64 / recorded as f64
        } else {
            0.0
        },
        classification,
        elapsed,
    })
}

/// One grid step of the article's stepper: the new state, or `None` (the state kept,
/// `status` set) where it is not finite or a position lies beyond `bound`.
fn article_step(st: &mut ArticleStepper, status: &mut Status, bound: f64) -> Option<State> {
    let before = st.x;
    st.advance_grid_step();
    if st.x.iter().any(|v| !v.is_finite()) {
        st.x = before;
        *status = Status::NonFinite;
        return None;
    }
    let reach = [0, 2, 4, 6]
        .iter()
        .map(|&i| st.x[i].abs())
        .fold(0.0, f64::max);
    if reach > bound {
        st.x = before;
        *status = Status::Diverged;
        return None;
    }
    Some(st.x)
}

/// The rub outputs of a trajectory.
#[derive(Clone, Debug)]
pub struct RubOutputs {
    /// Forcing periods of the stretch.
    pub periods: u32,
    /// Rub figures and regime.
    pub figures: RubFigures,
    /// Full spectrum of the rotor's x + i y.
    pub rotor: FullSpectrum,
    /// Full spectrum of the stator's x + i y.
    pub stator: FullSpectrum,
    /// (t [s], dx [m], dy [m], g [m], F_n [N]) at each grid point of the stretch.
    pub contact: Vec<[f64; 5]>,
}

impl RubOutputs {
    /// The full spectra as `full_spectrum.npy` holds them, one row per bin: order
    /// (frequency / W, < 0 backward whirl), frequency [Hz], rotor and stator amplitude [m].
    pub fn spectrum_table(&self) -> Vec<[f64; 4]> {
        (0..self.rotor.order.len())
            .map(|k| {
                [
                    self.rotor.order[k],
                    self.rotor.hz[k],
                    self.rotor.amplitude[k],
                    self.stator.amplitude[k],
                ]
            })
            .collect()
    }
}

/// A simulation and the stretch continued from its final state that the rub figures,
/// full spectra and contact histories are taken over: what the command line's
/// `simulate`, Python's `simulate()` and `reproduce`'s spectrum section run.
#[derive(Clone, Debug)]
pub struct SimulateStudy {
    /// The trajectory.
    pub spec: SimulateSpec,
    /// Forcing periods of the rub stretch.
    pub spectrum_periods: u32,
}

impl SimulateStudy {
    /// Checks every input, the sizes of the trajectory and of the stretch included,
    /// before anything is allocated.
    pub fn validate(&self) -> Result<()> {
        self.spec.validate()?;
        self.spec.check_size()?;
        self.spec.check_spectrum_periods(self.spectrum_periods)
    }
}

/// What a simulation study computed.
#[derive(Clone, Debug)]
pub struct SimulateOutcome {
    /// The trajectory.
    pub result: SimulateResult,
    /// The rub outputs of the stretch; `None` when the run or the stretch froze.
    pub rub: Option<RubOutputs>,
}

/// Runs a simulation study: the trajectory (stopped within a forcing period once
/// `cancel` is set), then, unless it froze, the rub stretch from its final state.
pub fn run_study(study: &SimulateStudy, cancel: &Cancel) -> Result<SimulateOutcome> {
    study.validate()?;
    let spec = &study.spec;
    let result = simulate_with(spec, cancel)?;
    let rub = if result.status.is_frozen() {
        None
    } else {
        rub_outputs(
            &spec.params,
            spec.omega,
            &result.final_state,
            study.spectrum_periods,
            &spec.stepper,
        )?
    };
    Ok(SimulateOutcome { result, rub })
}

/// Integrates `periods` forcing periods from `x0` (a state at t = kT) and derives the
/// rub outputs; `None` when the stretch froze (diverged or non-finite).
pub fn rub_outputs(
    p: &Params,
    omega: f64,
    x0: &State,
    periods: u32,
    stepper: &StepperConfig,
) -> Result<Option<RubOutputs>> {
    let r = simulate(&SimulateSpec::stretch(p, omega, x0, periods, stepper))?;
    if r.status.is_frozen() || x0.iter().any(|v| !v.is_finite()) {
        return Ok(None);
    }
    let rows = &r.timeseries;
    let contact = rows
        .iter()
        .map(|row| {
            let mut x = [0.0; STATE_DIM];
            x.copy_from_slice(&row[1..]);
            [
                row[0],
                x[X_R] - x[X_S],
                x[Y_R] - x[Y_S],
                penetration(p.delta, &x),
                normal_force(p, &x),
            ]
        })
        .collect();
    Ok(Some(RubOutputs {
        periods,
        figures: rub_figures(p, omega, rows, periods),
        rotor: full_spectrum(&orbit(rows, false), periods, omega),
        stator: full_spectrum(&orbit(rows, true), periods, omega),
        contact,
    }))
}

/// The strongest lines of a spectrum: (order, amplitude [m]) of the `n` largest local
/// maxima above 0.1 % of the largest, strongest first.
pub fn strongest_lines(s: &FullSpectrum, n: usize) -> Vec<(f64, f64)> {
    let a = &s.amplitude;
    let top = a.iter().copied().fold(0.0, f64::max);
    let mut peaks: Vec<(f64, f64)> = (1..a.len().saturating_sub(1))
        .filter(|&k| a[k] >= a[k - 1] && a[k] > a[k + 1] && a[k] > 1e-3 * top)
        .map(|k| (s.order[k], a[k]))
        .collect();
    peaks.sort_by(|x, y| y.1.total_cmp(&x.1));
    peaks.truncate(n);
    peaks
}

/// "+1X", "-1/2X", "+2/3X", "+0.37X" for an order.
pub fn order_name(o: f64) -> String {
    let sign = if o < 0.0 { "-" } else { "+" };
    let a = o.abs();
    if a < 1e-9 {
        return "0X (static)".into();
    }
    for d in 1..=6u32 {
        let n = (a * d as f64).round();
        if (a * d as f64 - n).abs() < 1e-9 && n > 0.0 {
            return if d == 1 {
                format!("{sign}{n}X")
            } else {
                format!("{sign}{n}/{d}X")
            };
        }
    }
    format!("{sign}{a:.3}X")
}

/// One line of a full spectrum as the JSON files list it.
#[derive(Clone, Debug, Serialize)]
pub struct Line {
    /// Frequency / W (< 0: backward whirl).
    pub order: f64,
    /// The order as a name (`+1X`, `-1/2X`, ...).
    pub name: String,
    /// Amplitude [m].
    pub amplitude_m: f64,
}

/// The eight strongest lines of a full spectrum.
pub fn lines(s: &FullSpectrum) -> Vec<Line> {
    strongest_lines(s, 8)
        .into_iter()
        .map(|(order, amplitude_m)| Line {
            order,
            name: order_name(order),
            amplitude_m,
        })
        .collect()
}

/// Why a run has no class in the usual sense (`unclassified`, `diverged`); none
/// otherwise.
fn classification_reason(spec: &SimulateSpec, res: &SimulateResult) -> Option<String> {
    use crate::classify::MIN_POINTS;
    match res.classification.class {
        Class::Unclassified => Some(format!(
            "{} Poincare point(s) recorded; at least {MIN_POINTS} are needed to classify \
             (2 n to see period n): record more --periods",
            res.poincare.len()
        )),
        Class::Diverged => Some(format!(
            "the run ended with status {:?} after {} of {} recorded periods",
            res.status,
            res.poincare.len(),
            spec.periods
        )),
        _ => None,
    }
}

/// The summary of a simulation, as `summary.json` holds it (the command line adds the
/// list of files and the version). The Python package returns the same dictionary.
#[derive(Clone, Debug, Serialize)]
pub struct Summary<'a> {
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// 2 pi / W [s].
    pub forcing_period_s: f64,
    /// Forcing periods discarded.
    pub transient: u32,
    /// Forcing periods recorded.
    pub periods: u32,
    /// Poincare points recorded (fewer than `periods` when the run froze).
    pub recorded_poincare_points: usize,
    /// Macro steps per forcing period of the integrator used.
    pub steps_per_period: u32,
    /// The integrator used.
    pub integrator: Integrator,
    /// Class label (`period-2`, `aperiodic`, ...).
    pub class: String,
    /// The period, for a periodic class.
    pub period: Option<usize>,
    /// Lane status at the end.
    pub status: Status,
    /// How the class was decided.
    pub classification: ClassificationRecord,
    /// How much of the recorded stretch is in contact, and the lane's counters.
    pub contact: ContactRecord,
    /// Rub figures and strongest spectral lines (regime `diverged` only, for a frozen run).
    pub rub: RubRecord<'a>,
    /// Start state by coordinate.
    pub initial_state: NamedState,
    /// Final state by coordinate.
    pub final_state: NamedState,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
    /// Article integrator settings.
    pub article: ArticleConfig,
    /// Model parameters.
    pub params: &'a Params,
}

/// `summary.json`'s `classification`: the classifier's measures (null when not finite),
/// its tolerances, and why there is no class in the usual sense.
#[derive(Clone, Debug, Serialize)]
pub struct ClassificationRecord {
    /// Size of the Poincare set [m].
    pub size_m: f64,
    /// Repeat error at the period found [m].
    pub repeat_error_m: f64,
    /// Tolerance the repeat error was held to [m].
    pub tolerance_m: f64,
    /// Why the run is `unclassified` or `diverged`, otherwise null.
    pub reason: Option<String>,
    /// Largest period looked for.
    pub n_max: usize,
    /// Relative tolerance.
    pub rel_tol: f64,
    /// Absolute tolerance [m].
    pub abs_tol: f64,
}

/// `summary.json`'s `contact`.
#[derive(Clone, Debug, Serialize)]
pub struct ContactRecord {
    /// Fraction of the recorded grid points in contact.
    pub fraction_of_recorded_grid_points: f64,
    /// The lane's counters.
    pub counters: RunCounters,
}

/// `summary.json`'s `rub`: the figures over a stretch continued from the final state, or
/// only the regime `diverged`.
#[derive(Clone, Debug, Serialize)]
#[serde(untagged)]
pub enum RubRecord<'a> {
    /// The rub figures.
    Figures {
        /// Forcing periods of the stretch.
        periods: u32,
        /// The figures.
        figures: &'a RubFigures,
        /// The regime's label.
        regime: &'static str,
        /// The rotor's strongest full-spectrum lines.
        rotor_lines: Vec<Line>,
        /// The stator's strongest full-spectrum lines.
        stator_lines: Vec<Line>,
    },
    /// A frozen run has no figures.
    Diverged {
        /// Always `diverged`.
        regime: &'static str,
    },
}

/// The summary `summary.json` holds.
pub fn summary<'a>(
    spec: &'a SimulateSpec,
    res: &SimulateResult,
    rub: Option<&'a RubOutputs>,
) -> Summary<'a> {
    let c = &res.classification;
    let steps = match spec.integrator {
        Integrator::Lane => spec.stepper.steps_per_period,
        Integrator::Article => spec.article.steps_per_period,
    };
    Summary {
        omega: spec.omega,
        forcing_period_s: std::f64::consts::TAU / spec.omega,
        transient: spec.transient,
        periods: spec.periods,
        recorded_poincare_points: res.poincare.len(),
        steps_per_period: steps,
        integrator: spec.integrator,
        class: c.class.label(),
        period: c.class.period(),
        status: res.status,
        classification: ClassificationRecord {
            size_m: c.size,
            repeat_error_m: c.repeat_error,
            tolerance_m: c.tol,
            reason: classification_reason(spec, res),
            n_max: spec.classify.n_max,
            rel_tol: spec.classify.rel_tol,
            abs_tol: spec.classify.abs_tol,
        },
        contact: ContactRecord {
            fraction_of_recorded_grid_points: res.contact_fraction,
            counters: res.counters,
        },
        rub: match rub {
            Some(o) => RubRecord::Figures {
                periods: o.periods,
                figures: &o.figures,
                regime: o.figures.regime.label(),
                rotor_lines: lines(&o.rotor),
                stator_lines: lines(&o.stator),
            },
            None => RubRecord::Diverged { regime: "diverged" },
        },
        initial_state: NamedState(spec.x0),
        final_state: NamedState(res.final_state),
        stepper: spec.stepper,
        article: spec.article,
        params: &spec.params,
    }
}

/// The Poincare points of a run as `poincare.npy` holds them: one row per requested
/// period, as in `ensemble`; a run that froze (diverged, non-finite) stopped recording,
/// and the periods it never reached are NaN rows. Flat, `[periods, 8]` row-major.
pub fn poincare_rows(spec: &SimulateSpec, res: &SimulateResult) -> Vec<f64> {
    let mut flat: Vec<f64> = res.poincare.iter().flatten().copied().collect();
    flat.resize(spec.periods as usize * STATE_DIM, f64::NAN);
    flat
}

/// A few periods of an attractor, from its first representative point: what its phase
/// portrait draws.
#[derive(Clone, Debug)]
pub struct AttractorTrace {
    /// The attractor's id in its catalogue.
    pub id: u32,
    /// Rows (t, state) on the integrator grid.
    pub timeseries: Vec<[f64; STATE_DIM + 1]>,
    /// The attractor's Poincare points.
    pub poincare: Vec<State>,
}

/// Traces of the `max_traces` attractors with the largest basins (by lanes), in that
/// order: each over its period (12 periods for an aperiodic one), at most 32, on the
/// default lane stepper.
pub fn attractor_traces(
    params: &Params,
    omega: f64,
    attractors: &[crate::catalogue::Attractor],
    max_traces: usize,
) -> Result<Vec<AttractorTrace>> {
    let mut order: Vec<&crate::catalogue::Attractor> = attractors.iter().collect();
    order.sort_by_key(|a| std::cmp::Reverse(a.lanes));
    order
        .into_iter()
        .take(max_traces)
        .map(|a| {
            let periods = a.period.unwrap_or(12).clamp(1, 32) as u32;
            let spec = SimulateSpec {
                params: params.clone(),
                omega,
                x0: a.points[0],
                transient: 0,
                periods,
                timeseries_periods: periods,
                integrator: Integrator::Lane,
                stepper: Default::default(),
                article: Default::default(),
                classify: Default::default(),
            };
            let r = simulate(&spec)?;
            Ok(AttractorTrace {
                id: a.id,
                timeseries: r.timeseries,
                poincare: a.points.clone(),
            })
        })
        .collect()
}
