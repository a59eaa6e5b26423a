//! Lyapunov exponents of the nonsmooth rotor-stator system (docs/model.md 5 and 6).
//!
//! The full spectrum ([`spectrum`]) is computed on the CPU in `f64` by the method of
//! Benettin et al. with Mueller's transition conditions: the state and eight tangent
//! vectors are advanced together by the lane stepper itself
//! ([`crate::integrate::lane::macro_step_tangent`]), so the tangent vectors see the same
//! macro grid, the same located contact switches and the same frozen contact mode per
//! RK4 sub-step as the state. Their variational equations use the analytic Jacobian
//! (`model::contact_partials`); at each located crossing of g = 0 the saltation matrix
//! S = I + (f+ - f-) n^T / (n^T f-) is applied ([`crate::integrate::lane::saltation`]).
//! Every forcing period the tangent matrix is re-orthonormalised by a QR decomposition
//! (nalgebra) and ln|R_ii| accumulated; the exponents are those sums over the
//! accumulation time, in 1/s (natural log) and bits/s (log base 2).
//!
//! What the saltation matrix does here. For the model as specified the contact force is
//! proportional to g, so it vanishes on g = 0 from both sides: f+ = f- and S = I. With
//! the optional contact damping `c_c` the force jumps by c_c dg/dt and S != I. In both
//! cases det S = 1: n = grad g has position components only, the two fields share their
//! position rows (the velocities), so n^T f+ = n^T f-. The sum rule (docs/model.md 6)
//! therefore reads sum = <tr J> + (saltation log-det rate = 0) for any c_c; what S
//! changes is the individual exponents (the shear it applies moves volume between
//! directions), which the tests show against finite differences of the flow map.
//!
//! Convergence and error. After `transient` forcing periods of the state alone and
//! `tangent_transient` periods in which the tangent vectors align (re-orthonormalised,
//! not accumulated), the per-period increments ln|R_ii| / T are accumulated. The running
//! estimates are kept per period ([`Spectrum::history`]). Stopping rule: every `window`
//! periods, once `min_time` has been accumulated, stop when no exponent changed by more
//! than `tol` over the last window; stop anyway at `max_time`. Error estimate, per
//! exponent: the larger of (a) the standard error of the mean by batch means (the
//! increments split into `blocks` contiguous blocks; the spread of the block means over
//! sqrt(blocks)), which measures the chaotic fluctuation, and (b) the change of the
//! running estimate over the last window, which measures the slow 1/t drift of the
//! alignment transient that batch means cannot see on a periodic orbit.

use crate::error::{Error, Result};
use crate::integrate::lane::{
    Counters, Lane, LaneConsts, Status, StepperConfig, Tangent, advance_period, macro_step_tangent,
};
use crate::model::{Params, STATE_DIM, State, validate_omega};
use nalgebra::SMatrix;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

type Mat8 = SMatrix<f64, STATE_DIM, STATE_DIM>;

/// Settings of a spectrum computation.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpectrumConfig {
    /// Forcing periods of the state alone, discarded (the attractor's transient).
    pub transient: u32,
    /// Forcing periods in which the tangent vectors are advanced and re-orthonormalised
    /// but not accumulated (their alignment transient).
    pub tangent_transient: u32,
    /// Accumulation time after which the stopping rule may stop [s].
    pub min_time: f64,
    /// Accumulation time at which the computation stops regardless [s].
    pub max_time: f64,
    /// Periods between stopping-rule checks, and the window of the change estimate.
    pub window: u32,
    /// Stop when no exponent changed by more than this over the last window [1/s].
    pub tol: f64,
    /// Blocks of the batch-means error estimate.
    pub blocks: u32,
    /// Apply the saltation matrix at switches (`false` only to show its effect).
    pub saltation: bool,
    /// Lane stepper settings.
    pub stepper: StepperConfig,
}

impl SpectrumConfig {
    /// The defaults, in one place (the command line's option defaults are these).
    pub const DEFAULT: SpectrumConfig = SpectrumConfig {
        transient: 1000,
        tangent_transient: 50,
        min_time: 20.0,
        max_time: 100.0,
        window: 100,
        tol: 2e-3,
        blocks: 10,
        saltation: true,
        stepper: StepperConfig::DEFAULT,
    };
}

impl Default for SpectrumConfig {
    fn default() -> Self {
        SpectrumConfig::DEFAULT
    }
}

