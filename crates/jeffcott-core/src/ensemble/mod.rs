//! Ensembles: many independent lanes (each its own speed W, start state and, optionally,
//! parameter set) run by one call on either backend, with results identical in shape.
//! Bifurcation sweeps, basins and parameter-plane maps are all ensembles (docs/architecture.md).

pub mod cpu;
pub mod early;
pub mod refill;
pub mod table;

use crate::error::{Error, Result};
use crate::integrate::lane::{Counters, Lane, LaneConsts, Status, StepperConfig};
use crate::model::{
    COORD_NAMES, OMEGA_RANGE, Params, STATE_DIM, State, short_number, validate_omega,
};
use crate::real::Real;
use serde::{Deserialize, Serialize};

/// Floating-point precision of the lanes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Precision {
    /// Single precision (the GPU default).
    F32,
    /// Double precision (the CPU default; on the GPU only with `SHADER_F64`).
    F64,
}

/// One lane: its speed, its start state, and which parameter set it uses.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct LaneSpec {
    /// Rotor speed W [rad/s].
    pub omega: f64,
    /// Start state at t = 0.
    pub x0: State,
    /// Index into [`EnsembleSpec::param_sets`].
    pub param_set: u32,
}

/// What an ensemble run integrates.
///
/// # Example
///
/// Four speeds from the static equilibrium, run on the CPU backend:
///
/// ```
/// use jeffcott_core::control::Control;
/// use jeffcott_core::ensemble::{EnsembleSpec, LaneSpec, Precision, cpu};
/// use jeffcott_core::integrate::lane::{Status, StepperConfig};
/// use jeffcott_core::model::{Params, STATE_DIM};
///
/// let params = Params::default();
/// let x0 = params.static_equilibrium();
/// let spec = EnsembleSpec {
///     lanes: LaneSpec::at_speeds(&[130.0, 133.0, 136.0, 139.0], x0),
///     param_sets: vec![params],
///     transient: 20,
///     recorded: 4,
///     stepper: StepperConfig::default(),
///     precision: Precision::F64,
/// };
/// spec.validate()?;
/// let result = cpu::run(&spec, false, Control::none())?;
/// // One Poincare point (a state) per lane and recorded period, lane-major.
/// assert_eq!(result.poincare.len(), 4 * 4 * STATE_DIM);
/// assert_eq!(result.status, vec![Status::Ok; 4]);
/// assert!(result.lambda1.is_none()); // not asked for
/// # Ok::<(), jeffcott_core::Error>(())
/// ```
#[derive(Clone, Debug, Serialize)]
pub struct EnsembleSpec {
    /// Parameter sets the lanes refer to (at least one).
    pub param_sets: Vec<Params>,
    /// The lanes.
    pub lanes: Vec<LaneSpec>,
    /// Forcing periods integrated and discarded.
    pub transient: u32,
    /// Forcing periods recorded (one Poincare point per lane each).
    pub recorded: u32,
    /// Lane stepper settings (N, refinement cap, divergence bound).
    pub stepper: StepperConfig,
    /// Precision of the lanes.
    pub precision: Precision,
}

