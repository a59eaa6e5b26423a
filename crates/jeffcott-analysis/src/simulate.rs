//! One trajectory from a start state: transient, recorded Poincare points, a dense time
//! series of the last periods, counters and the classification. The work behind
//! `jeffcott simulate`; f64 on the CPU.

use crate::classify::{Classification, ClassifyConfig, classify};
use jeffcott_core::error::Result;
use jeffcott_core::integrate::article::{ArticleConfig, ArticleCounters, ArticleStepper};
use jeffcott_core::integrate::lane::{
    Counters, Lane, LaneConsts, Status, StepperConfig, macro_step,
};
use jeffcott_core::model::{Params, STATE_DIM, State, penetration, validate_omega};
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
        if self.classify.n_max == 0 {
            return Err(Error::invalid("n_max", 0, "must be >= 1"));
        }
        Ok(())
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