impl SpectrumConfig {
    /// Checks the settings; errors name the field and the allowed range.
    pub fn validate(&self) -> Result<()> {
        self.stepper.validate()?;
        // Named as the command line (`--time`) and Python (`time=`) spell it.
        crate::inputs::check_positive("time", self.max_time, "s")?;
        if !(self.min_time.is_finite() && self.min_time >= 0.0) {
            return Err(Error::invalid(
                "min-time",
                self.min_time,
                "must be finite and >= 0 s",
            ));
        }
        if self.window == 0 {
            return Err(Error::invalid("window", 0, "must be >= 1 period"));
        }
        crate::inputs::check_positive("tol", self.tol, "1/s")?;
        if self.blocks < 2 {
            return Err(Error::invalid("blocks", self.blocks, "must be >= 2"));
        }
        crate::limits::check_periods("transient", self.transient, 0)?;
        crate::limits::check_periods("tangent-transient", self.tangent_transient, 0)?;
        Ok(())
    }

    /// Forcing periods accumulated at most at speed `omega` (`max_time / T`, rounded
    /// up): the length of [`Spectrum::history`].
    pub fn max_accumulated_periods(&self, omega: f64) -> f64 {
        (self.max_time * omega / std::f64::consts::TAU)
            .ceil()
            .max(1.0)
    }

    /// Bytes a computation over `n_omegas` speeds up to `omega_max` holds at its peak, an
    /// upper estimate: every spectrum keeps its running estimates, one entry per
    /// accumulated period.
    pub fn memory_estimate(&self, n_omegas: u64, omega_max: f64) -> u64 {
        let entry = std::mem::size_of::<(f64, [f64; STATE_DIM])>() as f64;
        let per_speed = self.max_accumulated_periods(omega_max) * entry
            + std::mem::size_of::<Spectrum>() as f64
            + 1024.0;
        let total = n_omegas as f64 * per_speed;
        if total >= u64::MAX as f64 {
            u64::MAX
        } else {
            total as u64
        }
    }

    /// Refuses, before any speed is allocated, spectra at `n_omegas` speeds up to
    /// `omega_max` that would accumulate more than [`crate::limits::MAX_PERIODS`] forcing
    /// periods (`time`, the cap every period count has) or whose running estimates would
    /// not fit in memory (`option`, the input that sets the count, with `value`: the
    /// command line's `omega` range, Python's `time`). The one check of the command line
    /// and Python.
    pub fn check_size(
        &self,
        option: &str,
        value: &str,
        n_omegas: u64,
        omega_max: f64,
    ) -> Result<()> {
        validate_omega(omega_max)?;
        let periods = self.max_accumulated_periods(omega_max);
        let cap = crate::limits::MAX_PERIODS;
        if periods > cap as f64 {
            return Err(Error::invalid(
                "time",
                self.max_time,
                format!(
                    "{periods:.3e} forcing periods at W = {omega_max} rad/s; time must be at most {:.4e} s there ({cap} periods)",
                    cap as f64 * std::f64::consts::TAU / omega_max,
                ),
            ));
        }
        crate::limits::check_memory(
            option,
            value,
            self.memory_estimate(n_omegas, omega_max),
            &format!(
                "{n_omegas} speeds x up to {periods:.0} accumulated periods of running estimates"
            ),
            "ask for fewer speeds (a smaller n in a:b:n) or a shorter time",
        )
    }
}

/// Why a spectrum computation stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum StopReason {
    /// The stopping rule was met (change over the last window below `tol`).
    Converged,
    /// `max_time` was reached first.
    MaxTime,
    /// The lane left the divergence bound or became non-finite.
    LaneFrozen,
}

/// A Lyapunov spectrum and how it was obtained.
#[derive(Clone, Debug, Serialize)]
pub struct Spectrum {
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// The eight exponents [1/s], in the order of the QR columns (descending once the
    /// vectors have aligned).
    pub exponents: [f64; STATE_DIM],
    /// The same in bits/s (divided by ln 2).
    pub exponents_bits: [f64; STATE_DIM],
    /// Error estimate per exponent [1/s]: max of `block_stderr` and `window_change`.
    pub errors: [f64; STATE_DIM],
    /// Batch-means standard error per exponent [1/s].
    pub block_stderr: [f64; STATE_DIM],
    /// Change of each running estimate over the last window [1/s].
    pub window_change: [f64; STATE_DIM],
    /// Sum of the exponents [1/s].
    pub sum: f64,
    /// Time average of the Jacobian's trace over the accumulation time [1/s].
    pub trace_average: f64,
    /// Sum of ln|det S| over the switches, per second of accumulation [1/s].
    pub saltation_log_det_rate: f64,
    /// Accumulation time [s].
    pub integration_time: f64,
    /// Accumulated forcing periods.
    pub periods: u32,
    /// Why the computation stopped.
    pub stop: StopReason,
    /// Saltation matrices applied during the accumulation.
    pub saltations: u64,
    /// Largest |S_ij - I_ij| seen during the accumulation.
    pub max_saltation_deviation: f64,
    /// Lane status at the end.
    pub status: Status,
    /// Lane counters over the whole run (transient included).
    pub counters: Counters,
    /// State at the end (t = a whole number of forcing periods).
    pub final_state: State,
    /// Running estimates: (accumulation time [s], the eight exponents [1/s]) per period.
    #[serde(skip)]
    pub history: Vec<(f64, [f64; STATE_DIM])>,
    /// Wall time of the computation [s]: the command line records it in run.json only,
    /// so a re-run's spectrum.json is byte-identical.
    #[serde(skip)]
    pub wall_time_s: f64,
}