impl EnsembleSpec {
    /// Checks every input; errors name the field (and lane) and the allowed range.
    /// Non-finite start states are *not* errors: such lanes end `non_finite`, flagged,
    /// without touching their neighbours.
    pub fn validate(&self) -> Result<()> {
        if self.param_sets.is_empty() {
            return Err(Error::invalid(
                "param_sets",
                0,
                "at least one parameter set is needed",
            ));
        }
        for p in &self.param_sets {
            p.validate()?;
        }
        self.stepper.validate()?;
        if self.lanes.is_empty() {
            return Err(Error::invalid(
                "lanes",
                0,
                "an ensemble needs at least one lane",
            ));
        }
        crate::limits::check_periods("transient", self.transient, 0)?;
        crate::limits::check_periods("periods", self.recorded, 1)?;
        let cells = self.lanes.len() as u128 * self.recorded as u128 * STATE_DIM as u128;
        if cells > (1u128 << 34) {
            return Err(Error::invalid(
                "periods",
                self.recorded,
                format!(
                    "{} lanes x {} recorded periods x 8 values do not fit in memory; record fewer periods",
                    self.lanes.len(),
                    self.recorded
                ),
            ));
        }
        for (i, l) in self.lanes.iter().enumerate() {
            validate_omega(l.omega).map_err(|_| {
                Error::invalid(
                    &format!("omega (lane {i})"),
                    short_number(l.omega),
                    OMEGA_RANGE,
                )
            })?;
            if l.param_set as usize >= self.param_sets.len() {
                return Err(Error::invalid(
                    &format!("param_set (lane {i})"),
                    l.param_set,
                    format!("must be < {}", self.param_sets.len()),
                ));
            }
        }
        Ok(())
    }

    /// Lane constants in precision `R`.
    pub fn lane_consts<R: Real>(&self, i: usize) -> LaneConsts<R> {
        let l = &self.lanes[i];
        LaneConsts::new(
            &self.param_sets[l.param_set as usize],
            l.omega,
            &self.stepper,
        )
    }

    /// The initial lane in precision `R`.
    pub fn initial_lane<R: Real>(&self, i: usize) -> Lane<R> {
        let l = &self.lanes[i];
        Lane::new(&l.x0, self.param_sets[l.param_set as usize].delta)
    }
}

/// Per-lane results of an ensemble run, the same for both backends.
#[derive(Clone, Debug)]
pub struct EnsembleResult {
    /// Poincare points, shape [lanes, recorded, 8], C order (lane-major).
    pub poincare: Vec<f64>,
    /// Number of recorded periods per lane.
    pub recorded: usize,
    /// Final state of each lane.
    pub final_state: Vec<State>,
    /// Outcome of each lane.
    pub status: Vec<Status>,
    /// Counters of each lane.
    pub counters: Vec<Counters>,
    /// Largest Lyapunov exponent of each lane [1/s] over the recorded periods, when the
    /// run asked for it ([`run_with_lambda1`]); NaN for lanes that froze (diverged or
    /// non-finite). One tangent vector per lane, started along (1, ..., 1)/sqrt(8) at
    /// t = 0, advanced by the lane stepper with the state (saltation at switches),
    /// renormalised every forcing period; the same arithmetic on both backends.
    pub lambda1: Option<Vec<f64>>,
}

/// What one lane produced: its row of an [`EnsembleResult`].
#[derive(Clone, Debug)]
pub struct LaneResult {
    /// Its record (`recorded` rows of 8).
    pub points: Vec<f64>,
    /// Its final state.
    pub final_state: State,
    /// Its status.
    pub status: Status,
    /// Its counters.
    pub counters: Counters,
    /// Its lambda_1 (NaN where the run has none).
    pub lambda1: f64,
}

impl LaneResult {
    /// Appends this lane to `res` (its lambda_1 where `res` keeps them).
    pub fn append_to(self, res: &mut EnsembleResult) {
        if let Some(l) = res.lambda1.as_mut() {
            l.push(self.lambda1);
        }
        res.poincare.extend_from_slice(&self.points);
        res.final_state.push(self.final_state);
        res.status.push(self.status);
        res.counters.push(self.counters);
    }
}

/// lambda_1 of one lane from its per-period growths, NaN if the lane froze.
pub fn lane_lambda1(norms: &[f64], omega: f64, status: Status) -> f64 {
    if status.is_frozen() {
        f64::NAN
    } else {
        crate::lyapunov::lambda1_from_norms(norms, omega)
    }
}

