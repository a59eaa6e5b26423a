//! The article's variable-step RK4 (docs/numerics.md, the article's scheme), for single trajectories and as an
//! independent cross-check of the ensemble stepper.
//!
//! A fixed standard step T/N outside contact. A step in which any RK4 stage sees contact
//! (g > 0) is checked by step doubling: E = |X_{dt/2,dt/2} - X_dt| / (2^4 - 1), measured
//! on positions (metres, matching E_max) or on all 8 components; while E > E_max the step
//! shrinks to dt (E_max/E)^alpha. The two half steps are accepted. The reduced step is
//! kept while contact lasts and the standard step returns on the first step without
//! contact. Steps never cross the standard grid, so Poincare times t = kT are hit exactly.
//!
//! Known properties (docs/numerics.md measurements): positions-only error at T/200 does not
//! settle periodic orbits, at T/500 it can mistake the period, at T/1000 it is correct;
//! all-component error is accurate but costs tens of thousands of steps per period. Not
//! the default integrator.

use crate::integrate::rk4::rk4_step;
use crate::model::{Params, STATE_DIM, penetration, rhs};
use serde::{Deserialize, Serialize};

/// Which components the step-doubling error is measured on.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ErrorNorm {
    /// The four positions [m] (max norm).
    Positions,
    /// All eight components, positions in m and velocities in m/s (max norm).
    All,
}

/// Settings of the article's scheme.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ArticleConfig {
    /// Standard steps per forcing period (standard step T/N).
    pub steps_per_period: u32,
    /// Exponent of the step reduction dt (E_max/E)^alpha.
    pub alpha: f64,
    /// Components of the error estimate.
    pub norm: ErrorNorm,
    /// Cap on reductions of one step; reaching it flags the run.
    pub max_tries: u32,
}

impl ArticleConfig {
    /// The defaults, in one place (the command line's option defaults are these).
    pub const DEFAULT: ArticleConfig = ArticleConfig {
        steps_per_period: 1000,
        alpha: 0.2,
        norm: ErrorNorm::Positions,
        max_tries: 40,
    };
}

impl Default for ArticleConfig {
    fn default() -> Self {
        ArticleConfig::DEFAULT
    }
}

/// Counters of an article-scheme run.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize)]
pub struct ArticleCounters {
    /// Accepted steps.
    pub accepted: u64,
    /// Accepted steps that touched contact (step-doubled).
    pub contact_steps: u64,
    /// Rejected trial steps.
    pub rejected: u64,
    /// RK4 steps evaluated in total (trial, halves, rejections).
    pub rk4_evaluations: u64,
    /// Steps that hit `max_tries` and were accepted with E > E_max.
    pub capped: u64,
}

/// A single trajectory advanced by the article's scheme.
pub struct ArticleStepper<'a> {
    p: &'a Params,
    omega: f64,
    cfg: ArticleConfig,
    period: f64,
    /// The state.
    pub x: [f64; STATE_DIM],
    /// Index of the next standard grid point within the period (0..N).
    pub k: u32,
    dt: f64,
    /// Counters.
    pub counters: ArticleCounters,
}

impl<'a> ArticleStepper<'a> {
    /// Starts at `x0` at t = 0.
    pub fn new(p: &'a Params, omega: f64, cfg: ArticleConfig, x0: [f64; STATE_DIM]) -> Self {
        let period = std::f64::consts::TAU / omega;
        ArticleStepper {
            p,
            omega,
            cfg,
            period,
            x: x0,
            k: 0,
            dt: period / cfg.steps_per_period as f64,
            counters: ArticleCounters::default(),
        }
    }

    fn grid_time(&self, k: u32) -> f64 {
        self.period * k as f64 / self.cfg.steps_per_period as f64
    }

    /// RK4 step from local time t; also reports whether any stage saw contact.
    fn step(&mut self, t: f64, x: &[f64; STATE_DIM], h: f64) -> ([f64; STATE_DIM], bool) {
        let (p, omega) = (self.p, self.omega);
        let mut touched = false;
        let mut f = |t: f64, y: &[f64; STATE_DIM]| {
            touched |= penetration(p.delta, y) > 0.0;
            rhs(p, omega, t, y)
        };
        let out = rk4_step(&mut f, t, x, h);
        self.counters.rk4_evaluations += 1;
        touched |= penetration(p.delta, &out) > 0.0;
        (out, touched)
    }

    fn error(&self, a: &[f64; STATE_DIM], b: &[f64; STATE_DIM]) -> f64 {
        let idx: &[usize] = match self.cfg.norm {
            ErrorNorm::Positions => &[0, 2, 4, 6],
            ErrorNorm::All => &[0, 1, 2, 3, 4, 5, 6, 7],
        };
        idx.iter().map(|&i| (a[i] - b[i]).abs()).fold(0.0, f64::max) / 15.0
    }

    /// Advances to the next standard grid point (one standard step of the period grid).
    pub fn advance_grid_step(&mut self) {
        let dt_std = self.period / self.cfg.steps_per_period as f64;
        let t_end = self.grid_time(self.k + 1);
        let mut t = self.grid_time(self.k);
        while t < t_end {
            let remaining = t_end - t;
            // Land exactly on the grid; avoid a sliver step from roundoff.
            let mut h = if self.dt >= remaining * (1.0 - 1e-9) {
                remaining
            } else {
                self.dt
            };
            let mut tries = 0;
            loop {
                let x0 = self.x;
                let (full, touched) = self.step(t, &x0, h);
                if !touched {
                    self.x = full;
                    self.dt = dt_std;
                    break;
                }
                let (mid, _) = self.step(t, &x0, 0.5 * h);
                let (half, _) = self.step(t + 0.5 * h, &mid, 0.5 * h);
                let err = self.error(&half, &full);
                if err <= self.p.e_max || tries >= self.cfg.max_tries || !err.is_finite() {
                    if err > self.p.e_max {
                        self.counters.capped += 1;
                    }
                    self.x = half;
                    self.dt = h;
                    self.counters.contact_steps += 1;
                    break;
                }
                self.counters.rejected += 1;
                tries += 1;
                h *= (self.p.e_max / err).powf(self.cfg.alpha);
            }
            self.counters.accepted += 1;
            t = if h == remaining { t_end } else { t + h };
        }
        self.k = if self.k + 1 == self.cfg.steps_per_period {
            0
        } else {
            self.k + 1
        };
    }

    /// Advances one forcing period.
    pub fn advance_period(&mut self) {
        for _ in 0..self.cfg.steps_per_period {
            self.advance_grid_step();
        }
    }
}