/// A spectrum as `spectrum.json` holds it (NaN and infinities as null, as serde_json
/// writes every non-finite number): the spectrum and the residual of its sum rule
/// (docs/model.md: sum = <tr J> + saltation rate). The command line adds its settings; the
/// Python package returns it as a dictionary.
#[derive(Clone, Debug, Serialize)]
pub struct SpectrumRecord<'a> {
    /// The spectrum, its fields at the top level.
    #[serde(flatten)]
    pub spectrum: &'a Spectrum,
    /// `sum - trace_average - saltation_log_det_rate` [1/s].
    pub sum_rule_residual: f64,
}

impl Spectrum {
    /// The record `spectrum.json` holds.
    pub fn record(&self) -> SpectrumRecord<'_> {
        SpectrumRecord {
            spectrum: self,
            sum_rule_residual: self.sum - self.trace_average - self.saltation_log_det_rate,
        }
    }
}

/// The full Lyapunov spectrum at speed `omega` from `x0` (see the module docs).
pub fn spectrum(p: &Params, omega: f64, x0: &State, cfg: &SpectrumConfig) -> Result<Spectrum> {
    spectrum_with(p, omega, x0, cfg, &crate::control::Cancel::new())
}

/// [`spectrum`], stopped within a forcing period once `cancel` is set
/// ([`crate::error::Error::Interrupted`]; a Python caller's Ctrl-C). The result does not
/// depend on `cancel` otherwise.
pub fn spectrum_with(
    p: &Params,
    omega: f64,
    x0: &State,
    cfg: &SpectrumConfig,
    cancel: &crate::control::Cancel,
) -> Result<Spectrum> {
    let stopped = || crate::error::Error::Interrupted {
        committed: 0,
        total: 1,
    };
    p.validate()?;
    validate_omega(omega)?;
    cfg.validate()?;
    let start = std::time::Instant::now();
    let lc = LaneConsts::<f64>::new(p, omega, &cfg.stepper);
    let period = std::f64::consts::TAU / omega;
    let mut lane = Lane::<f64>::new(x0, p.delta);
    for _ in 0..cfg.transient {
        if lane.status.is_frozen() {
            break;
        }
        if cancel.is_set() {
            return Err(stopped());
        }
        advance_period(&lc, &mut lane);
    }
    let mut identity = [[0.0; STATE_DIM]; STATE_DIM];
    for (i, row) in identity.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    let mut tan = Tangent::<f64, STATE_DIM>::new(identity);
    tan.saltation = cfg.saltation;
    let acc = accumulate(&lc, &mut lane, &mut tan, cfg, period, cancel).ok_or_else(stopped)?;
    let t = acc.accumulated as f64 * period;
    let exponents = if acc.accumulated > 0 {
        acc.sums.map(|s| s / t)
    } else {
        [f64::NAN; STATE_DIM]
    };
    let history = acc.history;
    let window_change = match history.len().checked_sub(1 + cfg.window as usize) {
        Some(b) => {
            let now = history[history.len() - 1].1;
            let before = history[b].1;
            std::array::from_fn(|i| (now[i] - before[i]).abs())
        }
        None => [f64::NAN; STATE_DIM],
    };
    let block_stderr = batch_means_stderr(&acc.increments, cfg.blocks as usize, period);
    let errors = std::array::from_fn(|i| block_stderr[i].max(window_change[i]));
    Ok(Spectrum {
        omega,
        exponents,
        exponents_bits: exponents.map(|l| l / std::f64::consts::LN_2),
        errors,
        block_stderr,
        window_change,
        sum: exponents.iter().sum(),
        trace_average: acc.acc_trace / t,
        saltation_log_det_rate: acc.acc_log_det / t,
        integration_time: t,
        periods: acc.accumulated as u32,
        stop: acc.stop,
        saltations: acc.acc_saltations,
        max_saltation_deviation: acc.max_dev,
        status: lane.status,
        counters: lane.counters,
        final_state: lane.state_f64(),
        history,
        wall_time_s: start.elapsed().as_secs_f64(),
    })
}

