//! One trajectory from a start state: transient, recorded Poincare points, a dense time
//! series of the last periods, counters and the classification. The work behind
//! `jeffcott simulate`; f64 on the CPU.

use crate::classify::{Class, Classification, ClassifyConfig, classify};
use crate::rub::{RubFigures, normal_force, rub_figures};
use crate::spectrum::{FullSpectrum, full_spectrum, orbit};
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
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
#[serde(rename_all = "snake_case")]
pub enum Integrator {
    /// The ensemble lane stepper (MODEL.md 4.2), the default.
    Lane,
    /// The article's variable-step scheme (MODEL.md 4.1), a cross-check.
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
    /// Lane stepper settings.
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
                "timeseries_periods",
                self.timeseries_periods,
                format!("must be in 1..=periods ({})", self.periods),
            ));
        }
        let a = &self.article;
        if !(8..=10_000_000).contains(&a.steps_per_period) {
            return Err(Error::invalid(
                "article_steps",
                a.steps_per_period,
                "must be in 8..=10000000",
            ));
        }
        if !(a.alpha.is_finite() && a.alpha > 0.0 && a.alpha <= 4.0) {
            return Err(Error::invalid(
                "article_alpha",
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
    spec.validate()?;
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
    let (final_state, status, counters) = match spec.integrator {
        Integrator::Lane => {
            let lc = LaneConsts::<f64>::new(p, spec.omega, &spec.stepper);
            let mut lane = Lane::<f64>::new(&spec.x0, p.delta);
            let n = lc.n;
            'periods: for q in 0..total {
                for k in 0..n {
                    if k == 0 && q == ts_from {
                        record(q, 0, n, &lane.x, &mut timeseries);
                    }
                    macro_step(&lc, &mut lane);
                    if lane.status.is_frozen() {
                        break 'periods;
                    }
                    record(q, k + 1, n, &lane.x, &mut timeseries);
                }
                if q >= spec.transient {
                    poincare.push(lane.x);
                }
            }
            (lane.x, lane.status, RunCounters::Lane(lane.counters))
        }
        Integrator::Article => {
            let mut st = ArticleStepper::new(p, spec.omega, spec.article, spec.x0);
            let n = spec.article.steps_per_period;
            let mut status = Status::Ok;
            'periods: for q in 0..total {
                for k in 0..n {
                    if k == 0 && q == ts_from {
                        record(q, 0, n, &st.x, &mut timeseries);
                    }
                    let before = st.x;
                    st.advance_grid_step();
                    if st.x.iter().any(|v| !v.is_finite()) {
                        st.x = before;
                        status = Status::NonFinite;
                        break 'periods;
                    }
                    let reach = [0, 2, 4, 6]
                        .iter()
                        .map(|&i| st.x[i].abs())
                        .fold(0.0, f64::max);
                    if reach > spec.stepper.divergence_bound {
                        st.x = before;
                        status = Status::Diverged;
                        break 'periods;
                    }
                    record(q, k + 1, n, &st.x, &mut timeseries);
                }
                if q >= spec.transient {
                    poincare.push(st.x);
                }
            }
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

/// The rub outputs of a trajectory.
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
fn lines_json(s: &FullSpectrum) -> Vec<serde_json::Value> {
    strongest_lines(s, 8)
        .iter()
        .map(|(ord, a)| serde_json::json!({"order": ord, "name": order_name(*ord), "amplitude_m": a}))
        .collect()
}

fn finite_or_null(v: f64) -> serde_json::Value {
    if v.is_finite() {
        serde_json::json!(v)
    } else {
        serde_json::Value::Null
    }
}

fn named_state(x: &State) -> serde_json::Map<String, serde_json::Value> {
    jeffcott_core::model::COORD_NAMES
        .iter()
        .zip(x.iter())
        .map(|(n, v)| (n.to_string(), serde_json::json!(v)))
        .collect()
}

/// Why a run has no class in the usual sense (`unclassified`, `diverged`); null
/// otherwise.
fn classification_reason(spec: &SimulateSpec, res: &SimulateResult) -> serde_json::Value {
    use crate::classify::MIN_POINTS;
    match res.classification.class {
        Class::Unclassified => serde_json::json!(format!(
            "{} Poincare point(s) recorded; at least {MIN_POINTS} are needed to classify \
             (2 n to see period n): record more --periods",
            res.poincare.len()
        )),
        Class::Diverged => serde_json::json!(format!(
            "the run ended with status {:?} after {} of {} recorded periods",
            res.status,
            res.poincare.len(),
            spec.periods
        )),
        _ => serde_json::Value::Null,
    }
}

/// The summary of a simulation, as `summary.json` holds it (the command line adds the
/// list of files and the version): class, period, status, classification, contact
/// counters, rub figures and strongest full-spectrum lines, start and final state, wall
/// time, settings and parameters. The Python package returns the same dictionary.
pub fn summary(
    spec: &SimulateSpec,
    res: &SimulateResult,
    rub: Option<&RubOutputs>,
) -> serde_json::Value {
    let c = &res.classification;
    let steps = match spec.integrator {
        Integrator::Lane => spec.stepper.steps_per_period,
        Integrator::Article => spec.article.steps_per_period,
    };
    serde_json::json!({
        "omega": spec.omega,
        "forcing_period_s": std::f64::consts::TAU / spec.omega,
        "transient": spec.transient,
        "periods": spec.periods,
        "recorded_poincare_points": res.poincare.len(),
        "steps_per_period": steps,
        "integrator": spec.integrator,
        "class": c.class.label(),
        "period": c.class.period(),
        "status": res.status,
        "classification": {
            "size_m": finite_or_null(c.size),
            "repeat_error_m": finite_or_null(c.repeat_error),
            "tolerance_m": finite_or_null(c.tol),
            "reason": classification_reason(spec, res),
            "n_max": spec.classify.n_max,
            "rel_tol": spec.classify.rel_tol,
            "abs_tol": spec.classify.abs_tol,
        },
        "contact": {
            "fraction_of_recorded_grid_points": res.contact_fraction,
            "counters": res.counters,
        },
        "rub": match rub {
            Some(o) => serde_json::json!({
                "periods": o.periods,
                "figures": o.figures,
                "regime": o.figures.regime.label(),
                "rotor_lines": lines_json(&o.rotor),
                "stator_lines": lines_json(&o.stator),
            }),
            None => serde_json::json!({"regime": "diverged"}),
        },
        "initial_state": named_state(&spec.x0),
        "final_state": named_state(&res.final_state),
        "wall_time_s": res.elapsed.as_secs_f64(),
        "stepper": spec.stepper,
        "article": spec.article,
        "params": spec.params,
    })
}

/// The Poincare points of a run as `poincare.npy` holds them: one row per requested
/// period, as in `ensemble`; a run that froze (diverged, non-finite) stopped recording,
/// and the periods it never reached are NaN rows. Flat, `[periods, 8]` row-major.
pub fn poincare_rows(spec: &SimulateSpec, res: &SimulateResult) -> Vec<f64> {
    let mut flat: Vec<f64> = res.poincare.iter().flatten().copied().collect();
    flat.resize(spec.periods as usize * STATE_DIM, f64::NAN);
    flat
}