impl EnsembleResult {
    /// An empty result with room for `lanes` lanes recording `recorded` periods each,
    /// with an empty lambda_1 list when `lambda1`.
    pub fn with_capacity(lanes: usize, recorded: u32, lambda1: bool) -> Self {
        EnsembleResult {
            poincare: Vec::with_capacity(lanes * recorded as usize * STATE_DIM),
            recorded: recorded as usize,
            final_state: Vec::with_capacity(lanes),
            status: Vec::with_capacity(lanes),
            counters: Vec::with_capacity(lanes),
            lambda1: lambda1.then(|| Vec::with_capacity(lanes)),
        }
    }

    /// The recorded Poincare points of lane `i`.
    pub fn lane_points(&self, i: usize) -> &[f64] {
        let n = self.recorded * STATE_DIM;
        &self.poincare[i * n..(i + 1) * n]
    }

    /// Lane `i`'s points as states.
    pub fn lane_states(&self, i: usize) -> Vec<State> {
        self.lane_points(i)
            .chunks_exact(STATE_DIM)
            .map(|c| {
                let mut s = [0.0; STATE_DIM];
                s.copy_from_slice(c);
                s
            })
            .collect()
    }
}

impl EnsembleSpec {
    /// Bytes an ensemble of `lanes` lanes recording `recorded` periods holds at its peak,
    /// an upper estimate: the Poincare records twice (per-lane results are gathered into
    /// the flat array while they still exist), plus per-lane specs, constants, states,
    /// counters and the lane table written to `lanes.npy`.
    pub fn memory_estimate_for(lanes: u64, recorded: u64) -> u64 {
        let record = (STATE_DIM * std::mem::size_of::<f64>()) as u64;
        let per_lane = 2 * recorded.saturating_mul(record) + PER_LANE_BYTES;
        crate::limits::product(&[lanes, per_lane])
    }

    /// Refuses, before any lane is allocated, `lanes` lanes (set by the option `option`
    /// with `value`) recording `recorded` periods each when they would not fit in
    /// memory. The one check of the command line and Python.
    pub fn check_size(option: &str, value: &str, lanes: u64, recorded: u32) -> Result<()> {
        crate::limits::check_memory(
            option,
            value,
            Self::memory_estimate_for(lanes, recorded as u64),
            &format!("{lanes} lanes x {recorded} recorded periods"),
            "ask for fewer speeds (a smaller n in a:b:n) or lanes (a shorter table), or fewer periods",
        )
    }

    /// [`EnsembleSpec::memory_estimate_for`] of this spec.
    pub fn memory_estimate(&self) -> u64 {
        Self::memory_estimate_for(self.lanes.len() as u64, self.recorded as u64)
    }
}

/// Bytes per lane besides its records (spec, constants, state, status, counters, lane
/// table row, lambda_1), rounded up.
pub const PER_LANE_BYTES: u64 = 1024;

/// The global forcing period in which a frozen lane froze (its state at the end of that
/// period and of every later one was never reached), from its count of completed macro
/// steps: a lane advances one macro step at a time and stops counting when it freezes,
/// so `macro_steps = period * N + k` with k < N the step that failed. Both backends
/// count the same steps; the GPU's counter saturates at `u32::MAX`, so beyond that the
/// period is found from the records (`None` here).
pub fn freeze_period(macro_steps: u64, steps_per_period: u32) -> Option<u64> {
    (macro_steps < u32::MAX as u64).then(|| macro_steps / steps_per_period.max(1) as u64)
}

/// Replaces the records of frozen lanes (diverged, non-finite) from the period in which
/// they froze onward by NaN, so a frozen lane's last finite state, which both backends
/// repeat in every later record, cannot be read as a period-1 response. The rule, the
/// same for both backends and applied on the host after the run: the rows of the freeze
/// period ([`freeze_period`]) and of every later one are NaN; where the step counter cannot tell
/// (a GPU counter saturated after 4.29e9 steps), every trailing row bit-identical to the
/// frozen final state is NaN. Rows before the freeze are untouched.
pub fn mask_frozen_records(spec: &EnsembleSpec, res: &mut EnsembleResult) {
    mask_frozen_records_from(spec, res, |_| spec.transient);
}