/// What [`accumulate`] gathers over the periods after the tangent transient.
struct Accumulated {
    /// Sums of the log stretches per direction.
    sums: [f64; STATE_DIM],
    /// Each accumulated period's log stretches.
    increments: Vec<[f64; STATE_DIM]>,
    /// The running estimates, with their times.
    history: Vec<(f64, [f64; STATE_DIM])>,
    /// Why it stopped.
    stop: StopReason,
    /// The trace integral accumulated.
    acc_trace: f64,
    /// The saltation matrices' log-determinant accumulated.
    acc_log_det: f64,
    /// Saltations while accumulating.
    acc_saltations: u64,
    /// The largest saltation deviation while accumulating.
    max_dev: f64,
    /// Periods accumulated.
    accumulated: u64,
}

/// Steps `lane` and its tangent vectors `tan` period by period, re-orthonormalising
/// after each, and accumulates the log stretches after the tangent transient until the
/// estimates settle, the lane freezes or the time runs out. `None` once `cancel` is set.
fn accumulate(
    lc: &LaneConsts<f64>,
    lane: &mut Lane<f64>,
    tan: &mut Tangent<f64, STATE_DIM>,
    cfg: &SpectrumConfig,
    period: f64,
    cancel: &crate::control::Cancel,
) -> Option<Accumulated> {
    let max_periods = (cfg.max_time / period).ceil().max(1.0) as u64;
    let min_periods = (cfg.min_time / period).ceil() as u64;
    let mut sums = [0.0; STATE_DIM];
    let mut increments: Vec<[f64; STATE_DIM]> = Vec::new();
    let mut history: Vec<(f64, [f64; STATE_DIM])> = Vec::new();
    let mut stop = StopReason::MaxTime;
    let mut acc_trace = 0.0;
    let mut acc_log_det = 0.0;
    let mut acc_saltations = 0u64;
    let mut max_dev: f64 = 0.0;
    let mut accumulated = 0u64;
    let mut p_count = 0u64;
    loop {
        if lane.status.is_frozen() {
            stop = StopReason::LaneFrozen;
            break;
        }
        if cancel.is_set() {
            return None;
        }
        let accumulating = p_count >= cfg.tangent_transient as u64;
        let (tr0, ld0, ns0) = (tan.trace_integral, tan.saltation_log_det, tan.saltations);
        let dev0 = tan.max_saltation_deviation;
        tan.max_saltation_deviation = 0.0;
        for _ in 0..lc.n {
            macro_step_tangent(lc, lane, tan);
        }
        p_count += 1;
        let r = reorthonormalise(tan);
        if !accumulating {
            tan.max_saltation_deviation = dev0;
            continue;
        }
        let mut inc = [0.0; STATE_DIM];
        for (i, d) in inc.iter_mut().enumerate() {
            *d = r[i].abs().ln();
            sums[i] += *d;
        }
        acc_trace += tan.trace_integral - tr0;
        acc_log_det += tan.saltation_log_det - ld0;
        acc_saltations += tan.saltations - ns0;
        max_dev = max_dev.max(tan.max_saltation_deviation);
        increments.push(inc);
        accumulated += 1;
        let t = accumulated as f64 * period;
        history.push((t, sums.map(|s| s / t)));
        if accumulated >= max_periods {
            break;
        }
        if accumulated >= min_periods.max(cfg.window as u64 + 1)
            && accumulated.is_multiple_of(cfg.window as u64)
            && window_settled(&history, cfg)
        {
            stop = StopReason::Converged;
            break;
        }
    }
    Some(Accumulated {
        sums,
        increments,
        history,
        stop,
        acc_trace,
        acc_log_det,
        acc_saltations,
        max_dev,
        accumulated,
    })
}

/// Re-orthonormalises the tangent vectors (the columns of m) by QR; returns the
/// diagonal of R, each vector's stretch over the period.
#[inline(always)]
fn reorthonormalise(tan: &mut Tangent<f64, STATE_DIM>) -> [f64; STATE_DIM] {
    let m = Mat8::from_fn(|i, j| tan.v[j][i]);
    let qr = m.qr();
    let r = qr.r();
    let q = qr.q();
    for (j, v) in tan.v.iter_mut().enumerate() {
        for (i, vi) in v.iter_mut().enumerate() {
            *vi = q[(i, j)];
        }
    }
    std::array::from_fn(|i| r[(i, i)])
}