/// [`mask_frozen_records`] where lane i's record starts after `record_from(i)` periods
/// (the transient, or fewer for a lane recorded early: `early::Then::Record`).
pub fn mask_frozen_records_from(
    spec: &EnsembleSpec,
    res: &mut EnsembleResult,
    record_from: impl Fn(usize) -> u32,
) {
    let rec = res.recorded;
    let len = rec * STATE_DIM;
    for i in 0..res.status.len() {
        if !res.status[i].is_frozen() {
            continue;
        }
        let rows = &mut res.poincare[i * len..(i + 1) * len];
        let first = match freeze_period(res.counters[i].macro_steps, spec.stepper.steps_per_period)
        {
            Some(p) => p.saturating_sub(record_from(i) as u64).min(rec as u64) as usize,
            None => {
                let fin = res.final_state[i].map(f64::to_bits);
                let mut first = rec;
                while first > 0
                    && rows[(first - 1) * STATE_DIM..first * STATE_DIM]
                        .iter()
                        .zip(&fin)
                        .all(|(v, f)| v.to_bits() == *f)
                {
                    first -= 1;
                }
                first
            }
        };
        rows[first * STATE_DIM..].fill(f64::NAN);
    }
}

/// Column names of the lane table (`lanes.npy`): W, the parameter set and the start state.
pub fn lane_table_columns() -> Vec<String> {
    let mut c = vec!["omega".to_string(), "param_set".to_string()];
    c.extend(COORD_NAMES.iter().map(|n| format!("{n}0")));
    c
}

/// Which backend runs an ensemble.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Backend {
    /// A hardware GPU if one is present, else the CPU.
    #[default]
    Auto,
    /// The rayon CPU path.
    Cpu,
    /// A GPU adapter (software ones such as Mesa's llvmpipe included); an error if none.
    Gpu,
}

impl LaneSpec {
    /// One lane per speed, all from `x0` with parameter set 0.
    pub fn at_speeds(omegas: &[f64], x0: State) -> Vec<LaneSpec> {
        omegas
            .iter()
            .map(|&omega| LaneSpec {
                omega,
                x0,
                param_set: 0,
            })
            .collect()
    }
}

impl Backend {
    /// Parses `auto`, `cpu` or `gpu` (the command line's spelling); `field` names the
    /// argument in the error.
    pub fn parse(field: &str, text: &str) -> crate::Result<Backend> {
        match text {
            "auto" => Ok(Backend::Auto),
            "cpu" => Ok(Backend::Cpu),
            "gpu" => Ok(Backend::Gpu),
            _ => Err(crate::Error::invalid(
                field,
                text,
                "must be auto, cpu or gpu",
            )),
        }
    }
}

impl Precision {
    /// Parses `f32` or `f64`; `field` names the argument in the error.
    pub fn parse(field: &str, text: &str) -> crate::Result<Precision> {
        match text {
            "f32" => Ok(Precision::F32),
            "f64" => Ok(Precision::F64),
            _ => Err(crate::Error::invalid(field, text, "must be f32 or f64")),
        }
    }
}

/// How a run was carried out (for `run.json`).
#[derive(Clone, Debug, Serialize)]
pub struct RunInfo {
    /// "cpu" or "gpu".
    pub backend: &'static str,
    /// GPU adapter name, or the CPU thread count.
    pub device: String,
    /// Why this backend was chosen.
    pub reason: String,
    /// Precision of the lanes.
    pub precision: Precision,
    /// Wall time of the integration [s] (device set-up included).
    pub elapsed_s: f64,
    /// The part of `elapsed_s` spent opening the device and building its pipelines
    /// [s] (0 on the CPU and where not measured), so a benchmark can leave it out.
    pub setup_s: f64,
}

/// A range of the CLI syntax `a:b:n` (n values from a to b inclusive, evenly spaced)
/// or a single number, parsed and checked without materialising its values, so that
/// callers can check what `n` values cost before allocating them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RangeSpec {
    /// First value.
    pub a: f64,
    /// Last value (== `a` when n == 1).
    pub b: f64,
    /// Number of values (>= 1).
    pub n: u64,
}

/// Most values [`parse_range`] materialises: 1e9 (8 GB of f64 for the values alone).
/// [`RangeSpec`] itself takes any count, so that commands can say what a larger one
/// would cost ([`crate::limits::check_memory`]) before they allocate anything.
pub const MAX_RANGE_VALUES: u64 = 1_000_000_000;

impl RangeSpec {
    /// Parses `a:b:n` or a number; `option` names the option in errors.
    pub fn parse(option: &str, text: &str) -> Result<RangeSpec> {
        let parts: Vec<&str> = text.split(':').map(str::trim).collect();
        let num = |s: &str| -> Result<f64> {
            let v: f64 = s.parse().map_err(|_| {
                Error::invalid(
                    option,
                    text,
                    format!("`{s}` is not a number; expected a:b:n or a number"),
                )
            })?;
            if v.is_finite() {
                Ok(v)
            } else {
                Err(Error::invalid(option, text, "values must be finite"))
            }
        };
        match parts.as_slice() {
            [a] => {
                let a = num(a)?;
                Ok(RangeSpec { a, b: a, n: 1 })
            }
            [a, b, n] => {
                let (a, b) = (num(a)?, num(b)?);
                let n: u64 = n.parse().map_err(|_| {
                    Error::invalid(
                        option,
                        text,
                        "the count n in a:b:n must be a positive integer",
                    )
                })?;
                match n {
                    0 => Err(Error::invalid(
                        option,
                        text,
                        "the count n in a:b:n must be >= 1",
                    )),
                    1 if a != b => Err(Error::invalid(
                        option,
                        text,
                        "a:b:1 needs a == b (one value)",
                    )),
                    n if n > 1 && a == b => Err(Error::invalid(
                        option,
                        text,
                        "a:b:n with n > 1 needs a != b (it would give n equal values; give a alone for one)",
                    )),
                    n => Ok(RangeSpec { a, b, n }),
                }
            }
            _ => Err(Error::invalid(
                option,
                text,
                "expected a:b:n (n values from a to b inclusive) or a number",
            )),
        }
    }

    /// Number of values.
    pub fn len(&self) -> u64 {
        self.n
    }

    /// Always false (a range has at least one value); for clippy's `len` rule.
    pub fn is_empty(&self) -> bool {
        self.n == 0
    }

    /// The values.
    pub fn values(&self) -> Vec<f64> {
        (0..self.n)
            .map(|i| range_value(self.a, self.b, self.n, i))
            .collect()
    }
}

/// The i-th of n values from a to b inclusive, `a + (b - a) i / (n - 1)` (`a` when
/// n = 1): the one arithmetic of every evenly spaced axis (`a:b:n` ranges, basin and map
/// axes, refined grids), so the same index gives the same bits whichever study asks.
pub fn range_value(a: f64, b: f64, n: u64, i: u64) -> f64 {
    if n <= 1 {
        a
    } else {
        a + (b - a) * i as f64 / (n - 1) as f64
    }
}

/// Parses the CLI range syntax `a:b:n` (n values from a to b inclusive, evenly spaced)
/// or a single number. `option` names the option in errors. The count is checked
/// (at most [`MAX_RANGE_VALUES`]) before any value is allocated; callers that will
/// allocate more per value should use [`RangeSpec`] and check memory first.
pub fn parse_range(option: &str, text: &str) -> Result<Vec<f64>> {
    let r = RangeSpec::parse(option, text)?;
    if r.n > MAX_RANGE_VALUES {
        return Err(Error::invalid(
            option,
            text,
            format!("the count n in a:b:n must be in 1..={MAX_RANGE_VALUES}"),
        ));
    }
    Ok(r.values())
}