/// Whether the running estimates changed by less than `cfg.tol` over the last window.
#[inline(always)]
fn window_settled(history: &[(f64, [f64; STATE_DIM])], cfg: &SpectrumConfig) -> bool {
    let now = history[history.len() - 1].1;
    let before = history[history.len() - 1 - cfg.window as usize].1;
    let change = (0..STATE_DIM)
        .map(|i| (now[i] - before[i]).abs())
        .fold(0.0, f64::max);
    change < cfg.tol
}

/// Standard error of the mean rate (per second) by batch means: the per-period
/// increments split into `blocks` contiguous blocks (the last absorbs the remainder);
/// the sample standard deviation of the block means over sqrt(blocks). NaN with fewer
/// periods than blocks.
fn batch_means_stderr(
    increments: &[[f64; STATE_DIM]],
    blocks: usize,
    period: f64,
) -> [f64; STATE_DIM] {
    let n = increments.len();
    if n < blocks || blocks < 2 {
        return [f64::NAN; STATE_DIM];
    }
    let size = n / blocks;
    std::array::from_fn(|i| {
        let means: Vec<f64> = (0..blocks)
            .map(|b| {
                let lo = b * size;
                let hi = if b + 1 == blocks { n } else { lo + size };
                increments[lo..hi].iter().map(|d| d[i]).sum::<f64>() / ((hi - lo) as f64 * period)
            })
            .collect();
        let mean = means.iter().sum::<f64>() / blocks as f64;
        let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (blocks - 1) as f64;
        (var / blocks as f64).sqrt()
    })
}

/// Where each speed of a sweep starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum SweepStart {
    /// Every speed from the given state (independent; all in parallel).
    Given,
    /// Quasi-statically: the transient of each speed starts from the state the previous
    /// speed's transient ended in (in the order given), as in a bifurcation diagram;
    /// the transients run in sequence, the spectra then in parallel.
    Quasistatic,
}

/// Spectra at every speed of `omegas` (rayon over speeds), each with `cfg`.
pub fn sweep(
    p: &Params,
    omegas: &[f64],
    x0: &State,
    start: SweepStart,
    cfg: &SpectrumConfig,
) -> Result<Vec<Spectrum>> {
    let (starts, per_cfg) = sweep_starts(p, omegas, x0, start, cfg)?;
    omegas
        .par_iter()
        .zip(starts.par_iter())
        .map(|(&w, x)| spectrum(p, w, x, &per_cfg))
        .collect()
}

/// Where each speed of a sweep starts, and the configuration its spectrum then runs
/// with: for [`SweepStart::Quasistatic`] the transients run here, in sequence, and the
/// returned configuration has no transient left. The spectra themselves are
/// independent (a resumable range computes them unit by unit from these starts).
pub fn sweep_starts(
    p: &Params,
    omegas: &[f64],
    x0: &State,
    start: SweepStart,
    cfg: &SpectrumConfig,
) -> Result<(Vec<State>, SpectrumConfig)> {
    p.validate()?;
    cfg.validate()?;
    for &w in omegas {
        validate_omega(w)?;
    }
    Ok(match start {
        SweepStart::Given => (vec![*x0; omegas.len()], cfg.clone()),
        SweepStart::Quasistatic => {
            let mut x = *x0;
            let mut starts = Vec::with_capacity(omegas.len());
            for &w in omegas {
                let lc = LaneConsts::<f64>::new(p, w, &cfg.stepper);
                let mut lane = Lane::<f64>::new(&x, p.delta);
                for _ in 0..cfg.transient {
                    if lane.status.is_frozen() {
                        break;
                    }
                    advance_period(&lc, &mut lane);
                }
                if !lane.status.is_frozen() {
                    x = lane.state_f64();
                }
                starts.push(lane.state_f64());
            }
            (
                starts,
                SpectrumConfig {
                    transient: 0,
                    ..cfg.clone()
                },
            )
        }
    })
}

/// The largest Lyapunov exponent lambda_1 of one lane, as the ensembles compute it on
/// either backend: one tangent vector, started along (1, ..., 1)/sqrt(8) at t = 0,
/// advanced with the state (saltation included) and renormalised at the end of every
/// forcing period; the logarithms of the norms before renormalisation are summed over
/// the recorded periods (after the transient), in order, and divided by their duration.
/// `norms` are those per-period norms.
pub fn lambda1_from_norms(norms: &[f64], omega: f64) -> f64 {
    let period = std::f64::consts::TAU / omega;
    let mut sum = 0.0;
    for &n in norms {
        sum += n.ln();
    }
    sum / (norms.len() as f64 * period)
}
